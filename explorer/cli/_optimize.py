"""``explorer optimize STUDY [--force | --resume] [-o PATH] [--dask ADDRESS] [--quiet]``: search a study's
design parameters (its ``[optimize]`` table) with pymoo, one batch solve per generation."""

from __future__ import annotations

import sys


def register(sub) -> None:
    from ._args import add_output

    p = sub.add_parser(
        "optimize", help="search the design space: multi-objective optimisation or path synthesis of a study "
                         "with an [optimize] table (pymoo: auto, nsga2, nsga3, de, ga, cmaes; then an optional polish)",
        description="Run the search a study file's [optimize] table describes: its design parameters and bounds, "
                    "objectives (metric names; each metric's direction comes from `explorer metrics --list`), "
                    "constraints (the --where filter language over metrics and parameters), the algorithm, "
                    "population and generations; the seed is [study] seed. Each generation is one batch solve and "
                    "one committed chunk of an ordinary results file (a `generation` column is added), so rank, "
                    "show, plot, animate and open_results(...).frame() work on it unchanged. Designs that fail "
                    "(assembly, branch, no convergence), fail the buildability screen or break a constraint are "
                    "infeasible and never on a front. With [optimize] polish = true one more generation holds the "
                    "polished designs (one objective path_error: least squares on the path residuals; several "
                    "objectives: each front design moved downhill on the weighted sum of the objectives, none "
                    "worse; inside the constraints: an augmented Lagrangian). With [optimize] rounds = N the "
                    "search restarts from fresh seeds, each round with its polish, until N rounds, `seconds`, "
                    "an exact fit or `repeat` rounds reaching the same best value (the stopping rule, which the "
                    "summary states with what holds the answer: a bound, a constraint, an exact fit); with a "
                    "cached curve atlas of the mechanism (explorer atlas build) the polish also starts from "
                    "its designs nearest the target. The summary gives the front (or best design), for several objectives the "
                    "hypervolume by generation, and then the best design against the nominal: each searched "
                    "parameter, each objective and constrained metric (nominal, best, change, %; SI units when "
                    "the study's [operating] gives unit) and the `explorer show` command that compares them. "
                    "Examples: explorer optimize studies/jansen-optimize.toml; explorer optimize "
                    "studies/jansen-stance.toml (a leg whose foot follows a drawn stance)",
        epilog="Resume: a run stopped at any moment (Ctrl-C, kill -9) finishes with --resume to the same final "
               "file as an uninterrupted run: the algorithm is replayed from its seed and committed generations are "
               "read back instead of solved. See `explorer plot RESULTS --front` for how the front moved.")
    p.add_argument("study", metavar="STUDY", help="study .toml file with an [optimize] table")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--resume", action="store_true",
                   help="finish an interrupted optimisation of the same study (same final result)")
    add_output(p, "results file (default: the study's [output] path, relative to the working directory)", group=g,
               force="overwrite an existing results file")
    p.add_argument("--dask", metavar="ADDRESS", default=None,
                   help="evaluate each generation on a Dask cluster: a scheduler address (tcp://host:8786), a "
                        "scheduler file (.json), or local:N for N local worker processes (needs "
                        "pip install \"explorer[dask]\")")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar and no summary; errors only")
    p.set_defaults(func=run)


def run(args) -> int:
    from .._extras import require
    from ..optimize import run_optimize
    from ..study import load_study
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
        print("\n".join(best_lines(summary)))
        sys.stdout.flush()
    return 0


# -- the best design against the nominal ---------------------------------------------------------------
def best_variant(summary) -> tuple[int, str]:
    """:func:`explorer.optimize.best_design` (the rule's home): (variant, how it was chosen)."""
    from ..optimize import best_design
    return best_design(summary)


def best_lines(summary) -> list[str]:
    """Lines saying what the optimisation changed: the best design (:func:`best_variant`) against the
    nominal (variant 0 when the nominal lies inside the bounds): each searched parameter (nominal →
    best, change, change %), each objective (nominal, best, change, change % and whether it improved;
    in SI units when the study's [operating] gives ``unit``, as ``--units si``), and the
    ``explorer show`` command that prints the comparison in full."""
    import math
    import shlex

    from ..gait import SPEED, change_pct, filter_columns, metric, operating_line, results_si
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    from ._format import better, table
    from ._show import parameter_lines

    if summary.front is None or len(summary.front) == 0:
        return ["no feasible design: nothing to compare with the nominal"]
    v, how = best_variant(summary)
    with open_results(summary.path) as res:
        df = res.frame()
        mech, nominal, perturbed = res.mechanism, res.nominal, set(res.perturbed)
        design = res.design(v, frame=df)
        op = res.operating
        si = results_si(res, df, "si") if op is not None and op.unit is not None else None
    row0 = df.iloc[0]
    # variant 0 is the nominal only when the nominal lies inside the bounds (the optimiser's first design)
    has_nominal = all(float(row0[p]) == nominal[p] for p in perturbed if p in df.columns)
    shown = df if si is None else si.frame
    path = shlex.quote(str(summary.path))
    lines = ["", f"best design against the nominal: variant {v}, {how}"]
    if v == 0 and has_nominal:
        lines.append("  the nominal itself: no design found improves on it")
        return lines
    mm = None if si is None else si.operating.unit * 1000.0
    params = parameter_lines(mech, design, nominal, perturbed, mm)
    # the searched parameters only (and the note on coordinates only when one is searched)
    coordinates = any(mech.parameter_kind(p) == "coordinate" for p in perturbed)
    changed = [params[0]] + [ln for ln in params[1:] if "(fixed)" not in ln
                             and (coordinates or not ln.startswith("(a coordinate"))]
    lines += ["  " + ln for ln in changed]
    if not has_nominal:
        lines.append("  the nominal lies outside the [optimize] bounds, so the file does not hold it and its "
                     "objectives are not known; the parameters above are against it")
        lines.append(f"  shown in full by: explorer show {path} --variant {v}" + (" --units si" if si is not None else ""))
        return lines
    lines.append("")
    rows = [("metric", "nominal", "best", "change", "change %", "unit", "")]
    nominal_ok = str(row0["status"]) == "ok"
    objectives = list(zip(summary.objectives, summary.directions))
    if si is not None and SPEED in si.converted and "travel" in summary.objectives:  # the walking speed follows travel
        i = summary.objectives.index("travel")
        objectives.insert(i + 1, (SPEED, summary.directions[i]))
    objectives = [(o, d, "") for o, d in objectives]
    for c in summary.constraints:  # the metrics the constraints name, marked with their constraint
        for name in filter_columns(c):
            info = metric(name)
            if info is not None and name in shown.columns and name not in [o for o, _, _ in objectives]:
                objectives.append((name, info.direction, f"constraint {c}" + (" (model units)" if si is not None
                                                                                  else "")))
    for o, d, note in objectives:
        x, r = float(shown[o].iloc[v]), float(shown[o].iloc[0])
        unit = si.units.get(o, "") if si is not None else (metric(o).unit if metric(o) is not None else "")
        rtext = f"{r:.6g}" if math.isfinite(r) else "-"
        if math.isfinite(r):
            pct = change_pct(x, r)
            word = "same" if x == r else "better" if (x > r) == (d == "max") else "worse"
            rows.append((o, rtext, f"{x:.6g}", f"{x - r:+.4g}", f"{pct:+.3g} %" if math.isfinite(pct) else "-",
                         unit, note or f"{word} ({better(d)})"))
        else:
            rows.append((o, rtext, f"{x:.6g}", "-", "-", unit, note or f"({better(d)})"))
    lines += ["  " + ln for ln in table(rows, (False, True, True, True, True, False, False))]
    if not nominal_ok:
        lines.append(f"  the nominal did not solve ({row0['status']}): its objectives are not numbers")
    if si is not None:
        lines.append("  " + operating_line(si.operating))
    lines.append(f"  shown in full by: explorer show {path} --variant {v} --vs 0" + (" --units si" if si is not None else ""))
    return lines
