"""Four-bar path synthesis, the literature's problems: the error reached, with the evaluations and seconds.

    python benchmarks/bench_synthesis.py [--problem vertical-line|timed-five|all] [--population 100]
                                         [--generations 300] [--seed 1] [--steps 360]

The problems and their sources are in ``_synthesis_problems.py`` (with what was and was not verified
against the papers). The search runs in the source's own parametrisation (r1 … r4, rcx, rcy, θ0, x0,
y0, the bounds the source gives), with pymoo's differential evolution; each generation is ONE call of
explorer's batch kernel (``simulate_batch`` with every design's lengths and geometry) and of
``path_error`` (closest matching without timing; timed matching at θ2 with ``angle_offset = θ0``).
Designs that cannot turn a full cycle (assembly, branch) are infeasible. The error printed is the
source's objective, the sum of squared distances to the precision points, of the best design, next to
the best known value.
"""

import argparse
import sys
import time

import numpy as np

from _synthesis_problems import PROBLEMS, VARIABLES, fourbar_mechanism_dict
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
    a = arguments(__doc__).parse_args(argv)
    names = list(PROBLEMS) if a.problem == "all" else [a.problem]
    print(f"{'problem':<15} {'error (sum of squares)':>22} {'best known':>10} {'evaluations':>11} {'s':>7}  "
          f"source's budget")
    for name in names:
        p = PROBLEMS[name]
        err, n, wall, x = run(p, a.population, a.generations, a.seed, a.steps)
        print(f"{name:<15} {err:22.4g} {p.best_error:10.3g} {n:11,} {wall:7.1f}  {p.budget or 'not verified'}")
        print("   best design: " + ", ".join(f"{v}={xi:.6g}" for v, xi in zip(VARIABLES, x)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
