"""``explorer rank``, ``explorer show`` and ``explorer metrics``: output formats checked against the API and the
frame, recomputation without re-solving, and every error path (exit 2, one line on stderr).

Most calls go through ``explorer.cli.main`` in-process (a process start costs seconds of imports); one
test runs the real command.
"""

from __future__ import annotations

import io
import json
import math
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pandas as pd
import pytest

from explorer import open_results, run_study
from explorer.cli import main

from clihelp import cli, ok_cli
from explorer.gait import DEFAULT_WEIGHTS, WALKER_METRICS, DIRECTIONS, TARGET_METRICS
from explorer.gait import BY_NAME, FORCE_METRICS, ROBUSTNESS_METRICS
from explorer.gait import METRICS as ALL_METRICS

#: every metric a leg study stores (path synthesis's path_error needs a [target] path, the forces effect's
#: need [scene] forces)
METRICS = tuple(m for m in ALL_METRICS if m not in TARGET_METRICS and m not in FORCE_METRICS
                and m not in ROBUSTNESS_METRICS and BY_NAME[m].group not in ("slider", "physics"))  # slider: a foot on a slider; physics: `explorer physics`

STUDY = {
    "study": {"name": "clirank", "mechanism": "jansen", "variants": 40, "seed": 11, "steps": 36},
    "perturb": {"method": "uniform", "spread": 0.04, "links": "all", "crank": True},
    "scene": {"vertices": ["7"], "velocities": True, "metrics": True},
}


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    path = tmp_path_factory.mktemp("clirank") / "r.h5"
    run_study(STUDY, output=path, progress=False, chunk_size=16)
    with open_results(path) as res:
        assert 10 <= res.status_counts()["ok"] < 40
    return path


@pytest.fixture
def fresh(results, tmp_path):
    p = tmp_path / "copy.h5"
    shutil.copyfile(results, p)
    return p


def parse_table(out: str) -> tuple[list[str], pd.DataFrame]:
    """(header lines, table) of `explorer rank` table output: text lines, a blank line, aligned columns."""
    head, _, body = out.partition("\n\n")
    lines = body.strip("\n").splitlines()
    cols = lines[0].split()
    rows = [ln.split() for ln in lines[1:]]
    assert all(len(r) == len(cols) for r in rows), out
    # the last row is the reference design ("nominal:R" or "reference:R"), not one of the ranked rows
    assert ":" in rows[-1][0], out
    return head.splitlines(), pd.DataFrame(rows[:-1], columns=cols)


# -- rank --------------------------------------------------------------------------------------------------
def test_rank_table(results, capsys):
    out = ok_cli(capsys, "rank", results, "--by", "stride", "--include-screened")
    head, table = parse_table(out)
    with open_results(results) as res:
        api = res.rank(by="stride", top=10, include_screened=True)
        n_ok = res.status_counts()["ok"]
        removed = res.screen_summary()["removed"]
    assert head[0] == f"{results}: ranked by stride (higher is better)"
    assert head[1].startswith(f"{n_ok} ok of 40 variants; {n_ok} ranked; showing 10")
    assert head[2].startswith(f"buildability screen: not applied (--include-screened); it would remove {removed}")
    assert list(table.columns[:3]) == ["rank", "variant", "stride"] and table.columns[-1] == "screen"
    assert set(table.columns) == {"rank", "variant", "stride", "screen", "tightest", "margin%"} | set(WALKER_METRICS)
    assert list(table["rank"].astype(int)) == list(range(1, 11))
    assert list(table["variant"].astype(int)) == list(api["variant"])
    for m in WALKER_METRICS:  # shown to 5 significant digits of the column's largest value
        shown = table[m].astype(float).to_numpy()
        big = np.nanmax(np.abs(api[m].to_numpy()))
        atol = 0.5001 * 10 ** (math.floor(math.log10(big)) - 4)
        np.testing.assert_allclose(shown, api[m].to_numpy(), rtol=0, atol=atol)
    # the default: the walker score over the buildable variants, the screen's count in the header
    head, table = parse_table(ok_cli(capsys, "rank", results))
    with open_results(results) as res:
        api = res.rank(top=10)
    assert head[0].startswith(f"{results}: the walker score (1 = best")
    assert head[1].startswith(f"{n_ok} ok of 40 variants; {n_ok - removed} ranked")
    assert head[2].startswith(f"buildability screen removed {removed} ok variants")
    assert list(table.columns[:3]) == ["rank", "variant", "score"] and table.columns[-1] == "status"
    assert list(table["variant"].astype(int)) == list(api["variant"])
    # the ranking metrics come first, in the order given
    _, t = parse_table(ok_cli(capsys, "rank", results, "--pareto", "flatness,stride", "--top", "0"))
    assert list(t.columns[:4]) == ["rank", "variant", "flatness", "stride"]
    _, t = parse_table(ok_cli(capsys, "rank", results, "--weights", "duty=1,flatness=3", "--top", "4"))
    assert list(t.columns[:5]) == ["rank", "variant", "score", "duty", "flatness"] and len(t) == 4
    _, t = parse_table(ok_cli(capsys, "rank", results, "--by", "flatness", "--top", "3", "--columns", "crank,1-3"))
    assert list(t.columns) == ["rank", "variant", "flatness", "crank", "1-3"]


def test_rank_csv_round_trips_to_the_api_ranking(results, capsys):
    cases = [(["--by", "flatness", "--top", "7"], dict(by="flatness", top=7)),
             # csv and json carry every row unless --top is given
             (["--by", "stride", "--ascending", "--where", "duty > 0.2"], dict(by="stride", ascending=True,
                                                                                 where="duty > 0.2", top=None)),
             (["--pareto", "stride,speed_ripple", "--top", "0"], dict(pareto="stride,speed_ripple", top=None)),
             (["--weights", "stride=2,flatness=1"], dict(weights={"stride": 2.0, "flatness": 1.0}, top=None)),
             (["--by", "duty", "--include-failed", "--top", "0"], dict(by="duty", include_failed=True, top=None))]
    with open_results(results) as res:
        for argv, kw in cases:
            api = res.rank(**kw)
            got = pd.read_csv(io.StringIO(ok_cli(capsys, "rank", results, "--format", "csv", *argv)))
            assert list(got.columns) == [str(c) for c in api.columns], argv
            assert list(got["variant"]) == list(api["variant"]) and list(got["rank"]) == list(api["rank"]), argv
            for c in [m for m in METRICS if m in api.columns] + list(res.link_names) + ["crank"] + (["score"] if "score" in api else []):
                np.testing.assert_array_equal(got[c].to_numpy(dtype=float), api[c].to_numpy(dtype=float), err_msg=c)
            assert list(got["status"]) == [str(s) for s in api["status"]]


def test_rank_json(results, capsys):
    data = json.loads(ok_cli(capsys, "rank", results, "--format", "json", "--by", "max_speed", "--top", "0",
                             "--include-failed", "--include-screened"))
    with open_results(results) as res:
        api = res.rank(by="max_speed", top=None, include_failed=True, include_screened=True)
    assert isinstance(data, list) and len(data) == 40
    assert [r["variant"] for r in data] == list(api["variant"])
    assert list(data[0]) == [str(c) for c in api.columns]
    first, last = data[0], data[-1]
    assert first["status"] == "ok" and first["max_speed"] == api["max_speed"].iloc[0]
    assert first["fail_theta"] is None and first["fail_vertex"] is None
    assert last["status"] != "ok" and last["max_speed"] is None and isinstance(last["fail_theta"], float)
    assert data[0]["max_speed"] <= data[1]["max_speed"]  # lower is better
    assert json.loads(ok_cli(capsys, "rank", results, "--format", "json", "--where", "stride > 1e9")) == []


def test_rank_empty_table(results, capsys):
    out = ok_cli(capsys, "rank", results, "--where", "stride > 1e9")
    assert "0 match where stride > 1e9" in out and "(no variant to show)" in out


# -- show --------------------------------------------------------------------------------------------------
def test_show_ok_variant(results, capsys):
    with open_results(results) as res:
        df = res.frame()
        nominal = res.nominal
        links = res.link_names
    ok = df["status_code"].to_numpy() == 0
    v = int(np.flatnonzero(ok)[1])  # an ok variant other than the nominal
    out = ok_cli(capsys, "show", results, "--variant", v)
    lines = out.splitlines()
    assert lines[0].startswith(f"{results}: variant {v} of 40;") and lines[1] == "status: ok"
    row = df.iloc[v]
    for p in list(links) + ["crank"]:
        label = p if p == "crank" else f"link {p}"
        line = next(ln for ln in lines if ln.startswith(label + " "))
        val, nom = row[p], nominal[p]
        assert line.split() == label.split() + [f"{val:.4f}", f"{nom:.4f}", f"{val - nom:+.4f}",
                                                f"{100 * (val - nom) / nom:+.3f}", "%"]
    # ranks among the variants `explorer rank` ranks: ok and passing the buildability screen
    ranked = ok & df["buildable"].to_numpy(dtype=bool) if "buildable" in df.columns else ok
    ref = df.iloc[0]
    for m in METRICS:
        line = next(ln for ln in lines if ln.startswith(m + " "))
        x = row[m]
        cells = line.split()
        assert cells[1] == f"{x:.6g}" and cells[2] == f"{ref[m]:.6g}", line
        assert cells[3] == f"{x - ref[m]:+.4g}", line  # the change against the nominal, then in %
        if ref[m] != 0:
            assert cells[4] == f"{100 * (x - ref[m]) / abs(ref[m]):+.1f}", line
        pool_mask = ranked & np.isfinite(df[m].to_numpy(dtype=float))
        if not ranked[v]:
            assert "screened out" in line
            continue
        vals = df.loc[pool_mask, m].to_numpy()
        better = (vals > x) if DIRECTIONS[m] == "max" else (vals < x)
        r = int(better.sum()) + 1
        how = "higher is better" if DIRECTIONS[m] == "max" else "lower is better"
        assert line.endswith(f"rank {r} of {int(pool_mask.sum())} ({how})"), line
    # the walker score and its rank are those of `explorer rank` (the same set, the same score)
    with open_results(results) as res:
        scored = res.rank(top=None)
    if ranked[v]:
        s = scored[scored["variant"] == v].iloc[0]
        assert f"walker score {s['score']:.3f}, rank {int(s['rank'])} of {len(scored)} buildable variants" in out
    # the best stride is rank 1
    best = int(df.loc[ranked].sort_values(["stride", "variant"], ascending=[False, True])["variant"].iloc[0])
    assert "rank 1 of" in next(ln for ln in ok_cli(capsys, "show", results, "--variant", best).splitlines()
                               if ln.startswith("stride "))
    assert "(the nominal design)" in ok_cli(capsys, "show", results, "--variant", 0).splitlines()[0]


def test_show_failed_variant(results, capsys):
    with open_results(results) as res:
        df = res.frame()
    v = int(np.flatnonzero(df["status_code"].to_numpy() != 0)[0])
    row = df.iloc[v]
    out = ok_cli(capsys, "show", results, "--variant", v)
    th = row["fail_theta"]
    assert out.splitlines()[1] == (f"status: failed ({row['status']}) at θ = {th:.4f} rad ({math.degrees(th):.2f}°), "
                                   f"vertex {row['fail_vertex']}")
    assert out.count("- (variant failed)") == len(METRICS)


# -- metrics -----------------------------------------------------------------------------------------------
def naive_duty(y, band):
    S = len(y)
    q = y <= y.min() + band * (y.max() - y.min())
    if q.all():
        return 1.0
    best = 0
    for s in range(S):
        n = 0
        while q[(s + n) % S] and n < S:
            n += 1
        best = max(best, n)
    return best / S


def test_metrics_band_recomputes_without_touching_paths(fresh, capsys):
    with h5py.File(fresh, "r") as f:
        before = {g: f[g]["7"][...].tobytes() for g in ("paths", "velocities")}
    out = ok_cli(capsys, "metrics", fresh, "--band", "0.04")
    assert out.startswith(f"{fresh}: computed {len(METRICS)} metrics (") and "with band 0.04" in out
    assert "for 40 variants" in out
    with h5py.File(fresh, "r") as f:
        assert {g: f[g]["7"][...].tobytes() for g in ("paths", "velocities")} == before
        assert f["metrics"].attrs["band"] == 0.04
    with open_results(fresh) as res:
        df = res.frame()
        ok = np.flatnonzero(df["status_code"].to_numpy() == 0)
        for v in ok:
            path = res.path(int(v))
            assert df["duty"].iloc[v] == naive_duty(path[:, 1], 0.04)
            assert df["height"].iloc[v] == np.ptp(path[:, 1])
    # rank and show pick up the new band and values
    with open_results(fresh) as res:
        api = res.rank(by="duty", top=3)
    got = pd.read_csv(io.StringIO(ok_cli(capsys, "rank", fresh, "--by", "duty", "--top", "3", "--format", "csv")))
    assert list(got["variant"]) == list(api["variant"])
    assert "(band 0.04)" in ok_cli(capsys, "show", fresh, "--variant", 0)
    # a subset with another band: the other stance metrics follow, the rest are kept
    out = ok_cli(capsys, "metrics", fresh, "--band", "0.02", "--metrics", "flatness")
    assert "computed 1 metric (flatness)" in out and "also recomputed stride, duty," in out
    assert ("kept travel, bob, body_speed_ripple, peak_torque, torque_ripple, clearance, slip, contact_fraction, "
            "width, height, max_speed, min_transmission_angle, foot_headroom, self_crossings as stored") in out
    assert ok_cli(capsys, "metrics", fresh, "--metrics", "stride", "-q") == ""


def test_metrics_then_rank_on_a_file_run_without_metrics(tmp_path, capsys):
    bare = tmp_path / "bare.h5"
    run_study({**STUDY, "scene": {"vertices": ["7"], "velocities": True, "metrics": False}}, output=bare,
              progress=False)
    code, out, err = cli(capsys, "rank", bare)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert f"explorer metrics {bare}" in err and "[scene] metrics = true" in err
    assert "no gait metrics stored" in ok_cli(capsys, "show", bare, "--variant", 1)
    ok_cli(capsys, "metrics", bare)
    _, t = parse_table(ok_cli(capsys, "rank", bare, "--top", "3"))
    assert len(t) == 3


# -- errors ------------------------------------------------------------------------------------------------
@pytest.fixture
def incomplete(results, tmp_path):
    p = tmp_path / "inc.h5"
    shutil.copyfile(results, p)
    with h5py.File(p, "r+") as f:
        f.attrs["complete"] = False
    from explorer.store import seal
    seal(p)  # an edit on purpose: the checksums follow it
    return p


ERRORS = [
    (["rank", "{r}", "--by", "bogus"], "unknown metric 'bogus'"),
    (["rank", "{r}", "--where", "stride >"], "where: cannot parse"),
    (["rank", "{r}", "--where", "__import__('os').system('true')"], "where: a call is not allowed"),
    (["plot", "{r}", "--top", "3", "--where", "stride.__class__"], "where: an attribute is not allowed"),
    (["rank", "{r}", "--top", "-1"], "--top: expected a whole number"),
    (["rank", "{r}", "--top", "ten"], "--top: expected a whole number"),
    (["rank", "{r}", "--pareto", "stride", "--weights", "stride=1"], "exclude each other"),
    (["rank", "{r}", "--pareto", "stride,flatness", "--by", "duty"], "--by goes alone"),
    (["rank", "{r}", "--weights", "stride=1", "--ascending"], "go with --by"),
    (["rank", "{r}", "--weights", "stride=x"], "--weights: expected METRIC=WEIGHT"),
    (["rank", "{r}", "--weights", "stride=-1"], "weights: expected finite weights >= 0"),
    (["rank", "{r}", "--pareto", ","], "--pareto: expected comma-separated names"),
    (["rank", "{r}", "--columns", "nope"], "--columns: unknown column 'nope'"),
    (["rank", "{missing}"], "no such results file"),
    (["rank", "{junk}"], "cannot open as an HDF5 results file"),
    (["show", "{r}", "--variant", "40"], "variant 40 out of range (0 to 39"),
    (["show", "{r}", "--variant", "-1"], "--variant: expected a whole number >= 0 (a variant"),
    (["show", "{r}", "--variant", "two"], "--variant: expected a whole number >= 0 (a variant; 0 = the nominal), got 'two'"),
    (["show", "{missing}", "--variant", "0"], "no such results file"),
    (["metrics", "{inc}", "--band", "0.02"], "incomplete results file (an interrupted run); finish it first with"),
    (["metrics", "{r}", "--band", "1.5"], "--band: expected a number in [0, 1]"),
    (["metrics", "{r}", "--band", "wide"], "--band: expected a number in [0, 1]"),
    (["metrics", "{r}", "--metrics", "stride,nope"], "unknown metric 'nope'"),
    (["metrics", "{missing}"], "no such results file"),
    (["metrics", "{junk}"], "cannot open as an HDF5 results file"),
]


@pytest.mark.parametrize("argv, message", ERRORS, ids=[" ".join(a[:1] + a[2:]) for a, _ in ERRORS])
def test_errors_exit_2_with_one_line(argv, message, results, incomplete, tmp_path, capsys):
    junk = tmp_path / "junk.h5"
    junk.write_text("not an HDF5 file")
    names = {"r": results, "inc": incomplete, "missing": tmp_path / "missing.h5", "junk": junk}
    before = incomplete.read_bytes()
    code, out, err = cli(capsys, *[a.format(**names) for a in argv])
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and err.startswith("explorer: error: ") and "Traceback" not in err, err
    assert message in err, err
    assert incomplete.read_bytes() == before


def test_real_process(results):
    r = subprocess.run([sys.executable, "-m", "explorer.cli", "rank", str(results), "--by", "flatness", "--top", "2"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stderr == "" and "ranked by flatness (lower is better)" in r.stdout
    r = subprocess.run([sys.executable, "-m", "explorer.cli", "show", str(results), "--variant", "99"],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and r.stdout == "" and r.stderr.count("\n") == 1 and "out of range" in r.stderr


@pytest.mark.parametrize("verb", ["rank", "plot"])
def test_help_names_every_metric_of_the_default_score(verb, capsys):
    """The --help of rank and plot names the walker score's metrics: all of DEFAULT_WEIGHTS."""
    with pytest.raises(SystemExit):
        main([verb, "--help"])
    out = " ".join(capsys.readouterr().out.split())
    for m in DEFAULT_WEIGHTS:
        assert m in out, m


def test_show_verdict_quotes_the_numbers_it_judges(results, capsys):
    """The verdict names each score metric in which the variant is better or worse than the reference
    (--vs), with both values, and puts it on the right side by the metric's direction."""
    with open_results(results) as res:
        df = res.frame()
    ok = np.flatnonzero(df["status_code"].to_numpy() == 0)
    v, ref = int(ok[1]), int(ok[2])
    out = ok_cli(capsys, "show", results, "--variant", v, "--vs", ref)
    line = next(ln for ln in out.splitlines() if ln.startswith("verdict against the variant"))
    good, bad = line.split("; worse in ")
    for m in DEFAULT_WEIGHTS:
        x, r = df.iloc[v][m], df.iloc[ref][m]
        if x == r or not (np.isfinite(x) and np.isfinite(r)):
            continue
        text = f"{m} {x:.4g} vs {r:.4g}"
        is_better = (x > r) == (DIRECTIONS[m] == "max")
        assert text in (good if is_better else bad), (m, line)


def test_rank_table_ends_with_the_reference_and_its_changes(results, capsys):
    """The table's last row is the reference (nominal by default, --vs V otherwise) with its own place in
    the ranking; --change adds each ranking metric's change against it in %."""
    with open_results(results) as res:
        full = res.rank(top=None)
        df = res.frame()
    out = ok_cli(capsys, "rank", results, "--top", "3", "--change")
    body = out.partition("\n\n")[2].strip("\n").splitlines()
    head, rows = body[0].split(), [ln.split() for ln in body[1:]]
    place = full.loc[full["variant"] == 0, "rank"]
    assert rows[-1][0] == f"nominal:{int(place.iloc[0]) if len(place) else '-'}" and rows[-1][1] == "0"
    for cells in rows[:-1]:
        v = int(cells[1])
        for k in DEFAULT_WEIGHTS:
            x, r = df.iloc[v][k], df.iloc[0][k]
            got = float(cells[head.index(f"{k}%")])
            assert got == pytest.approx(100 * (x - r) / abs(r), rel=1e-3, abs=1e-3), (v, k)
    v = int(full["variant"].iloc[4])
    out = ok_cli(capsys, "rank", results, "--top", "2", "--vs", v)
    last = [ln.split() for ln in out.splitlines() if ln.startswith("reference:")][-1]
    assert last[:2] == ["reference:5", str(v)]


def test_rank_table_shows_each_designs_tightest_screen_margin(results, capsys):
    """Issue 40: the default ranking's #2 passed the foot-whip limit by 0.3 % (5.98 of 6 crank radii per
    radian) and the table showed it nowhere. Each row now names its closest screen limit and how far
    inside it is, recomputed here from the frame's own columns by the definitions written out plainly."""
    head, table = parse_table(ok_cli(capsys, "rank", results, "--top", "0", "--include-screened"))
    assert any(line.startswith("tightest, margin%:") and "--yield 0.5mm" in line for line in head)
    assert list(table.columns[2:3]) == ["score"]
    with open_results(results) as res:
        df = res.frame().set_index("variant", drop=False)
        limits = res.screen
    for _, row in table.iterrows():
        r = df.loc[int(row["variant"])]
        margins = {"toggle": (r["min_transmission_angle"] - limits.min_transmission_angle) / limits.min_transmission_angle,
                   "foot-above-the-frame": (r["foot_headroom"] - limits.min_foot_headroom) / r["crank"],
                   "foot-whip": (limits.max_foot_speed - r["max_speed"] / r["crank"]) / limits.max_foot_speed}
        which = min(margins, key=margins.get)
        assert row["tightest"] == which, (row["variant"], margins)
        assert float(row["margin%"]) == pytest.approx(100 * margins[which], rel=1e-3, abs=1e-3)
        # a design the screen removes is outside a limit: its margin is negative
        outside = any(c in row["screen"] for c in ("toggle", "foot-whip", "foot-above-the-frame"))
        assert (float(row["margin%"]) < 0) == outside, row
    # beside the yield too
    _, t = parse_table(ok_cli(capsys, "rank", results, "--top", "2", "--yield", "0.5%", "--copies", "4"))
    assert {"tightest", "margin%", "yield", "yield_se"} <= set(t.columns)
