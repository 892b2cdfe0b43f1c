"""``explorer report`` reads its results file in blocks of rows (issue 39, "lean reads that stay lean"): one
pass for the counts by reason, the ok designs, the filter and the ranked columns, then only the rows it shows.
With the block size patched to a few rows (so that every answer spans many blocks, the last one short) the
page must hold what the whole frame gives, computed here plainly with pandas and numpy from
``Results.frame()``: the designs in the views and their order (the default score over the buildable designs,
then the screened-out ones by their own score), the seeded sample and the filter, every axis' values, the
counts by reason and each reason's first variants, the table against the reference (its rows, places,
scores and values). And the report never reads the whole frame.

``plot --scatter`` above ``SCATTER_POINTS`` points (patched small here) draws each cloud as a density: the
cells' counts add up to the designs pandas counts, each design in the cell its values fall in, the Pareto
front is the brute-force one, and the figure says so.
"""

from __future__ import annotations

import base64
import html as htmlmod
import json
import re

import numpy as np
import pandas as pd
import pytest

from explorer import open_results, run_study, testing
from explorer.gait import CHECKS, DEFAULT_WEIGHTS, DIRECTIONS
from explorer.view import write_report

blocks = testing.store_blocks  # explorer.store._blocks: READ_BLOCK, patched small here

#: A lean Jansen study at ±6 %: about half its designs fail to assemble, the screen removes some others.
STUDY = {"study": {"name": "report-blocks", "mechanism": "jansen", "variants": 300, "seed": 3, "steps": 60},
         "perturb": {"method": "uniform", "spread": 0.06, "links": "all", "crank": True},
         "scene": {"vertices": ["7"], "velocities": True, "metrics": True, "store": "metrics"}}
BLOCK = 37  # rows per block: 300 rows = 8 blocks of 37 and one of 4


@pytest.fixture(scope="module")
def path(tmp_path_factory):
    p = tmp_path_factory.mktemp("report-blocks") / "blocks.h5"
    run_study(STUDY, output=p, progress=False)
    return p


@pytest.fixture(scope="module")
def frame(path):
    with open_results(path) as r:
        df = r.frame()
    ok = df["status"].astype(str) == "ok"
    assert 0 < ok.sum() < len(df) and 0 < (ok & ~df["buildable"]).sum() < ok.sum()  # failed, screened, buildable
    return df


def _data(text: str) -> dict:
    m = re.search(r'<script type="application/json" id="report-data">(.*?)</script>', text, re.S)
    return json.loads(m.group(1).replace("<\\/", "</"))


def _plain_score(sub: pd.DataFrame) -> np.ndarray:
    """The default score written out: each default metric min-max normalised over ``sub`` (1 = best), averaged."""
    total = np.zeros(len(sub))
    for m in DEFAULT_WEIGHTS:
        v = sub[m].to_numpy(dtype=float)
        lo, hi = np.nanmin(v), np.nanmax(v)
        s = ((v - lo) if DIRECTIONS[m] == "max" else (hi - v)) / (hi - lo) if hi > lo else np.ones(len(v))
        total = total + s
    return total / len(DEFAULT_WEIGHTS)


def _plain_order(sub: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """(variants best first: score descending, NaN last, ties by variant; their scores)."""
    score = _plain_score(sub)
    key = np.where(np.isnan(score), np.inf, -score)
    at = np.lexsort([sub["variant"].to_numpy(), key])
    return sub["variant"].to_numpy()[at], score[at]


def _expected_counts(df: pd.DataFrame) -> dict:
    ok = df["status"].astype(str) == "ok"
    screen = df["screen"].astype(str)
    out = {"ok, buildable": int((ok & (screen == "pass")).sum()), "screened out (any check)": int((ok & (screen != "pass")).sum())}
    for reasons in screen[ok & (screen != "pass")]:
        for part in reasons.split("; "):
            key = "screened out: " + part.split(":")[0]
            out[key] = out.get(key, 0) + 1
    for status, n in df.loc[~ok, "status"].astype(str).value_counts().items():
        out[f"failed: {status}"] = int(n)
    return out


def _variants_of(df: pd.DataFrame, key: str) -> list:
    ok = df["status"].astype(str) == "ok"
    screen = df["screen"].astype(str)
    if key == "screened out (any check)":
        m = ok & (screen != "pass")
    elif key.startswith("screened out: "):
        name = key.partition(": ")[2]
        m = ok & screen.map(lambda t: any(p.split(":")[0] == name for p in t.split("; ")))
    else:
        m = df["status"].astype(str) == key.partition(": ")[2]
    return df.loc[m, "variant"].tolist()


# (request, the reference: "failed", "screened" or a variant)
CASES = [({}, 0), (dict(max_designs=40, seed=2), "screened"), (dict(where="bob < 1.5 and travel > 0"), "failed"),
         (dict(max_designs=25, seed=7, where="travel > 0", reason_paths=3), 1)]


@pytest.mark.parametrize("request_,ref", CASES, ids=[f"{r}-vs-{v}" for r, v in CASES])
def test_report_in_blocks_is_the_whole_frames_report(path, frame, tmp_path, monkeypatch, request_, ref):
    df = frame
    ok = (df["status"].astype(str) == "ok").to_numpy()
    buildable = ok & df["buildable"].to_numpy(dtype=bool)
    if ref == "failed":
        ref = int(df["variant"][~ok].iloc[0])
    elif ref == "screened":
        ref = int(df["variant"][ok & ~buildable].iloc[0])
    monkeypatch.setattr(blocks, "READ_BLOCK", BLOCK)
    out = tmp_path / "report.html"
    rep = write_report(path, out, vs=ref, **request_)
    text = out.read_text(encoding="utf-8")
    data = _data(text)

    # the views: the buildable designs by the default score, then the screened-out ones by theirs
    best, best_score = _plain_order(df[buildable])
    order = np.r_[best, _plain_order(df[ok & ~buildable])[0]]
    if "where" in request_:  # the filter, written out: two comparisons
        keep = (df["bob"] < 1.5) & (df["travel"] > 0) if "bob" in request_["where"] else df["travel"] > 0
        order = order[keep.to_numpy()[order]]
    n_kept = len(order)
    place = np.arange(1, n_kept + 1)
    if "max_designs" in request_ and n_kept > request_["max_designs"]:
        pick = np.sort(np.random.default_rng(request_["seed"]).choice(n_kept, request_["max_designs"], replace=False))
        order, place = order[pick], place[pick]
    got = np.frombuffer(base64.b64decode(data["variant"]), dtype="<i4")
    np.testing.assert_array_equal(got, order)
    assert (rep.n_variants, rep.n_ok, rep.n_kept, rep.n_designs) == (len(df), int(ok.sum()), n_kept, len(order))

    # every axis: the frame's values of those designs, in that order (float32 in the page)
    table = np.frombuffer(base64.b64decode(data["table"]), dtype="<f4").reshape(-1, len(order))
    for c in data["columns"]:
        if c["kind"] in ("parameter", "metric"):
            np.testing.assert_array_equal(table[c["dim"]], df[c["key"]].to_numpy(dtype=float)[order].astype(np.float32))
        elif c["kind"] == "rank":
            np.testing.assert_array_equal(table[c["dim"]], place.astype(np.float32))
        elif c["key"] == "buildable":
            np.testing.assert_array_equal(table[c["dim"]], buildable[order].astype(np.float32))
        if c["kind"] in ("parameter", "metric"):  # the reference's value beside each axis
            r = float(df[c["key"]].iloc[ref])
            assert c["reference"] == (r if (ok[ref] or c["kind"] == "parameter") and np.isfinite(r) else None)

    # the counts by reason over every variant, and each reason's first variants
    counts = {htmlmod.unescape(k): int(v) for k, v in re.findall(r"<tr data-reason='([^']*)' data-count='(\d+)'", text)}
    assert counts == _expected_counts(df) == rep.counts
    # in the page's order: the screen's checks as the screen lists them, the failures as the variants meet them
    checks = [f"screened out: {c.name}" for c in CHECKS]
    failures = [f"failed: {s}" for s in df.loc[~ok, "status"].astype(str).unique()]
    assert list(counts) == ["ok, buildable", "screened out (any check)", *(k for k in checks if k in counts), *failures]
    for entry in data["reasons"]:
        plain = _variants_of(df, entry["key"])
        assert entry["count"] == len(plain) and entry["variants"] == plain[:500], entry["key"]
        assert entry["path_variants"] == plain[:request_.get("reason_paths", 50)]

    # the table against the reference: the ten best buildable designs, their places, scores and values
    rows = re.findall(r"<tr class='vs' data-variant='(\d+)'><td>(\d+)</td><td>\d+</td><td class='num'>([0-9.]+)</td>", text)
    assert [int(v) for v, _, _ in rows] == best[:10].tolist()
    assert [int(p) for _, p, _ in rows] == list(range(1, min(10, len(best)) + 1))
    assert [s for _, _, s in rows] == [f"{s:.3f}" for s in best_score[:10]]
    at = np.flatnonzero(best == ref)
    assert re.search(rf"<tr class='ref' data-variant='{ref}' data-place='{at[0] + 1 if len(at) else '-'}'>", text)
    if len(at):
        assert f"walker score is {best_score[at[0]]:.3f}, rank {at[0] + 1} of {len(best):,} buildable designs" in text
    else:
        assert "is not ranked (failed or screened out)" in text
    travel = [float(x) for x in re.findall(r"<td class='num' data-key='travel' data-value='([^']+)'", text)]
    expected = df["travel"].to_numpy()[np.r_[best[:10], ref]]
    np.testing.assert_array_equal(travel, expected)


def test_report_never_reads_the_whole_frame(path, tmp_path, monkeypatch):
    """Every row the report reads comes through a block (``frame(rows=...)``) or a row read by itself."""
    from explorer.store import Results
    whole = Results.frame

    def frame(self, rows=None):
        assert rows is not None, "the report read the whole frame"
        return whole(self, rows=rows)

    monkeypatch.setattr(blocks, "READ_BLOCK", BLOCK)
    monkeypatch.setattr(Results, "frame", frame)
    rep = write_report(path, tmp_path / "r.html", units="model", where="travel > 0")
    assert rep.n_designs > 0


def test_scatter_above_its_points_is_a_density(path, frame, monkeypatch):
    from matplotlib.image import AxesImage

    from explorer.view import plot_scatter
    _plots = testing.view_plots  # explorer.view._plots
    df = frame
    ok = (df["status"].astype(str) == "ok") & np.isfinite(df["travel"]) & np.isfinite(df["bob"])
    buildable, screened = df[ok & df["buildable"]], df[ok & ~df["buildable"]]
    monkeypatch.setattr(_plots, "SCATTER_POINTS", 20)
    monkeypatch.setattr(_plots, "DENSITY_ROWS", 7)  # the points counted a few at a time
    monkeypatch.setattr(blocks, "READ_BLOCK", BLOCK)
    with open_results(path) as r:
        fig = plot_scatter(r, "travel", "bob")
    ax = fig.axes[0]
    images = [a for a in ax.get_children() if isinstance(a, AxesImage)]
    assert len(images) == 2  # the screened-out designs (grey), then the buildable ones (blue)
    x0, x1, y0, y1 = images[0].get_extent()
    for image, part in zip(images, (screened, buildable)):
        counts = np.ma.filled(image.get_array(), 0)  # (rows: y, columns: x), origin lower
        assert counts.sum() == len(part)
        ny, nx = counts.shape
        ix = np.minimum(((part["travel"] - x0) / (x1 - x0) * nx).astype(int), nx - 1)
        iy = np.minimum(((part["bob"] - y0) / (y1 - y0) * ny).astype(int), ny - 1)
        plain = np.zeros_like(counts)
        np.add.at(plain, (iy.to_numpy(), ix.to_numpy()), 1)
        np.testing.assert_array_equal(counts, plain)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert f"buildable variants ({len(buildable):,}; designs per cell)" in labels
    assert f"screened out as unbuildable ({len(screened):,}; designs per cell)" in labels
    assert "drawn as densities" in ax.get_title()
    # the front: the buildable designs no other buildable design beats in both (brute force)
    t, b = buildable["travel"].to_numpy(), buildable["bob"].to_numpy()
    beaten = ((t[None, :] >= t[:, None]) & (b[None, :] <= b[:, None])
              & ((t[None, :] > t[:, None]) | (b[None, :] < b[:, None]))).any(axis=1)
    line = next(ln for ln in ax.get_lines() if ln.get_label().startswith("Pareto"))
    assert sorted(line.get_xdata()) == sorted(t[~beaten])


def test_read_once_hands_re_solved_series_back_unkept(path, capsys):
    """The report re-solves its 2,000 foot paths inside ``Results.read_once()``: they are not kept, so a later
    read solves them again (and says so), giving the same positions; outside it they are kept."""
    v = [5, 9, 40, 41]
    with open_results(path) as r:
        with r.read_once():
            once = r.path(v, "7")
        assert "re-solved variants 5, 9, 40, 41" in capsys.readouterr().err
        again = r.path(v, "7")
        assert "re-solved variants 5, 9, 40, 41" in capsys.readouterr().err  # not kept: solved again
        np.testing.assert_array_equal(once, again)
        r.path(v, "7")
        assert "re-solved" not in capsys.readouterr().err  # kept this time
