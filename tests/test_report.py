"""`explorer report RESULTS -o report.html`: one self-contained interactive page, checked in a real browser.

Every number the page shows is checked against a reference computed here from the results frame with
plain pandas/numpy, never against the report's own helpers:

* without a browser: the counts by reason in the page's table (status counts for the failed designs,
  the frame's ``screen`` text split into its checks for the screened-out ones); the page loads nothing
  from the network (no ``<script src=…>``, no stylesheet link); a study above ``max_designs`` is sampled
  deterministically and the page says so with the numbers; the CLI refuses to overwrite without
  ``--force`` and gives one line and exit 2 for a bad RESULTS path or output folder.
* in headless Chromium (Debian's ``chromium`` and ``chromium-driver``, through selenium): the page
  loads with no SEVERE console message; the best selected designs' table gives each one's change
  against the nominal in % and ends with the nominal's row, marked; it shows as many designs as the frame has ok rows; the Pareto
  front it draws has as many designs as a brute-force dominance count; a scripted brush on the
  parallel coordinates (``Plotly.restyle`` of a ``constraintrange``), then a box selection in the
  scatter (``Plotly.relayout`` of ``selections``, which plotly turns into its selection event), change
  the selected count to what pandas counts; "clear every brush" restores it; "show" on a reason lists
  that reason's variants.

The browser tests skip, naming the install command, only where no Chromium or chromedriver is found.
"""

from __future__ import annotations

import html as htmlmod
import json
import re

import numpy as np
import pandas as pd
import pytest

import explorer
from browser import chromium, wait
from explorer.cli import main
from explorer.view import write_report

METRICS = ["travel", "bob", "stride", "clearance", "max_speed", "self_crossings"]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """80 Jansen variants, four links and the crank within ±7 %: some cannot assemble, some fail the
    screen (several checks at once for some)."""
    root = tmp_path_factory.mktemp("report")
    out = explorer.run_study({"study": {"name": "rep", "mechanism": "jansen", "variants": 80, "seed": 5, "steps": 48},
                              "perturb": {"method": "uniform", "spread": 0.07, "links": ["2-3", "3-4", "4-5", "5-6"]},
                              "scene": {"metrics": True}}, output=root / "rep.h5", progress=False).path
    with explorer.open_results(out) as res:
        df = res.frame()
    return out, df, root


@pytest.fixture(scope="module")
def page(study):
    path, df, root = study
    out = root / "report.html"
    rep = write_report(path, out, metrics=METRICS)
    return out, rep


def _table_counts(text: str) -> dict:
    return {htmlmod.unescape(k): int(v) for k, v in re.findall(r"<tr data-reason='([^']*)' data-count='(\d+)'", text)}


def _data(text: str) -> dict:
    m = re.search(r'<script type="application/json" id="report-data">(.*?)</script>', text, re.S)
    return json.loads(m.group(1).replace("<\\/", "</"))


def _expected_counts(df: pd.DataFrame) -> dict:
    ok = df["status"].astype(str) == "ok"
    screen = df["screen"].astype(str)
    out = {"ok, buildable": int((ok & (screen == "pass")).sum())}
    screened = ok & (screen != "pass")
    out["screened out (any check)"] = int(screened.sum())
    checks: dict = {}
    for reasons in screen[screened]:
        for part in reasons.split("; "):
            name = part.split(":")[0]
            checks[name] = checks.get(name, 0) + 1
    out.update({f"screened out: {k}": v for k, v in checks.items()})
    for status, n in df.loc[~ok, "status"].astype(str).value_counts().items():
        out["not run yet" if status == "not-run" else f"failed: {status}"] = int(n)
    return out


# -- the page as a file ------------------------------------------------------------------------------------
def test_counts_by_reason_match_the_frame(study, page):
    _, df, _ = study
    out, rep = page
    text = out.read_text(encoding="utf-8")
    expected = _expected_counts(df)
    assert expected["failed: assembly"] > 0 and expected["screened out (any check)"] > 0  # the study has both
    assert sum(1 for k in expected if k.startswith("screened out: ")) >= 2
    assert _table_counts(text) == expected
    assert rep.n_designs == rep.n_ok == int((df["status"].astype(str) == "ok").sum()) and not rep.sampled
    assert rep.n_variants == len(df)
    # the variants listed for a reason are that reason's, lowest numbers first
    data = _data(text)
    failed = df.loc[df["status"].astype(str) == "assembly", "variant"].tolist()
    entry = next(r for r in data["reasons"] if r["key"] == "failed: assembly")
    assert entry["variants"] == failed[:len(entry["variants"])] and entry["count"] == len(failed)


def test_page_is_self_contained(page):
    out, rep = page
    text = out.read_text(encoding="utf-8")
    assert rep.bytes == out.stat().st_size
    assert '<script src="http' not in text
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, re.I)  # plotly.js and the glue are inline
    assert not re.search(r"<link[^>]*\bhref\s*=\s*['\"]?(https?:)?//", text, re.I)
    assert "Plotly" in text and text.count("<html") == 1


def test_sampled_above_the_cap_deterministically(study):
    path, df, root = study
    n_ok = int((df["status"].astype(str) == "ok").sum())
    a = write_report(path, root / "a.html", max_designs=25, paths=10, seed=3)
    write_report(path, root / "b.html", max_designs=25, paths=10, seed=3)
    ta, tb = (root / "a.html").read_text(encoding="utf-8"), (root / "b.html").read_text(encoding="utf-8")
    assert a.sampled and a.n_designs == 25 and a.n_ok == n_ok
    assert _data(ta)["variant"] == _data(tb)["variant"]  # the same sample for the same seed
    v = np.frombuffer(__import__("base64").b64decode(_data(ta)["variant"]), dtype="<i4")
    ok_variants = set(df.loc[df["status"].astype(str) == "ok", "variant"])
    assert len(set(v)) == 25 and set(v) <= ok_variants
    note = re.search(r"<p class='warn' id='sample-note'>(.*?)</p>", ta, re.S).group(1)
    assert f"{n_ok:,} ok designs" in note and "sample of 25" in note and "seed 3" in note
    assert _table_counts(ta) == _expected_counts(df)  # counts are over every variant, not the sample


def test_cli_writes_and_refuses_to_overwrite(study, tmp_path, capsys):
    path, df, _ = study
    out = tmp_path / "r.html"
    assert main(["report", str(path), "-o", str(out), "--metrics", "travel,bob", "--paths", "5"]) == 0
    said = capsys.readouterr().out
    n_ok = int((df["status"].astype(str) == "ok").sum())
    assert said.startswith(f"wrote {out}") and f"{n_ok:,} designs" in said
    before = out.read_bytes()
    code = main(["report", str(path), "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "--force" in err and str(out) in err
    assert out.read_bytes() == before
    assert main(["report", str(path), "-o", str(out), "--force", "--metrics", "bob,travel"]) == 0
    assert out.read_bytes() != before
    capsys.readouterr()


def test_cli_defaults_are_the_modules():
    from explorer.testing import cli_report as cli
    from explorer.testing import view_report as view
    for name in ("DEFAULT_MAX_DESIGNS", "DEFAULT_PC_LINES", "DEFAULT_PATHS", "DEFAULT_SHOWN", "DEFAULT_POINTS"):
        assert getattr(cli, name) == getattr(view, name), name


@pytest.mark.parametrize("argv, words", [
    (["report", "{t}/missing.h5", "-o", "{t}/r.html"], ["missing.h5", "no such results file"]),
    (["report", "{r}", "-o", "{r}/r.html"], ["is not a folder"]),
    (["report", "{r}", "-o", "{t}/r.png"], ["r.png", ".html"]),
    (["report", "{r}", "-o", "{t}/r.html", "--metrics", "travel,nope"], ["nope", "not stored"]),
    (["report", "{r}", "-o", "{t}/r.html", "--scatter", "travel"], ["--scatter", "two metrics"]),
])
def test_cli_errors_are_one_line_exit_2(study, tmp_path, capsys, argv, words):
    path, _, _ = study
    code = main([a.format(r=path, t=tmp_path) for a in argv])
    err = capsys.readouterr().err
    assert code == 2 and err.startswith("explorer: error: ") and err.count("\n") == 1, err
    for w in words:
        assert w in err, err
    assert not (tmp_path / "r.html").exists()


# -- --where: the views hold the ok designs the filter keeps (issue 40's vocabulary) -------------------------
def _where(df: pd.DataFrame):
    """A filter on bob at its median over the ok designs, and the variants plain pandas says it keeps."""
    ok = df[df["status"].astype(str) == "ok"]
    cut = float(np.median(ok["bob"]))
    kept = ok.loc[(ok["bob"] < cut) & (ok["stride"] > 0), "variant"]
    return f"bob < {cut!r} and stride > 0", set(int(v) for v in kept)


def test_where_keeps_the_designs_the_filter_keeps_and_says_so(study):
    path, df, root = study
    expr, kept = _where(df)
    n_ok = int((df["status"].astype(str) == "ok").sum())
    assert 0 < len(kept) < n_ok
    rep = write_report(path, root / "where.html", where=expr, paths=5)
    text = (root / "where.html").read_text(encoding="utf-8")
    v = np.frombuffer(__import__("base64").b64decode(_data(text)["variant"]), dtype="<i4")
    assert set(v.tolist()) == kept and len(v) == len(kept)
    assert rep.where == expr and rep.n_kept == rep.n_designs == len(kept) and rep.n_ok == n_ok and not rep.sampled
    note = htmlmod.unescape(re.search(r"<p class='warn' id='where-note'>(.*?)</p>", text, re.S).group(1))
    assert expr in note and f"{len(kept):,} of the {n_ok:,} ok" in note
    assert _table_counts(text) == _expected_counts(df)  # the counts by reason stay over every variant
    # sampled from the kept designs only
    few = write_report(path, root / "where-few.html", where=expr, max_designs=3, paths=0, seed=1)
    v = np.frombuffer(__import__("base64").b64decode(_data((root / "where-few.html").read_text("utf-8"))["variant"]),
                      dtype="<i4")
    assert few.sampled and len(v) == 3 and set(v.tolist()) <= kept


def test_cli_where(study, tmp_path, capsys):
    path, df, _ = study
    expr, kept = _where(df)
    out = tmp_path / "w.html"
    assert main(["report", str(path), "-o", str(out), "--where", expr, "--paths", "5"]) == 0
    said = capsys.readouterr().out
    assert said.startswith(f"wrote {out}") and f"{len(kept):,} designs in the views (where {expr}: " in said
    for bad, words in (("bob <", ["bob <"]), ("nope > 1", ["nope"]), ("bob < -1e9", ["keeps none"]),
                       ("__import__('os')", ["__import__"])):
        code = main(["report", str(path), "-o", str(tmp_path / "bad.html"), "--where", bad])
        err = capsys.readouterr().err
        assert code == 2 and err.startswith("explorer: error: ") and err.count("\n") == 1, err
        for w in words:
            assert w in err, err
        assert not (tmp_path / "bad.html").exists()


# -- in a real browser ---------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def browser():
    drv = chromium("1400,1600")  # (skips, naming the install command, where there is no browser)
    yield drv
    drv.quit()


_wait = wait


def _count(drv, el):
    return int(drv.execute_script(f"return document.getElementById('{el}').getAttribute('data-count')"))


def _front_size(x: np.ndarray, y: np.ndarray, dx: str, dy: str) -> int:
    """Designs no other dominates (at least as good in both, better in one), by brute force."""
    cx = -x if dx == "max" else x
    cy = -y if dy == "max" else y
    le = (cx[None, :] <= cx[:, None]) & (cy[None, :] <= cy[:, None])
    lt = (cx[None, :] < cx[:, None]) | (cy[None, :] < cy[:, None])
    return int((~(le & lt).any(axis=1)).sum())


def _between(v: np.ndarray, q_lo: float, q_hi: float) -> tuple[float, float]:
    """A range whose ends lie half-way between neighbouring values of v, near quantiles q_lo, q_hi."""
    u = np.unique(v)
    i, j = int(q_lo * (len(u) - 1)), int(q_hi * (len(u) - 1))
    return float((u[i] + u[i + 1]) / 2), float((u[j] + u[j + 1]) / 2)


def test_report_in_headless_chromium(study, page, browser):
    _, df, _ = study
    out, _ = page
    drv = browser
    drv.get(out.as_uri())
    assert _wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
    severe = [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe

    ok = df[df["status"].astype(str) == "ok"]
    n = len(ok)
    text = drv.execute_script("return document.getElementById('n-designs').textContent")
    assert int(text.replace(",", "")) == n == _count(drv, "n-designs")
    assert _count(drv, "n-selected") == n
    # values as the page holds them (float32)
    f32 = {m: ok[m].to_numpy(dtype=np.float64).astype(np.float32) for m in ("travel", "bob", "stride")}
    build = ok["buildable"].to_numpy(dtype=bool)
    assert _count(drv, "n-front") == _front_size(f32["travel"][build], f32["bob"][build], "max", "min")

    # a brush on the stride axis of the parallel coordinates
    lo, hi = _between(f32["stride"], 0.3, 0.8)
    in_stride = (f32["stride"] >= lo) & (f32["stride"] <= hi)
    assert 0 < in_stride.sum() < n
    drv.execute_script("""
        var gd = document.getElementById('parcoords');
        var k = gd.data[0].dimensions.findIndex(function (d) { return d.label.startsWith('stride'); });
        var u = {}; u['dimensions[' + k + '].constraintrange'] = [[arguments[0], arguments[1]]];
        Plotly.restyle(gd, u, [0]);""", lo, hi)
    assert _wait(drv, "return document.getElementById('n-selected').getAttribute('data-count')",
                 str(int(in_stride.sum()))) == str(int(in_stride.sum()))
    keep = in_stride & build
    assert _count(drv, "n-front") == _front_size(f32["travel"][keep], f32["bob"][keep], "max", "min")

    # then a box in the scatter (travel against bob): both filters hold
    x0, x1 = _between(f32["travel"], 0.2, 0.9)
    y0, y1 = _between(f32["bob"], 0.1, 0.7)
    in_box = (f32["travel"] >= x0) & (f32["travel"] <= x1) & (f32["bob"] >= y0) & (f32["bob"] <= y1)
    want = int((in_box & in_stride).sum())
    assert want not in (0, int(in_stride.sum()))
    drv.execute_script("""Plotly.relayout(document.getElementById('scatter'), {selections: [{type: 'rect',
        xref: 'x', yref: 'y', x0: arguments[0], x1: arguments[1], y0: arguments[2], y1: arguments[3]}]});""",
                       x0, x1, y0, y1)
    assert _wait(drv, "return document.getElementById('n-selected').getAttribute('data-count')", str(want)) == str(want)
    # the foot-path view draws the selected designs' paths (at most 50; this page holds every design's path)
    drawn = drv.execute_script("var d = document.getElementById('feet').data[1];"
                               "return [d.x.filter(function (v) { return v === null; }).length, d.customdata];")
    assert drawn[0] == min(50, want)
    assert set(v for v in drawn[1] if v is not None) <= set(ok.loc[in_box & in_stride, "variant"])
    # the best selected designs listed are the selection's
    listed = drv.execute_script("return Array.from(document.querySelectorAll('#best tr:not(.ref)')).slice(1)"
                                ".map(function (tr) { return Number(tr.cells[0].textContent); })")
    chosen = set(ok.loc[in_box & in_stride, "variant"])
    assert listed and set(listed) <= chosen
    # ... each with its change against the reference (the nominal), which closes the table, marked
    best = drv.execute_script("var rows = document.querySelectorAll('#best tr');"
                              "return [rows[1].cells[0].textContent, rows[1].cells[3].textContent,"
                              " rows[rows.length - 1].className, rows[rows.length - 1].cells[0].textContent];")
    assert best[2] == "ref" and best[3] == "nominal (0)"
    x, x0 = float(ok.loc[ok["variant"] == int(best[0]), "travel"].astype(np.float32).iloc[0]), float(df.iloc[0]["travel"])
    assert float(best[1].rstrip(" %")) == pytest.approx(100 * (x - x0) / abs(x0), abs=0.051)

    # clear every brush
    drv.find_element("id", "reset").click()
    assert _wait(drv, "return document.getElementById('n-selected').getAttribute('data-count')", str(n)) == str(n)

    # a reason, shown: its variants listed
    failed = df.loc[df["status"].astype(str) == "assembly", "variant"].tolist()
    drv.execute_script("document.querySelector(\"#reasons tr[data-reason='failed: assembly'] button\").click()")
    listed = _wait(drv, "return document.getElementById('reason-variants').textContent",
                   "failed: assembly: variants " + ", ".join(map(str, failed)))
    assert listed == "failed: assembly: variants " + ", ".join(map(str, failed))
    severe = [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe


def test_where_page_in_headless_chromium(study, tmp_path, browser):
    """The filtered page loads clean, counts the designs pandas keeps and says the filter."""
    path, df, _ = study
    expr, kept = _where(df)
    out = tmp_path / "where.html"
    write_report(path, out, where=expr, metrics=METRICS, paths=5)
    drv = browser
    drv.get(out.as_uri())
    assert _wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
    severe = [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
    assert not severe, severe
    assert _count(drv, "n-designs") == _count(drv, "n-selected") == len(kept)
    note = drv.execute_script("return document.getElementById('where-note').textContent")
    assert expr in note and note.startswith("Filtered:")
    summary = drv.execute_script("return document.getElementById('summary').textContent")
    assert f"the ok ones where {expr}" in " ".join(summary.split())


# -- the force axes: scaled to the buildable designs, their end labels apart (issue 40) ---------------------
@pytest.fixture(scope="module")
def forces_page(tmp_path_factory):
    """300 plywood Jansen walkers within ±3 %, with forces: a few screened-out designs near a toggle reach
    motor torques 20 times the buildable ones'."""
    root = tmp_path_factory.mktemp("report-forces")
    out = explorer.run_study({"study": {"name": "repf", "mechanism": "studies/mechanisms/jansen-plywood.toml",
                                        "variants": 300, "seed": 1, "steps": 72},
                              "perturb": {"method": "uniform", "spread": 0.03},
                              "scene": {"metrics": True, "forces": True},
                              "walker": {"legs": 4, "mirrored": True, "drag": 0.1}},
                             output=root / "repf.h5", progress=False).path
    with explorer.open_results(out) as res:
        df = res.frame()
    page = root / "report.html"
    write_report(out, page)
    return df, page


@pytest.mark.slow
def test_force_axes_span_the_buildable_designs_and_say_what_is_off_scale(forces_page, browser):
    """The report's motor-torque axis was scaled by screened-out near-toggle designs (2,192 N·m against
    8.1 for the buildable ones), so every buildable design sat in its bottom pixels. Each force axis now
    spans the buildable designs (checked against pandas' min and max of the frame), the page lists what
    lies beyond with the counts pandas gives, and in headless Chromium no axis' end label runs into its
    neighbour's."""
    df, page = forces_page
    ok = df[df["status"].astype(str) == "ok"]
    build = ok["buildable"].to_numpy(dtype=bool)
    text = page.read_text()
    data = _data(text)
    fig = json.loads(re.search(r"<script type='application/json' id='fig-parcoords'>(.*?)</script>", text, re.S)
                     .group(1).replace("<\\/", "</"))
    dims = {d["label"].split(" ")[0]: d for d in fig["data"][0]["dimensions"]}
    note = htmlmod.unescape(re.search(r"<p class='note' id='off-scale-note'>(.*?)</p>", text, re.S).group(1))
    for m in ("motor_torque_peak", "motor_power_peak", "pin_force_max"):
        v = ok[m].to_numpy(dtype=np.float64)
        lo, hi = v[build].min(), v[build].max()
        assert v.max() > 5 * hi                               # the near-toggle designs the screen removed
        a, b = dims[m]["range"]
        assert a <= lo < hi <= b and b - a <= 1.05 * (hi - lo)   # the buildable designs fill the axis
        off = int(((v < a) | (v > b)).sum())
        assert off > 0 and f"{m} ({off:,} designs, up to {v.max():.4g}" in note
        col = next(c for c in data["columns"] if c["key"] == m)
        assert col["clip"] == [a, b]
    # the screen's own inputs keep their whole span: they show why designs were screened out
    assert "range" not in dims["max_speed"] and "range" not in dims["min_transmission_angle"]

    drv = browser
    drv.get(page.as_uri())
    assert _wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
    boxes = drv.execute_script("""
      return ['axis-extent-top-text', 'axis-extent-bottom-text'].map(function (cls) {
        return Array.from(document.querySelectorAll('#parcoords .' + cls)).map(function (e) {
          var r = e.getBoundingClientRect(); return [e.textContent, r.left, r.right]; }); });""")
    assert all(len(side) >= 40 for side in boxes)
    for side in boxes:
        side = sorted((b for b in side if b[0]), key=lambda b: b[1])
        clash = [(a[0], b[0]) for a, b in zip(side, side[1:]) if a[2] > b[1]]
        assert not clash, clash
    # a brush on the top end of the motor-torque axis keeps the designs beyond it (drawn there)
    v = ok["motor_torque_peak"].to_numpy(dtype=np.float64).astype(np.float32)
    a, b = dims["motor_torque_peak"]["range"]
    lo = float(np.quantile(v[build], 0.9))
    drv.execute_script("""
        var gd = document.getElementById('parcoords');
        var k = gd.data[0].dimensions.findIndex(function (d) { return d.label.startsWith('motor_torque_peak'); });
        var u = {}; u['dimensions[' + k + '].constraintrange'] = [[arguments[0], arguments[1]]];
        Plotly.restyle(gd, u, [0]);""", lo, b)
    want = str(int((v >= np.float32(lo)).sum()))
    assert _wait(drv, "return document.getElementById('n-selected').getAttribute('data-count')", want) == want
    assert not [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]
