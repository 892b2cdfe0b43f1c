"""The hypervolume of an optimisation's front, generation by generation.

How it is measured (one definition for the summary, the CLI and the tests):

* The designs counted at generation g are the *feasible* designs (:func:`~._objectives.objective_matrix`:
  solved, every objective a number, passing the screen when ``screen = true``, every constraint
  true) of generations 0 … g: the front found so far, so the figure never goes down.
* Each objective is taken as pymoo minimises it (negated where the metric is maximised) and
  normalised by the fronts of the run: f' = (f − ideal) / (nadir − ideal), where ideal is the best
  feasible value of that objective in the file and nadir the worst value it takes on any generation's
  front (the front as it stood after generation g, for every g) (an objective with no spread, nadir =
  ideal, is divided by 1). Every front of the run thus lies in [0, 1]^M.
* The reference point is :data:`REFERENCE` = 1.1 in every normalised objective (the nadir plus 10 %
  of the range), so every design on any generation's front, its extremes included, adds volume and a
  generation with a feasible design has a positive figure. The largest possible value is 1.1^M (a
  single design at the ideal point): 1.21 for two objectives, 1.331 for three. (Not the nadir of
  every feasible design, which one poor feasible design would push out, squeezing every figure toward
  the maximum; not the final front's, beyond which a polish generation can leave every earlier front.)
* A generation with no feasible design so far has hypervolume 0 (the empty set's).

Because the normalisation uses the whole file, the figures are comparable within one run (and are
the same on ``--resume`` as in an uninterrupted run: they are computed from the file), not between
runs. The volume itself is pymoo's (:class:`pymoo.indicators.hv.HV`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..study import Optimize
from ._objectives import objective_matrix

#: The reference point in every normalised objective (the nadir of the run's fronts is 1, the ideal 0).
REFERENCE = 1.1


@dataclass(frozen=True)
class Hypervolume:
    """What :func:`hypervolume_history` gives.

    values : (G,) the hypervolume of the feasible designs of generations 0 … g, in the normalised
    objectives (dimensionless; at most ``REFERENCE ** M``). ideal, nadir : (M,) the best feasible value
    of each objective and its worst on any generation's front, in the objective's own unit and sign as the
    metric reads (not negated), the normalisation's 0 and 1. reference : (M,) the reference point in
    the same units (nadir + 10 % of the range, toward the worse side).
    """

    values: np.ndarray
    ideal: np.ndarray
    nadir: np.ndarray
    reference: np.ndarray

    @property
    def maximum(self) -> float:
        """The largest value the definition allows: REFERENCE ** M."""
        return REFERENCE ** len(self.ideal)


def hypervolume_per_generation(F: np.ndarray, feasible: np.ndarray, generation: np.ndarray,
                               n_generations: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hypervolume of the module docstring from arrays.

    F : (n, M) objectives as minimised (maximised metrics negated), any value where infeasible;
    feasible : (n,) bool; generation : (n,) int, each design's generation; n_generations : how many
    generations to report (default max(generation) + 1). Returns (values (G,), ideal (M,), nadir (M,)),
    ideal and nadir in F's (minimised) sign (NaN when no design is feasible).
    """
    from pymoo.indicators.hv import HV
    from pymoo.util.nds.non_dominated_sorting import find_non_dominated

    F = np.asarray(F, dtype=np.float64)
    feasible = np.asarray(feasible, dtype=bool)
    generation = np.asarray(generation, dtype=np.int64)
    G = int(generation.max()) + 1 if n_generations is None and len(generation) else int(n_generations or 0)
    M = F.shape[1]
    fronts, archive = [], np.empty((0, M))
    for g in range(G):  # the front after each generation, in the objectives' own units
        new = F[feasible & (generation == g)]
        if len(new):
            union = np.vstack([archive, new])
            archive = union[find_non_dominated(union)]
        fronts.append(archive)
    values = np.zeros(G)
    if not feasible.any():
        return values, np.full(M, np.nan), np.full(M, np.nan)
    ideal = F[feasible].min(axis=0)
    nadir = np.vstack(fronts).max(axis=0)
    span = np.where(nadir > ideal, nadir - ideal, 1.0)
    hv = HV(ref_point=np.full(M, REFERENCE))
    for g, front in enumerate(fronts):
        values[g] = float(hv((front - ideal) / span)) if len(front) else 0.0
    return values, ideal, nadir


def hypervolume_history(df, opt: Optimize, screen=None) -> Hypervolume:
    """:class:`Hypervolume` of an optimisation's results frame (``Results.frame()``, with its
    ``generation`` column), one value per generation in the file."""
    F, _, feasible = objective_matrix(df, opt, screen)
    gen = df["generation"].to_numpy(dtype=np.int64)
    values, ideal, nadir = hypervolume_per_generation(F, feasible, gen)
    sign = np.array([-1.0 if d == "max" else 1.0 for d in opt.directions])
    reference = nadir + (REFERENCE - 1.0) * np.where(nadir > ideal, nadir - ideal, 1.0)
    return Hypervolume(values, sign * ideal, sign * nadir, sign * reference)
