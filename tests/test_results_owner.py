"""store owns results files: every dataset comes from the one spec table, a run's and a recompute's metric
datasets describe themselves alike, and Results reads one variant (row, design, mechanism)."""

from __future__ import annotations

import copy

import h5py
import numpy as np
import pandas as pd
import pytest

import explorer
from explorer import UserError, open_results, run_study
from explorer.store import DATASETS, dataset_spec, is_results
from explorer.analysis import recompute_metrics

STUDY = {
    "study": {"name": "owner", "mechanism": "jansen", "variants": 12, "seed": 5, "steps": 36},
    "perturb": {"method": "uniform", "spread": 0.03, "parameters": ["1-3", "2-6", "crank", "2.x", "2.y"]},
    "scene": {"vertices": ["7"], "velocities": True, "metrics": ["travel", "bob", "stride"]},
}


@pytest.fixture(scope="module")
def results_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("owner") / "owner.h5"
    run_study(copy.deepcopy(STUDY), output=path, progress=False, chunk_size=8)
    return path


def _datasets(f: h5py.File) -> dict:
    out = {}
    f.visititems(lambda n, o: out.__setitem__(n, o) if isinstance(o, h5py.Dataset) else None)
    return out


def test_every_dataset_has_a_spec_and_describes_itself(results_path):
    with h5py.File(results_path, "r") as f:
        found = _datasets(f)
        assert {"theta", "status", "paths/7", "velocities/7", "metrics/travel", "chunks/done"} <= set(found)
        for name, d in found.items():
            spec = dataset_spec(name)  # KeyError: a dataset outside the table
            assert d.dtype == np.dtype(spec.dtype), name
            assert "description" in d.attrs, name
            if spec.units:
                assert "units" in d.attrs, name
    # the forces study's series are in the table too
    assert dataset_spec("torque").shape == ("N", "S") and dataset_spec("torque").units == "N·m"
    assert dataset_spec("forces/2").shape == ("N", "S", 2) and dataset_spec("forces/2").units == "N"
    assert len({s.name for s in DATASETS}) == len(DATASETS)


def test_recomputed_metric_carries_the_same_attrs_as_a_run(results_path, tmp_path):
    copy_ = tmp_path / "copy.h5"
    copy_.write_bytes(results_path.read_bytes())
    with h5py.File(results_path, "r") as f:
        run_attrs = {m: dict(f["metrics"][m].attrs) for m in f["metrics"]}
        run_group = set(f["metrics"].attrs)
    recompute_metrics(copy_, names=["travel", "bob", "stride"])
    with h5py.File(copy_, "r") as f:
        for m, attrs in run_attrs.items():
            again = dict(f["metrics"][m].attrs)
            assert set(again) == set(attrs) >= {"band", "units", "direction", "description", "computed"}, m
            for k in ("band", "units", "direction", "description"):
                assert again[k] == attrs[k], (m, k)
            np.testing.assert_array_equal(f["metrics"][m][...], h5py.File(results_path, "r")["metrics"][m][...])
        assert run_group <= set(f["metrics"].attrs)


def test_row_is_the_frames_row(results_path):
    with open_results(results_path) as r:
        df = r.frame()
        for v in range(r.n_variants):
            row = r.row(v)
            assert isinstance(row, pd.Series)
            pd.testing.assert_series_equal(row, df.iloc[v])
        with pytest.raises(UserError, match="out of range"):
            r.row(r.n_variants)
        with pytest.raises(UserError, match="whole number"):
            r.row("x")


def test_design_is_every_parameter_nominal_where_not_perturbed(results_path):
    with open_results(results_path) as r:
        mech = r.mechanism
        nominal = mech.parameters()
        perturbed = set(r.perturbed)
        assert {"1-3", "2-6", "crank", "2.x", "2.y"} <= perturbed
        df = r.frame()
        for v in (0, 3, r.n_variants - 1):
            d = r.design(v)
            assert list(d) == list(nominal)  # every parameter, in mechanism.parameters() order
            for name, value in d.items():
                if name in perturbed:
                    assert value == float(df[name].iloc[v]), name
                else:
                    assert value == nominal[name], name
            # the design rebuilds the variant's mechanism
            assert r.variant_mechanism(v).parameters() == mech.with_parameters(d).parameters()
        assert r.design(0) == pytest.approx(nominal)  # variant 0 is the nominal
        assert is_results(r)


def test_view_names_still_import():
    from explorer.store import check_variant, variant_mechanism, variant_row
    from explorer.view import variant_mechanism as vm
    from explorer.testing import check_variant as cv, is_results as ir, results_band, variant_row as vr
    assert vm is variant_mechanism and cv is check_variant and vr is variant_row and ir is is_results
    assert callable(results_band)


def test_run_optimize_at_the_top_level():
    from explorer.optimize import run_optimize
    assert explorer.run_optimize is run_optimize
    assert "run_optimize" in explorer.__all__ and "run_optimize" in dir(explorer)


def test_metric_ranks_count_the_strictly_better_ok_variants(results_path):
    from explorer.gait import DIRECTIONS
    with open_results(results_path) as r:
        df = r.frame()
        ok = (df["status_code"] == 0).to_numpy()
        for v in range(r.n_variants):
            ranks = r.metric_ranks(v, frame=df, include_screened=True)
            assert set(ranks) == set(r.metric_names)
            for m, got in ranks.items():
                x = df[m].to_numpy(dtype=float)
                pool = ok & np.isfinite(x)
                if not pool[v]:
                    assert got is None
                    continue
                better = x[pool] > x[v] if DIRECTIONS[m] == "max" else x[pool] < x[v]
                assert got == (int(better.sum()) + 1, int(pool.sum()))
