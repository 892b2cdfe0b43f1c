"""Gait metrics of foot paths, computed in batch by a Numba kernel.

Conventions
-----------
* ``paths`` is (N, S, 2): the foot position (x, y) of N variants at S crank angles
  θ_k = 2πk/S, in model units (the units of the link lengths). "Down" is −y.
* ``velocities`` is (N, S, 2): dF/dθ, model units **per radian of crank** (multiply by the crank
  speed ω in rad/s for a real speed).
* ``status`` is (N,) integer: 0 = ok; every other code gets NaN metrics and never raises.

Definitions (the contract; ``std`` is the population standard deviation, ddof = 0)
------------------------------------------------------------------------------------
Let y_min, y_max be the extremes of y over the whole cycle, ``height`` = y_max − y_min and
``band`` ∈ [0, 1] (default 0.01).

stance
    The longest run of consecutive samples, taken cyclically (a run may wrap from k = S−1 to
    k = 0), in which y_k ≤ y_min + band · height. Ties between runs of equal length go to the run
    with the smallest start index in 0 … S−1. If every sample qualifies, the stance is the whole
    cycle. The stance always holds at least one sample (the lowest one). n = its sample count.
width           max(x) − min(x) over the whole cycle.
height          max(y) − min(y) over the whole cycle.
stride          max(x) − min(x) over the stance.
duty            n / S.
flatness        std(y over the stance) / stride; NaN if stride == 0.
stance_rms_line sqrt(mean_i d_i²) with d_i = |y_i − a − b x_i| / sqrt(1 + b²): the RMS
                perpendicular distance of the stance points from their ordinary least-squares
                line y = a + b x (y regressed on x; b = Σ(x−x̄)(y−ȳ)/Σ(x−x̄)², a = ȳ − b x̄).
                NaN if the stance x-values are all equal (the fit is undefined, e.g. n = 1).
stance_speed    mean of |dF/dθ| = hypot(vx, vy) over the stance (per radian).
speed_ripple    std / mean of |dF/dθ| over the stance; NaN if that mean is 0.
max_speed       max of |dF/dθ| over the whole cycle (per radian).
min_transmission_angle
                for every crank-driven four-bar loop of the mechanism (a vertex v linked both to
                the crank tip and to a fixed pivot f: ground = |centre − f|, crank r, coupler
                L(tip, v), rocker L(f, v)), the transmission angle μ at v is the angle between
                v→tip and v→f, cos μ = (c² + l² − d²)/(2 c l) with d the tip–f distance. Over a full
                crank turn d sweeps [|g − r|, g + r], so min over θ of min(μ, 180° − μ) is exact
                in closed form: min(μ(d = |g − r|), 180° − μ(d = g + r)). The metric is the least
                of these over all such loops, in degrees (continuous in θ, not sampled).

A variant whose path holds a non-finite value gets NaN for every foot metric; one whose
velocities hold a non-finite value gets NaN for the three speed metrics.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import UserError
from ..kernels import parallel_rows
from ..plan import fourbar_loops

#: Every metric, in storage/display order.
METRICS: tuple[str, ...] = ("width", "height", "stride", "duty", "flatness", "stance_rms_line",
                            "stance_speed", "speed_ripple", "max_speed", "min_transmission_angle")
#: Metrics computed from the foot path alone.
PATH_METRICS: tuple[str, ...] = ("width", "height", "stride", "duty", "flatness", "stance_rms_line")
#: Metrics that also need the foot velocities dF/dθ.
VELOCITY_METRICS: tuple[str, ...] = ("stance_speed", "speed_ripple", "max_speed")
#: Metrics that need the mechanism and each variant's lengths (not the foot path).
MECHANISM_METRICS: tuple[str, ...] = ("min_transmission_angle",)
#: The metrics of the foot (path and velocity), computed by the Numba kernel.
FOOT_METRICS: tuple[str, ...] = PATH_METRICS + VELOCITY_METRICS

#: Natural ranking direction of each metric: "max" = larger is better, "min" = smaller is better.
DIRECTIONS: dict[str, str] = {
    "width": "max",            # a larger sweep of the foot (reach); overridable, size measure only
    "height": "max",           # step height: more ground clearance on the return swing
    "stride": "max",           # more ground covered per crank turn
    "duty": "max",             # longer ground contact: fewer legs needed to carry the body
    "flatness": "min",         # a flatter stance does not bob the body up and down
    "stance_rms_line": "min",  # a straighter stance
    "stance_speed": "max",     # faster walking per radian of crank
    "speed_ripple": "min",     # a steadier foot speed on the ground
    "max_speed": "min",        # a gentler return swing (lower peak foot speed, lower inertial loads)
    "min_transmission_angle": "max",  # further from toggle: better force transmission
}

#: Unit of each metric ("length" = the model units of the link lengths).
UNITS: dict[str, str] = {
    "width": "length",
    "height": "length",
    "stride": "length",
    "duty": "fraction of cycle",
    "flatness": "1 (length/length)",
    "stance_rms_line": "length",
    "stance_speed": "length/rad",
    "speed_ripple": "1",
    "max_speed": "length/rad",
    "min_transmission_angle": "deg",
}

#: One-line help text per metric.
DESCRIPTIONS: dict[str, str] = {
    "width": "x-range of the whole foot path",
    "height": "y-range of the whole foot path (step height)",
    "stride": "x-span of the stance: ground covered while the foot is down",
    "duty": "fraction of the cycle in stance",
    "flatness": "std of y over the stance / stride (lower is flatter)",
    "stance_rms_line": "RMS perpendicular distance of the stance points from their least-squares line y = a + b x",
    "stance_speed": "mean foot speed |dF/dθ| over the stance, per radian of crank",
    "speed_ripple": "std / mean of the foot speed over the stance",
    "max_speed": "largest foot speed |dF/dθ| over the cycle, per radian of crank",
    "min_transmission_angle": "smallest transmission angle (deviation from toggle) of the crank-driven four-bar loops",
}

DEFAULT_BAND = 0.01

_INDEX = {name: i for i, name in enumerate(FOOT_METRICS)}
_N_FOOT = len(FOOT_METRICS)


# -- the kernel --------------------------------------------------------------------------------------
@njit(cache=True)
def _stance(y, thr):
    """Longest cyclic run of y <= thr: (start, length); ties to the smallest start. (0, S) if all."""
    S = y.shape[0]
    k0 = -1
    for k in range(S):
        if not (y[k] <= thr):
            k0 = k
            break
    if k0 < 0:
        return 0, S
    best_start = 0
    best_len = 0
    run_start = 0
    run_len = 0
    # scan S samples starting right after a sample that is out of the band, so no run is cut
    for j in range(1, S + 1):
        k = (k0 + j) % S
        if y[k] <= thr:
            if run_len == 0:
                run_start = k
            run_len += 1
        else:
            if run_len > best_len or (run_len == best_len and run_len > 0 and run_start < best_start):
                best_start = run_start
                best_len = run_len
            run_len = 0
    # the scan ends on sample k0, which is out of the band, so every run has been closed
    return best_start, best_len


def stance_indices(path, band: float = DEFAULT_BAND) -> np.ndarray:
    """Sample indices of the stance of one foot path (S, 2), in cyclic order: the longest cyclic run
    with y ≤ y_min + band · height, ties to the smallest start (the metrics' own definition).

    Non-finite samples (a failed variant) never qualify; an empty array if none is finite.
    """
    y = np.asarray(path, dtype=np.float64)[:, 1]
    fin = np.isfinite(y)
    if not fin.any():
        return np.zeros(0, dtype=np.int64)
    lo, hi = y[fin].min(), y[fin].max()
    start, n = _stance(np.where(fin, y, np.inf), lo + band * (hi - lo))
    return (start + np.arange(n)) % y.shape[0]


@njit(cache=True, nogil=True)
def _foot_metrics_kernel(band, want_path, want_stance, want_vel, paths, vel, status, out):
    """Fill out[i, m] for the FOOT_METRICS of every ok variant i (out comes in NaN-filled); the
    per-row arrays come last, for :func:`explorer.kernels.parallel_rows`."""
    N = paths.shape[0]
    S = paths.shape[1]
    for i in range(N):
        if status[i] != 0:
            continue
        # whole-cycle extremes
        xmin = np.inf
        xmax = -np.inf
        ymin = np.inf
        ymax = -np.inf
        finite = True
        for k in range(S):
            x = paths[i, k, 0]
            y = paths[i, k, 1]
            if not (math.isfinite(x) and math.isfinite(y)):
                finite = False
                break
            if x < xmin:
                xmin = x
            if x > xmax:
                xmax = x
            if y < ymin:
                ymin = y
            if y > ymax:
                ymax = y
        path_ok = finite
        if path_ok and want_path:
            out[i, 0] = xmax - xmin
            out[i, 1] = ymax - ymin
        start = 0
        n = 0
        if path_ok and want_stance:
            thr = ymin + band * (ymax - ymin)
            start, n = _stance(paths[i, :, 1], thr)
            # stance statistics, two-pass for accuracy
            sx = 0.0
            sy = 0.0
            sxmin = np.inf
            sxmax = -np.inf
            for j in range(n):
                k = (start + j) % S
                x = paths[i, k, 0]
                sx += x
                sy += paths[i, k, 1]
                if x < sxmin:
                    sxmin = x
                if x > sxmax:
                    sxmax = x
            mx = sx / n
            my = sy / n
            sxx = 0.0
            sxy = 0.0
            syy = 0.0
            for j in range(n):
                k = (start + j) % S
                dx = paths[i, k, 0] - mx
                dy = paths[i, k, 1] - my
                sxx += dx * dx
                sxy += dx * dy
                syy += dy * dy
            stride = sxmax - sxmin
            out[i, 2] = stride
            out[i, 3] = n / S
            if stride > 0.0:
                out[i, 4] = math.sqrt(syy / n) / stride
            if sxx > 0.0:
                b = sxy / sxx
                sse = 0.0
                for j in range(n):
                    k = (start + j) % S
                    e = (paths[i, k, 1] - my) - b * (paths[i, k, 0] - mx)
                    sse += e * e
                out[i, 5] = math.sqrt(sse / n / (1.0 + b * b))
        if want_vel and path_ok:
            vmax = -np.inf
            vok = True
            for k in range(S):
                s = math.hypot(vel[i, k, 0], vel[i, k, 1])
                if not math.isfinite(s):
                    vok = False
                    break
                if s > vmax:
                    vmax = s
            if vok:
                out[i, 8] = vmax
                if want_stance:
                    ss = 0.0
                    for j in range(n):
                        k = (start + j) % S
                        ss += math.hypot(vel[i, k, 0], vel[i, k, 1])
                    ms = ss / n
                    var = 0.0
                    for j in range(n):
                        k = (start + j) % S
                        d = math.hypot(vel[i, k, 0], vel[i, k, 1]) - ms
                        var += d * d
                    out[i, 6] = ms
                    if ms > 0.0:
                        out[i, 7] = math.sqrt(var / n) / ms


# -- public ------------------------------------------------------------------------------------------
def _resolve_names(names, have_mechanism: bool) -> list[str]:
    """The requested metric names in METRICS order (validated)."""
    if names is None or names is True:
        return [m for m in METRICS if m not in MECHANISM_METRICS or have_mechanism]
    if names is False:
        return []
    if isinstance(names, str):
        names = [names]
    try:
        names = [str(n) for n in names]
    except TypeError:
        raise UserError(f"metrics: expected a list of metric names or true, got {names!r}") from None
    unknown = [n for n in names if n not in METRICS]
    if unknown:
        raise UserError(f"metrics: unknown metric {unknown[0]!r} (known: {', '.join(METRICS)})")
    chosen = set(names)
    return [m for m in METRICS if m in chosen]


def _check_band(band) -> float:
    if isinstance(band, bool) or not isinstance(band, (int, float, np.integer, np.floating)):
        raise UserError(f"band: expected a number in [0, 1], got {band!r}")
    b = float(band)
    if not (0.0 <= b <= 1.0):
        raise UserError(f"band: expected a number in [0, 1], got {band!r}")
    return b


def compute_metrics(paths, velocities=None, status=None, names=None, band: float = DEFAULT_BAND, *,
                    mechanism=None, lengths=None, crank=None) -> dict[str, np.ndarray]:
    """Gait metrics of N foot paths (see the module docstring for the exact definitions).

    Parameters
    ----------
    paths : array (N, S, 2)
        Foot positions (x, y) at θ_k = 2πk/S, model units. S ≥ 2.
    velocities : array (N, S, 2) or None
        dF/dθ, model units per radian of crank. Needed only for stance_speed, speed_ripple and
        max_speed.
    status : array (N,) of int, or None
        0 = ok (None: all ok). Variants with any other code get NaN for every metric.
    names : iterable of metric names, a single name, None or True
        The metrics to compute. None/True: every foot metric (width … max_speed; velocities are
        then required) plus min_transmission_angle when ``mechanism`` is given and has a
        crank-driven four-bar loop. Unknown names raise UserError listing the known ones.
    band : float in [0, 1]
        Stance band as a fraction of the path height (default 0.01).
    mechanism : Mechanism, optional
        Needed only for min_transmission_angle.
    lengths : array (N, n_links), optional
        Link lengths of each variant in ``mechanism.links`` order (default: the nominal's).
    crank : array (N,), optional
        Crank radius of each variant (default: the nominal's).

    Returns
    -------
    dict name -> float64 array (N,), in METRICS order, holding only the requested metrics.
    """
    paths = np.asarray(paths, dtype=np.float64)
    if paths.ndim != 3 or paths.shape[2] != 2 or paths.shape[1] < 2:
        raise UserError(f"paths: expected shape (N, S, 2) with S >= 2, got {paths.shape}")
    N = paths.shape[0]
    if status is None:
        status = np.zeros(N, dtype=np.int64)
    else:
        status = np.asarray(status)
        if status.shape != (N,):
            raise UserError(f"status: expected shape ({N},), got {status.shape}")
        if not np.issubdtype(status.dtype, np.integer):
            raise UserError(f"status: expected integer codes (0 = ok), got dtype {status.dtype}")
        status = status.astype(np.int64, copy=False)
    band = _check_band(band)
    explicit = not (names is None or names is True)
    chosen = _resolve_names(names, mechanism is not None)
    need_vel = [m for m in chosen if m in VELOCITY_METRICS]
    if need_vel and velocities is None:
        raise UserError(f"metrics: {', '.join(need_vel)} need the foot velocities dF/dθ; pass velocities= "
                        f"or ask only for {', '.join(PATH_METRICS)}")
    if velocities is not None and need_vel:
        vel = np.asarray(velocities, dtype=np.float64)
        if vel.shape != paths.shape:
            raise UserError(f"velocities: expected shape {paths.shape} like paths, got {vel.shape}")
        vel = np.ascontiguousarray(vel)
    else:
        vel = np.zeros((N, 0, 2))
    out = np.full((N, _N_FOOT), np.nan)
    want_stance = any(m in chosen for m in ("stride", "duty", "flatness", "stance_rms_line",
                                             "stance_speed", "speed_ripple"))
    want_path = "width" in chosen or "height" in chosen
    if N and any(m in FOOT_METRICS for m in chosen):
        parallel_rows(_foot_metrics_kernel, (band, want_path, want_stance, bool(need_vel)),
                      (np.ascontiguousarray(paths), vel, status, out))
    result = {}
    for m in chosen:
        if m == "min_transmission_angle":
            if mechanism is None:
                raise UserError("metrics: min_transmission_angle needs the mechanism (mechanism=, lengths=, crank=)")
            if not fourbar_loops(mechanism):
                if explicit:
                    raise UserError(f"metrics: min_transmission_angle: mechanism {mechanism.name!r} has no "
                                    "crank-driven four-bar loop")
                continue
            result[m] = min_transmission_angle(mechanism, lengths, crank, status=status, n=N)
        else:
            result[m] = out[:, _INDEX[m]].copy()
    return result


# -- transmission angle ------------------------------------------------------------------------------
def min_transmission_angle(mech, lengths=None, crank=None, *, status=None, n: int | None = None) -> np.ndarray:
    """Least transmission angle (degrees) over a full crank turn of every crank-driven four-bar loop.

    lengths : (N, n_links) in ``mech.links`` order (default: the nominal, N = ``n`` or 1);
    crank : (N,) crank radii (default: the nominal's); status : (N,) ints, non-zero → NaN.
    Returns (N,) float64; NaN where a loop cannot close at an extreme (|cos μ| > 1), for non-ok
    variants, and everywhere if ``mech`` has no crank-driven four-bar loop. Closed form (see the
    module docstring), exact in θ rather than sampled.
    """
    nl = len(mech.links)
    if lengths is None:
        N = n if n is not None else (len(crank) if crank is not None else 1)
        L = np.broadcast_to(mech.lengths, (N, nl))
    else:
        L = np.asarray(lengths, dtype=np.float64)
        if L.ndim != 2 or L.shape[1] != nl:
            raise UserError(f"lengths: expected shape (N, {nl}) in mechanism.links order, got {L.shape}")
        N = L.shape[0]
    if n is not None and N != n:
        raise UserError(f"lengths: expected {n} rows like paths, got {N}")
    if crank is None:
        r = np.full(N, float(mech.crank.radius))
    else:
        r = np.asarray(crank, dtype=np.float64).reshape(-1)
        if r.shape != (N,):
            raise UserError(f"crank: expected shape ({N},), got {r.shape}")
    out = np.full(N, np.inf)
    loops = fourbar_loops(mech)
    cx, cy = mech.crank.center
    with np.errstate(invalid="ignore", divide="ignore"):
        for v, f, i_c, i_l in loops:
            fx, fy = mech.fixed[f]
            g = math.hypot(fx - cx, fy - cy)
            c, l = L[:, i_c], L[:, i_l]
            cos_lo = (c * c + l * l - (g - r) ** 2) / (2 * c * l)  # d = |g - r|: smallest μ
            cos_hi = (c * c + l * l - (g + r) ** 2) / (2 * c * l)  # d = g + r: largest μ
            bad = (np.abs(cos_lo) > 1.0) | (np.abs(cos_hi) > 1.0)
            mu_lo = np.degrees(np.arccos(np.clip(cos_lo, -1.0, 1.0)))
            mu_hi = np.degrees(np.arccos(np.clip(cos_hi, -1.0, 1.0)))
            m = np.minimum(mu_lo, 180.0 - mu_hi)
            m[bad] = np.nan
            out = np.minimum(out, m)  # NaN in any loop propagates
    out[np.isinf(out)] = np.nan
    if status is not None:
        st = np.asarray(status)
        if st.shape != (N,):
            raise UserError(f"status: expected shape ({N},), got {st.shape}")
        out[st != 0] = np.nan
    return out
