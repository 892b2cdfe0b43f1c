"""Sliders in the views: which metrics apply to a foot on a slider, how `show` labels slider
parameters, and how the drawings show a slider's guide line."""

from __future__ import annotations

import copy
from importlib import resources

import numpy as np
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
    from explorer.testing import parameter_lines

    mech = load_mechanism("whitworth")
    design = {"ram.y": 0.35, "block.offset": -0.07, "ram.dy": 0.1}
    lines = parameter_lines(mech, design, {}, {"ram.y", "block.offset"}, mm_per_unit=10.0)
    assert not any(line.startswith("joint") for line in lines)
    row = {line.split("  ")[0].strip(): line.split() for line in lines[1:] if "  " in line}
    assert row["slider ram point y"][-7:] == ["3.5000", "0.0000", "+3.5000", "+5.000", "%", "of", "size"]  # 0.35·10 mm; 0.35/7
    assert row["slot block offset"][-7:] == ["-0.7000", "0.0000", "-0.7000", "-1.000", "%", "of", "size"]
    assert row["slider ram direction y (fixed) (no unit)"][-4:] == ["0.1000", "0.0000", "+0.1000", "-"]
    assert "slider ram point x (fixed)" in row and "slider ram direction x (fixed) (no unit)" in row


# -- 3. the drawings show a ground slider's guide and a slot ------------------------------------------
def test_guide_segment_of_the_slider_crank_over_its_travel():
    """The piston's guide: y = 1, from the closed form's lowest to highest x at the same crank angles,
    lengthened by 10 % of the stroke at each end; mirrored about the crank centre for a mirrored leg."""
    from explorer.testing import guide_segments

    mech = load_mechanism("slidercrank")
    cyc = simulate(mech, steps=90, velocities=False)
    th = cyc.theta
    s = 1.4 * np.sin(th) - 1.0
    x = 1.4 * np.cos(th) + np.sqrt(16.0 - s * s)  # x = a cos θ + √(b² − (a sin θ − c)²)
    stroke = x.max() - x.min()
    want = [[x.min() - 0.1 * stroke, 1.0], [x.max() + 0.1 * stroke, 1.0]]
    got = guide_segments(mech, cyc.positions)
    assert got.shape == (1, 2, 2)
    np.testing.assert_allclose(got[0], want, atol=1e-9)


def test_slot_segment_by_hand():
    """A slot a → b with the slider's vertex off it by the offset: the groove runs through the vertex
    parallel to a → b, from a's projection to b's (a = (0, 0), b = (3, 4), the vertex 1 along and 0.5
    to the left: the groove from (−0.4, 0.3) to (2.6, 4.3)); past b it reaches the vertex."""
    from explorer.testing import slot_segments

    mech = load_mechanism("whitworth")
    P = np.zeros((len(mech.vertices), 2))
    idx = mech.vertex_index
    P[idx("B")] = (3.0, 4.0)
    P[idx("A")] = 0.2 * np.array([3.0, 4.0]) + 0.5 * np.array([-0.8, 0.6])
    np.testing.assert_allclose(slot_segments(mech, P), [[[-0.4, 0.3], [2.6, 4.3]]], atol=1e-12)
    P[idx("A")] = (4.5, 6.0)  # beyond b on the line
    np.testing.assert_allclose(slot_segments(mech, P), [[[0.0, 0.0], [4.5, 6.0]]], atol=1e-12)


def _pixels(fig, color, tol=6):
    fig.canvas.draw()
    img = np.asarray(fig.canvas.buffer_rgba())[:, :, :3].astype(int)
    rgb = np.array([int(color[i:i + 2], 16) for i in (1, 3, 5)])
    return np.argwhere(np.abs(img - rgb).sum(axis=2) <= tol)


def test_rendered_frames_show_the_guide_and_the_slot():
    """A slider-crank frame has the guide's grey pixels on the line y = 1 beyond the foot path's ends;
    a Whitworth frame has the slot's pixels along the arm O4 → B, between the two."""
    from explorer.view import LinkageAnimation
    from explorer.testing import GUIDE_COLOR, SLOT_COLOR

    anim = LinkageAnimation(load_mechanism("slidercrank"), cycles=1, frames=4, steps=72)
    grey = _pixels(anim.fig, GUIDE_COLOR)
    assert len(grey) > 20
    xmax = np.sqrt(5.4 ** 2 - 1.0)  # the outer dead centre (a + b)² = x² + c²
    (c0, r0), (c1, _) = anim.data_to_pixels(np.array([[xmax, 1.0], [xmax + 0.25, 1.0]]))
    beyond = grey[(grey[:, 1] > c0 + 2) & (grey[:, 1] < c1)]  # the guide's pad past the stroke
    assert len(beyond) > 0 and np.all(np.abs(beyond[:, 0] - r0) <= 3)

    mech = load_mechanism("whitworth")
    anim = LinkageAnimation(mech, cycles=1, frames=12, steps=72)
    anim.draw_frame(2)  # θ = 60°: the arm clear of the crank (at 90° the crank lies on it)
    k = anim.frame_index(2)
    P = anim.cycle.positions[k]
    o4, b = anim.data_to_pixels(P[[mech.vertex_index("O4"), mech.vertex_index("B")]])
    d = b - o4

    def groove():  # light pixels within 1.5 px of the arm's axis, its middle 80 %
        light = _pixels(anim.fig, SLOT_COLOR, tol=45)[:, ::-1].astype(float)  # (column, row)
        t = (light - o4) @ d / (d @ d)
        off = np.abs((light - o4) @ np.array([-d[1], d[0]])) / np.hypot(*d)
        return int(((t > 0.1) & (t < 0.9) & (off <= 1.5)).sum())

    with_slot = groove()
    anim.legs_artists[0].slots.set_visible(False)
    assert with_slot > 0.4 * np.hypot(*d) and groove() < 0.3 * with_slot  # the groove, not the background


def test_no_walker_load_on_a_foot_on_a_ground_slider(tmp_path):
    """[operating] load rides on a walker's contact foot: refused for a piston, naming the key."""
    study = {"study": {"name": "sc", "mechanism": "slidercrank", "variants": 2, "steps": 36},
             "perturb": {"method": "uniform", "spread": 0.02, "links": "all"},
             "scene": {"forces": True}, "operating": {"unit": 0.01, "rpm": 60.0, "load": 2.0}}
    with pytest.raises(UserError, match=r"operating\.load.*ground slider 'piston'"):
        run_study(study, output=tmp_path / "sc.h5", progress=False)
    assert not (tmp_path / "sc.h5").exists()


def test_describe_names_slider_parameters_and_what_does_not_apply():
    """describe says what each slider parameter is (never "in body ...'s frame") and that a foot on a
    ground slider has no walker, leg or screen metric."""
    from explorer.testing import cli_describe as describe, describe_text as text

    out = text(describe(load_mechanism("whitworth")))
    assert "in body" not in out
    lines = {line.split()[0]: line for line in out.splitlines() if line.startswith("  ") and line.split()}
    assert lines["block.offset"].endswith("offset of slider block's slot O4-B (to its left)")
    assert lines["ram.dy"].endswith("slider ram's line: its direction y")
    assert lines["ram.x"].endswith("slider ram's line: its point x")
    assert "walker, leg and screen metrics: not applicable (the foot C runs on the ground slider ram" in out
    assert "buildability screen (default" not in out
    assert "buildability screen (default" in text(describe(load_mechanism("jansen")))
