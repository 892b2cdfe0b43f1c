"""``explorer plot RESULTS (--top N --by METRIC | --scatter M1,M2 | --velocity VARIANT | --sensitivity | --front)
-o PATH``."""

from __future__ import annotations

import os
from pathlib import Path

MODES = ("top", "scatter", "velocity", "sensitivity", "front")


def _top(g) -> None:
    """--top N in plot's mode group (the vocabulary's option; 0 = every ranked design)."""
    from ._args import add_top
    add_top(g, "foot paths of the N best buildable variants over the nominal, ranked as `explorer rank` ranks them "
               "(the walker score; or --by / --weights)", "5")


def register(sub) -> None:
    from ._args import add_include_screened, add_output, add_units, add_variant, add_where

    p = sub.add_parser(
        "plot", help="plot a results file: best foot paths, two metrics with the Pareto front, foot velocity, "
                     "one-at-a-time sensitivity, an optimisation's front, or motor torque and joint reactions",
        description="Draw one picture of a results file and write it as PNG, SVG or PDF (by the extension of "
                    "-o). Exactly one of --top/--by, --scatter, --velocity, --sensitivity, --front, --forces. Lengths are in the "
                    "model units of the link lengths; rates are per radian of crank.")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    g = p.add_mutually_exclusive_group()
    _top(g)
    g.add_argument("--scatter", metavar="M1,M2", default=None,
                   help="every ok variant in two metrics (x,y) with the Pareto front and the nominal marked")
    g.add_argument("--velocity", metavar="VARIANT", nargs="?", const=-1, default=None,
                   help="dx/dθ and dy/dθ of the foot of the --variant N (default 0 = nominal): analytic solid, "
                        "central finite differences dashed on top (--velocity N: the old spelling)")
    g.add_argument("--sensitivity", action="store_true",
                   help="one-at-a-time (oat) study: %% change of each metric per +1 %% of each link")
    g.add_argument("--front", nargs="?", const="", default=None, metavar="X,Y",
                   help="an optimisation (`explorer optimize`): how the Pareto front moved over the generations, "
                        "in two of its objectives (default: the first two), or the best value per generation for "
                        "one objective")
    g.add_argument("--forces", action="store_true",
                   help="a study run with [scene] forces = true: the motor torque of one variant (--variant N, "
                        "default 0 = nominal) over the turn with its mean and flywheel energy, and its stored joint "
                        "reactions, in N·m and N")
    p.add_argument("--by", metavar="METRIC", default=None,
                   help="metric to rank by for --top (default: the walker score of travel, bob, body_speed_ripple, "
                        "peak_torque and clearance, as `explorer rank`)")
    p.add_argument("--weights", metavar="M1=W1,...", default=None,
                   help="with --top: rank by a weighted score of these metrics instead")
    add_include_screened(p, "with --top or --scatter: also rank (or put on the front) the variants the screen "
                            "removes")
    add_where(p, "for --top and --scatter")
    add_units(p, "with --top: foot paths in mm; with --scatter: both axes")
    add_output(p, "output .png, .svg or .pdf (default: RESULTS-<mode>.png in the working directory); missing "
                  "folders are created, an existing file is kept unless --force")
    add_variant(p, "with --velocity or --forces: the variant (0 = the nominal)")
    p.add_argument("--dpi", type=float, default=150, help="resolution of PNG output (default: 150)")
    p.set_defaults(func=run)


def _mode(args) -> str:
    from ..errors import UserError
    if args.scatter is not None:
        mode = "scatter"
    elif args.velocity is not None:
        mode = "velocity"
    elif args.sensitivity:
        mode = "sensitivity"
    elif args.front is not None:
        mode = "front"
    elif args.forces:
        mode = "forces"
    elif args.top is not None or args.by is not None or args.weights is not None:
        mode = "top"
    else:
        raise UserError("plot: say what to plot: --top N [--by METRIC], --scatter M1,M2, --velocity VARIANT, "
                        "--sensitivity, --front or --forces")
    for opt, given in (("--by", args.by is not None), ("--weights", args.weights is not None),
                       ("--include-screened", args.include_screened and mode != "scatter")):
        if given and mode != "top":
            raise UserError(f"plot: {opt} goes with --top, not with --{mode}")
    if args.by is not None and args.weights is not None:
        raise UserError("plot: --by and --weights exclude each other: pick one way to rank")
    if args.variant is not None and mode not in ("velocity", "forces"):
        raise UserError(f"plot: --variant goes with --velocity or --forces, not with --{mode}")
    if args.where is not None and mode not in ("top", "scatter"):
        raise UserError(f"plot: --where goes with --top or --scatter, not with --{mode}")
    if args.units != "model" and mode not in ("top", "scatter"):
        raise UserError(f"plot: --units goes with --top or --scatter, not with --{mode}")
    return mode


def run(args) -> int:
    from ..errors import UserError
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    from ..view import FIGURE_FORMATS, plot_scatter, plot_sensitivity, plot_top, plot_velocity, save_figure
    from ._args import output_path

    mode = _mode(args)
    out = args.output
    if out is None:
        out = f"{Path(args.results).stem}-{mode}.png"
    output_path(out, args.force, formats=FIGURE_FORMATS, protect=[args.results])  # a bad path fails before any work
    if not (1 <= args.dpi <= 1200):  # beyond that a figure is gigapixels: matplotlib fails or fills memory
        raise UserError(f"--dpi: expected a number from 1 to 1200, got {args.dpi!r}")
    with open_results(args.results) as res:
        if mode == "top":
            from ._args import parse_weights
            weights = parse_weights(args.weights) if args.weights is not None else None
            from ._args import top_count
            fig = plot_top(res, by=args.by, top=top_count(args.top, 5) or res.n_variants, where=args.where,
                           weights=weights, include_screened=args.include_screened, units=args.units)
        elif mode == "scatter":
            names = [s.strip() for s in args.scatter.split(",") if s.strip()]
            if len(names) != 2:
                raise UserError(f"--scatter: expected two metrics as M1,M2, got {args.scatter!r}")
            fig = plot_scatter(res, names[0], names[1], where=args.where, include_screened=args.include_screened,
                               units=args.units)
        elif mode == "velocity":
            if args.velocity != -1:  # the old spelling --velocity N
                from ._args import _variant_value, old_spelling
                old_spelling(f"--velocity {args.velocity}", f"--velocity --variant {args.velocity}")
                args.velocity = _variant_value(args.velocity)
            v = args.velocity if args.velocity != -1 else args.variant
            if args.velocity != -1 and args.variant is not None and args.variant != args.velocity:
                raise UserError(f"plot: two different variants given (--velocity {args.velocity}, --variant "
                                f"{args.variant})")
            if v is None:
                raise UserError("plot: --velocity needs a variant: --velocity --variant N (or --velocity N)")
            fig = plot_velocity(res, v)
        elif mode == "front":
            from ..view import plot_front
            names = [s.strip() for s in args.front.split(",") if s.strip()]
            if len(names) not in (0, 2):
                raise UserError(f"--front: expected two objectives as X,Y (or nothing), got {args.front!r}")
            fig = plot_front(res, *names)
        elif mode == "forces":
            from ..view import plot_forces
            fig = plot_forces(res, 0 if args.variant is None else args.variant)
        else:
            fig = plot_sensitivity(res)
        path = save_figure(fig, out, dpi=args.dpi)
    print(f"wrote {os.fspath(path)}")
    return 0
