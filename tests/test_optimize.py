"""``explorer optimize``: the [optimize] table, objectives and feasibility as documented (checked with
plain pandas and brute-force dominance written here), the designs stored as solved, infeasible designs
never on a front, and kill -9 then --resume equal to an uninterrupted run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from explorer import load_mechanism, open_results
from explorer.errors import UserError
from explorer.gait import compute_metrics
from explorer.kernels import simulate_batch
from explorer.optimize import front_history, run_optimize
from explorer.study import load_study

STUDY = """\
[study]
name = "opt"
mechanism = "jansen"
seed = {seed}
steps = 72

[optimize]
algorithm = "{algorithm}"
population = {population}
generations = {generations}
objectives = {objectives}
constraints = ["clearance >= 1", "`1-3` < 51"]
spread = 0.05
parameters = ["1-3", "2-6", "1-6", "5-7", "crank", "2.x"]

[scene]
velocities = false
"""


def write(tmp_path: Path, name="opt.toml", seed=3, algorithm="nsga2", population=12, generations=4,
          objectives='["travel", "bob"]') -> Path:
    p = tmp_path / name
    p.write_text(STUDY.format(seed=seed, algorithm=algorithm, population=population, generations=generations,
                              objectives=objectives))
    return p


def explorer_cmd(*args) -> list[str]:
    return [sys.executable, "-m", "explorer.cli", *map(str, args)]


def dominates(a, b) -> bool:
    return bool(np.all(a <= b) and np.any(a < b))


@pytest.mark.parametrize("algorithm", ["nsga2", "nsga3"])
def test_objectives_constraints_and_front_as_documented(tmp_path, algorithm):
    study = write(tmp_path, algorithm=algorithm)
    summary = run_optimize(study, output=tmp_path / "o.h5", progress=False)
    with open_results(summary) as res:
        df = res.frame()
        screen_ok = df["buildable"].to_numpy(dtype=bool)
    assert len(df) == 48 and list(df["generation"]) == [g for g in range(4) for _ in range(12)]
    # variant 0 is the nominal (inside the bounds)
    jansen = load_mechanism("jansen")
    assert df.loc[0, "1-3"] == jansen.parameters()["1-3"] and df.loc[0, "2.x"] == jansen.parameters()["2.x"]
    # every design is within its bounds
    nominal = jansen.parameters()
    for p in ("1-3", "2-6", "1-6", "5-7", "crank"):
        assert (df[p] >= 0.95 * nominal[p] - 1e-12).all() and (df[p] <= 1.05 * nominal[p] + 1e-12).all()
    assert (abs(df["2.x"] - nominal["2.x"]) <= 0.05 * jansen.size + 1e-12).all()

    # feasibility, written plainly: ok, numbers, buildable, both constraints
    feasible = ((df["status"].astype(str) == "ok") & df["travel"].notna() & df["bob"].notna() & screen_ok
                & (df["clearance"] >= 1) & (df["1-3"] < 51)).to_numpy()
    assert summary.feasible == int(feasible.sum()) and 0 < summary.feasible < 48
    # the front by brute force: feasible designs no other feasible design dominates (travel max, bob min)
    F = np.column_stack([-df["travel"], df["bob"]])
    idx = np.flatnonzero(feasible)
    front = {int(i) for i in idx if not any(dominates(F[j], F[i]) for j in idx if j != i)}
    assert set(summary.front["variant"]) == front
    assert all(feasible[v] for v in summary.front["variant"])  # infeasible designs never on the front
    # front_history at the last generation is the same front
    hist = front_history(df, load_study(study).optimize, None)
    assert set(hist.loc[hist["upto"] == 3, "variant"]) == front


def test_stored_designs_are_the_solved_designs(tmp_path):
    """The metrics of each row equal an independent solve of the design its parameter columns describe."""
    summary = run_optimize(write(tmp_path), output=tmp_path / "o.h5", progress=False)
    with open_results(summary) as res:
        df = res.frame()
    jansen = load_mechanism("jansen")
    rows = df.iloc[::5]
    lengths = np.array([[row[name] for name in jansen.link_names] for _, row in rows.iterrows()])
    batch = simulate_batch(jansen, lengths, rows["crank"].to_numpy(), 72, geometry={"2.x": rows["2.x"].to_numpy()},
                           velocities=True)
    m = compute_metrics(batch.paths["7"], batch.velocities["7"], batch.status, ["travel", "bob", "clearance"],
                        mechanism=jansen, lengths=lengths, crank=rows["crank"].to_numpy(),
                        geometry={"2.x": rows["2.x"].to_numpy()})
    assert np.array_equal(batch.status, rows["status_code"].to_numpy())
    for name in ("travel", "bob", "clearance"):
        np.testing.assert_allclose(m[name], rows[name].to_numpy(), rtol=1e-9, atol=1e-9, equal_nan=True)


def test_single_objective_algorithms_and_early_stop_accounting(tmp_path):
    for algorithm in ("de", "cmaes"):
        study = write(tmp_path, name=f"{algorithm}.toml", algorithm=algorithm, population=8, generations=3,
                      objectives='["bob"]')
        s = run_optimize(study, output=tmp_path / f"{algorithm}.h5", progress=False)
        with open_results(s) as res:
            df = res.frame()
        assert len(df) == 24
        run = df[df["status"].astype(str) != "not-run"]
        assert s.evaluations == len(run)
        ok = run[(run["status"].astype(str) == "ok") & run["buildable"] & (run["clearance"] >= 1) & (run["1-3"] < 51)]
        assert len(s.front) == 1 and s.front["bob"].iloc[0] == ok["bob"].min()


@pytest.mark.slow
def test_kill_9_then_resume_equals_an_uninterrupted_run(tmp_path):
    study = write(tmp_path, population=16, generations=40)
    out = tmp_path / "killed.h5"
    proc = subprocess.Popen(explorer_cmd("optimize", study, "-o", out, "--quiet"), stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    killed = False
    try:
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline and proc.poll() is None:
            try:
                with h5py.File(out, "r", locking=False) as f:
                    done = int(f["chunks/done"][...].sum())
            except Exception:
                done = 0
            if done >= 2:
                os.kill(proc.pid, signal.SIGKILL)
                proc.wait(timeout=60)
                killed = True
                break
            time.sleep(0.002)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert killed, f"the optimisation finished (rc {proc.returncode}) before it could be killed: {proc.stderr.read()}"
    with h5py.File(out, "r") as f:
        done = f["chunks/done"][...]
        assert done.any() and not done.all()

    r = subprocess.run(explorer_cmd("optimize", study, "-o", out, "--resume"), capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert "resumed here" in r.stdout
    ref = run_optimize(study, output=tmp_path / "ref.h5", progress=False)
    with h5py.File(ref.path, "r") as a, h5py.File(out, "r") as b:
        names = []
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert {"variants/generation", "variants/lengths", "metrics/travel", "status"} <= set(names)
        for n in names:
            assert a[n][...].tobytes() == b[n][...].tobytes(), n


@pytest.mark.slow
def test_resume_refuses_a_changed_study_and_overwrite_needs_force(tmp_path):
    study = write(tmp_path, generations=2)
    out = tmp_path / "o.h5"
    run_optimize(study, output=out, progress=False)
    with pytest.raises(UserError, match="--force"):
        run_optimize(study, output=out, progress=False)
    changed = write(tmp_path, name="changed.toml", seed=4, generations=2)
    with pytest.raises(UserError, match="different run"):
        run_optimize(changed, output=out, resume=True, progress=False)
    before = out.read_bytes()
    r = subprocess.run(explorer_cmd("optimize", changed, "-o", out), capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--force" in r.stderr
    assert out.read_bytes() == before  # nothing already written is lost


@pytest.mark.slow
@pytest.mark.parametrize("edit, key", [
    (('algorithm = "nsga2"', 'algorithm = "pso"'), "optimize.algorithm"),
    (('objectives = ["travel", "bob"]', 'objectives = ["travel", "speed"]'), "optimize.objectives"),
    (('algorithm = "nsga2"', 'algorithm = "de"'), "optimize.objectives"),  # de takes one objective
    (('"2.x"]', '"9.x"]'), "optimize.parameters"),
    (('constraints = ["clearance >= 1", "`1-3` < 51"]', 'constraints = ["__import__(\'os\')"]'),
     "optimize.constraints"),
    (('population = 12', 'population = 2'), "optimize.population"),
    (("[scene]", "[optimize.bounds]\n\"1-3\" = [5, 1]\n\n[scene]"), "optimize.bounds.1-3"),
    (("[scene]", "[perturb]\nspread = 0.1\n\n[scene]"), "perturb"),
])
def test_bad_optimize_tables_are_one_line_errors(tmp_path, edit, key):
    p = write(tmp_path)
    p.write_text(p.read_text().replace(*edit))
    r = subprocess.run(explorer_cmd("optimize", p, "-o", tmp_path / "x.h5"), capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert str(p) in r.stderr and key in r.stderr
    assert not (tmp_path / "x.h5").exists()


def test_run_refuses_an_optimize_study_and_optimize_a_sampled_one(tmp_path):
    with pytest.raises(UserError, match="explorer optimize"):
        from explorer.study import run_study
        run_study(write(tmp_path), output=tmp_path / "x.h5", progress=False)
    with pytest.raises(UserError, match=r"no \[optimize\]"):
        run_optimize("default", output=tmp_path / "y.h5", progress=False)
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "y.h5").exists()


@pytest.mark.slow
def test_rank_show_and_plot_front_work_on_an_optimisation(tmp_path):
    out = tmp_path / "o.h5"
    run_optimize(write(tmp_path), output=out, progress=False)
    for args in (("rank", out, "--pareto", "travel,bob", "--top", "0"), ("show", out, "--variant", "0"),
                 ("plot", out, "--front", "-o", tmp_path / "front.png")):
        r = subprocess.run(explorer_cmd(*args), capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, (args, r.stderr)
    assert (tmp_path / "front.png").stat().st_size > 10_000


def test_the_shipped_example_loads():
    study = load_study(str(Path(__file__).parents[1] / "studies" / "jansen-optimize.toml"))
    opt = study.optimize
    assert opt.algorithm == "nsga2" and opt.objectives == ("travel", "bob", "peak_torque")
    assert opt.directions == ("max", "min", "min") and study.n_variants == opt.population * opt.generations
    assert len(opt.parameters) == 11 and set(("clearance", "foot_headroom")) <= set(study.metrics)


@pytest.mark.slow
def test_path_synthesis_recovers_a_known_fourbar(tmp_path):
    """A target made by a known four-bar (three dimensions moved off the nominal), matched at its crank
    angles: CMA-ES from the nominal recovers the dimensions to 1e-6 and the path to 1e-6."""
    from explorer.kernels import simulate_batch
    fourbar = load_mechanism("fourbar")
    truth = {"rocker": 26.0, "A-P": 24.0, "B0.x": 31.0}
    L = fourbar.lengths.copy()
    names = list(fourbar.link_names)
    L[names.index("rocker")], L[names.index("A-P")] = truth["rocker"], truth["A-P"]
    S = 48
    foot = simulate_batch(fourbar, L[None], None, S, geometry={"B0.x": np.array([truth["B0.x"]])}).paths["P"][0]
    k = np.arange(0, S, 4)
    study = {"study": {"name": "syn", "mechanism": "fourbar", "seed": 1, "steps": S},
             "target": {"points": foot[k].tolist(), "angles_deg": (360.0 * k / S).tolist()},
             "optimize": {"algorithm": "cmaes", "population": 8, "generations": 200, "objectives": ["path_error"],
                          "screen": False,
                          "bounds": {"rocker": [23.0, 28.0], "A-P": [22.0, 27.0], "B0.x": [28.0, 33.0]}},
             "scene": {"vertices": ["P"], "metrics": ["path_error"]}}
    s = run_optimize(study, output=tmp_path / "syn.h5", progress=False)
    best = s.front.iloc[0]
    assert best["path_error"] <= 1e-6
    for p, v in truth.items():
        assert abs(best[p] - v) <= 1e-6, (p, best[p])
    # the stored path_error of the best row is the RMS distance to the target, recomputed here plainly
    with open_results(s) as res:
        P = res.file["paths/P"][int(best["variant"])]
    assert np.sqrt(np.mean(np.sum((P[k] - foot[k]) ** 2, axis=1))) == pytest.approx(best["path_error"], abs=1e-12)
