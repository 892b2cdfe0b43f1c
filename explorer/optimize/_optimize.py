"""``explorer optimize``: search a study's design parameters with pymoo, one batch solve per generation.

Each generation is one call of the chunk runner (:func:`~explorer.study.runner.design_solver`, the same code that
runs a sampled study's chunks, locally or on Dask) and one committed chunk of an ordinary results
file: rows ``g·P … g·P + P − 1`` hold generation g (P = ``[optimize] population``), with a
``generation`` column, so ``rank``, ``show``, ``plot``, ``animate`` and ``open_results(...).frame()``
read an optimisation like any study.

Objectives and feasibility (:func:`~._objectives.objective_matrix`) are computed from the rows as
read back from the file, the same way for a fresh generation and for a committed one. That is what
makes ``--resume`` exact: the algorithm is replayed from its seed, a committed generation is not
solved again but read (its designs must be bitwise the ones the replay asks for, or the file is
refused), and the run goes on from the first generation not committed: the final file equals an
uninterrupted run's, whenever the previous run was stopped (kill -9 included: a chunk is committed
atomically or not at all).

With ``[optimize] polish`` (the default of ``algorithm = "auto"`` on ``path_error``), one more
generation, number G = ``generations``, holds the polished designs (:mod:`explorer.synthesis._polish`: the batched
Levenberg–Marquardt from the ``polish_starts`` best distinct feasible designs of generations 0 … G−1,
then least squares from the best of its answers and the ``restarts`` next best distinct ones; with
constraints or the screen, also points on the way back to each start), solved
by the same chunk runner; its starts are read from the file, so ``--resume`` polishes them to the same
designs. Its rows beyond the polished designs are "not-run".

A generation the algorithm fills with fewer designs than the population (CMA-ES's first: its start
point alone) leaves the rest of its rows "not-run"; so does every generation after an algorithm that
stops early (CMA-ES when its step size has collapsed). The summary says so.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Terminated, UserError, signals_held
from ..gait import pareto_front
from ..store import Results
from ..store import OutputLock, ResultsWriter
from ..study import Study, load_study
from ..study.runner import (Recipe, check_client, design_solver, designs_from_x, nominal_x, one_thread, optimize_writer,
                           results_path, results_state, stored_x, validate_study, warm_everywhere, worker_threads, writer_counts)
from ._front_polish import front_polish_generation
from ._hypervolume import Hypervolume, hypervolume_history
from ._objectives import objective_matrix


@dataclass
class OptimizeSummary:
    """What :func:`run_optimize` did. ``os.fspath(summary)`` is the results path.

    generations : generations in the file; ran : generations evaluated by this call (the rest were
    read back on ``--resume``); evaluations : designs solved over the whole run; feasible : feasible
    designs; front : the final Pareto front (or best design) as a DataFrame of variant, generation,
    the parameters and the objectives; stopped_early : the generation after which the algorithm
    stopped on its own (None if it ran every generation); wall_s : seconds this call took; polished :
    with ``[optimize] polish``, {"starts", "best_before", "best_after", "solved"} (the best objective
    before and after the polish generation, and the designs its least squares solved; None when the
    polish generation was read back on --resume), else None.
    hypervolume : for several objectives, the front's hypervolume after each generation (list of G floats,
    :mod:`._hypervolume` defines it; [] for one objective); hypervolume_detail : its
    :class:`~._hypervolume.Hypervolume` (ideal, nadir and reference point in the objectives' units).
    rounds : {"rounds": [{"round", "best", "variant"} per round run], "reason": why the rounds stopped (the
    stopping rule), "atlas": {"used", "path", "designs"} or {"used": False, "why"}}; the polish's
    ``polished["held"]`` says what holds its best design: {"bounds", "constraints", "exact", "gradient"}.
    """

    path: Path
    name: str
    algorithm: str
    objectives: tuple
    directions: tuple
    generations: int
    ran: int
    evaluations: int
    feasible: int
    counts: dict
    front: object
    wall_s: float
    stopped_early: int | None = None
    resumed: bool = False
    hypervolume: list = field(default_factory=list)
    constraints: tuple = ()
    hypervolume_detail: Hypervolume | None = None
    polished: dict | None = None
    rounds: dict | None = None

    def __fspath__(self) -> str:
        return str(self.path)

    def rank_command(self) -> str:
        """The ``explorer rank`` command that lists the same designs from the file."""
        objs = ",".join(self.objectives)
        cmd = f"explorer rank {self.path} " + (f"--pareto {objs} --top 0" if len(self.objectives) > 1 else
                                               f"--by {objs} --top 1")
        if self.constraints:
            where = " and ".join(f"({c})" for c in self.constraints)
            cmd += f" --where '{where}'"
        return cmd

    def text(self) -> str:
        objs = ", ".join(f"{o} ({d})" for o, d in zip(self.objectives, self.directions))
        lines = [f"{self.name}: {self.algorithm}, {self.generations} generations, {self.evaluations:,} designs solved "
                 f"({self.ran} generations {'resumed' if self.resumed else 'run'} here) → {self.path}",
                 f"  objectives: {objs}",
                 f"  feasible {self.feasible:,} of {self.evaluations:,}; statuses: "
                 + ", ".join(f"{k} {n:,}" for k, n in self.counts.items() if n)]
        if self.stopped_early is not None:
            lines.append(f"  the algorithm stopped on its own after generation {self.stopped_early}; later rows are "
                         f"not-run")
        front = self.front
        if front is None or len(front) == 0:
            lines.append("  no feasible design")
        else:
            what = "best design" if len(self.objectives) == 1 else f"Pareto front: {len(front)} designs"
            lines.append(f"  {what} ({self.rank_command()}):")
            lines += ["    " + line for line in front.head(10).to_string(index=False).splitlines()]
        if self.hypervolume_detail is not None:
            lines.append("  " + _hypervolume_line(self.hypervolume_detail, self.objectives))
        if self.polished is not None and "improved" in self.polished:  # several objectives: the front's polish
            p = self.polished
            lines.append(f"  front polish (generation {self.generations}): " + (
                f"{p['improved']} designs read back" if p["front"] is None else
                f"{p['improved']} of {p['front']} front designs improved, each dominating the design it started "
                f"from ({p['evaluations']:,} designs solved)"))
        elif self.polished is not None:
            p = self.polished
            solved = "read back" if p["solved"] is None else f"{p['solved']:,} designs solved by its least squares"
            lines.append(f"  polish: {p['starts']} starts (generation {self.generations}; {solved}); best "
                         f"{self.objectives[0]} {p['best_before']:.6g} -> {p['best_after']:.6g}")
        lines += self._rounds_lines()
        lines.append(f"  wall {self.wall_s:.2f} s")
        return "\n".join(lines)

    def _rounds_lines(self) -> list:
        """The restart rounds and the stopping rule: why the search stopped, and what holds its answer."""
        info = self.rounds or {}
        out = []
        rs = info.get("rounds") or []
        if len(rs) > 1 or (info.get("reason") and "all 1 rounds" not in info.get("reason", "")):
            vals = ", ".join(f"{x['best']:.6g}" for x in rs[:12]) + (" …" if len(rs) > 12 else "")
            out.append(f"  rounds: {len(rs)} ran, best of each: {vals}; stopped: {info.get('reason')}")
        at = info.get("atlas")
        if at and at.get("used"):
            out.append(f"  atlas starts from {at['path']} ({at['designs']:,} designs)")
        held = (self.polished or {}).get("held")
        if held is not None:
            if held.get("exact"):
                what = "an exact fit (the objective is 0 to rounding)"
            elif held.get("bounds") or held.get("constraints"):
                what = "held by " + "; ".join([f"the bound {b}" for b in held["bounds"]]
                                              + [f"the constraint `{c}`" for c in held["constraints"]])
            else:
                what = f"an interior minimum (no bound or constraint holds it; largest gradient {held.get('gradient', 0):.3g})"
            out.append(f"  the best polished design is {what}")
        return out

    __str__ = text


def _hypervolume_line(h: Hypervolume, objectives) -> str:
    """One line: the hypervolume at (up to) eight generations, evenly spaced, and how it is normalised."""
    G = len(h.values)
    picks = sorted(set(np.linspace(0, G - 1, min(G, 8)).round().astype(int).tolist())) if G else []
    gens = ", ".join(f"{g}: {h.values[g]:.4f}" for g in picks)
    ref = ", ".join(f"{o} {r:.6g}" for o, r in zip(objectives, h.reference))
    return (f"hypervolume by generation ({gens}; of at most {h.maximum:.4g}: each objective normalised to 0 at "
            f"its best feasible value and 1 at its worst on any generation's front; reference point 1.1 each, "
            f"i.e. {ref}; every generation in OptimizeSummary.hypervolume)")


def _initial(study: Study, seed: int | None = None) -> np.ndarray:
    """The first generation of a population-based algorithm: the nominal design (when inside the
    bounds), then a Latin hypercube over the bounds (scipy.stats.qmc, seeded by ``seed``, default
    ``[study] seed``)."""
    from scipy.stats import qmc
    opt = study.optimize
    lo, hi = np.array(opt.lower), np.array(opt.upper)
    P = opt.population
    nominal = np.array([study.mech.parameters()[p] for p in opt.parameters])
    inside = bool(np.all((nominal >= lo) & (nominal <= hi)))
    m = P - int(inside)
    pts = qmc.LatinHypercube(d=len(lo), seed=np.random.default_rng(study.seed if seed is None else seed)).random(m)
    X = lo + pts * (hi - lo)
    return np.vstack([nominal[None, :], X]) if inside else X


def _algorithm(study: Study, seed: int | None = None):
    """The pymoo algorithm of ``[optimize] algorithm``, configured for the study."""
    opt = study.optimize
    P = opt.population
    name = opt.search
    if name == "nsga2":
        from pymoo.algorithms.moo.nsga2 import NSGA2
        return NSGA2(pop_size=P, sampling=_initial(study, seed))
    if name == "nsga3":
        from pymoo.algorithms.moo.nsga3 import NSGA3
        from pymoo.util.ref_dirs import get_reference_directions
        M = len(opt.objectives)
        p = 1
        while math.comb(p + 1 + M - 1, M - 1) <= P:
            p += 1
        return NSGA3(ref_dirs=get_reference_directions("das-dennis", M, n_partitions=p), pop_size=P,
                     sampling=_initial(study, seed))
    if name == "de":
        from pymoo.algorithms.soo.nonconvex.de import DE
        return DE(pop_size=P, sampling=_initial(study, seed))
    if name == "ga":
        from pymoo.algorithms.soo.nonconvex.ga import GA
        return GA(pop_size=P, sampling=_initial(study, seed))
    from pymoo.algorithms.soo.nonconvex.cmaes import CMAES
    return CMAES(x0=nominal_x(study), sigma=0.25, popsize=P, tolfun=0.0, tolx=0.0)


# -- evaluation: local or on Dask ----------------------------------------------------------------------
def _local_evaluator(study: Study):
    solve = design_solver(study)
    return lambda lengths, crank, geometry: solve(lengths, crank, geometry)


def _concat(parts):
    """One (batch, metrics) from the (batch, metrics) of consecutive row ranges."""
    import dataclasses
    batches = [b for b, _ in parts]
    first = batches[0]
    joined = {}
    for f in dataclasses.fields(first):
        v = getattr(first, f.name)
        if f.name == "theta" or v is None:  # None: a part the run did not ask for (torque without forces)
            joined[f.name] = v
        elif isinstance(v, dict):
            joined[f.name] = {k: np.concatenate([getattr(b, f.name)[k] for b in batches]) for k in v}
        else:
            joined[f.name] = np.concatenate([getattr(b, f.name) for b in batches])
    metrics = None
    if parts[0][1] is not None:
        metrics = {k: np.concatenate([m[k] for _, m in parts]) for k in parts[0][1]}
    return dataclasses.replace(first, **joined), metrics


def _design_task(recipe, lengths, crank, geometry):
    """A Dask task: solve some designs of a generation on one Numba thread."""
    one_thread()
    study = recipe.study()
    return design_solver(study)(lengths, crank, geometry)


def _dask_evaluator(client, study: Study):
    """Evaluate a generation by splitting its designs over the cluster's worker threads."""
    recipe = Recipe(study)
    warm_everywhere(client, recipe)
    workers = max(1, worker_threads(client))
    [recipe_f] = client.scatter([recipe], broadcast=True)

    def evaluate(lengths, crank, geometry):
        n = len(crank)
        cuts = np.linspace(0, n, min(n, workers) + 1).astype(int)
        futures = [client.submit(_design_task, recipe_f, lengths[a:b], crank[a:b], geometry[a:b], pure=False)
                   for a, b in zip(cuts[:-1], cuts[1:]) if b > a]
        return _concat(client.gather(futures))

    return evaluate


# -- the run -----------------------------------------------------------------------------------------
def run_optimize(study, output=None, resume: bool = False, force: bool = False, progress: bool = True,
                 client=None) -> OptimizeSummary:
    """Run the ``[optimize]`` search of a study into one HDF5 results file.

    study : a study with an ``[optimize]`` table (path, dict or :class:`Study`). output, resume,
    force, progress : as for :func:`~explorer.study.run_study` (``resume`` replays the algorithm
    from its seed and solves only the generations not committed). client : a
    ``dask.distributed.Client`` to evaluate each generation on (default: this process).

    Returns an :class:`OptimizeSummary`. Raises :class:`~explorer.errors.UserError` for a study
    without ``[optimize]``, an existing file without --force/--resume, or a file written by another
    run.
    """
    from .._extras import require
    t0 = time.perf_counter()
    require("pymoo", "explorer optimize")  # before a results file is created
    if client is not None:
        check_client(client, "run_optimize")
    study = load_study(study)
    if study.optimize is None:
        raise UserError(f"{study.source}: no [optimize] table; `explorer optimize` needs one (see `explorer optimize "
                        f"--help`), `explorer run` runs a sampled study")
    opt = study.optimize
    out = results_path(study, output, resume, force)
    validate_study(study, optimizing=True)
    with OutputLock(out):
        resumed = False
        if out.exists():
            if resume:
                writer = ResultsWriter.resume(out, study)
                resumed = True
            elif force:
                writer = optimize_writer(out, study)
            else:
                state = results_state(out)
                raise UserError(f"{out}: results file exists ({state}); pass --force to overwrite it"
                                + (" or --resume to finish it" if state != "complete" else ""))
        else:
            writer = optimize_writer(out, study)
        try:
            evaluate = _dask_evaluator(client, study) if client is not None else _local_evaluator(study)
            ran, stopped, _, polished, rounds = _search(study, writer, out, evaluate, progress)
            if not writer.complete:
                writer.finish()
            counts = writer_counts(writer)
            df = Results(writer.f, out).frame()
        finally:
            with signals_held():
                writer.close()
    F, _, feasible = objective_matrix(df, opt, study.screen)
    front = final_front(df, study)
    hvd = hypervolume_history(df, opt, study.screen) if len(opt.objectives) > 1 else None
    hv = [] if hvd is None else [float(v) for v in hvd.values]
    return OptimizeSummary(out, study.name, opt.algorithm, opt.objectives, opt.directions, opt.generations, ran,
                           int((df["status"].astype(str) != "not-run").sum()), int(feasible.sum()), counts, front,
                           time.perf_counter() - t0, stopped, resumed, hv, opt.constraints, hvd, polished=polished,
                           rounds=rounds)


def final_front(df, study: Study):
    """The feasible non-dominated designs of an optimisation's frame (the best one for a single
    objective): variant, generation, the searched parameters and the objectives, best first."""
    opt = study.optimize
    F, _, feasible = objective_matrix(df, opt, study.screen)
    cols = ["variant", "generation", *opt.parameters, *opt.objectives]
    cols = list(dict.fromkeys(c for c in cols if c in df.columns))
    ok = df[feasible]
    if len(ok) == 0:
        return ok[cols]
    if len(opt.objectives) == 1:
        best = int(np.argmin(F[feasible, 0]))
        return ok.iloc[[best]][cols]
    mask = pareto_front(ok, list(opt.objectives), dict(zip(opt.objectives, opt.directions)))
    front = ok[mask]
    first = opt.objectives[0]
    return front.sort_values(first, ascending=opt.directions[0] == "min", kind="mergesort")[cols]


def _round_seed(seed: int, r: int) -> int:
    """The search's seed in restart round r: the study's own in round 0, then one drawn from (seed, r)."""
    if r == 0:
        return int(seed)
    return int(np.random.SeedSequence([int(seed), int(r)]).generate_state(1)[0] % (2**31 - 1))


def _search(study: Study, writer: ResultsWriter, out: Path, evaluate, progress: bool):
    """Run the rounds: in each, replay committed generations, evaluate the rest, then the polish
    generation; then the stopping rule. Returns (generations evaluated here, generation after which the
    algorithm stopped on its own or None, hypervolume per generation, the polish's summary, the rounds'
    summary dict)."""
    opt = study.optimize
    results = Results(writer.f, out)
    t_start = time.perf_counter()
    total_ran, stopped, hv, polished = 0, None, [], None
    starts = _AtlasStarts(study) if (opt.polish and len(opt.objectives) == 1) else None
    rounds = []
    reason = None
    bar = _bar(progress, opt.rounds * opt.generations, study.name)
    try:
        for r in range(opt.rounds):
            if r > 0:
                reason = _stop_reason(study, rounds, time.perf_counter() - t_start, writer, r)
                if reason is not None:
                    break
            ran, stop_r, hv_r, pol_r = _one_round(study, writer, out, evaluate, results, r, starts, bar)
            total_ran += ran
            stopped = stop_r if stopped is None else stopped
            hv += hv_r
            if pol_r is not None:
                polished = pol_r if polished is None else _merge_polish(polished, pol_r)
            rounds.append(_round_best(study, results, r))
        else:
            reason = _stop_reason(study, rounds, time.perf_counter() - t_start, writer, opt.rounds)
        # rounds not begun are committed empty, in one go: not-run rows, and a complete file
        with signals_held():
            writer.skip_chunks([g for g in range(opt.chunks) if not writer.done[g]])
    except KeyboardInterrupt as exc:
        done = int(writer.done.sum())
        what = "terminated" if isinstance(exc, Terminated) else "interrupted"
        raise type(exc)(f"{out}: {what} with {done} of {opt.chunks} generations committed; run again with --resume to "
                        f"finish it (the same final result)") from None
    finally:
        if bar is not None:
            bar.close()
    info = {"rounds": rounds, "reason": reason, "atlas": None if starts is None else starts.describe()}
    return total_ran, stopped, hv, polished, info


def _merge_polish(a: dict, b: dict) -> dict:
    """The polish summaries of two rounds as one (starts and designs solved added, best before and after
    the better)."""
    out = dict(a)
    for k in ("starts", "solved"):
        if a.get(k) is not None and b.get(k) is not None:
            out[k] = a[k] + b[k]
        else:
            out[k] = None
    for k in ("best_before", "best_after"):
        va, vb = a.get(k), b.get(k)
        out[k] = vb if (va is None or (vb is not None and vb < va)) else va
    if "held" in b:
        out["held"] = b["held"]
    return out


def _one_round(study: Study, writer: ResultsWriter, out: Path, evaluate, results, r: int, starts, bar):
    """Round r: the algorithm's generations (rows of generations r·per_round …), then its polish."""
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem

    opt = study.optimize
    P, G = opt.population, opt.generations
    base = r * opt.per_round
    n_obj, n_con = len(opt.objectives), 2 + len(opt.constraints)
    state = {"g": 0, "ran": 0}

    def generation(X):
        g = base + state["g"]
        a, _ = writer.chunk_range(g)
        m = X.shape[0]
        if writer.done[g]:
            df = results.frame(rows=(a, a + m))
            if not np.array_equal(stored_x(df, study), X):
                raise UserError(f"{out}: generation {g} in the file is not what this run's algorithm asks for (another "
                                f"pymoo or numpy version?); start over with --force")
        else:
            lengths, crank, geometry = designs_from_x(study, X)
            batch, metrics = evaluate(lengths, crank, geometry)
            with signals_held():  # a commit is never cut in half by Ctrl-C (kill -9 leaves it uncommitted)
                writer.write_chunk(g, lengths, crank, batch, metrics, geometry=geometry, partial=True)
            state["ran"] += 1
            df = results.frame(rows=(a, a + m))
        return objective_matrix(df, opt, study.screen)

    class _Study(Problem):
        def __init__(self):
            super().__init__(n_var=len(opt.parameters), n_obj=n_obj, n_ieq_constr=n_con, xl=np.array(opt.lower),
                             xu=np.array(opt.upper))

        def _evaluate(self, X, out_, *args, **kwargs):
            F, Gc, _ = generation(np.asarray(X, dtype=np.float64))
            out_["F"] = F
            out_["G"] = Gc

    problem = _Study()
    algorithm = _algorithm(study, seed=_round_seed(study.seed, r))
    algorithm.setup(problem, termination=("n_gen", G), seed=_round_seed(study.seed, r), verbose=False)
    evaluator = Evaluator()
    hv = []
    ref = None
    t_start = time.perf_counter()
    stopped = None
    while state["g"] < G:
        if not algorithm.has_next():
            stopped = base + state["g"] - 1
            break
        pop = algorithm.ask()
        if len(pop) > P:
            raise RuntimeError(f"{opt.algorithm} asked for {len(pop)} designs in one generation, more than the "
                               f"population {P}")
        evaluator.eval(problem, pop)
        algorithm.tell(infills=pop)
        F = algorithm.opt.get("F") if algorithm.opt is not None else None
        feas = algorithm.opt.get("feas") if algorithm.opt is not None else None
        value, ref = _progress_value(F, feas, n_obj, opt.directions, ref)
        hv.append(value)
        state["g"] += 1
        if bar is not None:
            rate = state["g"] * P / max(time.perf_counter() - t_start, 1e-9)
            label = "best" if n_obj == 1 else "hypervolume"
            bar.set_postfix_str(f"round {r + 1}, {rate:,.0f} designs/s, {label} {value:.6g}", refresh=False)
            bar.update(1)
    # generations never asked for (an algorithm that stopped early) are committed empty: not-run rows
    for g in range(base + state["g"], base + G):
        if not writer.done[g]:
            writer.write_chunk(g, np.empty((0, len(study.mech.links))), np.empty(0), None, partial=True)
    polished = None
    if opt.polish and len(opt.objectives) > 1:  # the front's polish (_front_polish)
        polished = front_polish_generation(study, writer, results, evaluate, final_front)
    elif opt.polish:
        polished = _polish_generation(study, writer, results, evaluate, r, starts)
    return state["ran"], stopped, hv, polished


def _round_best(study: Study, results, r: int) -> dict:
    """{"round", "best" (the round's best feasible objective as the metric reads, NaN if none), "variant"}."""
    opt = study.optimize
    P = opt.population
    a, b = r * opt.per_round * P, (r + 1) * opt.per_round * P
    df = results.frame(rows=(a, b))
    F, _, feasible = objective_matrix(df, opt, study.screen)
    if not feasible.any():
        return {"round": r, "best": math.nan, "variant": None}
    i = int(np.argmin(np.where(feasible, F[:, 0], np.inf)))
    v = float(F[i, 0])
    return {"round": r, "best": -v if opt.directions[0] == "max" else v, "variant": int(df["variant"].iloc[i])}


#: Two rounds reach the same best value when they differ by less than this, relative.
REPEAT_RTOL = 1e-6


def _stop_reason(study: Study, rounds: list, elapsed: float, writer, r: int) -> str | None:
    """Why the rounds stop before round r (None: go on). In order: every round ran; an exact fit (the
    one objective path_error within 1e-12 of the target's size of 0); the best value reached by
    ``repeat`` rounds; the ``seconds`` budget spent (not checked for a round already committed, so a
    resumed run begins no round its first run had not)."""
    opt = study.optimize
    if r >= opt.rounds:
        return f"all {opt.rounds} rounds ran"
    vals = [x["best"] for x in rounds if math.isfinite(x["best"])]
    if vals:
        best = min(vals) if opt.directions[0] == "min" else max(vals)
        if opt.objectives == ("path_error",) and study.target is not None:
            size = float(np.sqrt(np.mean(np.sum((study.target.points - study.target.points.mean(axis=0)) ** 2,
                                                axis=1)))) or 1.0
            if best <= 1e-12 * size:
                return f"an exact fit after round {len(rounds)} (path_error {best:.3g})"
        if opt.repeat:
            hits = sum(abs(v - best) <= REPEAT_RTOL * max(abs(best), 1e-300) for v in vals)
            if hits >= opt.repeat:
                return f"the best value {best:.6g} was reached by {hits} rounds (repeat = {opt.repeat})"
    begun = bool(writer.done[r * opt.per_round])
    if opt.seconds is not None and elapsed >= opt.seconds and not begun:
        return f"the time budget ({opt.seconds:g} s) was spent after {len(rounds)} rounds"
    return None


class _AtlasStarts:
    """Polish starts from the curve atlas of the study's mechanism (``[optimize] atlas``): the atlas
    designs whose paths best match the target, moved onto it, as the study's parameters (clipped into the
    bounds); round r takes the next ``polish_starts`` of them. None of it when there is no atlas of the
    mechanism's structure and assembly, no [target], or the search cannot move and turn a design (it must
    search the crank centre and the first ground pivot)."""

    def __init__(self, study: Study):
        self.study = study
        self.atlas = None
        self.why = None
        self._cands = None
        opt = study.optimize
        if opt.atlas is False or study.target is None or opt.objectives != ("path_error",):
            self.why = "not asked for" if opt.atlas is False else "no target"
            return
        from ..synthesis import atlas_spec, find_atlas, open_atlas, same_branch, structure_key
        mech = study.mech
        gauge = atlas_spec(mech).gauge
        missing = [g for g in gauge if g not in opt.parameters]
        if missing:
            self.why = f"the search holds {', '.join(missing)} (an atlas design must be moved and turned onto the target)"
            return
        if study.target.ignore or study.target.match == "arc":
            self.why = f"match {study.target.match!r}" + (" with ignore" if study.target.ignore else "")
            return
        path = find_atlas(mech) if opt.atlas == "auto" else Path(opt.atlas)
        if path is None:
            self.why = "no atlas of this mechanism (explorer atlas build)"
            return
        at = open_atlas(path)
        if at.attrs.get("structure") != structure_key(mech) or not same_branch(at.mech, mech):
            if opt.atlas != "auto":
                raise UserError(f"{study.source}: optimize.atlas: {path} is an atlas of {at.mech.name!r}, whose designs "
                                f"{study.mech.name!r} cannot take (another structure or assembly)")
            self.why = "the cached atlas is of another assembly"
            return
        self.atlas = at

    def describe(self) -> dict:
        if self.atlas is None:
            return {"used": False, "why": self.why}
        return {"used": True, "path": str(self.atlas.path), "designs": len(self.atlas)}

    def starts(self, r: int, k: int) -> np.ndarray:
        """(≤ k, n_parameters) the starts of round r."""
        if self.atlas is None or k <= 0:
            return np.empty((0, len(self.study.optimize.parameters)))
        if self._cands is None:
            t = self.study.target
            angles = t.angles if t.match == "timed" else None
            pool = self.atlas.query(t.points, angles, closed=t.closed, free_phase=t.phase == "free",
                                    k=max(256, 8 * k))
            if angles is None and not t.closed:
                # an open stretch may also be met by a path that comes back past it (a thin loop along the
                # points): the closed look-up of the points there and back, interleaved with the stretches
                there_back = np.vstack([t.points, t.points[-2:0:-1]]) if len(t.points) > 2 else t.points
                loops = self.atlas.query(there_back, None, closed=True, k=len(pool))
                pool = [c for pair in zip(pool, loops) for c in pair]
            from ..synthesis import diverse
            self._cands = diverse(self.atlas, pool, len(pool), distinct=0.02)
        opt = self.study.optimize
        chosen = self._cands[r * k:(r + 1) * k]
        rows = []
        from ..synthesis import move_parameters
        names = tuple(self.study.mech.parameters())
        for c in chosen:
            full = move_parameters(self.atlas.mech, self.atlas.design(c.row), c.A, c.B, names)
            rows.append([full[p] for p in opt.parameters])
        return np.clip(np.array(rows, dtype=np.float64).reshape(len(rows), len(opt.parameters)), opt.lower, opt.upper)


def _polish_generation(study: Study, writer: ResultsWriter, results: Results, evaluate, r: int = 0,
                       atlas=None) -> dict:
    """The polish of round r (``[optimize] polish``, :mod:`explorer.synthesis._polish`): the batched
    Levenberg–Marquardt from the ``polish_starts`` best distinct feasible designs of the round's
    generations and as many atlas starts (:class:`_AtlasStarts`), then least squares from the best of its
    answers and the ``restarts`` next best distinct ones, inside the constraints when there are any (or
    the screen: :func:`explorer.synthesis.polish_constrained`), the polished designs committed as the round's last
    generation through the chunk runner (rows beyond them not-run). Read from the file and the atlas, so
    a resumed run polishes the same starts to the same designs; a committed polish generation is read
    back. Returns {"starts", "best_before", "best_after", "solved" (None when read back), "held" (what
    holds the best answer, :func:`_held`)}."""
    opt = study.optimize
    P, G = opt.population, opt.generations
    base = r * opt.per_round
    gpol = base + G
    df = results.frame(rows=(base * P, gpol * P))
    F, _, feasible = objective_matrix(df, opt, study.screen)
    f = np.where(feasible, F[:, 0], np.inf)
    before = float(f.min()) if np.isfinite(f).any() else math.nan
    a, _ = writer.chunk_range(gpol)
    if writer.done[gpol]:
        new = results.frame(rows=(a, a + P))
        Fn, _, feas_n = objective_matrix(new, opt, study.screen)
        run = (new["status"].astype(str) != "not-run").to_numpy()
        after = float(min(before, Fn[feas_n, 0].min())) if feas_n.any() else before
        return {"starts": int(run.sum()), "best_before": before, "best_after": after, "solved": None}
    X = stored_x(df, study)
    lo, hi = np.array(opt.lower), np.array(opt.upper)
    res, cres, coarse = _residuals(study, evaluate)
    from ..synthesis import distinct_best, finish, polish, polish_constrained, scout_and_polish
    inside = -1  # the candidate polished inside the constraints even though it meets them (a feasible start)
    extra = atlas.starts(r, max(opt.polish_starts, 1 + opt.restarts)) if atlas is not None else np.empty((0, len(lo)))
    first = distinct_best(X, f, lo, hi, opt.polish_starts, distinct=0.02) if opt.polish_starts > 0 else []
    S0 = np.vstack([X[first], extra]) if len(first) or len(extra) else np.empty((0, len(lo)))
    if len(S0):  # the batched LM from the best distinct feasible designs and the atlas's, scouted, then finished
        lm = scout_and_polish(res, S0, lo, hi, coarse=coarse, ordered=study.target.closed)
        cand_x, cand_f, _ = finish(res, lm, lo, hi, 1 + opt.restarts)
        if cres is not None:  # the LM's answers may break a constraint: the round's best feasible design too
            cand_x = np.vstack([cand_x, X[distinct_best(X, f, lo, hi, 1)]])
            inside = len(cand_x) - 1  # ... polished from where it stands, inside the constraints
    else:  # the plain polish of the best distinct designs of the round
        cand_x = np.array([polish(res, X[i], lo, hi).x for i in distinct_best(X, f, lo, hi, 1 + opt.restarts)])
        cand_x = cand_x.reshape(len(cand_x), len(lo))
    pick = list(range(len(cand_x)))
    out = []
    for j, x in enumerate(cand_x):  # inside the constraints (cres) where an answer breaks one
        if cres is None or (j != inside and cres.state(x)[2]):
            out.append(x)
            continue
        best, last = polish_constrained(cres, x, lo, hi, max_nfev=AL_NFEV)
        out.append(last)
        if best is not None:
            out.append(best.x)
    Xp = np.array(out).reshape(len(out), len(lo))
    Xp = Xp[:P]
    lengths, crank, geometry = designs_from_x(study, Xp)
    batch, metrics = evaluate(lengths, crank, geometry) if len(Xp) else (None, None)
    with signals_held():
        writer.write_chunk(gpol, lengths, crank, batch, metrics, geometry=geometry if len(Xp) else None, partial=True)
    new = results.frame(rows=(a, a + len(Xp)))
    Fn, _, feas_n = objective_matrix(new, opt, study.screen)
    after = float(min(before, Fn[feas_n, 0].min())) if feas_n.any() else before
    solved = res.evaluations + coarse.evaluations + (cres.evaluations if cres is not None else 0)
    out = {"starts": len(pick), "best_before": before, "best_after": after, "solved": solved}
    if feas_n.any():
        i = int(np.argmin(np.where(feas_n, Fn[:, 0], np.inf)))
        out["held"] = _held(study, cres if cres is not None else res, Xp[i], lo, hi)
    return out


#: Most residual evaluations of each least-squares solve of the polish inside the constraints.
AL_NFEV = 200


def _residuals(study: Study, evaluate):
    """(residuals, constrained residuals or None, coarse residuals) of the polish: the plain path
    residuals of a batch solve; the same at a quarter of the steps (at least 24: the scouting of many
    starts); and, with constraints or the screen, :class:`._polish.ConstrainedResiduals`: the designs are solved by the
    chunk runner (metrics, screen) when a constraint names a metric or the screen applies, else by the
    same plain batch solve, the constraints then evaluated over the parameters alone."""
    from ..kernels import simulate_batch
    from ..study.runner import geometry_columns, metric_plan
    from ..synthesis import ConstrainedResiduals, PathResiduals
    opt = study.optimize
    mech, target = study.mech, study.target
    kw = dict(match=target.match, angles=target.angles, ignore=target.ignore, phase=target.phase)
    _, metric_vel, _ = metric_plan(study)
    velocities = study.velocities or metric_vel

    def simulate(Xs):
        lengths, crank, geometry = designs_from_x(study, Xs)
        moved = geometry_columns(study, geometry)
        b = simulate_batch(mech, lengths, crank if mech.crank is not None else None, study.steps,
                           vertices=[mech.foot], velocities=velocities, tolerance=study.tolerance,
                           method=study.method, **({"geometry": moved} if moved else {}))
        return b.paths[mech.foot], (b.velocities.get(mech.foot) if velocities else None), b.status == 0

    coarse_steps = max(24, study.steps // 4)

    def simulate_coarse(Xs):
        lengths, crank, geometry = designs_from_x(study, Xs)
        moved = geometry_columns(study, geometry)
        b = simulate_batch(mech, lengths, crank if mech.crank is not None else None, coarse_steps,
                           vertices=[mech.foot], velocities=True, tolerance=study.tolerance,
                           method=study.method, **({"geometry": moved} if moved else {}))
        return b.paths[mech.foot], b.velocities.get(mech.foot), b.status == 0

    coarse = PathResiduals(simulate_coarse, target.points, **kw)
    if not (opt.constraints or opt.screen):
        return PathResiduals(simulate, target.points, **kw), None, coarse
    import pandas as pd

    from ..gait import evaluate_filter, filter_columns, filter_margins, screen_columns
    names = set(mech.parameters())
    needs_metrics = opt.screen or any(c not in names for k in opt.constraints for c in filter_columns(k))
    scales = {}
    nominal = mech.parameters()

    def frame(Xs, ok, metrics):
        cols = {"status": np.where(ok, "ok", "failed")}
        cols.update({p: Xs[:, j] for j, p in enumerate(opt.parameters)})
        for p, v in nominal.items():
            cols.setdefault(p, np.full(len(Xs), v))
        cols.update(metrics or {})
        return pd.DataFrame(cols)

    def evaluate_designs(Xs):
        if needs_metrics:
            lengths, crank, geometry = designs_from_x(study, Xs)
            batch, metrics = evaluate(lengths, crank, geometry)
            ok = batch.status == 0
            foot, vel = batch.paths[mech.foot], batch.velocities.get(mech.foot)
        else:
            foot, vel, ok = simulate(Xs)
            metrics = None
        df = frame(Xs, ok, metrics)
        admissible = ok.copy()
        if "path_error" in df:
            admissible &= np.isfinite(df["path_error"].to_numpy(dtype=np.float64))
        if opt.screen:
            sc = screen_columns(df, study.screen)
            if sc is not None:
                admissible &= sc[0]
        margins = []
        for j, c in enumerate(opt.constraints):
            m = filter_margins(df, c, scales=True)
            if m is None:
                admissible &= evaluate_filter(df, c)
                continue
            for i, (mi, si) in enumerate(m):
                if (j, i) not in scales:  # the constraint's own size at the first design polished
                    scales[(j, i)] = max(float(si[0]) if np.isfinite(si[0]) else 1.0, 1e-12)
                margins.append(mi / scales[(j, i)])
        M = np.column_stack(margins) if margins else np.zeros((len(Xs), 0))
        feasible = admissible & np.all(np.isfinite(M), axis=1)
        for c in opt.constraints:
            feasible &= evaluate_filter(df, c)
        return foot, vel, ok, np.where(np.isfinite(M), M, -1.0), admissible, feasible

    return PathResiduals(simulate, target.points, **kw), \
        ConstrainedResiduals(evaluate_designs, target.points, n_margins=len(_margin_names(opt.constraints)), **kw), \
        coarse


def _margin_names(constraints) -> list:
    """The constraint of each margin :func:`explorer.gait.filter_margins` gives (a chain of n comparisons
    has n), in order; constraints without margins are left out."""
    import ast

    from ..gait import parse_filter
    out = []
    for c in constraints:
        node = parse_filter(c)[0].body
        if isinstance(node, ast.Compare) and all(isinstance(op, (ast.Lt, ast.LtE, ast.Gt, ast.GtE)) for op in node.ops):
            out += [c] * len(node.ops)
    return out


#: A constraint holds the answer when its margin (scaled by the constraint's own size) is at most this and
#: the unconstrained descent would break it: the polish inside the constraints ends within about 1e-5 of
#: an active one (its last step back to the feasible side), e.g. clearance 1.00001 on `clearance >= 1`.
HELD_MARGIN = 1e-4


def _held(study: Study, res, x, lo, hi) -> dict:
    """What holds the best polished design where it is (the stopping rule's answer): the bounds it sits on
    (within 1e-9 of the span) that the objective's gradient pushes against, and the constraints whose
    margin is at most HELD_MARGIN and which the unconstrained descent would break; "exact" when the fit is exact;
    else an interior minimum. One batch solve of the design and its forward-difference copies."""
    from ..synthesis import FD_STEP
    k = len(x)
    span = hi - lo
    step = FD_STEP * np.maximum(np.abs(x), 1e-2 * span)
    h = np.where(x + step <= hi, step, -step)
    Xs = np.repeat(x[None], k + 1, axis=0)
    Xs[np.arange(1, k + 1), np.arange(k)] += h
    theta = res.closest_angles(x) if res.free_angles else None
    R, _ = res.rows(Xs, theta)
    mp = res.m_path()
    r0 = R[0, :mp]
    cost = float(np.dot(r0, r0)) if np.all(np.isfinite(r0)) else math.inf
    size = float(np.sqrt(np.mean(np.sum((study.target.points - study.target.points.mean(axis=0)) ** 2, axis=1)))) or 1.0
    out = {"bounds": [], "constraints": [], "exact": bool(cost <= (1e-12 * size) ** 2 * len(study.target.points))}
    if not np.all(np.isfinite(R[:, :mp])):
        return out
    J = (R[1:, :mp] - r0[None]) / h[:, None]  # (k, m) d r / d x_j
    g = 2.0 * J @ r0  # gradient of the sum of squares
    gscale = float(np.max(np.abs(g))) if len(g) else 0.0
    for j, p in enumerate(study.optimize.parameters):
        if out["exact"]:
            break
        if x[j] - lo[j] <= 1e-9 * span[j] and g[j] > 1e-9 * gscale:
            out["bounds"].append(f"{p} = {lo[j]:.6g} (lower)")
        elif hi[j] - x[j] <= 1e-9 * span[j] and g[j] < -1e-9 * gscale:
            out["bounds"].append(f"{p} = {hi[j]:.6g} (upper)")
    last = getattr(res, "_last", None)
    if last is not None and last[1].shape[1] and not out["exact"]:
        M = last[1]
        dM = (M[1:] - M[0][None]) / h[:, None]  # (k, c)
        names = _margin_names(study.optimize.constraints)
        descent = -g
        for i, c in enumerate(names[:M.shape[1]]):
            if abs(M[0, i]) <= HELD_MARGIN and float(dM[:, i] @ descent) < 0:
                out["constraints"].append(c)
    out["gradient"] = gscale
    return out


def _progress_value(F, feas, n_obj: int, directions, ref):
    """The progress bar's figure: the best objective (as the metric reads, not negated) for one
    objective; for several, the hypervolume of the feasible optimum against a reference point fixed
    at the first generation that has a feasible design (its worst values plus 10 % of their range)."""
    if F is None or feas is None or not np.any(feas):
        return float("nan"), ref
    F = np.asarray(F)[np.asarray(feas).ravel()]
    if n_obj == 1:
        v = float(F[:, 0].min())
        return (-v if directions[0] == "max" else v), ref
    if ref is None:
        span = F.max(axis=0) - F.min(axis=0)
        ref = F.max(axis=0) + 0.1 * np.where(span > 0, span, np.maximum(np.abs(F.max(axis=0)), 1.0))
    from pymoo.indicators.hv import HV
    return float(HV(ref_point=ref)(F)), ref


def _bar(progress: bool, total: int, name: str):
    if not progress or not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
        return None
    from tqdm import tqdm
    return tqdm(total=total, unit="gen", desc=name, file=sys.stderr, dynamic_ncols=True, leave=False)


# -- reading an optimisation back ----------------------------------------------------------------------
def optimization_of(results):
    """The :class:`~._objectives.Optimize` of an optimisation's results file (an open
    :class:`~explorer.store.Results`); UserError for a file of a sampled study."""
    from ..study import optimize_from_dict
    d = results.study.get("optimize") if isinstance(results.study, dict) else None
    if not d:
        raise UserError(f"{results.filename}: not an optimisation (its study has no [optimize] table); "
                        f"`explorer optimize` writes one")
    return optimize_from_dict(d, results.mechanism)


def front_history(df, opt, screen=None, generations=None):
    """How the front moved: for each generation g in ``generations`` (default: every one), the
    feasible non-dominated designs among generations 0 … g. Returns a DataFrame of ``upto`` (g),
    ``variant``, ``generation`` and the objectives; for one objective, the best design so far."""
    import pandas as pd
    F, _, feasible = objective_matrix(df, opt, screen)
    gen = df["generation"].to_numpy()
    last = int(gen.max()) if len(gen) else -1
    generations = range(last + 1) if generations is None else generations
    dirs = dict(zip(opt.objectives, opt.directions))
    rows = []
    for g in generations:
        sel = df[feasible & (gen <= g)]
        if len(sel) == 0:
            continue
        if len(opt.objectives) == 1:
            Fs = F[feasible & (gen <= g), 0]
            front = sel.iloc[[int(np.argmin(Fs))]]
        else:
            front = sel[pareto_front(sel, list(opt.objectives), dirs)]
        part = front[["variant", "generation", *opt.objectives]].copy()
        part.insert(0, "upto", g)
        rows.append(part)
    cols = ["upto", "variant", "generation", *opt.objectives]
    return pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=cols)
