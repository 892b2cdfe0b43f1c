"""``explorer rank RESULTS [--by M | --pareto M1,M2 | --weights M1=W1,M2=W2] [--top N] [--where EXPR]
[--ascending|--descending] [--include-failed] [--format table|csv|json]``: rank the variants of a results file."""

from __future__ import annotations

import sys

from ._args import (FORMATS, add_format, add_include_screened, add_top, add_units, add_vs, add_where, parse_list, parse_top,
                    parse_weights, top_count)
from ._format import better, format_column, format_floats, json_records, results_si
from ._format import frame_table as format_table

# the argument types and the table formatter are shared (._args, ._format); their names stay importable here
__all__ = ["FORMATS", "better", "format_column", "format_floats", "format_table", "json_records", "parse_list",
           "parse_top", "parse_weights", "register", "run", "screen_line", "short_screen", "with_margins"]


def register(sub) -> None:
    p = sub.add_parser(
        "rank", help="rank the variants of a results file by a gait metric, a weighted score or a Pareto front",
        description="Rank the ok, buildable variants of a results file, best first. By default a score in [0, 1] "
                    "weighting equally the walker's travel per crank turn (up), bob, body speed ripple and peak "
                    "crank torque (down), each min-max normalised over the ranked variants. Or one metric (--by, "
                    "in its natural direction), a weighted score of your own (--weights), or the Pareto front of "
                    "several metrics (--pareto). Variants the buildability screen removes (toggle: min "
                    "transmission angle under 5°; a foot that rises to the crank axle or a ground pivot; a foot whipped "
                    "round faster than 6 crank radii per radian; a foot "
                    "path that crosses itself; thresholds in the study's [screen]) are left out and counted; "
                    "--include-screened keeps them. --where filters first over the columns "
                    "of the results frame (metrics, link lengths, crank, status). The table is for reading; csv "
                    "and json carry every column of the ranked frame (the same rows as Results.rank()) at full "
                    "precision.",
        epilog="examples: explorer rank results/jansen-2pct.h5; "
               "explorer rank R.h5 --by travel --where \"bob < 0.2\"; "
               "explorer rank R.h5 --pareto travel,bob --top 0; "
               "explorer rank R.h5 --weights travel=2,bob=1 --format csv > best.csv")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    p.add_argument("--by", metavar="METRIC", default=None,
                   help="metric to rank by (default: the walker score of travel, bob, body_speed_ripple, peak_torque and "
                        "clearance)")
    add_top(p, "rows to show", "10 in the table, every row in csv and json")
    add_where(p)
    p.add_argument("--pareto", metavar="M1,M2,...", default=None,
                   help="only the Pareto front (non-dominated variants) of these metrics, sorted by the first")
    p.add_argument("--weights", metavar="M1=W1,...", default=None,
                   help="rank by a weighted score in [0, 1] of min-max normalised metrics (1 = best)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--ascending", dest="ascending", action="store_const", const=True, default=None,
                   help="with --by: smaller is better (overrides the metric's natural direction)")
    g.add_argument("--descending", dest="ascending", action="store_const", const=False,
                   help="with --by: larger is better")
    p.add_argument("--include-failed", action="store_true",
                   help="keep failed variants (their metrics are NaN and sort last)")
    add_include_screened(p)
    add_format(p, what="csv and json: every column, to stdout")
    add_vs(p, "table only: the reference design, shown as a marked last row with its own rank (default 0: "
                        "the nominal)")
    p.add_argument("--change", action="store_true",
                   help="table only: after each ranking metric, its change against the reference in %% (column "
                        "METRIC%%)")
    p.add_argument("--columns", metavar="C1,C2,...", default=None,
                   help="table only: the columns after rank, variant and the ranking metrics (default: the other "
                        "metrics, then status); any frame column, e.g. crank or a link name")
    add_yield_arguments(p, "the rows shown (--top)")
    add_units(p)
    p.set_defaults(func=run)


# -- formatting --------------------------------------------------------------------------------------------
def short_screen(reason) -> str:
    """"pass", or the names of the failed checks ("toggle,foot-whip"), for a table cell."""
    reason = str(reason)
    if reason == "pass":
        return reason
    return ",".join(part.split(":")[0].split(" (")[0].replace(" ", "-") for part in reason.split("; "))


def screen_line(summary: dict, included: bool) -> str:
    """One line on what the buildability screen removed (or would have, with --include-screened)."""
    if not summary["applied"] and summary.get("path_driven"):
        return "buildability screen: not applicable (a mechanism driven along a path is no leg)"
    if not summary["applied"] and summary.get("not_applicable"):
        return f"buildability screen: not applicable ({summary['not_applicable']})"
    if not summary["applied"]:
        return ("buildability screen: not applied (this file stores none of min_transmission_angle, foot_headroom, "
                "self_crossings; recompute them with `explorer metrics RESULTS --metrics all`)")
    parts = ", ".join(f"{k} {v:,}" for k, v in summary["checks"].items() if v)
    why = f" ({parts})" if parts else ""
    if included:
        return f"buildability screen: not applied (--include-screened); it would remove {summary['removed']:,}{why}"
    return (f"buildability screen removed {summary['removed']:,} ok variants{why}; "
            f"--include-screened keeps them")


# -- yield ------------------------------------------------------------------------------------------------
def add_yield_arguments(p, rows: str) -> None:
    """--yield [TOL] and --copies N, shared by rank and show; ``rows``: which designs it re-solves."""
    p.add_argument("--yield", dest="yield_tol", nargs="?", const="", default=None, metavar="TOL",
                   help="the yield: the share of --copies copies, every design parameter cut with ±TOL (0.5%%: "
                        "lengths relatively, coordinates in %% of the mechanism's size; 0.1mm with [operating] unit; "
                        "0.02: model units; uniform, the same errors for every design), that turn and pass the "
                        "buildability screen, ± its binomial standard error. Without TOL: the study's [robustness] "
                        f"table. Re-solves the copies of {rows}")
    p.add_argument("--copies", metavar="N", default=None, help="with --yield TOL: copies per design (default 256)")


def check_yield_arguments(args) -> None:
    """--copies only with --yield TOL (a one-line UserError otherwise)."""
    if args.copies is not None and not args.yield_tol:
        from ..errors import UserError
        raise UserError("--copies goes with --yield TOL (without TOL the study's [robustness] table gives the copies)")


def yields(res, args, variants) -> tuple[dict, object]:
    """({variant: (yield, standard error)}, Robustness) of ``variants`` for --yield [TOL] [--copies N]."""
    from ..analysis import results_robustness, results_yield
    from ._args import whole

    copies = whole(args.copies, "--copies", 2) if args.copies is not None else None
    robustness = results_robustness(res, args.yield_tol or None, copies)
    wanted = list(dict.fromkeys(int(v) for v in variants))
    y = results_yield(res, wanted, robustness)
    return {v: (float(p), float(se)) for v, p, se in zip(wanted, y.share, y.se)}, y.robustness


#: What the tightest / margin% columns of the table are (``explorer rank`` prints it under the table's head).
MARGIN_LINE = ("tightest, margin%: each design's closest screen limit and how far inside it (toggle: % of the "
               "limit angle; foot-whip: % of the limit speed; foot-above-the-frame: % of the crank radius); a "
               "design a few % inside passes here, but cut with a workshop's errors it may not: --yield 0.5mm "
               "(or 0.5%) gives the share of copies that still turn and pass")


def with_margins(rows, screen):
    """``rows`` with each design's tightest screen margin (:func:`explorer.gait.screen_margins`): the
    columns screen_check, screen_margin (a fraction, positive inside), screen_value and screen_limit."""
    from ..gait import screen_margins
    margin, check, value, limit = screen_margins(rows, screen)
    return rows.assign(screen_check=check, screen_margin=margin, screen_value=value, screen_limit=limit)


#: What the two torque columns of a forces study are (``explorer rank`` prints it under the table's head).
TORQUES_LINE = ("torques: peak_torque is the walker metric, quasi-static: the load alone on massless legs; "
                "motor_torque_peak is the motor's (the forces effect: the legs' inertia and weight, the body as "
                "[operating] body says): size the motor from motor_torque_peak")


def run(args) -> int:
    from ..errors import UserError
    from ..gait import DEFAULT_WEIGHTS, DIRECTIONS, WALKER_METRICS, operating_line
    from ..study import open_results  # with explorer's re-solver (store only reads files)

    # machine formats carry everything unless --top is given; the table shows ten
    top = top_count(args.top, 0 if args.format in ("csv", "json") else 10)
    pareto = parse_list(args.pareto, "--pareto") if args.pareto is not None else None
    weights = parse_weights(args.weights) if args.weights is not None else None
    if pareto is not None and weights is not None:
        raise UserError("--pareto and --weights exclude each other: pick one way to rank")
    mode = "pareto" if pareto is not None else "weights" if weights is not None else "by"
    if mode != "by" and args.by is not None:
        raise UserError(f"--by goes alone: with --{mode} the ranking metrics are the ones --{mode} names")
    if mode != "by" and args.ascending is not None:
        raise UserError(f"--ascending/--descending go with --by, not with --{mode} (which use each metric's "
                        f"natural direction)")
    by = args.by
    if mode == "by" and by is None:
        if args.ascending is not None:
            raise UserError("--ascending/--descending go with --by METRIC, not with the default score")
        mode, weights = "default", dict(DEFAULT_WEIGHTS)
    extra = parse_list(args.columns, "--columns") if args.columns is not None else None
    check_yield_arguments(args)

    unstored = []
    with open_results(args.results) as res:
        if mode == "default":  # the default score over the metrics the file stores (an optimisation: some)
            weights, unstored = res.default_weights()
        # read in blocks of rows (a million-design file's frame is never held whole): the rows shown are read
        # whole, the rest of the ranking only as its rank and variant; one pass also counts the screen
        full = res.rank(by=by, top=None, where=args.where, ascending=args.ascending, weights=weights,
                        pareto=pareto, include_failed=args.include_failed, include_screened=args.include_screened,
                        columns=["variant"])
        counts = res.status_counts()
        screened = res.screen_summary()
        thresholds = res.screen
        n, complete, name = res.n_variants, res.complete, res.filename
        ref = res.check_variant(args.vs)
        ranked = full if top is None else full.iloc[:top]
        # the rows shown, whole (every frame column, the same rows as Results.rank()), ranked as above
        rows = res.frame_rows(ranked["variant"].to_numpy())
        rows.index = ranked.index
        ranked = rows.assign(**{k: ranked[k].to_numpy() for k in ranked.columns if k not in rows.columns})[
            ["rank", *rows.columns, *(["score"] if "score" in ranked.columns else [])]]
        # --units si: the rows shown in SI, the ranking itself over the stored values (--where too)
        frame = res.frame_rows([ref])  # the reference's row (its own place in the ranking, or none)
        si = results_si(res, frame.iloc[:0], args.units)
        robust = yields(res, args, [*ranked["variant"].tolist(), ref]) if args.yield_tol is not None else None
    if robust is not None:  # each shown design's yield, ± its binomial standard error
        ys, robustness = robust
        ranked = ranked.assign(**{"yield": [ys[v][0] for v in ranked["variant"]],
                                  "yield_se": [ys[v][1] for v in ranked["variant"]]})

    if args.format in ("csv", "json"):
        if si is not None:  # converted values under unit-suffixed names: bob[mm], travel[m/turn], speed[m/s]
            conv = si.apply(ranked)
            ranked = conv.frame.rename(columns=conv.labels())
        sys.stdout.write(ranked.to_csv(index=False) if args.format == "csv" else json_records(ranked) + "\n")
        return 0

    # -- table -----------------------------------------------------------------------------------------
    keys = pareto if mode == "pareto" else list(weights) if mode in ("weights", "default") else [by]

    def direction(c):
        if mode == "by" and args.ascending is not None:
            return "min" if args.ascending else "max"
        return DIRECTIONS.get(c, "min")

    if mode == "by":
        how = f"ranked by {by} ({better(direction(by))})"
    elif mode == "pareto":
        how = "Pareto front of " + ", ".join(f"{c} ({better(direction(c))})" for c in keys)
    elif mode == "default":
        how = ("the walker score (1 = best; equal weights; --by METRIC ranks by one metric) of " +
               ", ".join(f"{c} ({better(direction(c))})" for c in keys))
    else:
        how = ("weighted score (1 = best) of " +
               ", ".join(f"{c} ×{weights[c]:g} ({better(direction(c))})" for c in keys))
    ok = counts.get("ok", 0)
    pool = f"{ok:,} ok of {n:,} variants" + ("" if complete else f" (incomplete file: {counts.get('not-run', 0):,} "
                                                                    f"not run)")
    if args.include_failed:
        pool = f"all {n:,} variants ({ok:,} ok)"
    matched = f"{len(full):,} " + ("on the front" if mode == "pareto" else "match" if args.where else "ranked")
    if args.where:
        matched += f" where {args.where}"
    shown = f"showing {len(ranked):,}" if len(ranked) < len(full) else "showing all"
    lines = [f"{name}: {how}", f"{pool}; {matched}; {shown}"]
    lines.append(screen_line(screened, args.include_screened))
    if unstored:
        lines.append(f"ranked without {', '.join(unstored)}: not stored in this file")
    from ..physics._compare import rank_note
    note = rank_note(full, keys)
    if note:
        lines.append(note)
    if ranked.empty:
        lines.append("(no variant to show)")
        print("\n".join(lines))
        return 0
    lead = ["rank", "variant"] + (["score"] if mode in ("weights", "default") else []) + keys
    if extra is None:
        rest = [m for m in WALKER_METRICS if m in ranked.columns and m not in lead]
        rest += ["screen"] if args.include_screened and "screen" in ranked.columns else ["status"]
    else:
        unknown = [c for c in extra if c not in ranked.columns]
        if unknown:
            known = ", ".join(map(str, ranked.columns))
            raise UserError(f"--columns: unknown column {unknown[0]!r} (columns: {known})")
        rest = [c for c in extra if c not in lead]
    # the reference design (the nominal unless --vs) as a marked last row, with its place in this ranking
    import numpy as np
    import pandas as pd
    ref_label = "nominal" if ref == 0 else "reference"
    in_full = full.index[full["variant"] == ref]
    ref_row = (frame.assign(rank=full.loc[in_full[0], "rank"], **({"score": full.loc[in_full[0], "score"]}
                                                                  if "score" in full.columns else {}))
               if len(in_full) else frame).copy()
    if robust is not None:
        ref_row = ref_row.assign(**{"yield": ys[ref][0], "yield_se": ys[ref][1]})
    place = f"{int(ref_row['rank'].iloc[0])}" if len(in_full) else "-"
    table_rows = pd.concat([ranked, ref_row], ignore_index=True)
    if screened["applied"]:  # each design's tightest screen margin: which check, how close
        table_rows = with_margins(table_rows, thresholds)
    marks = [str(r) for r in table_rows["rank"].iloc[:-1]] + [f"{ref_label}:{place}"]
    table_rows = table_rows.assign(rank=marks)
    cols = lead + rest
    if extra is None and "motor_torque_peak" in ranked.columns and "motor_torque_peak" not in cols:
        # a forces study: the motor's own peak beside the walker metric's quasi-static one
        cols.insert(cols.index("peak_torque") + 1 if "peak_torque" in cols else len(lead), "motor_torque_peak")
    if "peak_torque" in cols and "motor_torque_peak" in cols:
        lines.append(TORQUES_LINE)
    if robust is not None:
        cols = lead + [c for c in ("yield", "yield_se") if c not in lead] + [c for c in rest if c not in
                                                                              ("yield", "yield_se")]
        lines.append(f"yield: the share of copies, {robustness.describe()}, that turn and pass the screen; "
                     f"yield_se its binomial standard error")
    if extra is None and screened["applied"]:  # the closest screen limit, right after the ranking metrics
        cols[len(lead):len(lead)] = ["tightest", "margin%"]
        table_rows = table_rows.assign(**{
            "tightest": [short_screen(c) if c else "-" for c in table_rows["screen_check"]],
            "margin%": 100.0 * table_rows["screen_margin"].to_numpy(dtype=float)})
        lines.append(MARGIN_LINE)
    conv = None
    if si is not None:  # the shown rows (the reference's included) in SI; speed follows travel
        conv = si.apply(table_rows)
        table_rows = conv.frame
        if "speed" in conv.converted and "travel" in cols and "speed" not in cols:
            cols.insert(cols.index("travel") + 1, "speed")
    if args.change:
        base = {k: float(table_rows[k].iloc[-1]) for k in keys if k in table_rows.columns}  # the reference, last
        with np.errstate(invalid="ignore", divide="ignore"):
            for k in keys:
                if k in base:
                    table_rows[f"{k}%"] = 100.0 * (table_rows[k].to_numpy(dtype=float) - base[k]) / abs(base[k])
        cols = [c for k in cols for c in ([k, f"{k}%"] if args.change and k in keys and k in base else [k])]
    if "screen" in cols:  # the check names only: `explorer show` gives the whole reason
        table_rows = table_rows.assign(screen=[short_screen(r) for r in table_rows["screen"]])
    lines.append(f"last row: the {ref_label} (variant {ref}) and its place in this ranking"
                 + ("; METRIC% columns: the change against it" if args.change else "")
                 + f"; `explorer show RESULTS --variant V --vs {ref}` compares a variant with it metric by metric")
    if conv is not None:
        lines.append(operating_line(conv.operating) + "; ranks are over the stored values (a torque's: per "
                     "weight × crank radius)")
        lines += conv.notes
        labels = conv.labels()
        if "motor_torque_peak" in cols:  # already SI, labelled beside peak_torque[N·m]
            labels["motor_torque_peak"] = "motor_torque_peak[N·m]"
        table_rows = table_rows.rename(columns=labels)
        cols = [labels.get(c, c) for c in cols]
    lines.append("")
    lines.append(format_table(table_rows, cols, right={"rank"}))
    print("\n".join(lines))
    return 0
