"""A study on a Dask LocalCluster: 1 vs 2 worker processes, and what a shard costs.

    python benchmarks/bench_dask.py [--workers 1,2] [--repeat 2] [--variants N] [--shard-size N] [--overhead]

Needs ``pip install "explorer[dask]"``. Rows (configurations = variants × crank steps; the default
study is 10,000 × 360 = 3.6 M):
  - ``run_study`` in this process (Numba's threads on every core: the single-machine baseline);
  - ``run_study_dask`` on a LocalCluster of W single-threaded worker processes for each W of
    --workers, end to end (warm-up, tasks, shard files, stitching), each on a fresh cluster whose
    workers were warmed by one untimed run; the speedup is time(W = first) / time(W);
  - with ``--overhead``: the fixed cost of one shard (``write_shard`` of 32 … 1,280 variants in this
    process, fitted as a + b·rows), Dask's round trip per no-op task, and stitching per shard: the
    figures behind the default shard size (see ``explorer.store._shards.plan_shards``).
The machines are shared and noisy: read the ratios. Each figure is the best of --repeat runs.
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _timing import best


def _study(args):
    from explorer.study import load_study
    st = load_study(args.study)
    if args.variants:
        d = st.as_dict()
        d["study"]["variants"] = args.variants
        st = load_study(d)
    return st


def _cluster(n: int):
    from distributed import Client, LocalCluster
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                           silence_logs=logging.CRITICAL)
    return cluster, Client(cluster)


def _spin(n: int) -> int:
    x = 0
    for i in range(n):
        x = (x * 31 + i) % 1000003
    return x


def ceiling(workers: list[int]) -> dict[int, float]:
    """What W busy processes get from this machine right now: time(1 process) / time(W processes,
    same work each) × W. On an idle machine with W free cores this is W; on a shared one it is the
    most any W-worker run can reach (other users' load included)."""
    from concurrent.futures import ProcessPoolExecutor
    n = 3_000_000
    out = {}
    for w in workers:
        with ProcessPoolExecutor(w) as ex:
            list(ex.map(_spin, [1000] * w))  # start the processes
            t = time.perf_counter()
            list(ex.map(_spin, [n] * w))
            out[w] = time.perf_counter() - t
    base = out[workers[0]] / workers[0]
    return {w: base * w / t for w, t in out.items()}


def scaling(args, study, tmp: Path) -> None:
    from explorer import run_study
    from explorer.study import run_study_dask
    configs = study.n_variants * study.steps
    print(f"{study.name}: {study.n_variants:,} variants × {study.steps} steps = {configs / 1e6:.2f} M configurations, "
          f"{os.cpu_count()} CPUs")

    run_study(study, output=tmp / "warm.h5", force=True, progress=False)
    t = best(lambda: run_study(study, output=tmp / "single.h5", force=True, progress=False), args.repeat, warm_up=False)
    print(f"  {'run_study, one process (all cores)':<44s} {t:7.2f} s {configs / t / 1e6:6.2f} M cfg/s")
    before = ceiling(args.workers)
    base = None
    for w in args.workers:
        cluster, client = _cluster(w)
        try:
            small = study.as_dict()
            small["study"]["variants"] = 2 * w
            run_study_dask(client, small, output=tmp / f"warm{w}.h5", force=True, progress=False)  # warm workers
            shards = []

            def once():
                s = run_study_dask(client, study, output=tmp / f"dask{w}.h5", force=True, progress=False,
                                   shard_size=args.shard_size)
                from explorer.store._shards import ShardPlan, shards_folder
                shards.append(ShardPlan.read(shards_folder(tmp / f"dask{w}.h5")))
                return s
            t = best(once, args.repeat, warm_up=False)
        finally:
            client.close()
            cluster.close()
        base = base or t
        plan = shards[-1]
        print(f"  {f'run_study_dask, {w} worker' + ('s' if w > 1 else ''):<44s} {t:7.2f} s "
              f"{configs / t / 1e6:6.2f} M cfg/s  speedup {base / t:4.2f}x  "
              f"({plan.n_shards} shards of {plan.shard_rows:,})")
    after = ceiling(args.workers)
    print("  machine ceiling now (busy-loop processes, same work each; W on an idle machine): "
          + ", ".join(f"{w}: {before[w]:.2f}x before, {after[w]:.2f}x after" for w in args.workers))
    if hasattr(os, "getloadavg"):
        print(f"  load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs (other users included)")


def overhead(args, study, tmp: Path) -> None:
    from explorer.store._shards import plan_shards, stitch, write_shard
    from explorer.study._dask import _one_thread, _solver
    _one_thread()
    solve = _solver(study)
    print("fixed cost per shard (this process, one Numba thread):")
    sizes = [s for s in (32, 128, 512, 1280) if s <= study.n_variants]
    rows = []
    for size in sizes:
        plan = plan_shards(study, shard_size=size)
        folder = tmp / f"ovh{size}"
        folder.mkdir(exist_ok=True)
        times = []
        for r in range(max(2, args.repeat)):
            for p in folder.glob("shard-*"):
                p.unlink()
            t = time.perf_counter()
            write_shard(folder, plan, 1, study, solve)
            times.append(time.perf_counter() - t)
        t_solve = min(_timed(lambda: solve(*plan.range(1))) for _ in range(max(2, args.repeat)))
        rows.append((plan.shard_rows, min(times), t_solve))
        print(f"  shard of {plan.shard_rows:5d} variants: {min(times) * 1e3:8.1f} ms "
              f"(solve alone {t_solve * 1e3:8.1f} ms, file {1e3 * (min(times) - t_solve):6.1f} ms)")
    x = np.array([r[0] for r in rows], float)
    y = np.array([r[1] for r in rows])
    b, a = np.polyfit(x, y, 1)
    print(f"  fit: {a * 1e3:.1f} ms + {b * 1e6:.1f} µs per variant → a shard of n variants loses "
          f"{a * 1e3:.1f} ms, i.e. < 5 % from n ≈ {a / (0.05 * b):,.0f} ({a / (0.05 * b) * study.steps:,.0f} "
          f"configurations at {study.steps} steps)")

    cluster, client = _cluster(1)
    try:
        client.submit(int, 0, pure=False).result()
        n = 200
        t = time.perf_counter()
        futs = [client.submit(int, i, pure=False) for i in range(n)]
        client.gather(futs)
        t = time.perf_counter() - t
        print(f"Dask round trip: {t / n * 1e3:.2f} ms per no-op task ({n} tasks, 1 worker)")
    finally:
        client.close()
        cluster.close()

    plan = plan_shards(study, shard_size=-(-study.n_variants // 64))
    folder = tmp / "st.shards"
    folder.mkdir(exist_ok=True)
    for i in range(plan.n_shards):
        write_shard(folder, plan, i, study, solve)
    t = min(_timed(lambda: stitch(tmp / "st.h5", folder, plan)) for _ in range(max(2, args.repeat)))
    print(f"stitching {plan.n_shards} shards: {t * 1e3:.0f} ms ({t / plan.n_shards * 1e3:.2f} ms per shard)")


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study", default=None, help="study file or built-in name (default: the built-in default)")
    ap.add_argument("--variants", type=int, default=None, help="override the study's variants (smaller: faster)")
    ap.add_argument("--workers", default="1,2", help="worker counts to compare (default 1,2)")
    ap.add_argument("--shard-size", type=int, default=None, help="variants per shard (default: plan_shards)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--overhead", action="store_true", help="measure the fixed costs per shard and per task")
    ap.add_argument("--no-scaling", action="store_true", help="skip the 1 vs 2 workers runs")
    args = ap.parse_args(argv)
    args.workers = [int(w) for w in args.workers.split(",")]
    try:
        import distributed  # noqa: F401
    except ImportError:
        sys.exit('bench_dask needs Dask: pip install "explorer[dask]"')
    study = _study(args)
    tmp = Path(tempfile.mkdtemp(prefix="bench-dask-"))
    try:
        if not args.no_scaling:
            scaling(args, study, tmp)
        if args.overhead:
            overhead(args, study, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
