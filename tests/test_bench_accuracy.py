"""Smoke tests of ``explorer bench accuracy`` on tiny sizes, and checks of its references and seed solvers."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

import explorer
from explorer import UserError, simulate, simulate_batch
from explorer.bench import accuracy_sweep, closed_form_reference, format_table, plot, write_csv
from explorer.testing import bench_seeds as _seeds
from explorer.testing import COLUMNS, draw_variants
from explorer.cli import main

MECH = explorer.load_mechanism("jansen")


@pytest.fixture(scope="module")
def tiny_report():
    return accuracy_sweep(MECH, variants=24, tolerances=(1e-6, 1e-10), steps=(36, 90), dense_variants=6,
                          seed_variants=5, seed_steps=(36,), reference_steps=720, repeat=1)


def test_reference_matches_the_kernel_closed_form_and_finite_differences():
    L, r = draw_variants(MECH, 12, 0.02, seed=3)
    p, v, ok = closed_form_reference(MECH, L, r, 90)
    closed = simulate_batch(MECH, L, r, 90, method="closed", velocities=False)
    np.testing.assert_array_equal(ok, closed.status == 0)
    np.testing.assert_allclose(p[ok], closed.paths["7"][ok], rtol=0, atol=1e-11)
    assert np.isnan(p[~ok]).any(axis=(1, 2)).all()
    # velocities: the chain rule against the kernels' eq. 29-30 solve and against central differences
    i = int(np.flatnonzero(ok)[0])
    mech = MECH.with_lengths(dict(zip(MECH.link_names, L[i])), crank=r[i])
    c = simulate(mech, 90, tolerance=1e-12, velocities=True)
    assert c.ok
    np.testing.assert_allclose(v[i], c.velocity("7"), rtol=0, atol=1e-7)
    fine, _, _ = closed_form_reference(MECH, L[i:i + 1], r[i:i + 1], 90 * 1000)
    k = np.arange(90) * 1000
    fd = (fine[0, k + 1] - fine[0, (k - 1) % (90 * 1000)]) / (2 * 2 * np.pi / (90 * 1000))
    np.testing.assert_allclose(v[i], fd, rtol=0, atol=1e-4)


@pytest.mark.slow
def test_sweep_rows_and_honest_errors(tiny_report):
    rep = tiny_report
    assert rep.meta["variants_drawn"] == 24 and 0 < rep.meta["variants_assembled"] <= 24
    kinds = {r["method"] for r in rep.rows}
    assert {"block", "auto", "dense", "closed", *(_seeds.SOLVERS)} <= kinds
    # 2 steps x (closed + 2 tolerances x 3 tolerance-bound methods) + 4 seed solvers x 2 tolerances at 36 steps
    assert len(rep.rows) == 2 * (1 + 2 * 3) + 4 * 2
    for r in rep.rows:
        assert set(COLUMNS) <= set(r)
        assert r["time_s"] > 0 and r["us_per_config"] > 0
        assert r["silent"] == 0
    closed = [r for r in rep.rows if r["method"] == "closed"]
    assert all(r["foot_err_max"] == 0.0 for r in closed)
    # coarse sampling costs metric accuracy even for the exact closed form
    assert closed[0]["stride_err_median"] >= closed[1]["stride_err_median"]
    tight = [r for r in rep.rows if r["method"] in ("block", "dense") and r["tolerance"] == 1e-10]
    assert all(r["failed"] == 0 and r["foot_err_max"] < 1e-6 for r in tight)
    assert all(r["iterations"] > 0 for r in tight)
    # auto: the vectorised closed-form pass solves these ±2 % designs with fewer Newton iterations (it flags
    # some at 36 steps, where a 10° step fails its move limit or gap bound) and the same verdicts
    auto = [r for r in rep.rows if r["method"] == "auto"]
    block = {(r["steps"], r["tolerance"]): r for r in rep.rows if r["method"] == "block"}
    assert auto and all(r["failed"] == block[r["steps"], r["tolerance"]]["failed"] for r in auto)
    assert all(r["iterations"] < block[r["steps"], r["tolerance"]]["iterations"] for r in auto)
    # the promise, per Newton row: every foot within tolerance x its design's longest link of the truth
    newton = [r for r in rep.rows if r["method"] in ("block", "dense", "auto")]
    for r in newton:
        # the bound of the longest design in the row (the dense rows run on a subset)
        assert 0.9 * r["tolerance"] * rep.meta["longest_link_max"] < r["foot_err_bound"]
        assert r["foot_err_bound"] <= r["tolerance"] * rep.meta["longest_link_max"]
        assert 0.0 <= r["promise_used"] <= 1.0, r
        assert r["foot_err_max"] <= r["foot_err_bound"]
    assert all(math.isnan(r["promise_used"]) for r in rep.rows if r["method"] not in ("block", "dense", "auto"))
    dense = [r for r in rep.rows if r["method"] == "dense"]
    assert all(r["variants"] == 6 and "first 6 variants" in r["note"] for r in dense)
    ge = [r for r in rep.rows if r["method"] == "seed001-full-GE" and r["tolerance"] == 1e-10]
    assert ge[0]["failed"] == 0 and ge[0]["foot_err_max"] < 1e-6
    seq = [r for r in rep.rows if r["method"] == "seed001-sequential" and r["tolerance"] == 1e-10]
    assert seq[0]["failed"] == 0 and seq[0]["foot_err_max"] < 1e-6
    # Gauss-Seidel straight on J meets a zero diagonal entry: the row must say that nothing converged
    gsj = [r for r in rep.rows if r["method"] == "seed003-GS(J)"]
    assert all(r["ok"] == 0 and "NOTHING CONVERGED" in r["note"] and math.isnan(r["foot_err_max"]) for r in gsj)


@pytest.mark.slow
def test_table_csv_and_plot(tiny_report, tmp_path):
    text = format_table(tiny_report)
    assert "seed001-sequential" in text and "NOTHING CONVERGED" in text and "foot err" in text
    path = write_csv(tiny_report, tmp_path / "a.csv")
    with path.open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == len(tiny_report.rows) and tuple(rows[0]) == COLUMNS
    png = plot(tiny_report, tmp_path / "a.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # read back: every number as written (NaN where it does not apply), the picture drawn again from it
    from explorer.bench import read_csv
    back = read_csv(path, {"mechanism": "jansen"})
    assert len(back.rows) == len(tiny_report.rows)
    for mine, theirs in zip(back.rows, tiny_report.rows):
        for k in COLUMNS:
            a, b = mine[k], theirs.get(k, "")
            if isinstance(a, float) and math.isnan(a):
                assert b in ("", None) or (isinstance(b, float) and math.isnan(b)), (k, b)
            else:
                assert a == b, (k, a, b)
    assert back.meta["variants_assembled"] == max(r["variants"] for r in tiny_report.rows)
    assert plot(back, tmp_path / "b.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_cli_bench_accuracy(tmp_path, capsys):
    code = main(["bench", "accuracy", "--variants", "10", "--tolerances", "1e-6", "--steps", "36",
                 "--dense-variants", "3", "--seed-rows", "seed001-full-GE", "--seed-variants", "3",
                 "--seed-steps", "36", "--reference-steps", "360", "--repeat", "1", "-q", "-o", str(tmp_path)])
    assert code == 0
    out = capsys.readouterr().out
    assert "block" in out and "seed001-full-GE" in out
    assert (tmp_path / "accuracy.csv").exists() and (tmp_path / "accuracy.png").exists()


def test_cli_rejects_bad_arguments(tmp_path, capsys):
    assert main(["bench", "accuracy", "--seed-rows", "nope", "-o", str(tmp_path)]) == 2
    assert "unknown nope" in capsys.readouterr().err
    assert main(["bench", "accuracy", "--tolerances", "2", "--variants", "3", "-q", "-o", str(tmp_path)]) == 2
    with pytest.raises(UserError):
        accuracy_sweep(MECH, variants=3, steps=(2,))


@pytest.mark.parametrize("solver", ["seed001-full-GE", "seed001-sequential"])
def test_seed_solvers_reproduce_every_joint(solver):
    L, r = draw_variants(MECH, 6, 0.02, seed=5)
    P, v, st, fth, its = _seeds.solve_seed(solver, MECH, L, r, 72, tolerance=1e-12, velocities=True)
    closed = simulate_batch(MECH, L, r, 72, method="closed", velocities=False, vertices="all")
    for i in range(len(r)):
        if closed.status[i] != 0:
            assert st[i] != 0  # the seeds cannot solve what cannot be assembled either
            continue
        assert st[i] == 0 and its[i] > 0
        for v_name in MECH.vertices:
            np.testing.assert_allclose(P[i, :, MECH.vertex_index(v_name)], closed.paths[v_name][i], rtol=0,
                                       atol=1e-8)
        assert np.isfinite(v[i]).all()


def test_linear_solvers():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(8, 8)) + 8 * np.eye(8)
    b = rng.normal(size=8)
    x = np.empty(8)
    assert _seeds.gauss_elim(A.copy(), b.copy(), x)
    np.testing.assert_allclose(A @ x, b, atol=1e-12)
    y = np.empty(8)
    assert _seeds.gauss_seidel(A, b, y, 1e-14, 1000) > 0  # diagonally dominant: converges
    np.testing.assert_allclose(y, x, atol=1e-10)
    A[3, 3] = 0.0
    assert _seeds.gauss_seidel(A, b, y, 1e-14, 1000) == -1  # a zero diagonal: cannot even start
    assert not _seeds.gauss_elim(np.zeros((8, 8)), b.copy(), x)


def test_seed_layout_is_jansen_only():
    assert _seeds.jansen_layout(MECH) is not None
    assert _seeds.jansen_layout(explorer.load_mechanism("fourbar")) is None
