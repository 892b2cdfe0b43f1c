"""``explorer atlas build MECHANISM [--designs N] [--seed S] [-o PATH] [--force]`` and ``explorer atlas info
[MECHANISM | PATH]``: the curve atlas of a mechanism (many designs and their paths as shapes) that
``explorer synth`` and ``explorer optimize`` (algorithm auto) look target curves up in."""

from __future__ import annotations


def register(sub) -> None:
    from ._args import add_output, add_seed

    p = sub.add_parser(
        "atlas", help="build or describe the curve atlas of a mechanism (what explorer synth looks curves up in)",
        description="The curve atlas of a mechanism: a Sobol sample of its design space (lengths within a factor, "
                    "coordinates within a share of its size of the nominal; the crank centre and the first ground "
                    "pivot fixed, since the shape of a path does not change when the design is moved, turned or "
                    "scaled), solved by the batch kernels at 128 crank steps, keeping the designs that turn a full "
                    "cycle (and pass the buildability screen, for a walking leg), each with its path resampled by "
                    "arc length and by crank angle, normalised for position and scale, and its Fourier magnitudes "
                    "(the index's descriptor: unchanged by position, rotation, scale and starting point). Families: "
                    "fourbar (a four-bar whose coupler is one rigid body), watt6 (Watt I), stephenson6 (Stephenson "
                    "III); any other crank-driven built-in or mechanism file takes the general rule. Atlases live "
                    "in $EXPLORER_ATLAS_DIR, else ~/.cache/explorer/atlas, one file per family "
                    "(about 300 bytes per design).",
        epilog="Examples: explorer atlas build fourbar; explorer atlas build watt6 --designs 200000; "
               "explorer atlas info fourbar")
    s = p.add_subparsers(dest="atlas_command", metavar="COMMAND", required=True)
    b = s.add_parser("build", help="build (sample, solve and store) the atlas of a mechanism",
                     description="Build the atlas of MECHANISM (fourbar, watt6, stephenson6, a built-in or a mechanism "
                                 "file) with N designs that turn a full cycle.")
    b.add_argument("mechanism", metavar="MECHANISM", help="fourbar, watt6, stephenson6, a built-in or a mechanism .toml")
    b.add_argument("--designs", metavar="N", default="1000000",
                   help="designs that turn a full cycle to keep (default 1,000,000)")
    add_seed(b, 0, "the scrambled Sobol sample")
    add_output(b, "atlas file (default: <atlas dir>/<MECHANISM>.h5)", force="build again over an existing atlas")
    b.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary")
    b.set_defaults(func=run_build)
    i = s.add_parser("info", help="describe an atlas (or every cached one)",
                     description="Describe the atlas of MECHANISM (its cached file) or the atlas file PATH; without an "
                                 "argument, every atlas in the atlas directory.")
    i.add_argument("atlas", metavar="MECHANISM|PATH", nargs="?", default=None)
    i.set_defaults(func=run_info)


def run_build(args) -> int:
    from ..synthesis import build_atlas
    from ._args import whole
    n = whole(args.designs.replace(",", "").replace("_", ""), "--designs", 1)
    seed = args.seed
    summary = build_atlas(args.mechanism, n, output=args.output, seed=seed, force=args.force, progress=not args.quiet)
    if not args.quiet:
        print(summary.text())
    return 0


def run_info(args) -> int:
    import json
    from pathlib import Path

    from ..errors import UserError
    from ..synthesis import atlas_dir, atlas_info, default_path
    if args.atlas is None:
        files = sorted(atlas_dir().glob("*.h5")) if atlas_dir().is_dir() else []
        if not files:
            print(f"no atlas in {atlas_dir()} (build one: explorer atlas build fourbar)")
            return 0
    else:
        p = Path(args.atlas)
        files = [p if p.suffix == ".h5" and p.is_file() else default_path(args.atlas)]
        if not files[0].is_file():
            raise UserError(f"{files[0]}: no atlas (build it: explorer atlas build {args.atlas})")
    for f in files:
        try:
            a = atlas_info(f)
        except OSError as exc:
            raise UserError(f"{f}: cannot read the atlas: {exc}") from None
        if a.get("format") != "explorer-atlas":
            print(f"{f}: not an explorer atlas")
            continue
        params = json.loads(a["parameters"])
        print(f"{f}: {a['family']} ({a['mechanism_name']}), {int(a['designs']):,} designs of {int(a['sampled']):,} "
              f"sampled, {a['size_bytes'] / 1e6:.1f} MB; built in {float(a['build_s']):.1f} s "
              f"({float(a['build_cpu_s']):.1f} CPU-s) by explorer {a['explorer_version']}; seed {a['seed']}; "
              f"varied: {', '.join(params)}")
    return 0
