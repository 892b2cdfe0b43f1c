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

foot_headroom   min(y of the crank centre, y of every ground pivot) − max(y over the cycle): how far
                the foot's highest point stays below the frame (negative: it rises above it).
self_crossings  number of proper crossings between non-adjacent segments of the closed polyline
                through the samples (0 for a simple loop, 1 for a figure eight).

A variant whose path holds a non-finite value gets NaN for every foot metric; one whose
velocities hold a non-finite value gets NaN for the three speed metrics.

The walker metrics (``travel``, ``bob``, …) are defined in :mod:`explorer.gait._walker`; every
metric's unit and direction is in the one table, :mod:`explorer.gait._table`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from ..errors import UserError
from ..kernels import parallel_rows
from ..plan import fourbar_loops
from ..plan import loop_ground, loop_side
from ._runs import all_finite, longest_cyclic_run
from ._walker import walker_metrics

from ._table import (BY_NAME, CRANK_METRICS, DESCRIPTIONS, DIRECTIONS, FOOT_METRICS, LEG_METRICS,  # noqa: F401
                     MECHANISM_METRICS, METRICS, PATH_METRICS, SCREEN_METRICS, UNITS, VELOCITY_METRICS,
                     WALKER_METRICS)

DEFAULT_BAND = 0.01

_INDEX = {name: i for i, name in enumerate(FOOT_METRICS)}
_N_FOOT = len(FOOT_METRICS)
# the foot kernel's columns, by name (reordering the table cannot mislabel a result)
(_WIDTH, _HEIGHT, _STRIDE, _DUTY, _FLATNESS, _STANCE_RMS, _STANCE_SPEED, _SPEED_RIPPLE, _MAX_SPEED) = (
    _INDEX["width"], _INDEX["height"], _INDEX["stride"], _INDEX["duty"], _INDEX["flatness"],
    _INDEX["stance_rms_line"], _INDEX["stance_speed"], _INDEX["speed_ripple"], _INDEX["max_speed"])


# -- the kernel --------------------------------------------------------------------------------------
@njit(cache=True)
def _stance(y, thr):
    """Longest cyclic run of y <= thr: (start, length); ties to the smallest start. (0, S) if all."""
    return longest_cyclic_run(y <= thr)


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
            out[i, _WIDTH] = xmax - xmin
            out[i, _HEIGHT] = ymax - ymin
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
            out[i, _STRIDE] = stride
            out[i, _DUTY] = n / S
            if stride > 0.0:
                out[i, _FLATNESS] = math.sqrt(syy / n) / stride
            if sxx > 0.0:
                b = sxy / sxx
                sse = 0.0
                for j in range(n):
                    k = (start + j) % S
                    e = (paths[i, k, 1] - my) - b * (paths[i, k, 0] - mx)
                    sse += e * e
                out[i, _STANCE_RMS] = math.sqrt(sse / n / (1.0 + b * b))
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
                out[i, _MAX_SPEED] = vmax
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
                    out[i, _STANCE_SPEED] = ms
                    if ms > 0.0:
                        out[i, _SPEED_RIPPLE] = math.sqrt(var / n) / ms


@njit(cache=True, nogil=True)
def _crossings_kernel(paths, status, out):
    """out[i] = proper crossings of the closed polyline through paths[i] (ok, finite rows only; out
    comes NaN-filled). Segments are bucketed by their smallest x (S buckets over the path's x-range,
    a linear-time counting sort) and each is tested only against segments from buckets up to the one
    holding its largest x, so a foot path costs about O(S), not O(S²)."""
    N = paths.shape[0]
    S = paths.shape[1]
    xlo = np.empty(S)
    xhi = np.empty(S)
    blo = np.empty(S, dtype=np.int64)
    start = np.empty(S + 1, dtype=np.int64)
    order = np.empty(S, dtype=np.int64)
    for i in range(N):
        if status[i] != 0 or not all_finite(paths[i]):
            continue
        xmin = np.inf
        xmax = -np.inf
        for k in range(S):
            x0 = paths[i, k, 0]
            x1 = paths[i, (k + 1) % S, 0]
            xlo[k] = min(x0, x1)
            xhi[k] = max(x0, x1)
            if xlo[k] < xmin:
                xmin = xlo[k]
            if xhi[k] > xmax:
                xmax = xhi[k]
        scale = (S - 1) / (xmax - xmin) if xmax > xmin else 0.0
        for b in range(S + 1):
            start[b] = 0
        for k in range(S):
            blo[k] = int((xlo[k] - xmin) * scale)
            start[blo[k] + 1] += 1
        for b in range(S):
            start[b + 1] += start[b]
        for k in range(S):  # counting sort by bucket (start[b] is consumed as a cursor, then restored)
            order[start[blo[k]]] = k
            start[blo[k]] += 1
        for b in range(S - 1, 0, -1):
            start[b] = start[b - 1]
        start[0] = 0
        count = 0
        for p in range(S):
            s = order[p]
            bhi = int((xhi[s] - xmin) * scale)
            ax = paths[i, s, 0]
            ay = paths[i, s, 1]
            bx = paths[i, (s + 1) % S, 0]
            by = paths[i, (s + 1) % S, 1]
            for q in range(p + 1, S):
                t = order[q]
                if blo[t] > bhi:
                    break
                if xlo[t] > xhi[s] or xlo[s] > xhi[t]:
                    continue
                gap = abs(s - t)
                if gap <= 1 or gap == S - 1:  # neighbours share an end point
                    continue
                cx = paths[i, t, 0]
                cy = paths[i, t, 1]
                dx = paths[i, (t + 1) % S, 0]
                dy = paths[i, (t + 1) % S, 1]
                if max(ay, by) < min(cy, dy) or max(cy, dy) < min(ay, by):
                    continue
                d1 = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)
                d2 = (bx - ax) * (dy - ay) - (by - ay) * (dx - ax)
                d3 = (dx - cx) * (ay - cy) - (dy - cy) * (ax - cx)
                d4 = (dx - cx) * (by - cy) - (dy - cy) * (bx - cx)
                if d1 * d2 < 0.0 and d3 * d4 < 0.0:
                    count += 1
        out[i] = count


def foot_headroom(mech, paths, status=None, geometry=None) -> np.ndarray:
    """(N,) min(y of the crank centre and every ground pivot) − max over the cycle of the foot's y.

    paths (N, S, 2). geometry : None or {coordinate parameter name: (N,) values}: each variant's own
    crank centre and pivots ("crank.y", "2.y"; those not given keep the nominal's). NaN for non-ok
    variants, non-finite paths, or a mechanism with neither a crank nor a ground pivot."""
    paths = np.asarray(paths, dtype=np.float64)
    geometry = geometry or {}
    N = paths.shape[0]
    heights = [geometry.get(f"{v}.y", y) for v, (_, y) in mech.fixed.items()]
    if mech.crank is not None:
        heights.append(geometry.get("crank.y", mech.crank.center[1]))
    if not heights:
        return np.full(N, np.nan)
    with np.errstate(invalid="ignore"):
        top = paths[:, :, 1].max(axis=1) if paths.shape[1] else np.full(N, np.nan)
    low = np.min(np.stack([np.broadcast_to(np.asarray(h, dtype=np.float64), (N,)) for h in heights]), axis=0)
    out = low - top
    out[~np.isfinite(paths).all(axis=(1, 2))] = np.nan
    if status is not None:
        out[np.asarray(status) != 0] = np.nan
    return out


# -- public ------------------------------------------------------------------------------------------


#: Metrics computed elsewhere than from a foot path: the need that says so, and where they come from.
COMPUTED_ELSEWHERE = {
    "forces": ("comes from the forces effect: a study's [scene] forces = true with an [operating] table, or "
               "simulate_batch(..., forces=True, operating=...)"),
    "physics": ("comes from the physics check of a shortlist (MuJoCo): `explorer physics RESULTS`, or "
                "explorer.physics.physics_check"),
    "robustness": ("comes from copies of each design cut with a manufacturing error: a study's [robustness] table "
                   "with yield in [scene] metrics, `explorer rank RESULTS --yield 0.5%` for the designs it shows, "
                   "or explorer.study.design_yield"),
}


def _foot_lifts(mech) -> str | None:
    """Where the walker, leg and screen groups apply: a foot that lifts and steps (not a ground slider's)."""
    sl = _foot_slider(mech)
    if sl is None:
        return None
    return (f"the foot {mech.foot!r} of mechanism {mech.name!r} runs on the ground slider {sl.name!r}: "
            f"a stroke along a fixed line, not a foot that lifts and steps (walker, leg and screen metrics)")


def _foot_slides(mech) -> str | None:
    """Where the slider group applies: a foot on a ground slider."""
    if _foot_slider(mech) is not None:
        return None
    return f"mechanism {mech.name!r} has no foot on a ground slider (a slider's metric)"


def _has_fourbar(mech) -> str | None:
    return None if fourbar_loops(mech) else f"mechanism {mech.name!r} has no crank-driven four-bar loop"


#: Metrics with a condition of their own beyond their group's: name -> where(mechanism) (None: it applies).
METRIC_WHERE = {"min_transmission_angle": _has_fourbar}


class _Where(NamedTuple):
    mechanism: object
    walker: object
    crank: object
    target: object


def _elsewhere(info, c: _Where) -> str | None:
    return next((why for need, why in COMPUTED_ELSEWHERE.items() if need in info.needs), None)


def _needs_mechanism(info, c: _Where) -> str | None:
    return "needs the mechanism (mechanism=, lengths=, crank=)" if "mechanism" in info.needs and c.mechanism is None \
        else None


def _group_applies(info, c: _Where) -> str | None:
    group = GROUPS.get(info.group)
    return group.where(c.mechanism) if group is not None and c.mechanism is not None else None


def _metric_applies(info, c: _Where) -> str | None:
    where = METRIC_WHERE.get(info.name)
    return where(c.mechanism) if where is not None else None


def _crank_driven(info, c: _Where) -> str | None:
    if c.mechanism is not None and c.mechanism.crank is None:
        return (f"mechanism {c.mechanism.name!r} is driven along a path, not by a crank: gait metrics describe a "
                f"leg's closed foot path over a crank turn")
    return None


def _crank_given(info, c: _Where) -> str | None:
    if info.name in CRANK_METRICS and c.mechanism is None and (c.walker is None or c.crank is None):
        return "needs a crank-driven mechanism (mechanism=) or walker= and crank="
    return None


def _target_given(info, c: _Where) -> str | None:
    return "needs a target path (a study's [target] table, or target=)" if "target" in info.needs and c.target is None \
        else None


#: Why a metric cannot be computed, asked in this order (the first reason given is the one reported): what
#: comes from elsewhere, what needs the mechanism, where its group applies (:data:`GROUPS`), where the metric
#: itself applies (:data:`METRIC_WHERE`), a crank drive, and the inputs a call must pass.
WHY_NOT = (_elsewhere, _needs_mechanism, _group_applies, _metric_applies, _crank_driven, _crank_given, _target_given)


def _available(mechanism, walker, crank, target=None) -> dict[str, str | None]:
    """{metric: None if it can be computed here, else why not} (the rules of :data:`WHY_NOT`)."""
    c = _Where(mechanism, walker, crank, target)
    return {m: next((why for rule in WHY_NOT if (why := rule(BY_NAME[m], c)) is not None), None) for m in METRICS}


def available_metrics(mechanism=None, target=None) -> dict[str, str | None]:
    """{metric: None if :func:`compute_metrics` can compute it for ``mechanism`` (given its foot path
    and velocities, and ``target`` for path_error), else the one-line reason why not}, in METRICS order."""
    return _available(mechanism, None, None, target)


def _resolve_names(names, available: dict[str, str | None]) -> list[str]:
    """The requested metric names in METRICS order (validated); True/None: every available one."""
    if names is None or names is True:
        return [m for m in METRICS if available[m] is None]
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
    for n in names:
        if available[n] is not None:
            raise UserError(f"metrics: {n}: {available[n]}")
    chosen = set(names)
    return [m for m in METRICS if m in chosen]


def check_band(band) -> float:
    """``band`` as a float in [0, 1], or UserError naming it."""
    if isinstance(band, bool) or not isinstance(band, (int, float, np.integer, np.floating)):
        raise UserError(f"band: expected a number in [0, 1], got {band!r}")
    b = float(band)
    if not (0.0 <= b <= 1.0):
        raise UserError(f"band: expected a number in [0, 1], got {band!r}")
    return b


def compute_metrics(paths, velocities=None, status=None, names=None, band: float = DEFAULT_BAND, *,
                    mechanism=None, lengths=None, crank=None, walker=None, geometry=None,
                    target=None) -> dict[str, np.ndarray]:
    """Metrics of N foot paths: the walker scene, the single-leg band metrics and the screen's inputs
    (definitions: :mod:`explorer.gait._walker` and this module's docstring; units and directions:
    :data:`explorer.gait.TABLE`).

    Parameters
    ----------
    paths : array (N, S, 2)
        Foot positions (x, y) at θ_k = 2πk/S, model units. S ≥ 2.
    velocities : array (N, S, 2) or None
        dF/dθ, model units per radian of crank. Needed for the metrics whose ``needs`` hold
        "velocity" (travel, body_speed_ripple, the torques, slip, the stance speeds, max_speed).
    status : array (N,) of int, or None
        0 = ok (None: all ok). Variants with any other code get NaN for every metric.
    names : iterable of metric names, a single name, None or True
        The metrics to compute. None/True: every metric that can be computed from what is given
        (velocities are then required): the walker metrics and foot_headroom need the mechanism (a
        crank-driven one for the walker), min_transmission_angle a crank-driven four-bar loop.
        Unknown or impossible names raise UserError saying why.
    band : float in [0, 1]
        Stance band of the single-leg metrics, a fraction of the path height (default 0.01).
    mechanism : Mechanism, optional
        Needed for the walker (its crank and default ``[walker]``), min_transmission_angle and
        foot_headroom.
    lengths : array (N, n_links), optional
        Link lengths of each variant in ``mechanism.links`` order (default: the nominal's).
    crank : array (N,), optional
        Crank radius of each variant (default: the nominal's).
    walker : :class:`explorer.mechanism.Walker`, optional
        The walker scene (default: the mechanism's ``[walker]`` table, else ``Walker()``: four legs
        evenly spaced).
    geometry : dict, optional
        {coordinate parameter name: (N,) values} of each variant's crank centre and ground pivots
        ("crank.x", "2.y", see ``Mechanism.parameters``; those not given keep the nominal's): read by
        foot_headroom and min_transmission_angle (the loops' ground links).
    target : :class:`explorer.gait.Target`, optional
        The target path of ``path_error`` (a study's ``[target]`` table: :func:`explorer.gait.load_target`).

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
    band = check_band(band)
    geometry = _geometry(geometry, mechanism, N)
    chosen = _resolve_names(names, _available(mechanism, walker, crank, target))
    need_vel = [m for m in chosen if m in VELOCITY_METRICS]
    if need_vel and velocities is None:
        raise UserError(f"metrics: {', '.join(need_vel)} need the foot velocities dF/dθ; pass velocities= "
                        f"or ask only for metrics of the path alone")
    if velocities is not None and need_vel:
        vel = np.asarray(velocities, dtype=np.float64)
        if vel.shape != paths.shape:
            raise UserError(f"velocities: expected shape {paths.shape} like paths, got {vel.shape}")
        vel = np.ascontiguousarray(vel)
    else:
        vel = np.zeros((N, 0, 2))
    cpaths = np.ascontiguousarray(paths)
    # no ok row (the runner's validation call, a chunk that failed whole): every metric is NaN, and no
    # kernel needs to run (or be compiled: a cold `explorer run` compiles them in parallel, see _warm)
    run = N > 0 and bool(np.any(status == 0))
    ctx = _Context(cpaths, vel, velocities, status, band, mechanism, lengths, crank, walker, geometry, target, run, N)
    result = {}
    for name, group in GROUPS.items():  # each group's kernel, for the metrics asked of it
        wanted = [m for m in chosen if BY_NAME[m].group == name]
        if wanted:
            result.update(group.compute(ctx, wanted))
    return {m: np.array(result[m], dtype=np.float64) for m in chosen}



class _Context(NamedTuple):
    """What a metric group's kernel reads: cpaths (N, S, 2) contiguous foot paths; vel (N, S, 2) the
    velocities when a requested metric needs them, else (N, 0, 2); velocities as given (or None);
    status (N,) int64; band; mechanism, lengths, crank, walker, geometry, target as given to
    :func:`compute_metrics`; run: some row is ok (else every metric is NaN and no kernel runs); N."""

    cpaths: np.ndarray
    vel: np.ndarray
    velocities: object
    status: np.ndarray
    band: float
    mechanism: object
    lengths: object
    crank: object
    walker: object
    geometry: object
    target: object
    run: bool
    N: int


def _leg_group(ctx: _Context, wanted: list[str]) -> dict:
    """The single-leg band metrics (one pass of the foot kernel)."""
    N = ctx.N
    out = np.full((N, _N_FOOT), np.nan)
    want_stance = any(m in wanted for m in ("stride", "duty", "flatness", "stance_rms_line", "stance_speed",
                                            "speed_ripple"))
    want_path = "width" in wanted or "height" in wanted
    want_vel = any(m in wanted for m in ("stance_speed", "speed_ripple", "max_speed"))
    if ctx.run:
        parallel_rows(_foot_metrics_kernel, (ctx.band, want_path, want_stance, want_vel),
                      (ctx.cpaths, ctx.vel, ctx.status, out))
    return {m: out[:, _INDEX[m]] for m in FOOT_METRICS}


def _walker_group(ctx: _Context, wanted: list[str]) -> dict:
    """The walker scene's metrics (one pass of the walker kernel)."""
    N, mechanism, walker = ctx.N, ctx.mechanism, ctx.walker
    if walker is None:
        from ..mechanism import Walker
        walker = mechanism.walker if mechanism is not None and mechanism.walker is not None else Walker()
    r = _per_variant(ctx.crank, N, mechanism.crank.radius if mechanism is not None else None, "crank")
    if ctx.velocities is None:  # only bob, clearance and contact_fraction were asked for
        wvel = np.zeros_like(ctx.cpaths)
    else:
        wvel = np.ascontiguousarray(np.asarray(ctx.velocities, dtype=np.float64))
        if wvel.shape != ctx.cpaths.shape:
            raise UserError(f"velocities: expected shape {ctx.cpaths.shape} like paths, got {wvel.shape}")
    out = walker_metrics(ctx.cpaths, wvel, ctx.status, r, walker) if ctx.run else np.full((N, len(WALKER_METRICS)),
                                                                                             np.nan)
    return {m: out[:, j] for j, m in enumerate(WALKER_METRICS)}


def _screen_group(ctx: _Context, wanted: list[str]) -> dict:
    """The screen's inputs: each its own computation."""
    result = {}
    if "self_crossings" in wanted:
        out = np.full(ctx.N, np.nan)
        if ctx.run:
            parallel_rows(_crossings_kernel, (), (ctx.cpaths, ctx.status, out))
        result["self_crossings"] = out
    if "foot_headroom" in wanted:
        result["foot_headroom"] = foot_headroom(ctx.mechanism, ctx.cpaths, ctx.status, geometry=ctx.geometry)
    if "min_transmission_angle" in wanted:
        result["min_transmission_angle"] = min_transmission_angle(ctx.mechanism, ctx.lengths, ctx.crank,
                                                                  status=ctx.status, n=ctx.N, geometry=ctx.geometry)
    return result


def _target_group(ctx: _Context, wanted: list[str]) -> dict:
    """Path synthesis: the foot path against the target."""
    out = np.full(ctx.N, np.nan)
    ok = np.flatnonzero(ctx.status == 0)
    if ctx.run and len(ok):
        v = None if ctx.velocities is None else np.asarray(ctx.velocities, dtype=np.float64)[ok]
        out[ok] = ctx.target.error(ctx.cpaths[ok], velocity=v)
    return {"path_error": out}


#: The metric groups of :data:`TABLE` computed from a foot path, each by its kernel: group -> compute(ctx,
#: wanted names) -> {name: (N,)}. A new metric is a row of the table and its column in its group's kernel;
#: a new group is a row here. (The ``forces`` group comes from the forces effect of the kernels,
#: ``simulate_batch(..., forces=True)``, which needs every vertex: :func:`_available` says so.)
def _foot_slider(mech):
    """The ground slider the foot runs on, or None."""
    return next((s for s in mech.sliders if s.vertex == mech.foot and s.ground), None)


def quick_return(mech, paths, status=None, geometry=None) -> np.ndarray:
    """(N,) the quick-return ratio of a foot on a ground slider: the crank angle from the dead centre
    nearest the line's −direction end to the one at its +direction end (the forward stroke), over the
    rest of the turn (the return). Dead centres are the extremes of s(θ) = (foot − point)·n over the
    samples, each refined by the parabola through its sample and their neighbours. NaN where not ok.

    paths (N, S, 2) at θ_k = 2πk/S; geometry: the variants' ``<slider>.x``, ``.y``, ``.dx``, ``.dy``."""
    sl = _foot_slider(mech)
    paths = np.asarray(paths, dtype=np.float64)
    N, S = paths.shape[:2]
    g = geometry or {}
    col = {k: np.broadcast_to(np.asarray(g.get(f"{sl.name}.{k}", v), dtype=np.float64), (N,))
           for k, v in (("x", sl.point[0]), ("y", sl.point[1]), ("dx", sl.direction[0]), ("dy", sl.direction[1]))}
    norm = np.hypot(col["dx"], col["dy"])
    s = ((paths[:, :, 0] - col["x"][:, None]) * col["dx"][:, None]
         + (paths[:, :, 1] - col["y"][:, None]) * col["dy"][:, None]) / norm[:, None]
    out = np.full(N, np.nan)
    for i in range(N):
        if not np.all(np.isfinite(s[i])) or (status is not None and status[i] != 0):
            continue
        ends = []
        for k in (int(np.argmin(s[i])), int(np.argmax(s[i]))):
            a, b, c = s[i, (k - 1) % S], s[i, k], s[i, (k + 1) % S]
            den = a - 2.0 * b + c
            ends.append((k + (0.5 * (a - c) / den if den != 0.0 else 0.0)) * 2.0 * np.pi / S)
        forward = (ends[1] - ends[0]) % (2.0 * np.pi)
        if 0.0 < forward < 2.0 * np.pi:
            out[i] = forward / (2.0 * np.pi - forward)
    return out


def _slider_group(ctx: _Context, wanted: list[str]) -> dict:
    return {"quick_return": quick_return(ctx.mechanism, ctx.cpaths, ctx.status, ctx.geometry)}


class MetricGroup(NamedTuple):
    """A group of metrics (the ``group`` column of the metric table): compute(ctx, wanted) -> {metric: (N,)}
    runs its kernel for the metrics asked of it; where(mechanism) -> None where the group applies, else the
    one-line reason why not."""

    compute: object
    where: object


def _everywhere(mech) -> None:
    return None


#: The metric groups with a kernel here, and where each applies (adding a group is one entry).
GROUPS = {"leg": MetricGroup(_leg_group, _foot_lifts), "walker": MetricGroup(_walker_group, _foot_lifts),
          "screen": MetricGroup(_screen_group, _foot_lifts), "target": MetricGroup(_target_group, _everywhere),
          "slider": MetricGroup(_slider_group, _foot_slides)}
#: Metric groups that describe a foot that lifts and steps: not applicable when the foot is the sliding
#: vertex of a ground slider (a piston, a ram: its path is a segment of a fixed line, so stance, stride,
#: slip, clearance ... and the screen's headroom and self-crossings have no meaning there); read from
#: :data:`GROUPS`.
FOOT_ON_LINE_GROUPS = tuple(name for name, group in GROUPS.items() if group.where is _foot_lifts)

def _geometry(geometry, mechanism, N: int) -> dict | None:
    """``geometry`` checked: {coordinate parameter name of ``mechanism``: (N,) float64}, or None."""
    if not geometry:
        return None
    if mechanism is None:
        raise UserError("geometry: needs the mechanism (mechanism=) whose coordinates it names")
    out = {}
    for key, col in dict(geometry).items():
        if mechanism.parameter_kind(str(key)) != "coordinate":
            raise UserError(f"geometry: {key!r} is a length, not a coordinate (pass it in lengths= or crank=)")
        v = np.asarray(col, dtype=np.float64).reshape(-1)
        if v.shape != (N,):
            raise UserError(f"geometry[{key!r}]: expected shape ({N},), got {np.shape(col)}")
        out[str(key)] = v
    return out


def _per_variant(values, N: int, default, name: str) -> np.ndarray:
    if values is None:
        if default is None:
            raise UserError(f"{name}: expected ({N},) values")
        return np.full(N, float(default))
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if v.shape != (N,):
        raise UserError(f"{name}: expected shape ({N},), got {v.shape}")
    return v


# -- transmission angle ------------------------------------------------------------------------------
def min_transmission_angle(mech, lengths=None, crank=None, *, status=None, n: int | None = None,
                           geometry=None) -> np.ndarray:
    """Least transmission angle (degrees) over a full crank turn of every crank-driven four-bar loop.

    lengths : (N, n_links) in ``mech.links`` order (default: the nominal, N = ``n`` or 1);
    crank : (N,) crank radii (default: the nominal's); status : (N,) ints, non-zero → NaN;
    geometry : None or {coordinate parameter name: (N,) values}, each variant's crank centre and
    ground pivots (they set each loop's ground link |centre − pivot|).
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
    if geometry:
        for key, col in geometry.items():
            if np.shape(col) != (N,):
                raise UserError(f"geometry[{key!r}]: expected shape ({N},), got {np.shape(col)}")
    out = np.full(N, np.inf)
    loops = fourbar_loops(mech)
    with np.errstate(invalid="ignore", divide="ignore"):
        for v, f, i_c, i_l in loops:
            g = loop_ground(mech, f, geometry, N)
            c, l = loop_side(mech, i_c, L, geometry), loop_side(mech, i_l, L, geometry)
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
