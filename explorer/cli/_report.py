"""``explorer report RESULTS -o report.html``: the study in one interactive page that opens offline."""

from __future__ import annotations

import os
from pathlib import Path

from ._args import add_output, add_seed, add_units, add_vs, add_where


# The defaults of explorer.view._report, repeated here: importing explorer.view to read them would load
# matplotlib (1.7 s) every time the command line starts (tests/test_report.py checks that they agree).
DEFAULT_MAX_DESIGNS, DEFAULT_PC_LINES, DEFAULT_PATHS, DEFAULT_SHOWN, DEFAULT_POINTS = 100_000, 10_000, 2_000, 50, 60


def register(sub) -> None:
    p = sub.add_parser(
        "report", help="an interactive HTML report of a results file: linked parallel coordinates, a metric "
                       "scatter with the Pareto front, foot paths, and the screened-out and failed designs by reason",
        description="Write one self-contained HTML page (plotly.js inlined: it opens offline, no server, no "
                    "network) of a results file. Parallel coordinates over the rank, the varied design "
                    "parameters and every stored metric; a scatter of any two metrics with the Pareto front of "
                    "the selected buildable designs; the foot paths of the best-ranked selected designs over the "
                    "nominal's; the best designs against the nominal (or --vs VARIANT: each metric's value and "
                    "change in %, the reference's own place); the screened-out and failed designs counted by "
                    "reason, each viewable. --units si gives lengths in mm, travel in m per turn, a walking speed in "
                    "m/s and torque in N·m at the study's [operating] point. Brushing "
                    "an axis or selecting in the scatter filters every view. The views hold the ok designs (those "
                    "--where EXPR keeps, as `explorer rank --where`: the page says the filter); "
                    f"above --max-designs (default {DEFAULT_MAX_DESIGNS:,}) a seeded uniform sample of them, "
                    "which the page states. An existing -o file is never replaced without --force.")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    add_output(p, "the HTML file to write (default: RESULTS-report.html in the working directory)")
    p.add_argument("--metrics", metavar="M1,M2,...", default=None,
                   help="the metric axes (default: every stored metric)")
    p.add_argument("--scatter", metavar="X,Y", default=None,
                   help="the scatter's first two metrics (default: travel,bob); the page has drop-downs for others")
    p.add_argument("--max-designs", type=int, metavar="N", default=DEFAULT_MAX_DESIGNS,
                   help=f"show at most N designs, a seeded uniform sample above that (default: {DEFAULT_MAX_DESIGNS:,})")
    p.add_argument("--lines", type=int, metavar="N", default=DEFAULT_PC_LINES,
                   help=f"the parallel coordinates draw at most N designs, a seeded sample (brushes still count "
                        f"every design; default: {DEFAULT_PC_LINES:,})")
    p.add_argument("--paths", type=int, metavar="N", default=DEFAULT_PATHS,
                   help=f"store the foot paths of the N best-ranked designs (default: {DEFAULT_PATHS:,})")
    p.add_argument("--shown", type=int, metavar="N", default=DEFAULT_SHOWN,
                   help=f"draw at most N selected foot paths at once (default: {DEFAULT_SHOWN})")
    p.add_argument("--points", type=int, metavar="N", default=DEFAULT_POINTS,
                   help=f"samples per stored foot path (default: {DEFAULT_POINTS})")
    add_seed(p, 0, "the sample above --max-designs")
    add_vs(p, "the reference design the tables compare every metric with (value and change in %%), "
                        "starred in the scatter and drawn under the foot paths (default 0: the nominal)")
    add_units(p)
    add_where(p, "the views hold the ok designs it keeps, and the page says the filter; the counts by reason stay "
                 "over every variant")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import UserError
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    from ._args import output_path
    from ..view import write_report
    from .._extras import require

    require("plotly", "explorer report")
    out = args.output if args.output is not None else f"{Path(args.results).stem}-report.html"
    if Path(out).suffix.lower() not in (".html", ".htm"):
        raise UserError(f"{out}: the report is an HTML page: name it .html")
    x = y = None
    if args.scatter is not None:
        names = [s.strip() for s in args.scatter.split(",") if s.strip()]
        if len(names) != 2:
            raise UserError(f"--scatter: expected two metrics as X,Y, got {args.scatter!r}")
        x, y = names
    for name, value, least in (("--max-designs", args.max_designs, 1), ("--lines", args.lines, 1), ("--paths", args.paths, 0),
                               ("--shown", args.shown, 0), ("--points", args.points, 3)):
        if value < least:
            raise UserError(f"{name}: expected a whole number >= {least}, got {value}")
    output_path(out, args.force, protect=[args.results])  # the verbs' one policy, before any work
    with open_results(args.results) as res:
        from ._show import warn_ignored_metrics
        warn_ignored_metrics(res)
        rep = write_report(res, out, force=args.force, metrics=args.metrics, max_designs=args.max_designs,
                           paths=args.paths, shown=args.shown, points=args.points, seed=args.seed, x=x, y=y, pc_lines=args.lines,
                           vs=args.vs, units=args.units, where=args.where)
    views = f"{rep.n_designs:,} designs in the views"
    if rep.where is not None:
        views += f" (where {rep.where}: {rep.n_kept:,} of the {rep.n_ok:,} ok" + (", a seeded sample" if rep.sampled else "") + ")"
    elif rep.sampled:
        views += f" (a seeded sample of the {rep.n_ok:,} ok)"
    failed = sum(n for k, n in rep.counts.items() if k.startswith("failed: "))
    screened = rep.counts.get("screened out (any check)", 0)
    not_run = rep.counts.get("not run yet", 0)
    print(f"wrote {os.fspath(rep.path)}: {views}, {rep.n_variants:,} variants ({screened:,} screened out, "
          f"{failed:,} failed" + (f", {not_run:,} not run yet" if not_run else "") + f"), foot paths of "
          f"{rep.n_paths:,}; {rep.bytes / 1e6:.1f} MB, opens offline in a browser")
    return 0
