"""Reading a results file in blocks of rows (issue 39, "lean reads that stay lean"): ``Results.rank``,
``select``, ``screen_summary``, ``metric_ranks``, ``row`` and ``frame_rows`` read the frame a block at a time
(``READ_BLOCK`` of ``testing.store_blocks``, patched to a few rows here so that every answer spans many blocks,
the last one short) and must give exactly what the whole frame gives: the same rows in the same order, the
same columns, dtypes and values, the same screened and failed counts. The references are plain pandas over
``Results.frame()`` (every row at once), written out in the tests, and ``explorer.gait.rank`` on that frame.
"""

from __future__ import annotations

import io
import tracemalloc
from contextlib import redirect_stdout

import numpy as np
import pandas as pd
import pytest

from explorer import testing
from explorer import open_results, run_study
from explorer.cli import main
from explorer.gait import DIRECTIONS, rank

blocks = testing.store_blocks  # explorer.store._blocks: READ_BLOCK, patched small here

#: A lean Jansen study at ±6 %: about half its designs fail to assemble, and the screen removes some of the others.
STUDY = {"study": {"name": "blocked", "mechanism": "jansen", "variants": 300, "seed": 3, "steps": 60},
         "perturb": {"method": "uniform", "spread": 0.06, "links": "all", "crank": True},
         "scene": {"vertices": ["7"], "velocities": True, "metrics": True, "store": "metrics"}}
BLOCK = 37  # rows per block in these tests: 300 rows = 8 blocks of 37 and one of 4


@pytest.fixture(scope="module")
def path(tmp_path_factory):
    p = tmp_path_factory.mktemp("blocked") / "blocked.h5"
    run_study(STUDY, output=p, progress=False)
    return p


@pytest.fixture(scope="module")
def res(path):
    with pytest.MonkeyPatch.context() as mp, open_results(path) as r:
        mp.setattr(blocks, "READ_BLOCK", BLOCK)
        df = r.frame()
        ok = df["status"] == "ok"
        # the file has what the tests need: failures, screened-out designs and buildable ones
        assert 0 < ok.sum() < len(df) and 0 < (ok & ~df["buildable"]).sum() < ok.sum()
        yield r


REQUESTS = [dict(), dict(top=None), dict(by="travel"), dict(by="bob", where="travel > 100 and bob < 1.5"),
            dict(by="travel", ascending=True, top=None), dict(pareto="travel,bob", top=None),
            dict(weights={"travel": 2, "bob": 1, "peak_torque": 0.5}, top=25), dict(include_screened=True, top=None),
            dict(by="travel", include_failed=True, top=None), dict(by="clearance", where="status != 'ok'",
                                                                  include_failed=True, top=0),
            dict(by="bob", where="fail_vertex == fail_vertex", include_failed=True, top=None)]


@pytest.mark.parametrize("request_", REQUESTS, ids=[str(r) for r in REQUESTS])
def test_rank_in_blocks_is_the_whole_frames_ranking(res, request_):
    whole = rank(res.frame(), **request_)
    got = res.rank(**request_)
    pd.testing.assert_frame_equal(got, whole, check_index_type=False)
    # only some columns: the same rows, ranks and scores
    slim = res.rank(**request_, columns=["variant"])
    assert list(slim["variant"]) == list(whole["variant"]) and list(slim["rank"]) == list(whole["rank"])
    if "score" in whole.columns:
        assert np.array_equal(slim["score"].to_numpy(), whole["score"].to_numpy(), equal_nan=True)


def test_rank_by_one_metric_against_plain_pandas(res):
    df = res.frame()
    keep = (df["status"] == "ok") & df["buildable"] & (df["bob"] < 1.5)
    plain = df[keep].sort_values(["travel", "variant"], ascending=[False, True], kind="stable", na_position="last")
    got = res.rank(by="travel", where="bob < 1.5", top=None)
    assert list(got["variant"]) == list(plain["variant"])
    assert list(got["rank"]) == list(range(1, len(plain) + 1))


def test_weighted_score_against_plain_pandas(res):
    weights = {"travel": 2.0, "bob": 1.0, "clearance": 1.0}
    df = res.frame()
    sub = df[(df["status"] == "ok") & df["buildable"]]
    total = 0.0
    for m, w in weights.items():
        v = sub[m]
        s = (v - v.min()) / (v.max() - v.min()) if DIRECTIONS[m] == "max" else (v.max() - v) / (v.max() - v.min())
        total = total + w * s
    plain = (total / sum(weights.values())).rename("score")
    got = res.rank(weights=weights, top=None)
    assert len(got) == len(sub)
    np.testing.assert_allclose(got["score"].to_numpy(), plain.loc[got.index].to_numpy(), rtol=0, atol=1e-14)
    assert (np.diff(got["score"].to_numpy()) <= 0).all()


def test_screened_and_failed_accounting(res):
    df = res.frame()
    ok = df["status"] == "ok"
    t = res.screen
    checks = {"toggle": ~(df["min_transmission_angle"] >= t.min_transmission_angle),
              "foot above the frame": ~(df["foot_headroom"] >= t.min_foot_headroom),
              "foot whip": ~(df["max_speed"] / df["crank"] <= t.max_foot_speed),
              "crossing path": ~(df["self_crossings"] <= t.max_self_crossings)}
    removed = np.zeros(len(df), dtype=bool)
    for c in checks.values():
        removed |= (ok & c).to_numpy()
    got = res.screen_summary()  # counted block by block
    assert got["removed"] == int(removed.sum()) == int((ok & ~df["buildable"]).sum())
    assert got["checks"] == {k: int((ok & c).sum()) for k, c in checks.items()}
    assert got == res.screen_summary(df)
    res.rank(top=3)  # a blocked rank counts the screen in its own pass: the same summary
    assert res.screen_summary() == got
    # the pool a ranking reports: ok, buildable; the failed ones counted by status
    assert len(res.rank(top=None)) == int((ok & df["buildable"]).sum())
    assert res.status_counts()["ok"] == int(ok.sum()) and sum(res.status_counts().values()) == len(df)


def test_select_is_the_whole_frames_selection(res):
    df = res.frame()
    for where, failed, screened in ((None, False, False), ("bob < 1.0", False, True), ("travel > 120", True, False)):
        keep = np.ones(len(df), dtype=bool) if failed else (df["status"] == "ok").to_numpy()
        if not screened:
            keep = keep & ~((df["status"] == "ok") & ~df["buildable"]).to_numpy()
        plain = df[keep]
        if where:
            col, op, x = where.split()
            plain = plain[plain[col] < float(x)] if op == "<" else plain[plain[col] > float(x)]
        got = res.select(where, include_failed=failed, include_screened=screened)
        pd.testing.assert_frame_equal(got, plain, check_index_type=False)
        some = res.select(where, include_failed=failed, include_screened=screened, columns=["bob", "status"])
        pd.testing.assert_frame_equal(some, plain[["variant", "bob", "status"]], check_index_type=False)


def test_rows_read_alone_are_the_whole_frames_rows(res):
    df = res.frame()
    failed = df.index[df["status"] != "ok"][:3].tolist()
    for v in [0, 1, 36, 37, 299] + failed:
        pd.testing.assert_series_equal(res.row(v), df.iloc[v])
        assert res.design(v) == res.design(v, frame=df)
    order = [299, 5, failed[0], 5, 0, 150, 37]  # any order, repeats, across blocks
    pd.testing.assert_frame_equal(res.frame_rows(order), df.loc[order], check_index_type=False)
    assert len(res.frame_rows([])) == 0 and list(res.frame_rows([]).columns) == list(df.columns)


def test_metric_ranks_counted_in_blocks(res):
    df = res.frame()
    pool = (df["status"] == "ok") & df["buildable"]
    v = int(df.index[pool][3])
    got = res.metric_ranks(v)
    for m in ("travel", "bob", "clearance"):
        x = df.loc[pool & np.isfinite(df[m]), m]
        better = (x > df.at[v, m]) if DIRECTIONS[m] == "max" else (x < df.at[v, m])
        assert got[m] == (int(better.sum()) + 1, len(x)), m
    assert got == res.metric_ranks(v, frame=df)
    assert all(r is None for r in res.metric_ranks(int(df.index[df["status"] != "ok"][0])).values())


def test_rank_verb_in_blocks_prints_the_whole_frames_ranking(res, path):
    expected = rank(res.frame(), top=None, by="travel", where="bob < 1.5")
    out = io.StringIO()
    with redirect_stdout(out):
        assert main(["rank", str(path), "--by", "travel", "--where", "bob < 1.5", "--format", "csv"]) == 0
    got = pd.read_csv(io.StringIO(out.getvalue()))
    assert list(got["variant"]) == list(expected["variant"]) and list(got.columns) == list(expected.columns)
    np.testing.assert_array_equal(got["travel"].to_numpy(), expected["travel"].to_numpy())


def test_bad_arguments_fail_before_any_block_is_read(res, monkeypatch):
    read = []
    monkeypatch.setattr(blocks, "blocks", lambda *a, **k: read.append(1) or iter(()))
    from explorer.errors import UserError
    for kw in (dict(by="no_such_metric"), dict(where="bob <"), dict(weights={"travel": -1}), dict(top=-2)):
        with pytest.raises(UserError):
            res.rank(**kw)
    assert not read


def test_rank_memory_stays_with_the_rows_it_ranks(tmp_path, monkeypatch):
    """A blocked rank holds a block and the ranked columns of the rows kept, not the whole frame: its peak of
    traced allocations is well under that of reading the frame and ranking it (the same rows, below)."""
    study = {**STUDY, "study": {**STUDY["study"], "variants": 8000, "steps": 24}, "perturb": {
        **STUDY["perturb"], "spread": 0.02}}
    p = tmp_path / "big.h5"
    run_study(study, output=p, progress=False)
    monkeypatch.setattr(blocks, "READ_BLOCK", 512)
    with open_results(p) as r:
        r.rank(top=3)  # imports and first calls before anything is measured
        tracemalloc.start()
        try:
            got = r.rank(top=3)
            blocked = tracemalloc.get_traced_memory()[1]
            tracemalloc.reset_peak()
            before = tracemalloc.get_traced_memory()[0]
            frame = r.frame()
            whole_rank = rank(frame, top=3)
            whole = tracemalloc.get_traced_memory()[1] - before
        finally:
            tracemalloc.stop()
        frame_bytes = frame.memory_usage(deep=False).sum()
    pd.testing.assert_frame_equal(got, whole_rank, check_index_type=False)
    # it keeps 6 of the frame's 45 columns (variant and the 5 metrics of the default score) of the rows it ranks:
    # at its peak, less than the frame's own bytes, which the whole-frame path holds and copies
    assert blocked < 0.75 * frame_bytes and blocked < 0.4 * whole, (blocked, whole, frame_bytes)
