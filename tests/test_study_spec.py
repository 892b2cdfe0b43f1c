"""Study files: the shipped studies load, and every validation error is one line naming file and key.

Errors are checked both from ``load_study`` (UserError) and through ``explorer run`` (exit code 2,
one line on stderr). Nothing here runs a simulation: validation happens before any solve.
"""

from __future__ import annotations

import copy
from pathlib import Path

import pytest

from explorer import UserError, load_study
from explorer.cli import main
from explorer.study import builtin_studies, default_study_text, dumps_toml, study_from_dict

ROOT = Path(__file__).resolve().parent.parent
STUDIES = ROOT / "studies"

BASE = {
    "study": {"name": "t", "mechanism": "jansen", "variants": 20, "seed": 3, "steps": 36, "tolerance": 1e-10,
              "method": "block"},
    "perturb": {"method": "uniform", "spread": 0.02, "links": "all", "crank": True},
    "scene": {"vertices": ["7"], "velocities": True, "accelerations": False, "band": 0.01, "metrics": False},
    "output": {"path": "results/t.h5"},
}


def with_value(key: str, value):
    """BASE with ``section.key`` set to ``value`` (``...`` deletes it)."""
    d = copy.deepcopy(BASE)
    sec, k = key.split(".", 1)
    if value is ...:
        del d[sec][k]
    else:
        d[sec][k] = value
    return d


def write(tmp_path: Path, data: dict, name="study.toml") -> Path:
    p = tmp_path / name
    p.write_text(dumps_toml(data), encoding="utf-8")
    return p


# -- the shipped studies -------------------------------------------------------------------------------
def test_default_study_shipped_in_package_is_the_repo_copy():
    assert "default" in builtin_studies()
    assert default_study_text() == (STUDIES / "default.toml").read_text(encoding="utf-8")


def test_default_study_contents():
    s = load_study()  # no argument: the built-in default
    assert s.source == "builtin:default"
    assert (s.name, s.mechanism, s.variants, s.steps, s.tolerance, s.method) == \
        ("jansen-2pct", "jansen", 10000, 360, 1e-11, "block")
    assert (s.perturb_method, s.spread, s.links, s.crank) == ("uniform", 0.02, "all", True)
    assert (s.vertices, s.velocities, s.accelerations) == (("7",), True, False)
    assert s.output == "results/jansen-2pct.h5"
    assert s.n_variants == 10000 and s.n_parameters == 11


@pytest.mark.parametrize("path", sorted(STUDIES.glob("*.toml")), ids=lambda p: p.name)
def test_example_studies_load(path):
    s = load_study(path)
    assert s.source == str(path) and s.n_variants >= 1
    assert s.text == path.read_text(encoding="utf-8")


def test_defaults_and_dict_input():
    s = load_study({"study": {"name": "x", "mechanism": "fourbar"}})
    assert s.source == "<dict>"
    assert (s.variants, s.seed, s.steps, s.method, s.perturb_method, s.spread) == (10000, 0, 360, "block", "uniform", 0.02)
    assert s.vertices == (s.mech.foot,) and s.metrics is False and s.band == 0.01
    assert s.output == "results/x.h5"
    # the dict's TOML text loads back to the same study
    assert study_from_dict(__import__("tomllib").loads(s.text)).fingerprint() == s.fingerprint()


def test_oat_and_grid_counts():
    oat = load_study(with_value("perturb.method", "oat") | {})
    assert oat.n_variants == 1 + 11 * 20
    d = with_value("perturb.method", "grid")
    d["perturb"]["links"] = ["1-3", "2-6"]
    d["study"]["variants"] = 5
    assert load_study(d).n_variants == 1 + 5 ** 3


def test_relative_mechanism_path_is_next_to_the_study(tmp_path):
    mech_dir = tmp_path / "mechs"
    mech_dir.mkdir()
    src = (ROOT / "explorer" / "mechanism" / "builtin" / "fourbar.toml").read_text()
    (mech_dir / "mine.toml").write_text(src)
    d = with_value("study.mechanism", "mechs/mine.toml")
    d["scene"]["vertices"] = "all"
    s = load_study(write(tmp_path, d))
    assert Path(s.mechanism_path) == mech_dir / "mine.toml"


# -- every validation error ----------------------------------------------------------------------------
BAD = [
    # (key, value, words the message must contain)
    ("study.name", ..., "missing"),
    ("study.name", 3, "string"),
    ("study.name", "a b/c", "letters"),
    ("study.mechanism", ..., "missing"),
    ("study.mechanism", "nonesuch", "built-ins"),
    ("study.mechanism", 1, "string"),
    ("study.variants", 0, "integer"),
    ("study.variants", 2.5, "integer"),
    ("study.variants", "10", "integer"),
    ("study.variants", True, "integer"),
    ("study.seed", -1, "integer"),
    ("study.seed", 1.0, "integer"),
    ("study.steps", 2, "integer"),
    ("study.steps", "360", "integer"),
    ("study.tolerance", 0.0, "from 1e-12 to 1e-06"),
    ("study.tolerance", 1.5, "from 1e-12 to 1e-06"),
    ("study.tolerance", 1e-4, "from 1e-12 to 1e-06"),
    ("study.tolerance", "tight", "from 1e-12 to 1e-06"),
    ("study.method", "newton", "'block', 'dense'"),
    ("study.colour", "red", "unknown key"),
    ("perturb.method", "random", "uniform"),
    ("perturb.method", 1, "uniform"),
    ("perturb.spread", -0.1, "[0, 1)"),
    ("perturb.spread", 1.0, "[0, 1)"),
    ("perturb.spread", "2%", "[0, 1)"),
    ("perturb.spread", float("nan"), "[0, 1)"),
    ("perturb.links", "some", "all"),
    ("perturb.links", [], "all"),
    ("perturb.links", ["1-3", "9-9"], "unknown link"),
    ("perturb.links", ["1-3", "1-3"], "twice"),
    ("perturb.links", [13], "names"),
    ("perturb.crank", "yes", "true or false"),
    ("perturb.seed", 1, "unknown key"),
    ("scene.vertices", ["8"], "unknown vertex"),
    ("scene.vertices", [7], "names"),
    ("scene.vertices", "foot", "all"),
    ("scene.vertices", ["7", "7"], "twice"),
    ("scene.velocities", 1, "true or false"),
    ("scene.accelerations", "no", "true or false"),
    ("scene.band", 0.0, "(0, 1)"),
    ("scene.band", 1.0, "(0, 1)"),
    ("scene.band", "wide", "(0, 1)"),
    ("scene.metrics", "stride", "true, false"),
    ("scene.metrics", [], "true, false"),
    ("scene.metrics", [1], "metric names"),
    ("scene.metrics", ["stride", "stride"], "twice"),
    ("scene.colour", "red", "unknown key"),
    ("output.path", "", "string"),
    ("output.path", 5, "string"),
    ("output.format", "csv", "unknown key"),
]


@pytest.mark.parametrize("key,value,words", BAD, ids=[f"{k}={v!r}" for k, v, _ in BAD])
def test_invalid_key_is_one_line_naming_file_and_key(tmp_path, capsys, key, value, words):
    path = write(tmp_path, with_value(key, value))
    with pytest.raises(UserError) as info:
        load_study(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(f"{path}: {key}"), msg
    assert words in msg, msg
    # and through the CLI: exit code 2, one line on stderr, no traceback
    code = main(["run", str(path), "-o", str(tmp_path / "out.h5"), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err
    assert str(path) in err and key in err
    assert not (tmp_path / "out.h5").exists()


def test_unknown_metric_is_checked_against_the_gait_module(tmp_path):
    from explorer.gait import METRICS
    assert "stride" in METRICS and "speediness" not in METRICS  # not a skip: lost METRICS is a regression
    with pytest.raises(UserError, match=r"scene\.metrics: unknown metric 'speediness'"):
        load_study(write(tmp_path, with_value("scene.metrics", ["stride", "speediness"])))


@pytest.mark.parametrize("text,words", [
    ("[study\nname = 1", "not valid TOML"),
    ("[colour]\nx = 1\n", "colour: unknown section"),
    ("study = 3\n", "study: expected a table"),
], ids=["toml", "section", "table"])
def test_malformed_files(tmp_path, text, words):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(UserError) as info:
        load_study(p)
    assert str(info.value).startswith(str(p)) and words in str(info.value) and "\n" not in str(info.value)


def test_a_mechanism_file_given_as_a_study_says_how_to_run_it(tmp_path, capsys):
    """The README's exported leg.toml handed to `explorer run`: one line naming the file and the key a
    study uses for it, exit 2, nothing written."""
    from importlib import resources
    mech = tmp_path / "leg.toml"
    mech.write_text((resources.files("explorer.mechanism") / "builtin" / "fourbar.toml").read_text(encoding="utf-8"))
    with pytest.raises(UserError) as info:
        load_study(mech)
    assert str(info.value).startswith(str(mech)) and "[study] mechanism" in str(info.value)
    code = main(["run", str(mech), "-o", str(tmp_path / "out.h5")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert "mechanism file, not a study" in err
    assert not (tmp_path / "out.h5").exists()


def test_grid_too_large(tmp_path):
    d = with_value("perturb.method", "grid")
    d["study"]["variants"] = 100  # 100 ** 11 variants
    with pytest.raises(UserError, match=r"study\.variants: grid with 100 levels over 11 parameters"):
        load_study(write(tmp_path, d))


def test_oat_needs_two_levels(tmp_path):
    d = with_value("perturb.method", "oat")
    d["study"]["variants"] = 1
    with pytest.raises(UserError, match=r"study\.variants: expected an integer from 2 .*levels per parameter"):
        load_study(write(tmp_path, d))


def test_nothing_to_perturb_is_impossible_by_construction(tmp_path):
    d = with_value("perturb.crank", False)
    d["perturb"]["links"] = ["1-3"]
    assert load_study(write(tmp_path, d)).n_parameters == 1


def test_missing_study_file(tmp_path, capsys):
    missing = tmp_path / "nope.toml"
    with pytest.raises(UserError, match="no such study file"):
        load_study(missing)
    assert main(["run", str(missing)]) == 2
    assert "nope.toml" in capsys.readouterr().err


# -- Study as typed sections (issue 40): one section per table, the flat names of before still read ----------
#: {flat name: (section attribute, key)} written out here, from the study file's tables (not from the code)
FLAT = {"steps": ("solver", "steps"), "tolerance": ("solver", "tolerance"), "method": ("solver", "method"),
        "perturb_method": ("perturb", "method"), "spread": ("perturb", "spread"), "links": ("perturb", "links"),
        "crank": ("perturb", "crank"), "parameters": ("perturb", "parameters"),
        "vertices": ("scene", "vertices"), "velocities": ("scene", "velocities"),
        "accelerations": ("scene", "accelerations"), "band": ("scene", "band"), "metrics": ("scene", "metrics"),
        "forces": ("scene", "forces"), "force_joints": ("scene", "force_joints"), "store": ("scene", "store"),
        "output": ("results_file", "path"), "compression": ("results_file", "compression")}


def test_study_is_typed_sections_and_the_flat_names_still_read(tmp_path):
    import dataclasses
    import pickle

    from explorer.study import Output, Perturb, Scene, Solver
    from explorer.study.runner import Recipe

    data = copy.deepcopy(BASE)
    data["scene"].update({"metrics": ["travel", "bob"], "store": "metrics"})
    data["output"]["compression"] = "lzf"
    s = study_from_dict(data, "s.toml")
    assert (type(s.solver), type(s.perturb), type(s.scene), type(s.results_file)) == (Solver, Perturb, Scene, Output)
    # each flat name is its section's value, and the value the file gave
    for flat, (section, key) in FLAT.items():
        assert getattr(s, flat) is getattr(getattr(s, section), key), flat
    assert (s.steps, s.tolerance, s.method) == (36, 1e-10, "block")
    assert (s.perturb_method, s.spread, s.links, s.crank) == ("uniform", 0.02, "all", True)
    assert (s.vertices, s.metrics, s.store, s.lean) == (("7",), ("travel", "bob"), "metrics", True)
    assert (s.output, s.compression) == ("results/t.h5", "lzf")
    # the flat names read only; a section is replaced whole, and the flat name follows it
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.scene.band = 0.5
    with pytest.raises(AttributeError):
        s.steps = 10
    t = dataclasses.replace(s, solver=dataclasses.replace(s.solver, steps=72))
    assert t.steps == 72 and t.n_series == s.n_series and t.fingerprint() != s.fingerprint()
    # what a worker rebuilds from a pickled recipe is the same study (the same fingerprint and text)
    back = pickle.loads(pickle.dumps(Recipe(s))).study()
    assert back == s and back.fingerprint() == s.fingerprint() and back.text == s.text
    # the fields are the sections, not the flat names: 33 flat fields became 19
    names = {f.name for f in dataclasses.fields(s)}
    assert {"solver", "perturb", "scene", "results_file"} <= names and not names & set(FLAT)


def test_an_optimize_study_has_the_optimisers_perturb_section():
    s = load_study(STUDIES / "jansen-optimize.toml")
    assert s.perturb.method == s.perturb_method == "optimize" and s.perturb.spread == 0.0
    assert s.perturb.parameters == s.optimize.parameters and s.variants == s.optimize.evaluations
