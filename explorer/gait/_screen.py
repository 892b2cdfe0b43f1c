"""The buildability screen: which ok variants nobody would build, and why.

A variant passes when every check whose metrics are stored holds (thresholds: :class:`Screen`, set in
a study's ``[screen]`` table):

* **toggle**: ``min_transmission_angle`` ≥ min_transmission_angle (default 5°; Jansen's nominal 8.6°):
  the crank-driven four-bar loops keep away from their toggle (dead-centre) positions.
* **foot above the frame**: ``foot_headroom`` ≥ min_foot_headroom (default 0): the foot's highest
  point stays below the crank axle and every ground pivot, so the leg clears its own frame.
* **foot whip**: ``max_speed`` / crank ≤ max_foot_speed (default 6 crank radii per radian; Jansen's
  nominal 3.6): a foot whipped round faster than that loads the leg with inertia the quasi-static
  torque does not show (near-toggle designs reach 10-60).
* **crossing path**: ``self_crossings`` ≤ max_self_crossings (default 0): the foot path is a simple loop.

A NaN metric fails its check (the check cannot vouch for the design). Failed variants (status not
ok) are never buildable and their reason is their status. :func:`screen_columns` gives the two frame
columns ``buildable`` (bool) and ``screen`` ("pass", or the reasons joined by "; ").

**Margins.** How close a design comes to each limit, as a fraction (positive inside the limit, negative
outside), so that the checks compare: toggle (angle − limit) / limit (a limit of 0°: angle / 90°);
foot above the frame (headroom − limit) / crank radius; foot whip (limit − speed) / limit. The
crossing check counts crossings and has no margin. :func:`screen_margins` gives each design's tightest
one, which ``explorer rank`` shows: a design that passes by 0.3 % of the foot-whip limit passes, but a
workshop's ±0.5 mm may push half of its copies over (``rank --yield 0.5mm`` measures that).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Callable, NamedTuple

import numpy as np

from ..errors import UserError, where


@dataclass(frozen=True)
class Screen:
    """Thresholds of the buildability screen (see the module docstring).

    min_transmission_angle : degrees, toggle margin of the crank-driven four-bar loops.
    min_foot_headroom : model units the foot's highest point must stay below the crank axle and every
        ground pivot (0: never at or above them; negative values allow that much).
    max_foot_speed : largest peak foot speed |dF/dθ|, in crank radii per radian of crank.
    max_self_crossings : crossings of the foot path allowed (0: a simple loop).
    """

    min_transmission_angle: float = 5.0
    min_foot_headroom: float = 0.0
    max_foot_speed: float = 6.0
    max_self_crossings: int = 0

    def as_dict(self) -> dict:
        return asdict(self)


def _column(name):
    def get(df):
        return df[name].to_numpy(dtype=np.float64, na_value=np.nan)
    return get


def _whip(df):
    with np.errstate(invalid="ignore", divide="ignore"):
        return _column("max_speed")(df) / _column("crank")(df)


class Check(NamedTuple):
    """One check of the screen: ``name`` (its reason starts with it); ``inputs``, the frame columns it
    reads (metrics, and "crank"); ``value(frame) -> (n,)``; ``field``, its threshold in
    :class:`Screen` (and the ``[screen]`` key); ``fails(value, threshold) -> (n,) bool``;
    ``reason(value, threshold) -> str``, one line for a variant it removes."""

    name: str
    inputs: tuple
    value: Callable
    field: str
    fails: Callable
    reason: Callable
    #: margin(value, threshold, frame) -> (n,) fraction inside the limit (module docstring); None: no margin
    margin: Callable | None = None


def _toggle_margin(v, t, df):
    return (v - t) / t if t > 0 else v / 90.0


def _headroom_margin(v, t, df):
    return (v - t) / _column("crank")(df)


def _whip_margin(v, t, df):
    return (t - v) / t


#: The screen's checks, in report order (the one home of what each reads and says).
CHECKS = (
    Check("toggle", ("min_transmission_angle",), _column("min_transmission_angle"), "min_transmission_angle",
          lambda v, t: ~(v >= t), lambda v, t: f"toggle: min transmission angle {v:.3g}° < {t:g}°", _toggle_margin),
    Check("foot above the frame", ("foot_headroom",), _column("foot_headroom"), "min_foot_headroom",
          lambda v, t: ~(v >= t), lambda v, t: f"foot above the frame: headroom {v:.4g} < {t:g}", _headroom_margin),
    Check("foot whip", ("max_speed", "crank"), _whip, "max_foot_speed",
          lambda v, t: ~(v <= t), lambda v, t: f"foot whip: peak foot speed {v:.3g} crank radii/rad > {t:g}",
          _whip_margin),
    Check("crossing path", ("self_crossings",), _column("self_crossings"), "max_self_crossings",
          lambda v, t: ~(v <= t), lambda v, t: f"crossing path: the foot path crosses itself {v:.0f}×"),
)
#: The metrics the screen reads (its checks' inputs that are metrics), in check order.
SCREEN_INPUTS = tuple(dict.fromkeys(col for c in CHECKS for col in c.inputs if col != "crank"))
SCREEN_KEYS = tuple(c.field for c in CHECKS)


def screen_from_dict(table, source: str, key: str = "screen") -> Screen:
    """Validate a study's ``[screen]`` table (keys :data:`SCREEN_KEYS`) into a :class:`Screen`."""
    if not isinstance(table, dict):
        raise UserError(f"{where(source, key)}: expected a table, got {table!r}")
    for k in table:
        if k not in SCREEN_KEYS:
            raise UserError(f"{where(source, f'{key}.{k}')}: unknown key (allowed in [{key}]: {', '.join(SCREEN_KEYS)})")
    out = {}
    for k, v in table.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise UserError(f"{where(source, f'{key}.{k}')}: expected a finite number, got {v!r}")
        if k == "max_self_crossings":
            if not isinstance(v, int) or v < 0:
                raise UserError(f"{where(source, f'{key}.{k}')}: expected a whole number >= 0, got {v!r}")
            out[k] = int(v)
        elif k == "min_transmission_angle" and not 0 <= v < 90:
            raise UserError(f"{where(source, f'{key}.{k}')}: expected degrees in [0, 90), got {v!r}")
        elif k == "max_foot_speed" and not v > 0:
            raise UserError(f"{where(source, f'{key}.{k}')}: expected crank radii per radian > 0, got {v!r}")
        else:
            out[k] = float(v)
    return Screen(**out)


def _evaluate(df, screen: Screen | None):
    """(applied checks, their values, their failure masks among the ok rows, ok mask): the one place
    the screen's checks are evaluated, for both the frame's columns and the counts."""
    from ._rank import ok_mask

    screen = screen if screen is not None else Screen()
    applied = [c for c in CHECKS if all(col in df.columns for col in c.inputs)]
    ok = ok_mask(df)
    values, fails = [], []
    for c in applied:
        v = c.value(df)
        with np.errstate(invalid="ignore"):
            fails.append(c.fails(v, getattr(screen, c.field)) & ok)
        values.append(v)
    return applied, values, fails, ok


def screen_columns(df, screen: Screen | None = None):
    """(buildable, reasons, applied) for a results frame, or None if it stores no screened metric.

    buildable : (n,) bool, ok and passing every applied check; reasons : (n,) object array of "pass",
    the failing checks' reasons joined by "; ", or "failed (STATUS)"; applied : the names of the
    checks whose metric the frame holds.
    """
    screen = screen if screen is not None else Screen()
    applied, values, fails, ok = _evaluate(df, screen)
    if not applied:
        return None
    n = len(df)
    bad = np.zeros(n, dtype=bool)
    for f in fails:
        bad |= f
    reasons = np.full(n, "pass", dtype=object)
    status = df["status"].astype(str).to_numpy() if "status" in df.columns else None
    for i in np.flatnonzero(~ok):
        reasons[i] = f"failed ({status[i]})" if status is not None else "failed"
    for i in np.flatnonzero(bad):
        parts = []
        for c, v, f in zip(applied, values, fails):
            if f[i]:
                parts.append(f"{c.name}: {c.inputs[0]} is undefined" if not math.isfinite(v[i])
                             else c.reason(float(v[i]), getattr(screen, c.field)))
        reasons[i] = "; ".join(parts)
    return ok & ~bad, reasons, [c.name for c in applied]


def screen_counts(df, screen: Screen | None = None) -> dict:
    """How many ok variants of a results frame the screen removes, in total and per check.

    Returns {"removed": n, "checks": {check name: n failing it (a variant may fail several)},
    "applied": [checks whose metric the frame holds]}; "removed" is 0 and "applied" empty when the
    frame stores no metric the screen reads.
    """
    applied, _, fails, ok = _evaluate(df, screen)
    removed = np.zeros(len(df), dtype=bool)
    for f in fails:
        removed |= f
    return {"removed": int(removed.sum()), "checks": {c.name: int(f.sum()) for c, f in zip(applied, fails)},
            "applied": [c.name for c in applied]}


def screen_margins(df, screen: Screen | None = None):
    """Each design's tightest margin of the buildability screen: (margin, check, value, limit), each (n,).

    margin : the smallest of the checks' margins (a fraction, positive inside the limit: the module
    docstring says how each is measured), NaN where no check with a margin applies or a design's inputs
    are undefined; check : that check's name (object array, "" where margin is NaN); value, limit : its
    value and threshold (degrees, model units or crank radii per radian, as the check reads them).
    """
    screen = screen if screen is not None else Screen()
    n = len(df)
    margin, value, limit = np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan)
    check = np.full(n, "", dtype=object)
    for c in CHECKS:
        if c.margin is None or not all(col in df.columns for col in c.inputs):
            continue
        t = getattr(screen, c.field)
        v = c.value(df)
        with np.errstate(invalid="ignore", divide="ignore"):
            m = np.asarray(c.margin(v, t, df), dtype=np.float64)
        tighter = np.isfinite(m) & ~(m >= margin)   # NaN margin so far, or a smaller one
        margin[tighter], value[tighter], limit[tighter] = m[tighter], v[tighter], t
        check[tighter] = c.name
    return margin, check, value, limit
