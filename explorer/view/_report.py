"""An interactive report of a results file: one self-contained HTML page (``explorer report``).

The page holds plotly.js itself (inlined, ~4.8 MB; no CDN, it opens offline) and four linked views:

* **parallel coordinates** (plotly ``parcoords``) over the rank, the varied design parameters, every
  stored metric (in the order of :data:`explorer.gait.TABLE`, ↑ higher / ↓ lower is better), whether
  the design passes the buildability screen, and whether it is picked in the scatter;
* a **scatter** of any two metrics (two drop-downs; default travel against bob) with the **Pareto
  front** of the selected buildable designs in the metrics' own directions and the reference design
  (``vs``: the nominal, variant 0, unless another is named) starred;
* the **foot paths** of the best-ranked selected designs (at most ``shown`` at once, default 50) over
  the reference design's;
* the **best designs against the reference**: the best-ranked buildable designs with each score
  metric's value and change in % against the reference's, the reference last with its own place, the
  walker score of both and a verdict of design #1 (as ``explorer rank --change`` and ``explorer show``);
  the best selected designs' table (linked to the brushes) shows the change too, the reference last;
* the **screened-out and failed designs counted by reason** (a design can fail several screen
  checks: it counts under each), each reason viewable: its first designs' foot paths drawn in red
  and its variant numbers listed.

Brushing an axis of the parallel coordinates (its ``constraintrange``) selects the designs inside
every brushed range; a box or lasso selection in the scatter brushes the "scatter pick" axis, so
that both filter every view. The selected count is in the element ``#n-selected`` (``data-count``),
the designs in the views in ``#n-designs``, the front's size in ``#n-front``.

Size: the linked views hold every ok design (``status`` ok; failed ones have no metrics), one float32
column per axis (base64 in the page), in the order of ``explorer rank`` (the default score over the
buildable designs, then the screened-out ones by the same score). Above ``max_designs`` (default
100,000) a seeded uniform sample of them is shown, and the page says so with the numbers; the counts
by reason are always over every variant. The parallel coordinates draw at most ``pc_lines`` (default
10,000) of the designs, a seeded random sample (1,000 where the browser draws WebGL in software, without
a GPU; a menu on the page changes it); brushes, counts, the scatter and the front are over all of them.
Foot paths are downsampled to ``points`` (default 60) per path and stored for the ``paths`` (default
2,000) best-ranked designs, the nominal, and the first ``reason_paths`` (default 50) of each reason, as
16-bit integers over their common bounding box. 10,000 Jansen variants make a 7.3 MB page, 100,000 a
22 MB one (plotly.js itself is 4.8 MB of it).

Filter: ``where="bob < 0.2"`` (``explorer report --where``, the restricted grammar of ``explorer rank
--where``) keeps the ok designs the filter holds for in the views (rank = place among them; the sample
above ``max_designs`` is drawn from them); the page says the filter and how many it keeps.

Units: the file's model units, or with ``units="si"`` (``--units si``) lengths in mm, travel in m per turn,
a walking speed in m/s and torque in N·m at the study's ``[operating]`` point (:func:`explorer.gait.to_si`);
the ranking stays that of the stored values.

Open from a notebook: ``write_report(res, "report.html")`` then
``IPython.display.IFrame("report.html", width="100%", height=1100)``; or
:meth:`Report.iframe`.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._memory import release
from ..errors import UserError
from ..gait import (BY_NAME, CHECKS, DEFAULT_WEIGHTS, SCREEN_INPUTS, METRICS, SPEED, change_pct, operating_line, rank_order,
                    results_si, verdict)

#: Above this many ok designs the linked views show a seeded uniform sample of them.
DEFAULT_MAX_DESIGNS = 100_000
#: Foot paths stored for this many best-ranked designs.
DEFAULT_PATHS = 2_000
#: The parallel coordinates draw at most this many designs (a seeded sample; brushes count every design).
DEFAULT_PC_LINES = 10_000
#: ... and this many where the browser renders WebGL in software (no GPU: SwiftShader, llvmpipe), where
#: every line costs milliseconds; the page offers the other counts.
PC_LINES_SOFTWARE = 1_000
#: Selected designs whose foot paths are drawn at once.
DEFAULT_SHOWN = 50
#: Samples kept per stored foot path (evenly spaced in crank angle).
DEFAULT_POINTS = 60
#: Foot paths stored per reason (screened-out check, failure status): its lowest variant numbers.
DEFAULT_REASON_PATHS = 50
#: Variant numbers listed per reason.
REASON_LIST = 500
#: Best-ranked buildable designs in the table against the reference design.
VS_ROWS = 10

_STATUS_TEXT = {
    "assembly": "cannot assemble at some crank angle (or time along its path)",
    "branch": "left its branch (a toggle crossed, or the mirror assembly)",
    "no-convergence": "Newton did not converge, or a step could not be resolved",
    "invalid": "a non-finite or non-positive length",
    "not-run": "not run yet (an interrupted run: finish it with explorer run --resume)",
}
_CHECK_TEXT = {
    "toggle": "a crank-driven four-bar loop comes within min_transmission_angle of toggle",
    "foot above the frame": "the foot rises above the crank axle or a ground pivot",
    "foot whip": "peak foot speed above max_foot_speed crank radii per radian",
    "crossing path": "the foot path crosses itself",
}
_UNIT_TEXT = {"length": "model units", "length/turn": "model units per crank turn", "length/rad": "model units/rad",
              "1": "ratio", "1 (length/length)": "ratio", "1 (per W·crank)": "per weight × crank radius"}


@dataclass
class Report:
    """What :func:`write_report` wrote (or :func:`report_html` built).

    path : the file (None for :func:`report_html`); bytes : its size; n_variants : every variant of
    the results; n_ok : the ok ones; n_designs : the designs in the linked views (n_kept, or the sample);
    sampled : whether they are a sample; n_paths : designs whose foot paths the page holds;
    parameters, metrics : the axes; counts : {reason: number of variants} (the table of the page:
    "ok, buildable", "screened out (any check)", "screened out: CHECK" …, "failed: STATUS" …, over every
    variant); where : the filter the views were chosen with (None: every ok design); n_kept : the ok
    designs it keeps (n_ok without a filter).
    """

    path: Path | None
    bytes: int
    n_variants: int
    n_ok: int
    n_designs: int
    sampled: bool
    n_paths: int
    parameters: list = field(default_factory=list)
    metrics: list = field(default_factory=list)
    counts: dict = field(default_factory=dict)
    where: str | None = None
    n_kept: int = -1

    def __post_init__(self):
        if self.n_kept < 0:
            self.n_kept = self.n_ok

    def iframe(self, width="100%", height: int = 1100):
        """The written page in a notebook cell (``IPython.display.IFrame``; the file must be reachable
        from the notebook's folder, as a relative path is)."""
        if self.path is None:
            raise UserError("report: nothing written; call write_report(results, PATH) first")
        try:
            from IPython.display import IFrame
        except ImportError:
            raise UserError("report: Report.iframe needs IPython (a notebook); open the file in a browser "
                            "instead") from None
        p = Path(os.path.relpath(self.path)) if self.path.is_absolute() else self.path
        return IFrame(str(p), width=width, height=height)


# -- the data ----------------------------------------------------------------------------------------
@dataclass
class _Scan:
    """What the report needs of every variant, gathered in one pass over the frame in blocks of rows
    (:func:`_scan`). ok : (n_ok,) int64, the ok variants in variant order; finite : {metric: whether any ok
    variant has a finite value}; kept : (N,) bool, the variants ``where`` keeps (None without a filter);
    ranked : {"buildable", "screened"}: the ok variants that pass the buildability screen and those it
    removes, each ((n,) int64 variant numbers in variant order, a frame of the default score's metrics of
    those rows, indexed 0 … n − 1, or None where not every one of them is stored); counts : {reason: variants} in :func:`reason_masks`' order;
    first : {reason: its first ``listed`` variant numbers}."""

    n_ok: int
    ok: np.ndarray
    finite: dict
    kept: np.ndarray | None
    ranked: dict
    counts: dict
    first: dict


def _scan(res, head, stored, where, by_score: bool, listed: int = REASON_LIST) -> _Scan:
    """One pass over ``res``'s frame in blocks of rows (``Results.frame_blocks``): the ok variants, which
    metrics any ok variant has a finite value of, the filter ``where``, the rows the ranking ranks (only its
    columns) and the counts by reason (:func:`reason_masks` of each block, added; each reason's first
    variants kept). ``head``: some rows of the frame, typed whole (its columns)."""
    import pandas as pd

    from ..gait import evaluate_filter, ok_mask
    N = int(res.n_variants)
    screen = res.screen
    cols = ["variant", *DEFAULT_WEIGHTS] if by_score else ["variant"]
    # the ok rows' ranked columns, written in place: the buildable rows from the front, the screened-out
    # ones from the back (no list of blocks joined afterwards: the memory of these columns, once)
    n_ok = int(res.status_counts().get("ok", 0))
    held = {c: np.empty(n_ok, dtype=head[c].dtype if c in head.columns else np.float64) for c in cols}
    ok_v = np.empty(n_ok, dtype=np.int64)
    lo, hi, filled = 0, n_ok, 0  # held[:lo]: buildable (lo counts up); held[hi:]: screened out (hi counts down)
    finite = dict.fromkeys(stored, False)
    kept = np.zeros(N, dtype=bool) if where is not None else None
    counts = {k: 0 for k in reason_masks(head.iloc[:0], screen)}  # the reasons every frame lists, first
    first: dict = {}
    for df in res.frame_blocks():
        ok = ok_mask(df)
        variants = df["variant"].to_numpy(dtype=np.int64)
        k = int(ok.sum())
        if filled + k > n_ok:
            raise RuntimeError(f"{res.filename}: more ok rows in the frame than ok status codes ({n_ok:,})")
        ok_v[filled:filled + k] = variants[ok]
        filled += k
        for m in stored:
            if not finite[m]:
                finite[m] = bool(np.isfinite(df[m].to_numpy(dtype=np.float64)[ok]).any())
        if kept is not None:
            kept[variants] = evaluate_filter(df, where)
        for key, mask in reason_masks(df, screen).items():
            counts[key] = counts.get(key, 0) + int(mask.sum())
            got = first.setdefault(key, [])
            if len(got) < listed:
                got.extend(int(v) for v in variants[mask][:listed - len(got)])
        b = df["buildable"].to_numpy(dtype=bool) if "buildable" in df.columns else np.ones(len(df), dtype=bool)
        kb, ks = int((ok & b).sum()), int((ok & ~b).sum())
        for c in cols:
            x = df[c].to_numpy()
            held[c][lo:lo + kb] = x[ok & b]
            held[c][hi - ks:hi] = x[ok & ~b]
        lo, hi = lo + kb, hi - ks
        del df
    if filled != n_ok:
        raise RuntimeError(f"{res.filename}: {filled:,} ok rows in the frame, {n_ok:,} ok status codes")
    # the screen's checks in their own order (a check first met in a later block too), then the failures
    # in the order the variants first meet them, as reason_masks lists them for the whole frame
    checks = [f"screened out: {c.name}" for c in CHECKS]
    base = [k for k in ("ok, buildable", "screened out (any check)") if k in counts]
    keys = base + [k for k in checks if k in counts] + [k for k in counts if k not in base and k not in checks]
    counts = {k: counts[k] for k in keys}
    back = np.argsort(held["variant"][hi:], kind="stable")  # the screened-out blocks came in back to front
    ranked = {}
    for k, part in (("buildable", slice(0, lo)), ("screened", slice(hi, n_ok))):
        joined = {c: (v[part] if k == "buildable" else v[part][back]) for c, v in held.items()}
        # the ranked metrics without the variant numbers: rank() breaks ties by row, here in variant order too
        ranked[k] = (joined.pop("variant"), pd.DataFrame(joined, copy=False) if by_score else None)
    del held, joined
    return _Scan(n_ok=n_ok, ok=ok_v, finite=finite, kept=kept, ranked=ranked, counts=counts,
                 first={k: first.get(k, []) for k in counts})


def _ranked_ok(scan: _Scan, by_score: bool):
    """(the ok variants in report order: the buildable ones as ``explorer rank`` orders them (default
    score), then the screened-out ones by the same score (over them), then whatever the ranking leaves out,
    by variant; the ranking of the buildable ones: (variants, their scores, their places) in rank order).
    Where the default score's metrics are not all stored: every ok variant by variant, and the buildable
    ones by variant (no scores)."""
    ok = scan.ok
    if not by_score:
        b = scan.ranked["buildable"][0]
        return ok, (b, np.full(len(b), np.nan), np.arange(1, len(b) + 1))
    variants, frame = scan.ranked.pop("buildable")  # the ok rows that pass the screen: rank()'s own filter
    at, score = rank_order(frame)  # rank(frame, top=None) without its rows: positions (the frame's index)
    del frame
    ranked = (variants[at], score, np.arange(1, len(at) + 1))
    pos = ranked[0]
    variants, screened = scan.ranked.pop("screened")
    if len(screened):
        pos = np.r_[pos, variants[rank_order(screened)[0]]]
    del screened
    rest = np.setdiff1d(ok, pos)  # whatever rank() leaves out (it ranks NaN scores last) comes last, by variant
    return np.r_[pos, rest].astype(np.int64), ranked


def _best(ranked, ref: int):
    """What the table against the reference needs of the buildable designs' ranking ``ranked`` (variants,
    scores, places in rank order: :func:`_ranked_ok`): (the first :data:`VS_ROWS` variants, their scores,
    their places; how many are ranked; the reference's (place, score), None where it is not ranked)."""
    pos, score, places = ranked
    at = np.flatnonzero(pos == ref)
    return (pos[:VS_ROWS].copy(), score[:VS_ROWS].copy(), places[:VS_ROWS].copy(), len(pos),
            (int(places[at[0]]), float(score[at[0]])) if len(at) else None)


def reason_masks(df, screen) -> dict:
    """{reason: (n,) bool} over the rows of a results frame: "ok, buildable", "screened out (any
    check)", "screened out: CHECK" per applied check of the buildability screen (a row may fail
    several), "failed: STATUS" per failure status, "not run yet" (an interrupted run). Only reasons
    with at least one row are listed, except "ok, buildable"."""
    from ..gait import ok_mask
    ok = ok_mask(df)
    out = {}
    checks = {}
    for c in CHECKS:
        if all(col in df.columns for col in c.inputs):
            with np.errstate(invalid="ignore", divide="ignore"):
                checks[c.name] = np.asarray(c.fails(c.value(df), getattr(screen, c.field)), dtype=bool) & ok
    anyfail = np.zeros(len(df), dtype=bool)
    for m in checks.values():
        anyfail |= m
    out["ok, buildable"] = ok & ~anyfail
    if checks:
        out["screened out (any check)"] = anyfail
        for name, m in checks.items():
            if m.any():
                out[f"screened out: {name}"] = m
    status = df["status"].astype(str).to_numpy()
    for s in dict.fromkeys(status[~ok]):
        out["not run yet" if s == "not-run" else f"failed: {s}"] = status == s
    return out


def _f32(a) -> np.ndarray:
    return np.asarray(a, dtype=np.float64).astype(np.float32)


def _b64(a: np.ndarray) -> str:
    """Base64 of ``a``'s little-endian bytes (no copy of a contiguous little-endian array)."""
    a = np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<"), copy=False)
    return base64.b64encode(a.reshape(-1).view(np.uint8)).decode("ascii")


def read_foot_paths(res, variants, points: int = DEFAULT_POINTS, vertex: str | None = None) -> np.ndarray:
    """Foot paths of ``variants`` (any order), downsampled to ``points`` evenly spaced samples:
    (len(variants), points, 2) float64, model units (NaN where a failed variant has no position).

    Reads the file chunk by chunk (each HDF5 chunk at most once), so scattered variants of a large
    file cost one pass over the chunks that hold them."""
    variants = np.asarray(variants, dtype=np.int64).reshape(-1)
    vname = vertex if vertex is not None else (res.mechanism.foot if res.mechanism.foot in res.vertices
                                               else res.vertices[0])
    lean = getattr(res, "lean", False)  # a lean file: the paths are re-solved, not read
    ds = None if lean else res.file["paths"][vname]
    S = int(res.steps) if lean else ds.shape[1]
    if res.mechanism.crank is not None:  # a turn: evenly spaced, the last sample comes back to the first
        keep = np.unique(np.round(np.linspace(0, S, min(points, S), endpoint=False)).astype(np.int64) % S)
    else:  # a path driver's samples run from its start to its end: keep both
        keep = np.unique(np.round(np.linspace(0, S - 1, min(points, S))).astype(np.int64))
    out = np.full((len(variants), len(keep), 2), np.nan)
    if not len(variants):
        return out
    if lean:  # re-solved once, not kept: the page holds the downsampled paths
        with res.read_once():
            return np.asarray(res.path(variants, vname), dtype=np.float64)[:, keep]
    rows = ds.chunks[0] if ds.chunks else 4096
    order = np.argsort(variants, kind="stable")
    sv = variants[order]
    starts = (sv // rows) * rows
    for a in np.unique(starts):
        sel = np.flatnonzero(starts == a)
        block = ds[a:min(a + rows, ds.shape[0])]
        out[order[sel]] = block[sv[sel] - a][:, keep]
    return out


def _quantize(paths: np.ndarray):
    """(uint16 array, [x0, y0, sx, sy]): x = x0 + q·sx, y = y0 + q·sy; 65535 = no position."""
    finite = np.isfinite(paths)
    if not finite.any():
        return np.full(paths.shape, 65535, dtype=np.uint16), [0.0, 0.0, 1.0, 1.0]
    lo = np.array([np.nanmin(paths[..., 0]), np.nanmin(paths[..., 1])])
    hi = np.array([np.nanmax(paths[..., 0]), np.nanmax(paths[..., 1])])
    step = np.maximum(hi - lo, 1e-12) / 65534.0
    with np.errstate(invalid="ignore"):
        q = np.round((paths - lo) / step)
    q = np.where(np.isfinite(q), q, 65535).astype(np.uint16)
    return q, [float(lo[0]), float(lo[1]), float(step[0]), float(step[1])]


def _unit_text(unit: str) -> str:
    return _UNIT_TEXT.get(unit, unit)


def _axis_label(m: str) -> str:
    meta = BY_NAME.get(m)
    if meta is None:
        return m
    arrow = {"max": " ↑", "min": " ↓"}.get(meta.direction, "")
    return f"{m}{arrow}"


def _title_label(m: str) -> str:
    meta = BY_NAME.get(m)
    if meta is None:
        return m
    better = {"max": "higher is better", "min": "lower is better"}[meta.direction]
    return f"{m} [{_unit_text(meta.unit)}], {better}"


#: Least width (px) of one axis of the parallel coordinates: room for its end labels (the page scrolls sideways
#: when the window is narrower than the axes need).
PC_AXIS_WIDTH = 34
#: An axis of the parallel coordinates spans the buildable designs when the screened-out ones reach
#: further than this many times the buildable designs' span beyond it (a near-toggle design's forces).
OFF_SCALE = 0.5


def axis_scale(values, buildable):
    """The range of one metric's axis, or None to let it span every value: {"range": [lo, hi] (the buildable
    designs' range, 2 % of its span added at each end), "off": the designs beyond it, "far": the farthest
    value} when some design lies more than :data:`OFF_SCALE` × that span beyond the buildable range."""
    v = np.asarray(values, dtype=np.float64)
    finite = np.isfinite(v)
    b = v[finite & np.asarray(buildable, dtype=bool)]
    if b.size == 0 or not finite.any():
        return None
    lo, hi = float(b.min()), float(b.max())
    span = hi - lo
    if not span > 0:  # one value among the buildable designs (a count such as self_crossings): no range
        return None
    allv = v[finite]
    if allv.min() >= lo - OFF_SCALE * span and allv.max() <= hi + OFF_SCALE * span:
        return None
    # float32-exact ends: the page holds float32 values and pins the others at exactly these ends
    lo, hi = float(np.float32(lo - 0.02 * span)), float(np.float32(hi + 0.02 * span))
    off = allv[(allv < lo) | (allv > hi)]
    far = float(off[np.argmax(np.abs(off - (lo + hi) / 2))])
    return {"range": [lo, hi], "off": int(off.size), "far": far}


def _range_format(values) -> str:
    """A d3 format for an axis' ticks and end labels, short enough that neighbouring axes' end labels do
    not run into each other: three significant digits, SI prefixes (k, M) from 10,000 up."""
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return ".3~g"
    big, span = float(np.abs(v).max()), float(v.max() - v.min())
    # enough digits that the ticks of a narrow range stay apart (11.68 … 11.75 kg: 5), at most 6
    digits = 3 if span <= 0 or big <= 0 else min(6, max(3, math.ceil(math.log10(big / span)) + 2))
    if big < 1e-2 and digits == 3:
        return ".2~e"  # 1.2e-5, not 0.000012
    return ".3~s" if big >= 1e4 and digits == 3 else f".{digits}~g"


def _check_count(name, value, minimum) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise UserError(f"report: {name}: expected a whole number >= {minimum}, got {value!r}")
    return int(value)


def build_report(res, *, metrics=None, max_designs: int = DEFAULT_MAX_DESIGNS, paths: int = DEFAULT_PATHS,
                 shown: int = DEFAULT_SHOWN, points: int = DEFAULT_POINTS, reason_paths: int = DEFAULT_REASON_PATHS,
                 seed: int = 0, x: str | None = None, y: str | None = None, title: str | None = None,
                 pc_lines: int = DEFAULT_PC_LINES, vs: int = 0, units: str = "model", where: str | None = None):
    """(the page, a :class:`_Page` (``.text()``: the HTML; ``.write(path)``), :class:`Report` with path None) of an
    open results file; see :func:`write_report`."""
    from .._extras import require
    require("plotly", "explorer report")
    import plotly.graph_objects as go
    import plotly.io as pio
    from plotly.offline import get_plotlyjs

    from .. import __version__
    from ..gait import evaluate_filter, ok_mask

    where = str(where).strip() if where is not None and str(where).strip() else None
    max_designs = _check_count("max_designs", max_designs, 1)
    paths = _check_count("paths", paths, 0)
    shown = _check_count("shown", shown, 0)
    points = _check_count("points", points, 3)
    reason_paths = _check_count("reason_paths", reason_paths, 0)
    pc_lines = _check_count("pc_lines", pc_lines, 1)
    head = res.frame_rows([0] if res.n_variants else [])  # the frame's columns (the nominal's row), typed whole
    N = int(res.n_variants)
    mech = res.mechanism
    ref = res.check_variant(vs)
    ref_label = "nominal" if ref == 0 else f"reference (variant {ref})"
    si = results_si(res, head.iloc[:0], units)  # --units si: every figure shown in SI; the ranking stays the stored values'
    params = [p for p in res.perturbed if p in head.columns]
    stored = [m for m in METRICS if m in head.columns] + [m for m in res.metric_names
                                                            if m not in METRICS and m in head.columns]
    if metrics is not None:
        names = [s.strip() for s in metrics.split(",") if s.strip()] if isinstance(metrics, str) else list(metrics)
        unknown = [m for m in names if m not in stored]
        if unknown:
            raise UserError(f"{res.filename}: metric {unknown[0]!r} is not stored "
                            f"(stored: {', '.join(stored) or 'none'})")
        stored = list(dict.fromkeys(names))
    if where is not None:
        evaluate_filter(head, where)  # a bad filter fails before any block is read
    by_score = all(m in head.columns for m in DEFAULT_WEIGHTS)
    scan = _scan(res, head, stored, where, by_score, max(REASON_LIST, reason_paths))
    n_ok = scan.n_ok
    dropped = [m for m in stored if not scan.finite[m]]
    # the physics check covers a shortlist (NaN elsewhere): its own panel, not axes every line would leave
    physics = [m for m in stored if m not in dropped and BY_NAME.get(m) is not None and BY_NAME[m].group == "physics"]
    mets = [m for m in stored if m not in dropped and m not in physics]
    if si is not None and SPEED in si.units and "travel" in mets:  # the walking speed follows travel
        mets.insert(mets.index("travel") + 1, SPEED)

    def unit_of(key) -> str:
        """The unit the page shows ``key`` in."""
        if si is not None and key in si.converted:
            return si.units[key]
        meta = BY_NAME.get(key)
        return _unit_text(meta.unit) if meta else "model units"

    order, ranked = _ranked_ok(scan, by_score)
    best = _best(ranked, ref)
    del ranked
    scan.ok = scan.ranked = None  # what the rest needs of the pass: the counts, the first variants, the filter
    release()  # the ranked columns' memory, back to the system before the views' rows are read
    if where is not None:  # the views hold the ok designs the filter keeps, in the same order
        order = order[scan.kept[order]]
    n_kept = len(order)
    if n_kept == 0 and where is not None:
        raise UserError(f"{res.filename}: --where {where!r} keeps none of the {n_ok:,} ok designs: nothing to show")
    sampled = n_kept > max_designs
    if sampled:
        rng = np.random.default_rng(seed)
        pick = np.sort(rng.choice(n_kept, size=max_designs, replace=False))
        order = order[pick]
    n = len(order)
    # -- foot paths: read first, while little else is held (a lean file re-solves them) ------------------------
    counts = scan.counts
    has_paths = bool(res.vertices)
    n_paths = min(paths, n) if has_paths else 0
    path_variants = [int(v) for v in order[:n_paths]]
    nominal_path = None
    reasons = []
    for key, count in counts.items():
        if key == "ok, buildable":
            continue
        vs = scan.first[key]
        kind, _, what = key.partition(": ")
        text = (_CHECK_TEXT.get(what, "") if kind == "screened out" else
                _STATUS_TEXT.get(what, "") if kind == "failed" else
                _STATUS_TEXT["not-run"] if key == "not run yet" else
                "fails at least one check of the buildability screen (each is counted below)")
        entry = {"key": key, "count": count, "text": text, "variants": [int(v) for v in vs[:REASON_LIST]],
                 "paths": [], "path_variants": []}
        if has_paths:
            take = [int(v) for v in vs[:reason_paths]]
            entry["paths"] = list(range(len(path_variants), len(path_variants) + len(take)))
            entry["path_variants"] = take
            path_variants += take
        reasons.append(entry)
    if has_paths:
        nominal_path = len(path_variants)
        path_variants.append(ref)
    vname = None
    blob, path_scale, npts = "", [0.0, 0.0, 1.0, 1.0], 0
    if has_paths:
        vname = mech.foot if mech.foot in res.vertices else res.vertices[0]
        P = read_foot_paths(res, path_variants, points, vname)
        if si is not None:
            P = P * (si.operating.unit * 1000.0)  # mm
        npts = P.shape[1]
        q, path_scale = _quantize(P)
        blob = _b64(q)
    release()  # what re-solving the paths let go of
    # the rows in the views, only the columns they show (order: variant numbers, the frame's positions)
    wanted = ["variant", "generation", *params, *(m for m in mets if m != SPEED), "buildable"]
    wanted += ["crank"] if si is not None else []
    by_variant = np.sort(order)  # read in variant order (no copy to put them in view order), then taken column by column
    rows = res.frame_rows(by_variant, columns=[c for c in dict.fromkeys(wanted) if c in head.columns])
    release()
    at = np.searchsorted(by_variant, order)  # a column's values [at]: in view order
    del by_variant

    def in_units(variants):
        """The frame rows of ``variants`` in the units shown."""
        got = res.frame_rows(variants)
        return got if si is None else si.apply(got).frame

    shown_rows = rows if si is None else si.apply(rows).frame  # the same rows in the units shown
    ref_row = res.frame_rows([ref])
    ref_shown = ref_row if si is None else si.apply(ref_row).frame
    variant = order
    buildable = rows["buildable"].to_numpy(dtype=bool)[at] if "buildable" in rows.columns else np.ones(n, dtype=bool)
    rank_col = (pick + 1) if sampled else np.arange(1, n + 1)  # place among every ok design

    # -- x, y of the scatter -----------------------------------------------------------------------------
    def _pair():
        if len(mets) < 2:
            return None, None
        a = x if x is not None else ("travel" if "travel" in mets else mets[0])
        b = y if y is not None else ("bob" if "bob" in mets and a != "bob" else next(m for m in mets if m != a))
        for m in (a, b):
            if m not in mets:
                raise UserError(f"{res.filename}: scatter metric {m!r} is not among the report's metrics "
                                f"({', '.join(mets) or 'none'})")
        if a == b:
            raise UserError(f"report: name two different metrics for the scatter, got {a!r} twice")
        return a, b

    sx, sy = _pair()

    # -- the table of the views: one float32 column per axis, rows in rank order --------------------------
    columns = []
    # the axes: rank, generation (an optimisation's), the parameters, the metrics, buildable and scatter pick
    table = np.empty((3 + ("generation" in rows.columns) + len(params) + len(mets), n), dtype=np.float32)
    dims = []

    ref_ok = bool(ok_mask(ref_row)[0])

    def add(key, label, kind, values, unit="", description="", direction=None, **extra):
        table[len(dims)] = _f32(values)
        dims.append(dict(label=label, values=[], **extra))
        meta = BY_NAME.get(key)
        r0 = float(ref_shown[key].iloc[0]) if key in ref_shown.columns and kind in ("parameter", "metric") else math.nan
        columns.append({"key": key, "label": label, "kind": kind, "dim": len(dims) - 1,
                        "unit": unit_of(key) if meta or kind == "parameter" else unit,
                        "direction": meta.direction if meta else direction,
                        "description": meta.description if meta else description,
                        "reference": r0 if math.isfinite(r0) and (ref_ok or kind == "parameter") else None})

    add("rank", "rank", "rank", rank_col, description="place in the ranking (1 = best; see above)")
    if "generation" in rows.columns:  # an optimisation (explorer optimize): when each design was tried
        add("generation", "generation", "generation", rows["generation"].to_numpy(dtype=np.float64)[at],
            description="the generation of the optimisation that tried the design (0 = the first)")
    for p in params:
        kind = mech.parameter_kind(p)
        vals = shown_rows[p].to_numpy(dtype=np.float64)[at]
        add(p, p, "parameter", vals, tickformat=_range_format(vals),
            description=("crank radius" if p == "crank" else f"length of link {p}" if kind == "length"
                         else f"coordinate {p}"))
    off_scale = []  # (metric, designs beyond the buildable range, the farthest value): the page says so
    for m in mets:
        vals = shown_rows[m].to_numpy(dtype=np.float64)[at]
        # the screen's own inputs keep their whole span: it shows why designs were screened out
        scale = None if m in SCREEN_INPUTS else axis_scale(vals, buildable)
        extra = dict(tickformat=_range_format(vals if scale is None else np.asarray(scale["range"])))
        if scale is not None:
            extra["range"] = scale["range"]
        if m == SPEED:
            add(m, f"{m} ↑", "metric", vals, unit="m/s", direction="max",
                description=f"walking speed at {si.operating.rpm:g} rpm: travel per turn × rpm / 60", **extra)
        else:
            add(m, _axis_label(m), "metric", vals, **extra)
        if scale is not None:
            columns[-1]["clip"] = scale["range"]
            off_scale.append((m, scale["off"], scale["far"]))
    col_of = {c["key"]: c for c in columns}

    def axis_title(m) -> str:
        c = col_of[m]
        return f"{m} [{c['unit']}], {'higher' if c['direction'] == 'max' else 'lower'} is better"
    add("buildable", "buildable", "flag", buildable.astype(np.float64), range=[0, 1], tickvals=[0, 1],
        ticktext=["screened out", "yes"], description="passes the buildability screen (yes) or is screened out")
    add("pick", "scatter pick", "flag", np.ones(n), range=[0, 1], tickvals=[0, 1], ticktext=["out", "in"],
        description="inside the box or lasso drawn in the scatter (all in while none is drawn)")
    del rows, shown_rows, at  # the views' rows live on in the table alone
    release()
    # the parallel coordinates draw at most pc_lines designs: the first of a seeded random order of the rows
    # (any prefix of it is a uniform sample: the page may draw fewer); brushes count every design
    pc_order = np.random.default_rng(seed + 1).permutation(n)[:pc_lines].astype(np.int32)
    pc = go.Figure(go.Parcoords(
        dimensions=dims, labelangle=-40, labelside="top", labelfont=dict(size=12), tickfont=dict(size=10),
        rangefont=dict(size=8),
        line=dict(color=[], colorscale=[[0.0, "#08306b"], [0.35, "#2171b5"], [0.7, "#9ecae1"], [1.0, "#dde8f3"]],
                  showscale=True,
                  cmin=1, cmax=max(float(rank_col.max()) if n else 1.0, 2.0),
                  colorbar=dict(title=dict(text="rank", side="right"), thickness=12, len=0.9))))
    pc.update_layout(margin=dict(l=60, r=40, t=150, b=30), height=520, font=dict(size=12), paper_bgcolor="white")

    # -- scatter (its points are filled in by the page's script from the table) ------------------------------
    # the reference design (the nominal unless vs): its star in the scatter, its row in the tables
    nominal_values = {m: col_of[m]["reference"] for m in mets}
    sc = go.Figure()
    keep = dict(marker=dict(opacity=1.0))  # a box drawn in the scatter dims only the all-designs layer
    if sx is not None:
        sc.add_trace(go.Scattergl(x=[], y=[], mode="markers", name=f"every design in the page ({n:,})",
                                  marker=dict(size=4, color="#d4d4d4"), hoverinfo="skip",
                                  unselected=dict(marker=dict(opacity=1.0)),
                                  selected=dict(marker=dict(color="#9a9a9a"))))
        sc.add_trace(go.Scattergl(x=[], y=[], mode="markers", name="selected, screened out",
                                  marker=dict(size=5, color="#9467bd", opacity=0.5), customdata=[], unselected=keep,
                                  hovertemplate="variant %{customdata} (screened out)<br>%{x:.4g}, %{y:.4g}"
                                                "<extra></extra>"))
        sc.add_trace(go.Scattergl(x=[], y=[], mode="markers", name="selected, buildable",
                                  marker=dict(size=5, color="#1f77b4", opacity=0.6), customdata=[], unselected=keep,
                                  hovertemplate="variant %{customdata}<br>%{x:.4g}, %{y:.4g}<extra></extra>"))
        sc.add_trace(go.Scatter(x=[], y=[], mode="lines+markers", name="Pareto front of the selected buildable",
                                line=dict(color="#ff7f0e", width=2), marker=dict(size=7, color="#ff7f0e"),
                                customdata=[], unselected=keep, hovertemplate="front: variant %{customdata}<br>%{x:.4g}, %{y:.4g}"
                                                             "<extra></extra>"))
        sc.add_trace(go.Scatter(x=[], y=[], mode="markers", name=f"{ref_label}" + (" (variant 0)" if ref == 0 else ""),
                                unselected=keep, hovertemplate=f"{ref_label}<br>%{{x:.4g}}, %{{y:.4g}}<extra></extra>",
                                marker=dict(symbol="star", size=16, color="#d62728", line=dict(color="black", width=1))))
        sc.update_layout(xaxis_title=axis_title(sx), yaxis_title=axis_title(sy))
    sc.update_layout(dragmode="select", height=520, margin=dict(l=70, r=20, t=30, b=60), font=dict(size=13),
                     legend=dict(orientation="h", yanchor="bottom", y=1.0, x=0, font=dict(size=11)),
                     plot_bgcolor="white", paper_bgcolor="white", hovermode="closest")
    sc.update_xaxes(showgrid=True, gridcolor="#e5e5e5", zeroline=False, linecolor="#444", mirror=True)
    sc.update_yaxes(showgrid=True, gridcolor="#e5e5e5", zeroline=False, linecolor="#444", mirror=True)

    # -- the foot paths' figure (their data: read above) ------------------------------------------------------
    nom_xy = P[nominal_path] if has_paths else np.zeros((0, 2))
    loop = has_paths and mech.crank is not None and np.isfinite(nom_xy).all()  # a path driver's path is no loop
    closed = np.vstack([nom_xy, nom_xy[:1]]) if loop else nom_xy
    fp = go.Figure()
    fp.add_trace(go.Scatter(x=closed[:, 0], y=closed[:, 1], mode="lines",
                            name=f"{ref_label}" + (" (variant 0)" if ref == 0 else ""),
                            line=dict(color="#555555", width=4), hoverinfo="name"))
    fp.add_trace(go.Scatter(x=[], y=[], mode="lines", name=f"selected: the best {shown} by rank",
                            line=dict(color="#1f77b4", width=1.2), opacity=0.75, customdata=[],
                            hovertemplate="variant %{customdata}<extra>selected</extra>"))
    fp.add_trace(go.Scatter(x=[], y=[], mode="lines", name="by reason (none chosen)",
                            line=dict(color="#d62728", width=1.2), opacity=0.8, customdata=[],
                            hovertemplate="variant %{customdata}<extra>reason</extra>"))
    unit = "model units" if si is None else "mm"
    fp.update_layout(height=500, margin=dict(l=70, r=20, t=30, b=60), font=dict(size=13),
                     legend=dict(orientation="h", yanchor="bottom", y=1.0, x=0, font=dict(size=11)),
                     plot_bgcolor="white", paper_bgcolor="white",
                     xaxis=dict(title=f"foot x [{unit}]", showgrid=True, gridcolor="#e5e5e5", zeroline=False,
                                linecolor="#444", mirror=True),
                     yaxis=dict(title=f"foot y [{unit}]", showgrid=True, gridcolor="#e5e5e5", zeroline=False,
                                linecolor="#444", mirror=True, scaleanchor="x", scaleratio=1))

    # -- the page's data ---------------------------------------------------------------------------------------
    study = res.study.get("study", {}) if isinstance(res.study, dict) else {}
    data = {
        "n_variants": N, "n_ok": n_ok, "n_kept": n_kept, "where": where, "n_designs": n, "sampled": bool(sampled), "seed": int(seed),
        "max_designs": max_designs, "columns": columns, "x": sx, "y": sy, "metrics": mets, "params": params,
        "by_score": by_score, "variant": _b64(variant.astype(np.int32)),
        "table": "",  # its base64 goes in as the page is written (_Page), never whole in memory
        "pc_order": _b64(pc_order), "pc_lines": min(pc_lines, n), "pc_lines_software": min(PC_LINES_SOFTWARE, n), "shown": shown, "n_paths": n_paths,
        "points": npts, "paths": blob, "scale": path_scale, "nominal_path": nominal_path, "reasons": reasons,
        "nominal": nominal_values, "foot": vname, "dropped": dropped, "closed": mech.crank is not None,
        "reference": {"variant": ref, "label": ref_label, "ok": ref_ok,
                      "place": (str(int(rank_col[np.flatnonzero(variant == ref)[0]])) if (variant == ref).any() else "-")}, "units": "si" if si is not None else "model",
    }
    figs = {"parcoords": pc, "scatter": sc, "feet": fp}
    fig_json = {k: pio.to_json(f, validate=False, engine="json") for k, f in figs.items()}

    name = str(study.get("name", Path(str(res.filename)).stem))
    page_title = title or f"{name}: explorer report"
    tables = _reason_table(reasons, counts, N)
    sample_note = ""
    if sampled:
        which = f"{n_kept:,} ok designs" + (" the filter keeps" if where is not None else "")
        sample_note = (f"<p class='warn' id='sample-note'>This study has {which}, more than the "
                       f"{max_designs:,} this page shows: the views hold a uniform random sample of {n:,} of them "
                       f"(seed {int(seed)}, in rank order; rank = place among all {n_kept:,}). The counts by reason "
                       f"below are over all {N:,} variants. Use <code>--max-designs</code> to change the cap, or "
                       f"<code>explorer rank --where</code> to narrow the study.</p>")
    where_note = ""
    if where is not None:
        where_note = (f"<p class='warn' id='where-note'>Filtered: the views hold the {n_kept:,} of the {n_ok:,} ok "
                      f"designs where <code>{html.escape(where)}</code> (<code>--where</code>; rank = place among "
                      f"them). The counts by reason are over all {N:,} variants.</p>")
    off_note = ""
    if off_scale:
        parts = ", ".join(f"{html.escape(m)} ({k:,} designs, up to {far:.4g} {html.escape(col_of[m]['unit'] or '')})"
                          .replace(" )", ")") for m, k, far in off_scale)
        off_note = ("<p class='note' id='off-scale-note'>Axes span the buildable designs; screened-out designs "
                    "far beyond them (near a toggle: forces that grow without bound) are drawn at the axis' end "
                    f"and counted by a brush that reaches it. Off scale: {parts}.</p>")
    dropped_note = (f"<p class='note'>Not shown (no finite value on any ok design): {html.escape(', '.join(dropped))}."
                    f"</p>" if dropped else "")
    order_note = ("rank: the order of <code>explorer rank</code> (the default score of "
                  + ", ".join(DEFAULT_WEIGHTS) + " over the buildable designs), the screened-out designs after them"
                  if by_score else "rank: variant order (the default score's metrics are not stored)")
    axes_rows = "".join(
        f"<tr data-key='{html.escape(c['key'], quote=True)}'><td>{html.escape(c['label'])}</td>"
        f"<td>{html.escape(c['unit'] or '')}</td>"
        f"<td class='num'>{'-' if c.get('reference') is None else format(c['reference'], '.6g')}</td>"
        f"<td>{ {'max': 'higher', 'min': 'lower'}.get(c['direction'], '')}</td>"
        f"<td>{html.escape(c['description'])}</td></tr>" for c in columns)
    keys = [m for m in DEFAULT_WEIGHTS if m in mets] or [m for m in mets if m != SPEED][:6]
    if SPEED in mets and "travel" in keys:
        keys.insert(keys.index("travel") + 1, SPEED)
    yield_note = ""
    if "yield" in mets and "yield" not in keys:  # will it survive the workshop: the stored yield, its settings
        keys.append("yield")
        from ..analysis import results_robustness
        rb = results_robustness(res)
        yield_note = (f"yield: the share of copies, {rb.describe()}, that turn and pass the buildability screen "
                      f"(binomial standard error √(p(1 − p)/{rb.copies}): ±{math.sqrt(0.25 / rb.copies):.3f} at "
                      f"most).")
    vs_section = _vs_section(best, in_units, ref, ref_label, ref_ok, keys, {k: col_of[k]["unit"] for k in keys},
                             by_score, None if si is None else {c: si.units[c] for c in si.converted}, yield_note)
    if physics:  # the designs `explorer physics` checked, beside their kinematic figures
        from ..physics._compare import report_panel
        vs_section += report_panel(res, res.frame_rows)
    units_note = ""
    if si is not None:
        units_note = "<p class='note' id='units-note'>" + html.escape(
            operating_line(si.operating) + ". Ranks, brushes' order and the default score are over the stored "
            "values (a torque's: per weight × crank radius). " + " ".join(f"{n}." for n in si.notes)) + "</p>"
    created = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    no_scatter = "" if sx is not None else "<p class='warn'>Fewer than two metrics stored: no scatter.</p>"
    no_paths = "" if has_paths else "<p class='warn'>This results file stores no paths: no foot paths to draw.</p>"
    options = "".join(f"<option value='{html.escape(m)}'>{html.escape(_axis_label(m))}</option>" for m in mets)
    fig_scripts = "\n".join(
        f"<script type='application/json' id='fig-{k}'>{_script_safe(v)}</script>" for k, v in fig_json.items())
    if len(dims) != len(table):
        raise RuntimeError(f"report: {len(dims)} axes for a table of {len(table)}")
    table = table.reshape(-1)  # column after column
    data_json = _script_safe(json.dumps(data))
    data = None
    page = _Page.of(_TEMPLATE, get_plotlyjs(), data_json, table, dict(
        title=html.escape(page_title), css=_CSS, js=_JS,
        heading=html.escape(f"{name} — {mech.name}"),
        meta=html.escape(f"{res.filename} · {N:,} variants × {res.steps} steps · {n_ok:,} ok · explorer {__version__} "
                         f"· {created}"),
        n_designs=n, n_designs_text=f"{n:,}", N=f"{N:,}",
        pool=(f"the ok ones: {n_ok:,} of {N:,} variants" if where is None else
              html.escape(f"the ok ones where {where}: {n_kept:,} of the {n_ok:,} ok, {N:,} variants")), sample_note=where_note + sample_note + dropped_note + units_note + off_note,
        order_note=order_note, options=options, reason_table=tables, axes_rows=axes_rows, no_scatter=no_scatter,
        no_paths=no_paths, n_paths=f"{n_paths:,}", shown=shown,
        figs=fig_scripts, results=html.escape(str(res.filename)), foot=html.escape(str(vname or "-")),
        vs_section=vs_section, ref_label=html.escape(ref_label), pc_width=PC_AXIS_WIDTH * len(dims) + 100,
        points=npts))
    data_json = table = None
    rep = Report(path=None, bytes=page.size(), n_variants=N, n_ok=n_ok, n_designs=n, sampled=sampled,
                 n_paths=n_paths, parameters=params, metrics=mets, counts=counts, where=where, n_kept=n_kept)
    return page, rep


def _vs_section(best, rows_of, ref: int, ref_label: str, ref_ok: bool, keys, units: dict, by_score: bool,
                verdict_units: dict | None = None, yield_note: str = "") -> str:
    """The table of the best-ranked buildable designs against the reference (as ``explorer rank --change``
    prints it): for each metric of ``keys`` its value (in the units shown) and the change against the
    reference's in %, the reference last, marked with its own place; then the walker score of both and a
    verdict of the best design against the reference (as ``explorer show``; its values followed by
    ``verdict_units``' unit where it names one). ``best``: the buildable designs' ranking as :func:`_best`
    keeps it; ``rows_of(variants)``: their frame rows in the units shown."""
    esc = html.escape
    pos, score, places, n_pool, ref_at = best
    if not keys:
        return ""
    top = [int(v) for v in pos]
    shown = rows_of(top + [ref])  # the rows of the table, the reference's last
    ref_row = shown.iloc[-1]
    r0 = {k: float(ref_row[k]) if ref_ok else math.nan for k in keys}
    head = ("<tr><th>rank</th><th>variant</th>" + ("<th class='num'>score</th>" if by_score else "")
            + "".join(f"<th class='num'>{esc(k)} [{esc(units.get(k) or '')}]</th><th class='num'>Δ %</th>"
                      for k in keys) + "</tr>")

    def cells(row) -> str:
        out = []
        for k in keys:
            x = float(row[k])
            d = change_pct(x, r0[k])
            out.append(f"<td class='num' data-key='{esc(k, quote=True)}' data-value='{x!r}' data-change='{d!r}'>"
                       f"{'-' if not math.isfinite(x) else format(x, '.5g')}</td>"
                       f"<td class='num'>{'-' if not math.isfinite(d) else format(d, '+.1f') + ' %'}</td>")
        return "".join(out)

    body = []
    for j, v in enumerate(top):
        sc = f"<td class='num'>{score[j]:.3f}</td>" if by_score else ""
        body.append(f"<tr class='vs' data-variant='{v}'><td>{int(places[j])}</td>"
                    f"<td>{v}</td>{sc}{cells(shown.iloc[j])}</tr>")
    place = f"{ref_at[0]}" if ref_at else "-"
    sc = (f"<td class='num'>{ref_at[1]:.3f}</td>" if ref_at else "<td class='num'>-</td>") if by_score else ""
    body.append(f"<tr class='ref' data-variant='{ref}' data-place='{place}'><td>{esc(ref_label)}: {place}</td>"
                f"<td>{ref}</td>{sc}{cells(ref_row)}</tr>")
    pool = f"{n_pool:,} buildable designs"
    lines = []
    if by_score:
        ref_score = (f"the {ref_label}'s walker score is {ref_at[1]:.3f}, rank {place} of {pool}" if ref_at
                     else f"the {ref_label} is not ranked (failed or screened out)")
        lines.append(f"Ranked by the walker score ({', '.join(DEFAULT_WEIGHTS)}; 1 = best); {ref_score}.")
    if n_pool and ref_ok and int(pos[0]) != ref:
        lines.append(f"Design #1 (variant {int(pos[0])}): "
                     + verdict(shown.iloc[0], ref_row, ref_label, keys, verdict_units) + ".")
    elif not ref_ok:
        lines.append(f"The {ref_label} failed: it has no metrics to compare with.")
    notes = "".join(f"<p class='note' id='{'vs-score' if t.startswith('Ranked') else 'vs-verdict'}'>{esc(t)}</p>"
                    for t in lines)
    if yield_note:
        notes += f"<p class='note' id='vs-yield'>{esc(yield_note)}</p>"
    return (f"<div class='panel' id='vs-panel'><h2>The best designs against the {esc(ref_label)}</h2>"
            f"<p class='note'>The {len(pos)} best-ranked of the {pool}, each metric with its change "
            f"against the {esc(ref_label)} in % of its value (Δ % = 100·(value − reference)/|reference|); the last row "
            f"is the {esc(ref_label)} with its place in the ranking. <code>explorer show RESULTS --variant V --vs {ref}</code> "
            f"compares one design metric by metric.</p><table id='vs'>{head}{''.join(body)}</table>{notes}</div>")


#: Characters of the page encoded at a time (a 25 MB page is not copied whole to count or write its bytes).
TEXT_PIECE = 1 << 20


def _utf8_size(text: str) -> int:
    """The size of ``text`` in UTF-8, in bytes, encoded :data:`TEXT_PIECE` characters at a time."""
    return sum(len(text[i:i + TEXT_PIECE].encode("utf-8")) for i in range(0, len(text), TEXT_PIECE))


def _b64_pieces(a: np.ndarray):
    """The base64 text of ``a``'s bytes (:func:`_b64`) in pieces of about :data:`TEXT_PIECE` characters (each
    piece encodes a whole number of 3-byte groups, so the pieces end to end are the base64 of the whole)."""
    raw = np.ascontiguousarray(a).reshape(-1).view(np.uint8)
    step = 3 * (TEXT_PIECE // 4)
    for i in range(0, len(raw), step):
        yield base64.b64encode(raw[i:i + step]).decode("ascii")


@dataclass
class _Page:
    """The report page as its pieces: text, or an array whose bytes the page holds in base64 (the views'
    table). Written a piece at a time (:meth:`write`), so that neither the whole page nor the table's base64
    (a third larger than the table) is ever held, nor plotly.js (4.8 MB) copied."""

    pieces: list

    #: The table's (empty) entry in the page's data (JSON): JSON escapes the quotes of any text, so only the
    #: entry itself reads so.
    TABLE = '"table": ""'

    @classmethod
    def of(cls, template: str, plotlyjs: str, data_json: str, table: np.ndarray, fields: dict) -> "_Page":
        """The page of ``template`` (a str.format text with one ``{plotlyjs}`` and, after it, one ``{data}``)
        with ``fields``, plotly.js, the data (``data_json``: :data:`TABLE` where the table's base64 goes)
        and ``table``."""
        start, rest = template.split("{plotlyjs}")
        middle, end = rest.split("{data}")
        before, mark, after = data_json.partition(cls.TABLE)
        if not mark:
            raise RuntimeError("report: the page's data has no table entry")
        table = np.ascontiguousarray(table).astype(table.dtype.newbyteorder("<"), copy=False)
        return cls([start.format(**fields), plotlyjs, middle.format(**fields) + before + mark[:-1], table,
                    mark[-1:] + after + end.format(**fields)])

    @staticmethod
    def _parts(piece):
        """A piece as text of about :data:`TEXT_PIECE` characters at a time."""
        if isinstance(piece, np.ndarray):
            return _b64_pieces(piece)
        return (piece[i:i + TEXT_PIECE] for i in range(0, len(piece), TEXT_PIECE))

    def size(self) -> int:
        """The page's size in UTF-8, bytes."""
        return sum(4 * -(-p.nbytes // 3) if isinstance(p, np.ndarray) else _utf8_size(p) for p in self.pieces)

    def text(self) -> str:
        """The whole page as one string."""
        return "".join(part for p in self.pieces for part in self._parts(p))

    def write(self, path) -> None:
        """Write the page to ``path`` (UTF-8), a piece at a time."""
        with open(path, "w", encoding="utf-8") as fh:
            for p in self.pieces:
                for part in self._parts(p):
                    fh.write(part)


def _script_safe(text: str) -> str:
    """JSON text that can sit inside a <script> element (no "</script>", no "<!--")."""
    return text.replace("</", "<\\/").replace("<!--", "<\\!--")


def _reason_table(reasons, counts, N) -> str:
    rows = [f"<tr data-reason='ok, buildable' data-count='{counts['ok, buildable']}'><td>ok, buildable</td>"
            f"<td class='num'>{counts['ok, buildable']:,}</td><td>in the views above</td><td></td></tr>"]
    for i, r in enumerate(reasons):
        key = html.escape(r["key"], quote=True)
        button = (f"<button class='show' data-i='{i}'>show</button>" if r["count"] else "")
        sub = " class='sub'" if r["key"].startswith("screened out: ") else ""
        rows.append(f"<tr data-reason='{key}' data-count='{r['count']}'{sub}><td>{html.escape(r['key'])}</td>"
                    f"<td class='num'>{r['count']:,}</td><td>{html.escape(r['text'])}</td><td>{button}</td></tr>")
    rows.append(f"<tr class='total'><td>every variant</td><td class='num'>{N:,}</td><td></td><td></td></tr>")
    return "".join(rows)


def report_html(results, **kw) -> str:
    """The report page of ``results`` (an open results file or a path) as one HTML string (keyword
    arguments as :func:`write_report`)."""
    return _with_results(results, lambda res: build_report(res, **kw)[0].text())


def _with_results(results, fn):
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    if hasattr(results, "frame") and hasattr(results, "file"):
        return fn(results)
    with open_results(results) as res:
        return fn(res)


def write_report(results, path, *, force: bool = False, metrics=None, max_designs: int = DEFAULT_MAX_DESIGNS,
                 paths: int = DEFAULT_PATHS, shown: int = DEFAULT_SHOWN, points: int = DEFAULT_POINTS,
                 reason_paths: int = DEFAULT_REASON_PATHS, seed: int = 0, x: str | None = None, y: str | None = None,
                 title: str | None = None, pc_lines: int = DEFAULT_PC_LINES, vs: int = 0, units: str = "model",
                 where: str | None = None) -> Report:
    """Write the interactive report of ``results`` (an open results file, or a path to one) to ``path``
    as one self-contained HTML file (plotly.js inlined; it opens offline). Returns a :class:`Report`.

    metrics : the metric axes (names or "a,b,c"; default every stored metric, in table order);
    max_designs : above this many ok designs, show a uniform sample of that many (seeded by ``seed``);
    paths : store the foot paths of this many best-ranked designs; shown : draw at most this many
    selected paths at once; points : samples per stored path; reason_paths : paths stored per reason
    (screen check, failure status); x, y : the scatter's first pair (default travel, bob); title : the
    page title; pc_lines : the parallel coordinates draw at most this many designs (a seeded sample;
    brushes and counts are over every design in the page); vs : the reference design (variant number;
    default 0, the nominal) whose value every metric table shows with the change against it in %, starred
    in the scatter and drawn grey under the foot paths; units : "model" (default) or "si" (lengths in mm,
    travel in m per turn, a walking speed in m/s, torque in N·m; needs the study's ``[operating] unit``,
    :func:`explorer.gait.to_si`); where : a filter over the results frame's columns (``explorer rank
    --where``'s restricted grammar, e.g. "bob < 0.2 and slip < 0.01"): the views hold the ok designs it keeps,
    and the page says so (the counts by reason stay over every variant). An existing ``path`` is replaced
    only with ``force``; never the results file itself.
    """
    from .._extras import require
    from .._files import output_path, write_replacing
    require("plotly", "explorer report")  # before anything is read
    protect = [results] if not hasattr(results, "file") else [getattr(results, "filename", None)]
    out = output_path(path, force, protect=[p for p in protect if p is not None])
    page, rep = _with_results(results, lambda res: build_report(
        res, metrics=metrics, max_designs=max_designs, paths=paths, shown=shown, points=points,
        reason_paths=reason_paths, seed=seed, x=x, y=y, title=title, pc_lines=pc_lines, vs=vs, units=units,
        where=where))
    write_replacing(out, page.write)
    rep.path = out
    rep.bytes = out.stat().st_size
    return rep


_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0 18px 30px; color: #222; }
h1 { font-size: 22px; margin: 14px 0 2px; } h2 { font-size: 16px; margin: 14px 0 6px; }
.meta { color: #666; font-size: 13px; margin: 0 0 8px; }
#summary { font-size: 15px; background: #f4f6f9; border-radius: 6px; padding: 8px 12px; margin: 8px 0; }
#summary b { font-size: 17px; }
#summary button, .controls button { margin-left: 12px; }
.note { color: #555; font-size: 13px; margin: 4px 0; } .warn { background: #fff4e0; padding: 6px 10px; border-radius: 4px; }
.row { display: flex; flex-wrap: wrap; gap: 16px; }
#parcoords-scroll { overflow-x: auto; }
.panel { flex: 1 1 560px; min-width: 420px; }
.controls { font-size: 14px; margin: 4px 0; } .controls select { font-size: 14px; margin-right: 10px; }
table { border-collapse: collapse; font-size: 13px; } td, th { padding: 3px 8px; border-bottom: 1px solid #e4e4e4; text-align: left; }
td.num, th.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.sub td:first-child { padding-left: 22px; } tr.total td { font-weight: bold; border-bottom: none; }
tr.active { background: #fde8e8; } tr.ref td { background: #fff4d6; font-weight: bold; }
#reason-variants { font-size: 12px; color: #333; max-height: 140px; overflow: auto; margin-top: 6px; word-break: break-word; }
details { margin: 10px 0; font-size: 13px; }
code { background: #f1f1f1; padding: 0 3px; border-radius: 3px; }
"""

_TEMPLATE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>{title}</title>
<style>{css}</style>
<script type="text/javascript">{plotlyjs}</script>
</head>
<body>
<h1>{heading}</h1>
<p class="meta">{meta}</p>
<div id="summary"><b id="n-selected" data-count="{n_designs}">{n_designs_text}</b> selected of
<b id="n-designs" data-count="{n_designs}">{n_designs_text}</b> designs in the views
({pool}) · <span id="n-front" data-count="0">0</span> on the Pareto front
<button id="reset">clear every brush</button></div>
{sample_note}
<p class="note">Drag along an axis to brush it (drag again elsewhere on it to add a range, click a range to
remove it); box- or lasso-select in the scatter to pick designs there. Every view shows what all brushes
keep. {order_note}. ↑ higher is better, ↓ lower is better.</p>
<p class="note" id="lines-note">The parallel coordinates draw <select id="pc-lines"></select> of the
{n_designs_text} designs (a seeded random sample when fewer; every brush and count is over all of them, and the
scatter draws them all).<span id="software-note"></span></p>
<div id="parcoords-scroll"><div id="parcoords" style="min-width: {pc_width}px"></div></div>
<div class="row">
 <div class="panel">
  <h2>Two metrics, with the Pareto front of the selection</h2>
  <div class="controls"><label>x <select id="x-metric">{options}</select></label>
  <label>y <select id="y-metric">{options}</select></label></div>
  {no_scatter}<div id="scatter"></div>
 </div>
 <div class="panel">
  <h2>Foot paths (vertex {foot}) over the {ref_label}'s</h2>
  <p class="note" id="feet-note"></p>
  {no_paths}<div id="feet"></div>
 </div>
</div>
{vs_section}
<div class="row">
 <div class="panel">
  <h2>Best selected designs</h2>
  <p class="note">Take one away: <code>explorer show {results} --variant N</code>,
  <code>explorer export {results} --variant N -o leg.svg</code>.</p>
  <table id="best"></table>
 </div>
 <div class="panel">
  <h2>Screened out and failed, by reason</h2>
  <p class="note">"show" draws the first of them (lowest variant numbers) in red in the foot-path view and lists
  their variant numbers. A design can fail several checks of the screen: it counts under each.</p>
  <table id="reasons"><tr><th>reason</th><th class="num">variants</th><th>what it means</th><th></th></tr>
  {reason_table}</table>
  <div id="reason-variants"></div>
 </div>
</div>
<details><summary>What the axes mean</summary>
<table><tr><th>axis</th><th>unit</th><th class="num">{ref_label}</th><th>better</th><th>meaning</th></tr>{axes_rows}</table>
<p class="note">Values are stored as 32-bit floats; foot paths as {points} samples per turn
(16-bit over their bounding box), for the {n_paths} best-ranked designs.</p></details>
<script type="application/json" id="report-data">{data}</script>
{figs}
<script type="text/javascript">{js}</script>
</body>
</html>
"""

_JS = r"""
(function () {
'use strict';
var T0 = performance.now();
var D = JSON.parse(document.getElementById('report-data').textContent);
function fig(id) { return JSON.parse(document.getElementById('fig-' + id).textContent); }
function bytes(b64) {
  var s = atob(b64), n = s.length, out = new Uint8Array(n);
  for (var i = 0; i < n; i++) out[i] = s.charCodeAt(i);
  return out.buffer;
}
function fmt(n) { return n.toLocaleString('en-US'); }
var N = D.n_designs;
var variant = new Int32Array(bytes(D.variant));
var table = new Float32Array(bytes(D.table));
var values = {}, dimOf = {}, colOf = {};
D.columns.forEach(function (c, j) {
  values[c.key] = table.subarray(j * N, (j + 1) * N); dimOf[c.key] = c.dim; colOf[c.key] = c;
});
var build = values['buildable'], pickDim = dimOf['pick'];
var pick = new Float32Array(N); pick.fill(1);
// the parallel coordinates draw the first `lines` rows of a seeded random order, worst rank first (the best on top)
var pcOrder = new Int32Array(bytes(D.pc_order)), pcRows = null, lines = D.pc_lines;
var renderer = '';
try {  // a browser without a GPU draws WebGL in software, where each line costs: draw fewer by default
  var gl = document.createElement('canvas').getContext('webgl');
  var ext = gl && gl.getExtension('WEBGL_debug_renderer_info');
  renderer = gl ? String(gl.getParameter(ext ? ext.UNMASKED_RENDERER_WEBGL : gl.RENDERER)) : '';
  var lose = gl && gl.getExtension('WEBGL_lose_context');
  if (lose) lose.loseContext();
} catch (e) { renderer = ''; }
var software = /swiftshader|llvmpipe|softpipe|software/i.test(renderer);
if (software) lines = D.pc_lines_software;
function chooseRows(L) {
  pcRows = Int32Array.from(pcOrder.subarray(0, L)).sort().reverse();
}
chooseRows(lines);
function drawn(a) {
  var out = new Float32Array(pcRows.length);
  for (var i = 0; i < pcRows.length; i++) out[i] = a[pcRows[i]];
  return out;
}
var PC = fig('parcoords'), SC = fig('scatter'), FP = fig('feet');
// the parallel coordinates' values: an axis that spans the buildable designs pins the others at its ends
// (drawn and brushed there; the scatter and the tables keep every value as it is)
var axisValues = {};
D.columns.forEach(function (c) {
  var a = values[c.key];
  if (c.clip) {
    a = Float32Array.from(a);
    var lo = c.clip[0], hi = c.clip[1];
    for (var i = 0; i < a.length; i++) if (a[i] < lo) a[i] = lo; else if (a[i] > hi) a[i] = hi;
  }
  axisValues[c.key] = a;
});
D.columns.forEach(function (c) { PC.data[0].dimensions[c.dim].values = drawn(c.key === 'pick' ? pick : axisValues[c.key]); });
PC.data[0].line.color = drawn(values['rank']);
var paths = D.paths ? new Uint16Array(bytes(D.paths)) : new Uint16Array(0), P = D.points;
var xKey = D.x, yKey = D.y, reason = null;
var gPC = document.getElementById('parcoords'), gSC = document.getElementById('scatter'),
    gFP = document.getElementById('feet');
var config = {responsive: true, displaylogo: false};

function pathXY(j, closeIt) {  // path j of the blob: [xs, ys], null where it has no position
  var xs = [], ys = [], s = D.scale, ok = true;
  for (var k = 0; k < P; k++) {
    var qx = paths[(j * P + k) * 2], qy = paths[(j * P + k) * 2 + 1];
    if (qx === 65535 || qy === 65535) { xs.push(null); ys.push(null); ok = false; }
    else { xs.push(s[0] + qx * s[2]); ys.push(s[1] + qy * s[3]); }
  }
  if (closeIt && D.closed && ok && P) { xs.push(xs[0]); ys.push(ys[0]); }  // a crank's path is a loop
  return [xs, ys];
}

function ranges(cr) {  // a constraintrange as a list of [lo, hi]
  if (!cr || !cr.length) return null;
  if (typeof cr[0] === 'number') return [cr];
  return cr;
}

function selectedMask() {  // every design inside every brushed range (over all N, drawn or not)
  var dims = gPC.data[0].dimensions, act = [];
  D.columns.forEach(function (c) {
    var r = ranges(dims[c.dim].constraintrange);
    if (r) act.push([c.key === 'pick' ? pick : axisValues[c.key], r]);
  });
  var mask = new Uint8Array(N), count = 0;
  for (var i = 0; i < N; i++) {
    var keep = 1;
    for (var a = 0; a < act.length && keep; a++) {
      var v = act[a][0][i], rr = act[a][1], inside = 0;
      for (var b = 0; b < rr.length; b++) if (v >= rr[b][0] && v <= rr[b][1]) { inside = 1; break; }
      keep = inside;
    }
    mask[i] = keep; count += keep;
  }
  return [mask, count];
}

function better(key) { return colOf[key].direction === 'min' ? -1 : 1; }  // +1: higher is better

function paretoFront(mask) {  // rows of the selected buildable designs that no other dominates in (x, y)
  var X = values[xKey], Y = values[yKey], sx = better(xKey), sy = better(yKey), idx = [];
  for (var i = 0; i < N; i++)
    if (mask[i] && build[i] === 1 && isFinite(X[i]) && isFinite(Y[i])) idx.push(i);
  idx.sort(function (a, b) { return (sx * X[b] - sx * X[a]) || (sy * Y[b] - sy * Y[a]) || (a - b); });
  var front = [], best = -Infinity, g = 0;
  while (g < idx.length) {  // groups of equal x, best x first; equal designs both stay
    var h = g, gx = X[idx[g]];
    while (h < idx.length && X[idx[h]] === gx) h++;
    var yb = sy * Y[idx[g]];
    if (yb > best) {
      for (var k = g; k < h && sy * Y[idx[k]] === yb; k++) front.push(idx[k]);
      best = yb;
    }
    g = h;
  }
  front.sort(function (a, b) { return X[a] - X[b] || Y[a] - Y[b]; });
  return front;
}

function setCount(id, n) {
  var el = document.getElementById(id);
  el.textContent = fmt(n); el.setAttribute('data-count', String(n));
}

function change(v, r) {  // the change against the reference in % of its value, as text
  if (r === null || r === undefined || r === 0 || !isFinite(v)) return '-';
  var d = 100 * (v - r) / Math.abs(r);
  return (d >= 0 ? '+' : '') + d.toFixed(1) + ' %';
}

function bestTable(mask) {  // the best selected designs, each metric with its change against the reference
  var keys = [xKey, yKey].filter(function (k, i, a) { return k && a.indexOf(k) === i; });
  var R = D.reference, ref = D.nominal;
  var html = '<tr><th>variant</th><th class="num">rank</th>' + keys.map(function (k) {
    return '<th class="num">' + k + ' [' + colOf[k].unit + ']</th><th class="num">Δ %</th>'; }).join('') +
    '<th>buildable</th></tr>', shown = 0;
  for (var i = 0; i < N && shown < 12; i++) {
    if (!mask[i]) continue;
    shown++;
    html += '<tr><td>' + variant[i] + '</td><td class="num">' + fmt(values['rank'][i]) + '</td>';
    keys.forEach(function (k) {
      html += '<td class="num">' + values[k][i].toPrecision(5) + '</td><td class="num">' + change(values[k][i], ref[k]) +
        '</td>';
    });
    html += '<td>' + (build[i] === 1 ? 'yes' : 'screened out') + '</td></tr>';
  }
  if (!shown) html += '<tr><td colspan="' + (3 + 2 * keys.length) + '">nothing selected</td></tr>';
  html += '<tr class="ref"><td>' + R.label + ' (' + R.variant + ')</td><td class="num">' + R.place + '</td>';
  keys.forEach(function (k) {
    var r = ref[k];
    html += '<td class="num">' + (r === null || r === undefined ? '-' : Number(r).toPrecision(5)) +
      '</td><td class="num">-</td>';
  });
  html += '<td>' + (R.ok ? 'reference' : 'reference (failed)') + '</td></tr>';
  document.getElementById('best').innerHTML = html;
}

function update() {
  var mc = selectedMask(), mask = mc[0], p = [];
  setCount('n-selected', mc[1]);
  if (xKey && yKey) {
    var X = values[xKey], Y = values[yKey];
    var bx = [], by = [], bv = [], sx = [], sy = [], sv = [];
    for (var i = 0; i < N; i++) {
      if (!mask[i]) continue;
      if (build[i] === 1) { bx.push(X[i]); by.push(Y[i]); bv.push(variant[i]); }
      else { sx.push(X[i]); sy.push(Y[i]); sv.push(variant[i]); }
    }
    var front = paretoFront(mask);
    setCount('n-front', front.length);
    p.push(Plotly.restyle(gSC, {x: [sx, bx, front.map(function (i) { return X[i]; })],
                                y: [sy, by, front.map(function (i) { return Y[i]; })],
                                customdata: [sv, bv, front.map(function (i) { return variant[i]; })]}, [1, 2, 3]));
  }
  if (D.points) {
    var fx = [], fy = [], fv = [], drawnPaths = 0, inSel = 0;
    for (var r = 0; r < N; r++) {
      if (!mask[r]) continue;
      inSel++;
      if (r >= D.n_paths || drawnPaths >= D.shown) continue;
      var xy = pathXY(r, true);
      fx = fx.concat(xy[0], [null]); fy = fy.concat(xy[1], [null]);
      for (var k = 0; k <= xy[0].length; k++) fv.push(variant[r]);
      drawnPaths++;
    }
    var note = 'Blue: the ' + fmt(drawnPaths) + ' best-ranked of the ' + fmt(inSel) + ' selected designs (at most ' +
      D.shown + ' at once; this page holds the paths of the ' + fmt(D.n_paths) + ' best-ranked). Grey: the nominal.';
    if (inSel && !drawnPaths) note = 'None of the ' + fmt(inSel) + ' selected designs is among the ' + fmt(D.n_paths) +
      ' best-ranked whose paths this page holds (explorer report --paths N stores more).';
    document.getElementById('feet-note').textContent = note;
    p.push(Plotly.restyle(gFP, {x: [fx], y: [fy], customdata: [fv],
                                name: ['selected: the ' + fmt(drawnPaths) + ' best by rank']}, [1]));
  }
  bestTable(mask);
  return Promise.all(p);
}

function showReason(i) {  // draw (and list) the designs of reason i; again, or null, to clear
  document.querySelectorAll('#reasons tr').forEach(function (tr) { tr.classList.remove('active'); });
  var box = document.getElementById('reason-variants');
  if (i === null || i === reason) {
    reason = null; box.textContent = '';
    if (D.points) return Plotly.restyle(gFP, {x: [[]], y: [[]], customdata: [[]], name: ['by reason (none chosen)']}, [2]);
    return Promise.resolve();
  }
  reason = i;
  var R = D.reasons[i];
  document.querySelectorAll('#reasons tr')[i + 2].classList.add('active');
  box.textContent = R.key + ': variants ' + R.variants.join(', ') +
    (R.count > R.variants.length ? ', … (' + fmt(R.count - R.variants.length) + ' more)' : '');
  if (!D.points) return Promise.resolve();
  var fx = [], fy = [], fv = [];
  R.paths.forEach(function (j, n) {
    var xy = pathXY(j, true);
    fx = fx.concat(xy[0], [null]); fy = fy.concat(xy[1], [null]);
    for (var k = 0; k <= xy[0].length; k++) fv.push(R.path_variants[n]);
  });
  return Plotly.restyle(gFP, {x: [fx], y: [fy], customdata: [fv],
    name: [R.key + ': the first ' + R.paths.length + ' of ' + fmt(R.count)]}, [2]);
}

function setPick(rows) {  // rows: null (no scatter pick) or a list of row numbers; filters through its axis
  pick.fill(rows === null ? 1 : 0);
  if (rows !== null) rows.forEach(function (r) { pick[r] = 1; });
  var upd = {};
  upd['dimensions[' + pickDim + '].values'] = [drawn(pick)];
  upd['dimensions[' + pickDim + '].constraintrange'] = [rows === null ? null : [0.5, 1.5]];
  return Plotly.restyle(gPC, upd, [0]);
}

function setLines(L) {  // draw L lines in the parallel coordinates; brushes are kept
  chooseRows(L);
  var upd = {'line.color': [drawn(values['rank'])]};
  D.columns.forEach(function (c) {
    upd['dimensions[' + c.dim + '].values'] = [drawn(c.key === 'pick' ? pick : axisValues[c.key])];
  });
  return Plotly.restyle(gPC, upd, [0]);
}

function linesMenu() {
  var sel = document.getElementById('pc-lines'), opts = [];
  [300, 1000, 3000, 10000, 30000, 100000].forEach(function (k) { if (k < D.pc_lines) opts.push(k); });
  opts.push(D.pc_lines);
  if (opts.indexOf(lines) < 0) opts.push(lines);
  opts.sort(function (a, b) { return a - b; });
  sel.innerHTML = opts.map(function (k) {
    return '<option value="' + k + '"' + (k === lines ? ' selected' : '') + '>' +
      (k === N ? 'all ' + fmt(k) : fmt(k)) + '</option>'; }).join('');
  sel.addEventListener('change', function () { lines = Number(sel.value); setLines(lines); });
  if (software) document.getElementById('software-note').textContent = ' This browser draws WebGL in software (' +
    renderer.match(/swiftshader|llvmpipe|softpipe|software/i)[0] + ', no GPU), where each line is slow to draw: ' +
    'it starts with ' + fmt(lines) + '.';
}

function nominalXY() {
  var nx = D.nominal[xKey], ny = D.nominal[yKey];
  return (nx === null || ny === null || nx === undefined || ny === undefined) ? [[], []] : [[nx], [ny]];
}

function title(k) {
  var m = colOf[k]; return k + ' [' + m.unit + '], ' + (m.direction === 'min' ? 'lower' : 'higher') + ' is better';
}

function setAxes() {  // new scatter axes: the scatter pick is cleared (it was drawn in the old ones)
  xKey = document.getElementById('x-metric').value; yKey = document.getElementById('y-metric').value;
  var nom = nominalXY();
  return Plotly.update(gSC, {x: [values[xKey], nom[0]], y: [values[yKey], nom[1]], selectedpoints: [null, null]},
                       {'xaxis.title.text': title(xKey), 'yaxis.title.text': title(yKey), 'xaxis.autorange': true,
                        'yaxis.autorange': true, selections: []}, [0, 4])
    .then(function () { return setPick(null); });
}

if (xKey && yKey) {
  var nom = nominalXY();
  SC.data[0].x = values[xKey]; SC.data[0].y = values[yKey];
  SC.data[4].x = nom[0]; SC.data[4].y = nom[1];
}
var times = {script: Math.round(T0)}, t = performance.now();
function lap(name) { var now = performance.now(); times[name] = Math.round(now - t); t = now; }
lap('decode');
var P0 = Plotly.newPlot(gPC, PC.data, PC.layout, config);
lap('parcoords');
var P1 = (xKey && yKey) ? Plotly.newPlot(gSC, SC.data, SC.layout, config) : Promise.resolve();
lap('scatter');
var P2 = D.points ? Plotly.newPlot(gFP, FP.data, FP.layout, config) : Promise.resolve();
lap('feet');
Promise.all([P0, P1, P2]).then(function () {
  if (xKey && yKey) {
    document.getElementById('x-metric').value = xKey; document.getElementById('y-metric').value = yKey;
    document.getElementById('x-metric').addEventListener('change', setAxes);
    document.getElementById('y-metric').addEventListener('change', setAxes);
    gSC.on('plotly_selected', function (ev) {
      if (!ev || !ev.points) return;
      var rows = [];
      ev.points.forEach(function (pt) { if (pt.curveNumber === 0) rows.push(pt.pointIndex); });
      setPick(rows);
    });
    gSC.on('plotly_deselect', function () { setPick(null); });
  } else {
    document.querySelectorAll('.controls').forEach(function (e) { e.style.display = 'none'; });
  }
  linesMenu();
  gPC.on('plotly_restyle', function () { update(); });
  document.getElementById('reset').addEventListener('click', function () {
    var upd = {};
    D.columns.forEach(function (c) { upd['dimensions[' + c.dim + '].constraintrange'] = [null]; });
    pick.fill(1); upd['dimensions[' + pickDim + '].values'] = [drawn(pick)];
    if (xKey && yKey) Plotly.update(gSC, {selectedpoints: [null]}, {selections: []}, [0]);
    Plotly.restyle(gPC, upd, [0]);
  });
  document.querySelectorAll('#reasons button.show').forEach(function (b) {
    b.addEventListener('click', function () { showReason(Number(b.getAttribute('data-i'))); });
  });
  lap('plots');
  return update();
}).then(function () {
  lap('update');
  document.body.setAttribute('data-load-ms', String(Math.round(performance.now())));
  document.body.setAttribute('data-ready', '1');
}).catch(function (e) { console.error('explorer report: ' + (e && e.stack || e)); });
window.explorerReport = {times: times, lines: function () { return pcRows.length; }, renderer: renderer,
                         setLines: setLines, data: D, values: values, update: update, setPick: setPick, showReason: showReason};
})();
"""
