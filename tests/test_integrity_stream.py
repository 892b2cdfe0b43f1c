"""The row digests are computed in bounded blocks (explorer.store._integrity.digests): the same SHA-256 as
hashing each chunk's rows whole, so files written before the streaming still verify, and a damaged row is
still refused when the rows are read a few at a time."""

from __future__ import annotations

import hashlib
import shutil

import h5py
import numpy as np
import pytest

import explorer
from explorer.errors import UserError
from explorer.store import _integrity

STUDY = {"study": {"name": "stream", "mechanism": "jansen", "variants": 150, "steps": 36, "seed": 3},
         "perturb": {"spread": 0.02}, "scene": {"metrics": True, "store": "metrics"}}


@pytest.fixture(scope="module")
def lean(tmp_path_factory):
    out = tmp_path_factory.mktemp("stream") / "stream.h5"
    explorer.run_study(STUDY, output=out, progress=False, chunk_size=16)
    return out


def whole_digest(datasets, a: int, b: int) -> bytes:
    """The reference: each dataset's rows [a, b) read in one piece and hashed in one update."""
    h = hashlib.sha256()
    for name, d in datasets:
        h.update(b"\0" + name.encode() + b"\0")
        h.update(np.ascontiguousarray(d[a:b]).tobytes())
    return h.digest()


def test_streamed_digest_equals_whole_array_digest(lean):
    with h5py.File(lean, "r") as f:
        n = int(f.attrs["n_variants"])
        rows = int(f["chunks"].attrs["rows"])
        assert -(-n // rows) >= 5  # several chunks, the last one short
        ds = _integrity.per_variant(f, n)
        assert {"status", "variants/lengths"} <= {name for name, _ in ds}
        ranges = [(i * rows, min((i + 1) * rows, n)) for i in range(-(-n // rows))]
        ref = [whole_digest(ds, a, b) for a, b in ranges]
        # the digests the writer stored (one commit at a time) are the whole-array ones
        assert [bytes(x) for x in f["chunks/digest"][...]] == ref
        for block in (1, 5, rows, 1 << 16):  # blocks inside a chunk, across chunks, whole
            assert _integrity.digests(ds, ranges, block=block) == ref
            assert _integrity.digests(ds, ranges[1::2], block=block) == ref[1::2]  # chunks with gaps between
        # a shard's chunks and the shard whole in the same pass (the stitch)
        chunks, whole = _integrity.digests_many(ds, [ranges, [(0, n)]], block=7)
        assert chunks == ref and whole == [whole_digest(ds, 0, n)]
        assert _integrity.chunk_digest(ds, 3, n - 2).tobytes() == whole_digest(ds, 3, n - 2)


def test_small_blocks_verify_and_still_refuse_a_changed_row(lean, tmp_path, monkeypatch):
    monkeypatch.setattr(_integrity, "READ_ROWS", 3)  # every read a few rows
    with explorer.open_results(lean) as r:
        assert r.n_variants == 150
    bad = tmp_path / "bad.h5"
    shutil.copy(lean, bad)
    with h5py.File(bad, "r+") as f:  # one metric of variant 100 changed, the checksums not resealed
        name = sorted(f["metrics"].keys())[0]
        v = f["metrics"][name][100]
        f["metrics"][name][100] = (v if np.isfinite(v) else 0.0) + 1.0
    rows = 16
    lo = 100 // rows * rows
    with pytest.raises(UserError, match=f"damaged: the data of variants {lo}..{lo + rows - 1} do not match"):
        explorer.open_results(bad)
