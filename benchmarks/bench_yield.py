"""What the ``yield`` metric costs: 100 designs × 256 copies (explorer.study.design_yield, one kernel
call) against the plain solves it is made of, measured in the same run.

    python benchmarks/bench_yield.py [--mechanism jansen] [--designs 100] [--copies 256] [--repeat 3]

Rows (best of --repeat after a warm-up, see _timing.best):
* plain solve of the designs: simulate_batch of the D designs, foot + velocities, the study's default;
* plain solve of D × K designs: the same kernel on as many designs as the copies (what yield solves);
* that, plus the four screen metrics and the screen (what yield computes per copy);
* design_yield: all of it, copies drawn and cut with common random numbers.
The ratios say what yield adds over the solves it cannot avoid (its overhead over the D × K row), and
what it costs against a plain study of the same designs (about K times).
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import best, variants  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mechanism", default="jansen")
    ap.add_argument("--designs", type=int, default=100)
    ap.add_argument("--copies", type=int, default=256)
    ap.add_argument("--tolerance", type=float, default=1.0, help="± %% (default 1)")
    ap.add_argument("--steps", type=int, default=360)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args(argv)

    import pandas as pd

    from explorer.gait import SCREEN_INPUTS, available_metrics, compute_metrics, screen_columns
    from explorer.kernels import simulate_batch
    from explorer.mechanism import load_mechanism
    from explorer.study import design_yield, robustness_from_dict
    from explorer.study._yield import _copies, split_parameters, draws, full_parameters

    mech = load_mechanism(a.mechanism)
    D, K = a.designs, a.copies
    L, r = variants(mech, D)
    rb = robustness_from_dict({"tolerance": a.tolerance, "copies": K}, "bench", mech)
    X = full_parameters(mech, L, r)
    Lc, rc, geo = split_parameters(mech, _copies(mech, X, draws(rb, X.shape[1]), rb))
    foot = mech.foot
    names = [m for m in SCREEN_INPUTS if available_metrics(mech).get(m) is None]

    def plain_designs():
        simulate_batch(mech, L, r, a.steps, vertices=[foot], velocities=True)

    def plain_copies():
        return simulate_batch(mech, Lc, rc, a.steps, geometry=geo, vertices=[foot], velocities=True)

    def copies_and_screen():
        b = plain_copies()
        m = compute_metrics(b.paths[foot], b.velocities[foot], b.status, names, mechanism=mech, lengths=Lc, crank=rc,
                            geometry=geo)
        df = pd.DataFrame(m)
        df["status"] = b.status
        df["crank"] = rc
        screen_columns(df)

    result = {}

    def yield_call():
        result["y"] = design_yield(mech, L, r, robustness=rb, steps=a.steps)

    rows = [("plain solve of the designs", D, plain_designs), ("plain solve of designs × copies", D * K, plain_copies),
            ("  + screen metrics and screen", D * K, copies_and_screen), ("design_yield", D * K, yield_call)]
    print(f"{mech.name}: {D} designs × {K} copies, ±{a.tolerance:g} % uniform on every design parameter, "
          f"{a.steps} steps, {os.cpu_count()} CPUs, numba threads {os.environ.get('NUMBA_NUM_THREADS', 'default')}")
    times = {}
    for label, n, fn in rows:
        t = best(fn, a.repeat)
        times[label] = t
        print(f"  {label:<34} {n:>8,} designs  {t:8.3f} s  {n * a.steps / t / 1e6:6.2f} M configs/s")
    y = result["y"].share
    base = times["plain solve of designs × copies"]
    print(f"  design_yield / plain solve of designs × copies: {times['design_yield'] / base:.2f}x "
          f"(its overhead: drawing, cutting, screen)")
    print(f"  design_yield / plain solve of the designs: {times['design_yield'] / times['plain solve of the designs']:.0f}x "
          f"(K = {K})")
    print(f"  yield over the designs: median {np.median(y):.3f}, min {y.min():.3f}, max {y.max():.3f}; "
          f"binomial standard error at the median ±{np.sqrt(np.median(y) * (1 - np.median(y)) / K):.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
