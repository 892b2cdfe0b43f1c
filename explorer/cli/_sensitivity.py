"""``explorer sensitivity RESULTS [--metrics M1,M2|all|none] [--method rbd-fast|delta|pawn|sobol] [--summary]
[--top N] [--format table|csv|json] [-o PATH [--force]] [--resamples N] [--seed N]``: which dimensions matter.

Global sensitivity indices (SALib) of a sampled study's metrics and failures, from the samples in its
results file, and its tolerance summary (:mod:`explorer.study._sensitivity`)."""

from __future__ import annotations

import math
import sys

from ._args import FORMATS, add_format, add_old, add_output, add_seed, add_top, check_format, top_count, whole  # noqa: F401
from ._format import aligned, json_records

_whole = whole  # the name this module had (explorer tolerance used it)
__all__ = ["FORMATS", "aligned", "index_table", "register", "run", "summary_lines"]


def register(sub) -> None:
    p = sub.add_parser(
        "sensitivity", help="which dimensions matter: global sensitivity indices and a tolerance summary of a "
                            "sampled study",
        description="Global sensitivity indices, with their intervals, of each metric and of each way to fail "
                    "(fails: cannot turn a full turn; fails:assembly@5: vertex 5 cannot assemble; screened: turns "
                    "but the buildability screen removes it; screened:toggle, ...) with respect to every parameter "
                    "the study perturbed, computed by SALib from the samples already in the results file (no new "
                    "solve). Failed variants have no metrics and are left out of a metric's indices (n says how "
                    "many were used); variant 0, the nominal, is never a sample. The table starts with the "
                    "tolerance summary: the share of sampled designs that assemble over a full turn and that "
                    "pass the buildability screen, each failure kind with the parameters that drive it, each "
                    "metric's median and 5-95 %% range against the nominal. Methods: rbd-fast (default: "
                    "first-order index S1), delta (moment-independent delta and S1; slow), pawn (median "
                    "Kolmogorov-Smirnov distance), sobol (S1 and total ST; only for a study with [perturb] "
                    "method = \"saltelli\", where it is the default). oat and grid studies have no global "
                    "indices.",
        epilog="examples: explorer sensitivity results/jansen-2pct.h5; "
               "explorer sensitivity R.h5 --summary; "
               "explorer sensitivity R.h5 --metrics travel,bob -o indices.png; "
               "explorer sensitivity R.h5 --format csv > indices.csv")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    p.add_argument("--metrics", metavar="M1,M2|all|none", default=None,
                   help="metrics to analyse (default: the walker score's: travel, bob, body_speed_ripple, "
                        "peak_torque, clearance); the failure outcomes are always analysed")
    p.add_argument("--method", metavar="METHOD", default=None,
                   help="rbd-fast (default), delta, pawn, or sobol (default and only choice for a saltelli study)")
    p.add_argument("--summary", action="store_true",
                   help="the tolerance summary only (csv/json: its rows instead of the indices)")
    add_top(p, "table only: parameters shown per output, largest first", "5")
    add_format(p, what="csv and json: every index of every parameter, to stdout")
    add_output(p, "also draw the indices as bars with their intervals, one panel per output (.png, .svg, .pdf); "
                  "missing folders are created, an existing file is kept unless --force")
    add_old(p, "--plot", "-o/--output", dest="output", metavar="PATH")
    p.add_argument("--resamples", metavar="N", default=None,
                   help="bootstrap resamples of the intervals (default: rbd-fast 50, sobol 100, delta 20, pawn 10)")
    add_seed(p, 1, "the bootstrap resamples")
    p.set_defaults(func=run)


def _pct(p: float) -> str:
    if not math.isfinite(p):
        return "-"
    return f"{100 * p:.1f} %" if 0.001 <= p <= 0.999 or p in (0.0, 1.0) else f"{100 * p:.2g} %"


def summary_lines(summary, indices) -> list[str]:
    """The tolerance summary, in words."""
    from ..analysis import INDEX_NAMES
    lines = ["tolerance summary (sampled variants; variant 0, the nominal, is no sample; ± binomial standard error):"]
    method = indices.attrs.get("method", "")
    s1 = indices[(indices["output"] == "fails") & (indices["index"] == "S1")]["value"]
    for _, r in summary[summary["kind"] != "metric"].iterrows():
        share = f"{r['count']:,} of {r['n']:,} = {_pct(r['share'])} ± {_pct(r['se'])}"
        lead = "  " if r["kind"] == "share" else "    "
        # the events the drivers explain: failures; for buildable, those screened out among the turning
        events = r["count"] if r["kind"] != "share" else r["n"] - r["count"]
        if r["item"] == "assembles":
            turning = r["count"]
        elif r["item"] == "buildable":
            events = turning - r["count"]
        text = f"{lead}{r['what']}: {share}"
        if r["kind"] == "share":
            text += f" (the nominal: {'yes' if r['nominal'] == 1.0 else 'no'})"
        lines.append(text)
        if r["drivers"]:
            whose = {"assembles": "failing to turn: ", "buildable": "being screened out, among those that turn: "}
            lines.append(f"{lead}  {whose.get(r['item'], '')}driven by {r['drivers']} ({r['index']})")
        elif events and r["index"]:
            lines.append(f"{lead}  no parameter stands out ({r['index']} intervals include 0)")
        if r["item"] == "assembles" and method in ("rbd-fast", "delta", "sobol") and s1.notna().any() and events:
            total = float(s1.clip(lower=0).sum())
            lines.append(f"{lead}  the first-order indices S1 of failing add up to {total:.2f}: "
                         f"{'the rest is interactions between parameters' if total < 0.9 else 'little interaction'}"
                         + ("" if method == "sobol" else " (a saltelli study gives the total indices ST)"))
    metrics = summary[summary["kind"] == "metric"]
    if len(metrics):
        idx = str(metrics["index"].iloc[0])
        lines.append("")
        lines.append(f"metrics over the variants that turn (5-95 % range; drivers by {INDEX_NAMES.get(idx, idx)}):")
        table = metrics[["item", "nominal", "median", "p5", "p95", "count"]].copy().set_axis(
            ["metric", "nominal", "median", "5%", "95%", "n"], axis=1)
        for c in ("nominal", "median", "5%", "95%"):  # each metric its own scale: 4 significant digits
            table[c] = [f"{v:.4g}" if math.isfinite(v) else "-" for v in table[c].to_numpy(dtype=float)]
        table["n"] = [f"{v:,}" for v in table["n"]]
        table["drivers"] = [d or "-" for d in metrics["drivers"]]
        lines.append(_plain_indent(aligned(table, list(table.columns), left=("metric", "drivers"))))
    return lines


def index_table(indices, top: int | None) -> str:
    """Per output, its parameters largest first (by the method's main index), every index side by side."""
    import pandas as pd

    from ..analysis import main_index
    method = str(indices["method"].iloc[0])
    names = list(dict.fromkeys(indices["index"]))
    first = main_index(method, "metric")
    names = [first] * (first in names) + [i for i in names if i != first]
    blocks = []
    for output in dict.fromkeys(indices["output"]):
        sel = indices[indices["output"] == output]
        kind = str(sel["kind"].iloc[0])
        main = main_index(method, kind)
        wide = pd.DataFrame({"output": output, "parameter": list(dict.fromkeys(sel["parameter"]))})
        for i in names:
            part = sel[sel["index"] == i].set_index("parameter")
            if part.empty:
                continue
            wide[i] = part["value"].reindex(wide["parameter"]).to_numpy()
            wide[f"±{i}"] = part["conf"].reindex(wide["parameter"]).to_numpy()
        wide = wide.sort_values(main, ascending=False, na_position="last", kind="stable")
        if top is not None:
            wide = wide.iloc[:top]
        for c in wide.columns[2:]:  # indices in [0, 1]: three decimals read at a glance
            wide[c] = [f"{v:.3f}" if math.isfinite(v) else "-" for v in wide[c].to_numpy(dtype=float)]
        wide["n"] = int(sel["n"].iloc[0])
        wide["note"] = str(sel["note"].iloc[0]) or ""
        blocks.append(wide)
    table = pd.concat(blocks, ignore_index=True).fillna("-")  # an index an output does not have: "-"
    cols = ["output", "parameter"] + [c for i in names for c in (i, f"±{i}") if c in table.columns] + ["n"]
    if table["note"].astype(bool).any():
        cols.append("note")
    table["n"] = [f"{v:,}" for v in table["n"]]
    return aligned(table, cols, left=("output", "parameter", "note"))


def run(args) -> int:
    from .._extras import require
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    from ..analysis import sensitivity, tolerance_summary
    from ..analysis import INDEX_NAMES

    require("SALib", "explorer sensitivity")
    top = top_count(args.top, 5)
    resamples = whole(args.resamples, "--resamples", 2) if args.resamples is not None else None
    seed = args.seed
    plot_path = None
    if args.output is not None:
        from ..view import FIGURE_FORMATS
        from ._args import output_path
        plot_path = output_path(args.output, args.force, "-o", formats=FIGURE_FORMATS, protect=[args.results])

    # the library calls a Python user makes; this verb only formats what they return
    with open_results(args.results) as res:
        indices = sensitivity(res, metrics=args.metrics, method=args.method, resamples=resamples, seed=seed)
        summary = tolerance_summary(res, indices=indices)
        n_total = res.n_variants
        spread = res.study.get("perturb", {}).get("spread")
    source, design, params = indices.attrs["source"], indices.attrs["design"], list(indices.attrs["parameters"])

    if plot_path is not None:
        from ..view import plot_indices, save_figure
        fig = plot_indices(indices)
        save_figure(fig, plot_path)
        print(f"wrote {plot_path}", file=sys.stderr if args.format != "table" else sys.stdout)

    if args.format == "csv":
        sys.stdout.write((summary if args.summary else indices).to_csv(index=False))
        return 0
    if args.format == "json":
        sys.stdout.write(json_records(summary if args.summary else indices) + "\n")
        return 0

    a = indices.attrs
    kinds = ", ".join(INDEX_NAMES.get(i, i) for i in dict.fromkeys(indices["index"]))
    how = {"rbd-fast": "RBD-FAST", "delta": "delta", "pawn": "PAWN", "sobol": "Sobol (Saltelli's design)"}[a["method"]]
    spread_text = f" ±{100 * float(spread):g} %" if spread is not None else ""
    lines = [f"{source}: {a['samples']:,} sampled variants of {n_total:,} ({design}{spread_text}, "
             f"{len(params)} parameters: {', '.join(params)})",
             f"{kinds} by {how} (SALib); ± is the half-width of the {100 * a['conf_level']:g} % interval "
             f"({a['resamples']} bootstrap resamples, seed {a['seed']})", ""]
    lines += summary_lines(summary, indices)
    if not args.summary:
        lines.append("")
        shown = "all parameters" if top is None else f"the {top} largest per output (--top 0: all)"
        lines.append(f"indices, {shown}; n = variants used (failed variants have no metrics):")
        lines.append(_plain_indent(index_table(indices, top)))
    print("\n".join(lines))
    return 0


def _plain_indent(text: str) -> str:
    return "\n".join("  " + row for row in text.split("\n"))
