"""Four-bar path synthesis, the literature's problems: success over seeds, with evaluations and seconds.

    python benchmarks/bench_synthesis.py [--problem all|vertical-line|timed-five|closed-timed|closed-untimed]
                                         [--seeds 10] [--population 40] [--generations 30] [--starts 8]
                                         [--seconds 40] [--steps 360] [--de-only] [--batch 0]
                                         [--lm-iterations 80]

The problems, their sources and what was verified are in ``_synthesis_problems.py``; ``all`` runs the
issue's four. Each is searched in the source's own parametrisation (r1 … r4, rcx, rcy, θ0, x0, y0 within
the source's bounds; the variables a problem fixes are left out; φ, the start angle of a phase-timed
problem; an untimed problem's crank angle per point is a variable of the polish, each point's closest
match in the global search). Every batch of designs is ONE call of explorer's kernel
(``simulate_batch`` with every design's lengths and geometry) and of ``path_residuals``.

explorer's ``auto`` (as ``[optimize] algorithm = "auto"`` runs it): pymoo DE, ``population`` ×
``generations`` from a Latin hypercube, then ``explorer.synthesis.polish`` (bounded least squares on the
residuals, Jacobian by one batched finite difference per iteration) from the ``starts`` best distinct
designs DE evaluated; then restart rounds (DE from a fresh seed, polish) while the seed has run for less
than ``--seconds`` (a round begun runs to its end). ``--batch K``: after each DE round,
``explorer.synthesis.batched_lm`` (``--lm-iterations``) advances K starts together first: the round's final
population, its K/2 best distinct evaluated designs and a Latin hypercube of the box from the seed's
generator filling up to K; the ``--starts`` best distinct answers of DE and the LM are then polished
(0, the default, is 28a's auto; the README text says what K = 128 gave). ``--de-only`` is the baseline: DE alone,
population × generations.

Printed per problem over seeds 0 … n−1: success (the literature's objective, the sum of squared
distances, within 1 % of the best known; below 1e-6 where the best known is 0), median, worst and best,
designs solved (the polish's Jacobian batches included) and seconds per seed, and how many answers sit
on a bound (within 1e-6 of the span) and, untimed, meet the points in their order along the path. The
load average is printed before and after: figures are only comparable at the same load.
"""

import argparse
import sys
import time

import numpy as np

from _synthesis_problems import LITERATURE, PROBLEMS, VARIABLES, fourbar_mechanism_dict
from explorer.gait import path_residuals
from explorer.kernels import simulate_batch
from explorer.mechanism import mechanism_from_dict


def designs(mech, X):
    """simulate_batch arguments of designs X (n, 9) in VARIABLES order."""
    r1, r2, r3, r4, rcx, rcy, th0, x0, y0 = X.T
    names = list(mech.link_names)
    L = np.broadcast_to(mech.lengths, (len(X), len(names))).copy()
    L[:, names.index("rocker")] = r4
    geometry = {"crank.x": x0, "crank.y": y0, "B0.x": x0 + r1 * np.cos(th0), "B0.y": y0 + r1 * np.sin(th0),
                "coupler.B.x": r3, "coupler.P.x": rcx, "coupler.P.y": rcy}
    return L, r2, geometry


def evaluate(mech, problem, X, steps):
    L, crank, geometry = designs(mech, X)
    b = simulate_batch(mech, L, crank, steps, geometry=geometry, velocities=True)
    foot, vel = b.paths["P"], b.velocities["P"]
    f = np.full(len(X), np.inf)
    ok = np.flatnonzero(b.status == 0)
    if len(ok):
        kw = dict(match="closest")
        if problem.timed:
            kw = dict(match="timed", angles=np.array(problem.angles), angle_offset=X[ok, 6])
        d = path_residuals(foot[ok], np.array(problem.points), velocity=vel[ok], **kw)
        f[ok] = np.sum(d * d, axis=1)
    return f


def bounds(problem):
    """(lo, hi), each (9,) in VARIABLES order: the problem's bounds, link lengths at least 1e-3."""
    lo = np.array([max(problem.bounds[v][0], 1e-3) if v.startswith("r") and v not in ("rcx", "rcy")
                   else problem.bounds[v][0] for v in VARIABLES])
    hi = np.array([problem.bounds[v][1] for v in VARIABLES])
    return lo, hi


def template(problem):
    """The mechanism every design is simulated from: a crank-rocker at the problem's scale, branch +1
    (its branch is the one every design keeps)."""
    R = bounds(problem)[1][0]
    x = np.array([0.5, 1 / 6, 0.5, 5 / 12, 1 / 6, -1 / 6, 0.0, 0.0, 0.0]) * np.array([R] * 6 + [1, 1, 1])
    return mechanism_from_dict(fourbar_mechanism_dict(*x), "bench_synthesis template")


def run(problem, population, generations, seed, steps):
    from pymoo.algorithms.soo.nonconvex.de import DE
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem
    lo, hi = bounds(problem)
    mech = template(problem)

    class P(Problem):
        def __init__(self):
            super().__init__(n_var=9, n_obj=1, n_ieq_constr=1, xl=lo, xu=hi)

        def _evaluate(self, X, out, *a, **k):
            f = evaluate(mech, problem, X, steps)
            bad = ~np.isfinite(f)
            out["F"] = np.where(bad, 1e30, f)[:, None]
            out["G"] = bad.astype(float)[:, None]

    algo = DE(pop_size=population)
    prob = P()
    algo.setup(prob, termination=("n_gen", generations), seed=seed)
    ev = Evaluator()
    t0 = time.perf_counter()
    n = 0
    while algo.has_next():
        pop = algo.ask()
        ev.eval(prob, pop)
        algo.tell(infills=pop)
        n += len(pop)
    wall = time.perf_counter() - t0
    best = algo.opt[0]
    return float(best.F[0]), n, wall, best.X


class Posed:
    """A problem as the search sees it: the vector x of its free variables (those of ``problem.free``,
    then φ for a phase-timed problem), their bounds, the map to the nine variables, one batch solve of
    designs, and the residuals (explorer.synthesis.PathResiduals: timed x/y differences, or the untimed
    formulation with a free crank angle per point)."""

    def __init__(self, problem, steps=360):
        self.problem, self.steps = problem, steps
        lo9, hi9 = bounds(problem)
        self.free = [VARIABLES.index(v) for v in problem.free]
        self.fixed = lo9.copy()
        self.lower = np.concatenate([lo9[self.free], [0.0] if problem.phase else []])
        self.upper = np.concatenate([hi9[self.free], [2 * np.pi] if problem.phase else []])
        self.mech = template(problem)
        self.target = np.array(problem.points)
        from explorer.synthesis import PathResiduals
        offset = (lambda X: self.nine(X)[:, 6] + (X[:, -1] if problem.phase else 0.0)) if problem.timed else None
        self.residuals = PathResiduals(self.simulate, self.target, match="timed" if problem.timed else "closest",
                                       angles=np.array(problem.angles) if problem.timed else None, offset=offset)

    def nine(self, X):
        """The nine variables (n, 9) of designs X (n, k)."""
        X9 = np.repeat(self.fixed[None], len(X), axis=0)
        X9[:, self.free] = X[:, :len(self.free)]
        return X9

    def simulate(self, X):
        L, crank, geometry = designs(self.mech, self.nine(X))
        b = simulate_batch(self.mech, L, crank, self.steps, geometry=geometry, velocities=True)
        return b.paths["P"], b.velocities["P"], b.status == 0

    def sumsq(self, X):
        """The literature's objective (n,): sum of squared distances (inf where a design fails); the
        untimed problems' free angles are each point's closest match."""
        foot, vel, ok = self.simulate(X)
        f = np.full(len(X), np.inf)
        idx = np.flatnonzero(ok)
        if len(idx):
            kw = dict(match="closest")
            if self.problem.timed:
                kw = dict(match="timed", angles=np.array(self.problem.angles),
                          angle_offset=self.residuals.offset(X[idx]))
            d = path_residuals(foot[idx], self.target, velocity=vel[idx], **kw)
            f[idx] = np.sum(d * d, axis=1)
        return np.where(np.isfinite(f), f, np.inf)


def auto(posed, seed, *, population=40, generations=60, starts=4, budget=None, deadline_s=None, batch=0,
         lm_iterations=80):
    """explorer's ``algorithm = "auto"`` on a posed problem: pymoo DE (``population`` × ``generations``)
    from a Latin hypercube, then :func:`explorer.synthesis.polish` from the ``starts`` best distinct designs
    it evaluated; repeated from fresh seeds (restarts) while fewer than ``budget`` designs were solved
    (default: one round). Returns (best sum of squares, best x, designs solved, rounds)."""
    from pymoo.algorithms.soo.nonconvex.de import DE
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem
    from explorer.synthesis import batched_lm, distinct_best, polish

    lo, hi = posed.lower, posed.upper
    best_f, best_x, solved, rounds = np.inf, None, 0, 0
    rng = np.random.default_rng(seed)
    t0 = time.perf_counter()
    while True:
        rounds += 1
        seen_X, seen_f = [], []

        class P(Problem):
            def __init__(self):
                super().__init__(n_var=len(lo), n_obj=1, n_ieq_constr=1, xl=lo, xu=hi)

            def _evaluate(self, X, out, *a, **k):
                f = posed.sumsq(X)
                seen_X.append(X.copy())
                seen_f.append(f)
                bad = ~np.isfinite(f)
                out["F"] = np.where(bad, 1e30, f)[:, None]
                out["G"] = bad.astype(float)[:, None]

        from pymoo.operators.sampling.lhs import LHS
        algo = DE(pop_size=population, sampling=LHS())
        prob = P()
        algo.setup(prob, termination=("n_gen", generations), seed=int(rng.integers(2**31)), verbose=False)
        ev = Evaluator()
        while algo.has_next():
            pop = algo.ask()
            ev.eval(prob, pop)
            algo.tell(infills=pop)
        X, f = np.vstack(seen_X), np.concatenate(seen_f)
        solved += len(X)
        before = posed.residuals.evaluations
        if batch:  # batched LM from the final population and a Latin hypercube of the box, then finish
            pop = algo.pop.get("X")
            pop = np.vstack([pop, X[distinct_best(X, f, lo, hi, batch // 2, distinct=0.02)]])
            extra = max(batch - len(pop), 0)
            u = (rng.permuted(np.tile(np.arange(extra), (len(lo), 1)), axis=1).T + rng.random((extra, len(lo))))
            S0 = np.vstack([pop, lo + u / max(extra, 1) * (hi - lo)])
            lm = batched_lm(posed.residuals, S0, lo, hi, iterations=lm_iterations)
            X, f = np.vstack([X, lm.X]), np.concatenate([f, lm.cost])
        for i in distinct_best(X, f, lo, hi, starts):
            r = polish(posed.residuals, X[i], lo, hi)
            if r.cost < best_f:
                best_f, best_x = r.cost, r.x
            if f[i] < best_f:
                best_f, best_x = float(f[i]), X[i]
        solved += posed.residuals.evaluations - before
        if budget is None or solved >= budget or (deadline_s is not None and time.perf_counter() - t0 > deadline_s):
            return best_f, best_x, solved, rounds


def on_bound(posed, x, rel=1e-6) -> list[str]:
    """The variables of x (free, then φ) that sit on a bound (within rel × the span)."""
    names = list(posed.problem.free) + (["phi"] if posed.problem.phase else [])
    span = posed.upper - posed.lower
    return [n for n, xi, a, b, s in zip(names, x, posed.lower, posed.upper, span)
            if xi - a <= rel * s or b - xi <= rel * s]


def in_order(posed, x) -> bool | None:
    """Untimed problems: whether the best design meets the points in their order along the path (the
    closest matches' crank angles cyclically monotone, either way round); None for timed problems."""
    if posed.problem.timed:
        return None
    th = posed.residuals.closest_angles(np.asarray(x, dtype=float))
    if th is None:
        return False
    d = np.mod(np.diff(np.append(th, th[0])), 2 * np.pi)  # steps forward, wrapping once
    return bool(np.sum(d) <= 2 * np.pi + 1e-9 or np.sum(2 * np.pi - d) <= 2 * np.pi + 1e-9)


def success(problem, f) -> bool:
    """Within 1 % of the best known value; for a best known 0, below 1e-6."""
    return f < 1e-6 if problem.best_error == 0 else f <= 1.01 * problem.best_error


def arguments(description: str) -> argparse.ArgumentParser:
    """The options every synthesis benchmark takes: the problem, the budget, the seed, the steps."""
    ap = argparse.ArgumentParser(description=description, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problem", default="all", choices=["all", *PROBLEMS])
    ap.add_argument("--population", type=int, default=100)
    ap.add_argument("--generations", type=int, default=300)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--steps", type=int, default=360)
    return ap


def main(argv=None):
    ap = arguments(__doc__)
    ap.add_argument("--seeds", type=int, default=10, help="seeds 0 … n-1 per problem (default 10)")
    ap.add_argument("--starts", type=int, default=8, help="polish starts per round (default 8)")
    ap.add_argument("--seconds", type=float, default=40.0,
                    help="restart rounds begin while a seed has run less than this (default 40)")
    ap.add_argument("--batch", type=int, default=0,
                    help="batched LM starts per round (final DE population + Latin hypercube); 0: none (default 0)")
    ap.add_argument("--lm-iterations", type=int, default=80, help="batched LM iterations (default 80)")
    ap.add_argument("--de-only", action="store_true", help="the baseline: pymoo DE alone, population x generations")
    ap.set_defaults(population=40, generations=30)
    a = ap.parse_args(argv)
    import os
    names = list(LITERATURE) if a.problem == "all" else [a.problem]
    print(f"load before: {os.getloadavg()[0]:.2f} (1-min average), numba threads "
          f"{__import__('numba').get_num_threads()}")
    print(f"{'problem':<15} {'vars':>4} {'best known':>10} {'success':>8} {'median':>10} {'worst':>10} {'best':>10} "
          f"{'evals (med)':>11} {'s (med)':>7} {'s (max)':>7}  on a bound / in order")
    for name in names:
        p = PROBLEMS[name]
        posed = Posed(p, a.steps)
        posed.sumsq((posed.lower + posed.upper)[None] / 2)  # compile
        rows = []
        for seed in range(a.seeds):
            t0 = time.perf_counter()
            if a.de_only:
                f, x, n, rounds = de_only(posed, seed, a.population, a.generations)
            else:
                f, x, n, rounds = auto(posed, seed, population=a.population, generations=a.generations,
                                       starts=a.starts, budget=10**12, deadline_s=a.seconds, batch=a.batch,
                                       lm_iterations=a.lm_iterations)
            rows.append((f, x, n, rounds, time.perf_counter() - t0))
        f = np.array([r[0] for r in rows])
        ok = sum(success(p, v) for v in f)
        bound = [", ".join(on_bound(posed, r[1])) for r in rows]
        nb = sum(bool(b) for b in bound)
        order = [in_order(posed, r[1]) for r in rows]
        extra = f"{nb}/{len(rows)} on a bound"
        if order[0] is not None:
            extra += f"; {sum(order)}/{len(rows)} in order"
        print(f"{name:<15} {p.n_variables:>4} {p.best_error:>10.4g} {ok:>5}/{len(rows):<2} {np.median(f):>10.4g} "
              f"{f.max():>10.4g} {f.min():>10.4g} {int(np.median([r[2] for r in rows])):>11,} "
              f"{np.median([r[4] for r in rows]):>7.1f} {max(r[4] for r in rows):>7.1f}  {extra}", flush=True)
        for seed, (r, b) in enumerate(zip(rows, bound)):
            print(f"    seed {seed}: {r[0]:.6g}, {r[2]:,} designs, {r[3]} rounds, {r[4]:.1f} s"
                  + (f", on a bound: {b}" if b else ""), flush=True)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


def de_only(posed, seed, population, generations):
    """The baseline: pymoo DE alone on the posed problem (no polish); the untimed angles are each
    point's closest match. Returns (best, x, designs solved, 1)."""
    from pymoo.algorithms.soo.nonconvex.de import DE
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem
    from pymoo.operators.sampling.lhs import LHS

    class P(Problem):
        def __init__(self):
            super().__init__(n_var=len(posed.lower), n_obj=1, n_ieq_constr=1, xl=posed.lower, xu=posed.upper)

        def _evaluate(self, X, out, *a, **k):
            f = posed.sumsq(X)
            bad = ~np.isfinite(f)
            out["F"] = np.where(bad, 1e30, f)[:, None]
            out["G"] = bad.astype(float)[:, None]

    algo = DE(pop_size=population, sampling=LHS())
    prob = P()
    algo.setup(prob, termination=("n_gen", generations), seed=seed, verbose=False)
    ev, n = Evaluator(), 0
    while algo.has_next():
        pop = algo.ask()
        ev.eval(prob, pop)
        algo.tell(infills=pop)
        n += len(pop)
    best = algo.opt[0]
    return float(best.F[0]) if best.feas else np.inf, best.X, n, 1


if __name__ == "__main__":
    sys.exit(main())
