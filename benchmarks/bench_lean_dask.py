"""A lean study on a Dask LocalCluster of 2 single-threaded worker processes: wall time, each worker's and
the client's peak resident memory, the shard files, and opening the stitched file.

    python benchmarks/bench_lean_dask.py N STEPS OUT.h5      # e.g. 10000000 36 /scratch/lean10m.h5

(needs pip install "explorer[dask]"; the shards go to OUT.shards/ beside OUT.h5).
"""
import logging
import os
import sys
import time
from pathlib import Path

from distributed import Client, LocalCluster

import explorer



def peak() -> int:
    """This process's peak resident memory, bytes (run in each worker by client.run)."""
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


if __name__ == "__main__":
    n, steps = int(sys.argv[1]), int(sys.argv[2])
    out = Path(sys.argv[3])
    spec = {"study": {"name": f"lean-dask-{n}", "mechanism": "jansen", "variants": n, "seed": 1, "steps": steps},
            "perturb": {"method": "uniform", "spread": 0.02},
            "scene": {"metrics": True, "store": "metrics"}}
    print("start", time.strftime("%H:%M:%S"), "load %.2f %.2f %.2f" % os.getloadavg(), flush=True)
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=logging.CRITICAL) as cluster, Client(cluster) as client:
        t0 = time.perf_counter()
        s = explorer.run_study(spec, output=out, force=True, client=client, progress=False)
        wall = time.perf_counter() - t0
        workers = client.run(peak)
    print(s)
    print("wall", round(wall, 1), "s; load %.2f %.2f %.2f" % os.getloadavg())
    print("worker peak RSS MB", {k.split(":")[-1]: round(v / 1e6) for k, v in workers.items()})
    print("client peak RSS MB", round(peak() / 1e6))
    folder = out.with_suffix(".shards")
    shards = sorted(folder.glob("shard-*.h5"))
    print("study file", out.stat().st_size, "bytes;", len(shards), "shards,", sum(p.stat().st_size for p in shards) / 1e6, "MB")
    t = time.perf_counter()
    with explorer.open_results(out) as r:
        df = r.frame(rows=(n - 1000, n))
        top = r.path([0, n - 1])
        print("open + frame of 1,000 rows + re-solve 2:", round(time.perf_counter() - t, 2), "s;", r.lean, top.shape,
              r.status_counts())
