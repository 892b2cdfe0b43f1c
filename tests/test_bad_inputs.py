"""Bad inputs, one case per line: each is a one-line error naming the file, key or value, exit code 2,
no traceback, and nothing written. Add a line to add a case."""

from __future__ import annotations

from importlib import resources

import pytest

from explorer.cli import main

JANSEN = (resources.files("explorer.mechanism") / "builtin" / "jansen.toml").read_text()
STUDY = '[study]\nname = "bad"\nmechanism = "m.toml"\nvariants = 4\nsteps = 12\n[scene]\nmetrics = true\n'


def mech(old, new):
    return {"m.toml": JANSEN.replace(old, new, 1), "s.toml": STUDY}


def study(extra):
    return {"m.toml": JANSEN, "s.toml": STUDY + extra}


# (id, files to write, argv after `explorer`, words the one-line error must hold)
CASES = [
    ("nested-toml-mechanism", {"m.toml": "a = " + "[" * 3000 + "]" * 3000, "s.toml": STUDY}, ["run", "s.toml"],
     "nested too deeply"),
    ("nested-toml-study", {"m.toml": JANSEN, "s.toml": "a = " + "[" * 3000 + "]" * 3000}, ["run", "s.toml"],
     "nested too deeply"),
    ("huge-integer-length", mech("length = 50.0", "length = " + "9" * 400), ["run", "s.toml"], "links[0].length"),
    ("length-1e308", mech("length = 50.0", "length = 1e308"), ["run", "s.toml"], "links[0].length"),
    ("length-1e-308", mech("length = 50.0", "length = 1e-308"), ["run", "s.toml"], "links[0].length"),
    ("slash-in-vertex-name", mech('"2" = [-38.0, -7.8]', '"2" = [-38.0, -7.8]\n"a/b" = [0.0, 1.0]'),
     ["run", "s.toml"], "fixed.a/b"),
    ("fixed-vertex-on-no-link", mech('"2" = [-38.0, -7.8]', '"2" = [-38.0, -7.8]\n"Z" = [0.0, 1.0]'),
     ["run", "s.toml"], "fixed.Z: vertex 'Z' is on no link"),
    ("loose-tolerance", study(""), ["run", "s.toml"], None),  # (a control: this one runs)
    ("tolerance-1e-2", {"m.toml": JANSEN, "s.toml": STUDY.replace("steps = 12", "steps = 12\ntolerance = 1e-2")},
     ["run", "s.toml"], "study.tolerance"),
    ("walker-legs-0", study("[walker]\nlegs = 0\n"), ["run", "s.toml"], "walker.legs"),
    ("screen-unknown-key", study("[screen]\nmax_angle = 3\n"), ["run", "s.toml"], "screen.max_angle"),
    ("output-is-the-study", study(""), ["run", "s.toml", "-o", "s.toml", "--force"], "run's own study file"),
    ("output-is-the-mechanism", study(""), ["run", "s.toml", "-o", "m.toml", "--force"], "run's own mechanism file"),
    ("force-over-a-text-file", {**study(""), "notes.txt": "keep"}, ["run", "s.toml", "-o", "notes.txt", "--force"],
     "not an explorer results file"),
    ("where-runs-python", study(""), ["rank", "out.h5", "--where", "__import__('os').system('touch pwned')"],
     "a call is not allowed"),
    ("where-pandas-at", study(""), ["rank", "out.h5", "--where", "stride > 0 and @pd.io.common.os.system('x')"],
     "cannot parse"),
    ("dpi-1e9", study(""), ["plot", "out.h5", "--top", "1", "--dpi", "1e9", "-o", "x.png"], "--dpi"),
    ("unknown-metric", study(""), ["rank", "out.h5", "--by", "speed"], "unknown metric 'speed'"),
    ("results-not-hdf5", {**study(""), "fake.h5": "not hdf5"}, ["rank", "fake.h5"], "fake.h5"),
]


@pytest.mark.parametrize("files,argv,words", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_exit_2(tmp_path, monkeypatch, capsys, files, argv, words):
    monkeypatch.chdir(tmp_path)
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    if argv[0] in ("rank", "plot") and "out.h5" in argv:
        assert main(["run", "s.toml", "-o", "out.h5", "-q"]) == 0
        capsys.readouterr()
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    code = main(argv)
    err = capsys.readouterr().err
    if words is None:
        assert code == 0, err
        return
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("explorer: error: ") and "Traceback" not in err, err
    assert words in err, err
    after = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    assert {k: v for k, v in after.items() if k in before} == before  # nothing already there changed
    assert not (tmp_path / "pwned").exists()


def test_a_study_larger_than_the_disk_is_refused_before_writing(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.toml").write_text(JANSEN, encoding="utf-8")
    big = STUDY.replace("variants = 4", "variants = 1000000000").replace("steps = 12", "steps = 10000000")
    (tmp_path / "s.toml").write_text(big, encoding="utf-8")
    code = main(["run", "s.toml", "-o", "big.h5"])
    err = capsys.readouterr().err
    assert code == 2 and " free; store fewer" in err and err.count("\n") == 1, err
    assert not list(tmp_path.glob("*.h5")) and not list(tmp_path.glob(".*"))


def test_a_very_long_output_name_is_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "m.toml").write_text(JANSEN, encoding="utf-8")
    (tmp_path / "s.toml").write_text(STUDY, encoding="utf-8")
    code = main(["run", "s.toml", "-o", "x" * 300 + ".h5", "-q"])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err


def test_every_cli_verb_imports():
    """A verb whose module fails to import shows as "(unavailable)" in --help: here it fails loudly."""
    from explorer.testing import verb_modules as _verb_modules
    broken = {verb: mod for verb, mod in _verb_modules() if isinstance(mod, Exception)}
    assert not broken, broken
