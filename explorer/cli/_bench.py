"""``explorer bench accuracy [--variants N] [--spread F] [--seed S] [--tolerances ...] [--steps ...] [-o DIR]``
and ``explorer bench rotations [--steps N] [--timing linear|quintic] [--csv FILE] [-o rotations.png]``."""

from __future__ import annotations

import sys


def _floats(text: str) -> tuple[float, ...]:
    from ..errors import UserError
    try:
        out = tuple(float(x) for x in text.replace(" ", ",").split(",") if x)
    except ValueError:
        raise UserError(f"expected comma-separated numbers, got {text!r}") from None
    if not out:
        raise UserError(f"expected at least one number, got {text!r}")
    return out


def _ints(text: str) -> tuple[int, ...]:
    from ..errors import UserError
    vals = _floats(text)
    if any(v != int(v) for v in vals):
        raise UserError(f"expected comma-separated integers, got {text!r}")
    return tuple(int(v) for v in vals)


def register(sub) -> None:
    from ._args import add_output, add_seed

    p = sub.add_parser("bench", help="benchmarks a user can run: what accuracy costs in time",
                       description="Benchmarks of explorer's solvers, run on this machine.")
    verbs = p.add_subparsers(dest="bench", metavar="BENCH", required=True)
    a = verbs.add_parser(
        "accuracy", help="accuracy vs time: Newton tolerance x crank steps x method (+ the link-angle formulations)",
        description="Over the variants that assemble (default: 1,000 Jansen variants at ±2 %), sweep Newton "
                    "tolerance, crank steps per cycle and method (block Newton, auto: the vectorised closed-form pass with Newton "
                    "where it flags a design, dense Newton, exact closed form), "
                    "plus the link-angle formulations explorer grew from as extra rows (8 link angles solved as one "
                    "8x8 Newton system and as four 2x2 systems in order; Gauss-Seidel instead of Gaussian "
                    "elimination in the Newton step). Per cell: wall time (best of a few runs, kernels warmed), mean Newton "
                    "iterations, max foot-position error against the closed form at the same angles, and the error "
                    "of stride, flatness and stance_speed against a 14,400-step closed-form reference. Prints a "
                    "table and writes DIR/accuracy.csv and DIR/accuracy.png (log-log error vs time).")
    a.add_argument("--mechanism", default="jansen", metavar="NAME|FILE",
                   help="built-in mechanism name or .toml file; its plan must be all dyads (default: jansen)")
    a.add_argument("--variants", type=int, default=1000, metavar="N",
                   help="variants drawn; those that assemble all round are kept (default: 1000)")
    a.add_argument("--spread", type=float, default=0.02, metavar="F",
                   help="each link and the crank scaled by uniform(1-F, 1+F) (default: 0.02)")
    add_seed(a, 1, "the draw (numpy default_rng)")
    a.add_argument("--tolerances", type=_floats, default=None, metavar="T1,T2,...",
                   help="Newton tolerances, each from 1e-12 to 1e-6: every solved position within tolerance x the "
                        "longest link (default: 1e-6,1e-8,1e-10,1e-11,1e-12)")
    a.add_argument("--steps", type=_ints, default=None, metavar="S1,S2,...",
                   help="crank steps per cycle (default: 36,90,360,1440)")
    a.add_argument("--methods", default="block,auto,dense,closed", metavar="M1,M2",
                   help="kernel methods to sweep (default: block,auto,dense,closed)")
    a.add_argument("--dense-variants", type=int, default=100, metavar="N",
                   help="dense Newton runs on the first N variants only (it is ~10x slower; default: 100)")
    a.add_argument("--seed-rows", default="all", metavar="NAMES",
                   help="seed formulations to add: all, none, or a comma list of seed001-full-GE, "
                        "seed001-sequential, seed003-GS(JtJ), seed003-GS(J) (default: all)")
    a.add_argument("--seed-variants", type=int, default=50, metavar="N",
                   help="the seed rows run on the first N variants only (default: 50)")
    a.add_argument("--seed-steps", type=_ints, default=(360,), metavar="S1,...",
                   help="crank steps for the seed rows (default: 360)")
    a.add_argument("--reference-steps", type=int, default=14_400, metavar="S",
                   help="steps of the closed-form reference for the gait metrics (default: 14400)")
    a.add_argument("--repeat", type=int, default=3, metavar="R", help="timing runs per cell, best kept (default: 3)")
    add_output(a, "directory for accuracy.csv and accuracy.png (default: ./bench-accuracy)", default="bench-accuracy",
               metavar="DIR", force="overwrite DIR's accuracy.csv and accuracy.png if they exist (never done without it)")
    a.add_argument("-q", "--quiet", action="store_true", help="no progress lines on stderr")
    a.set_defaults(func=run)
    r = verbs.add_parser(
        "rotations", help="seed 004's orientation problem: what each way of interpolating a rotation costs",
        description="Seed 004, problem 1: a tool's orientation from I to R = Rz(45°)·Ry(30°)·Rz(20°) in 10 s. "
                    "Prints R and the seed's two Z-Y-X Euler sets (28.02/11.17/67.8° and 151.98/191.17/247.8°, "
                    "R = Rz(phi)·Ry(theta)·Rx(psi)), the issue's two facts (the element-wise midpoint of I and a "
                    "90° turn has det 0.5; Euler 0->90° on Z-Y-X sweeps 116° for a 90° geodesic), and one row "
                    "per interpolation (slerp, spline, matrix, Euler Z-Y-X sets 1 and 2, Euler X-Y-Z, "
                    "axis-angle, the seed's literal axis+angle 4-vector): orthonormality defect (max "
                    "||R^T R - I||, |det R - 1|), geodesic deviation (max angle to slerp at the same time, "
                    "degrees), swept angle vs the geodesic's, angular-speed ripple ((max-min)/mean of the "
                    "rate per unit path fraction), and evaluation time per sample as a ratio to slerp timed "
                    "in the same run. With -o, draws the frames at t = 0, 2, ..., 10 s as the seed does.")
    r.add_argument("--steps", type=int, default=1001, metavar="N",
                   help="samples of the 10 s move for the accuracy columns (default: 1001)")
    r.add_argument("--timing", choices=("linear", "quintic"), default=None,
                   help="timing law of the move: the seed's linear, or the arm's quintic rest-to-rest "
                        "(default: linear, or the --mechanism's own)")
    r.add_argument("--mechanism", default=None, metavar="NAME|FILE",
                   help="instead of the seed's move, a path-driven mechanism's [driver] orientation (e.g. arm): its "
                        "keyframes, wrist, branch, duration and timing, one row per interpolation")
    r.add_argument("--wrist-csv", default=None, metavar="FILE",
                   help="also write the wrist's series for one method (--wrist-method) as CSV: t, s, the three "
                        "joint angles on the tracked branch and their rates (SI), the solution set, angular speed, "
                        "geodesic deviation, orthonormality defect")
    r.add_argument("--wrist-method", default=None, metavar="ROW",
                   help="the row --wrist-csv writes (default: the mechanism's own interpolation, or slerp)")
    r.add_argument("--samples", type=int, default=10_000, metavar="N",
                   help="samples per timed evaluation (default: 10000)")
    r.add_argument("--repeat", type=int, default=5, metavar="R", help="timing runs per method, best kept (default: 5)")
    r.add_argument("--methods", default="all", metavar="ROWS",
                   help="rows to run, comma-separated: all, or of slerp, spline, matrix, 'euler ZYX set 1', "
                        "'euler ZYX set 2', 'euler XYZ', axis-angle, 'seed axang 4-vector' (slerp always runs: "
                        "the time baseline; default: all)")
    r.add_argument("--csv", default=None, metavar="FILE", help="also write the table as CSV")
    add_output(r, "draw the interpolated frames, one 3-D panel per method (.png, .pdf or .svg)", metavar="FILE.png",
               force="overwrite an existing -o or --csv file")
    r.set_defaults(func=run_rotations)


def run(args) -> int:
    from ..errors import UserError
    from ..bench import DEFAULT_STEPS, DEFAULT_TOLERANCES, accuracy_sweep, format_table, plot, write_csv
    from ..bench import _seeds

    if args.bench != "accuracy":  # pragma: no cover - argparse only offers 'accuracy'
        raise UserError(f"unknown benchmark {args.bench!r}")
    methods = tuple(m.strip() for m in args.methods.split(",") if m.strip())
    if args.seed_rows == "all":
        solvers = tuple(_seeds.SOLVERS)
    elif args.seed_rows == "none":
        solvers = ()
    else:
        solvers = tuple(s.strip() for s in args.seed_rows.split(",") if s.strip())
        unknown = [s for s in solvers if s not in _seeds.SOLVERS]
        if unknown:
            raise UserError(f"--seed-rows: unknown {', '.join(unknown)} (known: all, none, "
                            f"{', '.join(_seeds.SOLVERS)})")
    for name, value in (("--dense-variants", args.dense_variants), ("--seed-variants", args.seed_variants),
                        ("--repeat", args.repeat), ("--reference-steps", args.reference_steps)):
        if value < 1:
            raise UserError(f"{name}: expected a positive integer, got {value}")
    from ._args import output_path
    for name in ("accuracy.csv", "accuracy.png"):  # the one output policy, before the sweep
        output_path(f"{args.output}/{name}", args.force)
    progress = None if args.quiet else (lambda line: print(line, file=sys.stderr, flush=True))
    report = accuracy_sweep(args.mechanism, variants=args.variants, spread=args.spread, seed=args.seed,
                            tolerances=args.tolerances or DEFAULT_TOLERANCES, steps=args.steps or DEFAULT_STEPS,
                            methods=methods, dense_variants=args.dense_variants, seed_solvers=solvers,
                            seed_variants=args.seed_variants, seed_steps=args.seed_steps,
                            reference_steps=args.reference_steps, repeat=args.repeat, progress=progress)
    print(format_table(report))
    csv_path = write_csv(report, f"{args.output}/accuracy.csv")
    png_path = plot(report, f"{args.output}/accuracy.png")
    print(f"wrote {csv_path} and {png_path}")
    return 0


def run_rotations(args) -> int:
    from ..errors import UserError
    from ._args import output_path
    from ..bench import _rotations

    for name, value, low in (("--steps", args.steps, 3), ("--samples", args.samples, 1), ("--repeat", args.repeat, 1)):
        if value < low:
            raise UserError(f"{name}: expected an integer >= {low}, got {value}")
    png = output_path(args.output, args.force, formats={".png", ".pdf", ".svg"}) if args.output else None
    csv_path = output_path(args.csv, args.force, formats={".csv"}, option="--csv") if args.csv else None
    mech = None
    known = list(_rotations.ROWS)
    if args.mechanism is not None:
        from ..mechanism import INTERPOLATIONS, load_mechanism

        mech = load_mechanism(args.mechanism)
        if mech.path is None or mech.path.orientation is None:
            raise UserError(f"--mechanism: {mech.name} has no [driver] orientation (the wrist's keyframes) to "
                            f"interpolate")
        known = list(INTERPOLATIONS)
    rows = None
    if args.methods != "all":
        rows = [m.strip() for m in args.methods.split(",") if m.strip()]
        unknown = [m for m in rows if m not in known]
        if unknown or not rows:
            raise UserError(f"--methods: unknown {', '.join(map(repr, unknown)) or 'empty list'} (known: all, "
                            f"{', '.join(known)})")
    own = mech.path.orientation.interpolation if mech is not None else "slerp"
    wrist_row = args.wrist_method or own
    if args.wrist_csv is not None and (wrist_row not in known or wrist_row == "seed axang 4-vector"):
        raise UserError(f"--wrist-method: expected one of {', '.join(k for k in known if k != 'seed axang 4-vector')}, "
                        f"got {wrist_row!r}")
    if rows is not None and args.wrist_csv is not None and wrist_row not in rows:
        rows.append(wrist_row)
    wrist_csv = output_path(args.wrist_csv, args.force, formats={".csv"}, option="--wrist-csv") if args.wrist_csv else None
    report = _rotations.rotations_bench(steps=args.steps, timing=args.timing, samples=args.samples,
                                        repeat=args.repeat, rows=rows, mechanism=mech)
    print(_rotations.format_table(report))
    if csv_path is not None:
        print(f"wrote {_rotations.write_csv(report, csv_path)}")
    if wrist_csv is not None:
        print(f"wrote {_rotations.write_wrist_csv(report.wrists[wrist_row], wrist_csv)}")
    if png is not None:
        print(f"wrote {_rotations.plot(report, png)}")
    return 0
