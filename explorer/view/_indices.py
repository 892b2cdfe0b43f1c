"""Global sensitivity indices as a picture: one panel per output, the parameters as horizontal bars with
their intervals (:func:`plot_indices`, what ``explorer sensitivity -o`` draws)."""

from __future__ import annotations

import math

import numpy as np

from ..errors import UserError
from ._plots import new_figure

#: Method names as the plot writes them.
METHOD_TITLES = {"rbd-fast": "RBD-FAST", "delta": "delta", "pawn": "PAWN", "sobol": "Sobol (Saltelli)"}
#: Bar colours: the main index (the one that sorts the bars), and a second one beside it (S1 under ST for
#: Sobol, S1 under delta).
MAIN_COLOR, SECOND_COLOR = "#1f77b4", "#ff7f0e"


def plot_indices(indices, outputs=None, *, columns: int | None = None, figsize=None, dpi: float = 100):
    """Sensitivity indices (the frame of :func:`explorer.analysis.sensitivity`) as horizontal bars with
    their intervals, one panel per output (``outputs``: a subset, in that order), parameters sorted by
    the method's main index, largest on top. Returns a matplotlib Figure."""
    from ..analysis import INDEX_NAMES, main_index
    if indices is None or len(indices) == 0:
        raise UserError("sensitivity plot: no indices to draw")
    names = list(dict.fromkeys(indices["output"]))
    if outputs is not None:
        unknown = [o for o in outputs if o not in names]
        if unknown:
            raise UserError(f"sensitivity plot: unknown output {unknown[0]!r} (outputs: {', '.join(names)})")
        names = list(outputs)
    method = str(indices["method"].iloc[0])
    n_par = indices["parameter"].nunique()
    cols = columns or min(3, len(names))
    rows = math.ceil(len(names) / cols)
    if figsize is None:
        figsize = (5.2 * cols, max(3.2, 0.36 * n_par + 1.6) * rows)
    fig = new_figure(figsize, dpi)
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    shown = indices[indices["output"].isin(names)]
    # one scale for every panel, so that sizes compare: the indices' range, within [-0.15, 1.05] (a wild
    # interval of a rare outcome runs off the panel rather than squeezing every other one)
    low = max(-0.15, np.nanmin(np.r_[0.0, (shown["value"] - shown["conf"].fillna(0.0)).to_numpy(dtype=float)]))
    high = min(1.05, np.nanmax(np.r_[0.05, (shown["value"] + shown["conf"].fillna(0.0)).to_numpy(dtype=float)]))
    from matplotlib.ticker import MaxNLocator
    for ax, name in zip(axes.flat, names):
        sel = indices[indices["output"] == name]
        kind = str(sel["kind"].iloc[0])
        main = main_index(method, kind)
        order = list(sel[sel["index"] == main].sort_values("value", ascending=True, na_position="first")["parameter"])
        kinds = [i for i in dict.fromkeys(sel["index"])]
        kinds = [main] + [i for i in kinds if i != main]
        height = 0.8 / len(kinds)
        y = np.arange(len(order), dtype=float)
        for j, idx in enumerate(kinds):
            part = sel[sel["index"] == idx].set_index("parameter").reindex(order)
            v = part["value"].to_numpy(dtype=float)
            c = part["conf"].to_numpy(dtype=float)
            off = (len(kinds) - 1) / 2 * height - j * height
            ax.barh(y + off, np.nan_to_num(v), height=height * 0.92, color=MAIN_COLOR if j == 0 else SECOND_COLOR,
                    xerr=np.where(np.isfinite(c), c, 0.0), ecolor="0.15", capsize=3, label=idx, zorder=2)
        ax.set_yticks(y, order, fontsize=12)
        ax.tick_params(axis="x", labelsize=11)
        ax.set_xlim(low - 0.02 * (high - low), high + 0.04 * (high - low))
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.axvline(0.0, color="0.3", lw=0.8, zorder=1)
        ax.grid(axis="x", color="0.88", zorder=0)
        n = int(sel["n"].iloc[0])
        note = str(sel["note"].iloc[0])
        what = str(sel["what"].iloc[0]) if "what" in sel.columns and kind != "metric" else ""
        ax.set_title(f"{name}  (n = {n:,})" + (f"\n{what}" if what else "") + (f"\n{note}" if note else ""),
                     fontsize=14, wrap=True)
        ax.set_xlabel(f"sensitivity index ({', '.join(kinds)})", fontsize=12)
        if len(kinds) > 1:
            ax.legend(fontsize=11, loc="lower right", frameon=False)
    labels = ", ".join(INDEX_NAMES.get(i, i) for i in dict.fromkeys(indices["index"]))
    level = indices.attrs.get("conf_level", 0.95)
    fig.suptitle(f"{METHOD_TITLES.get(method, method)}: {labels}; bars ± {100 * level:g} % interval", fontsize=15, wrap=True)
    return fig
