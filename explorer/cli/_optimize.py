"""``explorer optimize STUDY [--force | --resume] [-o PATH] [--dask ADDRESS] [--quiet]``: search a study's
design parameters (its ``[optimize]`` table) with pymoo, one batch solve per generation."""

from __future__ import annotations

import sys


def register(sub) -> None:
    p = sub.add_parser(
        "optimize", help="search the design space: multi-objective optimisation or path synthesis of a study "
                         "with an [optimize] table (pymoo: nsga2, nsga3, de, ga, cmaes)",
        description="Run the search a study file's [optimize] table describes: its design parameters and bounds, "
                    "objectives (metric names; each metric's direction comes from `explorer metrics --list`), "
                    "constraints (the --where filter language over metrics and parameters), the algorithm, "
                    "population and generations; the seed is [study] seed. Each generation is one batch solve and "
                    "one committed chunk of an ordinary results file (a `generation` column is added), so rank, "
                    "show, plot, animate and open_results(...).frame() work on it unchanged. Designs that fail "
                    "(assembly, branch, no convergence), fail the buildability screen or break a constraint are "
                    "infeasible and never on a front. Example: explorer optimize studies/jansen-optimize.toml",
        epilog="Resume: a run stopped at any moment (Ctrl-C, kill -9) finishes with --resume to the same final "
               "file as an uninterrupted run: the algorithm is replayed from its seed and committed generations are "
               "read back instead of solved. See `explorer plot RESULTS --front` for how the front moved.")
    p.add_argument("study", metavar="STUDY", help="study .toml file with an [optimize] table")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--force", action="store_true", help="overwrite an existing results file")
    g.add_argument("--resume", action="store_true",
                   help="finish an interrupted optimisation of the same study (same final result)")
    p.add_argument("-o", "--output", metavar="PATH", default=None,
                   help="results file (default: the study's [output] path, relative to the working directory)")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="evaluate each generation on a Dask cluster: a scheduler address (tcp://host:8786), a "
                        "scheduler file (.json), or local:N for N local worker processes (needs "
                        "pip install \"explorer[dask]\")")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary; errors only")
    p.set_defaults(func=run)


def run(args) -> int:
    from .._extras import require
    from ..study import load_study, run_optimize
    require("pymoo", "explorer optimize")
    study = load_study(args.study)  # a bad study fails before a cluster is started
    if args.dask:
        from ..study import dask_client, require_dask
        require_dask()
        with dask_client(args.dask) as client:
            summary = run_optimize(study, output=args.output, resume=args.resume, force=args.force,
                                   progress=not args.quiet, client=client)
    else:
        summary = run_optimize(study, output=args.output, resume=args.resume, force=args.force,
                               progress=not args.quiet)
    if not args.quiet:
        print(summary.text())
        sys.stdout.flush()
    return 0
