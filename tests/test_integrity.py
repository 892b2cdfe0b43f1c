"""A damaged results file never gives numbers without an error (issue 31, items 1 and 7).

The fuzzer damages one byte of a small results file (20 variants x 36 steps, with metrics) at a time,
in every byte region HDF5 gives it: the superblock, chunk data, the B-trees (chunk indexes and group
indexes), the global heap (the variable-length attributes: study, study_resolved, mechanism ...),
local heaps and symbol nodes (names), the contiguous datasets (/theta, /chunks/done, /chunks/digest)
and the rest of the metadata (object headers: datatypes, dataspaces, layouts, filter pipelines and
the fixed-size attributes such as nominal). On each damaged copy ``open_results(...).frame()``,
``rank``, ``show`` and ``export --format toml`` must either refuse (a UserError, or exit 2 with one
line on stderr) or give exactly the output of the undamaged file.
"""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

import explorer
from explorer.cli import main
from explorer.errors import UserError

STUDY = {"study": {"name": "fz", "mechanism": "jansen", "variants": 20, "steps": 36, "seed": 5},
         "perturb": {"spread": 0.03}, "scene": {"metrics": True, "vertices": ["7", "4"], "velocities": True}}


def build(folder, compression: str):
    study = {**STUDY, "output": {"compression": compression}}
    return explorer.run_study(study, output=folder / f"fz-{compression}.h5", progress=False).path


class _Files(dict):
    def __init__(self, folder):
        super().__init__()
        self.folder = folder

    def __missing__(self, compression):  # built on first use (the quick tests need only lzf)
        self[compression] = build(self.folder, compression)
        return self[compression]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return _Files(tmp_path_factory.mktemp("fuzz"))


# -- byte regions ---------------------------------------------------------------------------------------------
def regions(path) -> dict[str, list[tuple[int, int]]]:
    """{region: [(start, stop), ...]} of the file's bytes (see the module docstring)."""
    out: dict[str, list] = {"superblock": [(0, 96)], "chunk data": [], "contiguous datasets": [],
                            "B-trees (chunk and group indexes)": [], "global heap (attributes)": [],
                            "local heaps and symbol nodes (names)": []}

    def visit(name, obj):
        if not isinstance(obj, h5py.Dataset):
            return
        if obj.chunks:
            for k in range(obj.id.get_num_chunks()):
                info = obj.id.get_chunk_info(k)
                out["chunk data"].append((info.byte_offset, info.byte_offset + info.size))
        elif obj.id.get_offset() is not None:
            out["contiguous datasets"].append((obj.id.get_offset(), obj.id.get_offset() + obj.id.get_storage_size()))

    with h5py.File(path, "r") as f:
        f.visititems(visit)
    data = path.read_bytes()
    dense = "fractal heaps and v2 B-trees (dense attributes and names)"
    out[dense] = []
    for sig, region, size in ((b"TREE", "B-trees (chunk and group indexes)", 24 + 64 * 40),
                              (b"GCOL", "global heap (attributes)", None), (b"HEAP", "local heaps and symbol nodes (names)", 32),
                              (b"SNOD", "local heaps and symbol nodes (names)", 8 + 16 * 40),
                              # files written with v2 object headers (explorer.store._write.LIBVER) keep more than
                              # a few attributes of an object, or big ones, in a fractal heap indexed by a v2 B-tree
                              (b"FRHP", dense, 146), (b"FHIB", dense, 64), (b"FHDB", dense, 512), (b"BTHD", dense, 38),
                              (b"BTIN", dense, 512), (b"BTLF", dense, 512), (b"FSHD", dense, 64), (b"FSSE", dense, 64)):
        at = data.find(sig)
        while at >= 0:
            n = int.from_bytes(data[at + 8:at + 16], "little") if sig == b"GCOL" else size
            out[region].append((at, min(at + n, len(data))))
            at = data.find(sig, at + 4)
    out = {k: v for k, v in out.items() if v or k in ("chunk data", "superblock")}  # the regions this file has
    taken = np.zeros(len(data), dtype=bool)
    for spans in out.values():
        for a, b in spans:
            taken[a:b] = True
    rest = np.flatnonzero(~taken)
    out["other metadata (object headers, inline attributes)"] = [(int(i), int(i) + 1) for i in rest]
    return out


def sample(spans, rng, k: int) -> list[int]:
    offsets = np.concatenate([np.arange(a, b) for a, b in spans]) if spans else np.array([], dtype=int)
    return sorted(set(int(x) for x in rng.choice(offsets, min(k, len(offsets)), replace=False))) if len(offsets) else []


# -- outputs --------------------------------------------------------------------------------------------------
def outputs(path, capsys, tmp, verbs=True) -> dict:
    """What each consumer gives for ``path``: ("refused", message) or ("ok", the exact output)."""
    got = {}
    try:
        with explorer.open_results(path) as r:
            df = r.frame()
        got["frame"] = ("ok", df)
    except UserError as exc:
        assert "\n" not in str(exc), str(exc)
        got["frame"] = ("refused", str(exc))
    capsys.readouterr()
    if not verbs:
        return got
    toml = tmp / "export.toml"
    for name, argv in (("rank", ["rank", path]), ("show", ["show", path, "--variant", "3"]),
                       ("export", ["export", path, "--variant", "3", "--as", "toml", "-o", toml, "--force"])):
        toml.unlink(missing_ok=True)
        code = main([str(a) for a in argv])
        out, err = capsys.readouterr()
        if code == 0:
            text = toml.read_text(encoding="utf-8") if name == "export" else out
            text = text.replace(str(path), "RESULTS").replace(path.name, "RESULTS")
            got[name] = ("ok", text, err)
        else:
            assert code == 2, (name, code, err)  # never a traceback (exit 1) or a crash
            assert err.count("\n") == 1 and err.startswith("explorer: error: "), (name, err)
            got[name] = ("refused", err)
    return got


def same(a, b) -> bool:
    if a[0] != b[0]:
        return False
    if isinstance(a[1], str):
        return a[1] == b[1]
    return list(a[1].columns) == list(b[1].columns) and a[1].equals(b[1])


def fuzz(path, capsys, tmp, per_region: int, seed: int, verbs_always: bool) -> dict:
    """Damage one byte at a time (XOR with a random non-zero byte) at ``per_region`` offsets of every
    region; returns {"faults", "outputs", "refused", "exact", "wrong": [...]}."""
    rng = np.random.default_rng(seed)
    good = path.read_bytes()
    ref = outputs(path, capsys, tmp)
    assert all(v[0] == "ok" for v in ref.values()), ref
    assert all(v[2] == "" for k, v in ref.items() if k != "frame")  # a verified file: no warning
    stats = {"faults": 0, "outputs": 0, "refused": 0, "exact": 0, "wrong": [], "regions": {}}
    bad = tmp / "damaged.h5"
    for region, spans in regions(path).items():
        offsets = sample(spans, rng, per_region)
        stats["regions"][region] = len(offsets)
        for off in offsets:
            data = bytearray(good)
            data[off] ^= int(rng.integers(1, 256))
            bad.write_bytes(bytes(data))
            stats["faults"] += 1
            got = outputs(bad, capsys, tmp, verbs=verbs_always)
            if got["frame"][0] == "ok" and not verbs_always:
                got = outputs(bad, capsys, tmp)
            for name, g in got.items():
                stats["outputs"] += 1
                if g[0] == "refused":
                    stats["refused"] += 1
                elif same(g, ref[name]):
                    stats["exact"] += 1
                else:
                    stats["wrong"].append((region, off, name))
    return stats


def known_weak_bytes(path) -> dict[str, int]:
    """Bytes the issue found to give numbers from a damaged file before checksums: a chunk-index key of
    a metric, the study's resolved text (screen thresholds), the nominal design, /theta."""
    data = path.read_bytes()
    with h5py.File(path, "r") as f:
        key = data.find(f["metrics/stride"].id.get_chunk_info(0).byte_offset.to_bytes(8, "little")) - 16
        theta = f["theta"].id.get_offset() + 8 * 3
        nominal = data.find(np.asarray(f["variants/lengths"].attrs["nominal"]).tobytes()) + 8 * 2 + 6
        resolved = data.find(b'"spread"') + 12
    assert min(key, theta, nominal, resolved) > 0
    return {"chunk-index key": key, "/theta": theta, "nominal attribute": nominal, "study_resolved": resolved}


def test_quick_fuzz_every_region(files, capsys, tmp_path, monkeypatch):
    """A sample (the default run, < 10 s): every region of the lzf file, one byte each, plus the bytes
    the issue found weak (each changed in its low bits, the way a value drifts rather than breaks)."""
    path = files["lzf"]
    weak = known_weak_bytes(path)
    real_regions = regions
    monkeypatch.setitem(globals(), "regions", lambda p: {**real_regions(p),
                                                           **{k: [(v, v + 1)] for k, v in weak.items()}})
    stats = fuzz(path, capsys, tmp_path, per_region=1, seed=1, verbs_always=False)
    assert all(n > 0 for n in stats["regions"].values()), stats["regions"]
    assert stats["wrong"] == [], stats["wrong"]
    assert stats["refused"] > 0


@pytest.mark.slow
@pytest.mark.parametrize("compression", ["lzf", "gzip", "none"])
def test_fuzz_every_region(files, capsys, tmp_path, compression):
    """The long fuzz: ``EXPLORER_FUZZ_BYTES`` bytes of every region of each file (default 12 for lzf, the
    default compression, and 6 for gzip and none, whose metadata regions are the same and whose chunks
    differ only in their filter; the release note's run used 40: 840 faults, 3,360 outputs, 0 wrong),
    every consumer on every damaged copy. The defaults keep the suite within its time (each damaged copy
    costs four guarded opens; 40 bytes took 90 s per file on 2 cores)."""
    import os
    per_region = int(os.environ.get("EXPLORER_FUZZ_BYTES", "12" if compression == "lzf" else "6"))
    stats = fuzz(files[compression], capsys, tmp_path, per_region=per_region, seed=7, verbs_always=True)
    print(compression, {k: v for k, v in stats.items() if k != "wrong"})
    assert stats["wrong"] == [], stats["wrong"]


# -- checksums: what they cover, and what keeps them valid ------------------------------------------------------
def test_changed_attribute_or_index_key_is_refused(files, tmp_path):
    """The issue's cases, made directly: an attribute changed (a study threshold, the nominal, the stored
    mechanism), a chunk-index key moved, /theta changed, an ok row's metric set to NaN."""
    def damaged(name, edit):
        p = tmp_path / f"{name}.h5"
        shutil.copy(files["lzf"], p)
        with h5py.File(p, "r+") as f:
            edit(f)
        with pytest.raises(UserError, match="not a readable explorer results file \\(damaged") as info:
            explorer.open_results(p)
        assert "\n" not in str(info.value) and str(p) in str(info.value)

    damaged("resolved", lambda f: f.attrs.__setitem__("study_resolved", f.attrs["study_resolved"].replace("0.", "1.", 1)))
    damaged("nominal", lambda f: f["variants/lengths"].attrs.__setitem__(
        "nominal", f["variants/lengths"].attrs["nominal"] * 1.01))
    damaged("mechanism", lambda f: f.attrs.__setitem__("mechanism", f.attrs["mechanism"] + "\n"))
    damaged("theta", lambda f: f["theta"].__setitem__(1, 0.5))

    def nan_ok_row(f):
        ok = np.flatnonzero(f["status"][...] == 0)[0]
        f["metrics/stride"][ok] = np.nan
    damaged("nan", nan_ok_row)
    damaged("n_variants", lambda f: f.attrs.__setitem__("n_variants", 21))
    damaged("status", lambda f: f["status"].__setitem__(0, 7))


def test_index_key_byte_is_refused(files, tmp_path):
    """One byte of a chunk-index key (the offset of a chunk of /metrics/stride in its B-tree): HDF5 then
    reads the fill value, NaN, for the chunk it no longer finds; the digest refuses it."""
    p = tmp_path / "key.h5"
    data = bytearray(files["lzf"].read_bytes())
    with h5py.File(files["lzf"], "r") as f:
        addr = f["metrics/stride"].id.get_chunk_info(0).byte_offset
    # a v1 B-tree key of a chunk index: chunk size (4), filter mask (4), offsets (8 per dimension + 1),
    # then the child address; find the child address of the chunk and change the offset before it
    at = data.find(addr.to_bytes(8, "little"))
    assert at > 0
    data[at - 16] ^= 0x01  # the chunk's first offset (row 0 -> row 1)
    p.write_bytes(bytes(data))
    with pytest.raises(UserError, match="damaged"):
        explorer.open_results(p)


def test_legacy_file_opens_with_a_one_line_warning(files, tmp_path, capsys):
    p = tmp_path / "old.h5"
    shutil.copy(files["lzf"], p)
    with h5py.File(p, "r+") as f:  # as an earlier version wrote it
        del f.attrs["integrity"]
        del f["chunks/digest"]
    capsys.readouterr()
    with explorer.open_results(p) as r:
        assert len(r.frame()) == 20
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "without checksums" in err and str(p) in err
    with explorer.open_results(p):  # once per file and process
        pass
    assert capsys.readouterr().err == ""
    # one marker removed but not the other: damaged, not old
    q = tmp_path / "half.h5"
    shutil.copy(files["lzf"], q)
    with h5py.File(q, "r+") as f:
        del f.attrs["integrity"]
    with pytest.raises(UserError, match="integrity attribute is missing"):
        explorer.open_results(q)


def test_legacy_file_with_damaged_counts_is_one_line(files, tmp_path, capsys):
    """Item 7: a file without checksums whose n_variants or status values are damaged: one line, no traceback."""
    for name, edit in (("n", lambda f: f.attrs.__setitem__("n_variants", 25)),
                       ("st", lambda f: f["status"].__setitem__(slice(0, 3), [7, -5, 99]))):
        p = tmp_path / f"old-{name}.h5"
        shutil.copy(files["lzf"], p)
        with h5py.File(p, "r+") as f:
            del f.attrs["integrity"]
            del f["chunks/digest"]
            edit(f)
        for argv in (["rank", p], ["show", p, "--variant", "3"], ["export", p, "--variant", "3", "--as", "toml", "-o", tmp_path / "x.toml",
                                                     "--force"]):
            code = main([str(a) for a in argv])
            err = capsys.readouterr().err
            lines = [x for x in err.splitlines() if not x.startswith("explorer: warning:")]
            assert code in (0, 2) and (code == 0 or (len(lines) == 1 and "explorer: error:" in lines[0])), (name, argv, err)


def test_metrics_recompute_keeps_the_file_verified(files, tmp_path):
    p = tmp_path / "m.h5"
    shutil.copy(files["lzf"], p)
    explorer.recompute_metrics(p, band=0.02)
    with explorer.open_results(p) as r:
        assert r.band == 0.02 and len(r.frame()) == 20


def test_a_commit_cut_by_a_kill_is_solved_again_on_resume(tmp_path):
    """kill -9 during the flush of a commit can leave a chunk marked done before its digest and the metadata
    checksum reach the disk. --resume solves that chunk again (its rows do not match its digest) instead of
    refusing the file; the result equals an uninterrupted run. Made here by marking a chunk done by hand."""
    study = {"study": {"name": "cut", "mechanism": "jansen", "variants": 40, "seed": 3, "steps": 24},
             "perturb": {"spread": 0.01}, "scene": {"metrics": ["travel"]}, "output": {"compression": "none"}}
    whole = tmp_path / "whole.h5"
    explorer.run_study(study, output=whole, progress=False, chunk_size=8)
    cut = tmp_path / "cut.h5"
    shutil.copy(whole, cut)
    with h5py.File(cut, "r+") as f:  # as if killed: chunks 2.. not done, chunk 3 marked done, rows unwritten
        done = f["chunks/done"][...]
        done[2:] = False
        f["chunks/done"][...] = done
        f.attrs["complete"] = False
    explorer.store.seal(cut)
    with h5py.File(cut, "r+") as f:
        f["status"][24:32] = -1          # its rows as an unfinished commit left them
        done = f["chunks/done"][...]
        done[3] = True                   # the done mark reached the disk; digest and checksum did not
        f["chunks/done"][...] = done
    with pytest.raises(UserError, match="damaged"):
        explorer.open_results(cut)
    explorer.run_study(study, output=cut, progress=False, resume=True, chunk_size=8)
    with explorer.open_results(cut) as r, explorer.open_results(whole) as w:
        a, b = r.frame(), w.frame()
        assert r.complete
        assert a.drop(columns=[]).equals(b)
