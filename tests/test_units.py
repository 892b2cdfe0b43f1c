"""``--units si`` of ``show``, ``rank`` and ``report``, and the report's columns against a reference design.

Every expected number is computed here from the model-unit output (``rank --format csv``, the results
frame) with the plain formulas of issue 26, never with :mod:`explorer.gait._units`:

* lengths (metrics of unit "length", link lengths, the crank radius, coordinates): × unit × 1000 (mm);
* travel per turn: × unit (m); walking speed: travel × unit × rpm / 60 (m/s);
* peak_torque, torque_ripple (per weight × crank radius): × load · g × crank · unit (N·m), the crank
  radius of each variant;
* change against the reference: 100 · (v − ref) / |ref|.

The operating point is written plainly: studies/mechanisms/jansen-plywood.toml gives unit = 0.01 m,
load = 8 kg, gravity = 9.81 m/s²; the study here sets rpm = 40.
"""

from __future__ import annotations

import html as htmlmod
import io
import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from explorer import open_results, run_study

from clihelp import cli, ok_cli

REPO = Path(__file__).resolve().parents[1]
PLYWOOD = (REPO / "studies" / "mechanisms" / "jansen-plywood.toml").as_posix()
UNIT, LOAD, G, RPM = 0.01, 8.0, 9.81, 40.0  # the plywood leg's [operating] (rpm: this study's)
LINKS = ["1-3", "3-4", "2-3", "2-4", "4-5", "2-6", "1-6", "5-6", "5-7", "6-7"]
MM = LINKS + ["crank", "crank.x", "crank.y", "2.x", "2.y", "bob", "clearance", "width", "height", "stride",
              "stance_rms_line", "foot_headroom"]
SAME = ["body_speed_ripple", "slip", "contact_fraction", "duty", "flatness", "speed_ripple", "min_transmission_angle",
        "self_crossings", "score", "variant"]


def _study(name, mechanism, operating):
    return {"study": {"name": name, "mechanism": mechanism, "variants": 30, "seed": 2, "steps": 36},
            "perturb": {"method": "uniform", "spread": 0.03, "links": "all", "crank": True, "parameters": "all"},
            "scene": {"vertices": ["7"], "velocities": True, "metrics": True}, "operating": operating}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Three small Jansen studies: the plywood leg with its [operating] (unit, load) and rpm 40; the
    built-in leg with only [operating] unit (no load, no rpm); the built-in leg with no [operating]."""
    d = tmp_path_factory.mktemp("units")
    si = run_study(_study("si", PLYWOOD, {"rpm": RPM}), output=d / "si.h5", progress=False).path
    bare = run_study(_study("bare", "jansen", {"unit": UNIT}), output=d / "bare.h5", progress=False).path
    plain = _study("plain", "jansen", {})
    del plain["operating"]
    none = run_study(plain, output=d / "none.h5", progress=False).path
    return {"si": si, "bare": bare, "none": none, "dir": d}


def _half_ulp(cell: str) -> float:
    """Half a unit of the last decimal a table cell prints (the table rounds each column to 5 digits)."""
    decimals = len(cell.split(".")[1]) if "." in cell else 0
    return 0.5 * 10.0 ** -decimals * (1 + 1e-9)


def csv(capsys, *args) -> pd.DataFrame:
    return pd.read_csv(io.StringIO(ok_cli(capsys, *args)))


# -- rank --------------------------------------------------------------------------------------------------
def test_rank_csv_si_is_the_model_csv_times_the_factors(files, capsys):
    model = csv(capsys, "rank", files["si"], "--format", "csv")
    si = csv(capsys, "rank", files["si"], "--format", "csv", "--units", "si")
    assert len(model) == len(si) > 5 and (model["variant"] == si["variant"]).all()
    for c in MM:
        np.testing.assert_allclose(si[f"{c}[mm]"], model[c] * UNIT * 1000.0, rtol=1e-12, err_msg=c)
        assert c not in si.columns
    np.testing.assert_allclose(si["travel[m/turn]"], model["travel"] * UNIT, rtol=1e-12)
    np.testing.assert_allclose(si["speed[m/s]"], model["travel"] * UNIT * RPM / 60.0, rtol=1e-12)
    for c in ("stance_speed", "max_speed"):
        np.testing.assert_allclose(si[f"{c}[mm/rad]"], model[c] * UNIT * 1000.0, rtol=1e-12)
    weight = LOAD * G
    for c in ("peak_torque", "torque_ripple"):  # each variant's own crank radius
        np.testing.assert_allclose(si[f"{c}[N·m]"], model[c] * weight * model["crank"] * UNIT, rtol=1e-12)
    for c in SAME:  # dimensionless: the same values under the same names
        np.testing.assert_array_equal(si[c], model[c])
    # the speed column follows travel
    cols = list(si.columns)
    assert cols.index("speed[m/s]") == cols.index("travel[m/turn]") + 1


def test_rank_json_si_carries_the_csv_values(files, capsys):
    si = csv(capsys, "rank", files["si"], "--format", "csv", "--units", "si", "--top", "4")
    rows = json.loads(ok_cli(capsys, "rank", files["si"], "--format", "json", "--units", "si", "--top", "4"))
    assert [r["variant"] for r in rows] == si["variant"].tolist()
    for c in ("bob[mm]", "travel[m/turn]", "speed[m/s]", "peak_torque[N·m]", "crank[mm]"):
        np.testing.assert_allclose([r[c] for r in rows], si[c], rtol=1e-15, err_msg=c)


def test_rank_table_si_with_change_over_the_shown_values(files, capsys):
    """The table's columns carry their units; the change against the nominal is over the SI values (a
    torque's change includes the crank radius); the last row is the nominal."""
    with open_results(files["si"]) as res:
        df = res.frame()
    out = ok_cli(capsys, "rank", files["si"], "--units", "si", "--change", "--top", "5")
    head, _, body = out.partition("\n\n")
    assert "SI units" in head and "0.01 m per model unit" in head and "40 rpm" in head
    lines = body.strip("\n").splitlines()
    cols = lines[0].split()
    for c in ("travel[m/turn]", "speed[m/s]", "bob[mm]", "peak_torque[N·m]", "clearance[mm]"):
        assert c in cols, cols
    rows = [ln.split() for ln in lines[1:]]
    assert rows[-1][0].startswith("nominal:") and rows[-1][1] == "0"
    nom = df.iloc[0]
    torque = lambda r: r["peak_torque"] * LOAD * G * r["crank"] * UNIT  # noqa: E731
    for cells in rows[:-1]:
        r = df.iloc[int(cells[1])]
        for name, x, x0 in (("bob", r["bob"] * UNIT * 1000, nom["bob"] * UNIT * 1000),
                            ("travel", r["travel"] * UNIT, nom["travel"] * UNIT),
                            ("peak_torque", torque(r), torque(nom))):
            cell = cells[cols.index(f"{name}%")]
            assert float(cell) == pytest.approx(100 * (x - x0) / abs(x0), abs=_half_ulp(cell)), (name, cell)
        cell = cells[cols.index("bob[mm]")]
        assert float(cell) == pytest.approx(r["bob"] * UNIT * 1000, abs=_half_ulp(cell))
        cell = cells[cols.index("speed[m/s]")]
        assert float(cell) == pytest.approx(r["travel"] * UNIT * RPM / 60, abs=_half_ulp(cell))


def test_without_load_and_rpm_torque_stays_and_speed_is_left_out(files, capsys):
    """[operating] unit only: lengths convert; the torque metrics keep their names and values, no speed,
    and the table says both in one line each."""
    model = csv(capsys, "rank", files["bare"], "--format", "csv")
    si = csv(capsys, "rank", files["bare"], "--format", "csv", "--units", "si")
    np.testing.assert_allclose(si["bob[mm]"], model["bob"] * UNIT * 1000.0, rtol=1e-12)
    np.testing.assert_array_equal(si["peak_torque"], model["peak_torque"])
    assert "speed[m/s]" not in si.columns and not any(c.startswith("peak_torque[") for c in si.columns)
    out = ok_cli(capsys, "rank", files["bare"], "--units", "si")
    said = [ln for ln in out.splitlines() if "no load" in ln or "no rpm" in ln]
    assert len(said) == 2 and any("peak_torque" in ln for ln in said), out


@pytest.mark.parametrize("verb", [["rank"], ["show", "--variant", "1"], ["report", "-o", "{d}/r.html"]])
def test_si_without_an_operating_unit_is_one_line_exit_2(files, capsys, verb):
    argv = [verb[0], str(files["none"])] + [a.format(d=files["dir"]) for a in verb[1:]] + ["--units", "si"]
    code, out, err = cli(capsys, *argv)
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    assert str(files["none"]) in err and "[operating]" in err and "unit = " in err and "metres per model unit" in err
    assert not (files["dir"] / "r.html").exists()


# -- show --------------------------------------------------------------------------------------------------
def test_show_si_lines(files, capsys):
    with open_results(files["si"]) as res:
        df = res.frame()
    ok = np.flatnonzero(df["status_code"].to_numpy() == 0)
    v = int(ok[2])
    r, nom = df.iloc[v], df.iloc[0]
    out = ok_cli(capsys, "show", files["si"], "--variant", v, "--units", "si")
    lines = out.splitlines()
    head = next(ln for ln in lines if ln.startswith("parameter "))
    assert "value [mm]" in head and "nominal [mm]" in head
    for p in ("3-4", "5-7"):
        cells = next(ln for ln in lines if ln.startswith(f"link {p} ")).split()
        assert cells[2:5] == [f"{r[p] * UNIT * 1000:.4f}", f"{nom[p] * UNIT * 1000:.4f}",
                              f"{(r[p] - nom[p]) * UNIT * 1000:+.4f}"]
    cells = next(ln for ln in lines if ln.startswith("crank ")).split()
    assert cells[1] == f"{r['crank'] * UNIT * 1000:.4f}"

    def metric_line(m):
        return next(ln for ln in lines if ln.startswith(m + " ")).split()

    torque = lambda row: row["peak_torque"] * LOAD * G * row["crank"] * UNIT  # noqa: E731
    for m, x, x0, unit in (("travel", r["travel"] * UNIT, nom["travel"] * UNIT, "m/turn"),
                           ("speed", r["travel"] * UNIT * RPM / 60, nom["travel"] * UNIT * RPM / 60, "m/s"),
                           ("bob", r["bob"] * UNIT * 1000, nom["bob"] * UNIT * 1000, "mm"),
                           ("peak_torque", torque(r), torque(nom), "N·m")):
        cells = metric_line(m)
        assert cells[1] == f"{x:.6g}" and cells[2] == f"{x0:.6g}", (m, cells)
        assert cells[4] == f"{100 * (x - x0) / abs(x0):+.1f}" and cells[6] == unit, (m, cells)
    # a dimensionless metric keeps its value; the speed ranks as travel does
    assert metric_line("body_speed_ripple")[1] == f"{r['body_speed_ripple']:.6g}"
    assert metric_line("speed")[7:] == metric_line("travel")[7:]
    assert any(ln.startswith("SI units at the study's [operating] point: unit 0.01 m per model unit, 40 rpm, load 8 kg")
               for ln in lines)
    verdict = next(ln for ln in lines if ln.startswith("verdict against the nominal"))
    assert f"bob {r['bob'] * UNIT * 1000:.4g} vs {nom['bob'] * UNIT * 1000:.4g} mm" in verdict


def test_show_model_units_unchanged_by_default(files, capsys):
    with open_results(files["si"]) as res:
        r = res.frame().iloc[0]
    lines = ok_cli(capsys, "show", files["si"], "--variant", 0).splitlines()
    cells = next(ln for ln in lines if ln.startswith("bob ")).split()
    assert cells[1] == f"{r['bob']:.6g}" and cells[6] == "length"
    assert not any(ln.startswith("speed ") for ln in lines)


# -- report ------------------------------------------------------------------------------------------------
def _vs_rows(text: str) -> list[dict]:
    """The rows of the report's table against the reference: variant, class, {key: (value, change)}."""
    table = re.search(r"<table id='vs'>(.*?)</table>", text, re.S).group(1)
    out = []
    for cls, v, body in re.findall(r"<tr class='(vs|ref)' data-variant='(\d+)'[^>]*>(.*?)</tr>", table, re.S):
        cells = {k: (float(a), float(b)) for k, a, b in
                 re.findall(r"data-key='([^']+)' data-value='([^']+)' data-change='([^']+)'", body)}
        out.append({"class": cls, "variant": int(v), "cells": cells})
    return out


@pytest.mark.parametrize("units", ["model", "si"])
def test_report_against_the_reference(files, tmp_path, units):
    """The report's table of the best designs: the variants of `explorer rank`, each score metric's value
    and change 100·(v − ref)/|ref| against the reference (--vs), the reference last with its place."""
    from explorer.view import write_report
    with open_results(files["si"]) as res:
        df = res.frame()
        ranked = res.rank(top=None)
    ref = int(ranked["variant"].iloc[3])
    out = tmp_path / "r.html"
    write_report(files["si"], out, vs=ref, units=units, paths=5)
    text = out.read_text(encoding="utf-8")
    rows = _vs_rows(text)
    assert [r["variant"] for r in rows[:-1]] == ranked["variant"].iloc[:10].tolist()
    assert rows[-1]["class"] == "ref" and rows[-1]["variant"] == ref
    assert f"data-place='{int(ranked['rank'].iloc[3])}'" in text

    def shown(row, m):
        if units == "model":
            return row[m]
        return {"travel": row["travel"] * UNIT, "speed": row["travel"] * UNIT * RPM / 60,
                "bob": row["bob"] * UNIT * 1000, "clearance": row["clearance"] * UNIT * 1000,
                "peak_torque": row["peak_torque"] * LOAD * G * row["crank"] * UNIT,
                "body_speed_ripple": row["body_speed_ripple"]}[m]

    keys = ["travel", "bob", "body_speed_ripple", "peak_torque", "clearance"] + (["speed"] if units == "si" else [])
    r0 = df.iloc[ref]
    for r in rows:
        assert sorted(r["cells"]) == sorted(keys)
        row = df.iloc[r["variant"]]
        for m in keys:
            x, x0 = shown(row, m), shown(r0, m)
            got, change = r["cells"][m]
            assert got == pytest.approx(x, rel=1e-12), (r["variant"], m)
            assert change == pytest.approx(100 * (x - x0) / abs(x0), rel=1e-9, abs=1e-9), (r["variant"], m)
    # the verdict of design #1 against the reference quotes the numbers of the table
    verdict = htmlmod.unescape(re.search(r"<p class='note' id='vs-verdict'>(.*?)</p>", text).group(1))
    best = df.iloc[rows[0]["variant"]]
    assert f"bob {shown(best, 'bob'):.4g} vs {shown(r0, 'bob'):.4g}" in verdict
    # the axes table gives the reference's value; the page's data names it and its units
    data = json.loads(re.search(r'<script type="application/json" id="report-data">(.*?)</script>', text,
                                re.S).group(1).replace("<\\/", "</"))
    assert data["reference"]["variant"] == ref and data["units"] == units
    col = {c["key"]: c for c in data["columns"]}
    assert col["bob"]["unit"] == ("mm" if units == "si" else "model units")
    assert col["bob"]["reference"] == pytest.approx(shown(r0, "bob"), rel=1e-12)
    assert data["nominal"]["bob"] == pytest.approx(shown(r0, "bob"), rel=1e-12)  # the starred design: the reference
    cell = re.search(r"<tr data-key='bob'>.*?<td class='num'>([^<]*)</td>", text).group(1)
    assert cell == f"{shown(r0, 'bob'):.6g}"
    if units == "si":
        assert "speed" in col and col["speed"]["unit"] == "m/s" and col["3-4"]["unit"] == "mm"


def test_report_cli_takes_vs_and_units(files, tmp_path, capsys):
    out = tmp_path / "r.html"
    ok_cli(capsys, "report", files["si"], "-o", out, "--vs", 3, "--units", "si", "--paths", "3")
    rows = _vs_rows(out.read_text(encoding="utf-8"))
    assert rows[-1]["class"] == "ref" and rows[-1]["variant"] == 3
    code, _, err = cli(capsys, "report", files["si"], "-o", tmp_path / "x.html", "--vs", 999)
    assert code == 2 and err.count("\n") == 1 and "999" in err


# -- the conversion itself ---------------------------------------------------------------------------------
def test_to_si_leaves_si_and_dimensionless_metrics_alone():
    """The forces group (already N, N·m, W …) and ratios pass through; gravity 0 leaves the torque
    metrics per weight × crank radius and says so."""
    from explorer.gait import to_si
    from explorer.mechanism import Operating
    df = pd.DataFrame({"crank": [10.0, 12.0], "travel": [100.0, 90.0], "bob": [0.5, 0.7], "peak_torque": [0.1, 0.2],
                       "motor_torque_peak": [3.0, 4.0], "pin_force.2": [50.0, 60.0], "slip": [0.01, 0.02]})
    names = ["travel", "bob", "peak_torque", "motor_torque_peak", "pin_force.2", "slip"]
    out = to_si(df, names, Operating(unit=0.02, rpm=30.0, load=2.0, gravity=9.81))
    np.testing.assert_allclose(out.frame["peak_torque"], df["peak_torque"] * 2.0 * 9.81 * df["crank"] * 0.02)
    np.testing.assert_allclose(out.frame["speed"], df["travel"] * 0.02 * 30.0 / 60.0)
    for c in ("motor_torque_peak", "pin_force.2", "slip"):
        np.testing.assert_array_equal(out.frame[c], df[c])
    assert out.units["motor_torque_peak"] == "N·m" and out.units["pin_force.2"] == "N"
    assert sorted(out.converted) == ["bob", "peak_torque", "speed", "travel"] and not out.notes
    off = to_si(df, names, Operating(unit=0.02, load=2.0, gravity=0.0))
    np.testing.assert_array_equal(off.frame["peak_torque"], df["peak_torque"])
    assert "speed" not in off.frame.columns and len(off.notes) == 2 and "gravity" in off.notes[0]
