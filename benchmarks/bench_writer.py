"""Does the writer keep up? `explorer run` against the kernels in CPU-seconds, and a lean million.

    python benchmarks/bench_writer.py [--n 100000] [--lean 1000000] [--repeat 1] [--dir DIR]

Two rows, each measured in this one run (the machines are shared: read the ratios, and the load printed
with them):

  - ``--n`` (default 100,000) ±2 % Jansen designs × 360 steps, foot path and velocities stored, no metrics
    (``[scene] metrics = false``): ``simulate_batch`` on the study's designs, one call per study chunk,
    outputs dropped (the kernels: the baseline), then ``run_study`` of the same study (sampling, kernels,
    the commit thread's filters, checksums and HDF5 writes). CPU-seconds of the process
    (``time.process_time``, every thread) beside wall seconds; the target is run / kernels within 1.3x in
    CPU-seconds. Rounds alternate kernels and run (``--repeat``), the best of each kept.
  - ``--lean`` (default 1,000,000; 0 to skip) designs stored lean (``[scene] store = "metrics"``: every
    metric, no series) with ``python -c "explorer.run_study(...)"`` in a fresh process
    (:func:`bench_lean.run_command`): its wall seconds, its CPU-seconds and its peak resident memory
    (``getrusage(RUSAGE_CHILDREN)``: the largest child, after a 2,048-design run that fills the kernel
    cache); the targets are under 60 s wall on an idle 2-core machine and under 1 GB.

Run it on another checkout (``PYTHONPATH=/path/to/that/checkout``) for the same figures of that version.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import explorer  # noqa: E402
from bench_lean import run_command  # noqa: E402
from bench_pipeline import study_for  # noqa: E402
from explorer.study import study_variants  # noqa: E402


def _load() -> str:
    return "load %.2f %.2f %.2f" % os.getloadavg()


def kernels(study) -> tuple[float, float]:
    """(wall s, CPU s) of simulate_batch on ``study``'s designs (sampled beforehand), chunk by chunk."""
    n = study.n_variants
    rows = explorer.store.chunk_rows(n, study.steps, study.n_series)
    designs = [study_variants(study, lo, min(lo + rows, n)) for lo in range(0, n, rows)]
    kw = dict(vertices=list(study.vertex_names), velocities=study.velocities, tolerance=study.tolerance,
              method=study.method)
    t, c = time.perf_counter(), time.process_time()
    for lengths, crank, _ in designs:
        explorer.simulate_batch(study.mech, lengths, crank, study.steps, **kw)
    return time.perf_counter() - t, time.process_time() - c


def run(study, out: Path) -> tuple[float, float, dict]:
    """(wall s, CPU s, the run's timers) of run_study(study) into ``out``."""
    out.unlink(missing_ok=True)
    t, c = time.perf_counter(), time.process_time()
    s = explorer.run_study(study, output=out, force=True, progress=False)
    wall, cpu = time.perf_counter() - t, time.process_time() - c
    return wall, cpu, dict(s.timings or {}, bytes=out.stat().st_size)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=100_000, help="designs of the stored-series row (default 100,000)")
    ap.add_argument("--lean", type=int, default=1_000_000, help="designs of the lean row (default 1,000,000; 0: none)")
    ap.add_argument("--repeat", type=int, default=1, help="rounds of kernels + run (the best of each kept)")
    ap.add_argument("--compression", default="blosc", help="[output] compression of the series row")
    ap.add_argument("--dir", default=None, help="folder for the results files (default: a temporary one)")
    a = ap.parse_args(argv)
    folder = Path(a.dir or tempfile.mkdtemp(prefix="bench-writer-"))
    folder.mkdir(parents=True, exist_ok=True)
    out = folder / "series.h5"
    import numba
    print(f"explorer {explorer.__version__} ({Path(explorer.__file__).parent}); {os.cpu_count()} CPUs, numba "
          f"threads {numba.get_num_threads()}; {_load()}")
    warm = study_for(2048, a.compression, metrics=False)
    kernels(warm)
    run(warm, out)  # every kernel loaded, the disk touched
    if a.n:
        study = study_for(a.n, a.compression, metrics=False)
        best_k = best_r = None
        for _ in range(a.repeat):
            k = kernels(study)
            r = run(study, out)
            best_k = k if best_k is None or k[1] < best_k[1] else best_k
            best_r = r if best_r is None or r[1] < best_r[1] else best_r
        (kw, kc), (rw, rc, t) = best_k, best_r
        print(f"\n{a.n:,} × {study.steps} foot path + velocities stored ({a.compression}), no metrics  ({_load()})")
        print(f"  {'':26s} {'wall s':>8s} {'CPU s':>8s}")
        print(f"  {'kernels (simulate_batch)':26s} {kw:8.2f} {kc:8.2f}")
        print(f"  {'explorer run (run_study)':26s} {rw:8.2f} {rc:8.2f}   file {t['bytes'] / 1e6:,.0f} MB")
        print(f"    run / kernels: {rc / kc:.2f}x in CPU-seconds, {rw / kw:.2f}x wall (target: 1.3x CPU)")
        print("    run timers: " + ", ".join(f"{k} {v:.2f} s" for k, v in t.items() if k != "bytes"))
        out.unlink(missing_ok=True)
    if a.lean:
        run_command(2048, folder)  # the metric kernels compiled into the cache, if they were not
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        print(f"\n{a.lean:,} × 360 lean (every metric, no series), a fresh process  ({_load()})", flush=True)
        r = run_command(a.lean, folder)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        print(f"  wall {r['process']:.1f} s (run_study {r['wall']:.1f} s), CPU {cpu:.1f} s, peak RSS "
              f"{r['rss'] / 1e6:,.0f} MB, file {r['bytes'] / 1e6:,.0f} MB  (targets: 60 s on an idle 2-core "
              f"machine, 1 GB)")
        if r.get("timings"):
            print("    run timers: " + ", ".join(f"{k} {v:.2f} s" for k, v in r["timings"].items()))
        print(f"  ({_load()})")


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
