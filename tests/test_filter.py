"""The --where filter language: a restricted grammar, never executed as Python.

Valid filters are checked against pandas' own ``DataFrame.query`` on a trusted frame (the
independent reference); hostile or malformed ones, one case per line, must be refused with a
one-line error and must not run anything.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from explorer.errors import UserError
from explorer.gait import rank
from explorer.testing import evaluate_filter


@pytest.fixture(scope="module")
def frame():
    rng = np.random.default_rng(4)
    n = 60
    return pd.DataFrame({
        "variant": np.arange(n),
        "stride": rng.uniform(10, 60, n),
        "bob": rng.uniform(0, 2, n),
        "duty": rng.uniform(0.1, 0.5, n),
        "1-3": rng.uniform(49, 51, n),
        "status": pd.Categorical(rng.choice(["ok", "assembly", "branch"], n)),
        "buildable": rng.random(n) < 0.7,
        "screen": np.array(rng.choice(["pass", "toggle: min transmission angle 4.1° < 5°"], n), dtype=object),
    })


# (filter in explorer's grammar, the same filter for pandas.query)
VALID = [
    ("stride > 40", "stride > 40"),
    ("stride > 40 and bob < 1", "stride > 40 and bob < 1"),
    ("stride > 40 & bob < 1 | duty >= 0.45", "stride > 40 & bob < 1 | duty >= 0.45"),
    ("not (bob < 0.5)", "not (bob < 0.5)"),
    ("~(bob < 0.5)", "~(bob < 0.5)"),
    ("0.5 < bob < 1.5", "0.5 < bob < 1.5"),
    ("stride / duty > 150", "stride / duty > 150"),
    ("stride * 2 - 10 >= bob ** 2 + 50", "stride * 2 - 10 >= bob ** 2 + 50"),
    ("-bob > -1", "-bob > -1"),
    ("variant % 3 == 0", "variant % 3 == 0"),
    ("variant in [1, 4, 7]", "variant in [1, 4, 7]"),
    ("variant not in [1, 4, 7]", "variant not in [1, 4, 7]"),
    ('status == "ok"', 'status == "ok"'),
    ("status != 'branch'", "status != 'branch'"),
    ("status in ['ok', 'branch']", "status in ['ok', 'branch']"),
    ("`1-3` > 50", "`1-3` > 50"),
    ("`1-3` > 50 and stride < 30", "`1-3` > 50 and stride < 30"),
    ("buildable", "buildable"),
    ("buildable and not (bob > 1)", "buildable and not (bob > 1)"),
    ("buildable == true", "buildable == True"),
    ("stride > 1e9", "stride > 1e9"),
    ("screen == 'pass' and bob < 1", "screen == 'pass' and bob < 1"),   # a text column (str under pandas 3)
    ("screen != 'pass'", "screen != 'pass'"),
]


@pytest.mark.parametrize("ours,theirs", VALID)
def test_valid_filters_match_pandas_query(frame, ours, theirs):
    want = frame.query(theirs).index.to_numpy()
    got = frame.index.to_numpy()[evaluate_filter(frame, ours)]
    np.testing.assert_array_equal(got, want)


def test_nan_compares_false(frame):
    f = frame.assign(bob=np.where(frame["variant"] % 2 == 0, np.nan, frame["bob"]))
    assert not evaluate_filter(f, "bob < 100")[f["variant"] % 2 == 0].any()
    assert evaluate_filter(f, "bob < 100")[f["variant"] % 2 == 1].all()


# One hostile or malformed filter per line, with a word of the one-line error it must give.
REFUSED = [
    ("stride > 0 and @pd.io.common.os.system('touch {mark}')", "cannot parse"),
    ("__import__('os').system('touch {mark}')", "a call is not allowed"),
    ("stride.__class__", "an attribute is not allowed"),
    ("stride[0] > 1", "a subscript is not allowed"),
    ("(lambda: 1)() == 1", "not allowed"),
    ("(x := 3) > 1", "not allowed"),
    ("[s for s in stride] == 1", "not allowed"),
    ("open('{mark}', 'w')", "a call is not allowed"),
    ("f'{{stride}}' == 'a'", "not allowed"),
    ("stride if bob else duty", "not allowed"),
    ("stride @ bob", "MatMult is not allowed"),
    ("stride << 2", "LShift is not allowed"),
    ("stride in bob", "'in' takes a list"),
    ("stride in [bob]", "'in' takes a list"),
    ("stride > ", "cannot parse"),
    ("nonsense > 3", "unknown column 'nonsense'"),
    ("`no such` > 3", "unknown column 'no such'"),
    ("stride + 1", "is not a filter"),
    ("status > 'ok'", "ordering on text"),
    ("stride and 3", "not true/false"),
    ("`1-3 > 5", "unmatched backtick"),
    ("None == stride", "not allowed"),
    ("(" * 300 + "stride" + ")" * 300 + " > 1", "cannot parse"),
    ("stride > 1 and " * 200 + "stride > 1", "too long"),
    ("+".join(["bob"] * 150) + " > 1", "too complex"),
]


@pytest.mark.parametrize("text,words", REFUSED, ids=[f"{i}-{w.split()[0]}" for i, (_, w) in enumerate(REFUSED)])
def test_refused_with_one_line_and_nothing_runs(frame, tmp_path, text, words):
    mark = tmp_path / "pwned"
    text = text.format(mark=mark) if "{mark}" in text else text
    with pytest.raises(UserError) as e:
        evaluate_filter(frame, text)
    msg = str(e.value)
    assert words in msg and "\n" not in msg and msg.startswith("where:"), msg
    assert not mark.exists()


def test_huge_powers_are_numbers_not_computations(frame):
    # pandas.eval would compute the integer 10**10**10 and hang; here numbers are float64
    assert evaluate_filter(frame, "(stride > 0) * 10**10**10 > 0").all()
    assert not evaluate_filter(frame, "stride > 10**400").any()


def test_rank_uses_the_grammar(frame):
    got = rank(frame, by="stride", top=None, where="bob < 1 and `1-3` > 50", include_failed=True,
               include_screened=True)
    want = frame.query("bob < 1 and `1-3` > 50").sort_values(["stride", "variant"], ascending=[False, True])
    assert got["variant"].tolist() == want["variant"].tolist()
    with pytest.raises(UserError, match="a call is not allowed"):
        rank(frame, by="stride", where="__import__('os').system('true')")
