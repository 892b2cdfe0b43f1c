"""Local polish of path-synthesis designs: bounded least squares on the path residuals.

What is minimised is the sum of squared residuals of the design against the M target points
(``path_error`` is its RMS: sum = M · path_error²), with scipy's ``least_squares`` (method "trf",
the design parameters held inside their bounds). Which residuals, by the target's ``match``:

``"timed"`` (no ``ignore``)
    2M residuals: foot(θ_i) − q_i, x and y, the foot interpolated at the target's crank angles as
    ``path_error`` does (:func:`explorer.gait.path_at`: cubic Hermite on the solved samples).
``"closest"`` (no ``ignore``): the *untimed formulation* of the synthesis literature
    the crank angle θ_i of each target point is a variable beside the design parameters (unbounded:
    taken modulo 2π), and the 2M residuals are foot(θ_i) − q_i. The angles start at each point's
    closest match, so the start's sum is M · path_error², and at a converged answer every θ_i is the
    closest point again (the residual is normal to the path): polish lowers the same ``path_error``.
    No order of the points along the path is imposed (the literature's untimed problems sometimes
    require the θ_i in increasing order; check the answer's angles if that matters).
any other match, or any ``ignore``
    M residuals: the distances ``path_residuals`` gives.

Jacobian: forward finite differences of every design parameter at once, as ONE batch solve of the
1 + k designs (the design and each parameter moved by h_j = 1e-6 · max(|x_j|, 1e-2 · (upper_j −
lower_j)), backwards where that would leave the bounds; a moved design that fails is moved the
other way in one more batch solve, and its column is zero if that fails too). The columns of the
free crank angles are exact: the path's tangent dF/dθ at θ_i. A design that fails to solve over the
whole cycle gets residuals of 10⁶ × the target's size, so the trust region rejects the step.

Everything is deterministic: the same start gives the same answer bit for bit (resume relies on it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Relative finite-difference step of the Jacobian.
FD_STEP = 1e-6
#: Most residual evaluations (each a batch solve) one polish start may take.
MAX_NFEV = 1000
#: Two starts are distinct when their parameters differ by more than this share of the bounds' span.
DISTINCT = 0.05


@dataclass
class PolishResult:
    """One polished start. x : (k,) the design parameters; theta : (M,) the free crank angles
    (radians, untimed formulation) or None; cost : sum of squared residuals (model units²; the sum of
    squared distances to the target points); start_cost : the same at the start; evaluations : designs
    solved (every batch row, the Jacobians' included); iterations : Jacobians computed; message :
    scipy's."""

    x: np.ndarray
    theta: np.ndarray | None
    cost: float
    start_cost: float
    evaluations: int
    iterations: int
    message: str


class PathResiduals:
    """The residuals of designs against target points.

    simulate : X (n, k) → (foot (n, S, 2), velocity (n, S, 2) or None, ok (n,) bool), one batch
        solve of n designs (model units; ``ok`` false for a design that does not solve over the cycle).
    target : (M, 2) model units. match : "timed", "closest" or "arc"; angles : (M,) radians for
        "timed"; offset : X (n, k) → (n,) radians added to the angles per design (a parametrisation
        whose crank angle is measured from a rotated frame), or None; ignore : as ``path_error``.
    """

    def __init__(self, simulate, target, *, match="closest", angles=None, offset=None, ignore=()):
        self.simulate = simulate
        self.target = np.asarray(target, dtype=np.float64)
        self.match = match
        self.angles = None if angles is None else np.asarray(angles, dtype=np.float64)
        self.offset = offset
        self.ignore = tuple(ignore)
        if match == "timed" and self.angles is None:
            raise ValueError("match 'timed' needs angles")
        if self.ignore:
            self.form = "distance"
        elif match == "timed":
            self.form = "timed"
        elif match == "closest":
            self.form = "untimed"
        else:
            self.form = "distance"
        c = self.target - self.target.mean(axis=0)
        self.big = 1e6 * (1.0 + float(np.sqrt(np.mean(np.sum(c * c, axis=1)))))
        self.evaluations = 0

    @property
    def free_angles(self) -> bool:
        return self.form == "untimed"

    def m(self) -> int:
        M = len(self.target)
        return M if self.form == "distance" else 2 * M

    def _solve(self, X):
        self.evaluations += len(X)
        return self.simulate(X)

    def rows(self, X, theta=None, solved=None):
        """Residuals (n, m) of designs X (n, k); theta (M,) the free angles (untimed) shared by every
        row. Rows of designs that fail hold NaN. Also returns the (foot, velocity, ok) solved."""
        from ..gait import path_at, path_residuals
        foot, vel, ok = self._solve(X) if solved is None else solved
        n, M = len(X), len(self.target)
        R = np.full((n, self.m()), np.nan)
        idx = np.flatnonzero(ok)
        if len(idx) == 0:
            return R, (foot, vel, ok)
        f, v = foot[idx], (None if vel is None else vel[idx])
        if self.form == "distance":
            kw = {"angles": self.angles} if self.match == "timed" else {}
            if self.match == "timed" and self.offset is not None:
                kw["angle_offset"] = self.offset(X[idx])
            R[idx] = path_residuals(f, self.target, velocity=v, match=self.match, ignore=self.ignore, **kw)
        else:
            if self.form == "timed":
                th = np.broadcast_to(self.angles, (len(idx), M))
                if self.offset is not None:
                    th = th + np.asarray(self.offset(X[idx]))[:, None]
            else:
                th = np.broadcast_to(theta, (len(idx), M))
            pts, _ = path_at(f, th, velocity=v)
            R[idx] = (pts - self.target[None]).reshape(len(idx), 2 * M)
        bad = ~np.all(np.isfinite(R), axis=1)
        R[bad] = np.nan
        return R, (foot, vel, ok)

    def jacobian(self, z, k: int, step, upper) -> np.ndarray:
        """The Jacobian (m, len(z)) of the residuals at z = (x (k,), then the free angles (M,) in the
        untimed formulation) by forward differences of x with steps ``step`` (k,) (backwards where
        x + step would pass ``upper``), all in one batch solve; the free angles' columns exact (the
        path's tangent). See the module docstring for failing moved designs."""
        from ..gait import path_at
        z = np.asarray(z, dtype=np.float64)
        x, th = z[:k], (z[k:] if self.free_angles else None)
        m = self.m()
        h = np.where(x + step <= upper, step, -step)
        X = np.repeat(x[None], k + 1, axis=0)
        X[np.arange(1, k + 1), np.arange(k)] += h
        R, (foot, vel, ok) = self.rows(X, th)
        base = R[0]
        J = np.zeros((m, len(z)))
        if not np.all(np.isfinite(base)):  # the accepted design solves (its residuals said so)
            return J
        redo = np.flatnonzero(~np.all(np.isfinite(R[1:]), axis=1))
        if len(redo):  # a moved design failed: move it the other way, in one more batch
            h[redo] = -h[redo]
            X2 = np.repeat(x[None], len(redo), axis=0)
            X2[np.arange(len(redo)), redo] += h[redo]
            R[1 + redo] = self.rows(X2, th)[0]
        cols = (R[1:] - base[None]) / h[:, None]
        cols[~np.all(np.isfinite(cols), axis=1)] = 0.0
        J[:, :k] = cols.T
        if th is not None:
            _, tan = path_at(foot[:1], th[None], velocity=None if vel is None else vel[:1])
            M = len(th)
            J[2 * np.arange(M), k + np.arange(M)] = tan[0, :, 0]
            J[2 * np.arange(M) + 1, k + np.arange(M)] = tan[0, :, 1]
        return J

    def closest_angles(self, x):
        """The crank angles (M,) of the target points' closest matches on design x's path (None if it
        fails)."""
        from ..gait import path_match
        foot, vel, ok = self._solve(x[None])
        if not ok[0]:
            return None
        pm = path_match(foot, self.target, velocity=vel, match="closest")
        return None if not np.all(np.isfinite(pm.theta)) else pm.theta[0]


def polish(res: PathResiduals, x0, lower, upper, *, max_nfev: int = MAX_NFEV) -> PolishResult:
    """Bounded least squares from design x0 (k,) within [lower, upper] (k,); see the module
    docstring. Returns a :class:`PolishResult` (the start itself when it does not solve). The batch
    solves run on one Numba thread (batches of 1 + k designs: a thread pool costs more than it gives)."""
    import numba
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        return _polish(res, x0, lower, upper, max_nfev)
    finally:
        numba.set_num_threads(threads)


def _polish(res, x0, lower, upper, max_nfev):
    from scipy.optimize import least_squares
    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    x0 = np.clip(np.asarray(x0, dtype=np.float64), lo, hi)
    k = len(x0)
    start_evals = res.evaluations
    theta0 = None
    if res.free_angles:
        theta0 = res.closest_angles(x0)
        if theta0 is None:
            return PolishResult(x0, None, math.inf, math.inf, res.evaluations - start_evals, 0, "the start fails")
    z0 = x0 if theta0 is None else np.concatenate([x0, theta0])
    M2 = res.m()
    step = FD_STEP * np.maximum(np.abs(x0), 1e-2 * (hi - lo))
    cache = {}

    def split(z):
        return (z[:k], z[k:]) if res.free_angles else (z, None)

    def fun(z):
        key = z.tobytes()
        if key in cache:
            return cache[key]
        x, th = split(z)
        R, _ = res.rows(x[None], th)
        r = R[0] if np.all(np.isfinite(R[0])) else np.full(M2, res.big)
        cache.clear()
        cache[key] = r
        return r

    def jac(z):
        return res.jacobian(z, k, step, hi)

    r0 = fun(z0)
    start_cost = float(np.dot(r0, r0)) if np.all(r0 != res.big) else math.inf
    if not math.isfinite(start_cost):
        return PolishResult(x0, theta0, math.inf, math.inf, res.evaluations - start_evals, 0, "the start fails")
    lb = np.concatenate([lo, np.full(len(z0) - k, -np.inf)])
    ub = np.concatenate([hi, np.full(len(z0) - k, np.inf)])
    out = least_squares(fun, z0, jac=jac, bounds=(lb, ub), method="trf", x_scale="jac", xtol=1e-15, ftol=1e-15,
                        gtol=1e-15, max_nfev=max_nfev)
    x, th = split(out.x)
    x = np.clip(x, lo, hi)
    cost = float(np.dot(out.fun, out.fun))
    if not cost < start_cost:  # never worse than the start
        x, th, cost = x0, theta0, start_cost
    if th is not None:
        th = np.mod(th, 2.0 * math.pi)
    return PolishResult(x, th, cost, start_cost, res.evaluations - start_evals, int(out.njev or 0), out.message)


def distinct_best(X, f, lower, upper, k: int, distinct: float = DISTINCT) -> list[int]:
    """Indices of at most k rows of X (n, p) with finite f (n,), best (lowest f) first, each more than
    ``distinct`` × the bounds' span from every one chosen before it (largest normalised coordinate
    difference); ties in f keep row order."""
    span = np.asarray(upper, dtype=np.float64) - np.asarray(lower, dtype=np.float64)
    order = np.argsort(np.where(np.isfinite(f), f, np.inf), kind="stable")
    chosen: list[int] = []
    for i in order:
        if not np.isfinite(f[i]) or len(chosen) >= k:
            break
        if all(np.max(np.abs(X[i] - X[j]) / span) > distinct for j in chosen):
            chosen.append(int(i))
    return chosen


def multistart(res: PathResiduals, starts, lower, upper, *, max_nfev: int = MAX_NFEV) -> list[PolishResult]:
    """:func:`polish` from each start (rows of ``starts`` (s, k)), in order."""
    return [polish(res, x, lower, upper, max_nfev=max_nfev) for x in np.atleast_2d(starts)]
