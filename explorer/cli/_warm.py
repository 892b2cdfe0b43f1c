"""``explorer warm [STUDY ...] [--mechanisms all|NAMES]``: compile the kernels into the on-disk cache once."""

from __future__ import annotations


def register(sub) -> None:
    p = sub.add_parser(
        "warm", help="compile the kernels a study needs into the on-disk cache, so later runs start warm",
        description="Compile (or load) every kernel the given studies need, by running each on a few variants "
                    "into a temporary file, so that later runs of them load the kernels instead of compiling them "
                    "(the cache folder is keyed by explorer's kernel code; a copy of it serves another folder, user "
                    "or machine with the same explorer). With no STUDY, the built-in default study. A second "
                    "warm compiles nothing.",
        epilog="examples: explorer warm; explorer warm studies/jansen-forces.toml --mechanisms all; "
               "NUMBA_CACHE_DIR=/opt/explorer-cache explorer warm")
    p.add_argument("study", nargs="*", metavar="STUDY",
                   help="study .toml files or built-in study names (default: the built-in 'default')")
    p.add_argument("--mechanisms", metavar="all|NAMES", default=None,
                   help="also the foot-path-and-velocity kernels of these mechanisms: 'all' (every built-in) or "
                        "comma-separated built-in names or .toml files")
    p.add_argument("-q", "--quiet", action="store_true", help="print nothing")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..mechanism import builtin_mechanisms
    from ..study._warm import warm_kernels

    mechs = ()
    if args.mechanisms:
        mechs = builtin_mechanisms() if args.mechanisms == "all" else tuple(
            m.strip() for m in args.mechanisms.split(",") if m.strip())
    out = warm_kernels(tuple(args.study) or (None,), mechs)
    if not args.quiet:
        print(f"warm: {', '.join(out['items'])}: {out['compiled']} kernels compiled, the rest loaded, in "
              f"{out['seconds']:.1f} s ({out['cpu_seconds']:.1f} CPU-s); cache {out['cache']}")
    return 0
