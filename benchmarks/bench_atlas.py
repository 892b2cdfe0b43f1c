"""The curve atlas: size and build time, look-up and polish times, and how well targets are recovered.

    python benchmarks/bench_atlas.py [--families fourbar,watt6,stephenson6] [--targets 10] [--designs 1000000]
                                     [--build] [--starts 96] [--seed 1000]

For each family, the cached atlas (``explorer atlas build``; ``--build`` builds it first, timed) is
opened and asked for:

* **held-out targets**: ``--targets`` random designs of the family's design space (uniform in the
  atlas's bounds, lengths log-uniform, seeds ``--seed`` …; not atlas rows: the atlas is a Sobol
  sequence), each solved at 720 crank steps, 60 of its points (every 12th) moved by a random
  similarity (scale 0.5–5, any rotation, shift up to 10): ``explorer synth --closed`` must recover a
  design whose path passes through them to 1e-6 of the curve's size (RMS distance / RMS radius);
* **drawn shapes**: ``benchmarks/targets/letter-d.csv`` (the letter D, 31 points as a pen samples them)
  and ``benchmarks/targets/stance.csv`` (a foot path with a flat stance, 26 points), closed.

Printed per target: the look-up time (index or scan, then the alignment of the candidates; the
atlas's open is printed once), the polish time, the CPU seconds of the whole synthesis, and the
relative error reached. The machine's load average is printed before and after: seconds are only
comparable at the same load; the CPU seconds are the figures to read on a shared machine.
"""

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def held_out(at, n, seed):
    """n targets (points (60, 2), true relative error 0) from random designs of the atlas's space."""
    from explorer.kernels import simulate_batch
    from explorer.synthesis._atlas import _designs, _sample
    mech, spec = at.mech, at.spec
    out = []
    rng = np.random.default_rng(seed)
    while len(out) < n:
        X = _sample(spec, rng.random((256, len(spec.parameters))))
        L, c, g = _designs(mech, spec.parameters, X)
        b = simulate_batch(mech, L, c, 720, geometry=g, velocities=False)
        for i in np.flatnonzero(b.status == 0):
            P = b.paths[mech.foot][i]
            if np.max(np.hypot(*np.diff(P, axis=0).T)) > 0.02 * np.sum(np.hypot(*np.diff(P, axis=0).T)):
                continue  # a near-toggle whip (the atlas keeps none either)
            A = rng.uniform(0.5, 5.0) * np.exp(1j * rng.uniform(0, 2 * np.pi))
            B = complex(*rng.uniform(-10, 10, 2))
            z = A * (P[:, 0] + 1j * P[:, 1]) + B
            out.append(np.column_stack([z.real, z.imag])[::12])
            if len(out) == n:
                break
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--families", default="fourbar,watt6,stephenson6")
    ap.add_argument("--targets", type=int, default=10)
    ap.add_argument("--designs", type=int, default=1_000_000)
    ap.add_argument("--build", action="store_true", help="build the atlases first (timed)")
    ap.add_argument("--starts", type=int, default=256)
    ap.add_argument("--seed", type=int, default=1000)
    a = ap.parse_args(argv)
    import numba

    from explorer.synthesis import atlas_info, build_atlas, default_path, open_atlas, synthesize
    print(f"load before: {os.getloadavg()[0]:.2f} (1-min average); {os.cpu_count()} CPUs, numba threads "
          f"{numba.get_num_threads()}", flush=True)
    tmp = Path(tempfile.mkdtemp(prefix="bench-atlas-"))
    for fam in a.families.split(","):
        if a.build:
            s = build_atlas(fam, a.designs, force=True, progress=False)
            print(s.text(), f"(load {os.getloadavg()[0]:.1f})", flush=True)
        path = default_path(fam)
        info = atlas_info(path)
        print(f"{fam}: {int(info['designs']):,} designs ({int(info['sampled']):,} sampled), "
              f"{info['size_bytes'] / 1e6:.1f} MB, built in {float(info['build_s']):.1f} s wall / "
              f"{float(info['build_cpu_s']):.1f} CPU-s; {path}", flush=True)
        t = time.perf_counter()
        at = open_atlas(path)
        t_open = time.perf_counter() - t
        t = time.perf_counter()
        at.tree
        t_tree = time.perf_counter() - t
        print(f"  open {t_open:.2f} s, index (cKDTree of {len(at):,} descriptors) {t_tree:.2f} s", flush=True)
        # warm the kernels once (compilation is not the look-up's)
        warm = held_out(at, 1, a.seed + 999)[0]
        synthesize(warm, mechanism=fam, closed=True, atlas=path, output=tmp / "warm.h5", force=True, top=1,
                   starts=4, progress=False)
        rows = []
        targets = [(f"held-out {i}", p) for i, p in enumerate(held_out(at, a.targets, a.seed))]
        for name in ("letter-d", "stance"):
            targets.append((name, np.loadtxt(HERE / "targets" / f"{name}.csv", delimiter=",", skiprows=1)))
        for name, pts in targets:
            s = synthesize(pts, mechanism=fam, closed=True, atlas=path, output=tmp / "s.h5", force=True, top=3,
                           starts=a.starts, progress=False)
            rows.append((name, s.timings["query"], s.timings["polish"], s.cpu_s, s.relative))
            print(f"  {name:<12} look-up {s.timings['query']:6.3f} s  polish {s.timings['polish']:6.2f} s  "
                  f"{s.cpu_s:6.1f} CPU-s  relative error {s.relative:.3g}  (load {os.getloadavg()[0]:.1f})", flush=True)
        held = [r for r in rows if r[0].startswith("held-out")]
        ok = sum(r[4] <= 1e-6 for r in held)
        print(f"  {fam}: held-out recovered to 1e-6: {ok}/{len(held)}; look-up median {np.median([r[1] for r in rows]):.3f} s "
              f"(max {max(r[1] for r in rows):.3f}); polish median {np.median([r[2] for r in rows]):.2f} s (max "
              f"{max(r[2] for r in rows):.2f}); CPU-s median {np.median([r[3] for r in rows]):.1f}", flush=True)
    print(f"load after: {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
