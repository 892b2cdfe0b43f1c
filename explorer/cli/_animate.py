"""``explorer animate [RESULTS --variant ID | --mechanism NAME] -o leg.mp4|leg.gif [--cycles K] [--legs N]``."""

from __future__ import annotations

import os
from pathlib import Path


def register(sub) -> None:
    from ._args import add_output, add_variant

    p = sub.add_parser(
        "animate", help="animate a design (a variant of a results file, or a mechanism) to MP4 or GIF",
        description="Animate a linkage over a few crank turns: links, joints, crank and ground pivots over the "
                    "foot path of one cycle, with the foot's velocity arrow tangent to it. MP4 (H.264, yuv420p) "
                    "uses the ffmpeg of the imageio-ffmpeg package; GIF uses Pillow. A design that is not ok is "
                    "drawn up to its failure angle, with the failure in the title.")
    p.add_argument("results", nargs="?", default=None, metavar="RESULTS",
                   help="results file (.h5); animates --variant (default 0, the nominal)")
    add_variant(p, "variant of RESULTS to animate (default 0, the nominal)")
    p.add_argument("--mechanism", default=None, metavar="NAME",
                   help="animate this mechanism's nominal design instead (built-in name or .toml file)")
    add_output(p, "output .mp4 or .gif (default: <name>.mp4 in the working directory); missing folders are "
                  "created, an existing file is kept unless --force")
    p.add_argument("--cycles", type=float, default=2, metavar="K", help="crank turns to show (default: 2)")
    p.add_argument("--legs", type=int, default=1, metavar="N",
                   help="draw a walker of N legs, crank phases spread evenly, odd legs mirrored (default: 1)")
    p.add_argument("--walker", action="store_true",
                   help="draw the walker the metrics describe (the study's [walker], else the mechanism's: its legs, "
                        "phases and mirrored legs) instead of --legs")
    p.add_argument("--frames", type=int, default=None, metavar="F",
                   help="total frames (default: 60 per crank turn)")
    p.add_argument("--fps", type=float, default=30, help="frames per second of the movie (default: 30)")
    p.add_argument("--dpi", type=float, default=100, help="pixels per inch of the frames (default: 100)")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..errors import UserError
    from ..mechanism import load_mechanism
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    from ..view import MOVIE_FORMATS, animate
    from ._args import output_path

    if (args.results is None) == (args.mechanism is None):
        raise UserError("animate: give a RESULTS file (with --variant) or --mechanism NAME, not both and not neither")
    if args.variant is not None and args.results is None:
        raise UserError("animate: --variant goes with a RESULTS file")
    if not (1 <= args.dpi <= 600):  # beyond that a figure is gigapixels: matplotlib fails or fills memory
        raise UserError(f"--dpi: expected a number from 1 to 600, got {args.dpi!r}")
    if args.results is not None:
        stem = Path(args.results).stem + (f"-v{args.variant}" if args.variant is not None else "")
    else:
        stem = Path(args.mechanism).stem
    out = args.output if args.output is not None else f"{stem}.mp4"
    output_path(out, args.force, formats=MOVIE_FORMATS, protect=[args.results] if args.results else ())
    # (a bad path fails before any work)
    if args.walker and args.legs != 1:
        raise UserError("animate: --walker draws the walker of the study or mechanism; give it or --legs, not both")
    kw = dict(cycles=args.cycles, frames=args.frames, legs=args.legs, fps=args.fps, dpi=args.dpi,
              walker=True if args.walker else None)
    if args.results is not None:
        with open_results(args.results) as res:
            movie = animate(res, out, variant=0 if args.variant is None else args.variant, **kw)
    else:
        movie = animate(load_mechanism(args.mechanism), out, **kw)
    note = f"; not ok: {movie.failure} (drawn up to it)" if movie.failure else ""
    print(f"wrote {os.fspath(movie.path)}: {movie.frames} frames at {movie.fps:g} fps "
          f"({movie.frames / movie.fps:.1f} s of video) in {movie.seconds:.1f} s{note}")
    return 0
