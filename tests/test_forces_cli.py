"""The forces effect from the front door: a study with [scene] forces, what it stores, show, plot, metrics, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np
import pytest

import explorer
from explorer.cli import main

REPO = Path(__file__).resolve().parents[1]
MECH = REPO / "studies" / "mechanisms" / "jansen-plywood.toml"

STUDY = f"""\
[study]
name = "f"
mechanism = "{MECH.as_posix()}"
variants = 24
seed = 3
steps = 72

[perturb]
spread = 0.02

[scene]
metrics = ["travel", "peak_torque"]
forces = true
force_joints = ["1", "2"]

[walker]
drag = 0.1

[operating]
rpm = 40
"""


@pytest.fixture(scope="module")
def forces_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("forces")
    study = d / "f.toml"
    study.write_text(STUDY)
    out = d / "f.h5"
    assert main(["run", str(study), "-o", str(out)]) == 0
    return out


def test_the_file_holds_torque_reactions_and_si_metrics(forces_file):
    with h5py.File(forces_file) as f:
        N, S = f["status"].shape[0], f["theta"].shape[0]
        assert f["torque"].shape == (N, S) and f["torque"].attrs["units"] == "N·m"
        assert sorted(f["forces"]) == ["1", "2"] and f["forces/2"].shape == (N, S, 2)
        for name in explorer.gait.FORCE_METRICS:
            assert name in f["metrics"], name
        assert f["metrics/motor_torque_peak"].attrs["units"] == "N·m"
        assert f["metrics/pin_force.2"].attrs["units"] == "N"
        ok = f["status"][...] == 0
        assert ok.sum() > 10
        tau = f["torque"][...]
        assert np.isfinite(tau[ok]).all() and np.isnan(tau[~ok]).all()
        # the stored metrics are the stored series' own figures (a plain re-derivation)
        np.testing.assert_allclose(f["metrics/motor_torque_peak"][ok], np.abs(tau[ok]).max(axis=1), rtol=1e-12)
        w = 40 * 2 * math.pi / 60
        np.testing.assert_allclose(f["metrics/energy_per_turn"][ok],
                                   np.maximum(tau[ok], 0).sum(axis=1) * 2 * math.pi / S, rtol=1e-12)
        np.testing.assert_allclose(f["metrics/motor_power_peak"][ok], tau[ok].max(axis=1) * w, rtol=1e-12)
        F2 = f["forces/2"][...]
        assert np.all(np.hypot(F2[ok, :, 0], F2[ok, :, 1]).max(axis=1) <= f["metrics/pin_force.2"][ok] * (1 + 1e-12))
    # the nominal (variant 0) is what simulate() gives for the same build and operating point
    c = explorer.simulate(explorer.load_mechanism(MECH), S, forces=True,
                          walker=explorer.mechanism.Walker(legs=4, mirrored=(False, True, False, True), drag=0.1),
                          operating={"rpm": 40})
    with h5py.File(forces_file) as f:
        np.testing.assert_allclose(f["torque"][0], c.torque, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(f["forces/1"][0], c.force("1"), rtol=1e-9, atol=1e-9)


def test_show_prints_si_figures(forces_file, capsys):
    assert main(["show", str(forces_file), "--variant", "0"]) == 0
    out = capsys.readouterr().out
    for text in ("motor_torque_peak", "N·m", "flywheel_inertia", "kg·m²", "pin_force.2", "rpm = 40"):
        assert text in out, text


def test_show_says_the_force_model_the_machine_and_the_flywheel(forces_file, capsys):
    with h5py.File(forces_file) as f:
        assert f.attrs["body"] == "moving"
    assert main(["show", str(forces_file), "--variant", "0"]) == 0
    out = capsys.readouterr().out
    assert 'force model: body = "moving"' in out
    assert "machine mass" in out and "flywheel_inertia_motor" in out
    assert "the flywheel belongs on the motor side of the gearbox" in out


def test_rank_units_si_puts_the_motor_peak_beside_the_quasi_static_one(forces_file, capsys):
    assert main(["rank", str(forces_file), "--units", "si", "--top", "3"]) == 0
    out = capsys.readouterr().out
    head = next(line for line in out.splitlines() if line.split()[:2] == ["rank", "variant"])
    assert head.index("peak_torque[N·m]") < head.index("motor_torque_peak[N·m]")
    assert "peak_torque is the walker metric, quasi-static" in out and "size the motor from motor_torque_peak" in out


def test_a_file_made_before_the_moving_body_reads_as_held(forces_file, tmp_path, capsys):
    """A forces file without the root attribute ``body`` and with no ``body`` in its stored [operating]
    was computed with the frame held: show says so, and a lean re-solve would use it."""
    import json

    from explorer.store import open_results
    from explorer.testing import stamp
    old = tmp_path / "old.h5"
    old.write_bytes(forces_file.read_bytes())
    with h5py.File(old, "r+") as f:
        del f.attrs["body"]
        study = json.loads(f.attrs["study_resolved"])
        del study["operating"]["body"], study["operating"]["gear_ratio"]
        f.attrs["study_resolved"] = json.dumps(study)
        stamp(f)
    with open_results(old) as res:
        assert res.body == "held" and res.operating.body == "held"
    assert main(["show", str(old), "--variant", "0"]) == 0
    assert 'force model: body = "held"' in capsys.readouterr().out


def test_plot_forces_draws_torque_and_reactions(forces_file, tmp_path):
    png = tmp_path / "forces.png"
    assert main(["plot", str(forces_file), "--forces", "--variant", "0", "-o", str(png)]) == 0
    import matplotlib.image as mpimg
    img = mpimg.imread(png)
    assert img.shape[0] > 500 and img.shape[1] > 500
    ink = (img[..., :3].mean(axis=2) < 0.6).mean()  # the curves, axes and text: not a blank page
    assert 0.01 < ink < 0.5


def test_recomputing_gait_metrics_keeps_the_force_metrics(forces_file, tmp_path):
    copy = tmp_path / "copy.h5"
    copy.write_bytes(forces_file.read_bytes())
    with h5py.File(copy) as f:
        before = f["metrics/motor_torque_peak"][...]
    assert main(["metrics", str(copy), "--band", "0.02"]) == 0
    with h5py.File(copy) as f:
        np.testing.assert_array_equal(f["metrics/motor_torque_peak"][...], before)


@pytest.mark.parametrize("edit, key", [
    (lambda s: s.replace("rpm = 40", "rpm = 0"), "operating.rpm"),
    (lambda s: s.replace("rpm = 40", "rpm = 40\nload = -1"), "operating.load"),
    (lambda s: s.replace("rpm = 40", "rpm = 40\ngear_ratio = 0"), "operating.gear_ratio"),
    (lambda s: s.replace("rpm = 40", "rpm = 40\ngear_ratio = nan"), "operating.gear_ratio"),
    (lambda s: s.replace("rpm = 40", "rpm = 40\ngear_ratio = -inf"), "operating.gear_ratio"),
    (lambda s: s.replace("rpm = 40", 'rpm = 40\nbody = "floating"'), "operating.body"),
    (lambda s: s.replace(f'mechanism = "{MECH.as_posix()}"', 'mechanism = "jansen"'), "operating.unit"),
    (lambda s: s.replace('force_joints = ["1", "2"]', 'force_joints = ["9"]'), "scene.force_joints"),
])
def test_bad_operating_input_is_one_line_exit_2(tmp_path, capsys, edit, key):
    study = tmp_path / "bad.toml"
    study.write_text(edit(STUDY))
    out = tmp_path / "bad.h5"
    assert main(["run", str(study), "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and key in err and str(study) in err
    assert not out.exists()


def test_a_build_round_trips_through_its_toml():
    """Masses, centroids, inertias, the link density and [operating] survive mechanism_toml (what export
    --format toml writes): the design a builder exports is the one whose forces were computed."""
    import tomllib

    from explorer.mechanism import mechanism_from_dict, mechanism_toml
    d = tomllib.loads((REPO / "explorer" / "mechanism" / "builtin" / "klann.toml").read_text())
    d["bodies"][0].update(mass=0.3, centroid=[5.0, 0.5], inertia=0.002)
    d["bodies"][1]["mass"] = 0.45
    d["crank"]["mass"] = 0.1
    d["links"][0]["mass"] = 0.05
    d["mass"] = {"link_density": 0.2}
    d["operating"] = {"unit": 0.01, "rpm": 20.0, "load": 3.0, "body": "held", "gear_ratio": 25.0}
    m = mechanism_from_dict(d, "klann-built")
    back = mechanism_from_dict(tomllib.loads(mechanism_toml(m)), "klann-built")
    assert back == m
    assert back.bodies[0].centroid == (5.0, 0.5) and back.operating.load == 3.0 and back.link_density == 0.2
    assert back.operating.body == "held" and back.operating.gear_ratio == 25.0



OPTIMIZE = f"""\
[study]
name = "fo"
mechanism = "{MECH.as_posix()}"
seed = 7
steps = 36
[optimize]
algorithm = "nsga2"
population = 8
generations = 2
objectives = ["travel", "motor_torque_peak"]
constraints = ["pin_force_max <= 500"]
spread = 0.03
parameters = ["1-3", "crank"]
[scene]
vertices = ["7"]
velocities = false
forces = true
[walker]
drag = 0.1
"""


def test_a_search_on_force_metrics(tmp_path, capsys):
    """explorer optimize takes force metrics as objectives and constraints (the one chunk runner computes
    them with the solve), and says in one line when the study has no forces to give them."""
    study = tmp_path / "fo.toml"
    study.write_text(OPTIMIZE)
    out = tmp_path / "fo.h5"
    assert main(["optimize", str(study), "-o", str(out)]) == 0
    with h5py.File(out) as f:
        ok = f["status"][...] == 0
        tau = f["torque"][...]
        assert ok.sum() > 4
        np.testing.assert_allclose(f["metrics/motor_torque_peak"][ok], np.abs(tau[ok]).max(axis=1), rtol=1e-12)
    capsys.readouterr()
    study.write_text(OPTIMIZE.replace("forces = true", "forces = false"))
    assert main(["optimize", str(study), "-o", str(tmp_path / "no.h5")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "motor_torque_peak" in err and "forces = true" in err
