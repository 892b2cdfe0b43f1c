"""Four-bar path synthesis, side by side: explorer's optimiser on explorer's kernel against pylinkage's
optimisers on pylinkage's own simulation, the same problems, bounds and number of evaluations.

    pip install -e ".[bench]"          # pylinkage, kept out of explorer's core dependencies
    python benchmarks/bench_synthesis_peers.py [--problem all|vertical-line|timed-five-free] [--seeds 10]
                                               [--population 40] [--generations 30] [--seconds 50]
                                               [--steps 360] [--threads 1] [--pylinkage-sim numba|python]
                                               [--sample 0]

The problems are those of ``_synthesis_problems.py`` with all nine variables free (``NINE``: the
vertical line, and the timed five with θ0, x0, y0 free); the literature's parametrisation r1, r2, r3,
r4, rcx, rcy, θ0, x0, y0 and its bounds. explorer's side is ``bench_synthesis.auto`` (DE, the
least-squares polish, restart rounds while a seed has run less than ``--seconds``); each of pylinkage's
optimisers then gets the same seed and the designs explorer solved for it as its budget (population ×
as many generations). Over the seeds: success (within 1 % of the best known; below 1e-6 for a best known
0), median, worst, best, evaluations and seconds.

How the problem is posed to pylinkage (1.3)
-------------------------------------------
pylinkage's optimisers search the vector ``linkage.get_constraints()``: ``differential_evolution_
optimization`` takes its length as the number of dimensions and rejects bounds of any other length
(``pylinkage/optimization/scipy_optimize.py``: ``dimensions = len(constraints)``, then "Bounds dimensions
... must match number of dimensions"), and a ``Ground`` has no constraints (``components/ground.py``:
``get_constraints`` returns ``()``, "ground has no constraints to optimize"). A plain pylinkage four-bar
therefore offers 5 dimensions (crank radius; the RRR dyad's two distances; the coupler point's distance and
angle), never the pivots x0, y0, r1, θ0. ``particle_swarm_optimization`` has a ``dimensions`` argument, but
its default is the same ``len(linkage.get_constraints())``.

So the four-bar is posed as :class:`SynthesisFourBar`, a subclass of pylinkage's own
``pylinkage.simulation.Linkage`` built from its own components (``Ground`` O2 and O4, a ``Crank`` at O2,
an ``RRRDyad`` B on the crank pin A and O4, a ``FixedDyad`` P on A with the line A → B as reference) whose
``get_constraints`` / ``set_constraints`` are the nine variables in the literature's order: setting them
moves the two ``Ground`` pivots (O2 = (x0, y0), O4 = O2 + r1·(cos θ0, sin θ0)), sets the crank radius r2,
the dyad's distances r3 (to A) and r4 (to O4) and the coupler point's polar constraint (|rc|,
atan2(rcy, rcx)), and puts the linkage in its start pose. Both optimisers then run unmodified, with these
nine dimensions and explorer's bounds (``bench_synthesis.bounds``).

The fitness (pylinkage's ``eval_func(linkage, params, init_pos)``) simulates one crank turn with
pylinkage's own solver: ``Linkage.step_fast`` (its numba solver; ``--pylinkage-sim python``: its
``kinematic_minimization`` decorator, i.e. ``Linkage.step``, about 30x slower), 360 steps of 1° as
explorer's. pylinkage turns the crank before it solves and places B at the circle–circle root nearest the
previous one, so the start pose is the crank one step before the first sample and B on explorer's branch
(+1: left of the line A → O4, as ``bench_synthesis.template``). A design that cannot be assembled
somewhere in the turn (a NaN in the trajectory) scores +inf, pylinkage's own penalty
(``kinematic_minimization``); explorer's side also rejects a full turn that fails. The objective is the
sources' sum of squared distances: without timing (vertical line), each point against the closest point
of the closed polyline through the 360 samples (explorer: of the cubic Hermite curve through its samples
and velocities); with timing (timed five), the crank starts at θ0 + θ2 of the first point, so the five
prescribed angles (15° apart) are samples 0, 15, ..., 60 exactly (explorer interpolates at θ0 + θ2).

Same budget: explorer's population × generations evaluations (counted in the fitness). The algorithms:
  * pylinkage DE = ``differential_evolution_optimization``, i.e. ``scipy.optimize.differential_evolution``:
    set to pymoo's defaults as explorer's side uses them (best/1/bin, F = 0.5, CR = 0.2, a uniform random
    initial population of ``population`` designs drawn from ``seed``, generational replacement
    (``updating="deferred"``)), ``maxiter = generations - 1``, ``tol = 0`` and ``polish = False`` so it
    neither stops early nor spends evaluations beyond the budget. What still differs: pymoo's DE adds
    polynomial mutation (probability 0.1) to each trial and ranks infeasible designs by constraint
    violation; scipy's compares +inf scores.
  * pylinkage PSO = ``particle_swarm_optimization`` (pylinkage's own local-best PSO), at its default
    coefficients (inertia 0.6, leader 3.0, follower 0.1, 17 neighbours), ``population`` particles,
    ``generations - 1`` iterations after the initial swarm. It takes no seed (it calls
    ``np.random.default_rng()``); here it is seeded by patching ``numpy.random.default_rng`` for the
    duration of the call.

What explorer's optimiser saw was narrower until this benchmark found it (not a pylinkage matter):
``bench_synthesis`` simulates every design in one batch call from ONE template configuration, and
explorer's batch kernel started each variant's first Newton solve at the template's configuration, so a
design whose branch-+1 root lay far from it converged to the other root and was flagged "branch",
although it turns a full cycle on branch +1: of 2,000 uniform random designs in the bounds, explorer's
optimiser could run 199 (vertical line) and 208 (timed five) of the 544 that pylinkage's fitness scores,
about 37 % of the feasible set. Every variant is now assembled at its first sample on the nominal's
branch by the closed form (``explorer.kernels._batch.design_setup``), and the last lines printed check
it: explorer's optimiser runs all 544, as explorer does from each design's own configuration.

Every best design is then re-scored with explorer's objective (``bench_synthesis.evaluate``: explorer's
kernel and ``path_residuals``), simulated from the design's own start configuration on branch +1 (the
mechanism ``fourbar_mechanism_dict(*x)``): the one yardstick of the "error" column. Beside it: the same
from the template's configuration, as explorer's optimiser would have scored it (inf: rejected there),
and the optimiser's own score of its best. Wall seconds are the optimisation loop only (numba compiled
beforehand), in one process: explorer's kernel on ``--threads`` numba threads (default 1, per core as
``bench_peers.py``), pylinkage's optimisers on one core (``workers=1``). One seed per run: differences
between optimisers smaller than their seed-to-seed spread (not measured here) mean nothing.
"""

from __future__ import annotations

import math
import sys
import time
from unittest import mock

import numpy as np

import bench_synthesis as ours
from _synthesis_problems import PROBLEMS, fourbar_mechanism_dict
from explorer.mechanism import mechanism_from_dict

try:
    import pylinkage
    from pylinkage.actuators import Crank
    from pylinkage.components import Ground
    from pylinkage.dyads import FixedDyad, RRRDyad
    from pylinkage.simulation import Linkage
except ImportError:  # the optional `bench` extra
    pylinkage = None
    Linkage = object

#: The index of the coupler point P among SynthesisFourBar's components (O2, O4, crank, B, P).
P_INDEX = 4


class SynthesisFourBar(Linkage):
    """A pylinkage four-bar whose constraints are the literature's nine variables
    (``_synthesis_problems.VARIABLES``: r1, r2, r3, r4, rcx, rcy, θ0, x0, y0).

    values : the nine variables.
    steps : crank steps per turn (angular velocity 2π/steps per step).
    start : θ2 (from the ground link) of the first sample, or None: the first sample at explorer's
        crank angle 0 (θ2 = −θ0), so sample k is at explorer's θ_k = 2πk/steps.
    branch : +1 (B left of the directed line A → O4) or −1.
    """

    def __init__(self, values, *, steps: int = 360, start: float | None = None, branch: int = 1):
        if pylinkage is None:
            raise ImportError('pylinkage is not installed: pip install -e ".[bench]"')
        self.steps, self.start, self.branch = int(steps), start, int(branch)
        self.omega = 2.0 * math.pi / self.steps
        self.O2 = Ground(0.0, 0.0, name="O2")
        self.O4 = Ground(1.0, 0.0, name="O4")
        self.crank = Crank(self.O2, 1.0, angular_velocity=self.omega, name="A")
        self.B = RRRDyad(self.crank.output, self.O4, 1.0, 1.0, x=0.0, y=1.0, name="B")
        self.P = FixedDyad(self.crank.output, self.B, 0.0, 0.0, name="P")
        super().__init__([self.O2, self.O4, self.crank, self.B, self.P], name="synthesis four-bar")
        self.set_constraints(values)

    def get_constraints(self) -> list[float]:
        return list(self.values)

    def set_constraints(self, values) -> None:
        """Set the nine variables, move the ground pivots and put the linkage in its start pose: the
        crank one step (ω) before the first sample's angle, B at that sample's root on ``branch``."""
        r1, r2, r3, r4, rcx, rcy, th0, x0, y0 = (float(v) for v in values)
        self.values = (r1, r2, r3, r4, rcx, rcy, th0, x0, y0)
        self._solver_data = None  # as pylinkage's own set_constraints: step_fast recompiles
        o4x, o4y = x0 + r1 * math.cos(th0), y0 + r1 * math.sin(th0)
        self.O2.set_coord(x0, y0)
        self.O4.set_coord(o4x, o4y)
        self.crank.set_constraints(r2)
        self.B.set_constraints(r3, r4)
        self.P.set_constraints(math.hypot(rcx, rcy), math.atan2(rcy, rcx))
        alpha = 0.0 if self.start is None else th0 + self.start  # the first sample's crank angle
        self.crank.set_coord(x0 + r2 * math.cos(alpha - self.omega), y0 + r2 * math.sin(alpha - self.omega))
        ax, ay = x0 + r2 * math.cos(alpha), y0 + r2 * math.sin(alpha)
        gx, gy = o4x - ax, o4y - ay
        d = math.hypot(gx, gy)
        bx, by = ax, ay  # not assemblable at the first sample: the simulation fails there
        if d > 0.0:
            a = (r3 * r3 - r4 * r4 + d * d) / (2.0 * d)
            h2 = r3 * r3 - a * a
            if h2 >= 0.0:
                h, ux, uy = math.sqrt(h2), gx / d, gy / d
                bx, by = ax + a * ux - self.branch * h * uy, ay + a * uy + self.branch * h * ux
        self.B.set_coord(bx, by)
        self.P.set_coord(ax, ay)

    def coupler_path(self, sim: str = "numba") -> np.ndarray | None:
        """(steps, 2) coupler point over one turn by pylinkage's solver (``Linkage.step_fast`` or
        ``Linkage.step``), None if it cannot be assembled somewhere."""
        if sim == "numba":
            path = self.step_fast(iterations=self.steps)[:, P_INDEX]
            return path if np.all(np.isfinite(path)) else None
        try:
            return np.array([s[P_INDEX] for s in self.step(iterations=self.steps)], dtype=float)
        except pylinkage.UnbuildableError:
            return None


def closest_sumsq(path, points) -> float:
    """Sum over points of the squared distance to the closed polyline through path (S, 2)."""
    a = path
    b = np.roll(path, -1, axis=0)
    ab = b - a
    L2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    ap = points[:, None, :] - a[None]                                # (M, S, 2)
    t = np.clip(np.einsum("msj,sj->ms", ap, ab) / L2, 0.0, 1.0)
    d = ap - t[..., None] * ab[None]
    return float(np.sum(np.min(np.einsum("msj,msj->ms", d, d), axis=1)))


def timed_samples(problem, steps: int) -> np.ndarray:
    """The sample indices of a timed problem's angles when the first sample is at its first angle."""
    k = (np.array(problem.angles) - problem.angles[0]) * steps / (2.0 * math.pi)
    idx = np.rint(k).astype(int)
    if np.max(np.abs(k - idx)) > 1e-9:
        raise ValueError(f"{problem.name}: the prescribed crank angles are not on a grid of {steps} steps per turn")
    return idx


def pylinkage_linkage(problem, x, steps: int = 360) -> SynthesisFourBar:
    """The pylinkage four-bar of design x for a problem: first sample at θ2 of the first timed point."""
    return SynthesisFourBar(x, steps=steps, start=problem.angles[0] if problem.timed else None)


def pylinkage_fitness(problem, steps: int = 360, sim: str = "numba"):
    """pylinkage's ``eval_func(linkage, params, init_pos)``: the sum of squared distances to the
    problem's points, +inf where the four-bar cannot be assembled over the turn. ``fitness.calls``
    counts the evaluations."""
    points = np.array(problem.points, dtype=float)
    idx = timed_samples(problem, steps) if problem.timed else None

    def score(path):
        if idx is not None:
            d = path[idx] - points
            return float(np.sum(d * d))
        return closest_sumsq(path, points)

    if sim == "python":  # pylinkage's own fitness decorator: set_coords, set_constraints, Linkage.step
        from pylinkage.optimization.utils import kinematic_minimization

        @kinematic_minimization
        def run_one(linkage, params, init_pos, loci):
            return score(np.array([s[P_INDEX] for s in loci[:steps]], dtype=float))
    elif sim == "numba":
        def run_one(linkage, params, init_pos=None):
            linkage.set_constraints(params)
            path = linkage.coupler_path("numba")
            return math.inf if path is None else score(path)
    else:
        raise ValueError(f"sim: expected 'numba' or 'python', got {sim!r}")

    def fitness(linkage, params, init_pos=None):
        fitness.calls += 1
        return run_one(linkage, params, init_pos)

    fitness.calls = 0
    return fitness


def run_pylinkage(problem, method, population, generations, seed, steps, sim="numba"):
    """pylinkage's optimiser ``method`` ("de" or "pso") on a problem: (its score of its best, the
    evaluations, wall seconds, the best design (9,))."""
    from pylinkage.optimization import differential_evolution_optimization, particle_swarm_optimization
    lo, hi = ours.bounds(problem)
    rng = np.random.default_rng(seed)
    x0 = lo + rng.random(9) * (hi - lo)
    linkage = pylinkage_linkage(problem, x0, steps)
    fitness = pylinkage_fitness(problem, steps, sim)
    fitness(linkage, list(x0))  # compile pylinkage's numba solver outside the timing
    fitness.calls = 0
    t0 = time.perf_counter()
    if method == "de":
        init = lo + rng.random((population, 9)) * (hi - lo)
        ens = differential_evolution_optimization(
            fitness, linkage, bounds=(list(lo), list(hi)), order_relation=min, strategy="best1bin",
            maxiter=generations - 1, tol=0.0, atol=0.0, mutation=0.5, recombination=0.2, seed=seed,
            workers=1, verbose=False, init=init, polish=False, updating="deferred")
    elif method == "pso":
        real = np.random.default_rng
        with mock.patch("numpy.random.default_rng", lambda *a, **k: real(seed)):
            ens = particle_swarm_optimization(
                fitness, linkage, n_particles=population, iterations=generations - 1,
                bounds=(list(lo), list(hi)), order_relation=min, verbose=False)
    else:
        raise ValueError(f"method: expected 'de' or 'pso', got {method!r}")
    wall = time.perf_counter() - t0
    best = ens[0]
    return float(best.score), fitness.calls, wall, np.asarray(best.dimensions, dtype=float)


def rescore(problem, x, steps) -> tuple[float, float]:
    """explorer's objective (``bench_synthesis.evaluate``: explorer's kernel and ``path_residuals``) of one
    design x (9,), twice: (simulated from the design's own start configuration on branch +1, i.e. the
    mechanism ``fourbar_mechanism_dict(*x)``; simulated from ``bench_synthesis.template``'s configuration,
    as explorer's optimiser sees it). inf where explorer finds it infeasible."""
    x = np.asarray(x, dtype=float)
    own = mechanism_from_dict(fourbar_mechanism_dict(*x), "bench_synthesis_peers design")
    return (float(ours.evaluate(own, problem, x[None], steps)[0]),
            float(ours.evaluate(ours.template(problem), problem, x[None], steps)[0]))


def feasible_counts(problem, n, seed, steps) -> tuple[int, int, int]:
    """Of n designs drawn uniformly in the bounds: how many explorer's optimiser can run (simulated from
    ``bench_synthesis.template``'s configuration), how many pylinkage's fitness scores finite, how many
    explorer runs from each design's own start configuration on branch +1."""
    lo, hi = ours.bounds(problem)
    X = lo + np.random.default_rng(seed).random((n, 9)) * (hi - lo)
    a = int(np.isfinite(ours.evaluate(ours.template(problem), problem, X, steps)).sum())
    f = pylinkage_fitness(problem, steps)
    linkage = pylinkage_linkage(problem, X[0], steps)
    b = int(sum(math.isfinite(f(linkage, list(x))) for x in X))
    c = int(sum(math.isfinite(rescore(problem, x, steps)[0]) for x in X))
    return a, b, c


#: The problems the comparison runs: those with the nine variables free (pylinkage's optimisers take the
#: linkage's whole constraint vector; the issue's timed-five fixes three, closed-timed adds a start angle).
NINE = ("vertical-line", "timed-five-free")


def main(argv=None):
    ap = ours.arguments(__doc__)
    ap.add_argument("--threads", type=int, default=1, help="numba threads for explorer's kernel (default 1)")
    ap.add_argument("--pylinkage-sim", default="numba", choices=["numba", "python"],
                    help="pylinkage's Linkage.step_fast (numba, default) or Linkage.step (python)")
    ap.add_argument("--seeds", type=int, default=10, help="seeds 0 … n-1 per problem and optimiser (default 10)")
    ap.add_argument("--seconds", type=float, default=50.0, help="explorer auto's restart rounds (bench_synthesis)")
    ap.add_argument("--sample", type=int, default=0,
                    help="uniform designs whose feasibility the two sides are compared on (default 0: skip)")
    ap.set_defaults(population=40, generations=30, problem="all")
    a = ap.parse_args(argv)
    if pylinkage is None:
        print('pylinkage is not installed: pip install -e ".[bench]"', file=sys.stderr)
        return 0
    import os

    import numba
    numba.set_num_threads(a.threads)
    names = list(NINE) if a.problem == "all" else [a.problem]
    print(f"pylinkage {pylinkage.__version__}; {a.seeds} seeds; {a.steps} steps; explorer's kernel on {a.threads} "
          f"numba thread(s), pylinkage on 1 core ({'Linkage.step_fast' if a.pylinkage_sim == 'numba' else 'Linkage.step'}); "
          f"load {os.getloadavg()[0]:.2f}")
    print("explorer: auto (DE, polish, restarts for --seconds); pylinkage's DE and PSO: population "
          f"{a.population}, as many generations as explorer's designs solved for that seed (the same budget). "
          "Error: the sum of squared distances of each best design, by explorer's evaluate from its own start.")
    print(f"{'problem':<16} {'optimiser':<22} {'success':>8} {'median':>10} {'worst':>10} {'best':>10} "
          f"{'evals (med)':>11} {'s (med)':>7}")
    for name in names:
        p = PROBLEMS[name]
        posed = ours.Posed(p, a.steps)
        posed.sumsq((posed.lower + posed.upper)[None] / 2)
        rows = {"explorer auto": [], "pylinkage DE": [], "pylinkage PSO": []}
        for seed in range(a.seeds):
            t0 = time.perf_counter()
            f, x, n, _ = ours.auto(posed, seed, population=a.population, generations=a.generations, budget=10**12,
                                   deadline_s=a.seconds)
            rows["explorer auto"].append((f, n, time.perf_counter() - t0))
            gens = max(2, -(-n // a.population))
            for method, label in (("de", "pylinkage DE"), ("pso", "pylinkage PSO")):
                own, m, wall, x = run_pylinkage(p, method, a.population, gens, seed, a.steps, a.pylinkage_sim)
                rows[label].append((rescore(p, x, a.steps)[0], m, wall))
        for label, rs in rows.items():
            f = np.array([r[0] for r in rs])
            ok = sum(ours.success(p, v) for v in f)
            print(f"{name:<16} {label:<22} {ok:>5}/{len(rs):<2} {np.median(f):>10.4g} {f.max():>10.4g} "
                  f"{f.min():>10.4g} {int(np.median([r[1] for r in rs])):>11,} "
                  f"{np.median([r[2] for r in rs]):>7.1f}", flush=True)
    if a.sample > 0:
        print(f"feasible designs among {a.sample:,} uniform in the bounds (seed {a.seed}): explorer's optimiser "
              f"(template start) / pylinkage's fitness / explorer from each design's own start")
        for name in names:
            print(f"  {name:<14} " + " / ".join(f"{k:,}" for k in feasible_counts(PROBLEMS[name], a.sample,
                                                                                 a.seed, a.steps)))
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
