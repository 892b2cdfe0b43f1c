"""``explorer metrics RESULTS [--band B] [--metrics M1,M2|all] [-q]``: recompute gait metrics from the stored
foot paths (foot velocities that are not stored are solved again)."""

from __future__ import annotations

import math


def register(sub) -> None:
    p = sub.add_parser(
        "metrics", help="(re)compute the gait metrics of a results file from its stored foot paths",
        description="Compute the gait metrics of an existing, complete results file from the foot path (and "
                    "velocities) it stores, chunk by chunk, and write them to /metrics (replacing the stored ones "
                    "only once all are computed). Use it to change the stance band or to add metrics to a file "
                    "run without them (an optimisation stores only its objectives and constraints). Metrics "
                    "that need the foot velocities (body_speed_ripple, max_speed, ...) of a file that does not "
                    "store them solve each ok variant again from its stored design (as long as the run took). "
                    "Stance-based metrics kept from before with another band are recomputed too, so a file "
                    "never mixes bands. Paths and velocities are read, never written.")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    p.add_argument("--band", metavar="B", default=None,
                   help="stance band, a fraction of the step height in [0, 1] (default: the file's band, i.e. "
                        "the study's [scene] band unless recomputed since)")
    p.add_argument("--metrics", metavar="M1,M2|all", default=None,
                   help="metrics to compute (default: the ones stored, or all if none is); 'all' for every metric")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary; errors only")
    p.set_defaults(func=run)


def parse_band(text):
    from ..errors import UserError
    if text is None:
        return None
    try:
        b = float(str(text).strip())
    except ValueError:
        b = math.nan
    if not (0.0 <= b <= 1.0):
        raise UserError(f"--band: expected a number in [0, 1] (a fraction of the step height), got {text!r}")
    return b


def run(args) -> int:
    from ..analysis import recompute_metrics
    band = parse_band(args.band)
    out = recompute_metrics(args.results, band=band, names=args.metrics, progress=not args.quiet)
    if args.quiet:
        return 0
    names = out["metrics"]
    lines = [f"{out['path']}: computed {len(names)} metric{'s' if len(names) != 1 else ''} "
             f"({', '.join(names)}) for {out['n_variants']:,} variants ({out['ok']:,} ok) with band "
             f"{out['band']:g} in {out['wall_s']:.2f} s"]
    if out.get("lean"):
        lines.append(f"  {out['path']} stores metrics only: re-solved {out['resolved']:,} variants, a chunk at a time")
    elif out.get("resolved"):
        lines.append(f"  solved the foot velocities of {out['resolved']:,} ok variants again (the file does not "
                     f"store them)")
    if out["also"]:
        lines.append(f"  also recomputed {', '.join(out['also'])}: they were stored with another band")
    if out["kept"]:
        lines.append(f"  kept {', '.join(out['kept'])} as stored")
    print("\n".join(lines))
    return 0
