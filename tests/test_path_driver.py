"""A path-driven mechanism (the built-in two-link arm) through every verb: it runs a study end to end,
and where a notion does not apply (a crank radius, a gait, a walker) the answer is one line."""

from __future__ import annotations

import math

import numpy as np
import pytest

import explorer
from explorer.cli import main
from explorer.errors import UserError

STUDY = {"study": {"name": "arm", "mechanism": "arm", "variants": 12, "seed": 2, "steps": 40},
         "perturb": {"spread": 0.02}, "scene": {"vertices": "all", "metrics": True}}


@pytest.fixture(scope="module")
def arm_results(tmp_path_factory):
    out = tmp_path_factory.mktemp("arm") / "arm.h5"
    explorer.run_study(STUDY, output=out, progress=False)
    return out


def cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_the_arm_runs_a_study_end_to_end(arm_results):
    with explorer.open_results(arm_results) as r:
        df = r.frame()
        assert len(df) == 12 and (df["status"] == "ok").any()
        assert df["crank"].isna().all() and math.isnan(r.nominal["crank"])
        assert r.metric_names == ()  # no gait metric applies to an arm
        # the stored tip path is the prescribed one: the arm's tip on its line, at every ok variant
        mech = r.mechanism
        tip = r.path(0, mech.driven)
        want = explorer.simulate(mech, 40).path(mech.driven)
        np.testing.assert_allclose(tip, want, rtol=0, atol=1e-9)


def test_verbs_on_the_arm(arm_results, capsys, tmp_path):
    code, out, _ = cli(capsys, "show", arm_results, "--variant", "0")
    assert code == 0 and "link upper" in out and "crank" not in out.split("parameter")[1].split("\n\n")[0]
    code, _, err = cli(capsys, "rank", arm_results)
    assert code == 2 and "driven along a path" in err and err.count("\n") == 1
    code, out, _ = cli(capsys, "rank", arm_results, "--by", "iterations", "--ascending")
    assert code == 0 and "not applicable" in out
    code, _, err = cli(capsys, "metrics", arm_results)
    assert code == 2 and "driven along a path" in err
    assert cli(capsys, "plot", arm_results, "--velocity", "--variant", "0", "-o", tmp_path / "v.png")[0] == 0
    code, out, err = cli(capsys, "animate", arm_results, "--variant", "0", "-o", tmp_path / "a.gif", "--cycles", "1",
                         "--frames", "8")
    assert code == 0, err
    code, _, err = cli(capsys, "animate", "--mechanism", "arm", "--legs", "2", "-o", tmp_path / "b.gif")
    assert code == 2 and "needs a crank" in err
    # a failed arm variant fails at a time, in seconds, and is not offered gait metrics
    with explorer.open_results(arm_results) as r:
        df = r.frame()
    failed = df.index[df["status"] != "ok"]
    if len(failed):
        code, out, _ = cli(capsys, "show", arm_results, "--variant", str(int(df.loc[failed[0], "variant"])))
        t = float(df.loc[failed[0], "fail_theta"])
        assert code == 0 and f"at t = {t:.6g} s" in out and "θ" not in out, out
        assert "explorer metrics" not in out and "driven along a path" in out


def test_the_shipped_arm_study_runs_at_360_samples(tmp_path):
    """studies/arm.toml: 360 samples (a fold passed tangentially at t = 4.09 s; it used to end every
    sweep there), base and links varied; a few variants through the CLI, each one the closed form."""
    import tomllib
    from pathlib import Path

    import naive_mech as nm

    d = tomllib.loads((Path(__file__).parent.parent / "studies" / "arm.toml").read_text())
    assert d["study"]["steps"] == 360
    d["study"]["variants"] = 20
    out = tmp_path / "arm.h5"
    explorer.run_study(d, output=out, progress=False)
    with explorer.open_results(out) as r:
        df = r.frame()
        assert (df["status"] == "ok").sum() >= 5 and {"O.x", "O.y"} <= set(df.columns)
        for i in df.index[df["status"] == "ok"][:5]:
            row = df.loc[i]
            tip = r.path(int(row["variant"]), "T") - [row["O.x"], row["O.y"]]
            elbow = r.path(int(row["variant"]), "E") - [row["O.x"], row["O.y"]]
            # the elbow is the two-link inverse kinematics of the tip about the moved base (elbow up)
            ref = nm.two_link_elbow(tip[:, 0], tip[:, 1], row["upper"], row["fore"], +1)
            assert np.max(np.abs(elbow - ref)) < 1e-7


def test_no_crank_to_perturb_and_no_walker():
    with pytest.raises(UserError, match="perturb.crank: mechanism 'arm' is driven along a path"):
        explorer.load_study({**STUDY, "perturb": {"crank": True}})
    with pytest.raises(UserError, match="walker"):
        explorer.load_study({**STUDY, "walker": {"legs": 2}})
    arm = explorer.load_mechanism("arm")
    z = np.zeros((1, 10, 2))
    with pytest.raises(UserError, match="driven along a path"):
        explorer.gait.compute_metrics(z, z, [0], ["stride"], mechanism=arm)


def test_stored_samples_of_a_path_are_times(arm_results):
    """/theta of a path-driven study holds the sample times t_k = T·k/(S−1) in seconds (it held crank
    angles 2πk/S)."""
    with explorer.open_results(arm_results) as r:
        S = r.steps
        np.testing.assert_allclose(r.file["theta"][...], 10.0 * np.arange(S) / (S - 1), rtol=0, atol=1e-12)
        assert r.file["theta"].attrs["units"] == "s"


def test_velocity_plot_of_a_path_is_against_time(arm_results):
    """plot --velocity of the arm: rates per second against time, finite differences over the sample
    times (they used crank-angle spacing and wrapped around, 86 units off a 0.56 peak)."""
    import re

    import matplotlib
    matplotlib.use("Agg")
    from explorer.view import plot_velocity

    fig = plot_velocity(explorer.open_results(arm_results), 0)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "" and fig.axes[1].get_xlabel() == "time t [s]"
    err, peak = map(float, re.search(r"= ([-\d.e+]+), peak \|dx/dt\| = ([-\d.e+]+)", ax.get_title()).groups())
    assert err < 0.02 * peak, ax.get_title()
