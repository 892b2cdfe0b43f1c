"""Lean studies (issue 29): ``[scene] store = "metrics"`` stores designs, statuses and metrics but no
series, and every reader that needs a series re-solves the designs it reads. The reference is the same
study run storing its series: the re-solved series must equal the stored ones bit for bit
(``np.array_equal``), on every built-in mechanism, failed variants (NaN rows) included."""

from __future__ import annotations

import copy
import tomllib
from pathlib import Path

import h5py
import numpy as np
import pytest

import explorer
from explorer import open_results, run_study
from explorer.cli import main
from explorer.errors import UserError
from explorer.mechanism import builtin_mechanisms

ROOT = Path(__file__).resolve().parents[1]


def study(mechanism: str, **scene) -> dict:
    """A small study that moves every design parameter (±4 %: some variants fail on the legs that can)."""
    crank = explorer.load_mechanism(mechanism).crank is not None
    return {"study": {"name": f"lean-{mechanism}", "mechanism": mechanism, "variants": 48, "seed": 7, "steps": 60},
            "perturb": {"method": "uniform", "spread": 0.04, "parameters": "all"},
            "scene": {"vertices": "all", "velocities": True, "metrics": crank, **scene}}


def both(tmp_path, spec: dict, tag: str = ""):
    """(full, lean): the study run storing its series and run lean, both open."""
    lean_spec = copy.deepcopy(spec)
    lean_spec["scene"]["store"] = "metrics"
    full = run_study(spec, output=tmp_path / f"full{tag}.h5", progress=False)
    lean = run_study(lean_spec, output=tmp_path / f"lean{tag}.h5", progress=False)
    return open_results(full), open_results(lean)


def test_every_builtin_is_leaned():
    """The test below runs on every built-in mechanism there is (the list is read when it is collected)."""
    assert {"arm", "fourbar", "hoeken", "jansen", "klann", "strider"} <= set(builtin_mechanisms())


@pytest.mark.parametrize("mechanism", builtin_mechanisms())
def test_resolved_series_equal_stored_ones(tmp_path, mechanism, capfd):
    F, L = both(tmp_path, study(mechanism))
    with F, L:
        assert L.lean and not F.lean
        assert L.file.attrs["store"] == "metrics"
        for group in ("paths", "velocities", "accelerations", "torque", "forces"):
            assert group not in L.file
        assert L.vertices == F.vertices and L.series_groups == F.series_groups == ("paths", "velocities")
        # designs, statuses (reasons, angles) and metrics: the same numbers
        df, dl = F.frame(), L.frame()
        assert df.equals(dl)
        capfd.readouterr()
        # any order, repeats, the nominal and the last variant: each design's series is its own whatever
        # else is solved with it (the kernels solve each design apart)
        order = [47, 3, 0, 3, 20, 11]
        for v in F.vertices:
            assert np.array_equal(L.path(order, v), F.path(order, v), equal_nan=True), v
            assert np.array_equal(L.velocity(order, v), F.velocity(order, v), equal_nan=True), v
        err = capfd.readouterr().err.strip().splitlines()
        assert err == [f"{L.filename} stores metrics only: re-solved variants 0, 3, 11, 20, 47 (0.0 s)"] or (
            len(err) == 1 and err[0].startswith(f"{L.filename} stores metrics only: re-solved variants 0, 3, 11, 20, 47"))
        # every variant at once, and one at a time: solved in other batches, the same bits
        everything = L.path(slice(None))
        assert np.array_equal(everything, F.path(slice(None)), equal_nan=True)
        one = L.path(17, F.vertices[-1])
        assert one.shape == (60, 2) and np.array_equal(one, F.path(17, F.vertices[-1]), equal_nan=True)
        if mechanism == "klann":  # the ±4 % Klann study has failures: their rows are NaN in both
            assert (df["status"] != "ok").any()


@pytest.mark.slow
def test_accelerations_and_forces(tmp_path):
    """The forces effect (torque, joint reactions) and accelerations are re-solved bit for bit too."""
    spec = tomllib.loads((ROOT / "studies" / "jansen-forces.toml").read_text())
    spec["study"].update(mechanism=str(ROOT / "studies" / "mechanisms" / "jansen-plywood.toml"), variants=24, steps=48)
    spec["scene"]["accelerations"] = True
    F, L = both(tmp_path, spec)
    with F, L:
        assert L.force_joints == F.force_joints == ("1", "2")
        assert F.frame().equals(L.frame())  # the force metrics are computed in the run, stored in both
        vs = [23, 0, 9]
        assert np.array_equal(L.acceleration(vs), F.acceleration(vs), equal_nan=True)
        for v in vs:
            assert np.array_equal(L.torque(v), F.torque(v), equal_nan=True)
            for j in F.force_joints:
                assert np.array_equal(L.force(v, j), F.force(v, j), equal_nan=True)


def test_what_is_not_stored_stays_refused(tmp_path):
    spec = study("jansen", vertices=["7"], velocities=False)
    F, L = both(tmp_path, spec)
    with F, L:
        for r in (F, L):
            with pytest.raises(UserError, match="no velocities stored"):
                r.velocity(0)
            with pytest.raises(UserError, match="vertex '3' is not stored"):
                r.path(0, "3")
            with pytest.raises(UserError, match="out of range"):
                r.path(48)
            with pytest.raises(UserError, match="no motor torque"):
                r.torque(0)
        assert np.array_equal(L.path([1, 2]), F.path([1, 2]), equal_nan=True)


@pytest.mark.slow
def test_explorer_metrics_on_a_lean_file(tmp_path, capsys):
    """`explorer metrics` re-solves a lean file a chunk at a time: the same metrics as from stored paths."""
    F, L = both(tmp_path, study("jansen", vertices=["7"]))
    spec = study("jansen", vertices=["3"], store="metrics")  # the foot is solved for the metrics, not stored
    L3 = open_results(run_study(spec, output=tmp_path / "lean3.h5", progress=False))
    F.close(), L.close(), L3.close()
    for r in (F, L, L3):
        assert main(["metrics", str(r.filename), "--band", "0.03", "--metrics", "bob,duty,stride"]) == 0
    out = capsys.readouterr().out
    assert f"{L.filename} stores metrics only: re-solved 48 variants" in out
    with open_results(F.filename) as f, open_results(L.filename) as lean, open_results(L3.filename) as lean3:
        assert lean.band == f.band == lean3.band == 0.03
        assert f.frame().equals(lean.frame())
        assert f.frame()[["bob", "duty", "stride"]].equals(lean3.frame()[["bob", "duty", "stride"]])


@pytest.mark.slow
def test_verbs_say_they_resolve(tmp_path, capfd):
    """plot --top, export --format csv and report read re-solved series (one stderr line each); the CSV
    is the full study's, byte for byte."""
    F, L = both(tmp_path, study("jansen", vertices=["7"]))
    df = F.frame()
    v = int(df.loc[(df["status"] == "ok") & (df["variant"] > 0), "variant"].iloc[0])
    F.close(), L.close()
    for r, tag in ((F, "f"), (L, "l")):
        assert main(["export", str(r.filename), "--variant", str(v), "--as", "csv",
                     "-o", str(tmp_path / f"{tag}.csv")]) == 0
    err = capfd.readouterr().err
    assert err.count("stores metrics only") == 1 and f"re-solved variant {v} " in err
    assert (tmp_path / "f.csv").read_bytes() == (tmp_path / "l.csv").read_bytes()
    assert main(["plot", str(L.filename), "--top", "3", "-o", str(tmp_path / "top.png")]) == 0
    err = capfd.readouterr().err
    assert err.count("stores metrics only") == 1 and (tmp_path / "top.png").stat().st_size > 0


def test_bad_store_value_is_one_line(tmp_path, capsys):
    spec = study("jansen")
    spec["scene"]["store"] = "paths"
    with pytest.raises(UserError, match=r"scene\.store: expected one of 'series', 'metrics', got 'paths'"):
        run_study(spec, output=tmp_path / "x.h5", progress=False)
    f = tmp_path / "s.toml"
    f.write_text('[study]\nname = "s"\nmechanism = "jansen"\nvariants = 4\n[scene]\nstore = true\n')
    assert main(["run", str(f), "-o", str(tmp_path / "y.h5")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(f) in err[0] and "scene.store" in err[0] and "True" in err[0]
    assert not (tmp_path / "y.h5").exists()


def test_lean_is_in_the_fingerprint_and_the_default_unchanged(tmp_path):
    """A lean file cannot be --resumed by the same study storing series (nor the reverse); a study without
    the key keeps the fingerprint it had (store is written only when lean)."""
    spec = study("jansen")
    plain = explorer.load_study(spec)
    assert "store" not in plain.as_dict()["scene"]
    spec2 = copy.deepcopy(spec)
    spec2["scene"]["store"] = "series"
    assert explorer.load_study(spec2).fingerprint() == plain.fingerprint()
    _, L = both(tmp_path, spec)
    L.close()
    with pytest.raises(UserError, match="differs in scene.store"):
        run_study(spec, output=L.filename, resume=True, progress=False)
    with h5py.File(L.filename, "r") as f:
        assert "paths" not in f and f.attrs["store"] == "metrics"


@pytest.mark.slow
def test_lean_on_dask_is_stitched_and_resolves(tmp_path):
    """A lean study on a Dask cluster: lean shards (no series), stitched into one lean file whose frame is
    the single-process lean run's, and whose re-solved series are the full study's, bit for bit."""
    distributed = pytest.importorskip("distributed", reason='dask.distributed is not installed (pip install "explorer[dask]")')
    import logging
    spec = study("jansen", vertices=["7"])
    spec["study"]["variants"] = 400
    F, L = both(tmp_path, spec)
    lean_spec = copy.deepcopy(spec)
    lean_spec["scene"]["store"] = "metrics"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None,
                                  silence_logs=logging.CRITICAL) as cluster, distributed.Client(cluster) as client:
        out = run_study(lean_spec, output=tmp_path / "dask" / "lean.h5", client=client, shard_size=128,
                        progress=False)
    shards = sorted((tmp_path / "dask" / "lean.shards").glob("shard-*.h5"))
    assert len(shards) == 4
    for s in shards:
        with h5py.File(s, "r") as f:
            assert f.attrs["store"] == "metrics" and "paths" not in f and "velocities" not in f
    with F, L, open_results(out) as D:
        assert D.lean and D.file.attrs["shards"] == "lean.shards"
        assert D.frame().equals(L.frame())
        vs = [399, 0, 130, 257]
        assert np.array_equal(D.path(vs), F.path(vs), equal_nan=True)
        assert np.array_equal(D.velocity(vs), F.velocity(vs), equal_nan=True)
