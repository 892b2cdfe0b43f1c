"""What opening a big results file costs: open_results (which verifies every committed row's digest before
anything is read) against plain reads of the same rows, each in a fresh process with its peak resident
memory.

    python benchmarks/bench_open.py FILE.h5 [MODE ...]

Modes (default all, in this order, one new process each):
  import  explorer imported, nothing read (the baseline of the peak memory)
  read    read every per-variant dataset the digests cover, in blocks of whole HDF5 chunks, no hash
  hash    the same reads, and SHA-256 over every byte read (one hash): the floor of any full verification
  open    explorer.open_results(FILE) (the metadata checksum, every committed chunk's digest, the shards'
          checksums for a stitched file), then close
  whole   the digests as explorer computed them before they were streamed: each committed chunk's rows of
          every dataset read whole (for a stitched file a chunk is a shard: its rows whole in memory)
Prints one line per mode: wall seconds, MB of rows read, MB/s, peak RSS MB, and the load average.

    python benchmarks/bench_open.py --stitch FILE.h5      # a stitched (Dask) file: its shards folder

stitches FILE's shards again into a scratch file beside it, in a new process per mode: ``stream`` (the
stitch as it is: each shard's rows read in blocks) and ``whole`` (each shard's per-variant rows read
whole to digest them, as before), with the peak resident memory of each (the Dask client's cost).
"""
import hashlib
import os
import resource
import subprocess
import sys
import time

import h5py
import numpy as np


def _rows(f):
    from explorer.store._integrity import per_variant
    return per_variant(f, int(f.attrs["n_variants"]))


def child(path: str, mode: str) -> None:
    import explorer

    def _step(d, block=1 << 16):  # whole HDF5 chunks (works with explorer versions before the streaming)
        c = d.chunks[0] if d.chunks else 0
        return max(c, block // c * c) if c else block
    t = time.perf_counter()
    nbytes = 0
    if mode == "import":  # the baseline: explorer imported, nothing read
        pass
    elif mode == "open":
        with explorer.open_results(path) as r:
            nbytes = sum(d.dtype.itemsize * int(np.prod(d.shape)) for _, d in _rows(r.file))
    else:
        cache = {} if mode == "whole" else {"rdcc_nbytes": 1 << 20}  # whole: as explorer read before
        with h5py.File(path, "r", **cache) as f:
            ds = _rows(f)
            n = int(f.attrs["n_variants"])
            h = hashlib.sha256()
            if mode == "whole":
                rows = int(f["chunks"].attrs["rows"])
                done = np.asarray(f["chunks/done"][...], dtype=bool)
                for i in np.flatnonzero(done):
                    h = hashlib.sha256()
                    for name, d in ds:
                        v = np.ascontiguousarray(d[i * rows:min((i + 1) * rows, n)])
                        nbytes += v.nbytes
                        h.update(v.tobytes())
            else:
                for _, d in ds:
                    step = _step(d)
                    for a in range(0, n, step):
                        v = np.ascontiguousarray(d[a:min(a + step, n)])
                        nbytes += v.nbytes
                        if mode == "hash":
                            h.update(v)
    wall = time.perf_counter() - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{mode:6s} {wall:8.2f} s  {nbytes / 1e6:9.1f} MB  {nbytes / 1e6 / wall:8.1f} MB/s  peak RSS {peak:7.1f} MB  "
          f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)


def stitch_child(path: str, mode: str) -> None:
    from pathlib import Path

    import explorer  # noqa: F401 - the filters
    from explorer.store import _shards
    from explorer.store._integrity import per_variant
    out = Path(path)
    folder = _shards.shards_folder(out)
    plan = _shards.ShardPlan.read(folder)
    if mode == "whole":
        def whole(src, p, plan, i):
            a, b = plan.range(i)
            h = hashlib.sha256()
            for name, d in per_variant(src, plan.n_variants):
                h.update(b"\0" + name.encode() + b"\0")
                h.update(np.ascontiguousarray(d[a:b]).tobytes())
            return np.frombuffer(h.digest(), dtype=np.uint8)
        _shards._shard_digest = whole
    scratch = out.with_name(".bench-stitch-" + out.name)
    t = time.perf_counter()
    try:
        _shards.stitch(scratch, folder, plan)
    finally:
        scratch.unlink(missing_ok=True)
    wall = time.perf_counter() - t
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"stitch {mode:6s} {wall:8.2f} s  {plan.n_shards} shards of {plan.shard_rows} variants  peak RSS {peak:7.1f} MB  "
          f"load {' '.join(f'{x:.2f}' for x in os.getloadavg())}", flush=True)


if __name__ == "__main__":
    if len(sys.argv) >= 4 and sys.argv[1] == "--stitch-child":
        stitch_child(sys.argv[2], sys.argv[3])
        sys.exit(0)
    if len(sys.argv) >= 3 and sys.argv[1] == "--stitch":
        for m in sys.argv[3:] or ["stream", "whole"]:
            subprocess.run([sys.executable, __file__, "--stitch-child", sys.argv[2], m], check=True)
        sys.exit(0)
    if len(sys.argv) >= 4 and sys.argv[1] == "--child":
        child(sys.argv[2], sys.argv[3])
        sys.exit(0)
    path = sys.argv[1]
    modes = sys.argv[2:] or ["import", "read", "hash", "open", "whole"]
    print(path, os.path.getsize(path) / 1e6, "MB on disk")
    for m in modes:
        subprocess.run([sys.executable, __file__, "--child", path, m], check=True)
