"""Polish of a several-objective front: each final front design, moved downhill on the weighted sum of
the objectives while no objective gets worse.

For a front design x0 with objectives f(x0) (M objectives as pymoo minimises them: maximised metrics
negated), the polish solves, over the design parameters inside their bounds,

    minimise   φ(x) = (1/M) Σ_j (f_j(x) − f_j(x0)) / s_j
    subject to f_j(x) ≤ f_j(x0) for every j            (no objective worse than the start)

with s_j the spread of objective j over the front being polished (its nadir − ideal; 1 where the front
does not spread in it): the equal-weight sum of the normalised objectives. Because of the constraints,
every polished design *dominates* (or equals) the design it started from, so the front only moves
forward; the weights decide where along the common descent directions it goes.

The solver is scipy's SLSQP (``scipy.optimize.minimize(method="SLSQP")``) on the parameters scaled to
[0, 1] by their bounds. Values and gradients come from ONE batch solve of 1 + k designs per point (the
point and each parameter moved by :data:`FD_STEP` of its bounds' span, backwards at the upper bound:
forward differences), through the study's chunk runner (:func:`~explorer.study.runner.design_solver`, or the Dask
evaluator) and :func:`~._objectives.objective_matrix`, exactly as a generation is scored: a design that
fails, fails the screen or breaks a constraint is infeasible; SLSQP sees a large φ there and the
polish keeps the best *feasible* design it evaluated that satisfies the constraints. A design no
step improves is not written again.

Everything is deterministic (the same front gives the same designs, bit for bit), so ``--resume``
stays exact: a run stopped during the polish polishes again from the same front.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..study.runner import designs_from_x
from ._objectives import objective_matrix

#: Finite-difference step, a share of each parameter's bounds' span.
FD_STEP = 1e-6
#: SLSQP iterations per front design.
MAX_ITERATIONS = 15
#: φ of an infeasible point (the normalised objectives are O(1)).
PENALTY = 1e3
#: A polished design is kept when it lowers φ by more than this (normalised units).
MIN_GAIN = 1e-9


@dataclass
class FrontPolish:
    """What :func:`polish_front` did. X : (n, k) the improved designs (parameters in
    ``opt.parameters`` order), from : (n,) the variant each started from, gain : (n,) how much each
    lowered φ (normalised objectives, > 0); tried : front designs polished; evaluations : designs
    solved (every finite-difference row included)."""

    X: np.ndarray
    start: np.ndarray
    gain: np.ndarray
    tried: int
    evaluations: int


def design_frame(study, X: np.ndarray, batch, metrics):
    """The frame :func:`~._objectives.objective_matrix` scores, for designs X (n, k) as solved by the
    chunk runner (batch, metrics): status names, every design parameter column (link lengths, crank,
    coordinates), the metrics, and ``buildable`` / ``screen`` from the study's screen, as
    :meth:`explorer.store.Results.frame` gives them for the same rows."""
    import pandas as pd

    from ..gait import screen_columns
    from ..kernels import STATUS_NAMES

    mech = study.mech
    lengths, crank, geometry = designs_from_x(study, X)
    cols = {name: lengths[:, i] for i, name in enumerate(mech.link_names)}
    cols["crank"] = crank
    for j, name in enumerate(study.geometry_names):
        cols[name] = geometry[:, j]
    status = np.asarray(batch.status)
    cols["status"] = [STATUS_NAMES.get(int(c), "failed") for c in status]
    for name, v in (metrics or {}).items():
        cols[name] = np.asarray(v, dtype=np.float64)
    df = pd.DataFrame(cols)
    screened = screen_columns(df, study.screen)
    if screened is not None:
        df["buildable"], df["screen"] = screened[0], screened[1]
    return df


def polish_front(study, front, evaluate, limit: int | None = None) -> FrontPolish:
    """Polish the designs of ``front`` (a frame with the searched parameters and a ``variant`` column:
    :func:`~._optimize.final_front`), at most ``limit`` of them (evenly spaced along the front's
    order; default all). ``evaluate(lengths, crank, geometry) → (batch, metrics)`` solves designs.
    Returns a :class:`FrontPolish`."""
    from scipy.optimize import minimize

    opt = study.optimize
    lo, hi = np.array(opt.lower), np.array(opt.upper)
    span = hi - lo
    k, M = len(lo), len(opt.objectives)
    n = len(front)
    picks = np.arange(n) if limit is None or n <= limit else np.unique(np.linspace(0, n - 1, limit).round().astype(int))
    X0 = np.column_stack([front[p].to_numpy(dtype=np.float64) for p in opt.parameters])[picks]
    variants = front["variant"].to_numpy()[picks]
    count = {"evaluations": 0}

    def score(X):
        lengths, crank, geometry = designs_from_x(study, X)
        batch, metrics = evaluate(lengths, crank, geometry)
        count["evaluations"] += len(X)
        F, _, feasible = objective_matrix(design_frame(study, X, batch, metrics), opt, study.screen)
        return F, feasible

    F0, ok0 = score(X0)
    good = F0[ok0]
    scale = np.ones(M)
    if len(good):
        s = good.max(axis=0) - good.min(axis=0)
        scale = np.where(s > 0, s, 1.0)
    out_x, out_from, out_gain = [], [], []
    for i in range(len(X0)):
        if not ok0[i]:
            continue
        x, gain = _polish_one(X0[i], F0[i], scale, lo, span, score, minimize)
        if gain > MIN_GAIN and not np.array_equal(x, X0[i]):
            out_x.append(x)
            out_from.append(int(variants[i]))
            out_gain.append(gain)
    return FrontPolish(np.array(out_x).reshape(-1, k), np.array(out_from, dtype=np.int64), np.array(out_gain),
                       int(ok0.sum()), count["evaluations"])


def _polish_one(x0, f0, scale, lo, span, score, minimize):
    """(best feasible design satisfying every constraint, its gain −φ) for one start."""
    k = len(x0)
    M = len(f0)
    u0 = (x0 - lo) / span
    cache = {}
    best = {"x": x0.copy(), "phi": 0.0}

    def at(u):
        u = np.clip(np.asarray(u, dtype=np.float64), 0.0, 1.0)
        key = u.tobytes()
        if key in cache:
            return cache[key]
        steps = np.where(u + FD_STEP <= 1.0, FD_STEP, -FD_STEP)
        U = np.repeat(u[None, :], k + 1, axis=0)
        U[1 + np.arange(k), np.arange(k)] += steps
        X = lo + U * span
        X[0] = lo + u * span
        F, feasible = score(X)
        phi = ((F - f0) / scale).sum(axis=1) / M
        cons = (f0 - F) / scale  # >= 0: not worse
        if feasible[0]:
            if np.all(cons[0] >= 0.0) and phi[0] < best["phi"]:
                best["x"], best["phi"] = X[0].copy(), float(phi[0])
            ok = feasible[1:]
            grad = np.where(ok, (phi[1:] - phi[0]) / steps, 0.0)
            cjac = np.where(ok[:, None], (cons[1:] - cons[0]) / steps[:, None], 0.0).T  # (M, k)
            value = (float(phi[0]), grad, cons[0].copy(), cjac)
        else:
            value = (PENALTY, np.zeros(k), np.full(M, -1.0), np.zeros((M, k)))
        cache[key] = value
        return value

    minimize(lambda u: at(u)[0], u0, jac=lambda u: at(u)[1], method="SLSQP", bounds=[(0.0, 1.0)] * k,
             constraints=[{"type": "ineq", "fun": lambda u: at(u)[2], "jac": lambda u: at(u)[3]}],
             options={"maxiter": MAX_ITERATIONS, "ftol": 1e-12})
    return best["x"], -best["phi"]


def front_polish_generation(study, writer, results, evaluate, final_front) -> dict:
    """The polish generation of a several-objective run (``[optimize] polish = true``): the final front
    of generations 0 … G−1 (``final_front(frame, study)``), at most P of its designs polished
    (:func:`polish_front`) and the improved ones committed as generation G through the chunk runner
    (rows beyond them not-run). A committed polish generation is read back instead. Returns
    {"front": designs polished (None when read back), "improved": designs written, "evaluations":
    designs solved by the polish (None when read back), "from": the variant each written design
    started from (None when read back)}."""
    from ..errors import signals_held

    opt = study.optimize
    P, G = opt.population, opt.generations
    a, _ = writer.chunk_range(G)
    if writer.done[G]:
        new = results.frame(rows=(a, a + P))
        run = int((new["status"].astype(str) != "not-run").sum())
        return {"front": None, "improved": run, "evaluations": None, "from": None}
    front = final_front(results.frame(rows=(0, G * P)), study)
    r = polish_front(study, front, evaluate, limit=P)
    lengths, crank, geometry = designs_from_x(study, r.X)
    batch, metrics = evaluate(lengths, crank, geometry) if len(r.X) else (None, None)
    with signals_held():  # one commit, never cut in half by Ctrl-C
        writer.write_chunk(G, lengths, crank, batch, metrics, geometry=geometry if len(r.X) else None, partial=True)
    return {"front": r.tried, "improved": len(r.X), "evaluations": r.evaluations + len(r.X),
            "from": [int(v) for v in r.start]}
