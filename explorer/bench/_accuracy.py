"""What accuracy costs in time: a sweep of method x steps x tolerance over assembling variants.

Per cell (one method, one number of crank steps S, one Newton tolerance) over the same variants:

* ``time_s`` — wall time of one batch solve of the foot positions (``velocities=False``, the closed
  form gives positions only), best of ``repeat`` runs after the kernels were warmed up; ``us_per_config``
  is that divided by variants x S;
* ``iterations`` — mean Newton iterations per configuration (block: summed over the 5 dyad solves of
  a configuration; dense: one per full 14 x 14 solve; auto: the vectorised closed-form first pass
  takes none, only the designs it leaves to Newton count; seed rows: see :mod:`._seeds`);
* ``foot_err_max`` / ``foot_err_median`` — the largest foot-position error against the exact closed
  form at the same S angles, over all variants solved ok (max) and the median of the per-variant
  maxima;
* ``foot_err_bound`` / ``promise_used`` — what the tolerance promises (Newton rows): every solved
  position within tolerance × the design's longest link; the bound for the longest variant, and the
  largest ratio over the variants of the measured foot error to that variant's own bound (≤ 1: the
  promise is kept);
* ``<metric>_err_max`` / ``_median`` — error of the gait metrics stride, flatness and stance_speed
  (``explorer.gait.compute_metrics``) computed from that cell's S samples, against the same metrics of
  a 14,400-step closed-form reference with exact (chain-rule) velocities: coarse sampling costs
  accuracy too, so the closed form at S steps has a metric error of its own;
* ``failed`` — variants not solved ok (the status counts are in ``note``); ``silent`` — variants marked
  ok in which some dyad sits, at some sample, on the other side of its parents than in the nominal
  design (a branch jump nothing flagged).

Variants: ``variants`` draws with every link and the crank scaled by uniform(1 − spread, 1 + spread)
(numpy ``default_rng(seed)``, all lengths first, then the cranks); only those that assemble at all
14,400 reference angles are kept. Slow rows (dense Newton, the seed formulations) run on the first
``dense_variants`` / ``seed_variants`` of them, and say so.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..kernels import TOLERANCE_RANGE, simulate, simulate_batch
from ..errors import UserError
from ..mechanism import Mechanism, load_mechanism
from ..plan import DYAD, make_plan
from . import _seeds

#: Newton tolerances swept by default: the whole accepted range (:data:`explorer.kernels.TOLERANCE_RANGE`).
DEFAULT_TOLERANCES: tuple[float, ...] = (1e-6, 1e-8, 1e-10, 1e-11, 1e-12)
DEFAULT_STEPS: tuple[int, ...] = (36, 90, 360, 1440)
REFERENCE_STEPS = 14_400
GAIT = ("stride", "flatness", "stance_speed")

COLUMNS = ("method", "steps", "tolerance", "variants", "ok", "failed", "silent", "time_s", "us_per_config",
           "iterations", "foot_err_max", "foot_err_median", "foot_err_bound", "promise_used",
           *(f"{m}_err_{s}" for m in GAIT for s in ("max", "median")), "note")


@dataclass
class AccuracyReport:
    """rows: one dict per cell (keys COLUMNS); meta: what was run, on what, and where."""

    rows: list = field(default_factory=list)
    meta: dict = field(default_factory=dict)


# -- the closed-form reference (plain numpy, positions and exact velocities) --------------------------
def _dyads(mech: Mechanism):
    """[(vertex, parent a, parent b, link a, link b, branch sign)] in plan order (all-dyad plans only)."""
    plan = make_plan(mech)
    if any(b.kind != DYAD for b in plan.blocks):
        raise UserError(f"{mech.name}: the accuracy bench needs a closed form, i.e. a plan made only of dyads")
    P0 = simulate(mech, 3, method="closed", velocities=False).positions[0]
    out = []
    for blk in plan.blocks:
        v = blk.vertices[0]
        la, lb = blk.links
        a = int(plan.link_b[la] if plan.link_a[la] == v else plan.link_a[la])
        b = int(plan.link_b[lb] if plan.link_a[lb] == v else plan.link_a[lb])
        g, w = P0[b] - P0[a], P0[v] - P0[a]
        out.append((v, a, b, la, lb, 1.0 if g[0] * w[1] - g[1] * w[0] >= 0.0 else -1.0))
    return out


def closed_form_reference(mech: Mechanism, lengths, crank, steps: int, vertex: str | None = None,
                          chunk: int = 48):
    """Exact positions and velocities dV/dθ of ``vertex`` (default: the foot) at θ_k = 2πk/steps.

    Sequential circle–circle intersections on the nominal design's branches, differentiated by the
    chain rule (no Newton, no finite differences), in numpy. lengths (N, n_links) in mech.links order,
    crank (N,). Returns (paths (N, S, 2), velocities (N, S, 2), ok (N,) True where every dyad assembles
    at every sample); rows that are not ok are NaN from the first sample that does not assemble.
    """
    dyads = _dyads(mech)
    L = np.atleast_2d(np.asarray(lengths, dtype=float))
    r = np.asarray(crank, dtype=float).reshape(-1)
    N = L.shape[0]
    out_v = mech.vertex_index(mech.foot if vertex is None else vertex)
    theta = 2.0 * np.pi * np.arange(steps) / steps
    cth, sth = np.cos(theta), np.sin(theta)
    cx, cy = mech.crank.center
    tip = mech.vertex_index(mech.crank.tip)
    paths = np.empty((N, steps, 2))
    vels = np.empty((N, steps, 2))
    ok = np.empty(N, dtype=bool)
    for i0 in range(0, N, chunk):
        Lc, rc = L[i0:i0 + chunk], r[i0:i0 + chunk, None]
        n = Lc.shape[0]
        P, V = {}, {}
        P[tip] = (cx + rc * cth, cy + rc * sth)
        V[tip] = (-rc * sth, rc * cth)
        zero = np.zeros((n, steps))
        for f, xy in mech.fixed.items():
            P[mech.vertex_index(f)] = (np.full((n, steps), xy[0]), np.full((n, steps), xy[1]))
            V[mech.vertex_index(f)] = (zero, zero)
        with np.errstate(invalid="ignore", divide="ignore"):
            for v, a, b, la, lb, s in dyads:
                (ax, ay), (bx, by) = P[a], P[b]
                (dax, day), (dbx, dby) = V[a], V[b]
                ra2, rb2 = Lc[:, la, None] ** 2, Lc[:, lb, None] ** 2
                gx, gy = bx - ax, by - ay
                dgx, dgy = dbx - dax, dby - day
                d2 = gx * gx + gy * gy
                x = 0.5 * (ra2 - rb2 + d2) / d2
                y2 = ra2 / d2 - x * x
                y = s * np.sqrt(np.where(y2 >= 0.0, y2, np.nan))
                P[v] = (ax + x * gx - y * gy, ay + x * gy + y * gx)
                dd2 = 2.0 * (gx * dgx + gy * dgy)
                dx = dd2 * (rb2 - ra2) / (2.0 * d2 * d2)
                dy = (-ra2 * dd2 / (d2 * d2) - 2.0 * x * dx) / (2.0 * y)
                V[v] = (dax + dx * gx + x * dgx - dy * gy - y * dgy, day + dx * gy + x * dgy + dy * gx + y * dgx)
        px, py = P[out_v]
        fine = np.isfinite(px) & np.isfinite(py)
        ok[i0:i0 + chunk] = fine.all(axis=1)
        # NaN from the first sample that does not assemble on (as the kernels report)
        dead = np.cumsum(~fine, axis=1) > 0
        paths[i0:i0 + chunk] = np.where(dead[..., None], np.nan, np.stack([px, py], axis=-1))
        vels[i0:i0 + chunk] = np.where(dead[..., None], np.nan, np.stack(V[out_v], axis=-1))
    return paths, vels, ok


def draw_variants(mech: Mechanism, n: int, spread: float, seed: int):
    """n variants: every link and the crank scaled by uniform(1 − spread, 1 + spread), lengths first."""
    rng = np.random.default_rng(seed)
    lengths = mech.lengths * (1.0 + rng.uniform(-spread, spread, (n, len(mech.links))))
    crank = mech.crank.radius * (1.0 + rng.uniform(-spread, spread, n))
    return lengths, crank


def _gait(paths, velocities, status, band):
    from ..gait import compute_metrics  # imported late: the gait package is optional for the kernels

    return compute_metrics(paths, velocities, status, names=list(GAIT), band=band)


# -- timing ------------------------------------------------------------------------------------------
def _best(fn, repeat: int, budget: float) -> float:
    """Best wall time of up to ``repeat`` runs of fn(), stopping early once ``budget`` seconds are spent."""
    best, spent, runs = math.inf, 0.0, 0
    while runs < max(1, repeat):
        t = time.perf_counter()
        fn()
        dt = time.perf_counter() - t
        best, spent, runs = min(best, dt), spent + dt, runs + 1
        if spent >= budget:
            break
    return best


# -- the sweep -----------------------------------------------------------------------------------------
def _flips(P, ok, dyads):
    """(N,) number of samples of each variant at which some dyad sits on the other side of its parents
    than the nominal design's (P: (N, S, nv, 2) positions; NaN samples do not count)."""
    out = np.zeros(P.shape[0], dtype=np.int64)
    for v, a, b, _, _, sign in dyads:
        g = P[:, :, b] - P[:, :, a]
        w = P[:, :, v] - P[:, :, a]
        cr = g[..., 0] * w[..., 1] - g[..., 1] * w[..., 0]
        out += np.sum(np.sign(cr) == -sign, axis=1)
    return np.where(ok, out, 0)


def _row(method, steps, tol, n, status, iters, time_s, P, foot, closed, metrics, ref_metrics, dyads, note="",
         longest=None):
    ok = status == 0
    row = dict(method=method, steps=int(steps), tolerance=tol, variants=int(n), ok=int(ok.sum()),
               failed=int((~ok).sum()), time_s=time_s, us_per_config=1e6 * time_s / (n * steps),
               iterations=float(np.mean(iters[ok]) / steps) if ok.any() and iters is not None else math.nan,
               silent=int(np.sum(_flips(P, ok, dyads) > 0)) if P is not None else 0)
    if ok.any():
        paths = P[:, :, foot] if P is not None else closed
        err = np.max(np.hypot(paths[ok, :, 0] - closed[ok, :, 0], paths[ok, :, 1] - closed[ok, :, 1]), axis=1)
        row["foot_err_max"] = float(np.max(err))
        row["foot_err_median"] = float(np.median(err))
        if longest is not None:  # the tolerance's promise: within tol × each design's longest link
            row["foot_err_bound"] = float(tol * np.max(longest[ok]))
            row["promise_used"] = float(np.max(err / (tol * longest[ok])))
        for m in GAIT:  # (NaN where a metric is undefined, e.g. flatness of a one-sample stance)
            e = np.abs(metrics[m][ok] - ref_metrics[m][ok])
            fin = np.isfinite(e)
            row[f"{m}_err_max"] = float(np.max(e[fin])) if fin.any() else math.nan
            row[f"{m}_err_median"] = float(np.median(e[fin])) if fin.any() else math.nan
    else:
        row.update({k: math.nan for k in COLUMNS if k.endswith(("_max", "_median"))})
    row.setdefault("foot_err_bound", math.nan)
    row.setdefault("promise_used", math.nan)
    counts = np.bincount(status.astype(np.int64), minlength=5)
    names = {1: "assembly", 2: "branch", 3: "no-convergence", 4: "invalid"}
    fails = ", ".join(f"{int(counts[k])} {names[k]}" for k in sorted(names) if counts[k])
    if fails:
        note = f"{note}; failed: {fails}" if note else f"failed: {fails}"
    if not ok.any():
        note = f"{note}; NOTHING CONVERGED"
    row["note"] = note
    return row


def accuracy_sweep(mech: Mechanism | str = "jansen", *, variants: int = 1000, spread: float = 0.02, seed: int = 1,
                   tolerances=DEFAULT_TOLERANCES, steps=DEFAULT_STEPS, methods=("block", "auto", "dense", "closed"),
                   dense_variants: int = 100, seed_solvers=tuple(_seeds.SOLVERS), seed_variants: int = 50,
                   seed_steps=(360,), reference_steps: int = REFERENCE_STEPS, repeat: int = 3,
                   time_budget: float = 0.5, max_iterations: int = 50, seed_max_iterations: int = 500,
                   band: float = 0.01, progress=None) -> AccuracyReport:
    """Run the sweep (see the module docstring). ``progress``: a callable taking one line, or None."""
    mech = load_mechanism(mech) if isinstance(mech, str) else mech
    say = progress or (lambda line: None)
    lo, hi = TOLERANCE_RANGE
    for t in tolerances:
        if not (lo <= float(t) <= hi):
            raise UserError(f"tolerances: each must be from {lo:g} to {hi:g} (the accepted range), got {t!r}")
    for s in (*steps, *seed_steps):
        if int(s) < 3:
            raise UserError(f"steps: each must be an integer >= 3, got {s!r}")
    if variants < 1:
        raise UserError(f"variants: expected at least 1, got {variants}")
    if not 0.0 <= spread < 1.0:
        raise UserError(f"spread: expected a fraction in [0, 1), got {spread}")
    for m in methods:
        if m not in ("block", "auto", "dense", "closed"):
            raise UserError(f"methods: expected block, auto, dense or closed, got {m!r}")
    if seed_solvers and _seeds.jansen_layout(mech) is None:
        say("seed rows skipped: the seed formulations are written for the Jansen leg only")
        seed_solvers = ()

    t_start = time.perf_counter()
    lengths, crank = draw_variants(mech, variants, spread, seed)
    say(f"reference: closed form at {reference_steps} steps for {variants} variants")
    assembles = np.zeros(variants, dtype=bool)
    ref_metrics = {m: np.full(variants, np.nan) for m in GAIT}
    for i in range(0, variants, 100):  # in chunks: 100 variants x 14,400 steps is 23 MB a path
        ref_p, ref_v, ok = closed_form_reference(mech, lengths[i:i + 100], crank[i:i + 100], reference_steps)
        assembles[i:i + 100] = ok
        for m, val in _gait(ref_p, ref_v, (~ok).astype(np.int8), band).items():
            ref_metrics[m][i:i + 100] = val
    keep = np.flatnonzero(assembles)
    if len(keep) == 0:
        raise UserError("no variant assembles all round: lower --spread")
    lengths, crank = lengths[keep], crank[keep]
    ref_metrics = {m: v[keep] for m, v in ref_metrics.items()}
    N = len(keep)
    n_dense, n_seed = min(dense_variants, N), min(seed_variants, N)
    dyads = _dyads(mech)
    foot = mech.vertex_index(mech.foot)

    import numba

    report = AccuracyReport(meta=dict(
        mechanism=mech.name, variants_drawn=variants, variants_assembled=N, spread=spread, seed=seed,
        reference_steps=reference_steps, dense_variants=n_dense, seed_variants=n_seed, repeat=repeat,
        threads=numba.get_num_threads(), band=band, max_iterations=max_iterations,
        seed_max_iterations=seed_max_iterations, longest_link_max=float(lengths.max()),
        reference_metrics_median={m: float(np.median(ref_metrics[m])) for m in GAIT}))

    # warm every kernel up (compile, or load from the cache) outside the timings
    for m in methods:
        simulate_batch(mech, lengths[:2], crank[:2], 8, method=m, velocities=False)
        if m != "closed":
            simulate_batch(mech, lengths[:2], crank[:2], 8, method=m, velocities=True)
    for s in seed_solvers:
        _seeds.solve_seed(s, mech, lengths[:2], crank[:2], 8, velocities=True)

    all_steps = sorted(set(int(s) for s in steps) | (set(int(s) for s in seed_steps) if seed_solvers else set()))
    for S in all_steps:
        # the exact foot at the same S angles (kernel closed form), and the closed form's own gait error
        closed = simulate_batch(mech, lengths, crank, S, method="closed", velocities=False)
        closed_p = closed.paths[mech.foot]
        if S in steps and "closed" in methods:
            t = _best(lambda: simulate_batch(mech, lengths, crank, S, method="closed", velocities=False), repeat,
                      time_budget)
            cp, cv, _ = closed_form_reference(mech, lengths, crank, S)
            met = _gait(cp, cv, closed.status, band)
            report.rows.append(_row("closed", S, math.nan, N, closed.status, None, t, None, foot, closed_p, met,
                                    ref_metrics, dyads, "exact circle-circle; velocities (metrics only) by chain rule"))
            say(_progress_line(report.rows[-1]))
        for m in (x for x in methods if x != "closed") if S in steps else ():
            n = n_dense if m == "dense" else N
            Ls, rs = lengths[:n], crank[:n]
            for tol in tolerances:
                kw = dict(method=m, tolerance=float(tol), max_iterations=max_iterations)
                t = _best(lambda: simulate_batch(mech, Ls, rs, S, velocities=False, **kw), repeat, time_budget)
                b = simulate_batch(mech, Ls, rs, S, velocities=True, vertices="all", **kw)
                met = _gait(b.paths[mech.foot], b.velocities[mech.foot], b.status, band)
                note = f"first {n} variants (dense is slow)" if n < N else ""
                P = np.stack([b.paths[v] for v in mech.vertices], axis=2)
                report.rows.append(_row(m, S, float(tol), n, b.status, b.iterations, t, P, foot, closed_p[:n], met,
                                        {k: v[:n] for k, v in ref_metrics.items()}, dyads, note,
                                        longest=Ls.max(axis=1)))
                say(_progress_line(report.rows[-1]))
        if S in seed_steps:
            for s in seed_solvers:
                Ls, rs = lengths[:n_seed], crank[:n_seed]
                for tol in tolerances:
                    kw = dict(tolerance=float(tol), max_iterations=seed_max_iterations)
                    t = _best(lambda: _seeds.solve_seed(s, mech, Ls, rs, S, **kw), repeat, time_budget)
                    P, v, st, _, its = _seeds.solve_seed(s, mech, Ls, rs, S, velocities=True, **kw)
                    met = _gait(P[:, :, foot], v, st, band)
                    note = "; ".join(x for x in (f"first {n_seed} variants", _seeds.NOTES.get(s, "")) if x)
                    report.rows.append(_row(s, S, float(tol), n_seed, st, its, t, P, foot, closed_p[:n_seed], met,
                                            {k: val[:n_seed] for k, val in ref_metrics.items()}, dyads, note))
                    say(_progress_line(report.rows[-1]))
    report.meta["wall_s"] = time.perf_counter() - t_start
    return report


# -- rendering -------------------------------------------------------------------------------------------
def _g(x, fmt=".1e"):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return format(x, fmt)


def _progress_line(row) -> str:
    return (f"{row['method']:>19s} S={row['steps']:<5d} tol={_g(row['tolerance'], '.0e'):>6s} "
            f"{row['us_per_config']:8.3f} us/config  foot err {_g(row['foot_err_max'])}")


def format_table(report: AccuracyReport) -> str:
    """The report as a plain-text table (one line per cell), with a header saying what was run."""
    m = report.meta
    lines = [
        f"accuracy vs time: {m['mechanism']}, {m['variants_assembled']} of {m['variants_drawn']} variants "
        f"(±{100 * m['spread']:g} %, seed {m['seed']}) assemble all round; "
        f"reference: closed form at {m['reference_steps']} steps",
        f"time: foot positions only, best of {m['repeat']} (or of fewer once 0.5 s is spent), "
        f"{m['threads']} threads; dense on the first {m['dense_variants']}, seed rows on the first "
        f"{m['seed_variants']} variants; Newton capped at {m['max_iterations']} iterations per step "
        f"({m['seed_max_iterations']} for the seed rows)",
        "foot err: max over the variants solved ok of |foot − closed form| at the same angles (length units); "
        f"stride / flatness / speed: MEDIAN over them of |metric − the {m['reference_steps']}-step reference|",
        f"(median reference values: stride {m['reference_metrics_median']['stride']:.2f}, flatness "
        f"{m['reference_metrics_median']['flatness']:.2e}, stance_speed "
        f"{m['reference_metrics_median']['stance_speed']:.2f}; the max errors are in the CSV: they are dominated "
        "by variants whose stance flips to another run of samples)",
        "iter: mean Newton iterations per configuration (block: summed over its 5 dyads; seed001-sequential: over "
        "its four 2x2 systems); tol: every solved position within tol x the design's longest link (for the seed "
        "rows: a bound on every closure residual |f_i|, length units); bound: that promise for the longest "
        "variant; used: the largest foot err / its own variant's bound (<= 1: the promise is kept)",
        "",
    ]
    head = (f"{'method':>19s} {'steps':>5s} {'tol':>6s} {'n':>5s} {'fail':>4s} {'us/cfg':>8s} {'iter':>5s} "
            f"{'foot err':>8s} {'bound':>8s} {'used':>8s} {'stride~':>8s} {'flat~':>8s} {'speed~':>8s}  note")
    lines += [head, "-" * len(head)]
    last = None
    for r in report.rows:
        if last is not None and r["method"] != last:
            lines.append("")
        last = r["method"]
        note = "; ".join(x for x in (r["note"], f"{r['silent']} ok but off branch (SILENT JUMP)" if r["silent"] else "")
                         if x)
        lines.append(
            f"{r['method']:>19s} {r['steps']:5d} {_g(r['tolerance'], '.0e'):>6s} {r['variants']:5d} {r['failed']:4d} "
            f"{r['us_per_config']:8.3f} {_g(r['iterations'], '5.2f'):>5s} {_g(r['foot_err_max']):>8s} "
            f"{_g(r.get('foot_err_bound')):>8s} {_g(r.get('promise_used')):>8s} "
            f"{_g(r['stride_err_median']):>8s} {_g(r['flatness_err_median']):>8s} "
            f"{_g(r['stance_speed_err_median']):>8s}  "
            f"{note}")
    lines.append("")
    lines.append("seed rows: " + "; ".join(f"{k}: {v}" for k, v in _seeds.DESCRIPTIONS.items()))
    lines.append(f"total wall time {report.meta.get('wall_s', math.nan):.1f} s")
    return "\n".join(lines)


def write_csv(report: AccuracyReport, path) -> Path:
    """One row per cell, columns COLUMNS (NaN where a value does not apply)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS)
        w.writeheader()
        for r in report.rows:
            w.writerow({k: r.get(k, "") for k in COLUMNS})
    return path


def read_csv(path, meta: dict | None = None) -> AccuracyReport:
    """An :class:`AccuracyReport` read back from :func:`write_csv`'s file (to draw it again without running
    the sweep). ``meta``: what the CSV does not hold (mechanism, spread, threads, …) for the plot's title;
    ``variants_assembled`` defaults to the largest ``variants`` of its rows."""
    ints = {"steps", "variants", "ok", "failed", "silent"}
    rows = []
    with Path(path).open(newline="") as fh:
        for r in csv.DictReader(fh):
            row = {}
            for k, v in r.items():
                if k in ("method", "note"):
                    row[k] = v
                elif k in ints:
                    row[k] = int(float(v)) if v not in ("", "nan") else 0
                else:
                    row[k] = float(v) if v != "" else math.nan
            rows.append(row)
    meta = dict(meta or {})
    meta.setdefault("variants_assembled", max((r["variants"] for r in rows), default=0))
    return AccuracyReport(rows=rows, meta=meta)


def plot(report: AccuracyReport, path) -> Path:
    """Three log-log panels: max foot-position error vs Newton tolerance at one step count (seed 001's
    RMSE-vs-tolerance figure), max foot-position error vs time per configuration, and median stride error
    vs time per design cycle (where coarse sampling shows). One colour per method, one marker per step
    count, each said once in the legends on the right; a method that never converged is named there.
    Errors of exactly 0 (the closed form against itself) are drawn at 1e-16."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    floor = 1e-16
    rows = report.rows
    methods = list(dict.fromkeys(r["method"] for r in rows))
    steps = sorted(set(r["steps"] for r in rows))
    import matplotlib
    tab10 = matplotlib.colormaps["tab10"]
    colours = {m: tab10(i % 10) for i, m in enumerate(methods)}
    markers = dict(zip(steps, "os^Dvx*+"))
    title_size, label_size, tick_size, legend_size = 13, 12, 10.5, 10
    fig = Figure(figsize=(17.5, 5.8), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 3)
    # (a) error vs tolerance at the step count the seed rows ran at (or the largest common one)
    with_tol = [r for r in rows if not math.isnan(r["tolerance"])]

    def coverage(steps):
        return len({r["method"] for r in with_tol if r["steps"] == steps}), steps

    s_a = max({r["steps"] for r in with_tol}, key=coverage) if with_tol else None
    ax = axes[0]
    never = []
    for m in methods:
        sel = sorted((r for r in with_tol if r["method"] == m and r["steps"] == s_a), key=lambda r: r["tolerance"])
        good = [r for r in sel if r["ok"] > 0]
        if sel and not good:
            never.append(m)
            continue
        if good:
            ax.plot([r["tolerance"] for r in good], [max(r["foot_err_max"], floor) for r in good],
                    marker=markers.get(s_a, "o"), ms=6, lw=1.8, color=colours[m])
    bounds = sorted({(r["tolerance"], r["foot_err_bound"]) for r in with_tol
                     if r["steps"] == s_a and r.get("foot_err_bound") == r.get("foot_err_bound")
                     and r.get("foot_err_bound") is not None})
    if bounds:  # what the tolerance promises for block and dense: tol × the longest link
        ax.plot([b[0] for b in bounds], [b[1] for b in bounds], "k--", lw=1.4,
                label="promised bound (block, dense):\ntolerance × longest link")
    if any(r["method"].startswith("seed") for r in with_tol):
        ax.plot([], [], " ", label="seed rows: the tolerance bounds\nthe closure residual [model units]")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=legend_size, loc="upper left")
    ax.set_title(f"(a) max foot error vs Newton tolerance, {s_a} steps", fontsize=title_size)
    ax.set_xlabel("Newton tolerance [position error / longest link]", fontsize=label_size)
    ax.set_ylabel("max |foot − closed form| [model units]", fontsize=label_size)
    # (b), (c): every cell
    for ax, key, per_cycle, title, ylabel in (
            (axes[1], "foot_err_max", False, "(b) max foot error vs time", "max |foot − closed form| [model units]"),
            (axes[2], "stride_err_median", True, "(c) median stride error vs time",
             "median |stride − 14,400-step reference| [model units]")):
        for m in methods:
            for s in steps:
                sel = [r for r in rows if r["method"] == m and r["steps"] == s and r["ok"] > 0]
                if not sel:
                    continue
                x = [r["us_per_config"] * (s / 1e3 if per_cycle else 1.0) for r in sel]
                y = [max(r[key], floor) for r in sel]
                ax.scatter(x, y, marker=markers.get(s, "o"), color=colours[m], s=42, alpha=0.85, lw=0)
        ax.set_title(title, fontsize=title_size)
        ax.set_xlabel("time per design cycle [ms]" if per_cycle else
                      "time per configuration [µs], one crank angle of one design", fontsize=label_size)
        ax.set_ylabel(ylabel, fontsize=label_size)
    for ax in axes:
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.grid(True, which="major", alpha=0.35)
        ax.grid(True, which="minor", alpha=0.12)
        ax.tick_params(labelsize=tick_size)
    # what the colours and the markers mean, once, on the right
    method_handles = [Line2D([], [], color=colours[m], marker="o", lw=0, ms=8,
                             label=m + (": never converged" if m in never else "")) for m in methods]
    step_handles = [Line2D([], [], color="0.3", marker=markers[s], lw=0, ms=8, label=f"{s} steps per cycle")
                    for s in steps]
    fig.legend(handles=method_handles, title="colour: method", fontsize=legend_size, title_fontsize=legend_size + 0.5,
               loc="outside right upper", alignment="left", frameon=False)
    fig.legend(handles=step_handles, title="marker: crank steps", fontsize=legend_size,
               title_fontsize=legend_size + 0.5, loc="outside right lower", alignment="left", frameon=False)
    m = report.meta
    what = [f"{m['variants_assembled']:,} variants" if "variants_assembled" in m else None,
            f"±{100 * m['spread']:g} %" if "spread" in m else None,
            f"{m['threads']} threads" if "threads" in m else None]
    fig.suptitle(f"What accuracy costs in time: {m.get('mechanism', 'the mechanism')}, "
                 + ", ".join(w for w in what if w) + "; an error of exactly 0 is drawn at 1e-16",
                 fontsize=title_size + 1)
    fig.savefig(path, dpi=100)
    return path
