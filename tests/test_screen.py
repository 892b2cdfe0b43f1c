"""The buildability screen: its inputs against brute force and plain numpy, its verdicts against the
thresholds applied by hand, and rank / plot --top / show applying it by default."""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import explorer
import naive_walker as nw
from explorer.cli import main
from explorer.errors import UserError
from explorer.gait import Screen, compute_metrics, rank, screen_columns

STUDY = {
    "study": {"name": "screen", "mechanism": "jansen", "variants": 400, "seed": 3, "steps": 120},
    "perturb": {"method": "uniform", "spread": 0.03},
    "scene": {"metrics": True},
}


# -- the screen's inputs -----------------------------------------------------------------------------------
def _crossings(path):
    out = compute_metrics(np.asarray(path, dtype=float)[None], None, [0], ["self_crossings"])
    return int(out["self_crossings"][0])


def test_crossings_known_curves():
    t = 2 * np.pi * np.arange(400) / 400
    assert _crossings(np.c_[np.cos(t), np.sin(t)]) == 0                        # a circle
    assert _crossings(np.c_[np.sin(t), np.sin(2 * t) / 2]) == 1                  # a figure eight
    r = 0.5 + np.cos(t)                                                          # a limaçon with an inner loop
    assert _crossings(np.c_[r * np.cos(t), r * np.sin(t)]) == 1
    assert _crossings(np.c_[np.cos(3 * t), np.sin(2 * t)]) == 7                  # a Lissajous 3:2 figure


@settings(max_examples=60, deadline=None)
@given(st.integers(4, 40), st.integers(0, 2 ** 31 - 1))
def test_crossings_against_brute_force(n, seed):
    rng = np.random.default_rng(seed)
    path = rng.normal(size=(n, 2))
    if seed % 3 == 0:  # many segments sharing x-ranges: a zig-zag
        path[:, 0] = np.round(path[:, 0], 1)
    assert _crossings(path) == nw.crossings_brute(path)


def test_foot_headroom_plain_numpy():
    mech = explorer.load_mechanism("jansen")
    c = explorer.simulate(mech, 360)
    got = compute_metrics(c.path("7")[None], None, [0], ["foot_headroom"], mechanism=mech)["foot_headroom"][0]
    frame_top = min([y for _, y in mech.fixed.values()] + [mech.crank.center[1]])  # pivot 2 at y = −7.8
    assert frame_top == -7.8
    assert got == pytest.approx(frame_top - c.path("7")[:, 1].max(), rel=1e-14)


# -- verdicts -----------------------------------------------------------------------------------------
def _frame():
    import pandas as pd
    return pd.DataFrame({
        "variant": [0, 1, 2, 3, 4, 5],
        "status": ["ok", "ok", "ok", "ok", "assembly", "ok"],
        "crank": [15.0, 15.0, 15.0, 10.0, 15.0, 15.0],
        "min_transmission_angle": [8.6, 4.9, 9.0, 9.0, np.nan, np.nan],
        "foot_headroom": [61.6, 50.0, -0.5, 40.0, np.nan, 30.0],
        "max_speed": [53.6, 60.0, 60.0, 61.0, np.nan, 60.0],
        "self_crossings": [0, 0, 0, 0, np.nan, 2],
        "travel": [140.0, 150.0, 149.0, 148.0, np.nan, 147.0],
    })


def test_screen_verdicts_by_hand():
    df = _frame()
    buildable, reasons, applied = screen_columns(df)
    assert applied == ["toggle", "foot above the frame", "foot whip", "crossing path"]
    # by hand: 1 toggle (4.9 < 5); 2 foot above the frame (−0.5 < 0); 3 whip (61/10 = 6.1 > 6);
    # 4 failed; 5 crosses itself twice and its transmission angle is undefined (NaN fails the check)
    assert buildable.tolist() == [True, False, False, False, False, False]
    assert reasons[0] == "pass"
    assert reasons[1].startswith("toggle:") and "4.9" in reasons[1]
    assert reasons[2].startswith("foot above the frame:")
    assert reasons[3].startswith("foot whip:") and "6.1" in reasons[3]
    assert reasons[4] == "failed (assembly)"
    assert reasons[5].split("; ")[0].startswith("toggle:") and "undefined" in reasons[5]
    assert reasons[5].split("; ")[1] == "crossing path: the foot path crosses itself 2×"
    # other thresholds
    loose = Screen(min_transmission_angle=4.0, min_foot_headroom=-1.0, max_foot_speed=7.0, max_self_crossings=2)
    assert screen_columns(df, loose)[0].tolist() == [True, True, True, True, False, False]


def test_rank_leaves_screened_out_and_says_so():
    df = _frame()
    df["buildable"], df["screen"], _ = screen_columns(df)
    assert rank(df, by="travel").variant.tolist() == [0]
    assert rank(df, by="travel", include_screened=True).variant.tolist() == [1, 2, 3, 5, 0]


# -- a study, end to end ---------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("screen") / "s.h5"
    explorer.run_study(STUDY, output=out, progress=False)
    return out


def test_every_builtin_nominal_passes():
    for name in explorer.mechanism.builtin_mechanisms():
        mech = explorer.load_mechanism(name)
        if mech.crank is None or mech.sliders or mech.walker is None or mech.gears:
            continue  # a path-driven arm, a slider-crank, a quick-return or a six-bar path generator (watt6,
            # stephenson6: no [walker]) or the geared five-bar (a figure eight) is no leg: the leg checks do not apply
        c = explorer.simulate(mech, 360)
        m = compute_metrics(c.path(mech.foot)[None], c.velocity(mech.foot)[None], [0], mechanism=mech)
        import pandas as pd
        df = pd.DataFrame({k: v for k, v in m.items()})
        df["status"], df["crank"] = "ok", mech.crank.radius
        buildable, reasons, applied = screen_columns(df)
        assert buildable[0], (name, reasons[0])
        assert len(applied) == 4


def test_study_frame_has_walker_metrics_and_screen(results):
    with explorer.open_results(results) as r:
        df = r.frame()
        s = r.screen
    for m in ("travel", "bob", "body_speed_ripple", "peak_torque", "torque_ripple", "clearance", "slip",
              "contact_fraction"):
        assert m in df.columns and np.isfinite(df.loc[df.status == "ok", m]).all(), m
    ok = df.status == "ok"
    # the checks by hand, straight from the columns
    by_hand = (ok & (df.min_transmission_angle >= s.min_transmission_angle) & (df.foot_headroom >= s.min_foot_headroom)
               & (df.max_speed / df.crank <= s.max_foot_speed) & (df.self_crossings <= s.max_self_crossings))
    assert (df.buildable == by_hand).all()
    assert 0 < (ok & ~df.buildable).sum() < ok.sum()
    assert df.loc[0, "screen"] == "pass"


def _cli(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    assert code == 0, out.err
    return out.out


def test_rank_and_plot_top_show_the_same_designs(results, capsys, tmp_path):
    from explorer.view import plot_top
    out = _cli(capsys, "rank", results, "--top", "5")
    m = re.search(r"buildability screen removed ([\d,]+) ok variants \(([^)]*)\)", out)
    with explorer.open_results(results) as r:
        df = r.frame()
        removed = int(((df.status == "ok") & ~df.buildable).sum())
        assert m and int(m.group(1).replace(",", "")) == removed
        api = r.rank(top=5)
        fig = plot_top(r, top=5)
    rows = [line.split() for line in out.splitlines() if re.match(r"^\s+\d+\s+\d+\s", line)]
    assert [int(row[1]) for row in rows] == api.variant.tolist()
    labels = fig.axes[0].get_legend_handles_labels()[1]
    shown = [int(re.search(r"variant (\d+)", lab).group(1)) for lab in labels if lab.startswith("#")]
    assert shown == api.variant.tolist()
    assert api.buildable.all()
    # --include-screened ranks them back in
    every = _cli(capsys, "rank", results, "--by", "travel", "--top", "0", "--include-screened", "--format", "csv")
    assert len(every.strip().splitlines()) - 1 == int((df.status == "ok").sum())


def test_show_says_why_a_variant_is_screened_out(results, capsys):
    with explorer.open_results(results) as r:
        df = r.frame()
    v = int(df.index[(df.status == "ok") & ~df.buildable][0])
    out = _cli(capsys, "show", results, "--variant", v)
    assert f"screened out ({df.loc[v, 'screen']})" in out
    assert "buildability screen: pass" in _cli(capsys, "show", results, "--variant", 0)


def test_screen_table_in_study_is_validated():
    bad = {**STUDY, "screen": {"max_foot_speed": -1}}
    with pytest.raises(UserError, match="screen.max_foot_speed"):
        explorer.load_study(bad)
    with pytest.raises(UserError, match="screen.min_angle: unknown key"):
        explorer.load_study({**STUDY, "screen": {"min_angle": 3}})
    s = explorer.load_study({**STUDY, "screen": {"min_transmission_angle": 7}})
    assert s.screen.min_transmission_angle == 7.0 and s.screen.max_foot_speed == 6.0
    # the screen is applied when ranking, so a resume does not care about it
    assert s.fingerprint() == explorer.load_study(STUDY).fingerprint()
