"""``explorer edit [MECHANISM | RESULTS --variant V] [--port P] [--host H] [--no-browser]``: the design editor
in the browser (:mod:`explorer.edit`, the ``edit`` extra)."""

from __future__ import annotations

import sys
import time


def register(sub) -> None:
    from ._args import add_old_positional_variant, add_variant

    p = sub.add_parser(
        "edit", help="design by hand in the browser: drag a joint, watch the gait, the forces and the yield change",
        description="Start the design editor: a local web app (127.0.0.1 unless --host) that draws the leg at a "
                    "crank angle with every moving joint, ground pivot, crank and body point draggable, the foot path "
                    "over the turn, the walker's legs and the design it was opened with as a ghost; live walker "
                    "metrics, the buildability screen's margins, motor torque and pin forces in SI units (where the "
                    "design has an [operating] table with unit and rpm), yield on demand; a parameter panel with "
                    "undo, redo and reset; a results file's ranking and scatter to load designs from; save as a "
                    "mechanism file, SVG, DXF or a build kit (an existing file is replaced only once you confirm), a "
                    "link that holds the design, and a hand-off to explorer optimize and synth. Needs the edit "
                    "extra (pip install 'explorer[edit]').")
    p.add_argument("target", metavar="MECHANISM|RESULTS", nargs="?", default="jansen",
                   help="a built-in (default jansen), a mechanism .toml, or a results file (.h5) with --variant")
    add_variant(p, "the variant of RESULTS to open (default 0, the nominal)")
    add_old_positional_variant(p)
    p.add_argument("--port", type=int, default=None, metavar="P",
                   help="port to listen on (default 8765, or a free one if it is taken; 0: any free port)")
    p.add_argument("--host", default="127.0.0.1", metavar="H",
                   help="interface to listen on (default 127.0.0.1: this machine only; 0.0.0.0 lets anyone who can "
                        "reach this machine use the editor and save files as you)")
    p.add_argument("--no-browser", dest="browser", action="store_false", help="do not open a browser; print the URL")
    p.add_argument("--steps", type=int, default=None, metavar="S",
                   help="crank samples per turn (default 360, or the results file's own)")
    p.set_defaults(func=run)


def run(args) -> int:
    from .._extras import require
    from ..errors import UserError

    require("flask", "explorer edit")  # before any work: one line naming the extra
    if args.port is not None and not 0 <= args.port <= 65535:
        raise UserError(f"--port: expected a port from 0 to 65535, got {args.port}")
    variant = None
    if args.variant is not None or args.old_variant is not None:
        from ._args import chosen_variant
        variant = chosen_variant(args, "edit", "explorer edit RESULTS --variant N")
    from ..edit import EditSession, serve

    t = time.perf_counter()
    session = EditSession(args.target, variant, steps=args.steps)
    session.warm()  # every kernel the page uses, compiled (or loaded from the cache) before the page asks
    print(f"explorer edit: kernels ready in {time.perf_counter() - t:.1f} s", file=sys.stderr, flush=True)
    try:
        serve(session, args.host, args.port, open_browser=args.browser)  # until Ctrl-C (or SIGTERM)
    except KeyboardInterrupt:  # how the editor stops (Ctrl-C or SIGTERM): not an error
        from . import _interrupt_handled
        _interrupt_handled()
    print("explorer edit: stopped", file=sys.stderr)
    return 0
