"""Ranking results frames: natural directions, filters, weighted scores and Pareto fronts."""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from explorer.errors import UserError
from explorer.gait import DIRECTIONS, pareto_front, rank
from naive_gait import naive_pareto


@pytest.fixture
def frame():
    return pd.DataFrame({
        "variant": [0, 1, 2, 3, 4, 5, 6],
        "stride": [43.4, 45.0, np.nan, 40.0, 46.0, 45.0, 44.0],
        "flatness": [0.0012, 0.0030, np.nan, 0.0008, 0.0020, 0.0015, 0.0011],
        "duty": [0.31, 0.35, np.nan, 0.29, 0.33, 0.36, 0.32],
        "speed_ripple": [0.09, 0.12, np.nan, 0.05, 0.20, 0.10, 0.08],
        "L_1_3": [50.0, 50.5, 51.0, 49.5, 50.2, 49.8, 50.1],
        "status": ["ok", "ok", "assembly", "ok", "ok", "ok", "ok"],
    })


def test_single_metric_natural_direction(frame):
    r = rank(frame, by="stride")
    assert list(r["variant"]) == [4, 1, 5, 6, 0, 3]          # larger stride first, ties by variant, failed out
    assert list(r["rank"]) == [1, 2, 3, 4, 5, 6] and r.columns[0] == "rank"
    assert list(rank(frame, by="flatness")["variant"]) == [3, 6, 0, 5, 4, 1]  # smaller first
    assert list(rank(frame, by="flatness", ascending=False)["variant"]) == [1, 4, 5, 0, 6, 3]
    assert list(rank(frame, by="stride", ascending=True, top=2)["variant"]) == [3, 0]
    assert list(rank(frame, by="stride", top=3)["variant"]) == [4, 1, 5]
    assert len(rank(frame, by="stride", top=None)) == 6
    assert len(rank(frame, by="stride", top=0)) == len(frame) - 1  # 0 = every row, as on the command line (one failed)
    # the index is kept so rows can be found back in the frame
    assert list(rank(frame, by="stride", top=2).index) == [4, 1]


def test_failed_and_nan(frame):
    r = rank(frame, by="stride", top=None, include_failed=True)
    assert list(r["variant"]) == [4, 1, 5, 6, 0, 3, 2]       # NaN last
    r = rank(frame, by="flatness", top=None, include_failed=True)
    assert r["variant"].iloc[-1] == 2
    f = frame.assign(status=[0, 0, 1, 0, 0, 0, 0])         # integer codes work too
    assert 2 not in set(rank(f, by="stride", top=None)["variant"])
    assert len(rank(frame.drop(columns="status"), by="L_1_3", ascending=True, top=None)) == 7


def test_where(frame):
    r = rank(frame, by="stride", where="duty > 0.3 and flatness < 0.002")
    assert list(r["variant"]) == [5, 6, 0]
    assert list(rank(frame, by="flatness", where="variant in [1, 4]")["variant"]) == [4, 1]
    assert len(rank(frame, by="stride", where="stride > 1000")) == 0
    # the default ranking is the walker score, which a frame without walker metrics cannot give
    with pytest.raises(UserError, match="default ranking needs the walker metrics travel, bob"):
        rank(frame)
    for bad in ("duty >", "nonsense > 3", "duty >> 'a'"):
        with pytest.raises(UserError, match="where: ") as e:
            rank(frame, by="stride", where=bad)
        assert repr(bad) in str(e.value)


def test_unknown_metric_and_directions(frame):
    known = r"\(known: stride, duty, flatness, speed_ripple, L_1_3\)"
    with pytest.raises(UserError, match=r"unknown metric 'stridee' " + known):
        rank(frame, by="stridee")
    with pytest.raises(UserError, match="'max_speed' was not computed"):
        rank(frame, by="max_speed")
    with pytest.raises(UserError, match="no natural direction"):
        rank(frame, by="L_1_3")
    assert list(rank(frame, by="L_1_3", ascending=False, top=1)["variant"]) == [1]
    with pytest.raises(UserError, match="unknown metric"):
        rank(frame, pareto=["stride", "bogus"])
    with pytest.raises(UserError, match="unknown metric"):
        rank(frame, weights={"bogus": 1})
    with pytest.raises(UserError, match="ascending"):
        rank(frame, pareto=["stride", "flatness"], ascending=True)
    with pytest.raises(UserError, match="ascending"):
        rank(frame, pareto=["stride", "flatness"], ascending={"duty": True})
    with pytest.raises(UserError, match="either"):
        rank(frame, pareto=["stride"], weights={"stride": 1})
    with pytest.raises(UserError, match="top"):
        rank(frame, top=-1)


def test_weighted_score(frame):
    r = rank(frame, weights={"stride": 1.0, "flatness": 1.0}, top=None)
    ok = frame[frame.status == "ok"]
    s1 = (ok.stride - ok.stride.min()) / (ok.stride.max() - ok.stride.min())
    s2 = (ok.flatness.max() - ok.flatness) / (ok.flatness.max() - ok.flatness.min())  # smaller is better
    expected = ((s1 + s2) / 2).sort_values(ascending=False, kind="stable")
    assert list(r["variant"]) == list(ok.loc[expected.index, "variant"])
    assert np.allclose(r["score"].to_numpy(), expected.to_numpy())
    assert r["score"].between(0, 1).all()
    # weight only one metric: same order as ranking by it
    only = rank(frame, weights={"flatness": 3.0}, top=None)
    assert list(only["variant"]) == list(rank(frame, by="flatness", top=None)["variant"])
    # direction override flips that metric
    flip = rank(frame, weights={"flatness": 1.0}, ascending={"flatness": False}, top=None)
    assert list(flip["variant"]) == list(rank(frame, by="flatness", ascending=False, top=None)["variant"])
    # failed kept: NaN score, last
    inc = rank(frame, weights={"stride": 1, "duty": 2}, include_failed=True, top=None)
    assert inc["variant"].iloc[-1] == 2 and math.isnan(inc["score"].iloc[-1])
    # a constant metric adds the same to everyone
    const = frame.assign(duty=0.3)
    assert list(rank(const, weights={"stride": 1, "duty": 5}, top=None)["variant"]) == \
        list(rank(frame, by="stride", top=None)["variant"])
    for bad in ({"stride": -1}, {"stride": 0}, {"stride": "a"}, {}):
        with pytest.raises(UserError, match="weights"):
            rank(frame, weights=bad)


def test_pareto_rank(frame):
    r = rank(frame, pareto=["stride", "flatness"], top=None)
    # stride up, flatness down: 4 (46, .0020), 5 (45, .0015), 6 (44, .0011), 3 (40, .0008); 1 and 0 dominated
    assert list(r["variant"]) == [4, 5, 6, 3]
    assert list(r["rank"]) == [1, 2, 3, 4]
    assert list(rank(frame, pareto="stride,flatness", top=2)["variant"]) == [4, 5]
    # overriding a direction changes the front
    r = rank(frame, pareto=["stride", "flatness"], ascending={"flatness": False}, top=None)
    assert list(r["variant"]) == [4, 1]
    r = rank(frame, pareto=["stride", "flatness"], where="duty > 0.3", top=None)
    assert list(r["variant"]) == [4, 5, 6]
    # NaN rows (failed, kept) are never on the front
    assert 2 not in set(rank(frame, pareto=["stride", "flatness"], include_failed=True, top=None)["variant"])


def test_pareto_front_directions_forms(frame):
    cols = ["stride", "flatness"]
    a = pareto_front(frame, cols)
    b = pareto_front(frame, cols, {"stride": "max", "flatness": "min"})
    c = pareto_front(frame, cols, ["max", "min"])
    assert a.dtype == bool and a.shape == (7,)
    assert (a == b).all() and (a == c).all()
    assert (a == naive_pareto(frame[cols].to_numpy(), ["max", "min"])).all()
    with pytest.raises(UserError):
        pareto_front(frame, cols, ["max"])
    with pytest.raises(UserError):
        pareto_front(frame, cols, ["up", "min"])
    assert not pareto_front(frame.iloc[:0], cols).any()


_values = st.sampled_from([0.0, 1.0, 2.0, 3.0, 0.5, np.nan, -1.0])


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 3).flatmap(lambda k: st.tuples(
    arrays(np.float64, st.tuples(st.integers(0, 40), st.just(k)), elements=_values),
    st.lists(st.sampled_from(["max", "min"]), min_size=k, max_size=k))))
def test_pareto_front_matches_brute_force(case):
    values, dirs = case
    cols = ["stride", "flatness", "duty"][:values.shape[1]]
    df = pd.DataFrame(values, columns=cols)
    got = pareto_front(df, cols, dict(zip(cols, dirs)))
    assert (got == naive_pareto(values, dirs)).all()


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 300), st.just(2)),
              elements=st.floats(-1e3, 1e3, allow_nan=False)))
def test_pareto_front_random_floats(values):
    df = pd.DataFrame(values, columns=["stride", "flatness"])
    dirs = [DIRECTIONS["stride"], DIRECTIONS["flatness"]]
    assert (pareto_front(df, ["stride", "flatness"]) == naive_pareto(values, dirs)).all()
    # the ranked front is sorted by its first metric, best first
    r = rank(df.assign(variant=np.arange(len(df))), pareto=["stride", "flatness"], top=None)
    assert r["stride"].is_monotonic_decreasing
    assert r["flatness"].is_monotonic_decreasing  # and down a 2-metric front the other one improves


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, st.integers(0, 30), elements=st.sampled_from([1.0, 2.0, 3.0, np.nan])),
       st.booleans())
def test_single_rank_order_random(values, include_failed):
    n = len(values)
    df = pd.DataFrame({"variant": np.arange(n), "stride": values,
                       "status": ["ok" if i % 3 else "branch" for i in range(n)]})
    r = rank(df, by="stride", top=None, include_failed=include_failed)
    keep = df if include_failed else df[df.status == "ok"]
    expected = keep.sort_values(["stride", "variant"], ascending=[False, True], na_position="last", kind="stable")
    assert list(r["variant"]) == list(expected["variant"])
