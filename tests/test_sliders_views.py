"""Sliders in the views: which metrics apply to a foot on a slider, how `show` labels slider
parameters, and how the drawings show a slider's guide line."""

from __future__ import annotations

import copy
from importlib import resources

import pytest

from explorer import UserError, load_mechanism, open_results, run_study, simulate
from explorer.gait import TABLE, available_metrics, compute_metrics
from explorer.mechanism import mechanism_from_dict, parse_toml

LEGLIKE = [m.name for m in TABLE if m.group in ("walker", "leg", "screen")]


def builtin_dict(name):
    text = (resources.files("explorer.mechanism") / "builtin" / f"{name}.toml").read_text(encoding="utf-8")
    return parse_toml(text, f"{name}.toml")


# -- 1. a foot on a ground slider has no walker, leg or screen metric ----------------------------------
@pytest.mark.parametrize("name, slider", [("slidercrank", "piston"), ("whitworth", "ram")])
def test_foot_on_a_ground_slider_has_no_leg_metrics(name, slider):
    """The foot is the sliding vertex of a ground slider: every walker, leg and screen metric is not
    applicable and names the slider; quick_return is the one left. compute_metrics(True) computes only
    it, and asking for one of the others is a one-line error."""
    mech = load_mechanism(name)
    why = available_metrics(mech)
    for m in LEGLIKE:
        assert why[m] is not None and f"ground slider {slider!r}" in why[m], m
    assert why["quick_return"] is None
    cyc = simulate(mech, steps=72)
    got = compute_metrics(cyc.path(mech.foot)[None], cyc.velocity(mech.foot)[None], [0], True, mechanism=mech)
    assert list(got) == ["quick_return"]
    with pytest.raises(UserError, match=f"slip: .*ground slider '{slider}'"):
        compute_metrics(cyc.path(mech.foot)[None], cyc.velocity(mech.foot)[None], [0], ["slip"], mechanism=mech)


@pytest.mark.parametrize("foot", ["A", "B"])
def test_foot_off_a_ground_slider_keeps_them(foot):
    """The rule is the foot's own: Whitworth's crank pin A slides in a *slot* (its path is the crank's
    circle) and the arm's end B is on no slider; with either as the foot the leg metrics apply again and
    quick_return does not."""
    d = builtin_dict("whitworth")
    d["foot"] = foot
    mech = mechanism_from_dict(d, "whitworth.toml")
    why = available_metrics(mech)
    for m in ("width", "height", "stride", "duty", "travel", "slip", "foot_headroom", "self_crossings"):
        assert why[m] is None, (m, why[m])
    assert "no foot on a ground slider" in why["quick_return"]


def test_slider_study_runs_and_rank_says_what_it_lacks(tmp_path):
    """`[scene] metrics = true` on a slider-crank stores quick_return and no leg metric; the default
    score says its metrics do not apply and which one to rank by; --by quick_return ranks."""
    study = {"study": {"name": "sc", "mechanism": "slidercrank", "variants": 6, "steps": 36},
             "perturb": {"method": "uniform", "spread": 0.02, "links": "all"},
             "scene": {"metrics": True}}
    out = tmp_path / "sc.h5"
    run_study(study, output=out, progress=False)
    r = open_results(out)
    df = r.frame()
    assert "quick_return" in df.columns
    assert not set(LEGLIKE) & set(df.columns)
    with pytest.raises(UserError, match=r"do not apply: .*ground slider 'piston'.*--by quick_return"):
        r.rank()
    ranked = r.rank(by="quick_return", top=None)
    q = df.set_index("variant")["quick_return"]
    assert list(ranked["variant"]) == list(q.sort_values(ascending=False, kind="stable").index)
    summary = r.screen_summary(df)
    assert "ground slider 'piston'" in summary["not_applicable"]
    r.close()
    # a study that names one of them is refused at once, naming the key
    bad = copy.deepcopy(study)
    bad["scene"]["metrics"] = ["slip"]
    with pytest.raises(UserError, match="scene.metrics.*slip.*ground slider 'piston'"):
        run_study(bad, output=tmp_path / "bad.h5", progress=False)


# -- 2. show labels slider parameters by their slider ------------------------------------------------
def test_show_labels_slider_parameters():
    """Whitworth's slot offset and ram line are labelled by their sliders, never "joint"; a ground
    line's direction has no % of size and stays unitless in mm (--units si), its point is scaled."""
    from explorer.cli._show import parameter_lines

    mech = load_mechanism("whitworth")
    design = {"ram.y": 0.35, "block.offset": -0.07, "ram.dy": 0.1}
    lines = parameter_lines(mech, design, {}, {"ram.y", "block.offset"}, mm_per_unit=10.0)
    assert not any(line.startswith("joint") for line in lines)
    row = {line.split("  ")[0].strip(): line.split() for line in lines[1:] if "  " in line}
    assert row["slider ram point y"][-7:] == ["3.5000", "0.0000", "+3.5000", "+5.000", "%", "of", "size"]  # 0.35·10 mm; 0.35/7
    assert row["slot block offset"][-7:] == ["-0.7000", "0.0000", "-0.7000", "-1.000", "%", "of", "size"]
    assert row["slider ram direction y (fixed) (no unit)"][-4:] == ["0.1000", "0.0000", "+0.1000", "-"]
    assert "slider ram point x (fixed)" in row and "slider ram direction x (fixed) (no unit)" in row
