"""explorer against the best peer, per core: pylinkage's numba batch path on the same Jansen variants.

    pip install -e ".[bench]"          # pylinkage, kept out of explorer's core dependencies
    python benchmarks/bench_peers.py [--variants 10000] [--steps 360] [--repeat 3]

Both solve the same ±2 % variants over one crank turn, foot positions only, on ONE thread each
(pylinkage's ``Ensemble.simulate`` loops over members in Python around a numba kernel and does not
run in parallel, so one thread is the fair per-core figure). Rows, as ratios measured in the same
run: the limit (the Jansen leg's closed form written for that one topology and vectorised,
``_limit.py``), explorer's method "auto" (the vectorised closed-form first pass, Newton for the designs
it flags), explorer's block Newton, and pylinkage 1.3; wall and CPU seconds. The foot paths are checked against each other first
(pylinkage's sample k is explorer's sample k + 1: it turns the crank before it solves).

What each does per sample: pylinkage places every joint by circle–circle intersection, picking the
root nearest the last position (no branch check, no gap check, no failure report); explorer runs
Newton block by block with branch, gap and move checks, and reports every failure with its angle.
"""

import argparse
import math
import sys

import numpy as np

import explorer
from _limit import foot_limit
from _timing import best_cpu, load, variants


def jansen_pylinkage(lengths, crank, steps):
    """The built-in Jansen leg as a pylinkage Linkage (explorer's link order in ``lengths``)."""
    import pylinkage as pl
    l13, l34, l23, l24, l45, l26, l16, l56, l57, l67 = lengths
    O = pl.Ground(0.0, 0.0, name="O")
    A = pl.Ground(-38.0, -7.8, name="2")
    c = pl.Crank(O, crank, angular_velocity=2 * math.pi / steps, name="1")
    v3 = pl.RRRDyad(c, A, l13, l23, x=-50, y=50, name="3")
    v4 = pl.RRRDyad(v3, A, l34, l24, x=-100, y=0, name="4")
    v6 = pl.RRRDyad(c, A, l16, l26, x=-50, y=-50, name="6")
    v5 = pl.RRRDyad(v4, v6, l45, l56, x=-100, y=-50, name="5")
    v7 = pl.RRRDyad(v5, v6, l57, l67, x=-50, y=-100, name="7")
    return pl.Linkage([O, A, c, v3, v4, v6, v5, v7], name="jansen")


#: pylinkage's constraint vector: crank radius, then each dyad's two distances in component order.
PL_LINKS = ("1-3", "2-3", "3-4", "2-4", "1-6", "2-6", "4-5", "5-6", "5-7", "6-7")
PL_JOINTS = ("O", "2", "1", "3", "4", "6", "5", "7")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--steps", type=int, default=360)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)
    try:
        import pylinkage
        from pylinkage.population import Ensemble
    except ImportError:
        print('pylinkage is not installed: pip install -e ".[bench]"', file=sys.stderr)
        return 2
    import numba
    from explorer.kernels import assemble

    mech = explorer.load_mechanism("jansen")
    n, S = a.variants, a.steps
    lengths, crank = variants(mech, n)

    template = jansen_pylinkage(mech.lengths, mech.crank.radius, S)
    names = list(mech.link_names)
    dims = np.column_stack([crank, lengths[:, [names.index(x) for x in PL_LINKS]]])
    P0, _ = assemble(mech)
    start = np.array([[0.0, 0.0]] + [list(P0[mech.vertex_index(v)]) for v in PL_JOINTS[1:]])
    ens = Ensemble(template, dims, np.repeat(start[None], n, axis=0))

    numba.set_num_threads(1)
    ours = explorer.simulate_batch(mech, lengths, crank, S, vertices=["7"], velocities=False)
    theirs = ens.simulate(iterations=S, store=False)[:, :, PL_JOINTS.index("7")]
    both = (ours.status == 0) & np.isfinite(theirs).all(axis=(1, 2))
    diff = np.abs(np.roll(theirs[both], 1, axis=1) - ours.paths["7"][both]).max()
    print(f"{n} ±2 % Jansen variants x {S} steps, one thread each; explorer {explorer.__version__}, "
          f"pylinkage {pylinkage.__version__}")
    print(f"foot paths agree to {diff:.1e} on the {int(both.sum())} variants both solve "
          f"(explorer ok {int((ours.status == 0).sum())}, pylinkage finite {int(np.isfinite(theirs).all(axis=(1, 2)).sum())})")

    t_limit = best_cpu(lambda: foot_limit(lengths, crank, S), a.repeat)
    t_auto = best_cpu(lambda: explorer.simulate_batch(mech, lengths, crank, S, vertices=["7"], velocities=False,
                                                      method="auto"), a.repeat)
    t_ours = best_cpu(lambda: explorer.simulate_batch(mech, lengths, crank, S, vertices=["7"], velocities=False),
                      a.repeat)
    t_theirs = best_cpu(lambda: ens.simulate(iterations=S, store=False), a.repeat)
    configs = n * S
    print(f"{'one thread, foot positions':40s} {'M configs/s':>12s} {'vs limit':>9s} {'CPU-s':>7s} {'CPU vs limit':>12s} "
          f"{'pylinkage/it':>12s}")
    for name, (t, c) in (("limit (Jansen closed form, vectorised)", t_limit), ("explorer auto (vector pass + Newton)", t_auto),
                         ("explorer block Newton", t_ours), (f"pylinkage {pylinkage.__version__} Ensemble.simulate", t_theirs)):
        print(f"{name:40s} {configs / t / 1e6:12.2f} {t / t_limit[0]:9.2f} {c:7.3f} {c / t_limit[1]:12.2f} "
              f"{t_theirs[1] / c:11.2f}x")
    print(load())
    return 0


if __name__ == "__main__":
    sys.exit(main())
