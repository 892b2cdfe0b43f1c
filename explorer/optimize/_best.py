"""An optimisation's best design: the one rule the command line, the editor and a Python user share."""

from __future__ import annotations


def best_design(summary) -> tuple[int, str]:
    """(variant, how it was chosen) of an optimisation's best design: the one ``explorer optimize`` compares
    with the nominal. ``summary``: an :class:`OptimizeSummary` (its ``front``, ``objectives``, ``directions``).

    One objective: the best feasible design. Several: the front member with the best equal-weight
    score, each objective min-max normalised over the front (1 = its best end, 0 = its worst), the
    mean over objectives; ties go to the lower variant. ``summary.front`` must not be empty."""
    import numpy as np
    front = summary.front
    if len(summary.objectives) == 1 or len(front) == 1:
        return int(front["variant"].iloc[0]), "the best feasible design"
    score = np.zeros(len(front))
    for o, d in zip(summary.objectives, summary.directions):
        v = front[o].to_numpy(dtype=np.float64)
        span = v.max() - v.min()
        if span > 0:
            score += (v - v.min()) / span if d == "max" else (v.max() - v) / span
        else:
            score += 1.0
    score /= len(summary.objectives)
    variants = front["variant"].to_numpy()
    best = max(range(len(front)), key=lambda i: (score[i], -variants[i]))
    return int(variants[best]), (f"the front's balanced design: the best mean of its {len(summary.objectives)} "
                                 f"objectives, each min-max normalised over the {len(front)} front designs")
