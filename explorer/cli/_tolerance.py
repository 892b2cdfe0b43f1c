"""``explorer tolerance MECHANISM [--target 0.99] [--spread 0.01] [--variants 1000] [--parameters all|links|P1,P2]
[--criterion assembles|buildable] [--seed 1] [--steps 360] [--rtol 0.05] [--format table|json]``: how precisely
must the parts be cut so that a share of the legs walks (bisection on the spread,
:mod:`explorer.study._tolerance`)."""

from __future__ import annotations

import json
import math
import sys

FORMATS = ("table", "json")


def register(sub) -> None:
    from ._args import add_format, add_seed

    p = sub.add_parser(
        "tolerance", help="how precisely must the parts be cut so that 99 %% of legs walk (bisection on the spread)",
        description="Find the largest manufacturing spread ±s (every chosen length within ±s of its nominal, "
                    "uniformly; coordinates within ±s of the mechanism's size; by default every design parameter: "
                    "links, crank, pivots and body points) at which at least --target of the "
                    "legs still walk: assemble over a full crank turn (or, with --criterion buildable, also pass "
                    "the buildability screen). Each step runs a small uniform study (--variants, the same seed "
                    "every time, so the spreads are compared on the same random draws) into a temporary file and "
                    "counts; the spread doubles or halves from --spread until the target is bracketed, then is "
                    "bisected until the bracket is within --rtol. The answer is the largest spread that met the "
                    "target; its share carries the binomial standard error of --variants samples.",
        epilog="examples: explorer tolerance jansen; explorer tolerance klann --parameters links; "
               "explorer tolerance jansen --target 0.95 --parameters 1-6,2-6,crank; "
               "explorer tolerance my-leg.toml --criterion buildable --variants 2000")
    p.add_argument("mechanism", metavar="MECHANISM", help="built-in mechanism name or a mechanism .toml")
    p.add_argument("--target", metavar="SHARE", default="0.99", help="share of legs that must walk (default 0.99)")
    p.add_argument("--spread", metavar="S", default="0.01",
                   help="relative spread where the search starts (default 0.01 = ±1 %%)")
    p.add_argument("--variants", metavar="N", default="1000",
                   help="variants per study, the nominal included (default 1000)")
    p.add_argument("--parameters", metavar="all|links|P1,P2", default=None,
                   help="parameters cut to the spread: all (default: every design parameter: links, crank, pivots, "
                        "body points), links (the links and the crank radius only), or names as in [perturb] "
                        "parameters")
    p.add_argument("--criterion", metavar="WHAT", default="assembles",
                   help="assembles (default: turns a full turn) or buildable (and passes the buildability screen)")
    add_seed(p, 1, "the samples")
    p.add_argument("--steps", metavar="N", default="360", help="crank samples per cycle (default 360)")
    p.add_argument("--rtol", metavar="R", default="0.05",
                   help="stop when the bracket's ends are within this relative distance (default 0.05)")
    add_format(p, ("table", "json"), "json: every study of the search, to stdout")
    p.set_defaults(func=run)


def _number(text, option: str) -> float:
    from ..errors import UserError
    try:
        v = float(str(text).strip())
    except ValueError:
        v = math.nan
    if not math.isfinite(v):
        raise UserError(f"{option}: expected a number, got {text!r}")
    return v


def _pct(s: float) -> str:
    return "-" if not math.isfinite(s) else f"±{100 * s:.3g} %"


def run(args) -> int:
    from ..errors import UserError
    from ._args import whole as _whole
    from ..analysis import tolerance

    from ..analysis import PARAMETER_SETS, PARAMETER_WORDS
    params = "all"
    if args.parameters is not None:
        params = args.parameters.strip()
        if params not in PARAMETER_SETS:
            params = [s.strip() for s in params.split(",") if s.strip()]
            if not params:
                raise UserError(f"--parameters: expected comma-separated names or all, got {args.parameters!r}")
    table = args.format == "table"

    def progress(e):
        if table:
            print(f"  {_pct(e['spread']):>10}  {e['share']:.4f} ± {e['se']:.4f}  {e['count']:>7,} of {e['n']:,}  "
                  f"{'meets' if e['meets'] else 'misses'} the target", flush=True)

    if table:
        print(f"{args.mechanism}: the largest spread at which {100 * _number(args.target, '--target'):g} % of the legs "
              f"{'assemble over a full turn' if args.criterion == 'assembles' else 'turn and pass the buildability screen'} "
              f"(uniform studies of {_whole(args.variants, '--variants', 1):,} variants, seed {args.seed}), cutting "
              f"{PARAMETER_WORDS[params] if params in PARAMETER_SETS else 'the parameters named'} to the spread")
        print(f"  {'spread':>10}  {'share ± standard error':<22}  {'legs':>7}")
    res = tolerance(args.mechanism, target=_number(args.target, "--target"), spread=_number(args.spread, "--spread"),
                    variants=_whole(args.variants, "--variants", 1), parameters=params,
                    seed=args.seed, steps=_whole(args.steps, "--steps", 3),
                    criterion=args.criterion, rtol=_number(args.rtol, "--rtol"), progress=progress)
    if not table:
        sys.stdout.write(json.dumps(_jsonable(res.as_dict()), indent=1, allow_nan=False) + "\n")
        return 0
    lo, hi = res.bracket
    words = PARAMETER_WORDS[params] + ": " if params in PARAMETER_SETS else ""
    print(f"parameters cut to the spread: {words}{', '.join(res.parameters)}")
    if not math.isfinite(lo):
        print(f"no spread tried met the target within {len(res.evaluations)} studies")
        return 0
    if not math.isfinite(hi):
        print(f"answer: {_pct(lo)} or looser: even the widest spread tried keeps {100 * res.share:.2f} % "
              f"± {100 * res.se:.2f} % of the legs walking")
        return 0
    print(f"answer: cut to {_pct(lo)} (bracket {_pct(lo)} to {_pct(hi)}): at {_pct(lo)} {100 * res.share:.2f} % "
          f"± {100 * res.se:.2f} % of {res.n:,} sampled legs {'assemble' if res.criterion == 'assembles' else 'are buildable'} "
          f"(binomial standard error)")
    if math.isfinite(res.spread_se):
        print(f"accuracy: that standard error is ±{100 * res.spread_se:.2g} % in the spread (through the share's slope "
              f"across the bracket); the true crossing lies within about the bracket plus two of those")
    return 0


def _jsonable(d):
    if isinstance(d, dict):
        return {k: _jsonable(v) for k, v in d.items()}
    if isinstance(d, (list, tuple)):
        return [_jsonable(v) for v in d]
    if isinstance(d, float) and not math.isfinite(d):
        return None
    return d
