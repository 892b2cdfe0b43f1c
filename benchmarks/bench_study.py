"""The default study end to end (sampling, kernels, metrics, HDF5), as ratios against baselines
measured in the same run.

    python benchmarks/bench_study.py [--repeat 3] [--chunks] [--compression] [--memory] [--command] [--cold]

Rows (configurations = variants × crank steps; the default study is 10,000 × 360 = 3.6 M):
  - ``run_study`` on the default study, end to end into a fresh HDF5 file (warm numba cache);
  - the kernels alone on the same variants: foot positions only (the baseline), + velocities, the
    closed form (the speed limit, all-dyad plans only), and dense Newton on a subset;
  - with ``--command``: the ``explorer run`` command itself (process start-up and imports included),
    against the floor of any Numba program: a new process that imports numba and calls one cached
    function;
  - with ``--cold``: ``explorer run`` on an empty Numba cache (``NUMBA_CACHE_DIR`` set to a new
    folder), which compiles every kernel the run needs, once (not best-of);
  - with ``--chunks``: end-to-end time per chunk size (how the default chunk size was chosen);
  - with ``--compression``: size, write CPU cost and read speed of the stored paths per HDF5 filter
    (explorer's [output] compression choices and other candidates; the table in explorer/store/_write.py);
  - with ``--memory``: peak traced memory of run_study at N and 4N (flat in N).
The machines are shared and noisy: read the ratios, not the absolute figures. Each figure is the
best of --repeat runs after a warm-up run.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

import h5py
import numpy as np

import explorer
from explorer.study import load_study, study_variants
from _timing import best


def _row(label: str, seconds: float, configs: int, base: float | None, base_label: str = "") -> str:
    rate = configs / seconds
    ratio = f"{seconds / base:6.2f}x {base_label}" if base else ""
    return f"  {label:<46s} {seconds:8.3f} s {rate / 1e6:8.2f} M cfg/s  {ratio}"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--study", default=None, help="study file (default: the built-in default study)")
    ap.add_argument("--dense-variants", type=int, default=1000, help="dense Newton is slow: run it on a subset")
    ap.add_argument("--chunks", action="store_true", help="sweep the chunk size")
    ap.add_argument("--compression", action="store_true", help="compare HDF5 filters on real paths")
    ap.add_argument("--memory", action="store_true", help="peak memory at N and 4N")
    ap.add_argument("--command", action="store_true", help="time the `explorer run` command too")
    ap.add_argument("--cold", action="store_true",
                    help="time `explorer run` on an empty Numba cache (compiling every kernel it needs)")
    a = ap.parse_args(argv)

    study = load_study(a.study)
    mech = study.mech
    N, S = study.n_variants, study.steps
    configs = N * S
    L, c, _ = study_variants(study)
    tmp = Path(tempfile.mkdtemp(prefix="bench-study-"))
    out = tmp / "bench.h5"
    kw = dict(tolerance=study.tolerance, vertices=list(study.vertex_names))

    def e2e(chunk=None):
        return lambda: explorer.run_study(study, output=out, force=True, progress=False, chunk_size=chunk)

    print(f"{study.name}: {N:,} variants × {S} steps = {configs / 1e6:.2f} M configurations, "
          f"scene {list(study.vertex_names)} velocities={study.velocities}, metrics={study.metrics}; "
          f"{os.cpu_count()} CPUs, numba threads {_numba_threads()}")
    t_pos = best(lambda: explorer.simulate_batch(mech, L, c, S, velocities=False, method=study.method, **kw), a.repeat)
    t_vel = best(lambda: explorer.simulate_batch(mech, L, c, S, velocities=True, method=study.method, **kw), a.repeat)
    t_closed = None
    try:
        t_closed = best(lambda: explorer.simulate_batch(mech, L, c, S, velocities=False, method="closed", **kw),
                         a.repeat)
    except Exception as exc:  # closed form: all-dyad plans only
        print(f"  (closed form unavailable: {exc})")
    nd = min(a.dense_variants, N)
    t_dense = best(lambda: explorer.simulate_batch(mech, L[:nd], c[:nd], S, velocities=False, method="dense", **kw),
                    a.repeat)
    t_block_sub = best(lambda: explorer.simulate_batch(mech, L[:nd], c[:nd], S, velocities=False, method="block",
                                                        **kw), a.repeat)
    t_e2e = best(e2e(), a.repeat)
    size = out.stat().st_size

    print(f"\nbaseline: {study.method} kernels, positions only, whole study in one call")
    if t_closed is not None:
        print(_row("closed form, positions", t_closed, configs, t_pos, "of baseline"))
    print(_row(f"{study.method} Newton, positions (baseline)", t_pos, configs, None))
    print(_row(f"{study.method} Newton, + velocities", t_vel, configs, t_pos, "of baseline"))
    print(_row(f"run_study end to end (HDF5 {size / 1e6:.0f} MB)", t_e2e, configs, t_pos, "of baseline"))
    if t_closed is not None:
        print(f"  {'':46s} {'':10s} {'':17s} {t_e2e / t_closed:6.2f}x of closed form")
    print(f"\nblock vs dense on {nd:,} variants")
    print(_row("block Newton, positions", t_block_sub, nd * S, None))
    print(_row("dense Newton, positions", t_dense, nd * S, t_block_sub, "of block"))

    if a.command or a.cold:
        _command(a, out, configs, t_pos)

    if a.chunks:
        print("\nchunk size (variants per chunk; HDF5 commit per chunk)")
        base = None
        for chunk in (256, 512, 1024, 2048, 4096, 8192):
            if chunk > N:
                break
            t = best(e2e(chunk), a.repeat)
            base = base or t
            print(_row(f"chunk {chunk}", t, configs, base, "of chunk 256"))

    if a.compression:
        _compression(mech, L, c, S, study, tmp)

    if a.memory:
        print("\npeak traced memory of run_study (numpy buffers included)")
        for n in (N, 4 * N):
            s = load_study({**study.as_dict(), "study": {**study.as_dict()["study"], "variants": n}})
            tracemalloc.start()
            explorer.run_study(s, output=out, force=True, progress=False)
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
            print(f"  N = {n:>9,}: peak {peak / 2**20:8.1f} MiB")
    out.unlink(missing_ok=True)


_FLOOR = """
import numba

@numba.njit(cache=True)
def one(x):
    return x + 1.0

one(1.0)
"""


def _timed(cmd, repeat: int) -> float:
    """Best wall time of ``repeat`` runs of the command ``cmd`` (after one warm-up run), s."""
    return best(lambda: subprocess.run(cmd, check=True), repeat)


def _command(a, out: Path, configs: int, t_pos: float) -> None:
    run = [sys.executable, "-m", "explorer.cli", "run", *([a.study] if a.study else []), "--force", "--quiet",
           "-o", str(out)]
    print("\n`explorer run --force -o ...` in a new process (start-up, imports and cache loads included)")
    with tempfile.TemporaryDirectory(prefix="bench-floor-") as d:
        floor = Path(d) / "floor.py"
        floor.write_text(_FLOOR)
        t_floor = _timed([sys.executable, str(floor)], a.repeat)
    print(f"  {'floor: python + numba + one cached call':<46s} {t_floor:8.3f} s")
    if a.command:
        t_run = _timed(run, a.repeat)
        print(_row("explorer run command, warm cache", t_run, configs, t_pos, "of baseline"))
        print(f"  {'':46s} {'':10s} {'':17s} {t_run - t_floor:6.2f} s above the floor")
    if a.cold:
        with tempfile.TemporaryDirectory(prefix="bench-cold-") as d:
            env = {**os.environ, "NUMBA_CACHE_DIR": d}
            t = time.perf_counter()
            subprocess.run(run, check=True, env=env)
            t_cold = time.perf_counter() - t
        print(_row("explorer run command, empty numba cache", t_cold, configs, t_pos, "of baseline"))


def _compression(mech, L, c, S, study, tmp: Path, n: int = 4096) -> None:
    n = min(n, len(c))
    b = explorer.simulate_batch(mech, L[:n], c[:n], S, vertices=[mech.foot], velocities=True,
                                tolerance=study.tolerance)
    data = [np.ascontiguousarray(b.paths[mech.foot]), np.ascontiguousarray(b.velocities[mech.foot])]
    raw = sum(d.nbytes for d in data)
    rows = explorer.store.hdf5_rows(S)
    print(f"\nHDF5 filters on {n:,} foot paths + velocities ({raw / 1e6:.0f} MB raw, chunks of {rows} rows, "
          f"Fletcher-32 on each; read back bit for bit)")
    import hdf5plugin
    from explorer.store._datasets import SERIES_FILTERS  # the filters [output] compression names
    B = hdf5plugin.Blosc
    candidates = [(f"{name} (explorer's)", kw) for name, kw in SERIES_FILTERS.items()] + [
        ("lzf, no shuffle", {"compression": "lzf", "fletcher32": True}),
        ("gzip 4 + shuffle", {"compression": "gzip", "compression_opts": 4, "shuffle": True, "fletcher32": True}),
        ("blosc lz4 1 + shuffle", {**B(cname="lz4", clevel=1, shuffle=B.SHUFFLE), "fletcher32": True}),
        ("blosc lz4 5 + bitshuffle", {**B(cname="lz4", clevel=5, shuffle=B.BITSHUFFLE), "fletcher32": True}),
        ("blosc zstd 1 + shuffle", {**B(cname="zstd", clevel=1, shuffle=B.SHUFFLE), "fletcher32": True}),
        ("blosc zstd 3 + shuffle", {**B(cname="zstd", clevel=3, shuffle=B.SHUFFLE), "fletcher32": True}),
        ("shuffle + zstd 1", {"shuffle": True, **hdf5plugin.Zstd(clevel=1), "fletcher32": True}),
        ("blosc lz4hc 3 + shuffle", {**B(cname="lz4hc", clevel=3, shuffle=B.SHUFFLE), "fletcher32": True})]
    for name, f_kw in candidates:
        p = tmp / "c.h5"
        cpu, tr = [], []
        for _ in range(3):
            t = time.process_time()
            with h5py.File(p, "w") as f:
                for i, d in enumerate(data):
                    f.create_dataset(str(i), data=d, chunks=(rows, S, 2), **f_kw)
            cpu.append(time.process_time() - t)
            t = time.perf_counter()
            with h5py.File(p, "r") as f:
                for i in range(len(data)):
                    assert np.array_equal(f[str(i)][...].view(np.uint64), data[i].view(np.uint64)), name
            tr.append(time.perf_counter() - t)
        size = p.stat().st_size
        print(f"  {name:<28s} size {size / raw:5.3f} of raw   write {raw / min(cpu) / 1e6:6.0f} MB per CPU-s   "
              f"read {raw / min(tr) / 1e6:6.0f} MB/s")
        p.unlink()


def _numba_threads():
    try:
        import numba
        return numba.get_num_threads()
    except Exception:
        return "?"


if __name__ == "__main__":
    main()
