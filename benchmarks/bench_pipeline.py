"""Where `explorer run`'s time goes, per study size: sample, solve, metrics, write, wait, and the run
against ``simulate_batch`` on the same designs, measured in one run.

    python benchmarks/bench_pipeline.py [--sizes 10000 100000] [--million] [--repeat 1]
                                        [--compression lzf] [--modes series,metrics] [--dir DIR]

For each size N (the default study's ±2 % Jansen variants × 360 steps, foot + velocities):

  - ``kernels``: ``simulate_batch`` on the study's designs (sampled beforehand, not timed), one call per
    study chunk, outputs dropped: the baseline;
  - ``series``: ``run_study`` with the scene's series stored and no metrics (``[scene] metrics = false``):
    sampling + kernels + writing: the ratio to ``kernels`` is the pipeline's overhead;
  - ``metrics``: ``run_study`` of the default scene (series and every metric);
  - ``lean``: the same stored lean (``[scene] store = "metrics"``: designs, statuses, metrics, no series);
    ``--modes lean --million`` is the million-design row (``benchmarks/bench_lean.py`` adds peak memory);
  - further modes are one function each (:data:`MODES`): ``mode(n, args, out) -> (study, summary)``.

Columns: wall seconds of the whole run, then the run's own timers (``RunSummary.timings``): sample,
solve, metrics (the main thread, in turn), write (the commit thread, overlapping the main thread) and
wait (the main thread blocked on the commit thread), the commit thread's CPU seconds (wr CPU), then the
file size and the ratio to ``kernels``.
Each figure is the best of --repeat rounds (a round runs every mode once, in turn, so that the modes
share the machine's load) after one warm-up at a small size; the machines are shared and noisy: read
the ratios, and the load printed with them.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import explorer
from explorer.study import load_study, study_variants

#: The default study, resized (and rescoped) per row.
_BASE = load_study(None).as_dict()


def study_for(n: int, compression: str, **scene) -> object:
    """The default study with ``n`` variants, ``[output] compression`` and ``[scene]`` overrides."""
    d = {k: dict(v) if isinstance(v, dict) else v for k, v in _BASE.items()}
    d["study"]["variants"] = int(n)
    d["scene"].update(scene)
    d["output"]["compression"] = compression
    return load_study(d)


def kernels(n: int, a, out: Path):
    """The baseline: simulate_batch on the same designs, chunk by chunk, as the run calls it."""
    study = study_for(n, a.compression, metrics=False)
    rows = explorer.store.chunk_rows(n, study.steps, study.n_series)
    designs = [study_variants(study, lo, min(lo + rows, n)) for lo in range(0, n, rows)]
    kw = dict(vertices=list(study.vertex_names), velocities=study.velocities, tolerance=study.tolerance,
              method=study.method)

    def go():
        for lengths, crank, _ in designs:
            explorer.simulate_batch(study.mech, lengths, crank, study.steps, **kw)

    t = time.perf_counter()
    go()
    return study, time.perf_counter() - t, None


def _run(study, a, out: Path):
    out.unlink(missing_ok=True)
    s = explorer.run_study(study, output=out, force=True, progress=False)
    return study, s.wall_s, s


def series(n: int, a, out: Path):
    """run_study storing the foot path and velocities, no metrics."""
    return _run(study_for(n, a.compression, metrics=False), a, out)


def metrics(n: int, a, out: Path):
    """run_study of the default scene: series and every metric."""
    return _run(study_for(n, a.compression), a, out)


def lean(n: int, a, out: Path):
    """run_study of the default scene stored lean ([scene] store = "metrics"): designs, statuses and every
    metric, no series (peak memory per size: benchmarks/bench_lean.py)."""
    return _run(study_for(n, a.compression, store="metrics"), a, out)


#: Modes by name: fn(n, args, out) -> (study, wall s, RunSummary or None), one timed call each.
MODES = {"kernels": kernels, "series": series, "metrics": metrics, "lean": lean}


def _load() -> str:
    try:
        return "load %.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "load ?"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[10_000, 100_000])
    ap.add_argument("--million", action="store_true", help="add N = 1,000,000 (about 12 GB of series with lzf)")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--compression", default=_BASE["output"]["compression"],
                    help="[output] compression of the runs (default: the default study's)")
    ap.add_argument("--modes", default="series,metrics",
                    help=f"comma-separated modes besides the kernels baseline ({', '.join(MODES)})")
    ap.add_argument("--dir", default=None, help="folder for the results files (default: a temporary one)")
    a = ap.parse_args(argv)
    sizes = list(a.sizes) + ([1_000_000] if a.million else [])
    modes = ["kernels"] + [m for m in a.modes.split(",") if m and m != "kernels"]
    for m in modes:
        if m not in MODES:
            ap.error(f"--modes: unknown mode {m!r} (choose from {', '.join(MODES)})")
    tmp = Path(a.dir or tempfile.mkdtemp(prefix="bench-pipeline-"))
    tmp.mkdir(parents=True, exist_ok=True)
    out = tmp / "bench.h5"
    import numba
    print(f"explorer {explorer.__version__}: default study resized, compression {a.compression!r}; "
          f"{os.cpu_count()} CPUs, numba threads {numba.get_num_threads()}; {_load()}")
    for m in modes:  # warm-up: load every kernel, touch the disk
        MODES[m](min(sizes[0], 2048), argparse.Namespace(**{**vars(a), "repeat": 1}), out)
    head = (f"{'N':>9s} {'mode':<8s} {'wall s':>7s} {'sample':>7s} {'solve':>7s} {'metrics':>7s} {'write':>7s} "
            f"{'wait':>7s} {'wr CPU':>7s} {'file MB':>8s} {'M cfg/s':>8s} {'x kernels':>9s}")
    print(head)
    for n in sizes:
        best: dict = {}
        one = argparse.Namespace(**{**vars(a), "repeat": 1})
        for _ in range(a.repeat):  # rounds of every mode in turn: each mode sees the same machine load
            for m in modes:
                study, wall, summary = MODES[m](n, one, out)
                size = out.stat().st_size / 1e6 if summary is not None and out.exists() else float("nan")
                if m not in best or wall < best[m][1]:
                    best[m] = (study, wall, summary, size)
        base = best["kernels"][1]
        for m in modes:
            study, wall, summary, size = best[m]
            t = getattr(summary, "timings", None) or {}
            cells = " ".join(f"{t[k]:7.2f}" if k in t else f"{'':7s}"
                             for k in ("sample", "solve", "metrics", "write", "wait", "write_cpu"))
            print(f"{n:>9,d} {m:<8s} {wall:7.2f} {cells} {size:8.0f} {n * study.steps / wall / 1e6:8.2f} "
                  f"{wall / base:9.2f}", flush=True)
        print(f"{'':9s} ({_load()})")
    out.unlink(missing_ok=True)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
