"""`explorer physics`: the MuJoCo check of a shortlist (explorer.physics).

References written plainly here: the kinematic walker of the nominal Jansen leg from the closed form
(circle-circle intersections, ``naive.jansen_closed_form``, and the plain walker ``naive_walker``), the
machine's mass as a sum of link lengths × density, each leg's foot at the start from the closed form.
MuJoCo runs are slow (``@pytest.mark.slow``) but for one small case in the quick loop (one measured turn).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")  # the physics extra (tests/test_extras.py: the message without it)

import naive  # noqa: E402
import naive_walker as nw  # noqa: E402
from clihelp import cli  # noqa: E402
from test_report import _wait, browser  # noqa: E402,F401 - the suite's one headless-browser fixture
from explorer import load_mechanism, open_results, simulate  # noqa: E402
from explorer.cli import main  # noqa: E402
from explorer.mechanism import Operating, Walker  # noqa: E402
from explorer.physics import PHYSICS_METRICS, Settings, build_model, physics_check, run_model  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
MECH = REPO / "studies" / "mechanisms" / "jansen-plywood.toml"
UNIT = 0.01          # jansen-plywood: centimetres
LOAD = 8.0           # kg, the body
DENSITY = 0.1836     # kg/m, its [mass] link_density
CRANK_MASS = 0.05    # kg, its crank arm
OPERATING = Operating(unit=UNIT, rpm=30, load=LOAD)
FOUR = Walker(4, (), (False, True, False, True), 0.1)
EIGHT = Walker(8, (), tuple(j % 2 == 1 for j in range(8)), 0.1)

STUDY = f"""\
[study]
name = "phys"
mechanism = "{MECH.as_posix()}"
variants = 12
seed = 1              # 11 ok, 1 failed (assembly)
steps = 72

[perturb]
spread = 0.02

[scene]
vertices = ["7"]
velocities = true
metrics = true
forces = true

[walker]
legs = 4
mirrored = true
drag = 0.1

[operating]
rpm = 30
"""


# -- independent references ------------------------------------------------------------------------------
def closed_form_foot():
    """The nominal Jansen foot at any crank angle: positions and central-difference velocities (model units)."""
    def pos(theta):
        P, ok, _ = naive.jansen_closed_form(naive.JANSEN_LENGTHS, naive.JANSEN_CRANK, np.atleast_1d(theta))
        return P[:, 6]

    def foot(theta):
        theta = np.asarray(theta, dtype=float)
        return pos(theta), naive.central_difference(pos, theta, 1e-5)
    return foot


def kinematic(walker) -> tuple[float, float]:
    """The kinematic walker's travel (m/turn) and bob (m) of the nominal, from the closed form."""
    Y, VX, VY = nw.legs_at(closed_form_foot(), 360, walker.phases, walker.mirrored)
    ref = nw.naive_walker(Y, VX, VY, naive.JANSEN_CRANK, walker.drag, walker.contact)
    return ref["travel"] * UNIT, ref["bob"] * UNIT


@pytest.fixture(scope="module")
def nominal():
    mech = load_mechanism(MECH)
    cyc = simulate(mech, 360, velocities=True)
    assert cyc.ok
    return mech, cyc


def run(nominal, walker, **kw):
    mech, cyc = nominal
    model = build_model(mech, cyc.positions, cyc.velocities, walker, OPERATING, Settings(**kw))
    travel, _ = kinematic(walker)
    return model, run_model(model, 360, travel)


# -- the model ---------------------------------------------------------------------------------------------
def test_model_at_the_start_is_the_assembled_walker(nominal):
    """Compiled by MuJoCo: its mass is the plain sum, every loop is closed, each leg's foot is where the
    closed form puts it (mirrored legs mirrored), and the lowest foot is planted (zero velocity)."""
    mech, cyc = nominal
    model = build_model(mech, cyc.positions, cyc.velocities, FOUR, OPERATING, Settings())
    m = mujoco.MjModel.from_xml_string(model.xml)
    d = mujoco.MjData(m)
    d.qvel[:] = model.qvel0
    mujoco.mj_forward(m, d)
    leg_mass = sum(DENSITY * L * UNIT for L in naive.JANSEN_LENGTHS) + CRANK_MASS
    assert m.body_mass.sum() == pytest.approx(LOAD + 4 * leg_mass, rel=1e-12)
    assert model.massless == 0
    assert d.ne > 0 and np.abs(d.efc_pos[:d.ne]).max() < 1e-12  # the connect constraints hold at qpos0
    foot = closed_form_foot()
    sites = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"foot{j}") for j in range(4)]
    got = np.array([d.site_xpos[s][[0, 2]] for s in sites])  # (x, z) in metres
    want = []
    for phi, mirrored in zip(FOUR.phases, FOUR.mirrored):
        if mirrored:  # the mirror image about x = 0 (the crank centre) of the leg at π − φ
            p = foot(np.array([math.pi - phi]))[0][0]
            want.append([-p[0], p[1]])
        else:
            want.append(foot(np.array([phi]))[0][0])
    want = np.array(want) * UNIT
    assert np.abs((got - got[0]) - (want - want[0])).max() < 1e-9
    low = int(np.argmin(want[:, 1]))
    assert got[low, 1] == pytest.approx(Settings().foot_radius * naive.JANSEN_CRANK * UNIT, abs=1e-12)
    v = np.zeros(6)
    body = m.site_bodyid[sites[low]]
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_SITE, sites[low], v, 0)
    omega = OPERATING.omega
    assert np.abs(v[3:]).max() < 1e-9 * omega * naive.JANSEN_CRANK * UNIT, (body, v)


def test_nominal_one_turn_walks_like_the_kinematic_walker(nominal):
    """The quick loop's case: one measured turn, pitch held: travel within 2 %, bob within 10 %, one
    loaded foot at every sample."""
    model, out = run(nominal, FOUR, turns=1)
    travel, bob = kinematic(FOUR)
    assert out["physics_travel"] == pytest.approx(travel, rel=0.02)
    assert out["physics_bob"] == pytest.approx(bob, rel=0.10)
    assert out["physics_pitch"] == 0.0
    assert (out["series"]["loaded"] == 1).all() and out["physics_loaded_feet_max"] == 1
    assert out["physics_travel_diff"] == pytest.approx(100 * (out["physics_travel"] - travel) / travel, rel=1e-12)


@pytest.mark.slow
def test_nominal_three_turns_pitch_held(nominal):
    """The issue's check: travel within 2 %, bob within 10 %, one loaded foot at every sample; the torque is
    positive work on average (the motor drives the drag) and within the CPU budget (3 s for 4 legs, 3 turns)."""
    model, out = run(nominal, FOUR)
    travel, bob = kinematic(FOUR)
    assert out["physics_travel"] == pytest.approx(travel, rel=0.02)
    assert out["physics_bob"] == pytest.approx(bob, rel=0.10)
    assert (out["series"]["loaded"] == 1).all() and out["physics_loaded_feet_max"] == 1
    tau = out["series"]["torque"]
    # the motor's mean power at least drives the drag (8 kg × g × 0.1) over the travel
    drag_work = 0.1 * LOAD * 9.81 * out["physics_travel"]
    assert tau.mean() * 2 * math.pi >= 0.9 * drag_work
    assert out["physics_torque_peak"] == pytest.approx(np.abs(tau).max()) and out["physics_torque_peak"] > 0
    assert out["cpu_s"] < 3.0
    # the check of the forces effect: the phase-averaged servo torque's peak within 10 % of the
    # moving-body model's motor torque peak (the walker's body accelerating with the contact foot)
    moving = simulate(nominal[0], 360, forces=True, walker=FOUR,
                      operating={"unit": UNIT, "rpm": 30, "load": LOAD, "body": "moving"})
    assert out["physics_torque_peak"] == pytest.approx(moving.force_metrics["motor_torque_peak"], rel=0.10)


@pytest.mark.slow
def test_eight_legs_share_the_ground_and_fight(nominal):
    """Eight legs with the body free to pitch: two feet loaded at once and friction work, far more than
    four legs with the pitch held lose in their feet."""
    _, eight = run(nominal, EIGHT, pitch="free", turns=1)  # one turn measures what three do (3.32 J/turn both)
    _, four = run(nominal, FOUR, turns=1)
    assert eight["physics_loaded_feet_max"] == 2
    assert eight["physics_friction_work"] > 0
    assert eight["physics_friction_work"] > 100 * four["physics_friction_work"]


@pytest.mark.slow
def test_four_legs_rock_when_free_to_pitch(nominal):
    _, out = run(nominal, FOUR, pitch="free", turns=1)
    assert out["physics_pitch"] > 0.02  # rad: it rocks from foot to foot
    assert out["physics_bob"] > 5 * kinematic(FOUR)[1]


# -- the verb and the results file ---------------------------------------------------------------------------
@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("physics")
    study = d / "phys.toml"
    study.write_text(STUDY)
    out = d / "phys.h5"
    assert main(["run", str(study), "-o", str(out)]) == 0
    return out


@pytest.fixture
def results(study_file, tmp_path):
    p = tmp_path / "r.h5"
    p.write_bytes(study_file.read_bytes())
    return p


def stored(path):
    with h5py.File(path) as f:
        return json.loads(f["metrics/physics_travel"].attrs["physics"])


def sha(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.mark.slow
def test_physics_verb_stores_the_group_that_rank_show_and_frame_see(results, capsys):
    code, out, err = cli(capsys, "physics", results, "--top", "2", "--workers", "2")
    assert code == 0, err
    with open_results(results) as res:  # verifies: the file's checksums were kept
        df = res.frame()
        top = [int(v) for v in res.rank(top=2)["variant"]]
    for m in PHYSICS_METRICS:
        assert m in df.columns
        assert np.isfinite(df.loc[top, m]).all(), m
        assert df[m].drop(index=top).isna().all(), m  # designs not checked: NaN
    assert stored(results)["checked"] == {str(v): "ok" for v in top}
    assert "checked 2 designs" in out and "CPU-s" in out
    for v in top:
        assert f"\n{v:>7} " in out or f" {v} " in out
    code, out, _ = cli(capsys, "show", results, "--variant", top[0])
    assert code == 0 and "physics check (MuJoCo" in out and "kinematic" in out
    assert "agrees with the kinematic walker" in out or "disagrees:" in out
    other = next(v for v in range(len(df)) if v not in top)
    code, out, _ = cli(capsys, "show", results, "--variant", other)
    assert "this design was not checked" in out and "(not checked: `explorer physics`)" in out
    code, out, _ = cli(capsys, "rank", results, "--by", "physics_travel", "--top", "3")
    assert code == 0 and "physics_travel: 2 of the" in out
    # `explorer metrics` keeps them (they are not its to compute)
    before = df[list(PHYSICS_METRICS)].to_numpy()
    code, out, err = cli(capsys, "metrics", results)
    assert code == 0, err
    with open_results(results) as res:
        np.testing.assert_array_equal(res.frame()[list(PHYSICS_METRICS)].to_numpy(), before)
    assert not list(results.parent.glob(".*.partial"))


@pytest.mark.slow
def test_checks_add_up_and_other_settings_need_force(results, capsys):
    assert cli(capsys, "physics", results, "--variant", "0", "--turns", "1", "-q")[0] == 0
    assert cli(capsys, "physics", results, "--variant", "1", "--turns", "1", "-q")[0] == 0
    assert stored(results)["checked"] == {"0": "ok", "1": "ok"}
    before = sha(results)
    code, out, err = cli(capsys, "physics", results, "--variant", "2", "--turns", "2")
    assert code == 2 and err.count("\n") == 1 and "pass --force" in err and "2 designs" in err, err
    assert sha(results) == before  # refused: the file as it was
    assert cli(capsys, "physics", results, "--variant", "2", "--turns", "2", "--force", "-q")[0] == 0
    assert stored(results)["checked"] == {"2": "ok"}
    with open_results(results) as res:
        df = res.frame()
    assert df["physics_travel"].notna().sum() == 1 and math.isfinite(df.at[2, "physics_travel"])


@pytest.mark.slow
def test_an_interrupt_keeps_the_designs_checked(results):
    seen = []

    def stop(v, out, why):
        seen.append(v)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt, match="kept the physics figures of 1 design checked"):
        physics_check(results, variants=[0, 1, 3], turns=1, workers=1, on_result=stop)
    assert stored(results)["checked"] == {str(seen[0]): "ok"}
    with open_results(results) as res:
        assert res.frame()["physics_travel"].notna().sum() == 1


@pytest.mark.slow
def test_ctrl_c_in_the_command_stops_the_workers_and_keeps_the_file(results):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen([sys.executable, "-m", "explorer.cli", "physics", str(results), "--variant",
                             *map(str, range(8)), "--workers", "2", "--turns", "30"], cwd=REPO, env=env,
                            stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    lock = results.with_name(f".{results.name}.lock")
    t0 = time.time()
    while not lock.exists() and time.time() - t0 < 120:
        time.sleep(0.1)
    # the designs' models are built, the workers start (and may have checked a design): 30 turns make the
    # whole check take ~20 s on an idle machine (4 s with the default 3), so the signal comes while it runs
    time.sleep(4.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, (out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    # whether a design was done by then depends on the machine's load: either way the message says what the
    # file holds (test_an_interrupt_keeps_the_designs_checked interrupts after one, deterministically)
    if "before any design was checked" in err:
        assert err.startswith(f"explorer: {results}: interrupted before any design was checked; the file is as "
                              f"it was"), err
        kept = 0
    else:
        assert err.startswith(f"explorer: {results}: interrupted: kept the physics figures of "), err
        kept = int(err.split("figures of ")[1].split()[0])
    with open_results(results) as res:  # verifies
        n = int(res.frame()["physics_travel"].notna().sum()) if "physics_travel" in res.metric_names else 0
    assert n == kept
    assert not list(results.parent.glob(".*.partial"))


@pytest.mark.slow
def test_ctrl_c_while_the_table_prints_says_the_figures_are_written(results, capsys, monkeypatch):
    """A Ctrl-C after the check has written its figures (while the table is drawn) says so, not a bare
    "interrupted" that leaves the user guessing what the file holds."""
    from explorer.testing import cli_physics as verb

    def stopped(out):
        raise KeyboardInterrupt

    monkeypatch.setattr(verb, "summary_lines", stopped)
    code, out, err = cli(capsys, "physics", results, "--variant", 0, "--turns", "1", "--workers", "1")
    assert code == 130
    assert err == (f"explorer: {results}: interrupted while printing the table, after the check: the physics "
                   f"figures of 1 design are written\n"), err
    with open_results(results) as res:
        assert int(res.frame()["physics_travel"].notna().sum()) == 1


# -- bad input ---------------------------------------------------------------------------------------------
def one_line(capsys, *args, expect: str, code: int = 2):
    got, out, err = cli(capsys, *args)
    assert got == code, (got, out, err)
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert expect in err, err
    return err


@pytest.mark.slow
def test_failed_variants_are_skipped_and_counted(results, capsys):
    with open_results(results) as res:
        df = res.frame()
    failed = [int(v) for v in df.loc[df["status"] != "ok", "variant"]]
    assert failed  # the study's seed makes one
    code, out, err = cli(capsys, "physics", results, "--variant", failed[0], 0, "--turns", "1")
    assert code == 0, err
    assert f"skipped variant {failed[0]}: failed (" in out and "1 skipped" in out


@pytest.mark.slow
def test_where_checks_the_top_of_the_designs_the_filter_keeps(results, capsys):
    """--where (rank's filter language) narrows the ranking physics takes its top N from, as `explorer rank
    --where` does: the design checked is the top of the default ranking of the rows a plain pandas mask keeps
    (travel strictly below, or above, the unfiltered top design's)."""
    with open_results(results) as res:
        df = res.frame()
        ranked = res.rank(top=None, frame=df)
        travel = ranked["travel"].to_numpy()
        cut = float(travel[0])  # the top design's: the filter leaves it out
        op = "<" if (travel < cut).any() else ">"
        kept = df[df["travel"] < cut] if op == "<" else df[df["travel"] > cut]
        expected = int(res.rank(top=1, frame=kept)["variant"].iloc[0])
    assert expected != int(ranked["variant"].iloc[0])
    code, out, err = cli(capsys, "physics", results, "--where", f"travel {op} {cut!r}", "--top", "1", "--turns", "1",
                         "--workers", "1")
    assert code == 0, err
    assert stored(results)["checked"] == {str(expected): "ok"}
    assert f"top 1 where travel {op} {cut!r}" in out
    before = sha(results)
    one_line(capsys, "physics", results, "--where", "travel > 0", "--variant", "1",
             expect="--where and --variant: give one")
    one_line(capsys, "physics", results, "--where", "no_such_metric > 1", expect="no_such_metric")
    assert sha(results) == before


@pytest.mark.slow
def test_refusals_in_one_line(results, capsys, tmp_path):
    before = sha(results)
    one_line(capsys, "physics", results, "--turns", "0", expect="--turns: expected a whole number >= 1")
    one_line(capsys, "physics", results, "--pitch", "wobbly", expect="--pitch: expected one of held, free")
    one_line(capsys, "physics", results, "--top", "2", "--variant", "1", expect="--top and --variant: give one")
    one_line(capsys, "physics", results, "--variant", "99999", expect="out of range")
    one_line(capsys, "physics", tmp_path / "absent.h5", expect="no such results file")
    assert sha(results) == before
    # a path-driven mechanism, a foot on a slider, no operating point, no body mass
    for mech, extra, expect in [
        ("arm", "", "driven along a path"),
        ("slidercrank", "", "runs on the ground slider"),
        ("jansen", "", "needs the study's [operating] unit"),
        (MECH.as_posix(), "[operating]\nload = 0\n", "needs the body's mass: [operating] load"),
    ]:
        study = tmp_path / f"{Path(mech).stem}.toml"
        study.write_text(f'[study]\nname = "x"\nmechanism = "{mech}"\nvariants = 2\nseed = 1\nsteps = 24\n'
                         f'[perturb]\nspread = 0.01\n{extra}')
        out = tmp_path / f"{Path(mech).stem}.h5"
        assert main(["run", str(study), "-o", str(out), "-q"]) == 0
        one_line(capsys, "physics", out, "--variant", "0", expect=expect)


@pytest.mark.slow
def test_a_full_disk_leaves_the_file_as_it_was(results, monkeypatch):
    import errno

    from explorer.errors import UserError
    from explorer.testing import store_write
    monkeypatch.setattr(store_write, "_fallocate", lambda *a, **k: errno.ENOSPC)  # no room to reserve
    before = sha(results)
    with pytest.raises(UserError, match="the disk is full: updating the file needs up to .* unchanged"):
        physics_check(results, variants=[0], turns=1, workers=1)
    assert sha(results) == before and not list(results.parent.glob(".*.partial"))



@pytest.mark.slow
def test_report_lists_the_checked_designs_in_a_browser(results, tmp_path, capsys, browser):  # noqa: F811
    """The report in headless Chromium: a panel of the checked designs holding their stored figures, and the
    parallel coordinates keep every design's line (a physics axis, NaN off the shortlist, would drop them)."""
    assert cli(capsys, "physics", results, "--variant", "0", "2", "--turns", "1", "-q")[0] == 0
    page = tmp_path / "r.html"
    assert main(["report", str(results), "-o", str(page)]) == 0
    with open_results(results) as res:
        df = res.frame()
    drv = browser
    drv.get(page.as_uri())
    assert _wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
    assert not [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
    rows = drv.execute_script("return Array.from(document.querySelectorAll('#physics tr.physics')).map("
                              "function (tr) { return Array.from(tr.cells).map(function (c) { return c.textContent; "
                              "}); });")
    assert [int(r[0]) for r in rows] == [0, 2]
    for r in rows:
        v = int(r[0])
        assert float(r[1]) == pytest.approx(df.at[v, "physics_travel"], abs=5e-5)
        assert float(r[2]) == pytest.approx(df.at[v, "travel"] * UNIT, abs=5e-5)
        assert float(r[4]) == pytest.approx(df.at[v, "physics_bob"] * 1e3, abs=5e-4)
        assert r[-1].startswith(("agrees", "disagrees"))
    labels = drv.execute_script("return document.getElementById('parcoords').data[0].dimensions.map("
                                "function (d) { return d.label; });")
    assert labels and not [x for x in labels if x.startswith("physics")]


@pytest.mark.slow
def test_ctrl_c_while_the_worker_pool_starts_stops_every_worker(monkeypatch):
    """A Ctrl-C that lands while the physics check's worker pool is being made (deterministically: sent from
    inside the pool's constructor) is held until the pool exists, then stops it: the interrupt is raised,
    the pool is terminated and none of its workers lives on (raised inside the constructor, it used to
    leave a worker being started that printed a traceback after the command's one line)."""
    import multiprocessing.context as mpc

    from explorer.testing import run_physics_jobs

    made = []
    original = mpc.BaseContext.Pool

    def pool_with_a_ctrl_c(self, *args, **kwargs):
        os.kill(os.getpid(), signal.SIGINT)  # lands here, while the pool is made
        time.sleep(0.05)
        made.append(original(self, *args, **kwargs))
        return made[-1]

    monkeypatch.setattr(mpc.BaseContext, "Pool", pool_with_a_ctrl_c)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # Python's Ctrl-C, whatever the runner set
    try:
        with pytest.raises(KeyboardInterrupt):
            run_physics_jobs([0, 1], 2, lambda *got: pytest.fail("no design may run"), False)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert len(made) == 1, "the pool was not made (the interrupt cut its constructor)"
    pool = made[0]
    workers = list(pool._pool)
    assert len(workers) == 2
    assert not any(w.is_alive() for w in workers)
