"""``explorer show RESULTS VARIANT`` (or ``--variant N``): one variant's design parameters (lengths, crank,
pivots, ...) against the nominal, its metrics and ranks, its status."""

from __future__ import annotations

import math


def register(sub) -> None:
    p = sub.add_parser(
        "show", help="one variant of a results file: design parameters vs the nominal, metrics with their ranks, status",
        description="Print one variant of a results file: every design parameter (each link length, the crank "
                    "radius and centre, the ground pivots' and body joints' coordinates) against the nominal "
                    "design (absolute change, and % of the nominal for a length or of the mechanism's size for "
                    "a coordinate; parameters the study kept fixed are marked), each stored metric with its "
                    "rank among the ok "
                    "variants (1 = best in the metric's natural direction; ties share a rank), its status "
                    "(for a failed variant: the crank angle and vertex where it failed) and whether it passes the "
                    "buildability screen (and if not, why). Variant 0 is the nominal.")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    add_variant_arguments(p, "as `explorer animate` and `explorer plot --velocity` take it")
    p.set_defaults(func=run)


def add_variant_arguments(p, how: str) -> None:
    """The variant of a RESULTS file, given either as the positional VARIANT or as --variant N (``how``
    says which other verbs take it that way); read back with :func:`chosen_variant`."""
    p.add_argument("variant", metavar="VARIANT", nargs="?", default=None,
                   help="variant number, 0 to N-1 (0 = the nominal design); or give it as --variant N")
    p.add_argument("--variant", dest="variant_opt", metavar="N", default=None, help=f"the variant, {how}")


def chosen_variant(args, verb: str, usage: str) -> str:
    """The variant text of :func:`add_variant_arguments` (UserError if both forms differ, or neither is given)."""
    from ..errors import UserError
    if args.variant is not None and args.variant_opt is not None and args.variant != args.variant_opt:
        raise UserError(f"{verb}: two different variants given ({args.variant} and --variant {args.variant_opt})")
    chosen = args.variant if args.variant is not None else args.variant_opt
    if chosen is None:
        raise UserError(f"{verb}: say which variant: {usage}")
    return chosen


def parse_variant(text, n: int, filename) -> int:
    from ..errors import UserError
    try:
        v = int(str(text).strip())
    except ValueError:
        raise UserError(f"{filename}: variant: expected a whole number from 0 to {n - 1}, got {text!r}") from None
    if not 0 <= v < n:
        raise UserError(f"{filename}: variant {v} out of range (0 to {n - 1}: {n:,} variants)")
    return v


def metric_rank(values, ok, v: int, direction: str) -> tuple[int, int] | None:
    """(rank, pool): 1 + the number of ok variants with a strictly better finite value, and the number of
    ok variants with a finite value; None if variant ``v`` is not among them."""
    import numpy as np
    pool = ok & np.isfinite(values)
    if not pool[v]:
        return None
    x = values[pool]
    better = (x > values[v]) if direction == "max" else (x < values[v])
    return int(better.sum()) + 1, int(pool.sum())


def _table(rows, right) -> list[str]:
    widths = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
    out = []
    for r in rows:
        cells = [(c.rjust(w) if rj else c.ljust(w)) for c, w, rj in zip(r, widths, right)]
        out.append("  ".join(cells).rstrip())
    return out


def parameter_lines(mech, row, nominal: dict, perturbed) -> list[str]:
    """The table of every design parameter of ``mech`` (``Mechanism.parameters`` order): the variant's
    value (its frame ``row``'s column, or the nominal where the file stores none), the nominal
    (``nominal``, else the mechanism's), the change, and the change in % of the nominal (a length) or
    of the mechanism's size (a coordinate, whose own value is no scale)."""
    size = mech.size
    pivots = {f"{v}.{a}" for v in mech.fixed for a in "xy"}
    rows = [("parameter", "value", "nominal", "change", "change %")]
    for p, mech_nominal in mech.parameters().items():
        nom = float(nominal.get(p, mech_nominal))
        val = float(row[p]) if p in row.index else nom
        d = val - nom
        if mech.parameter_kind(p) == "length":
            pct = f"{100.0 * d / nom:+.3f} %" if nom else "-"
            label = p if p == "crank" else f"link {p}"
        else:
            pct = f"{100.0 * d / size:+.3f} % of size"
            label = f"pivot {p}" if p in pivots else (p if p in ("crank.x", "crank.y") else f"joint {p}")
        if p not in perturbed:
            label += " (fixed)"
        rows.append((label, f"{val:.4f}", f"{nom:.4f}", f"{d:+.4f}", pct))
    out = _table(rows, (False, True, True, True, True))
    if any(mech.parameter_kind(p) == "coordinate" for p in mech.parameters()):
        out.append(f"(a coordinate's change is in % of the mechanism's size, {size:g}: its longest link or body span)")
    return out


def run(args) -> int:
    import numpy as np

    from ..gait import METRICS, metric
    from ..store import open_results

    from ..errors import UserError
    chosen = chosen_variant(args, "show", "explorer show RESULTS VARIANT (or --variant N)")
    with open_results(args.results) as res:
        name, n = res.filename, res.n_variants
        v = parse_variant(chosen, n, name)
        df = res.frame()
        nominal = res.nominal
        perturbed = set(res.perturbed)
        mech = res.mechanism
        study = res.study.get("study", {})
        band = res.band
        metrics = list(res.metric_names)
        res_operating = res.study.get("operating") if res.study.get("scene", {}).get("forces") else None
    row = df.iloc[v]
    ok = (df["status_code"] == 0).to_numpy()

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
    lines.append("")
    lines += parameter_lines(mech, row, nominal, perturbed)

    # -- metrics -----------------------------------------------------------------------------------------
    if "screen" in row.index and status == "ok":
        lines.append("buildability screen: " + ("pass" if row["screen"] == "pass" else
                                                 f"screened out ({row['screen']}); `explorer rank` leaves it out "
                                                 f"unless --include-screened"))
    lines.append("")
    if not metrics:
        lines.append("no gait metrics: the mechanism is driven along a path, not by a crank, so it has no gait"
                     if mech.crank is None else f"no gait metrics stored; compute them with `explorer metrics {name}`")
        print("\n".join(lines))
        return 0
    n_ok = int(ok.sum())
    rows = [("metric", "value", "unit", f"rank among the {n_ok:,} ok variants (band {band:g})")]
    order = [m for m in METRICS if m in metrics] + [m for m in metrics if m not in METRICS]
    for m in order:
        values = df[m].to_numpy(dtype=np.float64)
        x = values[v]
        info = metric(m)
        direction = info.direction if info is not None else None
        if status != "ok":
            text, rank = "-", "- (variant failed)" if status != "not-run" else "- (not run)"
        elif not math.isfinite(x):
            text, rank = "nan", "- (undefined for this variant)"
        else:
            text = f"{x:.6g}"
            r = metric_rank(values, ok, v, direction) if direction else None
            if r is None:
                rank = "-"
            else:
                how = "higher is better" if direction == "max" else "lower is better"
                rank = f"rank {r[0]:,} of {r[1]:,} ({how})"
        rows.append((m, text, info.unit if info is not None else "", rank))
    lines += _table(rows, (False, True, False, False))
    op = res_operating
    if op:
        lines.append("")
        lines.append("forces at the operating point: " + ", ".join(f"{k} = {val:g}" for k, val in op.items())
                     + " (unit: metres per model unit; rpm: crank speed; gravity m/s²; load kg on the contact foot)")
    print("\n".join(lines))
    return 0
