"""Static plots of a study's results, each returned as a matplotlib Figure (Agg, no display needed).

* :func:`plot_top` — foot paths of the N best variants by a metric over the nominal path.
* :func:`plot_scatter` — every ok variant in two metrics, the Pareto front and the nominal.
* :func:`plot_velocity` — dx/dθ and dy/dθ of the foot: analytic (solid) against central finite
  differences of the positions (dashed, on top): the check of seed 000.
* :func:`plot_sensitivity` — a one-at-a-time (oat) study: change of each metric per link.
* :func:`save_figure` — write a figure as PNG, SVG or PDF, chosen by the extension.

Figures are built on :class:`matplotlib.figure.Figure` with an Agg canvas, never through pyplot, so
nothing depends on a display or on global figure state. Lengths are in the model units of the link
lengths; rates are per radian of crank.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from .._files import write_replacing, writable_kind
from ..errors import UserError
from ..gait import (DEFAULT_BAND, DIRECTIONS, METRICS, UNITS, ok_mask, pareto_front, rank, results_si,
                   screened_mask, select, stance_indices)
from ..kernels import Cycle, simulate
from ..mechanism import Mechanism
# the results helpers belong to explorer.store; the old names stay importable from here
from ..store import check_variant, is_results, results_band, variant_mechanism, variant_row  # noqa: F401
from ._draw import STANCE_COLOR

#: Figure formats save_figure writes, by extension.
FIGURE_FORMATS = {".png": "png", ".svg": "svg", ".pdf": "pdf"}

_UNIT_TEXT = {"length": "model units", "length/rad": "model units/rad", "length/turn": "model units per crank turn",
              "1 (per W·crank)": "per weight × crank radius", "1": "ratio", "1 (length/length)": "ratio"}

#: Font sizes (points) of every plot: readable at a glance on a screen and in the docs at 100-150 dpi.
TITLE_SIZE, LABEL_SIZE, TICK_SIZE, LEGEND_SIZE = 13, 12, 10.5, 10


def style_axes(ax, title: str | None = None, *, title_size: float = TITLE_SIZE) -> None:
    """Label, tick and title sizes of one axes (the units go in square brackets in the labels)."""
    ax.xaxis.label.set_size(LABEL_SIZE)
    ax.yaxis.label.set_size(LABEL_SIZE)
    ax.tick_params(labelsize=TICK_SIZE)
    if title is not None:
        # wrapped at the figure's edges: a title wider than the figure (a long --where filter, an axes
        # off centre beside its legend) breaks into lines instead of running off the canvas
        ax.set_title(title, fontsize=title_size, wrap=True)


# -- figures and files ---------------------------------------------------------------------------------
def new_figure(figsize=(7.0, 5.0), dpi: float = 100, **kw) -> Figure:
    """A Figure with an Agg canvas attached (draws and saves headless)."""
    fig = Figure(figsize=figsize, dpi=dpi, layout="constrained", **kw)
    FigureCanvasAgg(fig)
    return fig


def check_output(path, formats) -> Path:
    """``path`` as a Path if its extension is one of ``formats`` and its folder is writable, else UserError."""
    p = Path(os.fspath(path))
    ext = p.suffix.lower()
    if ext not in formats:
        raise UserError(f"{p}: unknown output extension {p.suffix or '(none)'!r} "
                        f"(expected one of {', '.join(sorted(formats))})")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise UserError(f"{p}: cannot write: folder {parent} does not exist")
    writable_kind(p)  # not a folder, a device, a FIFO or a socket
    if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise UserError(f"{p}: cannot write: permission denied")
    return p


def save_figure(fig: Figure, path, dpi: float | None = None) -> Path:
    """Save ``fig`` to ``path``: PNG, SVG or PDF by its extension (UserError on a bad extension or path).
    Written to a temporary file renamed into place: a link at ``path`` is replaced, never followed."""
    p = check_output(path, FIGURE_FORMATS)
    fmt = FIGURE_FORMATS[p.suffix.lower()]
    return write_replacing(p, lambda tmp: fig.savefig(tmp, format=fmt, dpi=dpi if dpi is not None else "figure"))


def _unit(metric: str) -> str:
    u = UNITS.get(metric)
    return _UNIT_TEXT.get(u, u) if u else ""


def metric_label(metric: str, unit: str | None = None) -> str:
    """Axis label of a metric: name, [unit], and which way is better, e.g. "travel [model units per crank
    turn], higher is better" (no nested parentheses); ``unit`` overrides the table's (an SI unit)."""
    u = unit or _unit(metric)
    d = DIRECTIONS.get(metric)
    better = {"max": "higher is better", "min": "lower is better"}.get(d)
    text = f"{metric} [{u}]" if u else metric
    return f"{text}, {better}" if better else text


def _blocked(results) -> bool:
    """Whether ``results`` reads its frame in blocks of rows (an open :class:`~explorer.store.Results`:
    ``frame_rows``, ``select``, ``rank`` without a frame), so that a view need not hold its whole frame."""
    return all(callable(getattr(results, a, None)) for a in ("frame_rows", "select", "rank", "screen_summary"))


def _check_metric(df: pd.DataFrame, metric: str) -> str:
    metric = str(metric)
    known = [m for m in METRICS if m in df.columns]
    if metric not in df.columns or metric in ("variant", "status"):
        if metric in METRICS:
            raise UserError(f"metric {metric!r} was not computed for these results "
                            f"(known: {', '.join(known) or 'none; run the study with [scene] metrics = true'})")
        raise UserError(f"unknown metric {metric!r} (known: {', '.join(known) or 'none'})")
    return metric


def _segments_of(indices: np.ndarray, S: int) -> list[tuple[int, int]]:
    """Contiguous (start, stop) index ranges of a cyclic run (two if it wraps past S−1)."""
    if len(indices) == 0:
        return []
    s, n = int(indices[0]), len(indices)
    if s + n <= S:
        return [(s, s + n)]
    return [(s, S), (0, s + n - S)]


# -- plot_top -------------------------------------------------------------------------------------------
def plot_top(results, by: str | None = None, top: int = 5, *, weights=None, where: str | None = None,
             include_screened: bool = False, vertex: str | None = None, band: float | None = None,
             units: str = "model", figsize=(9.0, 6.0), dpi: float = 100) -> Figure:
    """Foot paths of the ``top`` best variants over the nominal (variant 0) path.

    The ranking is :func:`explorer.gait.rank`'s, so it shows the rows ``explorer rank`` lists for the
    same request: by default the weighted score of :data:`explorer.gait.DEFAULT_WEIGHTS` (those of them
    stored; the title names the others), else one
    metric ``by`` or a ``weights`` score; variants the buildability screen removes are left out unless
    ``include_screened``; ``where`` is a filter as in :func:`explorer.gait.rank`. Equal axes; each variant labelled with
    its rank and ranking value; its single-leg band stance (longest run within ``band`` · height of its
    lowest point; default: the study's ``[scene] band``) drawn thick. ``units`` "si": the paths in mm and the
    ranking values in SI (:func:`explorer.gait.results_si`; the ranking itself over the stored values).
    """
    blocked = _blocked(results)  # an open results file: its frame is read in blocks of rows, never whole
    df = results.frame_rows([0]) if blocked else results.frame()  # blocked: the nominal's row
    conv = results_si(results, df.iloc[:0], units)
    mm = 1.0 if conv is None else conv.operating.unit * 1000.0  # model units -> mm
    if by is not None:
        by = _check_metric(df, by)
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1:
        raise UserError(f"top: expected a whole number >= 1, got {top!r}")
    band = results_band(results) if band is None else float(band)
    ranked = rank(df, by=by, top=int(top), where=where, weights=weights, include_screened=include_screened)
    n_all = len(df)
    if blocked:  # the same ranking and counts, read in blocks (the arguments checked on the row above first)
        ranked = results.rank(by=by, top=int(top), where=where, weights=weights, include_screened=include_screened)
        n_ok, n_all = int(results.status_counts().get("ok", 0)), int(results.n_variants)
        n_pool = n_ok - (0 if include_screened else int(results.screen_summary()["removed"]))
    else:
        n_ok = int(ok_mask(df).sum())
        n_pool = n_ok - (0 if include_screened else int(screened_mask(df).sum()))
    key = by if by is not None else "score"
    pool = f"{n_pool:,} ok" + ("" if include_screened or n_pool == n_ok else " buildable")
    if ranked.empty:
        raise UserError(f"no ok variant to rank ({pool} of {n_all:,}" + (f", filter {where!r}" if where else "") + ")")
    mech = results.mechanism
    vname = vertex if vertex is not None else mech.foot
    fig = new_figure(figsize, dpi)
    ax = fig.add_subplot()
    # the nominal, underneath (a lean file re-solves the designs drawn at once, in one line)
    if getattr(results, "prefetch", None) is not None:
        results.prefetch([0] + [int(v) for v in (ranked["variant"] if "variant" in ranked.columns else ranked.index)])
    nom = np.asarray(results.path(0, vertex), dtype=np.float64) * mm
    nom_row = df.loc[df["variant"] == 0] if "variant" in df.columns else df.iloc[:1]
    shown = ranked
    if conv is not None:  # the values labelled, in SI
        nom_row, shown = conv.apply(nom_row).frame, conv.apply(ranked).frame
    nom_val = nom_row[by].iloc[0] if by is not None else math.nan
    unit = "" if conv is None or by is None or by not in conv.converted else f" {conv.units[by]}"
    nom_text = f": {by} = {nom_val:.4g}{unit}" if by is not None and pd.notna(nom_val) else ""
    ax.plot(*_closed(nom).T, "-", color="0.55", lw=3.0, zorder=1, label=f"nominal (variant 0){nom_text}")
    si = stance_indices(nom, band)
    for a, b in _segments_of(si, len(nom)):
        ax.plot(nom[a:b, 0], nom[a:b, 1], "-", color="0.55", lw=7.0, alpha=0.45, solid_capstyle="butt", zorder=1)
    cmap = _cmap(len(ranked))
    for i, (_, row) in enumerate(shown.iterrows()):
        v = int(row["variant"]) if "variant" in row.index else int(row.name)
        p = np.asarray(results.path(v, vertex), dtype=np.float64) * mm
        c = cmap[i]
        ax.plot(*_closed(p).T, "-", color=c, lw=1.4, zorder=3 + i * 0.01,
                label=f"#{int(row['rank'])}  variant {v}: {key} = {row[key]:.4g}{unit}")
        for a, b in _segments_of(stance_indices(p, band), len(p)):
            ax.plot(p[a:b, 0], p[a:b, 1], "-", color=c, lw=4.5, alpha=0.55, solid_capstyle="butt",
                    zorder=2 + i * 0.01)
    handles, labels = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], color="0.3", lw=5, alpha=0.5))
    labels.append(f"band stance (y ≤ y_min + {band:g}·height)")
    ranked_by = (f"colour: rank by {by}" if by is not None else "colour: rank by score (1 = best)")
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=LEGEND_SIZE, frameon=False,
              title=ranked_by, title_fontsize=LEGEND_SIZE, alignment="left")
    ax.set_aspect("equal", adjustable="datalim")
    what = "foot" if vname == mech.foot else f"vertex {vname}"
    length = "model units" if conv is None else "mm"
    ax.set_xlabel(f"{what} x [{length}]")
    ax.set_ylabel(f"{what} y [{length}]")
    ax.grid(True, lw=0.4, alpha=0.5)
    if by is not None:
        first = {"max": "highest", "min": "lowest"}.get(DIRECTIONS.get(by), "best")
        how = f"by {by} ({first} first)"
    else:
        from ..gait import default_weights
        w, unstored = (weights, []) if weights is not None else default_weights(df.columns)
        how = "by score of " + ", ".join(w) + (f" (without {', '.join(unstored)}: not stored)" if unstored else "")
    filt = f", where {where}" if where else ""
    style_axes(ax, f"{mech.name}: foot path of vertex {vname}, top {len(ranked)} of {pool} variants\n"
                   f"{how}{filt}")
    return fig


def _closed(p: np.ndarray) -> np.ndarray:
    return np.vstack([p, p[:1]]) if np.isfinite(p).all() else p


def _cmap(n: int) -> list:
    from matplotlib import colormaps
    if n <= 10:
        return list(colormaps["tab10"].colors)[:n]
    return [colormaps["viridis"](x) for x in np.linspace(0.0, 0.9, n)]


# -- plot_scatter ---------------------------------------------------------------------------------------
def plot_scatter(results, x: str, y: str, *, where: str | None = None, directions=None,
                 include_screened: bool = False, units: str = "model", figsize=(7.5, 5.5),
                 dpi: float = 100) -> Figure:
    """Every ok variant as a point in metrics ``x`` and ``y``, the Pareto front over both, the nominal marked.

    Variants the buildability screen removes are drawn in grey and left off the front unless
    ``include_screened`` (as ``explorer rank`` leaves them out). ``directions`` overrides the natural
    directions of the front (dict metric -> "max"/"min"). ``units`` "si": both axes in SI
    (:func:`explorer.gait.results_si`; ``where`` filters the stored values).
    """
    blocked = _blocked(results)  # an open results file: only the columns drawn of the ok rows are read, in blocks
    df = results.frame_rows([0]) if blocked else results.frame()  # blocked: the nominal's row
    n = int(results.n_variants) if blocked else len(df)
    x, y = _check_metric(df, x), _check_metric(df, y)
    if x == y:
        raise UserError(f"scatter: name two different metrics, got {x!r} twice")
    if blocked:
        # ok rows only (so no status column); the crank radius only where --units si converts a torque by it
        extra = ("buildable",) + (("crank",) if units == "si" else ())
        ok = results.select(where, include_failed=False, include_screened=True,
                            columns=[x, y, *(c for c in extra if c in df.columns)])
    else:
        ok = df[ok_mask(df)]
        if where:
            ok = select(ok, where, include_failed=True, include_screened=True)
    si = results_si(results, df.iloc[:0], units)
    if si is not None:  # the axes in SI: every value converted, the filter above over the stored ones
        df, ok = si.apply(df).frame, si.apply(ok).frame
    ok = ok[np.isfinite(ok[x].to_numpy(dtype=float)) & np.isfinite(ok[y].to_numpy(dtype=float))]
    out = ok[screened_mask(ok)] if not include_screened else ok.iloc[:0]
    ok = ok[~screened_mask(ok)] if not include_screened else ok
    mech = results.mechanism
    fig = new_figure(figsize, dpi)
    ax = fig.add_subplot()
    label = "ok variants" if include_screened or "buildable" not in df.columns else "buildable variants"
    dense = len(ok) + len(out) > SCATTER_POINTS
    note = ""
    if dense:  # every point would cost time and memory to draw and hide the others: designs per cell instead
        note = "\n" + _density(fig, ax, ok, out, x, y, label)
    else:
        if len(out):
            ax.scatter(out[x], out[y], s=6, color="0.6", alpha=0.5, lw=0, rasterized=len(out) > 2000,
                       label=f"screened out as unbuildable ({len(out):,})", zorder=1)
        ax.scatter(ok[x], ok[y], s=7, color="tab:blue", alpha=0.45, lw=0, rasterized=len(ok) > 2000,
                   label=f"{label} ({len(ok):,})", zorder=2)
    front = ok[pareto_front(ok, [x, y], directions)] if len(ok) else ok
    if len(front):
        f = front.sort_values([x, y])
        ax.plot(f[x], f[y], "-o", color="tab:orange", ms=5, lw=1.6, zorder=3,
                label=f"Pareto front ({len(front):,}; {_front_directions(x, y, directions)})")
    nominal = df[df["variant"] == 0] if "variant" in df.columns else df.iloc[:1]
    if len(nominal) and np.isfinite(float(nominal[x].iloc[0])) and np.isfinite(float(nominal[y].iloc[0])):
        ax.plot(nominal[x], nominal[y], "*", color="tab:red", ms=16, mec="black", mew=0.8, zorder=4,
                label="nominal (variant 0)")
    ax.set_xlabel(metric_label(x, None if si is None else si.units.get(x)))
    ax.set_ylabel(metric_label(y, None if si is None else si.units.get(y)))
    ax.grid(True, lw=0.4, alpha=0.5)
    leg = ax.legend(loc="best", fontsize=LEGEND_SIZE, framealpha=0.9)
    for h in leg.legend_handles:  # the dots of the clouds, large enough to show their colour
        if hasattr(h, "set_sizes"):
            h.set_sizes([36.0])
            h.set_alpha(0.9)
    filt = f", where {where}" if where else ""
    style_axes(ax, f"{mech.name}: {y} against {x}, {len(ok) + len(out):,} ok of {n:,} variants{filt}{note}")
    return fig


#: Above this many points :func:`plot_scatter` draws each cloud as a density (designs per cell of a grid over
#: the axes, a log colour scale) rather than one dot per design, and says so in the figure.
SCATTER_POINTS = 100_000
#: Cells of that grid across the x axis (the y axis: as many per inch of the axes).
DENSITY_CELLS = 240
#: Points counted into the grid at a time (its temporaries stay small on a million points).
DENSITY_ROWS = 1 << 16


def _counts(frame: pd.DataFrame, x: str, y: str, xe: np.ndarray, ye: np.ndarray) -> np.ndarray:
    """(len(xe) − 1, len(ye) − 1) counts of ``frame``'s (x, y) points per cell of the edges, a block at a time."""
    h = np.zeros((len(xe) - 1, len(ye) - 1))
    xs, ys = frame[x].to_numpy(dtype=np.float64), frame[y].to_numpy(dtype=np.float64)
    for a in range(0, len(xs), DENSITY_ROWS):
        h += np.histogram2d(xs[a:a + DENSITY_ROWS], ys[a:a + DENSITY_ROWS], bins=(xe, ye))[0]
    return h


def _density(fig, ax, ok: pd.DataFrame, out: pd.DataFrame, x: str, y: str, label: str) -> str:
    """The screened-out (grey) and the ``label`` (blue) designs of :func:`plot_scatter` as densities: each a
    log-scaled image of its designs per cell of one grid over the axes (empty cells clear; the blue over the
    grey, a little transparent), a colour bar of the blue ones' counts and the legend's entries; returns the
    line that says so, for the title."""
    from matplotlib import colormaps
    from matplotlib.colors import ListedColormap, LogNorm

    both = [f for f in (ok, out) if len(f)]
    lo = np.array([min(float(f[c].min()) for f in both) for c in (x, y)])
    hi = np.array([max(float(f[c].max()) for f in both) for c in (x, y)])
    pad = np.where(hi > lo, 0.03 * (hi - lo), np.maximum(np.abs(lo) * 0.01, 1e-9))  # a margin, as a scatter has
    lo, hi = lo - pad, hi + pad
    w, h = ax.get_position().width * fig.get_figwidth(), ax.get_position().height * fig.get_figheight()
    xe = np.linspace(lo[0], hi[0], DENSITY_CELLS + 1)
    ye = np.linspace(lo[1], hi[1], max(8, round(DENSITY_CELLS * h / w)) + 1)
    extent = (lo[0], hi[0], lo[1], hi[1])
    layers = (("screened out as unbuildable", out, "Greys", (0.3, 0.75), 1, 1.0),
              (label, ok, "Blues", (0.35, 1.0), 2, 0.85))
    shown = None
    for name, frame, cmap, (c0, c1), z, alpha in layers:
        if not len(frame):
            continue
        counts = _counts(frame, x, y, xe, ye)
        colours = ListedColormap(colormaps[cmap](np.linspace(c0, c1, 256)))
        image = ax.imshow(np.ma.masked_equal(counts.T, 0), origin="lower", extent=extent, aspect="auto",
                          interpolation="nearest", cmap=colours, norm=LogNorm(vmin=1, vmax=max(counts.max(), 2)),
                          alpha=alpha, zorder=z)
        ax.fill([], [], color=colours(0.6), label=f"{name} ({len(frame):,}; designs per cell)")  # its legend entry
        shown = image if frame is ok else shown
    if shown is not None:
        bar = fig.colorbar(shown, ax=ax, pad=0.02, fraction=0.04, aspect=30)
        bar.set_label(f"{label} per cell (log scale)", fontsize=TICK_SIZE)
        bar.ax.tick_params(labelsize=TICK_SIZE)
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])
    return (f"drawn as densities: designs per cell of a {len(xe) - 1}×{len(ye) - 1} grid "
            f"(over {SCATTER_POINTS:,} points)")


def _front_directions(x: str, y: str, directions=None) -> str:
    """"max travel, min bob": the directions the Pareto front is taken in."""
    d = dict(DIRECTIONS)
    if directions:
        d.update(directions)
    return ", ".join(f"{d.get(m, 'max')} {m}" for m in (x, y))


# -- plot_velocity --------------------------------------------------------------------------------------
def central_differences(theta: np.ndarray, path: np.ndarray, cyclic: bool = True) -> np.ndarray:
    """dP/dθ by central differences (P[k+1] − P[k−1]) / (θ[k+1] − θ[k−1]) on a uniform cyclic grid.

    ``cyclic``: the grid covers one full turn (wraps from S−1 to 0); otherwise the two ends are NaN.
    """
    P = np.asarray(path, dtype=np.float64)
    theta = np.asarray(theta, dtype=np.float64)
    S = P.shape[0]
    if S < 3:
        return np.full_like(P, np.nan)
    h = 2.0 * np.pi / S if cyclic else float(theta[1] - theta[0])
    D = (np.roll(P, -1, axis=0) - np.roll(P, 1, axis=0)) / (2.0 * h)
    if not cyclic:
        D[0] = D[-1] = np.nan
    return D


def _velocity_source(source, variant, vertex, steps):
    """(theta, path, velocity, mechanism, title-bit, failure text or None) for plot_velocity."""
    if isinstance(source, Mechanism):
        source = simulate(source, steps, velocities=True)
    if isinstance(source, Cycle):
        cyc = source
        mech = cyc.mechanism
        if cyc.velocities is None:
            cyc = simulate(mech, len(cyc.theta), velocities=True)
        v = vertex if vertex is not None else mech.foot
        fail = cyc.failure.message if cyc.failure is not None else None
        return cyc.theta, cyc.path(v), cyc.velocity(v), mech, f"{mech.name}, vertex {v}", fail, v
    if is_results(source):
        res = source
        var = check_variant(res, 0 if variant is None else variant)
        mech = res.mechanism
        theta = np.asarray(res.theta, dtype=np.float64)
        path = np.asarray(res.path(var, vertex), dtype=np.float64)
        v = vertex if vertex is not None else (mech.foot if mech.foot in getattr(res, "vertices", (mech.foot,))
                                               else res.vertices[0])
        try:
            vel = np.asarray(res.velocity(var, vertex), dtype=np.float64)
        except UserError:  # velocities not stored: solve this variant again
            cyc = simulate(variant_mechanism(res, var), len(theta), velocities=True)
            vel = cyc.velocity(v)
        row = variant_row(res, var)
        fail = None
        st = str(row.get("status", "ok"))
        if st != "ok":
            ft = row.get("fail_theta", float("nan"))
            at = f" at θ = {math.degrees(float(ft)):.2f}°" if pd.notna(ft) else ""
            fail = f"status {st}{at}"
        return theta, path, vel, mech, f"{mech.name} variant {var}, vertex {v}", fail, v
    raise UserError(f"plot_velocity: expected a Mechanism, a Cycle or results, got {type(source).__name__}")


def plot_velocity(source, variant: int | None = None, *, vertex: str | None = None, steps: int = 360,
                  band: float | None = None, figsize=(8.0, 6.5), dpi: float = 100) -> Figure:
    """dx/dθ and dy/dθ of the foot (or ``vertex``) over one crank cycle.

    ``source`` is a Cycle (with or without velocities), a Mechanism (simulated at ``steps``), or
    results (then ``variant``, default 0 = the nominal). Analytic dV/dθ (the Jacobian solve) is the
    solid line; central finite differences of the positions, dashed, are drawn on top. The stance is
    shaded. Units: model units per radian of crank. A path-driven mechanism is plotted against time,
    its rates per second, with finite differences over its sample times (no wrap-around, no stance).
    """
    theta, path, vel, mech, what, fail, vname = _velocity_source(source, variant, vertex, steps)
    if band is None:
        band = results_band(source) if is_results(source) else DEFAULT_BAND
    finite = np.isfinite(path).all(axis=1)
    if not finite.any():
        raise UserError(f"{what}: nothing to plot: {fail or 'no finite positions'}")
    timed = mech is not None and mech.crank is None  # a path driver: samples are times, rates per second
    if timed:
        S = len(path)
        theta = mech.path.duration * np.arange(S) / (S - 1)  # t_k = T·k/(S−1), whatever the source stored
    cyclic = bool(finite.all()) and not timed
    fd = central_differences(theta, path, cyclic=cyclic)
    x = theta if timed else np.degrees(theta)
    d, unit = ("t", "s") if timed else ("θ", "rad")
    fig = new_figure(figsize, dpi)
    axes = fig.subplots(2, 1, sharex=True)
    stance = stance_indices(path, band) if cyclic else np.zeros(0, dtype=np.int64)
    S = len(theta)
    step = 360.0 / S
    spacing = f"Δt = {theta[1] - theta[0]:.3g} s" if timed else f"Δθ = {step:.3g}°"
    for j, (ax, name) in enumerate(zip(axes, ("x", "y"))):
        for a, b in _segments_of(stance, S):
            ax.axvspan(x[a], x[b - 1] + step if b < S else 360.0, color=STANCE_COLOR, alpha=0.12, lw=0,
                       label="stance" if a == stance[0] else None)
        ax.plot(x, vel[:, j], "-", color="tab:blue", lw=2.6, zorder=2, label="analytic (Jacobian)")
        ax.plot(x, fd[:, j], "--", color="tab:orange", lw=1.6, zorder=3, label=f"central finite differences, {spacing}")
        if not finite.all():
            k = int(np.argmin(finite))
            ax.axvline(x[k], color="tab:red", lw=1.2, ls=":", label="failure")
        err = np.nanmax(np.abs(vel[:, j] - fd[:, j])) if np.isfinite(vel[:, j] - fd[:, j]).any() else float("nan")
        scale = np.nanmax(np.abs(vel[:, j])) if np.isfinite(vel[:, j]).any() else float("nan")
        clipped = _robust_ylim(ax, vel[:, j], fd[:, j])
        ax.set_ylabel(f"d{name}/d{d} [model units/{unit}]" + ("\nclipped" if clipped else ""))
        style_axes(ax, f"d{name}/d{d}: max |analytic − finite difference| = {err:.2e}, "
                       f"peak |d{name}/d{d}| = {scale:.3g}", title_size=LABEL_SIZE - 1)
        ax.grid(True, lw=0.4, alpha=0.5)
        ax.axhline(0.0, color="0.3", lw=0.6)
    axes[0].legend(loc="best", fontsize=LEGEND_SIZE, framealpha=0.9)
    if timed:
        axes[1].set_xlabel("time t [s]", fontsize=LABEL_SIZE)
        axes[1].set_xlim(0.0, float(theta[-1]))
    else:
        axes[1].set_xlabel("crank angle θ [deg]", fontsize=LABEL_SIZE)
        axes[1].set_xlim(0.0, 360.0)
        axes[1].set_xticks(np.arange(0, 361, 60))
    title = f"Foot velocity dF/d{d} of {what}: analytic vs finite differences"
    if fail:
        title += f"\nnot ok: {fail}"
    fig.suptitle(title, fontsize=TITLE_SIZE, wrap=True)
    return fig


def _robust_ylim(ax, *series) -> bool:
    """Limit the y-range when a few samples dwarf the rest (a rate blowing up next to a failure).

    Returns True if the range was clipped."""
    v = np.concatenate([np.asarray(s, dtype=np.float64) for s in series])
    v = v[np.isfinite(v)]
    if v.size < 10:
        return False
    lo, hi = np.percentile(v, [2.0, 98.0])
    span = max(hi - lo, 1e-12)
    if v.min() >= lo - 2.0 * span and v.max() <= hi + 2.0 * span:
        return False
    ax.set_ylim(lo - 0.5 * span, hi + 0.5 * span)
    return True


# -- plot_sensitivity -----------------------------------------------------------------------------------
def oat_sensitivity(results, metrics=None, relative: bool = True) -> pd.DataFrame:
    """Sensitivity table (parameters × metrics) of a one-at-a-time study.

    Each ok variant that differs from the nominal (variant 0) in exactly one parameter (a link length,
    the crank radius, or a coordinate the study moved such as "2.x") is a sample of that parameter;
    the slope of the metric change against the parameter change is fitted by least squares through
    the nominal. ``relative``: elasticity, % change of the metric per +1 % of the parameter (of the
    mechanism's size for a coordinate, whose own value is no scale, as the study samples it);
    otherwise the metric change per model unit of the parameter. NaN where a parameter has no ok
    sample or the nominal metric is 0 or undefined.
    """
    df = results.frame()
    mech = results.mechanism
    params = [n for n in mech.parameters() if n in df.columns]
    if metrics is None:
        metrics = [m for m in METRICS if m in df.columns]
    else:
        metrics = [_check_metric(df, m) for m in ([metrics] if isinstance(metrics, str) else metrics)]
    if not metrics:
        raise UserError("sensitivity: these results hold no metrics (run the study with [scene] metrics = true)")
    nom = df[df["variant"] == 0] if "variant" in df.columns else df.iloc[:1]
    if not len(nom):
        raise UserError("sensitivity: the results have no nominal variant 0")
    nom = nom.iloc[0]
    P = df[params].to_numpy(dtype=np.float64)
    P0 = nom[params].to_numpy(dtype=np.float64)
    scale = np.array([mech.size if mech.parameter_kind(p) == "coordinate" else P0[j] for j, p in enumerate(params)])
    with np.errstate(invalid="ignore", divide="ignore"):
        dP = (P - P0) / scale if relative else P - P0
        changed = np.abs(P - P0) > 1e-12 * np.maximum(np.abs(P0), 1.0)
    one = changed.sum(axis=1) == 1
    ok = ok_mask(df)
    sel = one & ok
    if not one.any():
        raise UserError("sensitivity: not a one-at-a-time study: no variant differs from the nominal in exactly "
                        "one parameter (run a study with [perturb] method = \"oat\")")
    if changed.sum(axis=1).max() > 1 and one.sum() < 0.5 * (len(df) - 1):
        method = None
        try:
            method = results.study["perturb"]["method"]
        except (AttributeError, KeyError, TypeError):
            pass
        raise UserError("sensitivity: not a one-at-a-time study: most variants change several parameters"
                        + (f" (perturb method {method!r}; use \"oat\")" if method else ""))
    which = np.argmax(changed, axis=1)
    out = pd.DataFrame(np.nan, index=params, columns=metrics)
    counts = pd.Series(0, index=params)
    for m in metrics:
        mv = df[m].to_numpy(dtype=np.float64)
        m0 = float(nom[m])
        for j, p in enumerate(params):
            rows = sel & (which == j) & np.isfinite(mv)
            counts[p] = max(counts[p], int(rows.sum()))
            if not rows.any() or not math.isfinite(m0):
                continue
            r = dP[rows, j]
            dm = mv[rows] - m0
            if relative:
                if m0 == 0.0:
                    continue
                dm = dm / abs(m0)
            s = float(np.dot(r, dm) / np.dot(r, r))
            out.loc[p, m] = s
    out.attrs["samples"] = counts.to_dict()
    out.attrs["relative"] = relative
    return out


def _cell_text(v: float) -> str:
    """A heat-map cell: 3 significant digits, no exponent below 10,000."""
    if not math.isfinite(v):
        return "—"
    if abs(v) >= 1e4:
        return f"{v:.1e}"
    if abs(v) >= 100:
        return f"{v:.0f}"
    return f"{v:.2g}"


def plot_sensitivity(results, metrics=None, *, relative: bool = True, figsize=None, dpi: float = 100) -> Figure:
    """Heat map of a one-at-a-time (oat) study: the change of each metric per link (and the crank).

    ``relative`` (default): elasticity, % change of the metric per +1 % of the parameter, from a
    least-squares slope through the nominal (see :func:`oat_sensitivity`); otherwise metric units
    per model unit of length. Cells are annotated; grey = no ok sample or undefined.
    """
    table = oat_sensitivity(results, metrics, relative)
    mech = results.mechanism
    params, mets = list(table.index), list(table.columns)
    # metrics down, parameters across: a study has more metrics than parameters, and names read across
    data = table.to_numpy(dtype=np.float64).T
    nrow, ncol = data.shape
    if figsize is None:
        figsize = (max(7.0, 0.82 * ncol + 4.2), max(4.8, 0.36 * nrow + 2.3))
    fig = new_figure(figsize, dpi)
    ax = fig.add_subplot()
    finite = np.abs(data[np.isfinite(data)])
    # the colours saturate at the 95th percentile of |value|, so one extreme cell does not wash out the rest
    vmax = float(np.percentile(finite, 95)) if finite.size else 1.0
    vmax = vmax if vmax > 0 else (float(finite.max()) if finite.size and finite.max() > 0 else 1.0)
    from matplotlib import colormaps
    cmap = colormaps["RdBu_r"].with_extremes(bad="0.85")
    im = ax.imshow(np.ma.masked_invalid(data), cmap=cmap, vmin=-vmax, vmax=vmax, aspect="auto")
    for i in range(nrow):
        for j in range(ncol):
            v = data[i, j]
            ax.text(j, i, _cell_text(v), ha="center", va="center", fontsize=8.5,
                    color="white" if math.isfinite(v) and abs(v) > 0.6 * vmax else "black")
    samples = table.attrs["samples"]
    ax.set_xticks(range(ncol), [f"{p}\nn={samples.get(p, 0)}" for p in params], fontsize=TICK_SIZE)
    ax.set_yticks(range(nrow), mets, fontsize=TICK_SIZE)
    coords = any(mech.parameter_kind(p) == "coordinate" for p in params)
    ax.set_xlabel("parameter changed: link, crank radius" + (" or coordinate" if coords else "")
                  + "; n = ok samples", fontsize=LABEL_SIZE)
    ax.set_ylabel("metric", fontsize=LABEL_SIZE)
    if relative:
        unit = "% change of the metric per +1 % of the parameter" + ("\ncoordinates: +1 % of the size "
                                                                     f"{mech.size:g}" if coords else "")
    else:
        unit = "metric units per model unit of the parameter"
    extend = "both" if finite.size and finite.max() > vmax else "neither"
    cb = fig.colorbar(im, ax=ax, shrink=0.9, extend=extend)
    cb.set_label(unit + ("; colours saturate beyond ±" + _cell_text(vmax) if extend == "both" else ""),
                 fontsize=LABEL_SIZE - 1)
    cb.ax.tick_params(labelsize=TICK_SIZE)
    spread = ""
    try:
        spread = f", ±{100 * float(results.study['perturb']['spread']):g} %"
    except (AttributeError, KeyError, TypeError, ValueError):
        pass
    ax.set_title(f"{mech.name}: one-at-a-time sensitivity{spread}, {'elasticity' if relative else 'slope'}; "
                 f"red: the metric grows with the parameter, blue: it shrinks, grey: undefined",
                 fontsize=TITLE_SIZE - 1, wrap=True)
    return fig


def plot_forces(results, variant: int = 0, *, figsize=(8.0, 7.0), dpi: float = 100) -> Figure:
    """The forces effect of one variant of a study run with ``[scene] forces = true``: the motor torque
    over the crank turn (N·m) with its mean and the band the flywheel (``flywheel_inertia``) holds the
    speed in, and below it the magnitude of each stored joint reaction (N, ``[scene] force_joints``).
    """
    v = check_variant(results, variant)
    tau = np.asarray(results.torque(v), dtype=np.float64)
    if not np.isfinite(tau).all():
        raise UserError(f"{results.filename}: variant {v} has no forces (it failed: {variant_row(results, v)['status']})")
    op = results.study.get("operating", {})
    S = tau.shape[0]
    x = 360.0 * np.arange(S) / S
    fig = new_figure(figsize, dpi)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    mean = float(tau.mean())
    ax1.plot(x, tau, color="tab:blue", lw=2.0, label="motor torque τ(θ)")
    ax1.axhline(mean, color="tab:green", lw=1.2, ls="--", label=f"mean {mean:.4g} N·m")
    # the flywheel's band: with I = ΔE/(C_s ω²) the speed stays within ±C_s/2 of its mean
    cs = float(op.get("speed_fluctuation", 0.05))
    row = variant_row(results, v)
    if "flywheel_inertia" in row.index and np.isfinite(row["flywheel_inertia"]):
        E = np.concatenate([[0.0], np.cumsum((tau - mean) * 2.0 * np.pi / S)])[:-1]
        ax1.text(0.01, 0.97, f"flywheel {row['flywheel_inertia']:.3g} kg·m² holds ω within ±{100 * cs / 2:g} %: "
                             f"ΔE = {E.max() - E.min():.3g} J", transform=ax1.transAxes, va="top",
                 fontsize=LEGEND_SIZE)
        ax1b = ax1.twinx()
        ax1b.plot(x, E, color="tab:purple", lw=1.0, ls=":", label="∫(τ − mean)dθ")
        ax1b.set_ylabel("energy excess E(θ) [J]", fontsize=LABEL_SIZE - 1, color="tab:purple")
    ax1.set_ylabel("torque [N·m]", fontsize=LABEL_SIZE)
    ax1.grid(True, lw=0.4, alpha=0.5)
    ax1.axhline(0.0, color="0.3", lw=0.6)
    ax1.legend(loc="best", fontsize=LEGEND_SIZE, framealpha=0.9)  # where it covers the least of the curves
    style_axes(ax1, f"motor torque: peak |τ| {np.max(np.abs(tau)):.4g} N·m, rms {np.sqrt(np.mean(tau ** 2)):.4g} N·m",
               title_size=LABEL_SIZE)
    joints = results.force_joints
    for j, c in zip(joints, _cmap(len(joints))):
        f = np.asarray(results.force(v, j))
        ax2.plot(x, np.hypot(f[:, 0], f[:, 1]), color=c, lw=1.6, label=f"joint {j}")
    if not joints:
        ax2.text(0.5, 0.5, "no joint reactions stored: list joints in [scene] force_joints", ha="center",
                 va="center", transform=ax2.transAxes)
    else:
        ax2.legend(loc="best", fontsize=LEGEND_SIZE, framealpha=0.9, ncol=2)
    ax2.set_ylabel("|reaction| [N]", fontsize=LABEL_SIZE)
    ax2.set_xlabel("crank angle θ [deg]", fontsize=LABEL_SIZE)
    ax2.set_xlim(0.0, 360.0)
    ax2.set_xticks(np.arange(0, 361, 60))
    ax2.grid(True, lw=0.4, alpha=0.5)
    style_axes(ax2, "joint reactions of leg 0 (the force of each joint's most loaded member on its pin)",
               title_size=LABEL_SIZE)
    opt = ", ".join(f"{k} {op[k]:g}" for k in ("rpm", "load", "gravity", "unit") if k in op)
    fig.suptitle(f"Forces of variant {v} of {results.filename.name} ({opt})", fontsize=TITLE_SIZE, wrap=True)
    return fig
