"""How an optimisation's front moved over the generations (``explorer plot RESULTS --front``).

Several objectives: every feasible design of two objectives as grey dots, the front (feasible and
non-dominated among generations 0 … g) drawn for a few generations g in colours from early (light)
to late (dark), the final front in black, and the nominal design (variant 0, when it is in the
search) as a red star. One objective: the best feasible value so far against the generation, over
each generation's feasible values.
"""

from __future__ import annotations

import numpy as np

from ..errors import UserError
from ..optimize import front_history, objective_matrix, optimization_of
from ._plots import LEGEND_SIZE, metric_label, new_figure, style_axes


def plot_front(results, x: str | None = None, y: str | None = None, *, snapshots: int = 6, figsize=(7.0, 5.0),
               dpi: float = 100):
    """The front of an optimisation's results over its generations (a matplotlib Figure).

    results : an open :class:`~explorer.store.Results` of ``explorer optimize``; x, y : two of its
    objectives (default: the first two); snapshots : how many generations' fronts are drawn (evenly
    spaced, the last included).
    """
    opt = optimization_of(results)
    df = results.frame()
    screen = results.screen
    gen = df["generation"].to_numpy()
    last = int(gen[df["status"].astype(str).to_numpy() != "not-run"].max(initial=0))
    fig = new_figure(figsize=figsize, dpi=dpi)
    ax = fig.add_subplot()
    _, _, feasible = objective_matrix(df, opt, screen)
    if len(opt.objectives) == 1:
        name = opt.objectives[0]
        hist = front_history(df, opt, screen)
        v = df[name].to_numpy(dtype=float)
        ax.scatter(gen[feasible], v[feasible], s=8, color="0.7", label="feasible designs", zorder=1)
        ax.step(hist["upto"], hist[name], where="post", color="black", lw=2, label="best so far", zorder=2)
        ax.set_xlabel("generation")
        ax.set_ylabel(metric_label(name))
        style_axes(ax, f"{opt.algorithm}: best {name}, {opt.directions[0]}imised, over {last + 1} generations")
        ax.legend(loc="best", fontsize=LEGEND_SIZE)
        return fig
    names = list(opt.objectives)
    x = x or names[0]
    y = y or names[1]
    for m in (x, y):
        if m not in names:
            raise UserError(f"plot --front: {m!r} is not an objective of this optimisation "
                            f"(objectives: {', '.join(names)})")
    if x == y:
        raise UserError(f"plot --front: x and y are the same objective {x!r}")
    steps = sorted(set(np.linspace(0, last, max(2, snapshots)).round().astype(int)))
    hist = front_history(df, opt, screen, generations=steps)
    ax.scatter(df.loc[feasible, x], df.loc[feasible, y], s=6, color="0.8", label="feasible designs", zorder=1)
    from matplotlib import colormaps
    colors = [colormaps["viridis_r"](t) for t in np.linspace(0.15, 0.75, len(steps))]  # early light, late dark
    for g, c in zip(steps, colors):
        part = hist[hist["upto"] == g]
        if len(part) == 0:
            continue
        part = part.sort_values(x)
        final = g == steps[-1]
        ax.plot(part[x], part[y], "o-" if final else "o--", ms=4 if final else 3, lw=1.5 if final else 1,
                color="black" if final else c, label=f"front after generation {g}" + (" (final)" if final else ""),
                zorder=3 if final else 2)
    if len(df) and df["variant"].iloc[0] == 0 and bool(feasible[0]):
        ax.plot(df[x].iloc[0], df[y].iloc[0], "*", ms=14, color="tab:red", label="nominal (variant 0)", zorder=4)
    ax.set_xlabel(metric_label(x))
    ax.set_ylabel(metric_label(y))
    extra = f"; also {', '.join(n for n in names if n not in (x, y))}" if len(names) > 2 else ""
    style_axes(ax, f"{opt.algorithm}: Pareto front over {last + 1} generations{extra}")
    ax.legend(loc="best", fontsize=LEGEND_SIZE, title="colour: generation, light early, black final",
              title_fontsize=LEGEND_SIZE)
    return fig
