"""Which dimensions matter (issue 18): ``explorer sensitivity`` and ``explorer tolerance``.

How the indices are checked. Every synthetic model goes through the same code path as a study: a real
study (Jansen's leg, four links perturbed) is run into an HDF5 results file, then its ``/metrics/travel``
dataset is overwritten (plain h5py) with a function of the *stored* sampled lengths whose indices are
known in closed form, and the file is analysed by ``explorer.analysis.sensitivity(path)`` and by the
``explorer sensitivity`` command. The references are written here from the closed forms:

* the Ishigami function (a = 7, b = 0.1) of the first three parameters rescaled to [−π, π]; the fourth is
  a dummy: V1 = ½(1 + bπ⁴/5)², V2 = a²/8, V13 = 8b²π⁸/225, V = a²/8 + bπ⁴/5 + b²π⁸/18 + ½, S1 = (V1, V2,
  0, 0)/V ≈ (0.314, 0.442, 0, 0), ST = (V1 + V13, V2, V13, 0)/V ≈ (0.558, 0.442, 0.244, 0);
* a linear model Y = Σ a_i x_i of x_i uniform on [−1, 1]: S_i = a_i² / Σ a_j².

Sobol indices (a saltelli study) and RBD-FAST's S1 (a uniform and an LHS study) must recover them within
SALib's own interval. delta and PAWN have no closed form for these models (they depend on the whole
distribution of Y), so for them the test checks the ranking (the larger coefficient, the larger index;
the dummy last). The tolerance summary's shares and quantiles are checked against a direct count with
pandas; a study run in small chunks, in one chunk and on Dask (an in-process cluster) gives identical
indices; the bisection of ``explorer tolerance`` is checked against a direct count of a study at its
answer.
"""

from __future__ import annotations

import io
import json
import math

import h5py
import numpy as np
import pandas as pd
import pytest

from explorer import open_results, run_study
from explorer.cli import main
from explorer.analysis import sensitivity, tolerance, tolerance_summary
from explorer.study import Sampler, load_study

P = ["1-3", "3-4", "2-3", "5-7"]  # four links; the synthetic models use the first three
SPREAD = 0.01                      # at ±1 % on these links every variant turns


def synthetic_study(method: str, variants: int) -> dict:
    return {"study": {"name": "synthetic", "mechanism": "jansen", "variants": variants, "seed": 5, "steps": 24},
            "perturb": {"method": method, "spread": SPREAD, "parameters": P},
            "scene": {"metrics": ["travel"]}}


def replace_travel(path, model) -> np.ndarray:
    """Overwrite /metrics/travel with model(x), x (N, 4) the stored lengths mapped back to [−1, 1]."""
    with open_results(path) as r:
        df, nominal = r.frame(), r.nominal
    assert (df["status"] == "ok").all()
    x = np.stack([(df[p].to_numpy() / nominal[p] - 1.0) / SPREAD for p in P], axis=1)
    assert np.abs(x).max() <= 1.0 + 1e-9 and np.abs(x[1:]).min() > 0.0
    y = model(x)
    with h5py.File(path, "r+") as f:
        f["metrics/travel"][...] = y
    from explorer.store import seal
    seal(path)  # an edit on purpose: the checksums follow it
    return y


A, B = 7.0, 0.1


def ishigami(x):
    z = math.pi * x
    return np.sin(z[:, 0]) + A * np.sin(z[:, 1]) ** 2 + B * z[:, 2] ** 4 * np.sin(z[:, 0])


def ishigami_indices():
    pi = math.pi
    V1 = 0.5 * (1 + B * pi ** 4 / 5) ** 2
    V2 = A ** 2 / 8
    V13 = 8 * B ** 2 * pi ** 8 / 225
    V = A ** 2 / 8 + B * pi ** 4 / 5 + B ** 2 * pi ** 8 / 18 + 0.5
    return np.array([V1, V2, 0.0, 0.0]) / V, np.array([V1 + V13, V2, V13, 0.0]) / V


COEF = np.array([1.0, 2.0, 3.0, 0.0])


def linear(x):
    return x @ COEF


def index_of(ind: pd.DataFrame, output: str, index: str):
    sel = ind[(ind["output"] == output) & (ind["index"] == index)].set_index("parameter").reindex(P)
    return sel["value"].to_numpy(), sel["conf"].to_numpy()


# -- fixtures ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def saltelli_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("sens") / "saltelli.h5"
    run_study(synthetic_study("saltelli", 1024), output=path, progress=False)
    replace_travel(path, ishigami)
    return path


@pytest.fixture(scope="module")
def uniform_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("sens") / "uniform.h5"
    run_study(synthetic_study("uniform", 4001), output=path, progress=False)
    replace_travel(path, linear)
    return path


#: Jansen at ±3 %: about a third fails to turn, and the screen removes some of the rest.
LEG = {"study": {"name": "leg", "mechanism": "jansen", "variants": 500, "seed": 2, "steps": 36},
       "perturb": {"method": "uniform", "spread": 0.03},
       "scene": {"metrics": True}}


@pytest.fixture(scope="module")
def leg_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("sens") / "leg.h5"
    run_study(LEG, output=path, progress=False)
    return path


# -- the Saltelli design -------------------------------------------------------------------------------
def test_saltelli_sampler_is_salib_design_after_the_nominal():
    from SALib.sample import sobol as salib_sobol
    n, k, spread, seed = 16, 3, 0.05, 4
    s = Sampler("saltelli", n, k, spread, seed)
    rows = s.rows()
    assert rows.shape == (1 + n * (k + 2), k) and s.n_total == 1 + n * (k + 2)
    assert np.array_equal(rows[0], np.ones(k))  # variant 0: the nominal, exactly
    problem = {"num_vars": k, "names": ["a", "b", "c"], "bounds": [[-1.0, 1.0]] * k}
    ref = salib_sobol.sample(problem, n, calc_second_order=False, scramble=True, seed=seed)
    assert np.array_equal(rows[1:], 1.0 + spread * ref)
    # Saltelli's structure: per base point A, AB_1 … AB_k (A with column i from B), B
    blocks = rows[1:].reshape(n, k + 2, k)
    for i in range(k):
        assert np.array_equal(np.delete(blocks[:, 1 + i], i, axis=1), np.delete(blocks[:, 0], i, axis=1))
        assert np.array_equal(blocks[:, 1 + i, i], blocks[:, k + 1, i])
    # any range of variants is the same rows (chunks, resume, Dask shards)
    pieces = [Sampler("saltelli", n, k, spread, seed).rows(a, b) for a, b in ((0, 1), (1, 9), (9, 40), (40, 81))]
    assert np.array_equal(np.concatenate(pieces), rows)


def test_saltelli_study_counts_and_default():
    s = load_study({"study": {"name": "x", "mechanism": "jansen", "variants": 64},
                    "perturb": {"method": "saltelli", "parameters": P}})
    assert s.n_parameters == 4 and s.n_variants == 1 + 64 * (4 + 2)
    s = load_study({"study": {"name": "x", "mechanism": "jansen"}, "perturb": {"method": "saltelli"}})
    assert s.variants == 1024 and s.n_variants == 1 + 1024 * (11 + 2)


# -- closed forms through a results file ---------------------------------------------------------------
def test_sobol_indices_of_ishigami(saltelli_file):
    S1, ST = ishigami_indices()
    assert np.allclose(S1[:2], [0.3139, 0.4424], atol=1e-4) and np.allclose(ST[:3], [0.5576, 0.4424, 0.2437], atol=1e-4)
    ind = sensitivity(saltelli_file, metrics=["travel"])  # a saltelli study: Sobol by default
    assert ind.attrs["method"] == "sobol" and ind.attrs["samples"] == 1024 * 6
    for index, ref in (("S1", S1), ("ST", ST)):
        value, conf = index_of(ind, "travel", index)
        assert np.all(np.abs(value - ref) <= conf + 1e-12), (index, value, conf, ref)
        assert np.all(conf[:3] < 0.1)  # and the intervals are informative
    travel = ind[ind["output"] == "travel"]
    assert (travel["n"] == 1024 * 6).all() and (travel["kind"] == "metric").all()


def test_rbd_fast_of_a_linear_model_uniform_and_lhs(uniform_file, tmp_path):
    ref = COEF ** 2 / (COEF ** 2).sum()
    ind = sensitivity(uniform_file, metrics="travel")
    assert ind.attrs["method"] == "rbd-fast"
    value, conf = index_of(ind, "travel", "S1")
    assert np.all(np.abs(value - ref) <= conf), (value, conf, ref)
    assert (ind.loc[ind["output"] == "travel", "n"] == 4000).all()  # variant 0 is no sample
    # an LHS design, and Ishigami under RBD-FAST (first-order only)
    lhs = tmp_path / "lhs.h5"
    run_study(synthetic_study("lhs", 4001), output=lhs, progress=False)
    replace_travel(lhs, ishigami)
    value, conf = index_of(sensitivity(lhs, metrics=["travel"], failures=False), "travel", "S1")
    S1, _ = ishigami_indices()
    assert np.all(np.abs(value - S1) <= conf), (value, conf, S1)


@pytest.mark.slow
def test_delta_and_pawn_rank_a_linear_model(uniform_file):
    for method, indices in (("delta", ("delta", "S1")), ("pawn", ("pawn",))):
        ind = sensitivity(uniform_file, metrics=["travel"], method=method, resamples=4, failures=False)
        assert tuple(dict.fromkeys(ind["index"])) == indices
        for index in indices:
            value, conf = index_of(ind, "travel", index)
            assert list(np.argsort(-value)) == [2, 1, 0, 3], (method, index, value)
            assert np.isfinite(conf).all() and (conf > 0).all()


@pytest.mark.slow
def test_failed_variants_are_dropped_from_metric_indices(leg_file):
    with open_results(leg_file) as r:
        df = r.frame()
    ind = sensitivity(leg_file, metrics=["travel", "bob"])
    used = int(df["travel"].iloc[1:].notna().sum())
    assert used < 499
    assert (ind.loc[ind["output"] == "travel", "n"] == used).all()
    assert (ind.loc[ind["output"] == "fails", "n"] == 499).all()
    # the failure outcomes: one per (status, vertex) that occurs
    failed = df.iloc[1:][df["status"].iloc[1:] != "ok"]
    kinds = {f"fails:{s}@{v}" for s, v in zip(failed["status"].astype(str), failed["fail_vertex"])}
    assert kinds <= set(ind["output"]) and kinds
    # the default failure driver is the lower loop's link 1-6 (the Grashof margin)
    fails = ind[(ind["output"] == "fails") & (ind["index"] == "S1")].sort_values("value", ascending=False)
    assert fails["parameter"].iloc[0] in ("1-6", "2-6")


# -- the tolerance summary against a direct count ---------------------------------------------------------
@pytest.mark.slow
def test_tolerance_summary_counts(leg_file):
    summary = tolerance_summary(leg_file, metrics=["travel", "bob"])
    with open_results(leg_file) as r:
        df = r.frame()
    rows = df.iloc[1:]  # variant 0 is the nominal, no sample
    s = summary.set_index("item")
    n = len(rows)
    ok = int((rows["status"].astype(str) == "ok").sum())
    assert (s.loc["assembles", "count"], s.loc["assembles", "n"]) == (ok, n)
    assert s.loc["assembles", "share"] == pytest.approx(ok / n)
    assert s.loc["assembles", "se"] == pytest.approx(math.sqrt(ok / n * (1 - ok / n) / n))
    assert s.loc["buildable", "count"] == int(rows["buildable"].sum())
    failed = rows[rows["status"].astype(str) != "ok"]
    for (status, vertex), count in failed.groupby([failed["status"].astype(str), failed["fail_vertex"]]).size().items():
        assert s.loc[f"fails:{status}@{vertex}", "count"] == count
    turning = rows[rows["status"].astype(str) == "ok"]
    toggles = int(turning["screen"].str.contains("toggle:").sum())
    if toggles:
        assert (s.loc["screened:toggle", "count"], s.loc["screened:toggle", "n"]) == (toggles, len(turning))
    for m in ("travel", "bob"):
        q = rows[m].quantile([0.05, 0.5, 0.95])
        assert s.loc[m, ["p5", "median", "p95"]].tolist() == pytest.approx(q.tolist(), rel=1e-12)
        assert s.loc[m, "nominal"] == df[m].iloc[0]
        assert s.loc[m, "count"] == rows[m].notna().sum()
    assert s.loc["assembles", "drivers"]  # somebody drives the failures


# -- identical whatever the chunking or the runner ------------------------------------------------------
def test_identical_in_chunks_in_one_chunk_and_on_dask(tmp_path):
    study = {"study": {"name": "chunks", "mechanism": "jansen", "variants": 32, "seed": 3, "steps": 24},
             "perturb": {"method": "saltelli", "spread": 0.03}, "scene": {"metrics": ["travel", "bob"]}}
    one = run_study(study, output=tmp_path / "one.h5", progress=False)
    small = run_study(study, output=tmp_path / "small.h5", progress=False, chunk_size=7)
    a = sensitivity(one, metrics="all")
    b = sensitivity(small, metrics="all")
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    assert a["value"].notna().any()
    pd.testing.assert_frame_equal(tolerance_summary(one, indices=a), tolerance_summary(small, indices=b),
                                  check_exact=True)
    import logging

    import distributed  # in the [test] extras: required here, never skipped
    from explorer.study import run_study_dask
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None,
                                  silence_logs=logging.CRITICAL) as cluster, distributed.Client(cluster) as client:
        dask = run_study_dask(client, study, output=tmp_path / "dask.h5", shard_size=100, progress=False)
    pd.testing.assert_frame_equal(a, sensitivity(dask, metrics="all"), check_exact=True)


# -- the command -------------------------------------------------------------------------------------------
def run_cli(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_csv_goes_through_the_same_function(uniform_file, capsys):
    code, out, err = run_cli(["sensitivity", uniform_file, "--metrics", "travel", "--format", "csv"], capsys)
    assert code == 0, err
    table = pd.read_csv(io.StringIO(out))
    ref = COEF ** 2 / (COEF ** 2).sum()
    s1 = table[(table["output"] == "travel") & (table["index"] == "S1")].set_index("parameter").reindex(P)
    assert np.all(np.abs(s1["value"].to_numpy() - ref) <= s1["conf"].to_numpy())
    api = sensitivity(uniform_file, metrics=["travel"])
    assert np.array_equal(table["value"].to_numpy(), api["value"].to_numpy(), equal_nan=True)


@pytest.mark.slow
def test_cli_table_json_summary_and_plot(leg_file, saltelli_file, tmp_path, capsys):
    code, out, err = run_cli(["sensitivity", leg_file, "--metrics", "travel"], capsys)
    assert code == 0, err
    assert "tolerance summary" in out and "assembles over a full turn" in out and "cannot assemble" in out
    assert "first-order index S1 by RBD-FAST" in out and "travel" in out
    code, out, err = run_cli(["sensitivity", leg_file, "--metrics", "travel", "--format", "json"], capsys)
    assert code == 0, err
    records = json.loads(out)
    assert {r["output"] for r in records} >= {"fails", "travel"}
    assert set(records[0]) >= {"output", "parameter", "index", "value", "conf", "low", "high", "n", "method"}
    code, out, err = run_cli(["sensitivity", leg_file, "--metrics", "none", "--summary", "--format", "json"], capsys)
    assert code == 0, err
    items = {r["item"]: r for r in json.loads(out)}
    assert items["assembles"]["n"] == 499 and 0 < items["assembles"]["share"] < 1
    code, out, err = run_cli(["sensitivity", leg_file, "--metrics", "travel", "--summary", "--format", "csv"], capsys)
    assert code == 0, err
    assert list(pd.read_csv(io.StringIO(out))["item"])[0] == "assembles"
    png = tmp_path / "indices.png"
    code, out, err = run_cli(["sensitivity", saltelli_file, "--metrics", "travel", "-o", png, "--format", "csv"],
                             capsys)
    assert code == 0, err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert str(png) in err  # csv stays clean on stdout
    assert {"S1", "ST"} == set(pd.read_csv(io.StringIO(out))["index"])


@pytest.fixture(scope="module")
def oat_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("sens") / "oat.h5"
    run_study({"study": {"name": "oat", "mechanism": "jansen", "variants": 2, "steps": 24},
               "perturb": {"method": "oat", "spread": 0.01}}, output=path, progress=False)
    return path


@pytest.mark.parametrize("argv, message", [
    (["sensitivity", "{missing}"], "no such results file"),
    (["sensitivity", "{leg}", "--metrics", "stride_length"], "--metrics: unknown or not stored metric 'stride_length'"),
    (["sensitivity", "{leg}", "--method", "sobol"], "--method sobol needs a study sampled with perturb.method"),
    (["sensitivity", "{leg}", "--method", "morris"], "--method: expected one of rbd-fast, delta, pawn, sobol"),
    (["sensitivity", "{oat}"], "perturb.method = 'oat'"),
    (["sensitivity", "{leg}", "--format", "xml"], "--format: expected one of table, csv, json"),
    (["sensitivity", "{leg}", "--resamples", "1"], "--resamples: expected a whole number >= 2"),
    (["sensitivity", "{leg}", "-o", "{tmp}/p.gif"], "unknown output extension"),
    (["tolerance", "jansen", "--target", "1.5"], "--target: expected a share in (0, 1)"),
    (["tolerance", "nosuchleg"], "nosuchleg: no mechanism file or built-in"),
    (["tolerance", "jansen", "--parameters", "9-9", "--variants", "20"], "unknown design parameter '9-9'"),
])
def test_errors_exit_2_with_one_line(argv, message, leg_file, oat_file, tmp_path, capsys):
    argv = [a.format(missing=tmp_path / "nope.h5", leg=leg_file, oat=oat_file, tmp=tmp_path) for a in argv]
    code, out, err = run_cli(argv, capsys)
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("explorer: error: "), err
    assert message in err, err
    assert "Traceback" not in err


# -- explorer tolerance -------------------------------------------------------------------------------------
def test_tolerance_bisection(tmp_path):
    seen = []
    res = tolerance("jansen", target=0.9, spread=0.02, variants=201, steps=36, rtol=0.1, seed=4,
                    progress=seen.append)
    lo, hi = res.bracket
    assert 0 < lo < hi <= lo * 1.1 + 1e-15 and res.spread == lo
    assert len(seen) == len(res.evaluations) >= 3
    assert res.share >= 0.9 and res.n == 200 and res.se == pytest.approx(math.sqrt(res.share * (1 - res.share) / 200))
    at = {e["spread"]: e for e in res.evaluations}
    assert at[hi]["share"] < 0.9 <= at[lo]["share"]
    # monotone sense: on the same draws a tighter spread leaves more legs that turn
    shares = [at[s]["share"] for s in sorted(at)]
    assert all(a >= b for a, b in zip(shares, shares[1:])), shares
    # the answer against a direct count of the same study
    # (by default every design parameter is cut: the links, the crank, its centre and the pivots)
    path = run_study({"study": {"name": "check", "mechanism": "jansen", "variants": 201, "seed": 4, "steps": 36},
                      "perturb": {"method": "uniform", "spread": lo, "parameters": "all"}},
                     output=tmp_path / "check.h5", progress=False)
    with open_results(path) as r:
        rows = r.frame().iloc[1:]
    assert int((rows["status"].astype(str) == "ok").sum()) == res.count


def test_tolerance_cli_json_and_table(capsys):
    argv = ["tolerance", "jansen", "--target", "0.9", "--variants", "101", "--steps", "36", "--rtol", "0.2",
            "--parameters", "1-6,2-6,crank"]
    code, out, err = run_cli(argv + ["--format", "json"], capsys)
    assert code == 0, err
    d = json.loads(out)
    lo, hi = d["bracket"]
    assert d["parameters"] == ["2-6", "1-6", "crank"] and lo < hi and d["share"] >= 0.9
    code, out, err = run_cli(argv, capsys)
    assert code == 0, err
    assert "answer: cut to ±" in out and "bracket" in out and "binomial standard error" in out


@pytest.mark.parametrize("argv", [["--help"], ["sensitivity", "--help"], ["tolerance", "--help"]])
def test_help_renders(argv, capsys):
    """argparse %-formats help texts: a bare "99 %" in one of them used to crash `explorer --help`."""
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert "sensitivity" in out or "tolerance" in out
