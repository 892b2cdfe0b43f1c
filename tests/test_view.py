"""Pictures: plots (Figures, PNG/SVG/PDF) and animations (GIF, MP4) decode, hold what was asked, and
draw the foot path where its data says."""

from __future__ import annotations

import dataclasses
import math
import re

import matplotlib.pyplot
import numpy as np
import pytest
from matplotlib.colors import rgb_to_hsv, to_rgb
from PIL import Image, ImageSequence

import explorer
from explorer.cli import main
from explorer.errors import UserError
from explorer.gait import compute_metrics, pareto_front
from explorer.view import (FOOT_PATH_COLOR, LinkageAnimation, animate, central_differences, oat_sensitivity,
                           plot_scatter, plot_sensitivity, plot_top, plot_velocity, save_figure, stance_indices)

DPI = 50  # small frames keep the tests fast


# -- fixtures ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """A small uniform ±5 % study (120 steps): some variants fail mid-cycle, one at θ = 0."""
    out = tmp_path_factory.mktemp("view") / "u.h5"
    explorer.run_study({"study": {"name": "u", "mechanism": "jansen", "variants": 24, "seed": 3, "steps": 120},
                        "perturb": {"method": "uniform", "spread": 0.05}, "scene": {"metrics": True}},
                       output=out, progress=False)
    res = explorer.open_results(out)
    yield res
    res.close()


@pytest.fixture(scope="module")
def oat(tmp_path_factory):
    out = tmp_path_factory.mktemp("view") / "oat.h5"
    explorer.run_study({"study": {"name": "o", "mechanism": "jansen", "variants": 3, "steps": 120},
                        "perturb": {"method": "oat", "spread": 0.03}, "scene": {"metrics": True}},
                       output=out, progress=False)
    res = explorer.open_results(out)
    yield res
    res.close()


# -- pixel helpers -------------------------------------------------------------------------------------
def _matches(pixels: np.ndarray, colour, tol: float, hue: bool) -> np.ndarray:
    """Which RGB pixels (..., 3) match ``colour``: each channel within ``tol`` (0..255), or with ``hue``
    the same hue to within ``tol`` degrees and some saturation (H.264's yuv420p halves the colour
    resolution, so a thin line mixes with the white around it: its hue stays, its RGB does not)."""
    target = np.array(to_rgb(colour))
    px = pixels[..., :3].astype(float) / 255.0
    if not hue:
        return np.abs(px - target).max(axis=-1) * 255.0 <= tol
    h, s = rgb_to_hsv(px)[..., 0], rgb_to_hsv(px)[..., 1]
    dh = np.abs(h - rgb_to_hsv(target)[0])
    return (np.minimum(dh, 1.0 - dh) * 360.0 <= tol) & (s >= 0.3)


def _colour_near(img: np.ndarray, px: np.ndarray, colour, radius: int = 1, tol: float = 40.0,
                 hue: bool = False) -> np.ndarray:
    """For each pixel position (col, row): is ``colour`` within ``radius`` px (see :func:`_matches`)?"""
    h, w = img.shape[:2]
    hits = np.zeros(len(px), dtype=bool)
    for n, (c, r) in enumerate(np.round(px).astype(int)):
        r0, r1, c0, c1 = max(r - radius, 0), min(r + radius + 1, h), max(c - radius, 0), min(c + radius + 1, w)
        if r0 >= r1 or c0 >= c1:
            continue
        hits[n] = _matches(img[r0:r1, c0:c1], colour, tol, hue).any()
    return hits


def _gif_frames(path) -> list[np.ndarray]:
    with Image.open(path) as im:
        return [np.asarray(f.convert("RGB")) for f in ImageSequence.Iterator(im)]


def _not_blank(img: np.ndarray) -> None:
    assert img.astype(float).var() > 100.0


def _check_foot_path(img: np.ndarray, anim: LinkageAnimation, radius=1, tol=40.0, share=0.9, hue=False) -> None:
    """The drawn foot path lies where its data says, and the orange pixels are the path's, not elsewhere."""
    for path in anim.foot_paths:
        px = anim.data_to_pixels(path)
        hits = _colour_near(img, px, FOOT_PATH_COLOR, radius, tol, hue)
        # the moving legs and arrows may hide a few samples of the path
        assert hits.mean() >= share, hits.mean()
        # the same path shifted by a fifth of the frame is not drawn there
        shifted = px + np.array([0.0, -0.2 * img.shape[0]])
        assert _colour_near(img, shifted, FOOT_PATH_COLOR, radius, tol, hue).mean() < 0.3
    # every orange pixel inside the axes (the legend has an orange sample too) is near some path sample
    mask = _matches(img, FOOT_PATH_COLOR, tol, hue)
    bb = anim.ax.get_window_extent()
    inside = np.zeros_like(mask)
    inside[int(img.shape[0] - bb.y1) + 1:int(img.shape[0] - bb.y0) - 1, int(bb.x0) + 1:int(bb.x1) - 1] = True
    mask &= inside
    rows, cols = np.nonzero(mask)
    assert len(rows) > 20
    allpx = np.vstack([anim.data_to_pixels(p) for p in anim.foot_paths])
    d = np.hypot(cols[:, None] - allpx[None, :, 0], rows[:, None] - allpx[None, :, 1]).min(axis=1)
    assert np.mean(d <= 4.0) > 0.95


# -- animations ----------------------------------------------------------------------------------------
def test_gif_frame_count_content_and_path_pixels(jansen, tmp_path):
    anim = LinkageAnimation(jansen, cycles=2, frames=12, dpi=DPI)
    movie = anim.write(tmp_path / "leg.gif")
    assert movie.path.is_file() and movie.frames == 12 and movie.failure is None
    frames = _gif_frames(movie.path)
    assert len(frames) == 12
    w, h = anim.fig.canvas.get_width_height()
    assert frames[0].shape == (h, w, 3)
    for f in frames:
        _not_blank(f)
    # the leg moves: consecutive frames differ
    assert all(np.any(a != b) for a, b in zip(frames, frames[1:]))
    # 2 turns in 12 frames: frames 0 and 6 show the same crank angle
    assert anim.frame_theta(0) == anim.frame_theta(6) == 0.0
    assert anim.frame_theta(1) == pytest.approx(2 * math.pi / 6)
    _check_foot_path(frames[0], anim)
    _check_foot_path(frames[5], anim)


def test_gif_foot_marker_follows_the_cycle(jansen, jansen_cycle, tmp_path):
    anim = LinkageAnimation(jansen, cycles=1, frames=6, dpi=DPI)
    frames = _gif_frames(anim.write(tmp_path / "leg.gif").path)
    foot = jansen.vertex_index(jansen.foot)
    from explorer.testing import FOOT_COLOR
    for i, f in enumerate(frames):
        k = anim.frame_index(i)
        assert anim.cycle.theta[k] == pytest.approx(2 * math.pi * i / 6)
        px = anim.data_to_pixels(anim.cycle.positions[k, foot][None])
        assert _colour_near(f, px, FOOT_COLOR, radius=2, tol=50)[0]


def test_mp4_frame_count_size_and_path_pixels(jansen, tmp_path):
    import imageio_ffmpeg  # the test extra installs it (explorer[movie]): missing is a failure, not a skip
    anim = LinkageAnimation(jansen, cycles=2, frames=10, dpi=DPI)
    movie = anim.write(tmp_path / "leg.mp4")
    n, secs = imageio_ffmpeg.count_frames_and_secs(str(movie.path))
    assert n == 10
    assert secs == pytest.approx(10 / 30, abs=0.05)
    gen = imageio_ffmpeg.read_frames(str(movie.path))
    meta = next(gen)
    w, h = meta["size"]
    assert (w, h) == anim.fig.canvas.get_width_height() and w % 2 == 0 and h % 2 == 0
    assert "yuv420p" in meta.get("pix_fmt", "yuv420p")
    first = np.frombuffer(next(gen), dtype=np.uint8).reshape(h, w, 3)
    gen.close()
    _not_blank(first)
    # H.264 with yuv420p blurs colour: compare hues, in a 2-px neighbourhood
    _check_foot_path(first, anim, radius=2, tol=8.0, share=0.85, hue=True)


def test_walker_mirrored_pairs(jansen, tmp_path):
    anim = LinkageAnimation(jansen, cycles=1, frames=8, legs=4, dpi=DPI)
    assert len(anim.foot_paths) == 2  # the leg's path and its mirror image
    cx = jansen.crank.center[0]
    np.testing.assert_allclose(anim.foot_paths[1][:, 0], 2 * cx - anim.foot_paths[0][:, 0])
    S = anim.S
    # phases 0, π/2, π, 3π/2; odd legs mirrored and solved at α = π − β
    assert [anim.leg_index(j, 0) for j in range(4)] == [0, (S // 2 - S // 4) % S, S // 2, (S // 2 - 3 * S // 4) % S]
    frames = _gif_frames(anim.write(tmp_path / "walker.gif").path)
    assert len(frames) == 8
    _check_foot_path(frames[0], anim, share=0.75)


def test_long_title_never_runs_into_the_clock(jansen):
    # a walker's title on a long name is wider than the line beside the clock: the name goes on a line of
    # its own and the rest stays beside the clock, neither overlapping it (a plain leg's keeps one line)
    for name, walker, lines in (("jansen variant 2193", True, 2), ("jansen variant 2193 of a long study", True, 2),
                                ("jansen", None, 1)):
        mech = dataclasses.replace(jansen, name=name)
        anim = LinkageAnimation(mech, cycles=2, frames=4, walker=walker)  # the CLI's dpi
        r = anim.fig.canvas.get_renderer()
        anim.title.set_visible(True)  # drawn into the cached background, hidden since: measure it shown
        title, clock = anim.title.get_window_extent(r), anim.clock.get_window_extent(r)
        assert title.width > 100 and clock.width > 100
        last_line = title.y0 <= clock.y1 and clock.y0 <= title.y1
        em = anim.title.get_fontsize() * anim.fig.dpi / 72
        assert not last_line or clock.x0 - title.x1 >= em  # a clear gap, not letters touching
        assert anim.title.get_text().count("\n") + 1 == lines
        assert anim.title.get_text().startswith(mech.name)
        matplotlib.pyplot.close(anim.fig)


def test_failed_design_renders_up_to_its_failure(jansen, tmp_path):
    bad = jansen.with_lengths(crank=20.0)  # assembles, then vertex 5 fails near θ ≈ 165°
    cyc = explorer.simulate(bad, 120)
    assert not cyc.ok and 0 < cyc.failure.theta < 2 * math.pi
    anim = LinkageAnimation(bad, cycles=2, frames=16, dpi=DPI)
    assert anim.failure and "cannot assemble" in anim.failure
    assert "not ok" in anim.title.get_text()
    assert all(anim.frame_theta(i) < cyc.failure.theta for i in range(16))
    assert max(anim.frame_theta(i) for i in range(16)) > 0.5 * cyc.failure.theta  # sweeps the part that solved
    movie = anim.write(tmp_path / "bad.gif")
    assert movie.failure == anim.failure
    frames = _gif_frames(movie.path)
    assert len(frames) == 16
    _not_blank(frames[3])


def test_design_that_cannot_assemble_is_a_user_error(jansen, tmp_path):
    with pytest.raises(UserError, match="nothing to animate"):
        animate(jansen.with_lengths(crank=30.0), tmp_path / "x.gif", frames=4, dpi=DPI)
    assert not (tmp_path / "x.gif").exists()


def test_animate_a_results_variant(results, tmp_path):
    df = results.frame()
    failed = df[(df["status"] != "ok") & (df["fail_theta"] > 0)]
    assert len(failed)
    v = int(failed["variant"].iloc[0])
    movie = animate(results, tmp_path / "v.gif", variant=v, cycles=1, frames=6, dpi=DPI)
    assert movie.failure is not None and len(_gif_frames(movie.path)) == 6
    movie = animate(results, tmp_path / "v0.gif", cycles=1, frames=4, dpi=DPI)
    assert movie.failure is None
    at_zero = df[(df["status"] != "ok") & (df["fail_theta"] == 0)]
    if len(at_zero):
        with pytest.raises(UserError, match="nothing to animate"):
            animate(results, tmp_path / "z.gif", variant=int(at_zero["variant"].iloc[0]), frames=4, dpi=DPI)
    with pytest.raises(UserError, match="out of range"):
        animate(results, tmp_path / "z.gif", variant=len(df), frames=4)


@pytest.mark.slow
def test_animate_from_a_cycle_without_velocities(jansen, tmp_path):
    cyc = explorer.simulate(jansen, 60, velocities=False)
    anim = LinkageAnimation(cyc, cycles=1, frames=5, dpi=DPI)
    assert len(_gif_frames(anim.write(tmp_path / "c.gif").path)) == 5


@pytest.mark.parametrize("kw, match", [
    (dict(out="leg.avi"), "unknown output extension"),
    (dict(out="nowhere/leg.gif"), "does not exist"),
    (dict(legs=0), "legs"),
    (dict(frames=0), "frames"),
    (dict(cycles=-1), "cycles"),
    (dict(fps=0), "fps"),
])
def test_animate_errors(jansen, tmp_path, kw, match):
    kw = dict(kw)
    out = tmp_path / kw.pop("out", "leg.gif")
    with pytest.raises(UserError, match=match):
        animate(jansen, out, **{"frames": 4, "dpi": DPI, **kw})


def test_artists_are_reused_not_recreated(jansen):
    anim = LinkageAnimation(jansen, cycles=1, frames=10, dpi=DPI)
    before = list(anim.ax.get_children()) + list(anim.fig.get_children())
    lines = anim.legs_artists[0].links
    for i in range(10):
        anim.draw_frame(i)
        anim.fig.canvas.draw()
    after = list(anim.ax.get_children()) + list(anim.fig.get_children())
    assert len(before) == len(after) and all(a is b for a, b in zip(before, after))
    assert anim.legs_artists[0].links is lines


# -- velocity ------------------------------------------------------------------------------------------
def test_central_differences_on_a_circle():
    th = 2 * np.pi * np.arange(90) / 90
    p = np.column_stack([np.cos(th), np.sin(th)])
    d = central_differences(th, p)
    h = 2 * np.pi / 90
    np.testing.assert_allclose(d, np.column_stack([-np.sin(th), np.cos(th)]) * np.sin(h) / h, atol=1e-12)


def test_plot_velocity_of_a_cycle(jansen_cycle, tmp_path):
    fig = plot_velocity(jansen_cycle)
    axes = fig.axes
    assert len(axes) == 2
    foot = jansen_cycle.mechanism.foot
    for j, ax in enumerate(axes):
        solid = [l for l in ax.get_lines() if l.get_linestyle() == "-" and len(l.get_xdata()) == 360]
        dashed = [l for l in ax.get_lines() if l.get_linestyle() == "--"]
        assert len(solid) == 1 and len(dashed) == 1
        np.testing.assert_allclose(solid[0].get_ydata(), jansen_cycle.velocity(foot)[:, j])
        # finite differences agree with the analytic rate to O(Δθ²) and are drawn on top
        np.testing.assert_allclose(dashed[0].get_ydata(), solid[0].get_ydata(), atol=0.2)
        assert dashed[0].get_zorder() > solid[0].get_zorder()
        assert "model units/rad" in ax.get_ylabel()
    assert "θ" in axes[1].get_xlabel()
    out = save_figure(fig, tmp_path / "v.png")
    _not_blank(np.asarray(Image.open(out).convert("RGB")))


def test_plot_velocity_of_results_and_failures(results, jansen):
    df = results.frame()
    fig = plot_velocity(results, 0)
    assert "variant 0" in fig._suptitle.get_text()
    v = int(df[(df["status"] != "ok") & (df["fail_theta"] > 0)]["variant"].iloc[0])
    fig = plot_velocity(results, v)
    assert "not ok" in fig._suptitle.get_text()
    fig = plot_velocity(jansen.with_lengths(crank=20.0), steps=120)
    assert "not ok" in fig._suptitle.get_text()
    with pytest.raises(UserError, match="nothing to plot"):
        plot_velocity(jansen.with_lengths(crank=30.0), steps=60)
    with pytest.raises(UserError, match="out of range"):
        plot_velocity(results, 10_000)


# -- results plots -------------------------------------------------------------------------------------
def test_stance_matches_the_gait_metrics(jansen_cycle):
    path = jansen_cycle.path("7")
    idx = stance_indices(path, 0.01)
    m = compute_metrics(path[None], None, None, ["duty", "stride"], 0.01)
    assert len(idx) / len(path) == pytest.approx(m["duty"][0])
    assert np.ptp(path[idx, 0]) == pytest.approx(m["stride"][0])
    # a stance that wraps past θ = 0
    y = np.array([0.0, 0.0, 5.0, 5.0, 5.0, 0.0])
    assert list(stance_indices(np.column_stack([np.arange(6.0), y]), 0.01)) == [5, 0, 1]


def test_plot_top_draws_the_best_paths(results, tmp_path):
    fig = plot_top(results, by="stride", top=3)
    ax = fig.axes[0]
    labels = ax.get_legend().get_texts()
    text = [t.get_text() for t in labels]
    assert text[0].startswith("nominal") and text[1].startswith("#1") and "stride" in text[1]
    ranked = explorer.gait.rank(results.frame(), by="stride", top=3)
    best = int(ranked["variant"].iloc[0])
    assert f"variant {best}:" in text[1]
    assert ax.get_aspect() == 1.0
    assert "model units" in ax.get_xlabel() and "model units" in ax.get_ylabel()
    # the best variant's path is drawn in its colour where its data says
    line = next(l for l in ax.get_lines() if l.get_label().startswith("#1"))
    out = save_figure(fig, tmp_path / "top.png")
    img = np.asarray(Image.open(out).convert("RGB"))
    _not_blank(img)
    fig.canvas.draw()
    path = results.path(best)
    disp = ax.transData.transform(path)
    px = np.column_stack([disp[:, 0], img.shape[0] - disp[:, 1]])
    assert _colour_near(img, px, line.get_color(), radius=2, tol=40).mean() > 0.6
    with pytest.raises(UserError, match="unknown metric"):
        plot_top(results, by="nope")


def test_plot_scatter_front_and_nominal(results):
    fig = plot_scatter(results, "stride", "flatness")
    ax = fig.axes[0]
    df = results.frame()
    every_ok = df[df["status"] == "ok"]
    ok = every_ok[every_ok["buildable"]]  # the front is over the legs the screen passes
    screened = every_ok[~every_ok["buildable"]].dropna(subset=["stride", "flatness"])
    front = ok[pareto_front(ok, ["stride", "flatness"])]
    line = next(l for l in ax.get_lines() if l.get_label().startswith("Pareto"))
    assert sorted(line.get_xdata()) == sorted(front["stride"])
    star = next(l for l in ax.get_lines() if l.get_label().startswith("nominal"))
    assert star.get_xdata()[0] == pytest.approx(df.loc[0, "stride"])
    assert "higher is better" in ax.get_xlabel() and "lower is better" in ax.get_ylabel()
    shown = {c.get_label().split(" (")[0]: len(c.get_offsets()) for c in ax.collections}
    assert shown["buildable variants"] == len(ok.dropna(subset=["stride", "flatness"]))
    assert shown.get("screened out as unbuildable", 0) == len(screened)
    every = plot_scatter(results, "stride", "flatness", include_screened=True).axes[0]
    assert len(every.collections[0].get_offsets()) == len(every_ok.dropna(subset=["stride", "flatness"]))
    with pytest.raises(UserError, match="two different"):
        plot_scatter(results, "stride", "stride")


def test_sensitivity_of_an_oat_study(oat, results):
    table = oat_sensitivity(oat)
    mech = oat.mechanism
    assert list(table.index) == list(mech.link_names) + ["crank"]
    df = oat.frame()
    # one cell by hand: the crank radius against width
    nom = df.iloc[0]
    rows = df[(df["status"] == "ok") & (df["crank"] != nom["crank"])]
    r = (rows["crank"] - nom["crank"]) / nom["crank"]
    dm = (rows["width"] - nom["width"]) / nom["width"]
    assert table.loc["crank", "width"] == pytest.approx(float((r * dm).sum() / (r * r).sum()))
    fig = plot_sensitivity(oat)
    assert fig.axes[0].get_images()
    with pytest.raises(UserError, match="one-at-a-time"):
        plot_sensitivity(results)


def _paren_depth(text: str) -> int:
    depth = deepest = 0
    for ch in text:
        depth += ch == "("
        deepest = max(deepest, depth)
        depth -= ch == ")"
    return deepest


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["top", "scatter", "velocity", "sensitivity"])
def test_plots_read_at_a_glance(results, oat, kind):
    """Every title, axis label and legend entry lies inside the figure (nothing clipped), is at least 9 pt,
    axis labels give their unit in brackets without nested parentheses, and a legend or colour bar says
    what the colours mean."""
    fig = {"top": lambda: plot_top(results, top=3), "scatter": lambda: plot_scatter(results, "travel", "bob"),
           "velocity": lambda: plot_velocity(results, 0), "sensitivity": lambda: plot_sensitivity(oat)}[kind]()
    fig.canvas.draw()
    r = fig.canvas.get_renderer()
    W, H = fig.bbox.width, fig.bbox.height
    texts = [t for t in (fig._suptitle,) if t is not None and t.get_text()]
    for ax in fig.axes:
        texts += [t for t in (ax.title, ax.xaxis.label, ax.yaxis.label) if t.get_text()]
        if ax.get_legend() is not None:
            texts += list(ax.get_legend().get_texts())
        for label in (ax.get_xlabel(), ax.get_ylabel()):
            assert _paren_depth(label) <= 1, label
    assert len(texts) >= 3
    for t in texts:
        bb = t.get_window_extent(r)
        assert bb.x0 >= -1 and bb.y0 >= -1 and bb.x1 <= W + 1 and bb.y1 <= H + 1, (t.get_text(), bb, W, H)
        assert t.get_fontsize() >= 9, t.get_text()
    if kind == "sensitivity":  # the colour bar says what a cell's number is
        assert "% change of the metric" in fig.axes[1].get_ylabel()
    else:
        for ax in fig.axes:
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                assert not label or re.search(r"\[[^\]]+\]", label), label  # "foot x [model units]"
    says_colours = any(ax.get_legend() is not None for ax in fig.axes) or len(fig.axes) > 1  # legend or colour bar
    assert says_colours
    matplotlib.pyplot.close(fig)


@pytest.mark.parametrize("ext, magic", [(".png", b"\x89PNG"), (".svg", b"<?xml"), (".pdf", b"%PDF")])
def test_save_figure_formats(jansen_cycle, tmp_path, ext, magic):
    out = save_figure(plot_velocity(jansen_cycle, dpi=40), tmp_path / f"v{ext}")
    assert out.read_bytes()[:5].startswith(magic)


def test_save_figure_errors(jansen_cycle, tmp_path):
    fig = plot_velocity(jansen_cycle, dpi=40)
    with pytest.raises(UserError, match="unknown output extension"):
        save_figure(fig, tmp_path / "v.jpg")
    with pytest.raises(UserError, match="does not exist"):
        save_figure(fig, tmp_path / "no" / "v.png")


# -- command line --------------------------------------------------------------------------------------
@pytest.mark.slow
def test_cli_plot_and_animate(results, oat, tmp_path, capsys):
    r, o = str(results.filename), str(oat.filename)
    for argv in (["plot", r, "--top", "2", "--by", "stride"], ["plot", r, "--scatter", "stride,duty"],
                 ["plot", r, "--velocity", "--variant", "1"], ["plot", o, "--sensitivity"]):
        out = tmp_path / f"{argv[2][2:]}.png"
        assert main(argv + ["-o", str(out), "--dpi", "40"]) == 0, argv
        assert out.is_file()
    out = tmp_path / "leg.gif"
    assert main(["animate", "--mechanism", "jansen", "-o", str(out), "--frames", "4", "--dpi", "40"]) == 0
    assert len(_gif_frames(out)) == 4
    out = tmp_path / "v1.gif"
    assert main(["animate", r, "--variant", "1", "-o", str(out), "--frames", "3", "--cycles", "1",
                 "--dpi", "40"]) == 0
    assert len(_gif_frames(out)) == 3
    capsys.readouterr()


@pytest.mark.parametrize("verb", ["plot", "animate"])
def test_cli_help(verb, capsys):
    with pytest.raises(SystemExit) as exc:
        main([verb, "--help"])
    assert exc.value.code == 0
    assert "-o PATH" in capsys.readouterr().out


@pytest.mark.parametrize("argv, match", [
    (["plot", "{r}", "--top", "2", "--by", "nope", "-o", "{t}/x.png"], "unknown metric 'nope'"),
    (["plot", "{r}", "--velocity", "--variant", "999", "-o", "{t}/x.png"], "out of range"),
    (["plot", "{r}", "--top", "2", "-o", "{r}/x.png"], "is not a folder"),
    (["plot", "{r}", "--top", "2", "-o", "{t}/x.jpg"], "unknown output extension"),
    (["plot", "{r}", "-o", "{t}/x.png"], "say what to plot"),
    (["plot", "{r}", "--scatter", "stride", "-o", "{t}/x.png"], "two metrics"),
    (["animate", "{r}", "--variant", "999", "-o", "{t}/x.gif"], "out of range"),
    (["animate", "--mechanism", "jansen", "-o", "{t}/x.avi"], "unknown output extension"),
    (["animate", "--mechanism", "jansen", "-o", "{r}/x.gif"], "is not a folder"),
    (["animate", "-o", "{t}/x.gif"], "RESULTS file"),
])
def test_cli_errors_are_one_line_exit_2(results, tmp_path, capsys, argv, match):
    argv = [a.format(r=results.filename, t=tmp_path) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("explorer: error:") and match in err and "\n" not in err


def test_bodies_are_drawn_as_their_outline():
    """A rigid body is drawn: Hoeken's collinear coupler as the bar B–P (its outermost joints), a
    triangle as its three sides; links as before."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from explorer import load_mechanism, simulate
    from explorer.testing import LegArtists, hull_order

    assert hull_order([(0, 0), (2.5, 0), (5, 0)]) == [0, 2, 0]
    assert hull_order([(0, 0), (1, 0), (0.5, 1), (0.5, 0.3)]) == [0, 1, 2, 0]  # the inner point is no corner
    mech = load_mechanism("hoeken")
    P = simulate(mech, 36).positions[5]
    fig, ax = plt.subplots()
    leg = LegArtists(ax, mech)
    leg.update(P)
    xy = np.column_stack(leg.links.get_data())
    B, P_, C, D = (tuple(P[mech.vertex_index(v)]) for v in ("B", "P", "C", "D"))
    # the drawn segments: consecutive finite points of the polyline (NaN breaks it)
    pairs = {frozenset((tuple(xy[i]), tuple(xy[i + 1]))) for i in range(len(xy) - 1)
             if np.isfinite(xy[i]).all() and np.isfinite(xy[i + 1]).all()}
    assert pairs == {frozenset((D, C)), frozenset((B, P_))}  # the rocker, and the coupler bar there and back
    plt.close(fig)


# -- a long title stays on the canvas (issue 40) -------------------------------------------------------------
def test_a_long_plot_title_is_wrapped_not_clipped(results, tmp_path):
    """`plot --top` with a --where filter had a title wider than the figure, centred over an axes that sits
    left of its legend: its second line ran off the canvas on the left. Rasterised here: every line of
    the title lies inside the image, and the image's first and last pixel columns (white margin) carry no
    ink in the title's rows."""
    from explorer.view import plot_top, save_figure
    where = "bob < 100 and slip < 100 and travel > 0 and clearance > -1 and body_speed_ripple < 1000"
    fig = plot_top(results, top=3, where=where)
    path = save_figure(fig, tmp_path / "top.png")
    img = np.asarray(Image.open(path).convert("L"), dtype=np.float64)
    renderer = fig.canvas.get_renderer()
    fig.canvas.draw()
    title = fig.axes[0].title
    box = title.get_window_extent(renderer)
    W, H = fig.canvas.get_width_height()
    assert img.shape == (H, W)
    assert box.x0 >= 0 and box.x1 <= W, (box, W)
    assert where in title._get_wrapped_text().replace("\n", " ")
    assert title._get_wrapped_text().count("\n") >= 2          # it was wrapped onto more lines
    rows = slice(max(0, int(H - box.y1)), min(H, int(H - box.y0) + 1))   # image rows count from the top
    edge = np.concatenate([img[rows, :2].ravel(), img[rows, -2:].ravel()])
    assert (edge > 250).all(), "ink at the image's edge in the title's rows: the title is cut off"
    assert (img[rows] < 128).any()                           # and the title is there
