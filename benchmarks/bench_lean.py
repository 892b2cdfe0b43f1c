"""Lean studies (``[scene] store = "metrics"``) at scale: wall time, where it goes, file size and peak memory
per study size, against the kernels alone on the same designs, measured in one run.

    python benchmarks/bench_lean.py [--sizes 100000 1000000] [--dir DIR] [--no-kernels]

For each size N (the default study's ±2 % Jansen variants × 360 steps, every walker and leg metric, no
series stored):

  - ``kernels``: ``simulate_batch`` on the study's designs (sampled beforehand, not timed), one call per
    study chunk, foot + velocities as the run solves them, outputs dropped: the baseline;
  - ``kernels + metrics``: the same plus ``compute_metrics`` on each chunk (what the run must compute);
  - ``explorer run``: the command (``python -m explorer.cli run``) in a fresh process, its peak resident
    memory (``resource.getrusage(RUSAGE_CHILDREN).ru_maxrss``) and its own timers when the run reports
    them (``RunSummary.timings``: sample, solve, metrics, write, wait).

The machines are shared and noisy: read the ratios (each size's rows come from one run, in turn), and the
load printed with them.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import explorer
from explorer.study import load_study, study_variants


def lean_study(n: int, out: Path) -> dict:
    """The default study with ``n`` variants, stored lean."""
    d = load_study(None).as_dict()
    d["study"]["variants"] = int(n)
    d["study"]["name"] = f"lean-{n}"
    d["scene"]["store"] = "metrics"
    d["scene"]["metrics"] = True
    d["output"]["path"] = str(out)
    return d


def kernels(n: int, with_metrics: bool) -> float:
    """Seconds of the kernels (and the metrics) on the lean study's designs, chunk by chunk."""
    from explorer.study._chunk import compute_study_metrics, series_solve  # noqa: PLC2701 - the run's own recipe
    study = load_study(lean_study(n, Path("x.h5")))
    how = series_solve(study)
    rows = explorer.store.chunk_rows(n, study.steps, study.n_series)
    total = 0.0
    for lo in range(0, n, rows):
        lengths, crank, geometry = study_variants(study, lo, min(lo + rows, n))
        t0 = time.perf_counter()
        b = explorer.simulate_batch(study.mech, lengths, crank, study.steps, vertices=how["vertices"],
                                    velocities=how["velocities"], tolerance=study.tolerance, method=study.method)
        if with_metrics:
            foot = study.mech.foot
            compute_study_metrics(study, b.paths[foot], b.velocities[foot], b.status, lengths, crank, geometry)
        total += time.perf_counter() - t0
    return total


def run_command(n: int, folder: Path) -> dict:
    """`explorer run` of the lean study in a fresh process: wall, peak RSS, file size, timings."""
    out = folder / f"lean-{n}.h5"
    toml = folder / f"lean-{n}.toml"
    d = lean_study(n, out)
    toml.write_text(explorer.mechanism.dumps_toml(d))
    code = ("import json, sys, time, resource, explorer\n"
            "t = time.perf_counter()\n"
            f"s = explorer.run_study({str(toml)!r}, force=True, progress=False)\n"
            "wall = time.perf_counter() - t\n"
            "print(json.dumps({'wall': wall, 'timings': getattr(s, 'timings', None), 'counts': s.counts}))\n")
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    total = time.perf_counter() - t0
    rss = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024  # largest child so far, bytes
    r = json.loads(p.stdout.strip().splitlines()[-1])
    r.update(process=total, rss=rss, bytes=out.stat().st_size)
    out.unlink()
    return r


def load() -> str:
    return "load average %.2f, %.2f, %.2f" % os.getloadavg()


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000])
    ap.add_argument("--dir", default=None, help="folder for the results files (default: a temporary one)")
    ap.add_argument("--no-kernels", action="store_true", help="skip the kernel baselines (the command only)")
    a = ap.parse_args(argv)
    folder = Path(a.dir) if a.dir else Path(tempfile.mkdtemp(prefix="bench-lean-"))
    folder.mkdir(parents=True, exist_ok=True)
    kernels(2048, True)  # compile / load every kernel once
    print(f"lean studies, Jansen ±2 %, 360 steps, every metric; {os.cpu_count()} cores; {load()}")
    for n in sorted(a.sizes):  # the smaller first: each child's peak RSS is a new maximum, or not
        print(f"\nN = {n:,}  ({load()})")
        if not a.no_kernels:
            k = kernels(n, False)
            km = kernels(n, True)
            print(f"  kernels alone                {k:8.2f} s")
            print(f"  kernels + metrics            {km:8.2f} s   {km / k:5.2f}x kernels")
        r = run_command(n, folder)
        line = f"  explorer run (new process)   {r['process']:8.2f} s"
        if not a.no_kernels:
            line += f"   {r['process'] / k:5.2f}x kernels, {r['process'] / km:5.2f}x kernels + metrics"
        print(line)
        print(f"    run_study inside it        {r['wall']:8.2f} s")
        if r.get("timings"):
            print("    " + ", ".join(f"{k} {v:.2f} s" for k, v in r["timings"].items()))
        print(f"    file {r['bytes'] / 1e6:,.1f} MB; peak RSS of the largest run so far {r['rss'] / 1e6:,.0f} MB; "
              f"ok {r['counts'].get('ok', 0):,}")
        print(f"  ({load()})")


if __name__ == "__main__":
    main()
