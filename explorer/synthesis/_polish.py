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

Jacobian: central finite differences of every design parameter at once, as ONE batch solve of the
1 + 2k designs (the design and each parameter moved by ±h_j, h_j = 1e-6 · max(|x_j|, 1e-2 · (upper_j
− lower_j)); error O(h²): forward differences' O(h) error swamps the small singular values of an
ill-conditioned fit and stalls it short of an exact answer); one-sided where a moved design would
leave the bounds or fails (a failing one-sided copy is moved the other way in one more batch solve,
its column zero if that fails too). The columns of the extra variables (the free crank angles, a
free phase) are exact: the path's tangent dF/dθ. A design that fails to solve over the whole cycle
gets residuals of 10⁶ × the target's size, so the trust region rejects the step.

The untimed formulation's angles start at each point's closest match, or, for a drawn curve, at the
points matched in order along the path (:meth:`PathResiduals.ordered_start`): near a cusp the closest
match can lie on the wrong stretch of a path that passes near itself, a local minimum.
:func:`scout_and_polish` (many starts scouted on a coarse path, the best taken on, their points
matched in order again: :func:`lm_rematched`) and :func:`finish` are the multistart pipeline that
``explorer synth`` and ``explorer optimize``'s polish share; :func:`polish_constrained` keeps the
polish inside ``[optimize]`` constraints (an augmented Lagrangian of :class:`ConstrainedResiduals`).

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

    def __init__(self, simulate, target, *, match="closest", angles=None, offset=None, ignore=(), phase="fixed"):
        self.simulate = simulate
        self.target = np.asarray(target, dtype=np.float64)
        self.match = match
        self.angles = None if angles is None else np.asarray(angles, dtype=np.float64)
        self.offset = offset
        self.ignore = tuple(ignore)
        self.phase = phase
        #: central differences in the Jacobian (False: forward, half the designs: a coarse scout's)
        self.central = True
        if match == "timed" and self.angles is None:
            raise ValueError("match 'timed' needs angles")
        if phase == "free" and (match != "timed" or self.ignore):
            raise ValueError("phase 'free' needs match 'timed' without ignore")
        if self.ignore:
            self.form = "distance"
        elif match == "timed":
            self.form = "phase" if phase == "free" else "timed"
        elif match == "closest":
            self.form = "untimed"
        else:
            self.form = "distance"
        c = self.target - self.target.mean(axis=0)
        self.big = 1e6 * (1.0 + float(np.sqrt(np.mean(np.sum(c * c, axis=1)))))
        self.evaluations = 0

    @property
    def free_angles(self) -> bool:
        """Whether the formulation has variables beside the design's: the untimed formulation's crank
        angle per point, or a free phase's shift ψ (:attr:`n_extra` of them)."""
        return self.form in ("untimed", "phase")

    @property
    def n_extra(self) -> int:
        return len(self.target) if self.form == "untimed" else (1 if self.form == "phase" else 0)

    def theta(self, extra, X=None):
        """The crank angles (n, M) at which the target points are compared, from the extra variables
        (n, n_extra) (the untimed angles themselves, or α + ψ (+ offset) for a free phase)."""
        extra = np.atleast_2d(np.asarray(extra, dtype=np.float64))
        if self.form == "untimed":
            return extra
        th = self.angles[None, :] + extra[:, :1]
        if self.offset is not None and X is not None:
            th = th + np.asarray(self.offset(np.atleast_2d(X)))[:, None]
        return th

    def extra_columns(self, tan):
        """d residuals / d extra (n, 2M, n_extra) from the path's tangents (n, M, 2) at the compared angles."""
        n, M, _ = tan.shape
        if self.form == "untimed":
            J = np.zeros((n, 2 * M, M))
            a = np.arange(M)
            J[:, 2 * a, a] = tan[:, :, 0]
            J[:, 2 * a + 1, a] = tan[:, :, 1]
            return J
        return tan.reshape(n, 2 * M, 1).copy()

    def extra_start(self, X, foot, vel, ok):
        """Initial extra variables (n, n_extra) of solved designs (NaN rows where a design fails): each
        point's closest match (untimed) or the best shift (free phase)."""
        from ..gait import path_match
        n = len(foot)
        out = np.full((n, self.n_extra), np.nan)
        idx = np.flatnonzero(ok)
        if len(idx) == 0:
            return out
        v = None if vel is None else vel[idx]
        if self.form == "untimed":
            out[idx] = path_match(foot[idx], self.target, velocity=v, match="closest").theta
        else:
            kw = {}
            if self.offset is not None:
                kw["angle_offset"] = np.asarray(self.offset(np.atleast_2d(X)[idx]))
            th = path_match(foot[idx], self.target, velocity=v, match="timed", angles=self.angles, phase="free",
                            **kw).theta
            base = self.angles[None, :] + kw.get("angle_offset", np.zeros(len(idx)))[:, None]
            out[idx, 0] = np.mod(th[:, 0] - base[:, 0], 2.0 * math.pi)
        return out

    def m_path(self) -> int:
        """Residuals of the path: M distances, or 2M x and y differences."""
        M = len(self.target)
        return M if self.form == "distance" else 2 * M

    def m(self) -> int:
        """Every residual (the path's, and any a subclass appends: :meth:`extend`)."""
        return self.m_path()

    def extend(self, R, X):
        """The residual rows (n, m) of designs X from their path residuals R (n, m_path) (here: R)."""
        return R

    def _solve(self, X):
        self.evaluations += len(X)
        return self.simulate(X)

    def rows(self, X, theta=None, solved=None):
        """Residuals (n, m) of designs X (n, k); theta (M,) the free angles (untimed) shared by every
        row. Rows of designs that fail hold NaN. Also returns the (foot, velocity, ok) solved."""
        from ..gait import path_at, path_residuals
        foot, vel, ok = self._solve(X) if solved is None else solved
        n, M = len(X), len(self.target)
        R = np.full((n, self.m_path()), np.nan)
        idx = np.flatnonzero(ok)
        if len(idx) == 0:
            return self.extend(R, X), (foot, vel, ok)
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
                th = np.broadcast_to(self.theta(np.atleast_2d(theta), X[idx]), (len(idx), M))
            pts, _ = path_at(f, th, velocity=v)
            R[idx] = (pts - self.target[None]).reshape(len(idx), 2 * M)
        bad = ~np.all(np.isfinite(R), axis=1)
        R[bad] = np.nan
        return self.extend(R, X), (foot, vel, ok)

    def jacobian(self, z, k: int, step, upper, lower=None) -> np.ndarray:
        """The Jacobian (m, len(z)) of the residuals at z = (x (k,), then the extra variables) by finite
        differences of x with steps ``step`` (k,), all in one batch solve: central differences (x ± step;
        error O(step²), which an ill-conditioned fit needs: forward differences' O(step) error swamps
        its smallest singular values) where both moved designs stay inside [lower, upper], else forward
        (backwards where x + step would pass ``upper``); without ``lower``, forward differences
        throughout. The extra variables' columns are exact (the path's tangent). See the module
        docstring for failing moved designs."""
        from ..gait import path_at
        z = np.asarray(z, dtype=np.float64)
        x, th = z[:k], (z[k:] if self.free_angles else None)
        m = self.m()
        h = np.where(x + step <= upper, step, -step)
        central = np.zeros(k, bool) if (lower is None or not self.central) else (x + step <= upper) & (x - step >= lower)
        c = np.flatnonzero(central)
        X = np.repeat(x[None], k + 1 + len(c), axis=0)
        X[np.arange(1, k + 1), np.arange(k)] += h
        X[k + 1 + np.arange(len(c)), c] -= h[c]
        R, (foot, vel, ok) = self.rows(X, th)
        base = R[0]
        J = np.zeros((m, len(z)))
        if not np.all(np.isfinite(base)):  # the accepted design solves (its residuals said so)
            return J
        minus = np.full((k, R.shape[1]), np.nan)
        minus[c] = R[k + 1:]
        use_c = central & np.all(np.isfinite(R[1:k + 1]), axis=1) & np.all(np.isfinite(minus), axis=1)
        redo = np.flatnonzero(~use_c & ~np.all(np.isfinite(R[1:k + 1]), axis=1))
        if len(redo):  # a moved design failed: move it the other way, in one more batch
            h[redo] = -h[redo]
            X2 = np.repeat(x[None], len(redo), axis=0)
            X2[np.arange(len(redo)), redo] += h[redo]
            R[1 + redo] = self.rows(X2, th)[0]
        plus = R[1:k + 1]
        cols = np.where(use_c[:, None], (plus - minus) / (2.0 * h[:, None]), (plus - base[None]) / h[:, None])
        cols[~np.all(np.isfinite(cols), axis=1)] = 0.0
        J[:, :k] = cols.T
        if th is not None:
            _, tan = path_at(foot[:1], self.theta(th[None], x[None]), velocity=None if vel is None else vel[:1])
            J[:self.m_path(), k:] = self.extra_columns(tan)[0]
        return J

    def ordered_start(self, X):
        """The untimed formulation's start angles (K, M) of designs X (K, k): the target points matched in
        order along each design's path (:func:`explorer.synthesis._curves.ordered_match`: the assignment that
        goes round the path once, either way, never back). Each point's closest match on its own may lie
        on another stretch of a path that passes near itself, a local minimum the least squares does not
        leave. None when the formulation has no free angles."""
        from ._curves import ordered_match
        if self.form != "untimed":
            return None
        foot, _, ok = self._solve(np.atleast_2d(X))
        th, _ = ordered_match(foot, self.target)
        th[~np.asarray(ok, dtype=bool)] = np.nan
        return th

    def closest_angles(self, x):
        """The extra variables (n_extra,) of design x at its start: the crank angles of the target points'
        closest matches (untimed) or the best shift (free phase); None if it fails."""
        foot, vel, ok = self._solve(x[None])
        if not ok[0]:
            return None
        e = self.extra_start(x[None], foot, vel, ok)[0]
        return None if not np.all(np.isfinite(e)) else e


def polish(res: PathResiduals, x0, lower, upper, *, max_nfev: int = MAX_NFEV, extra0=None) -> PolishResult:
    """Bounded least squares from design x0 (k,) within [lower, upper] (k,); see the module
    docstring. Returns a :class:`PolishResult` (the start itself when it does not solve). The batch
    solves run on one Numba thread (batches of 1 + k designs: a thread pool costs more than it gives)."""
    import numba
    from threadpoolctl import threadpool_limits
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        with threadpool_limits(1, user_api="blas"):  # small dense algebra: BLAS threads only contend
            return _polish(res, x0, lower, upper, max_nfev, extra0)
    finally:
        numba.set_num_threads(threads)


def _polish(res, x0, lower, upper, max_nfev, extra0=None):
    from scipy.optimize import least_squares
    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    x0 = np.clip(np.asarray(x0, dtype=np.float64), lo, hi)
    k = len(x0)
    start_evals = res.evaluations
    theta0 = None
    if res.free_angles and extra0 is not None and np.all(np.isfinite(extra0)):
        theta0 = np.asarray(extra0, dtype=np.float64).copy()
    elif res.free_angles:
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
        return res.jacobian(z, k, step, hi, lo)

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


class ConstrainedResiduals(PathResiduals):
    """Path residuals of designs that must also be feasible (``[optimize]`` constraints, the screen).

    evaluate : X (n, k) → (foot, velocity, ok, margins (n, c), admissible (n,), feasible (n,)): one solve
    of the designs with everything their feasibility needs. margins : the smooth constraints'
    signed margins, each divided by its scale (>= 0 holds; see :func:`explorer.gait.filter_margins`);
    admissible : the design turns a full cycle and every check without a margin holds (the screen, a
    constraint that is not one comparison); feasible : every constraint holds as the filter says.

    A design that is not admissible is treated like one that does not turn (its residuals are NaN: the
    least squares refuses the step). Smooth constraints enter as the rows of an augmented Lagrangian
    (Powell–Hestenes–Rockafellar) appended to the path's: r_j = √μ · max(0, λ_j/μ − m_j), with the
    multipliers λ and the penalty μ set by :func:`polish_constrained` (0: no rows' worth)."""

    def __init__(self, evaluate, target, *, n_margins: int, **kw):
        super().__init__(None, target, **kw)
        self.evaluate = evaluate
        self.nc = int(n_margins)
        self.lam = np.zeros(self.nc)
        self.mu = 0.0
        self.path_weight = 1.0
        self.margin_offset = 0.0
        self._last = None

    def m(self) -> int:
        return self.m_path() + self.nc

    def _solve(self, X):
        X = np.atleast_2d(np.asarray(X, dtype=np.float64))
        self.evaluations += len(X)
        foot, vel, ok, margins, admissible, feasible = self.evaluate(X)
        margins = np.zeros((len(X), 0)) if margins is None else np.asarray(margins, dtype=np.float64)
        self._last = (X.copy(), margins, np.asarray(feasible, dtype=bool))
        return foot, vel, np.asarray(ok, dtype=bool) & np.asarray(admissible, dtype=bool)

    def extend(self, R, X):
        X = np.atleast_2d(X)
        lastX, margins, _ = self._last
        if lastX.shape != X.shape or not np.array_equal(lastX, X):
            raise RuntimeError("ConstrainedResiduals: rows of designs other than the last solved")
        if self.nc == 0:
            return R if self.path_weight == 1.0 else R * self.path_weight
        if self.mu > 0.0:
            P = math.sqrt(self.mu) * np.maximum(0.0, self.lam[None, :] / self.mu - (margins - self.margin_offset))
        else:
            P = np.zeros_like(margins)
        out = np.concatenate([R * self.path_weight, P], axis=1)
        out[~np.all(np.isfinite(out), axis=1)] = np.nan
        return out

    def state(self, x):
        """(path sum of squares, margins (c,), feasible) of design x, extra variables at their start."""
        x = np.asarray(x, dtype=np.float64)
        foot, vel, ok = self._solve(x[None])
        _, margins, feasible = self._last
        if not ok[0]:
            return math.inf, margins[0], False
        extra = self.extra_start(x[None], foot, vel, ok)[0] if self.free_angles else None
        w, self.path_weight = self.path_weight, 1.0
        try:
            R, _ = self.rows(x[None], extra, solved=(foot, vel, ok))
        finally:
            self.path_weight = w
        r = R[0, :self.m_path()]
        return (float(np.dot(r, r)) if np.all(np.isfinite(r)) else math.inf), margins[0], bool(feasible[0])


#: Most outer iterations (multiplier updates) of :func:`polish_constrained`.
AL_OUTER = 12
#: A smooth constraint counts as met when its scaled margin is above -AL_TOL.
AL_TOL = 1e-10


def polish_constrained(res: ConstrainedResiduals, x0, lower, upper, *, max_nfev: int = MAX_NFEV,
                       outer: int = AL_OUTER):
    """:func:`polish` inside the constraints: the augmented Lagrangian of :class:`ConstrainedResiduals`
    (at most ``outer`` least-squares solves; the penalty μ starts where a violation the size of the
    start's (at least 1e-3 of the constraint's scale) costs ten times its sum of squares; after each
    solve λ ← max(0, λ − μ·m), and μ × 10 when the worst violation did not fall below a quarter), barred
    from designs that are not admissible. If no feasible design was met, a restoration (the path's
    residuals weighted 1e-6: the least squares then meets the constraints first) gives one; if the last
    answer still breaks a constraint, the feasible point nearest it on the segment from the best feasible
    design met (bisection, 40 halvings) is taken. Returns (best feasible :class:`PolishResult` or None,
    the last augmented-Lagrangian answer x (k,))."""
    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    x = np.clip(np.asarray(x0, dtype=np.float64), lo, hi)
    f0, m0, feas0 = res.state(x)
    if not math.isfinite(f0):
        return None, x
    ev0 = res.evaluations
    best = (x.copy(), f0) if feas0 else None
    v0 = float(np.max(np.maximum(0.0, -m0))) if len(m0) else 0.0
    floor = 1e-12 * (1.0 + float(np.sum(res.target ** 2)))
    res.lam[:] = 0.0
    res.mu = 10.0 * max(f0, floor) / max(v0, 1e-3) ** 2
    prev = math.inf
    last = x
    try:
        for _ in range(max(1, outer)):
            r = polish(res, last, lo, hi, max_nfev=max_nfev)
            last = r.x
            f, m, feas = res.state(last)
            viol = float(np.max(np.maximum(0.0, -m))) if len(m) else 0.0
            if feas and math.isfinite(f) and (best is None or f < best[1]):
                best = (last.copy(), f)
            if res.nc == 0 or (viol <= AL_TOL and feas):
                break
            res.lam = np.maximum(0.0, res.lam - res.mu * m)
            if viol > 0.25 * prev:
                res.mu *= 10.0
            prev = viol
        f_last, _, feas_last = res.state(last)
        if not feas_last and best is None and res.nc:  # restoration: meet the constraints first
            res.lam[:] = 0.0
            res.mu, res.path_weight, res.margin_offset = 1.0, 1e-6, 1e-9
            r = polish(res, last, lo, hi, max_nfev=max_nfev)
            res.path_weight, res.margin_offset = 1.0, 0.0
            f, _, feas = res.state(r.x)
            if feas and math.isfinite(f):
                best = (r.x.copy(), f)
        if not feas_last and best is not None:  # the feasible point nearest the answer, on the way back
            a, b = best[0], last
            for _ in range(40):
                mid = 0.5 * (a + b)
                fm, _, ok = res.state(mid)
                if ok and math.isfinite(fm):
                    a = mid
                    if fm < best[1]:
                        best = (mid.copy(), fm)
                else:
                    b = mid
    finally:
        res.lam[:] = 0.0
        res.mu, res.path_weight, res.margin_offset = 0.0, 1.0, 0.0
    if best is None:
        return None, last
    return PolishResult(best[0], None, best[1], f0, res.evaluations - ev0, 0, "augmented Lagrangian"), last


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


# ---------------------------------------------------------------------------------------------
# batched bounded Levenberg–Marquardt: K starts advanced together, one batch solve per iteration
# ---------------------------------------------------------------------------------------------

#: Default most iterations of :func:`batched_lm` (each one batch solve of the active starts).
LM_ITERATIONS = 80
#: A start stops when its accepted step moves every parameter by less than this share of its scale.
LM_XTOL = 1e-10
#: A start stops when its cost fell by less than this fraction over the last LM_STALL iterations.
LM_FTOL = 1e-10
LM_STALL = 8


@dataclass
class BatchedLMResult:
    """Starts polished together. X : (K, k) design parameters; theta : (K, M) free crank angles
    (radians, untimed formulation; modulo 2π) or None; cost : (K,) sums of squared residuals (inf for a
    start that does not solve); start_cost : (K,) the same at the starts; iterations : (K,) iterations
    each start took part in; evaluations : designs solved (every batch row); calls : batch solves."""

    X: np.ndarray
    theta: np.ndarray | None
    cost: np.ndarray
    start_cost: np.ndarray
    iterations: np.ndarray
    evaluations: int
    calls: int


def _batch_rows(res: PathResiduals, X, theta):
    """Residuals (n, m) of designs X (n, k) with per-row free angles theta (n, M) (untimed) or None,
    and the solved (foot, velocity, ok). Rows of designs that fail hold NaN."""
    from ..gait import path_at
    if res.form == "distance" or theta is None:
        return res.rows(X)
    foot, vel, ok = res._solve(X)
    n, M = len(X), len(res.target)
    R = np.full((n, 2 * M), np.nan)
    idx = np.flatnonzero(ok)
    if len(idx):
        pts, _ = path_at(foot[idx], res.theta(theta[idx], X[idx]), velocity=None if vel is None else vel[idx])
        R[idx] = (pts - res.target[None]).reshape(len(idx), 2 * M)
    R[~np.all(np.isfinite(R), axis=1)] = np.nan
    return res.extend(R, X), (foot, vel, ok)


def batched_lm(res: PathResiduals, starts, lower, upper, *, iterations: int = LM_ITERATIONS,
               xtol: float = LM_XTOL, ftol: float = LM_FTOL, extra0=None) -> BatchedLMResult:
    """Bounded Levenberg–Marquardt from K starts at once; see :func:`_batched_lm` (BLAS on one thread:
    its algebra is many small systems, which BLAS threads only slow down on a busy machine)."""
    from threadpoolctl import threadpool_limits
    with threadpool_limits(1, user_api="blas"):
        return _batched_lm(res, starts, lower, upper, iterations=iterations, xtol=xtol, ftol=ftol, extra0=extra0)


def _batched_lm(res: PathResiduals, starts, lower, upper, *, iterations: int = LM_ITERATIONS,
                xtol: float = LM_XTOL, ftol: float = LM_FTOL, extra0=None) -> BatchedLMResult:
    """Bounded Levenberg–Marquardt from K starts (rows of ``starts`` (K, k)) at once, the design
    parameters held in [lower, upper] (k,).

    Every iteration is ONE batch solve of the active starts' trial points and their finite-difference
    copies (at most K_active · (1 + 2k) designs: central differences, steps as :func:`polish`'s, see the
    module docstring): the trial's residuals decide
    acceptance (gain ratio ρ = actual / predicted decrease), and an accepted trial's Jacobian is ready
    from the same batch. Per start: damping λ (Marquardt scaling diag(JᵀJ)) updated by Nielsen's rule;
    a parameter on a bound whose gradient points outwards is held (projected step), the rest of the
    step clipped into the box. The untimed formulation's free angles (start: each point's closest
    match) have exact Jacobian columns (the path's tangent). A start stops when its accepted step is
    below ``xtol`` × (|z| + xtol) in every coordinate, when its cost fell by less than ``ftol`` (relative)
    over the last 8 iterations, when λ > 1e16, or after ``iterations``. Deterministic. Finish the best
    few with :func:`polish` for the last digits."""
    from ..gait import path_at
    lo, hi = np.asarray(lower, dtype=np.float64), np.asarray(upper, dtype=np.float64)
    Z0 = np.clip(np.atleast_2d(np.asarray(starts, dtype=np.float64)), lo, hi)
    K, k = Z0.shape
    if K == 0:
        raise ValueError("batched_lm: no starts")
    if not (iterations >= 1 and xtol > 0 and ftol >= 0):
        raise ValueError("batched_lm: iterations >= 1, xtol > 0, ftol >= 0")
    ev0 = res.evaluations
    free = res.free_angles
    calls = 0
    theta = None
    E = res.n_extra
    if free:  # the extra variables' start (each point's closest match, or the best shift): one batch solve
        foot, vel, ok = res._solve(Z0)
        calls += 1
        theta = res.extra_start(Z0, foot, vel, ok)
        if extra0 is not None:  # the caller's start of the extra variables, where it gives one
            e0 = np.asarray(extra0, dtype=np.float64).reshape(K, -1)
            given = np.all(np.isfinite(e0), axis=1) & ok
            theta[given] = e0[given]
    step = FD_STEP * np.maximum(np.abs(Z0), 1e-2 * (hi - lo))  # (K, k), fixed per start
    n = k + E
    m = res.m()
    X = Z0.copy()
    TH = None if theta is None else theta.copy()
    cost = np.full(K, np.inf)
    J = np.zeros((K, m, n))
    r = np.zeros((K, m))
    lam = np.full(K, 1e-3)
    nu = np.full(K, 2.0)
    its = np.zeros(K, dtype=np.int64)
    history = np.full((K, LM_STALL + 1), np.inf)
    active = np.ones(K, dtype=bool)
    if free:
        active &= np.all(np.isfinite(theta), axis=1)

    def evaluate(idx, Xt, Tt):
        """Residuals (len(idx), m) at trial points and their Jacobians (len(idx), m, n)."""
        nonlocal calls
        s = step[idx]
        h = np.where(Xt + s <= hi, s, -s)
        # central differences where x ± h stay inside the box (see PathResiduals.jacobian), else one-sided
        central = (Xt + s <= hi) & (Xt - s >= lo) & res.central
        w = 1 + 2 * k  # the trial, k moved up (or down), k moved down (used where central)
        B = np.repeat(Xt[:, None, :], w, axis=1)  # (a, 1 + 2k, k)
        B[:, 1 + np.arange(k), np.arange(k)] += h
        B[:, 1 + k + np.arange(k), np.arange(k)] -= h
        keep = np.ones((len(idx), w), bool)
        keep[:, 1 + k:] = central
        Tb = None if Tt is None else np.repeat(Tt[:, None, :], w, axis=1)[keep].reshape(-1, E)
        Rk, (foot_k, vel_k, ok_k) = _batch_rows(res, B[keep].reshape(-1, k), Tb)
        calls += 1
        R = np.full((len(idx), w, m), np.nan)
        R[keep] = Rk
        base = R[:, 0]
        plus, minus = R[:, 1:k + 1], R[:, k + 1:]
        use_c = central & np.all(np.isfinite(plus), axis=2) & np.all(np.isfinite(minus), axis=2)
        cols = np.where(use_c[:, :, None], (plus - minus) / (2.0 * h[:, :, None]),
                        (plus - base[:, None]) / h[:, :, None])  # (a, k, m)
        cols[~np.isfinite(cols)] = 0.0
        first = np.flatnonzero(keep.reshape(-1))  # row of each (start, copy) in the solved batch
        pos = np.full(keep.size, -1)
        pos[first] = np.arange(len(first))
        base_rows = pos.reshape(len(idx), w)[:, 0]
        foot = foot_k[base_rows]
        vel = None if vel_k is None else vel_k[base_rows]
        Jt = np.zeros((len(idx), m, n))
        Jt[:, :, :k] = np.transpose(cols, (0, 2, 1))
        if Tt is not None:
            good = np.flatnonzero(np.all(np.isfinite(base), axis=1))
            if len(good):
                f0 = foot[good]
                v0 = None if vel is None else vel[good]
                _, tan = path_at(f0, res.theta(Tt[good], Xt[good]), velocity=v0)
                Jt[good, :res.m_path(), k:] = res.extra_columns(tan)
        return base, Jt

    # the starts themselves
    idx = np.flatnonzero(active)
    if len(idx):
        base, Jt = evaluate(idx, X[idx], None if TH is None else TH[idx])
        fin = np.all(np.isfinite(base), axis=1)
        c = np.where(fin, np.sum(np.where(fin[:, None], base, 0.0) ** 2, axis=1), np.inf)
        cost[idx], r[idx], J[idx] = c, np.where(fin[:, None], base, 0.0), Jt
        active[idx[~fin]] = False
    start_cost = cost.copy()
    history[:, -1] = cost
    xlo = np.concatenate([lo, np.full(n - k, -np.inf)])
    xhi = np.concatenate([hi, np.full(n - k, np.inf)])
    for _ in range(iterations):
        idx = np.flatnonzero(active)
        if len(idx) == 0:
            break
        Ja, ra = J[idx], r[idx]
        Z = X[idx] if TH is None else np.concatenate([X[idx], TH[idx]], axis=1)
        Jt_ = np.transpose(Ja, (0, 2, 1))
        A = Jt_ @ Ja  # (a, n, n): batched matrix products (BLAS), not einsum's loops
        g = (Jt_ @ ra[:, :, None])[:, :, 0]
        d = np.maximum(np.diagonal(A, axis1=1, axis2=2), 1e-12 * np.max(np.diagonal(A, axis1=1, axis2=2), axis=1,
                                                                           keepdims=True) + 1e-300)
        eps = 1e-12 * (xhi - xlo)
        eps = np.where(np.isfinite(eps), eps, 0.0)
        held = ((Z <= xlo + eps) & (g > 0)) | ((Z >= xhi - eps) & (g < 0))
        Ad = A.copy()
        Ad[:, np.arange(n), np.arange(n)] += lam[idx, None] * d
        rhs = np.where(held, 0.0, -g)
        Ad[held[:, :, None] & np.ones((1, 1, n), bool)] = 0.0
        Ad[held[:, None, :] & np.ones((1, n, 1), bool)] = 0.0
        Ad[:, np.arange(n), np.arange(n)] += held * 1.0
        try:
            delta = np.linalg.solve(Ad, rhs[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            delta = np.stack([np.linalg.lstsq(Ad[i], rhs[i], rcond=None)[0] for i in range(len(idx))])
        Zt = np.clip(Z + delta, xlo, xhi)
        s = Zt - Z
        pred = -(2.0 * np.sum(g * s, axis=1) + np.sum(s * (A @ s[:, :, None])[:, :, 0], axis=1))
        base, Jt = evaluate(idx, Zt[:, :k], None if TH is None else Zt[:, k:])
        its[idx] += 1
        fin = np.all(np.isfinite(base), axis=1)
        ct = np.where(fin, np.sum(np.where(fin[:, None], base, 0.0) ** 2, axis=1), np.inf)
        rho = np.where(pred > 0, (cost[idx] - ct) / np.where(pred > 0, pred, 1.0), -1.0)
        acc = fin & (ct < cost[idx]) & (rho > 0)
        ia, ir = idx[acc], idx[~acc]
        X[ia] = Zt[acc, :k]
        if TH is not None:
            TH[ia] = Zt[acc, k:]
        cost[ia], r[ia], J[ia] = ct[acc], base[acc], Jt[acc]
        ra_ = rho[acc]
        lam[ia] *= np.maximum(1.0 / 3.0, 1.0 - (2.0 * ra_ - 1.0) ** 3)
        nu[ia] = 2.0
        lam[ir] *= nu[ir]
        nu[ir] *= 2.0
        history[idx] = np.concatenate([history[idx, 1:], cost[idx, None]], axis=1)
        small = np.all(np.abs(s[acc]) <= xtol * (np.abs(Zt[acc]) + xtol), axis=1)
        stall = history[ia, 0] - history[ia, -1] <= ftol * history[ia, -1]
        done = np.zeros(len(idx), bool)
        done[acc] = small | stall | (cost[ia] == 0.0)
        done |= lam[idx] > 1e16
        active[idx[done]] = False
    if TH is not None:
        TH = np.mod(TH, 2.0 * math.pi)
    return BatchedLMResult(X, TH, cost, start_cost, its, res.evaluations - ev0, calls)


def lm_rematched(res: PathResiduals, starts, lower, upper, *, iterations: int = LM_ITERATIONS, extra0=None):
    """:func:`batched_lm` from ``starts``, then, in the untimed formulation, once more from each answer
    with its points matched in order along its own path (:meth:`PathResiduals.ordered_start`); each
    start keeps the better of the two. A point left on a wrong stretch of the path by the first pass
    moves to the right one. Returns a :class:`BatchedLMResult`."""
    lm = batched_lm(res, starts, lower, upper, iterations=iterations, extra0=extra0)
    if res.form != "untimed":
        return lm
    again = batched_lm(res, lm.X, lower, upper, iterations=iterations, extra0=res.ordered_start(lm.X))
    better = again.cost < lm.cost
    pick = lambda a, b: np.where(better.reshape(-1, *([1] * (a.ndim - 1))), b, a)  # noqa: E731
    return BatchedLMResult(pick(lm.X, again.X), pick(lm.theta, again.theta), np.where(better, again.cost, lm.cost),
                           lm.start_cost, lm.iterations + again.iterations, lm.evaluations + again.evaluations,
                           lm.calls + again.calls)


#: Starts :func:`scout_and_polish` takes on after scouting, and scouting iterations.
KEEP = 8
SCOUT_ITERATIONS = 12


def scout_and_polish(res: PathResiduals, starts, lower, upper, *, coarse: PathResiduals | None = None, extra0=None,
                     keep: int = KEEP, scout_iterations: int = SCOUT_ITERATIONS, iterations: int = LM_ITERATIONS,
                     ordered: bool = True) -> BatchedLMResult:
    """Many starts for the price of a few: every start ``scout_iterations`` of :func:`batched_lm` on
    ``coarse`` (the same residuals on a coarser path: which basin is it in?), its extra variables from
    ``extra0`` where given, else the untimed points matched in order along its path (``ordered``: a
    drawn curve) or each at its closest match; then the ``keep``
    best distinct answers to convergence on ``res`` (:func:`lm_rematched`). With at most ``keep``
    starts, only the second stage. Returns the second stage's :class:`BatchedLMResult`."""
    S0 = np.atleast_2d(np.asarray(starts, dtype=np.float64))
    if coarse is None:
        coarse = res
    else:  # scouting needs no last digits: forward differences, half the designs
        coarse.central = False

    def start_extra(r, X, given):
        if r.form != "untimed" or not ordered:
            return given
        th = r.ordered_start(X)
        if given is not None:
            g = np.asarray(given, dtype=np.float64)
            ok = np.all(np.isfinite(g), axis=1)
            th[ok] = g[ok]
        return th

    if len(S0) > keep:
        lm = batched_lm(coarse, S0, lower, upper, iterations=scout_iterations, extra0=start_extra(coarse, S0, extra0))
        pick = distinct_best(lm.X, lm.cost, lower, upper, keep, distinct=1e-6)
        S1 = lm.X[pick]
        th1 = None if lm.theta is None else lm.theta[pick]
    else:
        S1, th1 = S0, extra0
    return lm_rematched(res, S1, lower, upper, iterations=iterations, extra0=start_extra(res, S1, th1))


#: The finish of the best answers: batched Levenberg–Marquardt iterations (an ill-conditioned valley can
#: take hundreds to its end), then at most this many residual evaluations of scipy's least squares.
FINISH_ITERATIONS = 400
FINISH_NFEV = 30


def finish(res: PathResiduals, lm: BatchedLMResult, lower, upper, n: int, *, iterations: int = FINISH_ITERATIONS,
           max_nfev: int = FINISH_NFEV):
    """The ``n`` best distinct answers of ``lm`` taken on together (:func:`batched_lm`, ``iterations``),
    then each by :func:`polish` (``max_nfev``: the last digits). Returns (X (n', k), cost (n',), theta
    (n', E) or None), the polished answers in the order chosen."""
    pick = distinct_best(lm.X, lm.cost, lower, upper, n, distinct=1e-9)
    if not pick:
        return np.empty((0, lm.X.shape[1])), np.empty(0), None
    th = None if lm.theta is None else lm.theta[pick]
    fin = batched_lm(res, lm.X[pick], lower, upper, iterations=iterations, extra0=th)
    done = [polish(res, fin.X[j], lower, upper, max_nfev=max_nfev, extra0=None if fin.theta is None else fin.theta[j])
            for j in range(len(pick))]
    X = np.array([d.x for d in done])
    cost = np.array([d.cost for d in done])
    theta = None if res.n_extra == 0 else np.array([d.theta if d.theta is not None else np.full(res.n_extra, np.nan)
                                                   for d in done])
    return X, cost, theta
