"""``explorer show RESULTS --variant N [--format table|csv|json]``: one variant's design parameters (lengths,
crank, pivots, ...) against the nominal, its metrics and ranks, its status; ``--format csv|json`` prints its
metric table alone, for a program to read."""

from __future__ import annotations

import math
import sys

from ._args import (add_format, add_include_screened, add_old_positional_variant, add_units, add_variant, add_vs,
                    chosen_variant, parse_variant)
from ._rank import add_yield_arguments, check_yield_arguments, yields
from ._format import better, results_si, table

__all__ = ["chosen_variant", "parameter_lines", "parameter_records", "parse_variant", "register", "run"]


def register(sub) -> None:
    p = sub.add_parser(
        "show", help="one variant of a results file: design parameters vs the nominal, metrics with their ranks, status",
        description="Print one variant of a results file: every design parameter (each link length, the crank "
                    "radius and centre, the ground pivots' and body joints' coordinates) against the nominal "
                    "design (absolute change, and % of the nominal for a length or of the mechanism's size for "
                    "a coordinate; parameters the study kept fixed are marked), each stored metric with the "
                    "reference design's value (--vs, default the nominal), the change, and its rank among the "
                    "variants `explorer rank` ranks (1 = best in the metric's natural direction; ties share a "
                    "rank), the walker score and its rank, a verdict against the reference, its status "
                    "(for a failed variant: the crank angle and vertex where it failed) and whether it passes the "
                    "buildability screen (and if not, why). Variant 0 is the nominal. --format csv or json prints "
                    "one table alone to stdout: the metric table, one row per metric, or with --table "
                    "parameters the design parameters, one row per parameter.",
        epilog="examples: explorer show R.h5 --variant 3; explorer show R.h5 --variant 3 --vs 7 --format csv > v3.csv")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    add_variant(p, "the variant to show, 0 to N-1 (0 = the nominal design)")
    add_old_positional_variant(p)
    add_vs(p, "the reference design every metric is compared with (default 0: the nominal)")
    add_yield_arguments(p, "this variant and the reference")
    add_include_screened(p, "rank among every ok variant, as `explorer rank --include-screened` (default: among "
                            "the buildable ones, as `explorer rank`)")
    add_units(p)
    add_format(p, what="csv and json: one table alone (--table), numbers unrounded, to stdout")
    p.add_argument("--table", choices=TABLES, default=None,
                   help="with --format csv|json, the table printed: metrics (default; one row per metric: metric, "
                        "value, reference, change, change_pct, unit, rank, ranked_among) or parameters (one row per "
                        "design parameter: parameter, label, kind, value, nominal, change, change_pct, pct_of, unit, "
                        "perturbed; against the nominal design, in model units or mm with --units si)")
    p.set_defaults(func=run)


#: The tables ``show --format csv|json`` prints (``--table``).
TABLES = ("metrics", "parameters")


def slider_labels(mech) -> dict[str, str]:
    """{parameter: label} of the sliders' parameters: a ground line's point ("slider ram point x") and
    direction ("slider ram direction x"), a slot's offset ("slot block offset")."""
    out = {}
    for sl in mech.sliders:
        if sl.ground:
            for a in "xy":
                out[f"{sl.name}.{a}"] = f"slider {sl.name} point {a}"
                out[f"{sl.name}.d{a}"] = f"slider {sl.name} direction {a}"
        else:
            out[f"{sl.name}.offset"] = f"slot {sl.name} offset"
    return out


def parameter_records(mech, design: dict, nominal: dict, perturbed, mm_per_unit: float | None = None) -> list[dict]:
    """Every design parameter of ``mech`` (``Mechanism.parameters`` order) as one record: ``parameter``
    (its name), ``label`` (how the table says it), ``kind`` ("length", "coordinate", or "direction": a
    ground line's, which counts only by its angle), the variant's ``value`` (``design``,
    :meth:`Results.design`), the ``nominal`` (``nominal``, else the mechanism's), the ``change``,
    ``change_pct`` (% of the nominal for a length, of the mechanism's size for a coordinate, whose own
    value is no scale; None for a direction or a zero nominal), ``pct_of`` ("nominal", "size" or None),
    ``unit`` ("model", "mm" with ``mm_per_unit``, mm per model unit, or "" for a direction) and
    ``perturbed`` (False: the study kept it fixed)."""
    k = 1.0 if mm_per_unit is None else float(mm_per_unit)
    size = mech.size
    pivots = {f"{v}.{a}" for v in mech.fixed for a in "xy"}
    sliders = slider_labels(mech)
    out = []
    for p, mech_nominal in mech.parameters().items():
        nom = float(nominal.get(p, mech_nominal))
        val = float(design.get(p, nom))
        d = val - nom
        kk, unit = k, ("model" if mm_per_unit is None else "mm")
        if mech.parameter_kind(p) == "length":
            kind, pct, of = "length", (100.0 * d / nom if nom else None), "nominal"
            label = p if p == "crank" else f"link {p}"
        elif p in sliders and p.endswith((".dx", ".dy")):  # a direction: no unit, never in mm, no % of size
            kind, pct, of, kk, unit = "direction", None, None, 1.0, ""
            label = sliders[p]
        else:
            kind, pct, of = "coordinate", 100.0 * d / size, "size"
            label = (f"pivot {p}" if p in pivots else sliders[p] if p in sliders
                     else p if p in ("crank.x", "crank.y") else f"joint {p}")
        out.append({"parameter": p, "label": label, "kind": kind, "value": val * kk, "nominal": nom * kk,
                    "change": d * kk, "change_pct": pct, "pct_of": of if pct is not None else None, "unit": unit,
                    "perturbed": p in perturbed})
    return out


def parameter_lines(mech, design: dict, nominal: dict, perturbed, mm_per_unit: float | None = None) -> list[str]:
    """The table of every design parameter of ``mech`` (:func:`parameter_records`, the same arguments): the
    variant's value, the nominal, the change, and the change in % of the nominal (a length) or of the
    mechanism's size (a coordinate). Values in model units, or in mm with ``mm_per_unit`` (mm per model
    unit: ``--units si``)."""
    unit = "" if mm_per_unit is None else " [mm]"
    rows = [("parameter", "value" + unit, "nominal" + unit, "change" + unit, "change %")]
    for r in parameter_records(mech, design, nominal, perturbed, mm_per_unit):
        pct = ("-" if r["change_pct"] is None else
               f"{r['change_pct']:+.3f} %" + (" of size" if r["pct_of"] == "size" else ""))
        label = r["label"] + ("" if r["perturbed"] else " (fixed)")
        if r["kind"] == "direction" and unit:
            label += " (no unit)"
        rows.append((label, f"{r['value']:.4f}", f"{r['nominal']:.4f}", f"{r['change']:+.4f}", pct))
    out = table(rows, (False, True, True, True, True))
    if any(mech.parameter_kind(p) == "coordinate" for p in mech.parameters()):
        k = 1.0 if mm_per_unit is None else float(mm_per_unit)
        out.append(f"(a coordinate's change is in % of the mechanism's size, {mech.size * k:g}{' mm' if unit else ''}: "
                   f"its longest link or body span)")
    return out


#: Below this yield `show` warns that the design may not survive the workshop.
YIELD_WARNING = 0.95


def _robustness_lines(res, args, v: int, ref: int, row, ref_row) -> list[str]:
    """Will it survive the workshop: the variant's and the reference's yield ± binomial standard error
    (re-solved with --yield [TOL], else the stored metric with the study's [robustness]), and a warning
    under :data:`YIELD_WARNING`. [] when neither is asked for nor stored."""
    from ..analysis import results_robustness
    check_yield_arguments(args)
    if args.yield_tol is not None:
        ys, rb = yields(res, args, [v, ref])
        how = "re-solved now"
    elif "yield" in res.metric_names:
        rb = results_robustness(res)
        ys = {}
        for k, r in ((v, row), (ref, ref_row)):
            p = float(r["yield"])
            ys[k] = (p, math.sqrt(p * (1 - p) / rb.copies) if math.isfinite(p) else math.nan)
        how = "stored by the study"
    else:
        return []
    p, se = ys[v]
    ref_label = "the nominal" if ref == 0 else f"variant {ref}"
    out = [f"yield (will it survive the workshop?): {p:.3f} ± {se:.3f} of copies turn and pass the screen, each cut "
           f"{rb.describe()}; {ref_label}: {ys[ref][0]:.3f} ± {ys[ref][1]:.3f} ({how}; ± one binomial standard "
           f"error)"]
    if math.isfinite(p) and p < YIELD_WARNING:
        out.append(f"warning: only {100 * p:.1f} % of copies cut to that tolerance walk: cut tighter (`explorer "
                   f"tolerance` finds how tight) or choose a design with a higher yield")
    return out


def _physics_lines(res, v: int, row) -> list[str]:
    """The physics check of this design beside its kinematic figures, with a verdict
    (:func:`explorer.physics._compare.show_lines`); [] for a file no physics check has written to."""
    if "physics_travel" not in res.metric_names or res.operating is None or res.operating.unit is None:
        return []
    from ..physics import stored_physics
    from ..physics._compare import show_lines
    return show_lines(row, res.operating, stored_physics(res), v, res.filename)


def warn_ignored_metrics(res) -> None:
    """One line on stderr per dataset under /metrics that is not one value per variant (shape (N,)): the
    results reader leaves it out of every frame, which a verb showing "each stored metric" must not do
    silently."""
    g = res.file.get("metrics")
    if g is None:
        return
    for key in g.keys():
        shape = getattr(g[key], "shape", None)
        if shape != (res.n_variants,):
            what = f"has shape {shape}" if shape is not None else "is not a dataset"
            print(f"explorer: warning: {res.filename}: metrics/{key} {what}, not ({res.n_variants},) (one value per "
                  f"variant): ignored", file=sys.stderr)


def run(args) -> int:
    from ..gait import DEFAULT_WEIGHTS, METRICS, SPEED, metric, operating_line, verdict
    from ..study import open_results  # with explorer's re-solver (store only reads files)

    from ..errors import UserError

    chosen = chosen_variant(args, "show", "explorer show RESULTS --variant N")
    machine = getattr(args, "format", "table") != "table"
    which = getattr(args, "table", None)
    if which is not None and not machine:
        raise UserError(f"show: --table {which} chooses the table --format csv or json prints; the text format "
                        f"(--format table) shows every table")
    if machine and args.yield_tol is not None:
        raise UserError(f"show: --format {args.format} prints the metric table alone; --yield's lines are not part of "
                        f"it (use --format table, or `explorer rank --yield --format {args.format}`)")
    with open_results(args.results) as res:  # every figure below is a Results call; this verb only formats
        warn_ignored_metrics(res)
        name, n = res.filename, res.n_variants
        v = parse_variant(chosen, n, name)
        ref = parse_variant(args.vs, n, name)
        # the two rows shown, read by themselves; the ranks and the score are counted over the file in blocks of
        # rows (a million-design file's frame is never held whole)
        df = res.frame_rows([v, ref])
        si = results_si(res, df, args.units)  # --units si: the figures shown, converted (ranks stay the file's)
        row = res.row(v, frame=df)
        design = res.design(v, frame=df)
        ranks = res.metric_ranks(v, include_screened=args.include_screened)
        ref_row = res.row(ref, frame=df)
        shown, shown_ref = (row, ref_row) if si is None else (res.row(v, frame=si.frame), res.row(ref, frame=si.frame))
        # the walker score, as `explorer rank` computes it, where the file stores every metric it weighs
        scored = (res.rank(top=None, include_screened=args.include_screened, columns=["variant"])
                  if set(DEFAULT_WEIGHTS) <= set(res.metric_names) else None)
        nominal = res.nominal
        perturbed = set(res.perturbed)
        mech = res.mechanism
        study = res.study.get("study", {})
        band = res.band
        metrics = list(res.metric_names)
        res_operating = res.study.get("operating") if res.study.get("scene", {}).get("forces") else None
        body = res.body
        robust = _robustness_lines(res, args, v, ref, row, ref_row)
        physics = _physics_lines(res, v, row)

    # variant 0 is the nominal of a sampled study; of an optimisation only when the nominal lies in its bounds
    is_nominal = v == 0 and all(row[p] == nominal[p] for p in perturbed if p in row.index and p in nominal)
    lines = [f"{name}: variant {v} of {n:,}" + (" (the nominal design)" if is_nominal else "")
             + f"; study {study.get('name', '?')!r}, mechanism {mech.name!r}, {res.steps} steps"]
    if "generation" in df.columns:
        lines.append(f"generation: {int(row['generation'])} of the optimisation (explorer optimize)")
    status = str(row["status"])
    if status == "ok":
        lines.append("status: ok")
    elif status == "not-run":
        lines.append("status: not-run (the run was interrupted before this variant; finish it with --resume)")
    else:
        th = float(row["fail_theta"])
        if not math.isfinite(th):
            at = ""
        elif mech.crank is None:  # a path driver fails at a time
            at = f" at t = {th:.6g} s"
        else:
            at = f" at θ = {th:.4f} rad ({math.degrees(th):.2f}°)"
        vert = f", vertex {row['fail_vertex']}" if row["fail_vertex"] is not None else ""
        lines.append(f"status: failed ({status}){at}{vert}")

    # -- design parameters -------------------------------------------------------------------------------
    if machine and which == "parameters":
        _print_table(parameter_records(mech, design, nominal, perturbed,
                                       None if si is None else si.operating.unit * 1000.0), args.format,
                     text=("parameter", "label", "kind", "pct_of", "unit"), flags=("perturbed",))
        return 0
    lines.append("")
    lines += parameter_lines(mech, design, nominal, perturbed,
                             None if si is None else si.operating.unit * 1000.0)

    # -- metrics -----------------------------------------------------------------------------------------
    if "screen" in row.index and status == "ok":
        lines.append("buildability screen: " + ("pass" if row["screen"] == "pass" else
                                                 f"screened out ({row['screen']}); `explorer rank` leaves it out "
                                                 f"unless --include-screened"))
    lines.append("")
    if machine and not metrics:
        raise UserError(f"{name}: --format {args.format} prints the metric table, and this file stores no metrics "
                        f"(use --format table for the design parameters and status)")
    if not metrics:
        lines.append("no gait metrics: the mechanism is driven along a path, not by a crank, so it has no gait"
                     if mech.crank is None else f"no gait metrics stored; compute them with `explorer metrics {name}`")
        print("\n".join(lines))
        return 0
    pool = "ok" if args.include_screened else "buildable"
    n_pool = next((r[1] for r in ranks.values() if r is not None), None)
    ref_label = "nominal" if ref == 0 else f"variant {ref}"
    rows = [("metric", "value", ref_label, "change", "change %", "unit",
             f"rank among the {n_pool if n_pool is not None else '-'} {pool} variants (band {band:g})")]
    records = []  # the same table for --format csv|json: numbers unrounded, None where the text says "-"
    order = [m for m in METRICS if m in metrics] + [m for m in metrics if m not in METRICS]
    if si is not None and SPEED in si.units:  # the walking speed follows travel (it ranks as travel does)
        order.insert(order.index("travel") + 1, SPEED)
    for m in order:
        x = float(shown[m])
        r0 = float(shown_ref[m]) if str(ref_row["status"]) == "ok" else math.nan
        info = metric("travel" if m == SPEED else m)
        rtext = f"{r0:.6g}" if math.isfinite(r0) else "-"
        if status != "ok":
            text, change, pct = "-", "-", "-"
            rank = "- (variant failed)" if status != "not-run" else "- (not run)"
        elif not math.isfinite(x):
            text, change, pct, rank = "nan", "-", "-", "- (undefined for this variant)"
            if info is not None and info.group == "physics":
                rank = "- (not checked: `explorer physics`)"
        else:
            text = f"{x:.6g}"
            change = f"{x - r0:+.4g}" if math.isfinite(r0) else "-"
            pct = f"{100.0 * (x - r0) / abs(r0):+.1f} %" if math.isfinite(r0) and r0 != 0 else "-"
            r = ranks.get("travel" if m == SPEED else m)
            if r is None:
                rank = "- (screened out: `explorer rank` leaves it out)" if not args.include_screened else "-"
            else:
                rank = f"rank {r[0]:,} of {r[1]:,} ({better(info.direction)})"
        unit = si.units.get(m, "") if si is not None else (info.unit if info is not None else "")
        rows.append((m, text, rtext, change, pct, unit, rank))
        if machine:
            fin = status == "ok" and math.isfinite(x)
            r = ranks.get("travel" if m == SPEED else m) if fin else None
            records.append({"metric": m, "value": x if fin else None, "reference": r0 if math.isfinite(r0) else None,
                            "change": x - r0 if fin and math.isfinite(r0) else None,
                            "change_pct": 100.0 * (x - r0) / abs(r0) if fin and math.isfinite(r0) and r0 != 0 else None,
                            "unit": unit, "rank": int(r[0]) if r is not None else None,
                            "ranked_among": int(r[1]) if r is not None else None})
    if machine:
        _print_records(records, args.format)
        return 0
    lines += table(rows, (False, True, True, True, True, False, False))
    # -- the walker score and a verdict against the reference ------------------------------------------
    if scored is not None and "score" in scored.columns:
        where_v = scored.index[scored["variant"] == v]
        where_r = scored.index[scored["variant"] == ref]
        lines.append("")
        if len(where_v):
            sv = scored.loc[where_v[0]]
            text = f"walker score {sv['score']:.3f}, rank {int(sv['rank']):,} of {len(scored):,} {pool} variants"
        else:
            text = "walker score: - (not ranked: failed or screened out)"
        if len(where_r):
            sr = scored.loc[where_r[0]]
            text += f"; the {ref_label}: {sr['score']:.3f}, rank {int(sr['rank']):,}"
        lines.append(text + " (`explorer rank` with its default weights)")
    if status == "ok" and str(ref_row["status"]) == "ok" and v != ref:
        lines.append(verdict(shown, shown_ref, ref_label, [m for m in DEFAULT_WEIGHTS if m in metrics],
                             None if si is None else {c: si.units[c] for c in si.converted}))
    if robust:
        lines.append("")
        lines += robust
    if physics:
        lines.append("")
        lines += physics
    if si is not None:
        lines.append("")
        lines.append(operating_line(si.operating))
        lines += si.notes
        if any(m in si.converted and si.units[m] == "N·m" for m in metrics if metric(m) is not None
               and metric(m).unit != "N·m"):
            lines.append("ranks are over the stored values: a torque's rank is that of its value per weight × "
                         "crank radius")
    op = res_operating
    if op:
        lines.append("")
        lines.append("forces at the operating point: " + ", ".join(f"{k} = {val!r}" if isinstance(val, str) else
                                                                    f"{k} = {val:g}" for k, val in op.items())
                     + " (unit: metres per model unit; rpm: crank speed; gravity m/s²; load: the body's mass, kg; "
                       "gear_ratio: motor turns per crank turn)")
        lines += force_model_lines(body, row if status == "ok" else None, op)
    print("\n".join(lines))
    return 0


def _print_records(records: list[dict], fmt: str) -> None:
    """The metric table of ``show --format csv|json`` on stdout (None: an empty CSV cell, JSON null)."""
    # whole numbers stay whole (object columns): an empty cell (null) where a metric is unranked
    _print_table(records, fmt, text=("metric", "unit", "rank", "ranked_among"))


def _print_table(records: list[dict], fmt: str, text=(), flags=()) -> None:
    """``records`` (dicts with the same keys, in column order) as CSV or JSON on stdout: the columns
    ``text`` as they are (None: an empty CSV cell, JSON null), ``flags`` as booleans, the others as
    floats."""
    import pandas as pd
    from ._format import json_records
    columns = list(records[0]) if records else []
    df = pd.DataFrame({c: pd.Series([r[c] for r in records], dtype=object if c in text else bool if c in flags
                                    else "float64") for c in columns})
    sys.stdout.write(df.to_csv(index=False) if fmt == "csv" else json_records(df) + "\n")


def force_model_lines(body: str | None, row, op: dict) -> list[str]:
    """What a forces file's figures mean: the walker's force model it used (``body``), the machine's
    mass, and where its flywheel goes (``row``: the shown variant's metrics, None if it failed)."""
    if body == "moving":
        out = ["force model: body = \"moving\": the body (the load, everything but the legs) moves with the planted "
               "contact foot, and the ground carries the whole machine through that foot"]
    else:
        out = ["force model: body = \"held\": the frame is held still in space, the legs hang from it and the ground "
               "carries the load alone (`[operating] body = \"moving\"` for the machine walking: larger peaks)"]
    if row is None:
        return out
    mass = row.get("machine_mass", math.nan)
    if math.isfinite(mass):
        legs = mass - float(op.get("load", 0.0))
        out.append(f"machine mass {mass:.4g} kg: the legs {legs:.4g} kg and the body {float(op.get('load', 0.0)):.4g} kg")
    fly = row.get("flywheel_inertia", math.nan)
    if math.isfinite(fly) and fly > 0:
        n = float(op.get("gear_ratio", 1.0))
        disc = 2.0 * fly / 0.5 ** 2  # a solid disc 1 m across: I = m r²/2
        motor = fly / (n * n)
        text = (f"flywheel: {fly:.3g} kg·m² on the crank (a solid disc 1 m across weighing {disc:.3g} kg), {motor:.3g} "
                f"kg·m² on the motor shaft (I/N², gear_ratio N = {n:g}): at a low crank speed ({float(op.get('rpm', math.nan)):g} rpm "
                f"here) the flywheel belongs on the motor side of the gearbox, where it needs N² times less inertia")
        if n == 1:
            text += " (give [operating] gear_ratio to size it there)"
        out.append(text)
    return out
