"""The hypervolume of an optimisation's front, generation by generation.

How it is measured (one definition for the summary, the CLI and the tests):

* The designs counted at generation g are the *feasible* designs (:func:`~._objectives.objective_matrix`:
  solved, every objective a number, passing the screen when ``screen = true``, every constraint
  true) of generations 0 … g: the front found so far, so the figure never goes down.
* Each objective is taken as pymoo minimises it (negated where the metric is maximised) and
  normalised by the *final* front, the feasible non-dominated designs of the whole file:
  f' = (f − ideal) / (nadir − ideal), where ideal and nadir are the best and worst value of that
  objective on that front (an objective with no spread there, nadir = ideal, is divided by 1). The
  final front thus spans [0, 1] in every objective.
* The reference point is :data:`REFERENCE` = 1.1 in every normalised objective (the nadir plus 10 %
  of the front's range), so every design of the final front, its extremes included, adds volume;
  designs of earlier generations beyond it in some objective add none. The largest possible value is
  1.1^M (a single design at the ideal point): 1.21 for two objectives, 1.331 for three. (The nadir of
  the final front rather than the worst feasible design: one poor feasible design would otherwise
  squeeze every figure toward the maximum.)
* A generation with no feasible design so far has hypervolume 0 (the empty set's).

Because the normalisation uses the whole file, the figures are comparable within one run (and are
the same on ``--resume`` as in an uninterrupted run: they are computed from the file), not between
runs. The volume itself is pymoo's (:class:`pymoo.indicators.hv.HV`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._objectives import Optimize, objective_matrix

#: The reference point in every normalised objective (the run's feasible nadir is 1, its ideal 0).
REFERENCE = 1.1


@dataclass(frozen=True)
class Hypervolume:
    """What :func:`hypervolume_history` gives.

    values : (G,) the hypervolume of the feasible designs of generations 0 … g, in the normalised
    objectives (dimensionless; at most ``REFERENCE ** M``). ideal, nadir : (M,) the best and worst
    value of each objective on the file's final front, in the objective's own unit and sign as the
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


def _normalise(F: np.ndarray, feasible: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F normalised (n, M), ideal (M,), nadir (M,)) of minimised objectives F by the non-dominated
    feasible rows."""
    M = F.shape[1]
    if not feasible.any():
        return np.full_like(F, np.nan), np.full(M, np.nan), np.full(M, np.nan)
    from pymoo.util.nds.non_dominated_sorting import find_non_dominated
    ok = F[feasible]
    front = ok[find_non_dominated(ok)]
    ideal = front.min(axis=0)
    nadir = front.max(axis=0)
    span = np.where(nadir > ideal, nadir - ideal, 1.0)
    return (F - ideal) / span, ideal, nadir


def hypervolume_per_generation(F: np.ndarray, feasible: np.ndarray, generation: np.ndarray,
                               n_generations: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hypervolume of the module docstring from arrays.

    F : (n, M) objectives as minimised (maximised metrics negated), any value where infeasible;
    feasible : (n,) bool; generation : (n,) int, each design's generation; n_generations : how many
    generations to report (default max(generation) + 1). Returns (values (G,), ideal (M,), nadir (M,)),
    ideal and nadir in F's (minimised) sign.
    """
    from pymoo.indicators.hv import HV
    from pymoo.util.nds.non_dominated_sorting import find_non_dominated

    F = np.asarray(F, dtype=np.float64)
    feasible = np.asarray(feasible, dtype=bool)
    generation = np.asarray(generation, dtype=np.int64)
    G = int(generation.max()) + 1 if n_generations is None and len(generation) else int(n_generations or 0)
    Fn, ideal, nadir = _normalise(F, feasible)
    M = F.shape[1]
    hv = HV(ref_point=np.full(M, REFERENCE))
    values = np.zeros(G)
    archive = np.empty((0, M))
    for g in range(G):
        new = Fn[feasible & (generation == g)]
        if len(new):
            union = np.vstack([archive, new])
            archive = union[find_non_dominated(union)]
        values[g] = float(hv(archive)) if len(archive) else 0.0
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
