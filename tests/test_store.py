"""Results files: the HDF5 layout, scene pruning, the frame, overwrite safety and in-process resume.

Small studies (tens of variants, 36 steps) keep this fast; the kernels' numerics are tested elsewhere.
"""

from __future__ import annotations

import copy

import h5py
import numpy as np
import pytest

from explorer import STATUS_NAMES, UserError, load_study, open_results, run_study, simulate_batch
from explorer.store import FILE_STATUS_NAMES, ResultsWriter, chunk_rows, hdf5_rows, seal
from explorer.study import study_variants

SMALL = {
    "study": {"name": "small", "mechanism": "jansen", "variants": 45, "seed": 2, "steps": 36, "method": "block"},
    "perturb": {"method": "uniform", "spread": 0.03, "links": "all", "crank": True},
    "scene": {"vertices": ["7", "4"], "velocities": True, "accelerations": False, "metrics": False},
}


def small(**changes):
    d = copy.deepcopy(SMALL)
    for key, value in changes.items():
        sec, k = key.split("__")
        d[sec][k] = value
    return d


def same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def all_datasets(f: h5py.File) -> dict:
    out = {}
    f.visititems(lambda name, obj: out.__setitem__(name, obj[...]) if isinstance(obj, h5py.Dataset) else None)
    return out


@pytest.fixture(scope="module")
def results_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("store") / "small.h5"
    summary = run_study(small(), output=path, progress=False, chunk_size=16)
    return path, summary


def test_summary(results_file):
    path, s = results_file
    assert s.path == path and s.ran == s.n_variants == 45 and s.steps == 36
    assert sum(s.counts.values()) == 45 and set(STATUS_NAMES.values()) <= set(s.counts)
    assert "ran 45 of 45 variants" in s.text() and "configurations/s" in s.text()
    assert str(path) == __import__("os").fspath(s)


def test_layout(results_file):
    path, _ = results_file
    study = load_study(small())
    mech = study.mech
    N, S = 45, 36
    with h5py.File(path, "r") as f:
        a = f.attrs
        assert a["format"] == "explorer-results" and a["format_version"] == 1
        assert bool(a["complete"]) is True
        assert a["study"] == study.text and a["explorer_version"] and a["created"]
        assert a["n_variants"] == N and a["steps"] == S
        assert np.allclose(f["theta"][...], 2 * np.pi * np.arange(S) / S)
        assert f["variants/lengths"].shape == (N, len(mech.links))
        assert [s.decode() if isinstance(s, bytes) else s for s in f["variants/lengths"].attrs["links"]] == \
            list(mech.link_names)
        assert f["variants/crank"].shape == (N,)
        st = f["status"]
        assert st.shape == (N,) and st.dtype == np.int8
        mapping = dict(zip(st.attrs["codes"].tolist(), [n.decode() if isinstance(n, bytes) else n
                                                         for n in st.attrs["names"]]))
        assert mapping == FILE_STATUS_NAMES and all(mapping[c] == n for c, n in STATUS_NAMES.items())
        assert f["fail_theta"].shape == (N,) and f["fail_block"].shape == (N,)
        assert len(f["fail_block"].attrs["vertex"]) >= 1
        assert set(f["paths"]) == {"7", "4"} and set(f["velocities"]) == {"7", "4"}
        assert "accelerations" not in f
        for g in ("paths", "velocities"):
            d = f[g]["7"]
            assert d.shape == (N, S, 2) and d.dtype == np.float64
            plist = d.id.get_create_plist()  # the default series filter: Blosc (32001), then Fletcher-32 (3)
            assert d.chunks[1:] == (S, 2) and [plist.get_filter(i)[0] for i in range(plist.get_nfilters())] == [32001, 3]
        assert f["chunks/done"].shape == (3,) and f["chunks/done"][...].all()
        assert f["chunks"].attrs["rows"] == 16


def test_stored_paths_are_the_kernel_output(results_file):
    path, _ = results_file
    study = load_study(small())
    L, c, _ = study_variants(study)
    b = simulate_batch(study.mech, L, c, 36, vertices=["7", "4"], velocities=True)
    with open_results(path) as r:
        with h5py.File(path, "r") as f:
            assert same_bits(f["variants/lengths"][...], L) and same_bits(f["variants/crank"][...], c)
            assert same_bits(f["status"][...], b.status)
            assert same_bits(f["paths/4"][...], b.paths["4"]) and same_bits(f["velocities/7"][...], b.velocities["7"])
        assert same_bits(r.path(5, "7"), b.paths["7"][5]) and same_bits(r.velocity(5, "4"), b.velocities["4"][5])
        assert r.path(0).shape == (36, 2)  # default vertex: the foot
        assert same_bits(r.path(0), b.paths["7"][0])


def test_frame(results_file):
    path, _ = results_file
    with open_results(path) as r:
        df = r.frame()
        mech = r.mechanism
        assert mech.name == "jansen" and r.complete and r.theta.shape == (36,)
        assert r.study["study"]["name"] == "small" and r.study["scene"]["vertices"] == ["7", "4"]
    assert len(df) == 45
    assert list(df.columns[:1 + len(mech.links) + 1]) == ["variant", *mech.link_names, "crank"]
    for col in ("status", "status_code", "fail_theta", "fail_vertex"):
        assert col in df.columns
    assert df["status"].value_counts().sum() == 45
    assert (df["status"].astype(str) == df["status_code"].map(FILE_STATUS_NAMES)).all()
    ok = df["status"] == "ok"
    assert ok.iloc[0]  # the nominal design
    assert df.loc[ok, "fail_theta"].isna().all() and df.loc[ok, "fail_vertex"].isna().all()
    bad = ~ok
    if bad.any():
        assert df.loc[bad, "fail_vertex"].notna().all()
        assert set(df.loc[bad, "fail_vertex"]) <= set(mech.vertices)
    assert np.array_equal(df.loc[0, list(mech.link_names)].to_numpy(float), mech.lengths)


def test_frame_picks_up_metrics_datasets(results_file, tmp_path):
    path, _ = results_file
    copy_path = tmp_path / "m.h5"
    copy_path.write_bytes(path.read_bytes())
    with h5py.File(copy_path, "r+") as f:
        f["metrics"].create_dataset("stride", data=np.arange(45.0))
    seal(copy_path)  # an edit made on purpose: its checksums recomputed (unsealed, it is a damaged file)
    with open_results(copy_path) as r:
        assert r.metric_names == ("stride",)
        assert np.array_equal(r.frame()["stride"].to_numpy(), np.arange(45.0))


@pytest.mark.slow
def test_metrics_from_the_study(tmp_path):
    from explorer.gait import METRICS
    assert {"width", "height"} <= set(METRICS)  # an assertion, not a skip: a lost metric is a regression
    d = small(scene__metrics=["width", "height"], scene__vertices=["4"], scene__velocities=False)
    p = run_study(d, output=tmp_path / "m.h5", progress=False).path
    with open_results(p) as r:
        df = r.frame()
        assert r.vertices == ("4",)
    with h5py.File(p, "r") as f:
        assert "velocities" not in f and set(f["metrics"]) == {"width", "height"}
    ok = df["status"] == "ok"
    assert df.loc[ok, "width"].notna().all() and df.loc[~ok, "width"].isna().all()


def test_scene_pruning(tmp_path):
    p = run_study(small(scene__velocities=False, scene__vertices=["7"]), output=tmp_path / "a.h5", progress=False)
    with h5py.File(p, "r") as f:
        assert "velocities" not in f and "accelerations" not in f and set(f["paths"]) == {"7"}
    with open_results(p) as r, pytest.raises(UserError, match="no velocities stored"):
        r.velocity(0, "7")
    p = run_study(small(scene__accelerations=True, scene__vertices="all"), output=tmp_path / "b.h5", progress=False)
    with h5py.File(p, "r") as f:
        mech = load_study(small()).mech
        assert set(f["paths"]) == set(f["velocities"]) == set(f["accelerations"]) == set(mech.vertices)


def test_refuses_to_overwrite_and_force(results_file, tmp_path):
    path, _ = results_file
    target = tmp_path / "x.h5"
    target.write_bytes(path.read_bytes())
    before = target.read_bytes()
    with pytest.raises(UserError, match=r"exists \(complete\); pass --force"):
        run_study(small(), output=target, progress=False)
    assert target.read_bytes() == before
    s = run_study(small(), output=target, resume=True, progress=False)
    assert s.already_complete and s.ran == 0 and "already complete" in s.text()
    assert target.read_bytes() == before
    s = run_study(small(), output=target, force=True, progress=False, chunk_size=32)
    assert s.ran == 45
    with h5py.File(target, "r") as f:
        assert f["chunks"].attrs["rows"] == 32
    with pytest.raises(UserError, match="exclude each other"):
        run_study(small(), output=target, resume=True, force=True, progress=False)


def test_resume_refuses_another_study(results_file, tmp_path):
    path, _ = results_file
    target = tmp_path / "x.h5"
    target.write_bytes(path.read_bytes())
    with h5py.File(target, "r+") as f:
        f.attrs["complete"] = False
    with pytest.raises(UserError, match=r"different run: differs in study.seed"):
        run_study(small(study__seed=3), output=target, resume=True, progress=False)


def test_existing_non_results_file(tmp_path):
    target = tmp_path / "x.h5"
    target.write_text("hello")
    with pytest.raises(UserError, match="exists"):
        run_study(small(), output=target, progress=False)
    with pytest.raises(UserError, match="cannot open"):
        run_study(small(), output=target, resume=True, progress=False)
    with pytest.raises(UserError, match="cannot open as an HDF5 results file"):
        open_results(target)


def test_unwritable_path(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("")
    with pytest.raises(UserError, match="cannot create the results file") as info:
        run_study(small(), output=blocker / "sub" / "x.h5", progress=False)
    assert "\n" not in str(info.value)
    with pytest.raises(UserError, match="is a folder"):
        run_study(small(), output=tmp_path, progress=False)


def test_interrupted_file_opens_and_resume_is_identical(tmp_path, monkeypatch):
    full = run_study(small(), output=tmp_path / "full.h5", progress=False, chunk_size=16).path

    commits = []
    real = ResultsWriter.write_chunk

    def failing(self, i, *args, **kw):
        if len(commits) == 1:
            raise KeyboardInterrupt  # as if Ctrl-C arrived during the second commit
        commits.append(i)
        return real(self, i, *args, **kw)

    monkeypatch.setattr(ResultsWriter, "write_chunk", failing)
    part = tmp_path / "part.h5"
    with pytest.raises(KeyboardInterrupt, match="--resume"):
        run_study(small(), output=part, progress=False, chunk_size=16)
    monkeypatch.setattr(ResultsWriter, "write_chunk", real)

    with open_results(part) as r:
        assert not r.complete
        df = r.frame()
        counts = r.status_counts()
    assert len(df) == 45 and sum(counts.values()) == 45
    assert counts["not-run"] == 45 - 16 and (df["status"] == "not-run").sum() == 29
    with pytest.raises(UserError, match=r"incomplete\); pass --force to overwrite it or --resume"):
        run_study(small(), output=part, progress=False)

    s = run_study(small(), output=part, resume=True, progress=False, chunk_size=999)  # keeps the file's chunks
    assert s.resumed and s.ran == 45 - 16
    with h5py.File(full, "r") as a, h5py.File(part, "r") as b:
        da, db = all_datasets(a), all_datasets(b)
        assert da.keys() == db.keys()
        for k in da:
            assert same_bits(da[k], db[k]), k
        assert bool(b.attrs["complete"])


def test_chunk_rows():
    h = hdf5_rows(360)
    assert h == 128 and hdf5_rows(36) == 1024
    assert chunk_rows(10_000, 360, 2) == 2048
    assert chunk_rows(10_000_000, 360, 2) == 2048  # memory flat in N
    assert chunk_rows(100, 360, 2) == 100
    rows = chunk_rows(10_000, 360, 7 * 3)  # every vertex with velocities and accelerations
    assert rows % h == 0 and rows * 21 * 360 * 16 <= 96 << 20
    assert chunk_rows(10_000, 360, 2, target=16) == 16


def test_open_results_errors(tmp_path):
    with pytest.raises(UserError, match="no such results file"):
        open_results(tmp_path / "missing.h5")
    p = tmp_path / "plain.h5"
    with h5py.File(p, "w") as f:
        f["x"] = 1
    with pytest.raises(UserError, match="not an explorer results file"):
        open_results(p)
