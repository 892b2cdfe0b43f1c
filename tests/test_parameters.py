"""Design parameters beyond link lengths: ``[perturb] parameters`` (the crank centre, ground pivots, ...).

The study file's validation (one-line errors, exit code 2), the sampling map (a length to
nominal × (1 + δ), a coordinate to nominal + δ × the mechanism's size; variant 0 exact) checked
against the documented draws reproduced here in plain numpy, and a small study run through
``explorer run`` whose stored foot paths are checked against the closed form of Jansen's leg
with each variant's own pivot and crank centre (``naive.jansen_closed_form``), its pivot-dependent
metrics against plain formulas, and ``explorer show`` / ``variant_mechanism`` on the moved pivots.
"""

from __future__ import annotations

import copy
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

import naive
from explorer import UserError, load_mechanism, load_study, open_results, run_study
from explorer.cli import main
from explorer.study import BLOCK, Sampler, apply_multipliers, dumps_toml, study_from_dict, study_variants

REPO = Path(__file__).resolve().parent.parent
#: Jansen's size: its longest link (5-7), the scale of coordinate spreads.
SIZE = max(naive.JANSEN_LENGTHS)
COORDS = ["2.x", "2.y", "crank.x", "crank.y"]
#: nominal value of each coordinate parameter
NOMINAL = {"crank.x": naive.JANSEN_CENTER[0], "crank.y": naive.JANSEN_CENTER[1],
           "2.x": naive.JANSEN_FIXED2[0], "2.y": naive.JANSEN_FIXED2[1]}

BASE = {
    "study": {"name": "pivots", "mechanism": "jansen", "variants": 40, "seed": 4, "steps": 90},
    "perturb": {"method": "uniform", "spread": 0.02, "parameters": list(COORDS)},
    "scene": {"vertices": ["7"], "velocities": True, "metrics": True},
}


def study_dict(**perturb) -> dict:
    d = copy.deepcopy(BASE)
    for k, v in perturb.items():
        if v is ...:
            d["perturb"].pop(k, None)
        else:
            d["perturb"][k] = v
    return d


def write(tmp_path: Path, data: dict, name: str = "pivots.toml") -> Path:
    p = tmp_path / name
    p.write_text(dumps_toml(data), encoding="utf-8")
    return p


def uniform_draws(seed: int, k: int, n: int) -> np.ndarray:
    """The documented uniform draws, written out: variant i ≥ 1 is row i − 1 of block 0's
    U(−1, 1) (BLOCK, k) draw from SeedSequence(seed, spawn_key=(0,)); row 0 (the nominal) is 0."""
    assert n - 1 <= BLOCK
    rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(0,))))
    u = rng.uniform(-1.0, 1.0, (BLOCK, k))
    return np.vstack([np.zeros((1, k)), u[: n - 1]])


# -- the study file ------------------------------------------------------------------------------------
def test_parameters_alone_perturb_exactly_what_they_list():
    s = load_study(study_dict())
    assert s.parameter_names == ("crank.x", "crank.y", "2.x", "2.y")  # mech.parameters() order
    assert s.geometry_names == ("crank.x", "crank.y", "2.x", "2.y")
    assert s.link_names == () and s.crank is False and s.n_parameters == 4 and s.n_variants == 40


def test_parameters_are_a_union_with_links_and_crank():
    s = load_study(study_dict(links="all", crank=True))
    names = tuple(f"{a}-{b}" for a, b in naive.JANSEN_LINKS)
    assert s.parameter_names == names + ("crank", "crank.x", "crank.y", "2.x", "2.y") and s.n_parameters == 15
    # links and the crank named among the parameters join links = [...] / crank = false
    s = load_study(study_dict(parameters=["2.y", "crank", "2-6"], links=["1-3"], crank=False))
    assert s.link_names == ("1-3", "2-6") and s.crank is True and s.geometry_names == ("2.y",)
    assert s.parameter_names == ("1-3", "2-6", "crank", "2.y")
    # "all": every design parameter of the mechanism
    s = load_study(study_dict(parameters="all"))
    assert s.parameter_names == names + ("crank", "crank.x", "crank.y", "2.x", "2.y")
    # links = [] is allowed beside parameters
    assert load_study(study_dict(links=[])).parameter_names == ("crank.x", "crank.y", "2.x", "2.y")


def test_resolved_study_round_trips_and_old_studies_keep_their_fingerprint():
    for d in (study_dict(), study_dict(links=["1-3"]), study_dict(parameters="all"),
              study_dict(parameters=["crank", "2.x"], crank=False)):
        s = load_study(d)
        again = study_from_dict(json.loads(json.dumps(s.as_dict())))
        assert again.parameter_names == s.parameter_names and again.fingerprint() == s.fingerprint()
    # a study without [perturb] parameters resolves as before: no such key (same fingerprint as before)
    assert "parameters" not in load_study(study_dict(parameters=...)).as_dict()["perturb"]
    assert "parameters" not in json.loads(load_study().fingerprint())["perturb"]


BAD = [
    # (value of [perturb] parameters, words the message must contain)
    (["2.x", "9.x"], "unknown design parameter '9.x' (known: 1-3, "),
    (["2.z"], "unknown design parameter '2.z'"),
    (["2.x", "2.x"], "listed twice"),
    ([], "non-empty list"),
    ("some", "non-empty list"),
    ([2], "design parameter names"),
]


@pytest.mark.parametrize("value, words", BAD, ids=[repr(b[0]) for b in BAD])
def test_bad_parameters_are_one_line_errors(tmp_path, capsys, value, words):
    p = write(tmp_path, study_dict(parameters=value))
    with pytest.raises(UserError) as info:
        load_study(p)
    msg = str(info.value)
    assert msg.startswith(f"{p}: perturb.parameters: ") and words in msg and "\n" not in msg
    assert main(["run", str(p)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "perturb.parameters" in err and str(p) in err and "Traceback" not in err


def test_unknown_parameter_names_the_value_and_the_known_ones(tmp_path):
    p = write(tmp_path, study_dict(parameters=["3.x"]))
    with pytest.raises(UserError) as info:
        load_study(p)
    msg = str(info.value)
    assert "'3.x'" in msg and all(n in msg for n in ("crank.x", "crank.y", "2.x", "2.y", "5-7", "crank"))


def test_path_driven_mechanism_has_no_crank_parameters(tmp_path):
    d = study_dict(parameters=["crank.x"])
    d["study"]["mechanism"] = "arm"
    d["scene"] = {"metrics": False}
    with pytest.raises(UserError, match=r"perturb\.parameters: mechanism 'arm' is driven along a path"):
        load_study(write(tmp_path, d))


def test_unknown_parameter_through_the_cli_process(tmp_path):
    p = write(tmp_path, study_dict(parameters=["2.x", "nope.y"]))
    r = subprocess.run([sys.executable, "-m", "explorer.cli", "run", str(p)], cwd=tmp_path, capture_output=True,
                       text=True, timeout=300, env=_env())
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert str(p) in r.stderr and "perturb.parameters" in r.stderr and "'nope.y'" in r.stderr
    assert not (tmp_path / "results").exists()


# -- sampling ------------------------------------------------------------------------------------------
def test_uniform_sampling_maps_lengths_relatively_and_coordinates_by_the_size():
    spread, seed, n = 0.02, 9, 600
    s = load_study(study_dict(links=["1-3", "5-7"], crank=True) | {"study": {
        "name": "m", "mechanism": "jansen", "variants": n, "seed": seed, "steps": 36}})
    names = s.parameter_names
    assert names == ("1-3", "5-7", "crank", "crank.x", "crank.y", "2.x", "2.y")
    L, c, G = study_variants(s)
    delta = spread * uniform_draws(seed, len(names), n)
    # lengths: nominal × (1 + δ); the others untouched
    i13, i57 = naive.JANSEN_LINKS.index(("1", "3")), naive.JANSEN_LINKS.index(("5", "7"))
    assert np.allclose(L[:, i13], 50.0 * (1.0 + delta[:, 0]), rtol=1e-15, atol=0)
    assert np.allclose(L[:, i57], 65.7 * (1.0 + delta[:, 1]), rtol=1e-15, atol=0)
    others = [j for j in range(10) if j not in (i13, i57)]
    assert np.array_equal(L[:, others], np.broadcast_to(np.array(naive.JANSEN_LENGTHS)[others], (n, 8)))
    assert np.allclose(c, 15.0 * (1.0 + delta[:, 2]), rtol=1e-15, atol=0)
    # coordinates: nominal + δ × size (65.7, the longest link)
    for j, name in enumerate(("crank.x", "crank.y", "2.x", "2.y")):
        assert np.allclose(G[:, j], NOMINAL[name] + delta[:, 3 + j] * SIZE, rtol=0, atol=1e-13)
        off = G[1:, j] - NOMINAL[name]
        assert np.abs(off).max() <= spread * SIZE + 1e-12 and np.abs(off).max() > 0.95 * spread * SIZE
    # variant 0 is the nominal, exactly
    assert np.array_equal(L[0], naive.JANSEN_LENGTHS) and c[0] == 15.0
    assert G[0].tolist() == [NOMINAL[k] for k in ("crank.x", "crank.y", "2.x", "2.y")]
    # any range of variants is the same rows (chunking and resume rely on it)
    parts = [study_variants(s, a, b) for a, b in ((0, 1), (1, 77), (77, n))]
    assert all(np.array_equal(np.concatenate([p[i] for p in parts]), full) for i, full in enumerate((L, c, G)))


def test_oat_levels_of_a_coordinate_span_exactly_the_spread():
    d = study_dict(parameters=["2.y"], method="oat", spread=0.05)
    d["study"]["variants"] = 5
    s = load_study(d)
    assert s.n_variants == 1 + 5
    L, c, G = study_variants(s)
    want = -7.8 + np.array([0.0, -0.05, -0.025, 0.0, 0.025, 0.05]) * SIZE
    assert np.allclose(G[:, 0], want, rtol=0, atol=1e-14) and G[0, 0] == -7.8
    assert np.abs(G[:, 0] + 7.8).max() <= 0.05 * SIZE + 1e-12  # (rounding of the sum)
    assert np.array_equal(L, np.broadcast_to(naive.JANSEN_LENGTHS, L.shape)) and (c == 15.0).all()


def test_normal_sigma_of_a_coordinate_is_spread_times_size():
    d = study_dict(parameters=["crank.x"], method="normal", spread=0.01)
    d["study"]["variants"] = 4000
    _, _, G = study_variants(load_study(d))
    off = (G[1:, 0] - 0.0) / SIZE
    assert G[0, 0] == 0.0 and abs(off.std() - 0.01) < 0.0005 and abs(off.mean()) < 0.0005


def test_studies_without_coordinates_sample_as_before():
    """A length-only study's variants are the multipliers applied as they always were (old results
    files resume to the same numbers)."""
    for method, variants in (("uniform", 300), ("sobol", 65), ("oat", 4), ("lhs", 50)):
        s = load_study({"study": {"name": "o", "mechanism": "jansen", "variants": variants, "seed": 2},
                        "perturb": {"method": method, "spread": 0.03, "links": ["2-6", "1-3"], "crank": True}})
        L, c, G = study_variants(s)
        mult = Sampler(method, variants, 3, 0.03, 2).rows()
        L0, c0 = apply_multipliers(s.mech, mult, ["2-6", "1-3"], True)
        assert np.array_equal(L, L0) and np.array_equal(c, c0) and G.shape == (len(c), 0)


def test_shipped_pivots_study():
    s = load_study(REPO / "studies" / "jansen-pivots.toml")
    names = tuple(f"{a}-{b}" for a, b in naive.JANSEN_LINKS)
    assert s.parameter_names == names + ("crank", "crank.x", "crank.y", "2.x", "2.y")
    assert (s.n_variants, s.spread, s.perturb_method) == (2000, 0.02, "uniform")
    L, c, G = study_variants(s, 0, 300)
    assert np.abs(L / np.array(naive.JANSEN_LENGTHS) - 1).max() <= 0.02
    assert np.abs(G - np.array([0.0, 0.0, -38.0, -7.8])).max() <= 0.02 * SIZE + 1e-12


# -- a small study, end to end ---------------------------------------------------------------------------
def _env() -> dict:
    """The environment of a CLI process: this checkout first on the import path."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    return env


@pytest.fixture(scope="module")
def pivots_run(tmp_path_factory):
    """40 variants × 90 steps moving pivot 2 and the crank centre, run by `explorer run`."""
    tmp = tmp_path_factory.mktemp("pivots")
    study = write(tmp, study_dict())
    r = subprocess.run([sys.executable, "-m", "explorer.cli", "run", str(study), "--quiet"], cwd=tmp,
                       capture_output=True, text=True, timeout=600, env=_env())
    assert r.returncode == 0, r.stderr
    out = tmp / "results" / "pivots.h5"
    with open_results(out) as res:
        df = res.frame()
    return out, df, tmp


def test_frame_carries_the_sampled_coordinates(pivots_run):
    out, df, _ = pivots_run
    n = 40
    delta = 0.02 * uniform_draws(4, 4, n)  # columns in crank.x, crank.y, 2.x, 2.y order
    for j, name in enumerate(("crank.x", "crank.y", "2.x", "2.y")):
        assert name in df.columns
        assert np.allclose(df[name].to_numpy(), NOMINAL[name] + delta[:, j] * SIZE, rtol=0, atol=1e-13)
        assert df.loc[0, name] == NOMINAL[name]
    # the lengths and the crank were not perturbed
    names = [f"{a}-{b}" for a, b in naive.JANSEN_LINKS]
    assert np.array_equal(df[names].to_numpy(), np.broadcast_to(naive.JANSEN_LENGTHS, (n, 10)))
    assert (df["crank"] == 15.0).all()
    with h5py.File(out, "r") as f:
        g = f["variants/geometry"]
        assert g.shape == (n, 4) and g.dtype == np.float64
        assert [s.decode() if isinstance(s, bytes) else s for s in g.attrs["names"]] == \
            ["crank.x", "crank.y", "2.x", "2.y"]
        assert g.attrs["nominal"].tolist() == [0.0, 0.0, -38.0, -7.8]
        assert [s.decode() if isinstance(s, bytes) else s for s in f["variants"].attrs["perturbed"]] == \
            ["crank.x", "crank.y", "2.x", "2.y"]
    with open_results(out) as res:
        assert res.geometry_names == ("crank.x", "crank.y", "2.x", "2.y")
        assert res.perturbed == ("crank.x", "crank.y", "2.x", "2.y")
        nom = res.nominal
        assert (nom["2.x"], nom["2.y"], nom["crank.x"], nom["crank.y"], nom["crank"]) == (-38.0, -7.8, 0.0, 0.0, 15.0)


def _closed_foot(df, v, thetas):
    """Foot path of variant ``v`` from the plain closed form with its own pivot 2 and crank centre."""
    row = df.loc[v]
    pos, ok, _ = naive.jansen_closed_form(naive.JANSEN_LENGTHS, 15.0, thetas,
                                          center=(row["crank.x"], row["crank.y"]),
                                          fixed2=(row["2.x"], row["2.y"]))
    return pos[:, 6], ok


def test_stored_foot_paths_are_the_closed_form_with_each_variants_pivots(pivots_run):
    out, df, _ = pivots_run
    thetas = 2.0 * np.pi * np.arange(90) / 90
    ok = np.flatnonzero((df["status"] == "ok").to_numpy())
    picked = [0] + [int(v) for v in ok[ok > 0][:5]]
    assert len(picked) == 6
    nominal_foot, _ = _closed_foot(df, 0, thetas)
    with open_results(out) as res:
        for v in picked:
            ref, assembled = _closed_foot(df, v, thetas)
            assert assembled.all()
            stored = res.path(v)
            assert np.abs(stored - ref).max() < 1e-9, v
            if v:  # the pivots really moved this foot
                assert np.abs(stored - nominal_foot).max() > 0.05
    # a variant the kernels could not assemble cannot be assembled by the closed form either
    failed = np.flatnonzero((df["status"] == "assembly").to_numpy())
    for v in failed[:3]:
        _, assembled = _closed_foot(df, int(v), 2.0 * np.pi * np.arange(720) / 720)
        assert not assembled.all()


def test_pivot_dependent_metrics_use_each_variants_pivots(pivots_run):
    out, df, _ = pivots_run
    thetas = 2.0 * np.pi * np.arange(90) / 90
    ok = [int(v) for v in np.flatnonzero((df["status"] == "ok").to_numpy())[:8]]
    fine = 2.0 * np.pi * np.arange(7200) / 7200
    for v in ok:
        row = df.loc[v]
        cx, cy, fx, fy = row["crank.x"], row["crank.y"], row["2.x"], row["2.y"]
        # foot_headroom: the lower of the crank axle and pivot 2, less the foot's highest point
        foot, _ = _closed_foot(df, v, thetas)
        assert row["foot_headroom"] == pytest.approx(min(cy, fy) - foot[:, 1].max(), abs=1e-9)
        # Grashof margin of the limiting loop: ground = |pivot 2 − crank centre|
        g = math.hypot(fx - cx, fy - cy)
        margins = []
        for coupler, rocker in ((50.0, 41.5), (61.9, 39.3)):  # loops through vertices 3 and 6
            s = sorted((15.0, coupler, rocker, g))
            margins.append((s[1] + s[2]) - (s[0] + s[3]))
        assert row["grashof_margin"] == pytest.approx(min(margins), abs=1e-12)
        # least transmission angle of both loops, sampled finely on the variant's own closed form
        pos, assembled, _ = naive.jansen_closed_form(naive.JANSEN_LENGTHS, 15.0, fine, center=(cx, cy),
                                                     fixed2=(fx, fy))
        assert assembled.all()
        worst = 90.0
        for j in (2, 5):  # vertices 3 and 6: angle between v→tip (vertex 1) and v→pivot 2
            a, b = pos[:, 0] - pos[:, j], pos[:, 1] - pos[:, j]
            cosm = (a * b).sum(axis=1) / (np.hypot(*a.T) * np.hypot(*b.T))
            mu = np.degrees(np.arccos(np.clip(cosm, -1, 1)))
            worst = min(worst, np.minimum(mu, 180.0 - mu).min())
        assert row["min_transmission_angle"] == pytest.approx(worst, abs=2e-3)
    # the nominal's pivots would give other values: the metrics did move with the pivots
    moved = df.loc[ok[1:]]
    assert (np.abs(moved["grashof_margin"] - df.loc[0, "grashof_margin"]) > 1e-3).all()
    assert (np.abs(moved["min_transmission_angle"] - df.loc[0, "min_transmission_angle"]) > 1e-3).any()


def test_recomputed_metrics_keep_each_variants_pivots(pivots_run, tmp_path):
    from explorer import recompute_metrics
    out, df, _ = pivots_run
    copy_ = tmp_path / "copy.h5"
    copy_.write_bytes(out.read_bytes())
    recompute_metrics(copy_, names=["foot_headroom", "min_transmission_angle"])
    with open_results(copy_) as res:
        again = res.frame()
    for m in ("foot_headroom", "min_transmission_angle"):
        assert np.array_equal(again[m].to_numpy(), df[m].to_numpy(), equal_nan=True)


def test_show_prints_every_parameter_against_the_nominal(pivots_run):
    out, df, tmp = pivots_run
    v = int(np.flatnonzero((df["status"] == "ok").to_numpy())[1])
    r = subprocess.run([sys.executable, "-m", "explorer.cli", "show", str(out), "--variant", str(v)], cwd=tmp,
                       capture_output=True, text=True, timeout=300, env=_env())
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    row = df.loc[v]
    for name, label, nominal in (("2.x", "pivot 2.x", -38.0), ("2.y", "pivot 2.y", -7.8),
                                 ("crank.x", "crank.x", 0.0), ("crank.y", "crank.y", 0.0)):
        line = next(l for l in lines if l.startswith(label + " "))
        cells = line.split()
        change = row[name] - nominal
        assert f"{row[name]:.4f}" in cells and f"{nominal:.4f}" in cells and f"{change:+.4f}" in cells
        assert f"{100 * change / SIZE:+.3f}" in cells and "(fixed)" not in line
    assert any(l.startswith("link 1-3 (fixed)") for l in lines) and any(l.startswith("crank (fixed)") for l in lines)


def test_variant_mechanism_draws_the_variants_own_pivots(pivots_run):
    from explorer import simulate
    from explorer.view import variant_mechanism
    out, df, _ = pivots_run
    v = int(np.flatnonzero((df["status"] == "ok").to_numpy())[2])
    row = df.loc[v]
    with open_results(out) as res:
        mech = variant_mechanism(res, v)
        stored = res.path(v)
    assert mech.fixed["2"] == pytest.approx((row["2.x"], row["2.y"]), abs=0)
    assert mech.crank.center == pytest.approx((row["crank.x"], row["crank.y"]), abs=0)
    cyc = simulate(mech, 90)
    assert cyc.ok and np.abs(cyc.path("7") - stored).max() < 1e-9


def test_a_study_without_coordinates_writes_no_geometry(tmp_path):
    d = {"study": {"name": "plain", "mechanism": "jansen", "variants": 6, "seed": 1, "steps": 12},
         "perturb": {"links": ["1-3"], "crank": False}}
    out = run_study(d, output=tmp_path / "plain.h5", progress=False).path
    with h5py.File(out, "r") as f:
        assert "geometry" not in f["variants"]
    with open_results(out) as res:
        df = res.frame()
        assert res.geometry_names == () and res.perturbed == ("1-3",)
    assert not any(c in df.columns for c in COORDS)


def test_pivots_through_the_python_api_need_no_cli(tmp_path):
    """run_study with a dict moving only the crank centre: stored paths are the closed form's."""
    d = study_dict(parameters=["crank.y"])
    d["study"].update(variants=6, steps=24)
    d["scene"]["metrics"] = False
    out = run_study(d, output=tmp_path / "api.h5", progress=False).path
    thetas = 2.0 * np.pi * np.arange(24) / 24
    with open_results(out) as res:
        df = res.frame()
        for v in range(6):
            if df.loc[v, "status"] != "ok":
                continue
            pos, ok, _ = naive.jansen_closed_form(naive.JANSEN_LENGTHS, 15.0, thetas,
                                                  center=(0.0, df.loc[v, "crank.y"]))
            assert ok.all() and np.abs(res.path(v) - pos[:, 6]).max() < 1e-9
    assert list(df.columns[df.columns.get_loc("crank") + 1:][:1]) == ["crank.y"]


def test_sizes_of_the_mechanism_match_the_reference():
    assert load_mechanism("jansen").size == SIZE


def test_sharded_study_file_carries_the_geometry(pivots_run, tmp_path):
    """Shards (what a Dask run writes) stitched into one file read as the single-process file."""
    from explorer.testing import plan_shards, shards_folder, stitch, write_shard
    from explorer.testing import chunk_solver
    _, df, tmp = pivots_run
    study = load_study(tmp / "pivots.toml")
    out = tmp_path / "sharded.h5"
    folder = shards_folder(out)
    plan = plan_shards(study, workers=2, shard_size=16, chunk_size=8)
    plan.write(folder)
    solve = chunk_solver(study)
    for i in range(plan.n_shards):
        write_shard(folder, plan, i, study, solve)
    stitch(out, folder, plan)
    assert plan.n_shards == 3
    with open_results(out) as res:
        again = res.frame()
        assert res.geometry_names == ("crank.x", "crank.y", "2.x", "2.y")
    for c in COORDS + ["foot_headroom", "min_transmission_angle", "grashof_margin"]:
        assert np.array_equal(again[c].to_numpy(), df[c].to_numpy(), equal_nan=True), c
