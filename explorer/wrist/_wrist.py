"""Orientation paths and the spherical wrist that follows them (seed 004, problem 1).

A tool's orientation is interpolated between keyframe rotations (3 x 3 matrices) over the path
fraction s ∈ [0, 1] (keyframe k at s = k/(K−1), uniform knots as the spline path's), five ways:

    slerp       the geodesic: scipy.spatial.transform.Slerp, constant angular rate per segment
    spline      scipy.spatial.transform.RotationSpline through the keyframes (C² in angular rate;
                with two keyframes it is slerp)
    matrix      element-wise linear on the matrix (seed 004 (A)); leaves the rotation group: the
                midpoint of I and a 90° turn has det 0.5
    euler       linear on the Euler angles of a named sequence (seed 004 (B) Z-Y-X absolute with its two
                solution sets, (C) X-Y-Z relative); stays a rotation but is longer than the geodesic
                (0 → 90° on all three Z-Y-X angles sweeps 116.4° for a 90° geodesic)
    axis-angle  linear on the keyframes' rotation vectors (axis × angle, seed 004 (D)); from I it is the
                geodesic, between two turned keyframes it is not

The wrist is a spherical wrist of three revolute joints whose axes form an intrinsic Euler sequence
(``"ZYZ"``: R = Rz(q1)·Ry(q2)·Rz(q3); ``"ZYX"``: Rz(q1)·Ry(q2)·Rx(q3); upper case = intrinsic, as in
scipy). Each orientation has two joint solutions (two *sets*, the wrist's two branches, as crossed and
uncrossed are for the four-bar): set 1 is scipy's principal one (middle angle in [−90°, 90°] for a
Tait–Bryan sequence such as ZYX, in [0°, 180°] for a proper one such as ZYZ), set 2 is
(q1 + π, π − q2, q3 + π) resp. (q1 + π, −q2, q3 + π). :func:`track` follows one branch by continuity
(each sample takes the candidate, of both sets and every 2π turn, nearest the previous sample), so the
angles never jump silently. Where the middle angle reaches gimbal lock (0°/180° for proper, ±90° for
Tait–Bryan sequences) only q1 ± q3 is determined: the tracker keeps q1 continuous, the rates blow up as
1/sin q2 resp. 1/cos q2, and :func:`wrist_path` reports the lock with its time and angle.

All angles are radians, times seconds; arrays are (S,) per sample, (S, 3) angles, (S, 3, 3) matrices.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from ..mechanism import EULER_SEQUENCES as SEQUENCES  # noqa: F401 - re-exported by explorer.wrist
from ..mechanism import INTERPOLATIONS, valid_sequence  # one home: the mechanism's [driver] orientation
from ..kernels import LINEAR, QUINTIC, timing

#: A wrist angle this close (radians) to lock counts as *at* lock: q1/q3 split by continuity.
_AT_LOCK = 1e-7


def check_sequence(seq: str) -> str:
    """``seq`` if it is a valid Euler sequence (three of x/y/z, no axis twice in a row, one case), else ValueError."""
    if not valid_sequence(seq):
        raise ValueError(f"expected an Euler sequence such as 'ZYZ', 'ZYX' or 'xyz' (three of X/Y/Z, no axis "
                         f"twice in a row, all upper case = intrinsic or all lower = extrinsic), got {seq!r}")
    return seq


def is_proper(seq: str) -> bool:
    """True for a proper Euler sequence (first axis = last, e.g. ZYZ), False for Tait–Bryan (e.g. ZYX)."""
    return seq[0].upper() == seq[2].upper()


def _rot():
    from scipy.spatial.transform import Rotation
    return Rotation


# -- group facts ------------------------------------------------------------------------------------
def orthonormality_defect(R) -> tuple[np.ndarray, np.ndarray]:
    """(‖RᵀR − I‖_F, det R − 1), each (S,), of matrices R (S, 3, 3) (or one (3, 3): scalars)."""
    R = np.asarray(R, dtype=np.float64)
    g = np.einsum("...ji,...jk->...ik", R, R) - np.eye(3)
    return np.sqrt((g * g).sum(axis=(-2, -1))), np.linalg.det(R) - 1.0


def project(R) -> np.ndarray:
    """The nearest rotation (polar factor, Frobenius norm) of each matrix R (..., 3, 3)."""
    U, _, Vt = np.linalg.svd(np.asarray(R, dtype=np.float64))
    d = np.sign(np.linalg.det(U @ Vt))
    U = U.copy()
    U[..., :, 2] *= d[..., None]
    return U @ Vt


def relative_angle(A, B) -> np.ndarray:
    """Rotation angle (radians, [0, π]) of Aᵀ·B for rotation matrices A, B (S, 3, 3), accurate for small angles."""
    A = np.asarray(A, dtype=np.float64)
    B = np.asarray(B, dtype=np.float64)
    M = np.einsum("...ji,...jk->...ik", A, B)
    return _rot().from_matrix(M.reshape(-1, 3, 3)).magnitude().reshape(M.shape[:-2])


# -- interpolation ----------------------------------------------------------------------------------
def knots(n_keyframes: int) -> np.ndarray:
    """Path fractions (K,) of K keyframes: uniform, 0 … 1."""
    return np.linspace(0.0, 1.0, n_keyframes)


def euler_sets(R, seq: str) -> np.ndarray:
    """Both Euler solution sets (S, 2, 3), radians, of rotation matrices R (S, 3, 3) in sequence ``seq``.

    Set 1 is scipy's principal set; set 2 = (q1 + π, π − q2, q3 + π) (Tait–Bryan) or (q1 + π, −q2, q3 + π)
    (proper), wrapped to (−π, π]. At gimbal lock the two coincide (up to the q1/q3 split)."""
    R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # scipy warns at gimbal lock; wrist_path reports it
        a = _rot().from_matrix(R).as_euler(check_sequence(seq))
    b = a.copy()
    b[:, 0] += math.pi
    b[:, 1] = -a[:, 1] if is_proper(seq) else math.pi - a[:, 1]
    b[:, 2] += math.pi
    b = np.mod(b + math.pi, 2.0 * math.pi) - math.pi
    return np.stack([a, b], axis=1)


def _nearest(cands, prev):
    """The candidate (of rows ``cands`` (2, 3), each shifted by whole turns) nearest ``prev`` (3,)."""
    best, cost = None, math.inf
    for c in cands:
        c = c + 2.0 * math.pi * np.round((prev - c) / (2.0 * math.pi))
        d = float(np.abs(c - prev).sum())
        if d < cost:
            best, cost = c, d
    return best


def _nearest_rows(cands, prev) -> np.ndarray:
    """Row by row :func:`_nearest`: cands (S, 2, 3), prev (S, 3) -> (S, 3)."""
    two_pi = 2.0 * math.pi
    c = cands + two_pi * np.round((prev[:, None, :] - cands) / two_pi)
    pick = np.abs(c - prev[:, None, :]).sum(axis=-1).argmin(axis=1)
    return c[np.arange(len(c)), pick]


def keyframe_euler(keyframes, seq: str, euler_set: int = 1, given=None) -> np.ndarray:
    """Euler angles (K, 3) of the keyframes for the ``euler`` method: ``given[k]`` (radians) where not None
    (as the user wrote them), else keyframe 0 in set ``euler_set`` (1 or 2) and each later one the set and
    turn nearest the previous keyframe's angles."""
    K = np.asarray(keyframes, dtype=np.float64)
    if euler_set not in (1, 2):
        raise ValueError(f"euler_set: expected 1 or 2, got {euler_set!r}")
    if given is not None and len(given) != len(K):
        raise ValueError(f"euler_given: expected {len(K)} entries (one per keyframe, angles or None), got {len(given)}")
    sets = euler_sets(K, seq)
    out = np.empty((len(K), 3))
    for k in range(len(K)):
        if given is not None and given[k] is not None:
            out[k] = given[k]
        elif k == 0:
            out[k] = sets[0, euler_set - 1]
        else:
            out[k] = _nearest(sets[k], out[k - 1])
    return out


def _keyframe_rotvecs(K) -> np.ndarray:
    """Rotation vectors (K, 3) of the keyframes, each later one the equivalent (r or r − 2π r̂) nearest the last."""
    r = _rot().from_matrix(K).as_rotvec()
    for k in range(1, len(r)):
        n = np.linalg.norm(r[k])
        if n > 0.0:
            alt = r[k] * (1.0 - 2.0 * math.pi / n)
            if np.linalg.norm(alt - r[k - 1]) < np.linalg.norm(r[k] - r[k - 1]):
                r[k] = alt
    return r


def _piecewise(values, s) -> np.ndarray:
    """Linear interpolation of ``values`` (K, ...) over uniform knots at fractions s (S,) -> (S, ...)."""
    v = np.asarray(values, dtype=np.float64)
    flat = v.reshape(len(v), -1)
    x = knots(len(v))
    out = np.stack([np.interp(s, x, flat[:, j]) for j in range(flat.shape[1])], axis=-1)
    return out.reshape((len(s),) + v.shape[1:])


def interpolate(keyframes, s, method: str = "slerp", *, euler_seq: str = "ZYX", euler_set: int = 1,
                euler_given=None) -> np.ndarray:
    """Orientation (S, 3, 3) at path fractions s (S,) in [0, 1] between ``keyframes`` (K, 3, 3), K ≥ 2.

    method: one of :data:`INTERPOLATIONS`. ``euler_seq``/``euler_set``/``euler_given``: the sequence, the
    first keyframe's solution set and any literal keyframe angles (K entries, radians or None) of the
    ``euler`` method (see :func:`keyframe_euler`). Only ``matrix`` returns matrices that are not rotations."""
    K = np.asarray(keyframes, dtype=np.float64)
    s = np.clip(np.asarray(s, dtype=np.float64).reshape(-1), 0.0, 1.0)
    if K.ndim != 3 or K.shape[1:] != (3, 3) or len(K) < 2:
        raise ValueError(f"keyframes: expected an array (K, 3, 3) with K >= 2, got shape {K.shape}")
    if method not in INTERPOLATIONS:
        raise ValueError(f"interpolation: expected one of {', '.join(INTERPOLATIONS)}, got {method!r}")
    Rot = _rot()
    if method == "matrix":
        return _piecewise(K, s)
    if method == "euler":
        return Rot.from_euler(euler_seq, _piecewise(keyframe_euler(K, euler_seq, euler_set, euler_given), s)).as_matrix()
    if method == "axis-angle":
        return Rot.from_rotvec(_piecewise(_keyframe_rotvecs(K), s)).as_matrix()
    from scipy.spatial.transform import RotationSpline, Slerp

    rots = Rot.from_matrix(K)
    f = Slerp(knots(len(K)), rots) if method == "slerp" else RotationSpline(knots(len(K)), rots)
    return f(s).as_matrix()


# -- the wrist: joint angles on a tracked branch ----------------------------------------------------
def _lock_sigma(sets, seq):
    """(S,) +1 or −1: at lock, R is unchanged by (q1 + δ, q2, q3 + σδ)."""
    a = sets[:, 0]
    d = 0.3
    R0 = _rot().from_euler(seq, a).as_matrix()
    Rp = _rot().from_euler(seq, a + np.array([d, 0.0, d])).as_matrix()
    return np.where(np.abs(Rp - R0).max(axis=(1, 2)) < 1e-6, 1.0, -1.0)


@njit(cache=True)
def _track(sets, at_lock, sigma, start):
    """Continuity tracking: q (S, 3), set index (S,) int (0 or 1), from both sets (S, 2, 3) and the start (3,)."""
    S = sets.shape[0]
    q = np.empty((S, 3))
    which = np.empty(S, dtype=np.int64)
    prev = start.copy()
    two_pi = 2.0 * math.pi
    c = np.empty(3)
    for k in range(S):
        best = math.inf
        for j in range(2):
            for i in range(3):
                c[i] = sets[k, j, i]
            if at_lock[k]:  # only q1 + σ q3 is fixed: keep q1 where it was
                delta = prev[0] - c[0]
                c[0] += delta
                c[2] += sigma[k] * delta
            cost = 0.0
            for i in range(3):
                c[i] += two_pi * np.round((prev[i] - c[i]) / two_pi)
                cost += abs(c[i] - prev[i])
            if cost < best:
                best = cost
                which[k] = j
                for i in range(3):
                    q[k, i] = c[i]
        for i in range(3):
            prev[i] = q[k, i]
    return q, which


def lock_distance(R, seq: str) -> np.ndarray:
    """Angular distance (S,), radians, of the wrist's middle angle from gimbal lock for orientations R (S, 3, 3):
    |sin q2| = sin(distance) for proper sequences, |cos q2| for Tait–Bryan ones (set-independent)."""
    q2 = euler_sets(R, seq)[:, 0, 1]
    v = np.abs(np.sin(q2)) if is_proper(seq) else np.abs(np.cos(q2))
    return np.arcsin(np.minimum(v, 1.0))


def track(R, seq: str, branch: int = 1, start=None):
    """Wrist angles (S, 3), radians, of rotations R (S, 3, 3) on one branch followed by continuity, and the
    set (S,) int (1 or 2) each sample is on. The first sample starts on set ``branch`` (or nearest ``start``
    (3,) radians when given). Matrices that are not rotations are first projected (:func:`project`)."""
    R = np.asarray(R, dtype=np.float64).reshape(-1, 3, 3)
    if float(orthonormality_defect(R)[0].max(initial=0.0)) > 1e-9:
        R = project(R)
    sets = euler_sets(R, seq)
    at_lock = lock_distance(R, seq) < _AT_LOCK
    sigma = _lock_sigma(sets, seq)
    if start is None:
        if branch not in (1, 2):
            raise ValueError(f"branch: expected 1 or 2, got {branch!r}")
        start = sets[0, branch - 1]
    q, which = _track(sets, at_lock, sigma, np.asarray(start, dtype=np.float64).reshape(3))
    return q, which + 1


# -- a whole orientation path with its accuracy -----------------------------------------------------
@dataclass(frozen=True)
class GimbalLock:
    """The wrist passing at or near gimbal lock: ``t`` (s) and ``s`` (path fraction) of the closest approach,
    ``distance`` (rad) of the middle angle from lock there, ``middle`` (rad) the middle joint angle there on
    the tracked branch, ``t_from``/``t_to`` (s) the span within the lock tolerance, ``peak_rate`` (rad/s) the
    largest joint rate over that span, ``jump`` (rad) the largest q1/q3 change between the two samples
    around it, ``sets`` (before, after) the solution set on each side; ``locked`` False for a closest approach
    that stays outside the lock tolerance."""

    t: float
    s: float
    distance: float
    middle: float
    t_from: float
    t_to: float
    peak_rate: float
    jump: float
    sets: tuple[int, int]
    locked: bool = True  # False: only the closest approach (:attr:`WristPath.closest`), outside the tolerance

    def __str__(self) -> str:
        if not self.locked:
            return (f"no gimbal lock: closest at t = {self.t:.4g} s (s = {self.s:.4g}), middle joint "
                    f"{math.degrees(self.middle):.3f}°, {math.degrees(self.distance):.3g}° from lock")
        cross = f", the wrist passes from set {self.sets[0]} to set {self.sets[1]}" if self.sets[0] != self.sets[1] else ""
        return (f"gimbal lock at t = {self.t:.4g} s (s = {self.s:.4g}): middle joint {math.degrees(self.middle):.3f}°, "
                f"{math.degrees(self.distance):.3g}° from lock, within tolerance from t = {self.t_from:.4g} to "
                f"{self.t_to:.4g} s, joint rates up to {self.peak_rate:.3g} rad/s, the outer joints turn by up to "
                f"{math.degrees(self.jump):.3g}° between two samples there{cross}")


@dataclass(frozen=True)
class WristPath:
    """One interpolated orientation path, the wrist angles that follow it and what the method costs.

    t, s : (S,) time (s) and path fraction. R : (S, 3, 3) the interpolated matrices (not rotations for
    ``matrix``); R_used : (S, 3, 3) the rotations the wrist follows (R projected). angles : (S, 3) wrist
    joint angles (rad) on the tracked branch, rates : (S, 3) their rates (rad/s); sets : (S,) 1 or 2.
    omega : (S,) angular speed |ω| (rad/s); geodesic_deviation : (S,) angle (rad) between R_used and the
    slerp (geodesic) rotation at the same time; defect_frob : (S,) ‖RᵀR − I‖_F, defect_det : (S,) det R − 1.
    path_angle : total rotation swept (rad, the path's length in rotation angle, summed between samples: a
    keyframe's corner between two samples is cut); geodesic_angle : the geodesic's (rad, sum over keyframe
    segments). ripple : (max − min)/mean of the angular rate per unit path fraction |ω|/ṡ (the timing law's
    own speed profile divided out; 0 for slerp between two keyframes, whose segments through more keyframes
    differ in length). locks : the gimbal
    locks (within ``lock_tolerance``); closest : the closest approach to lock (always reported).
    """

    method: str
    wrist: str
    t: np.ndarray
    s: np.ndarray
    R: np.ndarray
    R_used: np.ndarray
    angles: np.ndarray
    rates: np.ndarray
    sets: np.ndarray
    omega: np.ndarray
    geodesic_deviation: np.ndarray
    defect_frob: np.ndarray
    defect_det: np.ndarray
    path_angle: float
    geodesic_angle: float
    ripple: float
    lock_tolerance: float
    locks: tuple[GimbalLock, ...] = field(default_factory=tuple)
    closest: GimbalLock | None = None

    def summary(self) -> dict:
        """Scalar figures of the path (SI: radians, seconds)."""
        return {"method": self.method, "wrist": self.wrist, "max_defect_frob": float(np.abs(self.defect_frob).max()),
                "max_defect_det": float(np.abs(self.defect_det).max()),
                "max_geodesic_deviation": float(self.geodesic_deviation.max()), "path_angle": self.path_angle,
                "geodesic_angle": self.geodesic_angle, "ripple": self.ripple, "gimbal_locks": len(self.locks),
                "max_rate": float(np.abs(self.rates).max()), "branch_changes": int((np.diff(self.sets) != 0).sum())}


def _law(timing_law) -> int:
    if timing_law in ("quintic", QUINTIC):
        return QUINTIC
    if timing_law in ("linear", LINEAR):
        return LINEAR
    raise ValueError(f"timing: expected 'linear' or 'quintic', got {timing_law!r}")


def wrist_path(keyframes, method: str = "slerp", *, duration: float = 10.0, timing_law="quintic",
               steps: int = 1001, wrist: str = "ZYZ", branch: int = 1, euler_seq: str | None = None,
               euler_set: int = 1, euler_given=None, lock_tolerance: float = math.radians(1.0),
               h: float = 1e-5) -> WristPath:
    """Interpolate ``keyframes`` (K, 3, 3) by ``method`` over ``duration`` seconds with the timing law
    ("linear" or "quintic", seed 004's rest-to-rest), sampled at ``steps`` times t_k = T·k/(steps − 1),
    and follow it with a ``wrist`` sequence from set ``branch``. ``euler_seq`` (default: the wrist's),
    ``euler_set``, ``euler_given``: the ``euler`` method's (see :func:`interpolate`). ``lock_tolerance``
    (rad): a middle angle this close to lock is flagged. Rates and |ω| are central differences in the path
    fraction with step ``h``, times ṡ(t). Returns a :class:`WristPath`."""
    check_sequence(wrist)
    euler_seq = check_sequence(euler_seq or wrist)
    if not (isinstance(steps, int) and steps >= 3):
        raise ValueError(f"steps: expected an integer >= 3, got {steps!r}")
    if not (duration > 0.0 and math.isfinite(duration)):
        raise ValueError(f"duration: expected a positive number of seconds, got {duration!r}")
    if not (0.0 < lock_tolerance < math.pi / 2):
        raise ValueError(f"lock_tolerance: expected an angle in (0, π/2) radians, got {lock_tolerance!r}")
    if branch not in (1, 2):
        raise ValueError(f"branch: expected 1 or 2, got {branch!r}")
    law = _law(timing_law)
    K = np.asarray(keyframes, dtype=np.float64)
    t = duration * np.arange(steps) / (steps - 1)
    sd = np.array([timing(law, duration, x)[:2] for x in t])
    s, sdot = sd[:, 0], sd[:, 1]
    kw = dict(euler_seq=euler_seq, euler_set=euler_set, euler_given=euler_given)
    R = interpolate(K, s, method, **kw)
    used = project(R) if method == "matrix" else R
    frob, det = orthonormality_defect(R)
    # central differences in s (one-sided at the ends)
    lo, hi = np.clip(s - h, 0.0, 1.0), np.clip(s + h, 0.0, 1.0)
    Rlo, Rhi = interpolate(K, lo, method, **kw), interpolate(K, hi, method, **kw)
    if method == "matrix":
        Rlo, Rhi = project(Rlo), project(Rhi)
    dphi_ds = relative_angle(Rlo, Rhi) / (hi - lo)
    q, sets = track(used, wrist, branch)
    q_lo = _nearest_rows(euler_sets(Rlo, wrist), q)
    q_hi = _nearest_rows(euler_sets(Rhi, wrist), q)
    dist = lock_distance(used, wrist)
    at_lock = dist < _AT_LOCK
    rates = (q_hi - q_lo) / (hi - lo)[:, None] * sdot[:, None]
    rates[at_lock] = np.where(sdot[at_lock, None] > 0.0, np.inf, 0.0)  # q1, q3 split undefined: rate unbounded
    geo = interpolate(K, s, "slerp")
    deviation = relative_angle(used, geo)
    path_angle = float(relative_angle(used[:-1], used[1:]).sum())
    geodesic_angle = float(relative_angle(K[:-1], K[1:]).sum())
    inner = dphi_ds[1:-1] if steps > 3 else dphi_ds
    mean = float(inner.mean())
    ripple = float((inner.max() - inner.min()) / mean) if mean > 0.0 else 0.0
    locks, closest = _locks(K, method, kw, wrist, t, s, dist, q, rates, sets, duration, law, lock_tolerance)
    return WristPath(method, wrist, t, s, R, used, q, rates, sets, dphi_ds * sdot, deviation, frob, det, path_angle,
                     geodesic_angle, ripple, float(lock_tolerance), tuple(locks), closest)


def _locks(K, method, kw, wrist, t, s, dist, q, rates, sets, duration, law, tol):
    """Gimbal-lock events: every local minimum of the lock distance, refined between its neighbours."""
    from scipy.optimize import minimize_scalar

    def d_at(x):
        Rx = interpolate(K, np.array([x]), method, **kw)
        if method == "matrix":
            Rx = project(Rx)
        return float(lock_distance(Rx, wrist)[0])

    def t_of(x):  # invert the (monotone) timing law by bisection
        a, b = 0.0, duration
        for _ in range(60):
            m = 0.5 * (a + b)
            a, b = (m, b) if timing(law, duration, m)[0] < x else (a, m)
        return 0.5 * (a + b)

    S = len(t)
    events = []
    lowest = int(np.argmin(dist))
    for k in range(S):
        left = dist[k - 1] if k > 0 else math.inf
        right = dist[k + 1] if k < S - 1 else math.inf
        if not (dist[k] <= left and dist[k] <= right) or (k > 0 and dist[k] == left):
            continue
        if k != lowest and dist[k] > 2.0 * tol:  # refine only the closest approach and the minima near lock
            continue
        a, b = s[max(k - 1, 0)], s[min(k + 1, S - 1)]
        if b > a:
            r = minimize_scalar(d_at, bounds=(a, b), method="bounded", options={"xatol": 1e-12})
            x, dmin = (float(r.x), float(r.fun)) if r.fun < dist[k] else (float(s[k]), float(dist[k]))
        else:
            x, dmin = float(s[k]), float(dist[k])
        events.append((dmin, k, x))
    records = []
    for dmin, k, x in events:
        k0 = k1 = k
        while k0 > 0 and dist[k0 - 1] < tol:
            k0 -= 1
        while k1 < S - 1 and dist[k1 + 1] < tol:
            k1 += 1
        a, b = max(k0 - 1, 0), min(k1 + 1, S - 1)
        jump = float(np.abs(np.diff(q[a:b + 1, [0, 2]], axis=0)).max(initial=0.0))
        r = np.abs(rates[a:b + 1])
        peak = float(r.max(initial=0.0))
        tl = t_of(x) if 0.0 < x < 1.0 else (0.0 if x <= 0.0 else duration)
        records.append(GimbalLock(tl, x, dmin, float(q[k, 1]), float(t[k0]), float(t[k1]), peak, jump,
                                  (int(sets[a]), int(sets[b])), bool(dmin < tol)))
    closest = min(records, key=lambda g: g.distance) if records else None
    return [g for g in records if g.locked], closest


def wrist_for(mech_or_driver, steps: int = 1001, *, method: str | None = None,
              lock_tolerance: float = math.radians(1.0)) -> WristPath:
    """The wrist path of a path-driven mechanism (or its :class:`explorer.mechanism.PathDriver`) with a
    ``[driver] orientation``: its keyframes, interpolation (or ``method``), wrist sequence and branch, timed
    by the driver's duration and timing law at the same ``steps`` samples as :func:`explorer.kernels.simulate`
    (t_k = T·k/(steps − 1)). ValueError if it has no orientation."""
    driver = getattr(mech_or_driver, "path", mech_or_driver)
    o = getattr(driver, "orientation", None)
    if o is None:
        name = getattr(mech_or_driver, "name", "this driver")
        raise ValueError(f"{name}: no [driver] orientation (a wrist needs orientation keyframes)")
    seq = o.euler_seq or o.wrist
    given = o.euler_radians(seq)
    return wrist_path(o.matrices(), method or o.interpolation, duration=driver.duration, timing_law=driver.timing,
                      steps=steps, wrist=o.wrist, branch=o.branch, euler_seq=seq, euler_set=o.euler_set,
                      euler_given=given if any(g is not None for g in given) else None, lock_tolerance=lock_tolerance)
