"""The command line's one vocabulary (explorer/cli/_args.py): every verb spells --top, --variant, -o/--force,
--format, --units, --where/--include-screened and --seed through the same functions, so they parse, default
and read alike; the old spellings still work for one release, each with a one-line note on stderr."""

from __future__ import annotations

import argparse
import json

import pytest

from explorer.cli import build_parser
from explorer.testing import VOCABULARY
from clihelp import cli

#: What each verb takes of the vocabulary (verb, or "bench accuracy"): the words of VOCABULARY.
EXPECTED = {
    "rank": {"top", "format", "units", "where", "include-screened"},
    "show": {"variant", "units", "include-screened", "format"},
    "plot": {"top", "variant", "output", "force", "units", "where", "include-screened"},
    "animate": {"variant", "output", "force"},
    "export": {"variant", "output", "force"},
    "report": {"output", "force", "seed", "units", "where"},
    "sensitivity": {"top", "format", "output", "force", "seed"},
    "tolerance": {"format", "seed"},
    "describe": {"format"},
    "physics": {"top", "variant", "force", "where"},
    "run": {"output", "force"},
    "optimize": {"output", "force"},
    "edit": {"variant"},
    "bench accuracy": {"output", "force", "seed"},
    "bench rotations": {"output", "force"},
    "atlas build": {"output", "force", "seed"},
    "synth": {"top", "output", "force"},
}
OPTIONS = {opt: word for word, opts in VOCABULARY.items() for opt in opts}


def subparsers(parser, prefix=""):
    """{verb (or "bench accuracy"): its parser}, through nested subcommands."""
    out = {}
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                key = f"{prefix}{name}"
                nested = subparsers(sub, key + " ")
                out.update(nested or {key: sub})
    return out


VERBS = subparsers(build_parser())


def words(sub) -> set[str]:
    return {getattr(a, "vocabulary") for a in sub._actions if getattr(a, "vocabulary", None)}


@pytest.mark.parametrize("verb", sorted(VERBS))
def test_every_vocabulary_option_comes_from_args(verb):
    """An option spelled like the vocabulary (--top, --variant, -o, --force, --format, --units, --where,
    --include-screened, --seed) is the vocabulary's own (made by cli/_args.py), never a verb's variant of it."""
    stray = [opt for a in VERBS[verb]._actions for opt in a.option_strings
             if opt in OPTIONS and a.help is not argparse.SUPPRESS and getattr(a, "vocabulary", None) != OPTIONS[opt]]
    assert not stray, f"explorer {verb}: {stray} are not made by explorer/cli/_args.py"


def test_each_verb_speaks_what_it_needs():
    assert set(EXPECTED) <= set(VERBS), sorted(set(EXPECTED) - set(VERBS))
    for verb, expected in EXPECTED.items():
        assert words(VERBS[verb]) >= expected, (verb, sorted(expected - words(VERBS[verb])))


@pytest.mark.parametrize("verb", sorted(EXPECTED))
def test_help_shows_the_vocabulary_and_hides_old_spellings(verb):
    text = " ".join(VERBS[verb].format_help().split())
    for word in EXPECTED[verb]:
        assert VOCABULARY[word][-1] in text, (verb, word)
    if "top" in EXPECTED[verb]:
        assert "0 = all" in text
    for old in ("--plot", "OLD_VARIANT", "old_variant"):
        assert old not in text, (verb, old)
    if verb == "export":
        assert "--as" in text and "--format" not in text
        for fmt in ("svg", "dxf", "csv", "toml", "kit"):
            assert f"{fmt}:" in text


def parse(*argv):
    return build_parser().parse_args([str(a) for a in argv])


@pytest.mark.parametrize("old, new, same", [
    (["sensitivity", "R.h5", "--plot", "p.png"], ["sensitivity", "R.h5", "-o", "p.png"], ["output"]),
    (["export", "R.h5", "3", "-o", "x.svg"], ["export", "R.h5", "--variant", "3", "-o", "x.svg"], []),
    (["export", "R.h5", "--variant", "3", "--format", "svg", "-o", "x"],
     ["export", "R.h5", "--variant", "3", "--as", "svg", "-o", "x"], ["fmt"]),
    (["show", "R.h5", "3"], ["show", "R.h5", "--variant", "3"], []),
    (["edit", "R.h5", "2"], ["edit", "R.h5", "--variant", "2"], []),
    (["describe", "jansen", "--format", "text"], ["describe", "jansen", "--format", "table"], ["format"]),
])
def test_old_spellings_still_parse_with_a_one_line_note(old, new, same, capsys):
    from explorer.testing import chosen_variant
    a = parse(*old)
    err = capsys.readouterr().err
    b = parse(*new)
    assert capsys.readouterr().err == ""  # the new spelling: no note
    assert err.count("\n") == 1 and err.startswith("explorer: note: ") and "old spelling" in err, err
    for key in same:
        assert getattr(a, key) == getattr(b, key)
    if old[0] in ("show", "export", "edit") and "--variant" not in old:
        assert chosen_variant(a, old[0], "") == chosen_variant(b, old[0], "") == int(new[new.index("--variant") + 1])
    assert new[0] in err or any(o in err for o in new if o.startswith("-"))


def test_top_zero_is_all_and_bad_values_are_one_line(capsys):
    from explorer.testing import top_count
    assert parse("rank", "R.h5", "--top", "0").top == 0 and top_count(0, 10) is None
    assert top_count(None, 10) == 10 and top_count(3, 10) == 3
    assert parse("plot", "R.h5", "--top", "7").top == 7
    for verb in ("rank", "plot", "sensitivity", "physics"):
        code, out, err = cli(capsys, verb, "R.h5", "--top", "-2")
        assert code == 2 and err.strip() == "explorer: error: --top: expected a whole number >= 0 (0 = all), got '-2'"


def test_variant_seed_and_format_parse_alike(capsys):
    assert parse("show", "R.h5", "--variant", "4").variant == 4
    assert parse("physics", "R.h5", "--variant", "1", "5").variant == [1, 5]
    assert parse("tolerance", "jansen", "--seed", "7").seed == 7
    assert parse("report", "R.h5", "--seed", "3").seed == 3
    for argv, msg in ((["show", "R.h5", "--variant", "x"], "--variant: expected a whole number >= 0"),
                      (["tolerance", "jansen", "--seed", "-1"], "--seed: expected a whole number >= 0"),
                      (["tolerance", "jansen", "--format", "csv"], "--format: expected one of table, json"),
                      (["rank", "R.h5", "--format", "xml"], "--format: expected one of table, csv, json")):
        code, out, err = cli(capsys, *argv)
        assert code == 2 and err.count("\n") == 1 and msg in err, (argv, err)


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    from explorer import run_study
    folder = tmp_path_factory.mktemp("vocab")
    return run_study({"study": {"name": "vocab", "mechanism": "jansen", "variants": 12, "seed": 1, "steps": 36},
                      "perturb": {"method": "uniform", "spread": 0.01},
                      "operating": {"unit": 0.001, "rpm": 30, "load": 1.0},
                      "scene": {"velocities": True, "metrics": True}},
                     output=folder / "small.h5", progress=False).path


def test_old_spellings_run_to_the_same_output(small, tmp_path, capsys):
    """The old spelling does what the new one does (the same file, byte for byte)."""
    code, _, err = cli(capsys, "export", small, "2", "--format", "toml", "-o", tmp_path / "old.toml")
    assert code == 0 and err.count("\n") == 2 and "a positional VARIANT is now --variant N" in err \
        and "--format toml is now --as toml" in err, err
    code, _, err = cli(capsys, "export", small, "--variant", "2", "--as", "toml", "-o", tmp_path / "new.toml")
    assert code == 0 and err == "", err
    strip = lambda p: [ln for ln in p.read_text().splitlines() if "Exported by" not in ln]  # noqa: E731
    assert strip(tmp_path / "old.toml") == strip(tmp_path / "new.toml")
    code, old, err = cli(capsys, "show", small, "3")
    assert code == 0 and err.startswith("explorer: note: ")
    code, new, err = cli(capsys, "show", small, "--variant", "3")
    assert code == 0 and err == "" and old == new
    code, _, err = cli(capsys, "plot", small, "--velocity", "2", "-o", tmp_path / "v.png", "--dpi", "30")
    assert code == 0 and "--velocity 2 is now --velocity --variant 2" in err


def test_show_format_prints_the_metric_table(small, capsys):
    """show --format csv|json: the metric table alone, one row per stored metric: the stored value, the nominal's,
    the change, and the rank among the buildable ok designs, counted here with plain pandas."""
    import io

    import numpy as np
    import pandas as pd

    import explorer
    from explorer.gait import metric
    with explorer.open_results(small) as res:
        df = res.frame()
        names = list(res.metric_names)
    pool = df[(df["status"].astype(str) == "ok") & df["buildable"].astype(bool)]
    v = int(pool["variant"].iloc[-1])
    row, nom = df[df["variant"] == v].iloc[0], df[df["variant"] == 0].iloc[0]
    code, out, err = cli(capsys, "show", small, "--variant", v, "--format", "json")
    assert code == 0 and err == "", err
    rows = {r["metric"]: r for r in json.loads(out)}
    assert set(rows) == set(names)
    for m, r in rows.items():
        x, x0 = float(row[m]), float(nom[m])
        assert r["value"] == x and r["reference"] == x0 and r["change"] == x - x0, m
        values = pool[m].to_numpy(dtype=np.float64)
        values = values[np.isfinite(values)]
        better = values > x if metric(m).direction == "max" else values < x
        assert (r["rank"], r["ranked_among"]) == (1 + int(better.sum()), len(values)), m
    code, out_csv, err = cli(capsys, "show", small, "--variant", v, "--format", "csv")
    table = pd.read_csv(io.StringIO(out_csv))
    assert code == 0 and list(table.columns) == ["metric", "value", "reference", "change", "change_pct", "unit",
                                                 "rank", "ranked_among"]
    assert table.set_index("metric")["rank"].to_dict() == {m: r["rank"] for m, r in rows.items()}
    # where a format does not apply: one line, exit 2
    for argv, words in ((["--format", "json", "--yield"], ["--format json", "--yield"]),
                        (["--format", "xml"], ["--format: expected one of table, csv, json"])):
        code, out, err = cli(capsys, "show", small, "--variant", v, *argv)
        assert code == 2 and out == "" and err.count("\n") == 1 and all(w in err for w in words), err


def test_show_format_prints_the_parameter_table(small, capsys):
    """show --format csv|json --table parameters: one row per design parameter, its value read from the
    file's /variants datasets with h5py (link lengths and crank radius, and their nominal), the change and
    its % computed here."""
    import io

    import h5py
    import pandas as pd

    import explorer
    with explorer.open_results(small) as res:
        mech, perturbed, nominal = res.mechanism, set(res.perturbed), res.nominal
    v = 3
    code, out, err = cli(capsys, "show", small, "--variant", v, "--format", "json", "--table", "parameters")
    assert code == 0 and err == "", err
    rows = json.loads(out)
    assert [r["parameter"] for r in rows] == list(mech.parameters())
    with h5py.File(small, "r") as f:
        ds = f["variants/lengths"]
        stored = dict(zip([str(n) for n in ds.attrs["links"]], ds[v].tolist()))
        noms = dict(zip([str(n) for n in ds.attrs["links"]], ds.attrs["nominal"].tolist()))
        stored["crank"], noms["crank"] = float(f["variants/crank"][v]), float(f["variants/crank"].attrs["nominal"])
    assert any(r["perturbed"] for r in rows) and len(stored) == len(mech.links) + 1
    for r in rows:
        nom = float(nominal.get(r["parameter"], mech.parameters()[r["parameter"]]))
        assert r["nominal"] == nom and r["perturbed"] == (r["parameter"] in perturbed)
        if r["parameter"] in stored:
            assert r["nominal"] == noms[r["parameter"]]
            assert r["value"] == stored[r["parameter"]] and r["kind"] == "length" and r["unit"] == "model"
            assert r["change"] == r["value"] - nom
            assert r["change_pct"] == pytest.approx(100.0 * (r["value"] - nom) / nom, rel=1e-12)
    code, out_csv, err = cli(capsys, "show", small, "--variant", v, "--format", "csv", "--table", "parameters")
    table = pd.read_csv(io.StringIO(out_csv))
    assert code == 0 and list(table.columns) == ["parameter", "label", "kind", "value", "nominal", "change",
                                                 "change_pct", "pct_of", "unit", "perturbed"]
    assert table["value"].tolist() == [r["value"] for r in rows]
    # --table goes with a machine format: one line, exit 2
    code, out, err = cli(capsys, "show", small, "--variant", v, "--table", "parameters")
    assert code == 2 and out == "" and err.count("\n") == 1 and "--format csv or json" in err, err


def test_plot_units_si(small, tmp_path, capsys):
    """plot --units si: the foot paths in mm (x 1000 x [operating] unit) and the scatter's axes in SI."""
    import explorer
    from explorer.view import plot_scatter, plot_top
    with explorer.open_results(small) as res:
        model = plot_top(res, top=2)
        si = plot_top(res, top=2, units="si")
        for a, b in zip(model.axes[0].lines, si.axes[0].lines):
            assert a.get_xydata() * 1.0 == pytest.approx(b.get_xydata() / 1000.0 / 0.001 * 1.0, rel=1e-12)
        assert si.axes[0].get_xlabel().endswith("[mm]") and model.axes[0].get_xlabel().endswith("[model units]")
        s = plot_scatter(res, "travel", "bob", units="si")
        assert "[m/turn]" in s.axes[0].get_xlabel() and "[mm]" in s.axes[0].get_ylabel()
        frame = res.frame()
    ok = frame[frame["status"] == "ok"]
    pts = s.axes[0].collections[-1].get_offsets() if len(s.axes[0].collections) else None
    assert pts is not None and float(max(pts[:, 1])) <= float(ok["bob"].max()) * 1.0 + 1e-12  # bob in mm = bob x 1
    code, _, err = cli(capsys, "plot", small, "--top", "2", "--units", "si", "-o", tmp_path / "t.png", "--dpi", "30")
    assert code == 0, err
    code, _, err = cli(capsys, "plot", small, "--sensitivity", "--units", "si", "-o", tmp_path / "s.png")
    assert code == 2 and "--units goes with --top or --scatter" in err


def test_a_toy_export_format_is_one_registry_entry(small, tmp_path, capsys):
    """Adding an export format is one register_export call and its code: the CLI's --as choices and help, the
    extension lookup and the dispatch all follow."""
    from explorer.fabrication import EXPORT_FORMATS, EXPORTS, ExportFormat, register_export

    def write_json(job):
        job.out.write_text(json.dumps({"variant": job.variant, "links": {k.name: k.length for k in job.mechanism.links}}))
        return f"wrote {job.out}"

    register_export(ExportFormat("json", ".json", "the design's link lengths as JSON", write_json))
    try:
        help_text = " ".join(subparsers(build_parser())["export"].format_help().split())
        assert "json: the design's link lengths as JSON (.json)" in help_text
        assert EXPORT_FORMATS["json"] == ".json"
        code, out, err = cli(capsys, "export", small, "--variant", "1", "-o", tmp_path / "d.json")
        assert code == 0, err
        data = json.loads((tmp_path / "d.json").read_text())
        import explorer
        with explorer.open_results(small) as res:
            row = res.row(1)
        assert data["variant"] == 1 and all(data["links"][k] == pytest.approx(float(row[k]), rel=1e-12)
                                            for k in data["links"] if k in row.index)
        code, out, err = cli(capsys, "export", small, "--variant", "1", "--as", "json", "-o", tmp_path / "d.json")
        assert code == 2 and "file exists" in err  # the one output policy holds for a new format too
        code, out, err = cli(capsys, "export", small, "--variant", "1", "--as", "json", "-o", tmp_path / "e.csv")
        assert code == 2 and "--as json into a .csv file" in err
    finally:
        del EXPORTS["json"]
    assert "json" not in EXPORT_FORMATS
    with pytest.raises(ValueError):
        register_export(ExportFormat("svg2", ".svg", "a second .svg", write_json))


def test_the_docs_page_lists_the_vocabulary_and_the_old_spellings():
    from pathlib import Path
    page = (Path(__file__).parents[1] / "docs" / "cli.md").read_text(encoding="utf-8")
    for opts in VOCABULARY.values():
        assert f"`{opts[-1]}" in page or f"`{opts[0]}/{opts[-1]}" in page, opts
    for old in ("--plot PATH", "--format svg", "--format text", "--velocity 12", "show RESULTS 12"):
        assert old in page, old
    for verb, expected in EXPECTED.items():  # each verb's row names it for every option it takes
        for word in expected - {"force", "output", "variant"}:
            row = next(ln for ln in page.splitlines() if ln.startswith(f"| `{VOCABULARY[word][-1]}"))
            assert verb.split()[0] in row, (verb, word, row)
