"""Results.rank on a small real study (checked against plain pandas) and recompute_metrics (checked against
plain numpy): another band without re-solving, paths untouched, refusals of files it cannot serve.

Tiny studies (tens of variants, 72 steps) keep this fast; the metric kernels are tested in test_gait_metrics.
"""

from __future__ import annotations

import copy
import shutil

import h5py
import numpy as np
import pytest

from explorer import UserError, open_results, run_study
from explorer.gait import DIRECTIONS, TARGET_METRICS
from explorer.gait import BY_NAME, FORCE_METRICS, ROBUSTNESS_METRICS
from explorer.gait import METRICS as ALL_METRICS
from explorer.analysis import recompute_metrics

#: every metric a leg study stores (path synthesis's path_error needs a [target] path, the forces effect's
#: need [scene] forces)
METRICS = tuple(m for m in ALL_METRICS if m not in TARGET_METRICS and m not in FORCE_METRICS
                and m not in ROBUSTNESS_METRICS and BY_NAME[m].group not in ("slider", "physics"))  # slider: a foot on a slider; physics: `explorer physics`

STUDY = {
    "study": {"name": "rank", "mechanism": "jansen", "variants": 48, "seed": 7, "steps": 72},
    "perturb": {"method": "uniform", "spread": 0.04, "links": "all", "crank": True},
    "scene": {"vertices": ["7"], "velocities": True, "metrics": True},
}
STANCE = ("stride", "duty", "flatness", "stance_rms_line", "stance_speed", "speed_ripple")


def study(**scene):
    d = copy.deepcopy(STUDY)
    d["scene"].update(scene)
    return d


@pytest.fixture(scope="module")
def results_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("rank") / "rank.h5"
    run_study(study(), output=path, progress=False, chunk_size=16)
    with open_results(path) as res:
        counts = res.status_counts()
    assert counts["ok"] >= 20 and counts["ok"] < 48, counts  # some failures, enough ok rows to rank
    return path


@pytest.fixture
def fresh(results_path, tmp_path):
    """A private copy of the results file (for the tests that rewrite its metrics)."""
    p = tmp_path / "copy.h5"
    shutil.copyfile(results_path, p)
    return p


def buildable(df):
    """The rows rank keeps by default: ok, and passing the buildability screen (tested in test_screen)."""
    return df[(df["status"].astype(str) == "ok") & df["buildable"]]


def pandas_sort(df, col, ascending):
    ok = buildable(df)
    return ok.sort_values([col, "variant"], ascending=[ascending, True], na_position="last")


# -- Results.rank ---------------------------------------------------------------------------------------
def test_rank_by_every_metric_matches_a_pandas_sort(results_path):
    with open_results(results_path) as res:
        df = res.frame()
        assert set(METRICS) <= set(df.columns)
        for m in METRICS:
            want = pandas_sort(df, m, DIRECTIONS[m] == "min").head(10)
            got = res.rank(by=m)
            assert list(got["variant"]) == list(want["variant"]), m
            assert list(got["rank"]) == list(range(1, len(want) + 1))
            np.testing.assert_array_equal(got[m].to_numpy(), want[m].to_numpy())
        # direction overrides, top=None, and the frame's index kept
        want = pandas_sort(df, "stride", True)
        got = res.rank(by="stride", ascending=True, top=None)
        assert list(got["variant"]) == list(want["variant"]) and list(got.index) == list(want.index)
        assert list(res.rank(by="flatness", ascending=False, top=5)["variant"]) == \
            list(pandas_sort(df, "flatness", False).head(5)["variant"])


def test_rank_where_and_failed(results_path):
    with open_results(results_path) as res:
        df = res.frame()
        got = res.rank(by="flatness", top=None, where="duty > 0.3 and stride > 40")
        ok = buildable(df)
        ok = ok[(ok["duty"] > 0.3) & (ok["stride"] > 40)]
        want = ok.sort_values(["flatness", "variant"])
        assert len(want) >= 1 and list(got["variant"]) == list(want["variant"])
        # failed variants are out unless asked for; then they come last (NaN metrics)
        n_ok = res.status_counts()["ok"]
        assert len(res.rank(top=None)) == len(buildable(df)) < n_ok
        assert len(res.rank(top=None, include_screened=True)) == n_ok
        allr = res.rank(by="stride", top=None, include_failed=True, include_screened=True)
        assert len(allr) == res.n_variants
        assert (allr["status"].astype(str).iloc[:n_ok] == "ok").all()
        assert allr["stride"].iloc[n_ok:].isna().all()
        with pytest.raises(UserError, match="where: cannot parse"):
            res.rank(where="stride >")


def test_rank_weights_and_pareto(results_path):
    with open_results(results_path) as res:
        df = res.frame()
        ok = buildable(df)
        # weighted score by hand: min-max normalise, flip the "min" metric, weighted mean
        s = (ok["stride"] - ok["stride"].min()) / (ok["stride"].max() - ok["stride"].min())
        f = (ok["flatness"].max() - ok["flatness"]) / (ok["flatness"].max() - ok["flatness"].min())
        score = (2 * s + 1 * f) / 3
        want = ok.assign(score=score).sort_values(["score", "variant"], ascending=[False, True])
        got = res.rank(weights={"stride": 2, "flatness": 1}, top=None)
        assert list(got["variant"]) == list(want["variant"])
        np.testing.assert_allclose(got["score"].to_numpy(), want["score"].to_numpy(), rtol=1e-12)
        # Pareto front by brute force: no other ok row at least as good in both and better in one
        st, fl = ok["stride"].to_numpy(), ok["flatness"].to_numpy()
        front = [v for v, a, b in zip(ok["variant"], st, fl)
                 if not ((st >= a) & (fl <= b) & ((st > a) | (fl < b))).any()]
        got = res.rank(pareto="stride,flatness", top=None)
        assert sorted(got["variant"]) == sorted(front)
        assert list(got["stride"]) == sorted(got["stride"], reverse=True)


def test_rank_missing_metrics_say_how_to_compute_them(results_path, tmp_path):
    bare = tmp_path / "bare.h5"
    run_study(study(metrics=False), output=bare, progress=False)
    with open_results(bare) as res:
        assert res.metric_names == ()
        with pytest.raises(UserError, match=r"no gait metrics stored.*explorer metrics .*bare\.h5.*metrics = true"):
            res.rank()
        # ranking on a stored column that is not a metric still works
        assert len(res.rank(by="crank", ascending=True, top=3)) == 3
    some = tmp_path / "some.h5"
    run_study(study(metrics=["width", "height"]), output=some, progress=False)
    with open_results(some) as res:
        with pytest.raises(UserError, match=r"metrics? stride, flatness not stored.*--metrics stride,flatness"):
            res.rank(pareto=["stride", "flatness"])
        assert len(res.rank(by="height")) == 10


def test_results_band_and_nominal(results_path):
    with open_results(results_path) as res:
        assert res.band == 0.01  # the study's [scene] band (default)
        nom = res.nominal
        assert list(nom) == list(res.link_names) + ["crank"]
        np.testing.assert_array_equal([nom[k] for k in res.link_names], res.mechanism.lengths)
        assert nom["crank"] == res.mechanism.crank.radius
        assert set(res.perturbed) == set(res.link_names) | {"crank"}


# -- recompute_metrics ----------------------------------------------------------------------------------
def naive_stance(y, band):
    """Indices of the longest cyclic run of y <= min + band * height (ties: smallest start)."""
    S = len(y)
    q = y <= y.min() + band * (y.max() - y.min())
    if q.all():
        return np.arange(S)
    best = (0, -1)
    for s in range(S):
        if q[s] and not q[s - 1]:
            n = 0
            while q[(s + n) % S]:
                n += 1
            if n > best[0]:
                best = (n, s)
    n, s = best
    return (s + np.arange(n)) % S


def naive_metrics(path, vel, band):
    idx = naive_stance(path[:, 1], band)
    x, y = path[idx, 0], path[idx, 1]
    speed = np.hypot(vel[idx, 0], vel[idx, 1])
    stride = x.max() - x.min()
    return {"width": np.ptp(path[:, 0]), "height": np.ptp(path[:, 1]), "stride": stride,
            "duty": len(idx) / len(path), "flatness": y.std() / stride, "stance_speed": speed.mean(),
            "speed_ripple": speed.std() / speed.mean(), "max_speed": np.hypot(vel[:, 0], vel[:, 1]).max()}


def series_bytes(path) -> dict:
    out = {}
    with h5py.File(path, "r") as f:
        for g in ("paths", "velocities", "variants", "status", "fail_theta", "theta"):
            obj = f[g]
            if isinstance(obj, h5py.Dataset):
                out[g] = obj[...].tobytes()
            else:
                for k in obj:
                    out[f"{g}/{k}"] = obj[k][...].tobytes()
    return out


def test_recompute_with_another_band_matches_numpy(fresh):
    before = series_bytes(fresh)
    with open_results(fresh) as res:
        old = res.frame()
    out = recompute_metrics(fresh, band=0.05)
    assert out["band"] == 0.05 and set(out["metrics"]) == set(METRICS) and out["n_variants"] == 48
    assert series_bytes(fresh) == before  # paths, velocities, lengths, status: not a byte changed
    with open_results(fresh) as res:
        new = res.frame()
        assert res.band == 0.05 and res.metric_names == tuple(METRICS)
        assert all(res.file["metrics"][m].attrs["band"] == 0.05 for m in METRICS)
        assert "metrics_partial" not in res.file
        ok = np.flatnonzero(new["status_code"].to_numpy() == 0)
        for v in ok:
            want = naive_metrics(res.path(int(v)), res.velocity(int(v)), 0.05)
            for m, x in want.items():
                assert new[m].iloc[v] == pytest.approx(x, rel=1e-9, abs=1e-12), (m, v)
    failed = new["status_code"].to_numpy() != 0
    assert new.loc[failed, list(METRICS)].isna().all().all()
    # band-free metrics are unchanged, stance metrics moved
    for m in ("width", "height", "max_speed", "min_transmission_angle"):
        np.testing.assert_array_equal(new[m].to_numpy(), old[m].to_numpy())
    assert (new["duty"].to_numpy()[ok] >= old["duty"].to_numpy()[ok]).all()
    assert (new["duty"].to_numpy()[ok] > old["duty"].to_numpy()[ok]).any()
    # back to the study's band: the original values, bit for bit
    recompute_metrics(fresh, band=0.01)
    with open_results(fresh) as res:
        back = res.frame()
    for m in METRICS:
        np.testing.assert_array_equal(back[m].to_numpy(), old[m].to_numpy())


def test_recompute_subset_keeps_one_band(fresh):
    out = recompute_metrics(fresh, band=0.03, names="stride")
    assert out["metrics"] == ("stride",)
    assert set(out["also"]) == set(STANCE) - {"stride"}
    assert set(out["kept"]) == set(METRICS) - set(STANCE)  # the walker's, the screen's, width, height, max_speed
    with open_results(fresh) as res:
        assert res.metric_names == tuple(METRICS)  # order kept
        assert {m: float(res.file["metrics"][m].attrs["band"]) for m in STANCE} == dict.fromkeys(STANCE, 0.03)
    # same band again: only what is asked for; band=None keeps the file's band
    out = recompute_metrics(fresh, names=["flatness"])
    assert out["band"] == 0.03 and out["also"] == () and out["metrics"] == ("flatness",)


def test_recompute_adds_metrics_to_a_bare_file(tmp_path):
    bare = tmp_path / "bare.h5"
    run_study(study(metrics=False), output=bare, progress=False)
    with_m = tmp_path / "with.h5"
    run_study(study(), output=with_m, progress=False)
    out = recompute_metrics(bare)  # nothing stored: every metric, at the study's band
    assert out["metrics"] == tuple(METRICS) and out["band"] == 0.01
    with open_results(bare) as a, open_results(with_m) as b:
        fa, fb = a.frame(), b.frame()
        for m in METRICS:
            np.testing.assert_array_equal(fa[m].to_numpy(), fb[m].to_numpy())


@pytest.mark.slow
def test_recompute_refusals(fresh, tmp_path):
    # an incomplete file (an interrupted run): finish it first
    inc = tmp_path / "inc.h5"
    shutil.copyfile(fresh, inc)
    with h5py.File(inc, "r+") as f:
        f.attrs["complete"] = False
    from explorer.store import seal
    seal(inc)  # an edit on purpose: the checksums follow it
    before = inc.read_bytes()
    with pytest.raises(UserError, match=r"incomplete results file.*--resume"):
        recompute_metrics(inc, band=0.02)
    assert inc.read_bytes() == before
    # no velocities stored: path metrics need no solve, speed metrics solve the ok variants again (issue 26)
    novel = tmp_path / "novel.h5"
    run_study(study(velocities=False, metrics=["stride", "duty"]), output=novel, progress=False)
    out = recompute_metrics(novel, names="stride,flatness", band=0.02)
    assert out["metrics"] == ("stride", "flatness") and out["resolved"] == 0
    out = recompute_metrics(novel, names="all")
    assert out["resolved"] == out["ok"] > 0
    with open_results(novel) as r:
        assert "velocities" not in r.file and r.frame()["max_speed"].notna().sum() == out["ok"]
    # the foot path not stored
    nofoot = tmp_path / "nofoot.h5"
    run_study(study(vertices=["4"], metrics=False), output=nofoot, progress=False)
    with pytest.raises(UserError, match=r"lacks /paths/7 \(the foot path\).*\[scene\] vertices"):
        recompute_metrics(nofoot)
    with pytest.raises(UserError, match="unknown metric 'strid'"):
        recompute_metrics(fresh, names="strid")
    with pytest.raises(UserError, match=r"band: expected a number in \[0, 1\]"):
        recompute_metrics(fresh, band=1.5)
    with pytest.raises(UserError, match="no such results file"):
        recompute_metrics(tmp_path / "nope.h5")
    junk = tmp_path / "junk.h5"
    junk.write_text("not hdf5")
    with pytest.raises(UserError, match="cannot open"):
        recompute_metrics(junk)
    # open for reading elsewhere: refused, nothing written
    with open_results(fresh):
        with pytest.raises(UserError, match="cannot open the results file for writing"):
            recompute_metrics(fresh, band=0.02)
