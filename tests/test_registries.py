"""What leaves the program has a registry, and adding to one is one entry and its code:

* a stored series (explorer.store._datasets.SERIES): the writer creates and fills it, ``Results.series``
  reads it, the integrity checks cover it and a lean file re-solves it, all from the one entry;
* a per-variant dataset (explorer.store._datasets.VARIANT_DATA): the writer creates and fills it, the chunk
  digests cover it, ``Results.frame`` reads it back, all from the one entry;
* a metric group (explorer.gait._metrics.GROUPS) says where it applies, with no chain of special cases;
* the export formats (explorer.fabrication.EXPORTS) are tested in test_cli_vocabulary.py (a toy format).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import explorer
from explorer.store import (SERIES, VARIANT_DATA, DatasetSpec, SeriesSpec, VariantData, register_series,
                            register_variant_data)

STUDY = {"study": {"name": "toy", "mechanism": "jansen", "variants": 8, "seed": 3, "steps": 36},
         "perturb": {"method": "uniform", "spread": 0.01}, "scene": {"velocities": True, "metrics": ["stride"]}}


def speed_rows(batch, name):
    v = batch.velocities[name]
    return np.hypot(v[..., 0], v[..., 1])


TOY = SeriesSpec("speeds", "vertex", stored=lambda study: bool(study.velocities),
                 members=lambda study: list(study.vertex_names),
                 solved=lambda solve: list(solve["stored"]) if "velocities" in solve["groups"] else None,
                 rows=speed_rows,
                 dataset=DatasetSpec("speeds/<vertex>", "f8", ("N", "S"), "series", math.nan, "model units per rad",
                                     "speed of the vertex per radian of crank, |dV/dθ|"))


def _registered(register, registry: list, entry):
    """A fixture's body: ``entry`` registered while the test runs, removed after."""
    register(entry)
    try:
        yield entry
    finally:
        registry.remove(entry)


@pytest.fixture
def toy_series():
    yield from _registered(register_series, SERIES, TOY)


def test_a_toy_series_is_one_registry_entry(toy_series, tmp_path):
    from explorer.testing import series_groups
    assert "speeds" in series_groups()  # the integrity checks read the registry
    full = explorer.run_study(STUDY, output=tmp_path / "full.h5", progress=False).path
    lean_study = {**STUDY, "scene": {**STUDY["scene"], "store": "metrics"}}
    lean = explorer.run_study(lean_study, output=tmp_path / "lean.h5", progress=False).path
    with explorer.open_results(full) as res:
        foot = res.mechanism.foot
        assert res.file["speeds"][foot].shape == (8, 36)  # the writer made and filled it from the entry
        assert res.file["speeds"][foot].attrs["vertex"] == foot
        ok = [v for v in range(8) if res.row(v)["status"] == "ok"]
        assert len(ok) >= 4
        for v in ok:
            vel = np.asarray(res.velocity(v, foot))
            np.testing.assert_allclose(res.series("speeds", v, foot), np.sqrt(vel[:, 0] ** 2 + vel[:, 1] ** 2),
                                       rtol=1e-15, atol=0)
        stored = {v: np.asarray(res.series("speeds", v, foot)) for v in ok}
    with explorer.open_results(lean) as res:
        assert "speeds" not in res.file  # a lean file stores no series ...
        for v in ok:  # ... and re-solves this one as the others, bit for bit
            np.testing.assert_array_equal(res.series("speeds", v, foot), stored[v])
    # the integrity check covers it: a flipped byte inside the toy series is a refusal, never a number
    import h5py
    with h5py.File(full, "r") as f:
        offset = f["speeds"][foot].id.get_chunk_info(0).byte_offset
    data = bytearray(full.read_bytes())
    data[offset + 40] ^= 0xFF
    bad = tmp_path / "bad.h5"
    bad.write_bytes(bytes(data))
    with pytest.raises((OSError, explorer.UserError)):
        with explorer.open_results(bad) as res:
            res.series("speeds", ok[0], foot)


def test_series_of_the_registry_read_alike(tmp_path):
    study = {**STUDY, "operating": {"unit": 0.001, "rpm": 30, "load": 1.0},
             "scene": {**STUDY["scene"], "forces": True, "force_joints": ["1", "2"]}}
    path = explorer.run_study(study, output=tmp_path / "f.h5", progress=False).path
    with explorer.open_results(path) as res:
        np.testing.assert_array_equal(res.series("torque", 2), res.torque(2))
        np.testing.assert_array_equal(res.series("forces", 2, res.force_joints[0]), res.force(2, res.force_joints[0]))
        np.testing.assert_array_equal(res.series("paths", 2), res.path(2))
        with pytest.raises(explorer.UserError, match="not a series"):
            res.series("status", 2)


def test_metric_groups_say_where_they_apply(monkeypatch):
    from explorer.gait import available_metrics
    from explorer.testing import METRIC_GROUPS as GROUPS, MetricGroup
    from explorer.testing import BY_NAME
    slider = explorer.load_mechanism("slidercrank")
    jansen = explorer.load_mechanism("jansen")
    assert all(isinstance(g, MetricGroup) and callable(g.where) for g in GROUPS.values())
    # the slider group applies where the foot slides, the leg groups where it lifts: from the groups' entries
    assert available_metrics(slider)["quick_return"] is None and available_metrics(jansen)["quick_return"]
    assert available_metrics(slider)["stride"] and available_metrics(jansen)["stride"] is None
    # a group's own rule is the one place that decides
    monkeypatch.setitem(GROUPS, "slider", GROUPS["slider"]._replace(where=lambda mech: "toy: never here"))
    assert available_metrics(slider)["quick_return"] == "toy: never here"
    leg = [m for m, info in BY_NAME.items() if info.group == "leg"]
    monkeypatch.setitem(GROUPS, "leg", GROUPS["leg"]._replace(where=lambda mech: None))
    assert all(available_metrics(slider)[m] is None or "foot" not in available_metrics(slider)[m] for m in leg
               if "mechanism" not in BY_NAME[m].needs)


def _foot_reach(commit):
    """Toy per-variant value: the longest link of each design over its crank radius (n,)."""
    return np.asarray(commit.lengths).max(axis=1) / np.asarray(commit.crank)


TOY_DATA = VariantData("toy/reach", rows=_foot_reach,
                       columns=lambda results, values, a: {"toy_reach": values},
                       dataset=DatasetSpec("toy/reach", "f8", ("N",), "scalar", math.nan, "",
                                           "longest link over crank radius"))


@pytest.fixture
def toy_variant_data():
    yield from _registered(register_variant_data, VARIANT_DATA, TOY_DATA)


def test_a_toy_per_variant_dataset_is_one_registry_entry(toy_variant_data, tmp_path):
    import h5py
    with pytest.raises(ValueError, match="already registered"):
        register_variant_data(TOY_DATA)
    path = explorer.run_study(STUDY, output=tmp_path / "toy.h5", progress=False).path
    with h5py.File(path, "r") as f:  # the writer made it from its entry and filled every row
        d = f["toy/reach"]
        assert d.shape == (8,) and d.dtype == np.float64 and d.attrs["description"] == "longest link over crank radius"
        stored = d[...]
        lengths, crank = f["variants/lengths"][...], f["variants/crank"][...]
    reach = np.array([max(lengths[i]) / crank[i] for i in range(8)])  # plainly, row by row
    np.testing.assert_array_equal(stored, reach)
    with explorer.open_results(path) as res:  # read back as a frame column, after the failure columns
        df = res.frame()
        np.testing.assert_array_equal(df["toy_reach"].to_numpy(), reach)
        cols = list(df.columns)
        assert cols.index("iterations") < cols.index("toy_reach") < cols.index("stride")
        np.testing.assert_array_equal(res.frame_rows([5, 2])["toy_reach"].to_numpy(), reach[[5, 2]])
    # the integrity checks cover it: one value changed with plain h5py is a refusal naming the file
    with h5py.File(path, "r+") as f:
        f["toy/reach"][3] = 1.0
    with pytest.raises(explorer.UserError, match="damaged"):
        explorer.open_results(path)
    # a file written without the entry opens alike (the entry is read where the file has it)
    VARIANT_DATA.remove(TOY_DATA)
    try:
        plain = explorer.run_study(STUDY, output=tmp_path / "plain.h5", progress=False).path
        with explorer.open_results(plain) as res:
            assert "toy_reach" not in res.frame().columns
    finally:
        VARIANT_DATA.append(TOY_DATA)


def test_open_results_takes_a_resolver(tmp_path):
    """store re-solves a lean file through the resolver it is given (store reads and writes files only);
    explorer.open_results is study's, with explorer's resolver; the kernels' assembly places a variant."""
    from explorer.store import Resolver
    from explorer.store import open_results as store_open
    from explorer.study import RESOLVER, resolve_series
    lean = {**STUDY, "scene": {**STUDY["scene"], "store": "metrics"}}
    path = explorer.run_study(lean, output=tmp_path / "lean.h5", progress=False).path
    calls = []

    def series(f, variants, **kw):
        calls.append(np.asarray(variants).tolist())
        return resolve_series(f, variants, **kw)

    with store_open(path, resolver=Resolver(series=series, assemble=RESOLVER.assemble)) as res:
        got = res.path(2)
        assert calls == [[2]]
    with explorer.open_results(path) as res:
        assert res.resolver is RESOLVER
        np.testing.assert_array_equal(res.path(2), got)
