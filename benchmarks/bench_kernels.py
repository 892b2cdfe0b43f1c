"""Kernel throughput on ±2 % Jansen variants, as ratios against baselines measured in the same run.

    python benchmarks/bench_kernels.py [--variants 10000] [--steps 360] [--repeat 3]

Baselines: the true speed limit (the Jansen leg's exact closed form written for that one
topology, ``_limit.py``: the ten lengths as scalars, prange, foot only; what a compiler of
equation-based models would generate for this model), explorer's own table-driven closed form, and
dense full-system Newton (the simple reference). Rows: block Newton with the foot path only, with velocities, with accelerations, and
with every vertex kept (what scene pruning saves), plus one 360-step cycle of a single design.
The machines are shared and noisy: read the ratios, not the absolute figures. Each figure is the
best of --repeat runs after a warm-up run that compiles (or loads the cached) kernels.
"""

import argparse

import numpy as np

import explorer
from _limit import foot_limit
from _timing import best, variants


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", type=int, default=10_000)
    ap.add_argument("--steps", type=int, default=360)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--dense-variants", type=int, default=1_000, help="dense Newton is slow: run it on a subset")
    a = ap.parse_args(argv)

    mech = explorer.load_mechanism("jansen")
    n = a.variants
    lengths, crank = variants(mech, n)
    configs = n * a.steps

    def batch(n_rows=n, **kw):
        return lambda: explorer.simulate_batch(mech, lengths[:n_rows], crank[:n_rows], a.steps, **kw)

    rows = []
    limit = best(lambda: foot_limit(lengths, crank, a.steps), a.repeat)
    rows.append(("true limit: Jansen closed form, specialised", limit, configs))
    closed = best(batch(velocities=False, method="closed"), a.repeat)
    rows.append(("explorer closed form (table-driven), foot", closed, configs))
    block = best(batch(velocities=False), a.repeat)
    rows.append(("block Newton, foot positions", block, configs))
    rows.append(("block Newton, foot + velocities", best(batch(velocities=True), a.repeat), configs))
    rows.append(("block Newton, foot + vel + acc", best(batch(velocities=True, accelerations=True), a.repeat),
                 configs))
    rows.append(("block Newton, all vertices + vel", best(batch(vertices="all", velocities=True), a.repeat), configs))
    nd = min(a.dense_variants, n)
    rows.append((f"dense Newton ({nd} variants), foot + vel", best(batch(nd, method="dense"), a.repeat), nd * a.steps))

    print(f"{n} ±2 % Jansen variants x {a.steps} steps, {explorer.__version__}; best of {a.repeat}")
    print(f"{'method':44s} {'M configs/s':>12s} {'vs true limit':>14s} {'vs block pos':>13s}")
    per_limit, per_block = limit / configs, block / configs  # seconds per configuration
    for name, t, c in rows:
        per = t / c
        print(f"{name:44s} {1e-6 / per:12.2f} {per / per_limit:14.2f} {per / per_block:13.2f}")
    one = best(lambda: explorer.simulate(mech, a.steps, velocities=True), a.repeat)
    one_dense = best(lambda: explorer.simulate(mech, a.steps, velocities=True, method="dense"), a.repeat)
    print(f"one {a.steps}-step cycle with velocities: block {one * 1e3:.3f} ms, dense {one_dense * 1e3:.3f} ms "
          f"(dense/block = {one_dense / one:.1f})")
    status = explorer.simulate_batch(mech, lengths, crank, a.steps, velocities=False).status
    counts = {explorer.STATUS_NAMES[k]: int(v) for k, v in enumerate(np.bincount(status, minlength=5)) if v}
    print("block Newton outcome:", counts)


if __name__ == "__main__":
    main()
