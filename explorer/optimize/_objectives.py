"""What an optimisation scores: the objectives, constraint violations and feasibility of evaluated
designs, as pymoo minimises them, read from their results frame the same way for a fresh generation and
a committed one (``--resume`` relies on it).

What is searched (the ``[optimize]`` table: parameters, bounds, objectives, constraints, algorithm) is
part of a study, :class:`explorer.study.Optimize` (parsed with the study file). A design is *feasible*
when it solved over the whole cycle (status ok), every objective is a number, it passes the
buildability screen (unless ``screen = false``) and every constraint holds.
"""

from __future__ import annotations

import numpy as np

from ..study import Optimize

#: What the objective of an infeasible design is set to (pymoo needs numbers; constraint domination
#: ranks every feasible design first, so the value never decides anything).
INFEASIBLE_VALUE = 1e30


def objective_matrix(df, opt: Optimize, screen) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Objectives and constraint violations of evaluated designs, as pymoo minimises them.

    df : the results frame of these designs (:meth:`explorer.store.Results.frame`: status, the
    parameters, the metrics, ``buildable``). Returns F (n, n_obj): each objective, negated where it
    is maximised, :data:`INFEASIBLE_VALUE` for infeasible designs; G (n, 2 + n_constraints) ≤ 0 where
    satisfied: [not ok or an objective NaN, fails the screen, each constraint false] as 0 / 1; and
    feasible (n,) bool.
    """
    n = len(df)
    G = np.zeros((n, 2 + len(opt.constraints)))
    ok = (df["status"].astype(str) == "ok").to_numpy()
    F = np.empty((n, len(opt.objectives)))
    for j, (name, direction) in enumerate(zip(opt.objectives, opt.directions)):
        v = df[name].to_numpy(dtype=np.float64, na_value=np.nan)
        F[:, j] = -v if direction == "max" else v
    solved = ok & np.isfinite(F).all(axis=1)
    G[:, 0] = np.where(solved, 0.0, 1.0)
    if opt.screen and "buildable" in df.columns:
        G[:, 1] = np.where(df["buildable"].to_numpy(dtype=bool), 0.0, 1.0)
    from ..gait import evaluate_filter
    for j, c in enumerate(opt.constraints):
        G[:, 2 + j] = np.where(evaluate_filter(df, c), 0.0, 1.0)
    feasible = (G <= 0.0).all(axis=1)
    F[~feasible] = INFEASIBLE_VALUE
    return F, G, feasible


def feasible_mask(df, opt: Optimize, screen=None) -> np.ndarray:
    """(len(df),) bool: the designs of a results frame that are feasible for ``opt``."""
    return objective_matrix(df, opt, screen)[2]
