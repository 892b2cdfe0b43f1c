"""Kernel throughput on ±2 % Jansen variants, as ratios against the speed limit measured in the same run.

    python benchmarks/bench_kernels.py [--variants 10000] [--steps 360] [--repeat 3] [--threads 2]

The baseline, **the limit**, is the Jansen leg's exact closed form written for that one topology and
vectorised (``_limit.py``: branch-free, x and y in separate arrays, 8 samples per AVX-512 instruction;
foot only, nothing checked). Beside it: the same arithmetic in its scalar form (the earlier baseline),
and the CPU's own ceiling for it (this CPU's vectorised divisions and square roots per second, measured
by ``_limit.probe`` on the same threads, divided by the limit's 4 divisions and 5 square roots per
configuration). Rows: explorer's methods: "auto" (the vectorised closed-form first pass, Newton for the
designs it flags), the block Newton sweep, the table-driven closed form, dense Newton on a subset;
foot only, with velocities, with accelerations, every vertex. Each row shows wall time and CPU time
(every thread of the process): the machines are shared, so read the ratios and the CPU seconds, not
the absolute figures. Each figure is the best of --repeat runs after a warm-up run that compiles (or
loads the cached) kernels. The targets (issue 39): "auto" foot within 2x of the limit, foot +
velocities within 2.5x.
"""

import argparse

import numba
import numpy as np

import explorer
from _limit import ceiling, foot_limit, foot_scalar, probe, vector_width
from _timing import best_cpu, load, variants


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--steps", type=int, default=360)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=None, help="Numba threads (default: Numba's)")
    ap.add_argument("--dense-variants", type=int, default=1_000, help="dense Newton is slow: run it on a subset")
    a = ap.parse_args(argv)
    if a.threads:
        numba.set_num_threads(a.threads)

    mech = explorer.load_mechanism("jansen")
    n = a.variants
    lengths, crank = variants(mech, n)
    configs = n * a.steps

    def batch(n_rows=n, **kw):
        return lambda: explorer.simulate_batch(mech, lengths[:n_rows], crank[:n_rows], a.steps, **kw)

    print(f"{n} ±2 % Jansen variants x {a.steps} steps, {numba.get_num_threads()} threads, explorer "
          f"{explorer.__version__}; best of {a.repeat}; {load()}")
    rows = []
    out = (np.empty((n, a.steps)), np.empty((n, a.steps)))
    limit = best_cpu(lambda: foot_limit(lengths, crank, a.steps, out), a.repeat)
    rows.append(("limit: Jansen closed form, vectorised", limit, configs))
    rows.append(("same closed form, scalar (earlier baseline)", best_cpu(lambda: foot_scalar(lengths, crank, a.steps),
                                                                          a.repeat), configs))
    rows.append(("auto (vector pass + Newton), foot", best_cpu(batch(velocities=False, method="auto"), a.repeat),
                 configs))
    rows.append(("auto, foot + velocities", best_cpu(batch(velocities=True, method="auto"), a.repeat), configs))
    rows.append(("auto, all vertices + vel", best_cpu(batch(vertices="all", velocities=True, method="auto"), a.repeat),
                 configs))
    rows.append(("block Newton, foot", best_cpu(batch(velocities=False), a.repeat), configs))
    rows.append(("block Newton, foot + velocities", best_cpu(batch(velocities=True), a.repeat), configs))
    rows.append(("block Newton, foot + vel + acc", best_cpu(batch(velocities=True, accelerations=True), a.repeat),
                 configs))
    rows.append(("block Newton, all vertices + vel", best_cpu(batch(vertices="all", velocities=True), a.repeat),
                 configs))
    rows.append(("closed form (table-driven), foot", best_cpu(batch(velocities=False, method="closed"), a.repeat),
                 configs))
    nd = min(a.dense_variants, n)
    rows.append((f"dense Newton ({nd} variants), foot + vel", best_cpu(batch(nd, method="dense"), a.repeat),
                 nd * a.steps))

    rates = probe()
    cap = ceiling(rates)
    print(f"{'method':44s} {'M configs/s':>11s} {'wall vs limit':>13s} {'CPU-s':>7s} {'CPU vs limit':>12s}")
    wl, cl = limit[0] / configs, limit[1] / configs
    for name, (t, c), m in rows:
        print(f"{name:44s} {m / t / 1e6:11.2f} {t / m / wl:13.2f} {c:7.3f} {c / m / cl:12.2f}")
    print(f"CPU ceiling for the limit's arithmetic: {cap / 1e6:.1f} M configs/s ({rates['div'] / 1e9:.2f} G div/s, "
          f"{rates['sqrt'] / 1e9:.2f} G sqrt/s on {numba.get_num_threads()} threads); the limit runs at "
          f"{configs / limit[0] / cap:.0%} of it")
    (vec,) = vector_width().values()
    print("the limit's machine code:", ", ".join(f"{k} {v}" for k, v in sorted(vec.items())))
    st = explorer.simulate_batch(mech, lengths, crank, a.steps, velocities=False, method="auto")
    newton = int((st.iterations > 0).sum())
    counts = {explorer.STATUS_NAMES[k]: int(v) for k, v in enumerate(np.bincount(st.status, minlength=5)) if v}
    print(f"auto outcome: {counts}; {newton} of {n} designs went through Newton (flagged by the first pass)")
    print(load())


if __name__ == "__main__":
    main()
