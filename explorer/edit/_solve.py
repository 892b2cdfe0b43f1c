"""What the editor shows of a design: one solve, as JSON.

:func:`solve_design` is ``explorer.simulate`` of the design (the positions of every vertex over the turn,
its status and failure), the metrics ``explorer.gait.compute_metrics`` gives for its foot path and
velocity (the walker scene of the design's own ``[walker]`` table, the single-leg metrics, the
buildability screen's inputs, or ``quick_return`` for a foot on a ground slider), the screen's margins
at the thresholds given, and, where the design has an ``[operating]`` table with ``unit`` and ``rpm``,
the forces effect (``explorer.simulate(..., forces=True)``: motor torque and pin forces in SI units).
Nothing here is computed by the editor itself: every figure is the library's.
"""

from __future__ import annotations

import base64
import math
import time

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism

#: The metric groups the editor shows live (the table's groups; ``forces`` come from the forces solve).
LIVE_GROUPS = ("walker", "leg", "screen", "slider")


def _f(x) -> float | None:
    """A float for JSON (None for NaN or infinity)."""
    x = float(x)
    return x if math.isfinite(x) else None


def encode(a: np.ndarray, dtype: str = "<f8") -> str:
    """An array as base64 of its bytes (little-endian float64, or ``dtype``; C order): the page reads it
    as a Float64Array (Float32Array) with NaN kept, much faster than a JSON list of numbers."""
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def failure_data(mech: Mechanism, failure) -> dict | None:
    """A :class:`explorer.Failure` as JSON: kind, message, the angles (degrees for a crank, seconds for a
    path), the block and its first vertex."""
    if failure is None:
        return None
    crank = mech.crank is not None
    conv = math.degrees if crank else float
    return {"kind": failure.kind, "message": failure.message, "vertex": failure.vertex, "block": failure.block,
            "theta": _f(conv(failure.theta)), "theta_end": None if failure.theta_end is None else _f(conv(failure.theta_end)),
            "unit": "deg" if crank else "s"}


def live_metrics(mech: Mechanism, cycle) -> tuple[dict, dict]:
    """({metric: value or None}, {metric: why not}) of a solved cycle: every metric of
    :data:`LIVE_GROUPS` that applies to ``mech``, by ``explorer.gait.compute_metrics``."""
    from ..gait import BY_NAME, available_metrics, compute_metrics

    avail = available_metrics(mech)
    names = [m for m, why in avail.items() if why is None and m in BY_NAME and BY_NAME[m].group in LIVE_GROUPS]
    not_applicable = {m: why for m, why in avail.items()
                      if why is not None and m in BY_NAME and BY_NAME[m].group in LIVE_GROUPS}
    if not names:
        return {}, not_applicable
    foot = mech.foot
    status = np.array([0 if cycle.ok else 1], dtype=np.int64)
    vel = cycle.velocity(foot)[None] if cycle.velocities is not None else None
    got = compute_metrics(cycle.path(foot)[None], vel, status, names, mechanism=mech)
    return {m: _f(v[0]) for m, v in got.items()}, not_applicable


class _Row:
    """One design as the screen's checks read a frame (``row[name].to_numpy(...)``, ``row.columns``):
    a one-row frame without pandas' cost (a DataFrame took 2.6 ms a drag step)."""

    class _Col:
        def __init__(self, v):
            self.v = v

        def to_numpy(self, dtype=None, na_value=None):
            return np.array([self.v], dtype=dtype)

    def __init__(self, values: dict):
        self.values = values
        self.columns = list(values)

    def __getitem__(self, name):
        return self._Col(self.values[name])


def screen_margins(mech: Mechanism, metrics: dict, status: str, screen=None) -> dict:
    """The buildability screen of one design of solve status ``status`` ("ok", or a failure's kind) by
    ``explorer.gait.CHECKS`` at the thresholds ``screen`` (an
    :class:`explorer.gait.Screen`, None for the defaults): {"buildable": bool, "reason": "pass" or the
    failing checks' reasons joined by "; " (as ``screen_columns`` words them), "checks": [{check, metric,
    field, value, threshold, margin, pass}]}; margin = how far the value is inside its threshold
    (negative: outside), in the metric's unit."""
    from ..gait import CHECKS, Screen, metric

    ok = status == "ok"
    screen = screen if screen is not None else Screen()
    row = {m: (np.nan if v is None else v) for m, v in metrics.items()}
    row["crank"] = float(mech.crank.radius) if mech.crank is not None else np.nan
    frame = _Row(row)
    checks, reasons = [], []
    for c in CHECKS:
        if not all(col in row for col in c.inputs):
            continue
        v = float(c.value(frame)[0])
        t = float(getattr(screen, c.field))
        fails = bool(c.fails(np.array([v]), t)[0])
        margin = (v - t) if metric(c.inputs[0]).direction == "max" else (t - v)
        checks.append({"check": c.name, "metric": c.inputs[0], "field": c.field, "value": _f(v), "threshold": t,
                       "margin": _f(margin), "pass": bool(ok and not fails)})
        if fails:
            reasons.append(f"{c.name}: {c.inputs[0]} is undefined" if not math.isfinite(v) else c.reason(v, t))
    if not checks:
        return {"buildable": None, "reason": "not applicable", "checks": checks}
    if not ok:
        return {"buildable": False, "reason": f"failed ({status})", "checks": checks}
    return {"buildable": not reasons, "reason": "; ".join(reasons) or "pass", "checks": checks}


def forces_data(mech: Mechanism, steps: int) -> dict:
    """The forces effect of ``mech`` at its own ``[operating]`` point (``explorer.simulate(mech, steps,
    forces=True)``): {"metrics": {name: SI value}, "torque": base64 (steps,), "status", "failure",
    "walker": legs} — or {"note": why not} where the design has no operating point with unit and rpm."""
    from ..kernels import simulate

    op = mech.operating
    if mech.crank is None:
        return {"note": "forces are computed for crank-driven mechanisms"}
    if op is None or op.unit is None or op.rpm is None:
        return {"note": "no motor torque or pin forces: the design has no [operating] table with unit (metres per "
                        "model unit) and rpm"}
    try:
        cyc = simulate(mech, steps, forces=True)
    except UserError as exc:
        return {"note": f"no forces: {exc}"}
    walker = mech.walker
    return {"metrics": {k: _f(v) for k, v in (cyc.force_metrics or {}).items()},
            "torque": encode(cyc.torque) if cyc.torque is not None else None,
            "status": "ok" if cyc.ok else cyc.failure.kind, "failure": failure_data(mech, cyc.failure),
            "legs": walker.legs if walker is not None else 1,
            "operating": op.as_dict()}


def _points(xy: np.ndarray) -> list:
    """(S, 2) → [[x, y] or None] × S (None where not finite: JSON has no NaN)."""
    out = xy.tolist()
    if not np.all(np.isfinite(xy)):
        bad = ~np.all(np.isfinite(xy), axis=1)
        for k in np.flatnonzero(bad):
            out[k] = None
    return out


def solve_design(mech: Mechanism, steps: int = 360, *, screen=None, forces: bool = True, foot: bool = True,
                 cycle=None) -> dict:
    """Everything the editor shows of ``mech`` (JSON-ready):

    status, ok, failure : of ``explorer.simulate(mech, steps)`` (the default tolerance and method).
    foot : [[x, y] or None] × steps, the foot path (model units), with ``foot`` (the page reads it from
        ``positions``, which hold it: the list is for other clients of POST /api/solve).
    positions : base64 float32 (steps, n_vertices, 2), every vertex over the turn, to draw (NaN where unsolved);
    vertices : their names in that order; theta : base64 (steps,), the driver's samples.
    metrics, not_applicable : :func:`live_metrics`; screen : :func:`screen_margins`.
    forces : :func:`forces_data` (``forces``), else None.
    ms : how long the solve, the metrics and the forces took, milliseconds.
    cycle : ``explorer.simulate(mech, steps)`` already computed (a drag step solves it on the way).
    """
    from ..kernels import simulate

    t0 = time.perf_counter()
    cyc = simulate(mech, steps) if cycle is None else cycle
    t1 = time.perf_counter()
    metrics, na = live_metrics(mech, cyc)
    status = "ok" if cyc.ok else cyc.failure.kind
    scr = screen_margins(mech, metrics, status, screen) if mech.crank is not None and any(
        m in metrics for m in ("min_transmission_angle", "foot_headroom", "max_speed", "self_crossings")) else None
    t2 = time.perf_counter()
    frc = forces_data(mech, steps) if forces else None
    t3 = time.perf_counter()
    return {
        "name": mech.name,
        "steps": int(steps),
        "status": status,
        "ok": bool(cyc.ok),
        "failure": failure_data(mech, cyc.failure),
        "foot": _points(cyc.path(mech.foot)) if foot else None,
        "vertices": list(mech.vertices),
        "positions": encode(cyc.positions, "<f4"),  # to draw: 7 digits (the metrics are sent as float64)
        "theta": encode(cyc.theta),
        "metrics": metrics,
        "not_applicable": na,
        "screen": scr,
        "forces": frc,
        "ms": {"solve": 1e3 * (t1 - t0), "metrics": 1e3 * (t2 - t1), "forces": 1e3 * (t3 - t2)},
    }
