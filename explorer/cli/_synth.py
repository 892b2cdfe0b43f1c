"""``explorer synth TARGET.csv [--mechanism fourbar|watt6|stephenson6|any] [--timed] [--closed]``: designs
whose foot passes through target points, from the curve atlas and a polish, as a results file."""

from __future__ import annotations


def register(sub) -> None:
    from ._args import add_output, add_top

    p = sub.add_parser(
        "synth", help="from target points (a drawn path) to designs: curve-atlas look-up, then a polish",
        description="Find designs whose foot passes through the points of TARGET.csv (columns x, y, and with "
                    "--timed angle_deg: each point's crank angle, degrees counter-clockwise from +x, as in a study's "
                    "[target]). The atlas of the mechanism is looked up (closed curves: the nearest Fourier "
                    "descriptors, then the best rotation, scale and starting point; open stretches and timed points: "
                    "a scan of the atlas), the best candidates are moved onto the target by the best similarity "
                    "transform and polished by least squares on the real kinematics (every design parameter, the "
                    "position, turn and size of the design included; a design must turn a full cycle), and the best "
                    "distinct designs are written as a results file that rank, show, plot, animate and export read "
                    "(path_error: the RMS distance to the points, model units). The atlas is built on first use "
                    "(1,000,000 designs; about a minute or two on 2 cores) unless --no-build.",
        epilog="Examples: explorer synth letter.csv --closed; explorer synth stance.csv --mechanism any; "
               "explorer synth timed.csv --timed --mechanism watt6")
    p.add_argument("target", metavar="TARGET.csv", help="target points: CSV with a header x,y[,angle_deg]")
    p.add_argument("--mechanism", default="fourbar", choices=["fourbar", "watt6", "stephenson6", "any"],
                   help="the atlas family (default fourbar; any: every family, the best one written)")
    p.add_argument("--timed", action="store_true",
                   help="match each point at its crank angle (the CSV's angle_deg column)")
    p.add_argument("--free-phase", action="store_true",
                   help="with --timed: the angles are known up to a common shift (a start nobody prescribes)")
    p.add_argument("--closed", action="store_true",
                   help="the points are a whole closed curve (default: a stretch of path the foot passes through, in order)")
    add_output(p, "results file (default results/synth-<mechanism>.h5)", force="overwrite an existing results file")
    add_top(p, "distinct designs written, best first", "10; 0 = every distinct design of the --starts polished")
    p.add_argument("--starts", metavar="N", default="96", help="look-up candidates polished (default 96)")
    p.add_argument("--atlas", metavar="PATH", default=None, help="atlas file (default: the cached atlas of --mechanism)")
    p.add_argument("--no-build", action="store_true", help="fail instead of building a missing atlas")
    p.add_argument("--designs", metavar="N", default="1000000",
                   help="designs of an atlas built on first use (default 1,000,000)")
    p.add_argument("--scan", metavar="N", default=None,
                   help="designs an open or timed look-up scans, the atlas's first (default 200,000)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress and no summary")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import UserError
    from ..synthesis import synthesize
    from ._args import top_count, whole
    starts = whole(args.starts, "--starts", 1)
    if args.atlas is not None and args.mechanism == "any":
        raise UserError("--atlas: one atlas belongs to one mechanism; give --mechanism with it, not any")
    summary = synthesize(args.target, mechanism=args.mechanism, timed=args.timed, closed=args.closed,
                         free_phase=args.free_phase, output=args.output, force=args.force,
                         top=top_count(args.top, 10) or starts, starts=starts, atlas=args.atlas,
                         build=not args.no_build, designs=whole(args.designs.replace(",", ""), "--designs", 1),
                         progress=not args.quiet, scan=None if args.scan is None else whole(args.scan, "--scan", 1),
                         echo=None if args.quiet else print)
    if not args.quiet:
        print(summary.text())
    return 0
