"""The writer that keeps up: series chunks filtered off the GIL and written with ``write_direct_chunk``
(explorer.store._chunks), commits marked done in groups (``ResultsWriter.sync``), and the kernels' one
persistent thread pool (explorer.kernels._rows).

References: HDF5 itself (the bytes it stores for the same chunk through h5py, read back with
``read_direct_chunk``), plain h5py in a fresh process that imports no explorer code, and HDF5's
Fletcher-32 written out line by line in ``tests/naive.py``."""

from __future__ import annotations

import multiprocessing
import subprocess
import sys
import threading

import h5py
import numpy as np
import pytest

from explorer.testing import (SERIES_FILTERS, ChunkFilter, check_integrity, chunk_solver, fletcher32, parallel_rows,
                              series_rows, write_rows)
from naive import fletcher32_naive


@pytest.mark.parametrize("n", [0, 1, 2, 3, 719, 720, 721, 1441, 5000, 131_073, 262_147])
def test_fletcher32_is_hdf5s(n):
    rng = np.random.default_rng(n)
    for data in (rng.integers(0, 256, n, dtype=np.uint8).tobytes(), b"\xff" * n, b"\x00" * n,
                 (rng.integers(0, 2, n, dtype=np.uint8) * 255).tobytes()):
        assert fletcher32(data) == fletcher32_naive(data)


def _series(rows: int, steps: int = 90, seed: int = 0) -> np.ndarray:
    """Smooth (rows, steps, 2) float64 series, as foot paths are (compressible, but not trivially)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 2.0 * np.pi, steps, endpoint=False)
    r = 1.0 + 0.05 * rng.standard_normal((rows, 1))
    return np.stack([r * np.cos(t) + 0.01 * rng.standard_normal((rows, steps)), r * np.sin(2.0 * t)], axis=-1)


@pytest.mark.parametrize("compression", sorted(SERIES_FILTERS))
def test_direct_chunks_are_the_bytes_hdf5_writes(tmp_path, compression):
    """Every HDF5 chunk written directly (the last one past the end of the dataset included) holds the bytes
    HDF5's own pipeline stores for the same rows, and plain h5py reads them back; lzf (inside h5py) goes
    through h5py."""
    x = _series(300)
    path = tmp_path / "c.h5"
    with h5py.File(path, "w") as f:
        kw = dict(shape=x.shape, chunks=(128,) + x.shape[1:], dtype="f8", fillvalue=np.nan, **SERIES_FILTERS[compression])
        ref, got = f.create_dataset("ref", **kw), f.create_dataset("got", **kw)
        ref[...] = x
        chunk_filter = ChunkFilter.of(got)
        assert (chunk_filter is None) == (compression == "lzf")
        write_rows(got, 0, 300, x, chunk_filter)
        f.flush()
        for off in (0, 128, 256):
            mask_ref, bytes_ref = ref.id.read_direct_chunk((off, 0, 0))
            mask_got, bytes_got = got.id.read_direct_chunk((off, 0, 0))
            assert mask_got == mask_ref == 0
            if chunk_filter is not None:  # (liblzf leaves its hash table uninitialised: its bytes vary run to run)
                assert bytes_got == bytes_ref
    code = ("import h5py, hdf5plugin, numpy as np, sys\n"
            f"f = h5py.File({str(path)!r}, 'r')\n"
            "assert 'explorer' not in sys.modules\n"
            "np.save(sys.stdout.buffer, f['got'][...])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, check=True).stdout
    import io
    assert np.array_equal(np.load(io.BytesIO(out)), x)


def test_a_direct_chunk_with_a_flipped_byte_is_a_read_error(tmp_path):
    """HDF5 checks the Fletcher-32 of a chunk written here as it checks its own."""
    x = _series(64)
    path = tmp_path / "c.h5"
    with h5py.File(path, "w") as f:
        d = f.create_dataset("s", shape=x.shape, chunks=x.shape, dtype="f8", **SERIES_FILTERS["none"])
        data = bytearray(ChunkFilter.of(d).encode(x).tobytes())
        d.id.write_direct_chunk((0, 0, 0), bytes(data), 0)
        assert np.array_equal(d[...], x)
        data[1000] ^= 0x10
        d.id.write_direct_chunk((0, 0, 0), bytes(data), 0)
    with h5py.File(path, "r") as f, pytest.raises(OSError):
        f["s"][...]


def test_rows_not_aligned_to_the_chunks_go_through_h5py(tmp_path):
    x = _series(300)
    with h5py.File(tmp_path / "c.h5", "w") as f:
        d = f.create_dataset("s", shape=x.shape, chunks=(128,) + x.shape[1:], dtype="f8", fillvalue=np.nan,
                             **SERIES_FILTERS["blosc"])
        cf = ChunkFilter.of(d)
        for a, b in ((0, 100), (100, 200), (200, 300)):  # partial chunks on both sides of each range
            write_rows(d, a, b, x[a:b], cf)
        assert np.array_equal(d[...], x)


def _kernel(out, idx):
    out[idx] = threading.get_ident()


def test_the_kernels_thread_pool_is_started_once():
    """Every call hands its blocks to the same worker threads (a run no longer starts a pool per chunk)."""
    seen = set()
    for _ in range(5):
        ids = np.zeros(64, dtype=np.int64)
        parallel_rows(_kernel, (ids,), (np.arange(64),), threads=2)
        assert (ids != 0).all()
        seen |= set(ids.tolist())
    assert threading.get_ident() not in seen and len(seen) <= 2


def _in_child(q):
    ids = np.zeros(16, dtype=np.int64)
    parallel_rows(_kernel, (ids,), (np.arange(16),), threads=2)
    q.put(bool((ids != 0).all()))


def test_the_pool_works_in_a_forked_child():
    """A child forked after the pool started gets a pool of its own (the parent's threads are not in it)."""
    parallel_rows(_kernel, (np.zeros(8, dtype=np.int64),), (np.arange(8),), threads=2)
    ctx = multiprocessing.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=_in_child, args=(q,))
    p.start()
    try:
        assert q.get(timeout=60) is True
    finally:
        p.join(timeout=60)
        if p.is_alive():
            p.kill()


SMALL = {
    "study": {"name": "sync", "mechanism": "jansen", "variants": 60, "seed": 3, "steps": 36, "method": "block"},
    "perturb": {"method": "uniform", "spread": 0.03, "links": "all", "crank": True},
    "scene": {"vertices": ["7"], "velocities": True, "accelerations": False, "metrics": ["stride"]},
}


def test_chunks_are_marked_done_per_sync_and_a_kill_between_syncs_leaves_a_file_that_verifies(tmp_path):
    """With ``sync_every``, chunks written since the last sync are not done on disk yet: a copy of the file
    taken then (what kill -9 leaves) verifies and names only the synced chunks; closing syncs the rest."""
    import shutil

    from explorer import load_study
    from explorer.store import ResultsWriter
    study = load_study(SMALL)
    path = tmp_path / "r.h5"
    w = ResultsWriter.create(path, study, 16)
    w.sync_every = 1e9
    solve = chunk_solver(study)
    for i in (0, 1, 2):
        lengths, crank, geometry, batch, metrics = solve(*w.chunk_range(i))
        w.write_chunk(i, lengths, crank, batch, metrics, geometry=geometry)
    assert w.done.tolist() == [True, False, False, False]  # the first commit syncs at once, the next two wait
    shutil.copy(path, tmp_path / "killed.h5")
    w.close()
    for name, done in (("killed.h5", [True, False, False, False]), ("r.h5", [True, True, True, False])):
        with h5py.File(tmp_path / name, "r") as f:
            check_integrity(f)
            assert f["chunks/done"][...].tolist() == done
            ran = f["status"][...] != -1
            assert ran[:16].all() and ran[48:].sum() == 0


@pytest.mark.parametrize("rows", [1, 50, 128, 200, 300, 384, 2048, 257])
def test_series_chunks_divide_the_commit(rows):
    """A new file's series chunks: at most hdf5_rows (128 at 360 steps) variants, and a divisor of the commit
    when one exists from half of that up (else 128: the commit's partial chunks then go through h5py)."""
    from explorer.store import hdf5_rows
    h = series_rows(rows, 360)
    assert hdf5_rows(360) == 128
    divisors = [d for d in range(64, 129) if rows % d == 0]
    assert h == (rows if rows <= 128 else max(divisors) if divisors else 128)
