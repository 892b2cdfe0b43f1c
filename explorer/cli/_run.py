"""``explorer run [STUDY] [--force] [--resume] [-o PATH] [--quiet] [--dask ADDRESS]``: run a study into an HDF5 file."""

from __future__ import annotations

import sys


def register(sub) -> None:
    from ._args import add_output

    p = sub.add_parser(
        "run", help="run a study (default: the built-in Jansen ±2 %% study) into an HDF5 results file",
        description="Simulate every variant of a study and stream the results to one HDF5 file. With no STUDY, "
                    "runs the built-in default study (studies/default.toml: 10,000 Jansen variants at ±2 %).")
    p.add_argument("study", nargs="?", default=None, metavar="STUDY",
                   help="study .toml file or built-in study name (default: the built-in 'default')")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--resume", action="store_true",
                   help="finish an interrupted run of the same study (only chunks not yet committed are run)")
    add_output(p, "results file (default: the study's [output] path, relative to the working directory)", group=g,
               force="overwrite an existing results file")
    p.add_argument("--chunk-size", type=int, default=None, metavar="N",
                   help="variants per chunk (memory per chunk; default: chosen from the scene, 2048 for a foot "
                        "path with velocities at 360 steps)")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="run on a Dask cluster, one HDF5 file per shard stitched into the results file: a "
                        "scheduler address (tcp://host:8786), a scheduler file (.json), or local:N to start "
                        "N local worker processes (needs pip install \"explorer[dask]\")")
    p.add_argument("--shard-size", type=int, default=None, metavar="N",
                   help="with --dask: variants per shard (one task and one file each; default: about 4 shards "
                        "per worker, at least ~520,000 configurations each, at most 1,000 shards)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary; errors only")
    p.set_defaults(func=run)


def run(args) -> int:
    if getattr(args, "dask", None):
        from ..study import load_study, run_study
        from ..study import dask_client, require_dask
        require_dask()
        study = load_study(args.study)  # a bad study fails before a cluster is started
        with dask_client(args.dask) as client:
            summary = run_study(study, output=args.output, resume=args.resume, force=args.force,
                                progress=not args.quiet, chunk_size=args.chunk_size, client=client,
                                shard_size=args.shard_size)
    elif getattr(args, "shard_size", None) is not None:
        from ..errors import UserError
        raise UserError("--shard-size applies to --dask runs only")
    else:
        from ..study import run_study
        summary = run_study(args.study, output=args.output, resume=args.resume, force=args.force,
                            progress=not args.quiet, chunk_size=args.chunk_size)
    if not args.quiet:
        print(summary.text())
        sys.stdout.flush()
    return 0
