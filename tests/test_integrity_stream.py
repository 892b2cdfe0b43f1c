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
from explorer.testing import store_integrity as _integrity

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


def _stitched(folder):
    """STUDY cut into shards of 64 variants (chunks of 16), written and stitched without a cluster."""
    from explorer.store import ShardPlan, plan_shards, shards_folder, stitch, write_shard
    from explorer.study import load_study
    from explorer.testing import chunk_solver
    study = load_study(STUDY)
    out = folder / "stitched.h5"
    plan = plan_shards(study, workers=2, shard_size=64, chunk_size=16)
    assert (plan.n_shards, plan.shard_rows, plan.chunk_rows) == (3, 64, 16)
    shards = shards_folder(out)
    plan.write(shards)
    for i in range(plan.n_shards):
        write_shard(shards, plan, i, study, chunk_solver(study))
    stitch(out, shards, plan)
    return out, shards, ShardPlan.read(shards)


@pytest.mark.slow
def test_stitched_file_rows_are_verified_once_and_damage_is_refused(lean, tmp_path):
    from explorer.store import stitch
    out, shards, plan = _stitched(tmp_path)
    with explorer.open_results(out) as r, explorer.open_results(lean) as ref:
        assert r.frame().equals(ref.frame())  # the same designs and metrics as the single-process file
    with h5py.File(out, "r") as f:  # the study file's digest of shard 1 is its rows whole
        ds = _integrity.per_variant(f, 150)
        assert bytes(f["chunks/digest"][1]) == whole_digest(ds, 64, 128)
    shard = shards / "shard-00001.h5"
    clean = shard.read_bytes()
    with h5py.File(shard, "r+") as f:  # one metric of variant 70 changed in the shard, not resealed
        name = sorted(f["metrics"].keys())[0]
        v = f["metrics"][name][70]
        f["metrics"][name][70] = (v if np.isfinite(v) else 0.0) + 1.0
    # the shard's rows are not hashed again at open: the study file's digest of them refuses the change
    with pytest.raises(UserError, match="damaged: the data of variants 64..127 do not match their checksum"):
        explorer.open_results(out)
    # nor is a shard damaged before the stitch baked into the study file's checksums
    with pytest.raises(UserError, match="damaged shard file: the data of variants 64..79 do not match"):
        stitch(tmp_path / "again.h5", shards, plan)
    shard.write_bytes(clean)
    with h5py.File(shard, "r+") as f:  # a shard attribute changed: its own metadata checksum
        f.attrs["shard_host"] = "elsewhere"
    with pytest.raises(UserError, match="damaged shard file .*metadata or attributes do not match"):
        explorer.open_results(out)
