"""The defects issue 26 found on the way, each checked on the behaviour it fixes.

* ``explorer tolerance`` cuts every design parameter by default (links, crank, pivots, body points),
  ``--parameters links`` the links and the crank radius only, and its errors name the mechanism file;
* an optimisation's results file works with every verb that reads results (rank, plot --top,
  metrics, the commands in ``studies/jansen-optimize.toml``'s header);
* ``explorer sensitivity`` refuses results whose variants are no sample;
* ``rank --by iterations`` on the path-driven arm;
* one output policy for every writing verb (missing folders created, no overwrite without --force);
* every foot's path in an animation, and axis labels with the README's [unit] brackets.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from explorer.cli import main
from explorer.analysis import tolerance

ROOT = Path(__file__).resolve().parents[1]


def cli(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def one_line_error(code, err, *fragments):
    assert code == 2, err
    assert err.startswith("explorer: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    for f in fragments:
        assert str(f) in err, (f, err)


# -- 1. explorer tolerance ------------------------------------------------------------------------------
KW = dict(target=0.9, spread=0.02, variants=41, steps=36, rtol=0.25, seed=2, criterion="buildable")


@pytest.fixture(scope="module")
def klann_default():
    return tolerance("klann", **KW)


def test_tolerance_cuts_every_design_parameter_by_default(klann_default):
    from explorer import load_mechanism
    names = set(klann_default.parameters)
    # links, the crank, the pivots and the body points: every design parameter of the leg
    assert {"leg.37.x", "9.x", "crank", "lower_rocker", "connecting_rod.27.y"} <= names
    assert names == set(load_mechanism("klann").parameters())


def test_tolerance_links_only_is_looser_than_every_parameter(klann_default):
    links = tolerance("klann", parameters="links", **KW)
    assert set(links.parameters) == {"lower_rocker", "upper_rocker", "crank"}
    # the holes in the bodies and the frame matter: cutting them too leaves a tighter tolerance
    assert klann_default.spread < links.spread


def test_tolerance_cli_says_what_it_cuts(capsys):
    argv = ["tolerance", "klann", "--target", "0.9", "--variants", "21", "--steps", "24", "--rtol", "0.5"]
    code, out, err = cli(capsys, *argv)
    assert code == 0, err
    assert "every design parameter (links, crank, pivots, body points)" in out
    line = next(x for x in out.splitlines() if x.startswith("parameters cut to the spread"))
    assert "leg.37.x" in line and "9.x" in line
    code, out, err = cli(capsys, *argv, "--parameters", "links")
    assert code == 0, err
    line = next(x for x in out.splitlines() if x.startswith("parameters cut to the spread"))
    assert "leg.37.x" not in line and "lower_rocker" in line


def test_tolerance_errors_name_the_mechanism_file(tmp_path, capsys):
    text = (ROOT / "explorer" / "mechanism" / "builtin" / "klann.toml").read_text()
    assert "length = 3.59" in text
    bad = tmp_path / "stretched.toml"
    bad.write_text(text.replace("length = 3.59", "length = 30.59"))  # the lower rocker cannot reach
    code, out, err = cli(capsys, "tolerance", bad, "--variants", "20", "--steps", "24")
    one_line_error(code, err, str(bad), "cannot be assembled")
    assert "<dict>" not in err
    code, out, err = cli(capsys, "tolerance", "jansen", "--parameters", "1-3,leg.37.x", "--variants", "20")
    one_line_error(code, err, "jansen", "leg.37.x")
    assert "<dict>" not in err


# -- 2. an optimisation's results with every verb that reads results ----------------------------------------
def header_commands(path: Path) -> list[list[str]]:
    """The `explorer ...` command lines of a study file's header comment, as argv lists (trailing comments cut)."""
    import shlex
    out = []
    for line in path.read_text().splitlines():
        if not line.startswith("#"):
            break
        text = line.lstrip("#").strip()
        if text.startswith("explorer "):
            out.append(shlex.split(text.split("  #")[0])[1:])
    return out


def small_optimize_study(text: str) -> str:
    """The shipped study with a budget for a test (16 designs x 2 generations, 72 steps)."""
    import re
    for key, value in (("population", 16), ("generations", 2), ("steps", 72)):
        text, n = re.subn(rf"(?m)^{key} = \d+", f"{key} = {value}", text)
        assert n == 1, key
    return text


def test_optimize_header_commands_run(tmp_path, monkeypatch, capsys):
    """Every command of studies/jansen-optimize.toml's header runs (on a small budget), and the file
    then works with rank, plot --top and metrics."""
    pytest.importorskip("pymoo")
    shipped = ROOT / "studies" / "jansen-optimize.toml"
    commands = header_commands(shipped)
    verbs = [c[0] for c in commands]
    assert verbs[0] == "optimize" and {"rank", "metrics", "plot"} <= set(verbs), commands
    (tmp_path / "studies").mkdir()
    (tmp_path / "studies" / "jansen-optimize.toml").write_text(small_optimize_study(shipped.read_text()))
    monkeypatch.chdir(tmp_path)
    outputs: dict[str, list[str]] = {}
    for argv in commands:
        code, out, err = cli(capsys, *argv)
        assert code == 0, (argv, err)
        outputs.setdefault(argv[0], []).append(out)
    assert (tmp_path / "results" / "jansen-optimize.h5").is_file()
    # the default rank before `explorer metrics` ranks without body_speed_ripple and says so; after, with it
    before = [o for o in outputs["rank"] if "walker score" in o]
    assert before and "ranked without body_speed_ripple" in before[0]
    code, out, err = cli(capsys, "rank", "results/jansen-optimize.h5")
    assert code == 0, err
    assert "ranked without" not in out and "body_speed_ripple" in out.splitlines()[0]


@pytest.fixture(scope="module")
def opt_file(tmp_path_factory):
    """A small run of studies/jansen-optimize.toml."""
    pytest.importorskip("pymoo")
    from explorer.optimize import run_optimize
    folder = tmp_path_factory.mktemp("opt")
    study = folder / "opt.toml"
    study.write_text(small_optimize_study((ROOT / "studies" / "jansen-optimize.toml").read_text()))
    out = folder / "opt.h5"
    run_optimize(str(study), output=out, progress=False)
    return out


def test_default_rank_and_plot_top_of_an_optimisation(opt_file, tmp_path, capsys):
    from explorer import open_results
    out = opt_file
    with open_results(out) as r:
        assert "body_speed_ripple" not in r.metric_names  # what broke the default ranking
        weights, missing = r.default_weights()
        ranked = r.rank(top=None)
    assert missing == ["body_speed_ripple"] and "body_speed_ripple" not in weights and len(weights) >= 3
    assert ranked["score"].notna().all() and ranked["score"].is_monotonic_decreasing and len(ranked) > 3
    code, text, err = cli(capsys, "rank", out)
    assert code == 0, err
    assert "ranked without body_speed_ripple: not stored" in text
    code, text, err = cli(capsys, "plot", out, "--top", "3", "-o", tmp_path / "p.png")
    assert code == 0, err
    assert (tmp_path / "p.png").stat().st_size > 1000


def test_metrics_solves_the_velocities_a_file_lacks(tmp_path, capsys):
    """body_speed_ripple of a file run without velocities, through `explorer metrics`, equals the value a
    run that stored them computed (the same designs, solved again)."""
    import numpy as np

    from explorer import open_results, run_study
    base = {"study": {"name": "v", "mechanism": "jansen", "variants": 30, "seed": 3, "steps": 72},
            "perturb": {"method": "uniform", "spread": 0.03}}
    without = run_study({**base, "scene": {"velocities": False, "metrics": ["travel", "bob"]}},
                        output=tmp_path / "without.h5", progress=False)
    with_vel = run_study({**base, "scene": {"velocities": True, "metrics": ["travel", "bob", "body_speed_ripple"]}},
                         output=tmp_path / "with.h5", progress=False)
    code, out, err = cli(capsys, "metrics", without.path, "--metrics", "body_speed_ripple")
    assert code == 0, err
    assert "solved the foot velocities of" in out
    with open_results(without.path) as a, open_results(with_vel.path) as b:
        assert "velocities" not in a.file  # nothing written but /metrics
        got, want = a.frame()["body_speed_ripple"].to_numpy(), b.frame()["body_speed_ripple"].to_numpy()
    assert np.isfinite(want).sum() > 10
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12, equal_nan=True)


# -- 3. sensitivity needs a sample ----------------------------------------------------------------------------
def test_sensitivity_refuses_an_optimisation(opt_file, capsys):
    pytest.importorskip("SALib")
    for extra in ([], ["--summary"]):
        code, out, err = cli(capsys, "sensitivity", opt_file, *extra)
        one_line_error(code, err, str(opt_file), "optimisation", "not a sample")
        assert "uniform sample" not in err and out == ""


def test_sensitivity_refuses_a_file_that_names_no_sampling(tmp_path, capsys):
    """A results file whose study says nothing of how its variants were chosen is not taken for a sample."""
    pytest.importorskip("SALib")
    import json

    import h5py

    from explorer import run_study
    path = run_study({"study": {"name": "s", "mechanism": "jansen", "variants": 40, "seed": 1, "steps": 24},
                      "perturb": {"method": "uniform", "spread": 0.01}, "scene": {"metrics": ["travel"]}},
                     output=tmp_path / "s.h5", progress=False).path
    code, out, err = cli(capsys, "sensitivity", path, "--metrics", "travel", "--format", "json")
    assert code == 0, err  # the sample itself is analysed
    with h5py.File(path, "r+") as f:
        study = json.loads(f.attrs["study_resolved"])
        del study["perturb"]
        f.attrs["study_resolved"] = json.dumps(study)
    from explorer.store import seal
    seal(path)  # an edit on purpose: the file's checksums follow it
    code, out, err = cli(capsys, "sensitivity", path, "--metrics", "travel")
    one_line_error(code, err, str(path), "no sample of the design space")


# -- 4. rank --by iterations on the arm (a README line) --------------------------------------------------------
@pytest.fixture(scope="module")
def arm_file(tmp_path_factory):
    from explorer import run_study
    study = (ROOT / "studies" / "arm.toml").read_text().replace("variants = 1000", "variants = 30")
    folder = tmp_path_factory.mktemp("arm")
    (folder / "arm.toml").write_text(study)
    return run_study(str(folder / "arm.toml"), output=folder / "arm.h5", progress=False).path


def test_rank_by_iterations_on_the_arm(arm_file, capsys):
    import pandas as pd
    code, out, err = cli(capsys, "rank", arm_file, "--by", "iterations")
    assert code == 0, err
    assert "ranked by iterations (lower is better)" in out
    code, out, err = cli(capsys, "rank", arm_file, "--by", "iterations", "--format", "csv")
    assert code == 0, err
    import io
    ranked = pd.read_csv(io.StringIO(out))
    assert len(ranked) > 3 and ranked["iterations"].is_monotonic_increasing  # fewest first
    # the default ranking of an arm points at the README's command, which works
    code, out, err = cli(capsys, "rank", arm_file)
    one_line_error(code, err, "--by iterations")
    assert "--ascending" not in err


def test_no_direction_hint_names_the_options_not_a_python_keyword(arm_file, capsys):
    code, out, err = cli(capsys, "rank", arm_file, "--by", "O.x")
    one_line_error(code, err, "'O.x' has no natural direction", "--ascending", "--descending")
    assert not err.split("explorer: error: ")[1].startswith("ascending=")
    code, out, err = cli(capsys, "rank", arm_file, "--by", "O.x", "--descending", "--format", "csv")
    assert code == 0, err


# -- 5. one output policy for every writing verb ------------------------------------------------------------------
@pytest.fixture(scope="module")
def small_results(tmp_path_factory):
    from explorer import run_study
    folder = tmp_path_factory.mktemp("small")
    return run_study({"study": {"name": "small", "mechanism": "jansen", "variants": 12, "seed": 1, "steps": 36},
                      "perturb": {"method": "uniform", "spread": 0.01}, "scene": {"velocities": True, "metrics": True}},
                     output=folder / "small.h5", progress=False).path


WRITERS = {
    "plot": lambda r, o: ["plot", r, "--top", "2", "-o", o, "--dpi", "30"],
    "animate": lambda r, o: ["animate", r, "--variant", "1", "--frames", "2", "--cycles", "0.1", "--dpi", "20",
                             "-o", o],
    "export": lambda r, o: ["export", r, "--variant", "1", "-o", o],
    "report": lambda r, o: ["report", r, "-o", o, "--paths", "2"],
    "sensitivity": lambda r, o: ["sensitivity", r, "--metrics", "travel", "--resamples", "2", "-o", o],
}
SUFFIX = {"plot": ".png", "animate": ".gif", "export": ".svg", "report": ".html", "sensitivity": ".png"}


@pytest.mark.parametrize("verb", sorted(WRITERS))
def test_every_writing_verb_creates_folders_and_keeps_files(verb, small_results, tmp_path, capsys):
    if verb == "report":
        pytest.importorskip("plotly")
    if verb == "sensitivity":
        pytest.importorskip("SALib")
    out = tmp_path / "new" / "deeper" / f"out{SUFFIX[verb]}"
    code, text, err = cli(capsys, *WRITERS[verb](small_results, out))
    assert code == 0, err
    assert out.is_file() and out.stat().st_size > 0
    assert "folder" not in text + err  # created silently
    out.write_bytes(b"mine")
    code, text, err = cli(capsys, *WRITERS[verb](small_results, out))
    one_line_error(code, err, str(out), "file exists", "--force")
    assert out.read_bytes() == b"mine"
    code, text, err = cli(capsys, *WRITERS[verb](small_results, out), "--force")
    assert code == 0, err
    assert out.read_bytes() != b"mine"


def test_run_and_optimize_follow_the_same_policy(tmp_path, capsys):
    """Results files: missing folders created, an existing file kept unless --force (and --resume)."""
    study = tmp_path / "s.toml"
    study.write_text('[study]\nname = "s"\nmechanism = "jansen"\nvariants = 8\nsteps = 24\n')
    out = tmp_path / "a" / "b" / "s.h5"
    assert cli(capsys, "run", study, "-o", out, "-q")[0] == 0 and out.is_file()
    code, text, err = cli(capsys, "run", study, "-o", out, "-q")
    one_line_error(code, err, str(out), "--force")
    assert cli(capsys, "run", study, "-o", out, "-q", "--force")[0] == 0
    pytest.importorskip("pymoo")
    opt = tmp_path / "opt.toml"
    opt.write_text(small_optimize_study((ROOT / "studies" / "jansen-optimize.toml").read_text())
                   .replace("generations = 2", "generations = 1"))
    out = tmp_path / "c" / "opt.h5"
    assert cli(capsys, "optimize", opt, "-o", out, "-q")[0] == 0 and out.is_file()
    code, text, err = cli(capsys, "optimize", opt, "-o", out, "-q")
    one_line_error(code, err, str(out), "--force")


# -- 6. every foot's path, and [unit] axis labels ---------------------------------------------------------------
def test_strider_animation_draws_both_feet():
    import numpy as np

    from explorer import load_mechanism, simulate
    from explorer.view import LinkageAnimation
    mech = load_mechanism("strider")
    anim = LinkageAnimation(mech, cycles=1, frames=2, dpi=30)
    assert anim.feet == ["4", "8"]
    cyc = simulate(mech, anim.S)
    assert len(anim.foot_paths) == 2
    for v, drawn in zip(("4", "8"), anim.foot_paths):
        np.testing.assert_allclose(drawn, cyc.path(v))
    # both are on the axes: some line of the figure goes through every point of foot 8's path
    lines = [np.asarray(line.get_xydata()) for line in anim.ax.get_lines()]
    assert any(len(xy) >= anim.S and np.allclose(xy[: anim.S], cyc.path("8")) for xy in lines)
    legend = " ".join(t.get_text() for leg in anim.fig.legends for t in leg.get_texts())
    assert "feet 4, 8" in legend


@pytest.mark.parametrize("name", ["jansen", "klann", "hoeken"])
def test_a_one_footed_leg_draws_one_path(name):
    from explorer import load_mechanism
    from explorer.view import LinkageAnimation
    mech = load_mechanism(name)
    anim = LinkageAnimation(mech, cycles=1, frames=2, dpi=30)
    assert anim.feet == [mech.foot] and len(anim.foot_paths) == 1
    assert len(LinkageAnimation(mech, cycles=1, frames=2, dpi=30, legs=2).foot_paths) == 2  # and its mirror image


def test_animation_axis_labels_use_brackets_as_the_docs_promise():
    from explorer.view import LinkageAnimation
    pictures = (ROOT / "docs" / "pictures.md").read_text()  # the README's "Pictures", moved to the docs site
    assert "units in square brackets in the axis labels" in pictures
    anim = LinkageAnimation("jansen", cycles=1, frames=2, dpi=30)
    for label in (anim.ax.get_xlabel(), anim.ax.get_ylabel()):
        assert label.endswith("[model units]") and "(" not in label, label
