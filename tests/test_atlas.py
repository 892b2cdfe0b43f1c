"""The curve atlas and ``explorer synth`` (explorer/synthesis/_atlas.py, _synth.py, _curves.py).

References written here, independent of the code: a plain numpy closed form of the atlas four-bar (crank,
rocker, coupler as one rigid body; the rocker pin left of the line from the crank pin to the rocker
pivot); brute-force enumeration of ordered assignments; the descriptor's invariances from their
definition. Atlases in these tests are small (a few thousand designs, built in a temporary directory);
hidden designs are made here, moved by a similarity, and their target points come from the closed form.
"""

from __future__ import annotations

import itertools
import math

import h5py
import numpy as np
import pytest

from clihelp import cli
from explorer import open_results
from explorer.errors import UserError
from explorer.testing import (N_CURVE, angles_at_arc, arc_fractions, descriptors, normalise, ordered_match,
                              reverse_descriptor)
from explorer.testing import build_atlas, move_parameters, open_atlas
from explorer.testing import synthesize

DESIGNS = 4000


def fourbar(theta, p):
    """The atlas four-bar's foot at crank angles theta (radians), plain numpy. p: every design parameter
    by name (crank, crank.x, crank.y, B0.x, B0.y, rocker, coupler.B.x, coupler.P.x, coupler.P.y)."""
    theta = np.asarray(theta, dtype=float)
    A = np.stack([p["crank.x"] + p["crank"] * np.cos(theta), p["crank.y"] + p["crank"] * np.sin(theta)], -1)
    d = np.array([p["B0.x"], p["B0.y"]]) - A
    dist = np.linalg.norm(d, axis=-1)
    u = d / dist[..., None]
    left = np.stack([-u[..., 1], u[..., 0]], -1)
    r3, r4 = p["coupler.B.x"], p["rocker"]
    a = (r3 ** 2 - r4 ** 2 + dist ** 2) / (2 * dist)
    B = A + a[..., None] * u + np.sqrt(r3 ** 2 - a ** 2)[..., None] * left
    e = (B - A) / r3
    eperp = np.stack([-e[..., 1], e[..., 0]], -1)
    return A + p["coupler.P.x"] * e + p["coupler.P.y"] * eperp


def moved(p, A, B):
    """A design moved by z ↦ A·z + B (complex), every parameter, written out here."""
    s = abs(A)
    out = dict(p)
    for v in ("crank", "B0"):
        z = A * complex(p[f"{v}.x"], p[f"{v}.y"]) + B
        out[f"{v}.x"], out[f"{v}.y"] = z.real, z.imag
    for k in ("crank", "rocker", "coupler.B.x", "coupler.P.x", "coupler.P.y"):
        out[k] = p[k] * s
    return out


def rms_to_path(points, p, n=40000):
    """RMS distance from points (M, 2) to the closed form's path of design p, densely sampled."""
    path = fourbar(2 * np.pi * np.arange(n) / n, p)
    a, b = path, np.roll(path, -1, axis=0)
    d = np.empty(len(points))
    for i, q in enumerate(points):
        ab = b - a
        t = np.clip(np.sum((q - a) * ab, axis=1) / np.maximum(np.sum(ab * ab, axis=1), 1e-300), 0, 1)
        d[i] = np.min(np.linalg.norm(a + t[:, None] * ab - q, axis=1))
    return float(np.sqrt(np.mean(d ** 2)))


KEYS = ("crank", "crank.x", "crank.y", "B0.x", "B0.y", "rocker", "coupler.B.x", "coupler.P.x", "coupler.P.y")


def design_of(row):
    """The closed form's parameters of a results frame's row."""
    return {k: float(row[k]) for k in KEYS}


def size(points):
    return float(np.sqrt(np.mean(np.sum((points - points.mean(0)) ** 2, axis=1))))


@pytest.fixture(scope="module")
def atlas_path(tmp_path_factory):
    p = tmp_path_factory.mktemp("atlas") / "fourbar.h5"
    build_atlas("fourbar", DESIGNS, output=p, progress=False)
    return p


@pytest.fixture(scope="module")
def atlas(atlas_path):
    return open_atlas(atlas_path)


def hidden(atlas, row=123, wiggle=0.003, A=2.5 * np.exp(0.8j), B=4 - 3j):
    """A design near the atlas's ``row``-th design whose path is at least a fifth of its ground link in
    size (every varied parameter moved by up to ±wiggle, relatively), that turns (the closed form is real
    all round), moved by A, B."""
    row = int(np.flatnonzero(atlas.scale > 0.2)[row])
    rng = np.random.default_rng(row)
    for _ in range(100):
        p = atlas.design(row)
        for k in atlas.spec.parameters:
            p[k] *= 1 + wiggle * rng.uniform(-1, 1)
        if np.all(np.isfinite(fourbar(np.linspace(0, 2 * np.pi, 2000), p))):
            return moved(p, A, B)
    raise AssertionError("no hidden design")


def test_the_atlas_stores_designs_that_turn_and_their_curves(atlas, atlas_path):
    """Every stored design turns a full cycle in the closed form, and its stored crank-angle curve is the
    closed form's path, moved by -centre and divided by scale (float16: 1e-3 of the scale)."""
    assert len(atlas) == DESIGNS
    with h5py.File(atlas_path) as f:
        assert f.attrs["designs"] == DESIGNS and f.attrs["sampled"] >= DESIGNS
        timed = f["timed"][:50].astype(float)
    for row in range(50):
        p = atlas.design(row)
        assert np.all(np.isfinite(fourbar(np.linspace(0, 2 * np.pi, 720), p)))
        ref = (fourbar(2 * np.pi * np.arange(N_CURVE) / N_CURVE, p) - atlas.centre[row]) / atlas.scale[row]
        assert np.max(np.abs(timed[row] - ref)) < 2e-3
        assert p["crank.x"] == 0 and p["crank.y"] == 0 and p["B0.x"] == 1 and p["B0.y"] == 0  # the gauge


def test_descriptor_ignores_position_rotation_scale_and_start(atlas):
    """The descriptor of a path moved by any similarity is the same (1e-9); so is that of its normalised
    curve started at another sample; running it backwards swaps |c_k| and |c_-k|."""
    p = atlas.design(7)
    th = 2 * np.pi * np.arange(128) / 128
    P = fourbar(th, p)
    z = (1.7 * np.exp(2.1j)) * (P[:, 0] + 1j * P[:, 1]) + (3 - 5j)
    Q = np.column_stack([z.real, z.imag])
    c1 = normalise(P[None])[0]
    c2 = normalise(Q[None])[0]
    d1, d2 = descriptors(c1), descriptors(c2)
    assert np.max(np.abs(d1 - d2)) < 1e-9
    assert np.max(np.abs(descriptors(np.roll(c1, 11, axis=1)) - d1)) < 1e-12
    assert np.max(np.abs(descriptors(c1[:, ::-1]) - reverse_descriptor(np.roll(d1, 0)))) < 1e-12


def test_ordered_match_is_the_best_ordered_assignment():
    """Against brute force over every assignment that goes round once, either way, from any start."""
    rng = np.random.default_rng(3)
    S, M = 10, 4
    t = 2 * np.pi * np.arange(S) / S
    path = np.column_stack([np.cos(t) + 0.3 * np.cos(2 * t), np.sin(t)])
    q = path[[1, 3, 6, 8]] + rng.normal(0, 0.05, (M, 2))
    th, cost = ordered_match(path[None], q, n_starts=S)
    best = math.inf
    for k0 in range(S):
        for d in (1, -1):
            for steps in itertools.combinations_with_replacement(range(S), M - 1):
                ks = [(k0 + d * s) % S for s in (0,) + steps]
                best = min(best, sum(np.sum((path[k] - q[i]) ** 2) for i, k in enumerate(ks)))
    assert cost[0] == pytest.approx(best, rel=1e-12)


def test_angles_at_arc_walks_the_path_by_length():
    S = 3600
    t = 2 * np.pi * np.arange(S) / S
    circle = np.column_stack([np.cos(t), np.sin(t)])  # the crank angle is the arc angle
    th = angles_at_arc(circle[None], np.array([1.0]), np.array([[0.0, 0.25, 0.5, 0.9]]))
    assert np.allclose(th[0], 1.0 + 2 * np.pi * np.array([0, 0.25, 0.5, 0.9]), atol=2 * np.pi / S)
    assert np.allclose(arc_fractions(circle[::900], closed=True), [0, 0.25, 0.5, 0.75])


@pytest.mark.slow
def test_synth_recovers_a_hidden_design_from_a_closed_curve(atlas, atlas_path, tmp_path):
    """48 points of a hidden four-bar's path (closed form), moved and turned: synth --closed writes a
    design whose path (closed form, its parameters from the results file) passes through them to 1e-6 of
    the curve's size, and a results file rank reads."""
    p = hidden(atlas)
    pts = fourbar(2 * np.pi * np.arange(48) / 48 + 0.3, p)
    s = synthesize(pts, mechanism="fourbar", closed=True, atlas=atlas_path, output=tmp_path / "s.h5", top=3,
                   progress=False)
    with open_results(s.path) as r:
        df = r.frame()
    best = df.iloc[0]
    assert rms_to_path(pts, design_of(best)) <= 1e-6 * size(pts)
    assert s.relative <= 1e-6
    assert best["path_error"] == pytest.approx(s.error)


@pytest.mark.slow
def test_synth_recovers_a_hidden_design_from_timed_points(atlas, atlas_path, tmp_path):
    """Ten points at their crank angles (explorer's θ in the target's frame): synth --timed writes a design
    whose foot is at each point at its angle (closed form) to 1e-6 of the curve's size."""
    p = hidden(atlas, row=321, A=1.5 * np.exp(-2.0j), B=1 + 1j)
    th = np.radians(np.arange(0, 360, 36) + 5.0)
    pts = fourbar(th, p)
    csv = tmp_path / "t.csv"
    csv.write_text("x,y,angle_deg\n" + "".join(f"{float(x)!r},{float(y)!r},{float(a)!r}\n" for (x, y), a in zip(pts, np.degrees(th))))
    s = synthesize(csv, mechanism="fourbar", timed=True, atlas=atlas_path, output=tmp_path / "t.h5", top=2,
                   progress=False)
    with open_results(s.path) as r:
        best = r.frame().iloc[0]
    assert np.max(np.linalg.norm(fourbar(th, design_of(best)) - pts, axis=1)) <= 1e-6 * size(pts)


@pytest.mark.slow
def test_synth_recovers_a_hidden_design_from_an_open_stretch(atlas, atlas_path, tmp_path):
    """Thirty points along 60 % of a hidden design's cycle, untimed and open: a design through them."""
    p = hidden(atlas, row=77, A=0.7 * np.exp(1.0j), B=-2 + 0j)
    pts = fourbar(np.linspace(0.2, 0.2 + 1.2 * np.pi, 30), p)
    s = synthesize(pts, mechanism="fourbar", closed=False, atlas=atlas_path, output=tmp_path / "o.h5", top=2,
                   progress=False)
    with open_results(s.path) as r:
        best = r.frame().iloc[0]
    assert rms_to_path(pts, design_of(best)) <= 1e-6 * size(pts)


def test_moved_parameters_are_the_design_moved(atlas):
    """move_parameters against the closed form: the moved design's path is the path moved, started later
    by the rotation (its crank angle is measured in the new frame)."""
    p = atlas.design(5)
    A, B = 1.3 * np.exp(0.4j), 2 + 1j
    q = move_parameters(atlas.mech, p, A, B, tuple(p))
    th = np.linspace(0, 2 * np.pi, 50)
    P = fourbar(th - np.angle(A), p)
    z = A * (P[:, 0] + 1j * P[:, 1]) + B
    assert np.max(np.abs(fourbar(th, q) - np.column_stack([z.real, z.imag]))) < 1e-12


def test_query_finds_an_atlas_curve_first(atlas):
    """A stored design's own path, moved: the closed look-up's best candidate is that design (its shape
    error ~0, its move the one applied)."""
    p = atlas.design(999)
    pts = fourbar(2 * np.pi * np.arange(64) / 64, p)
    z = (2 * np.exp(1j)) * (pts[:, 0] + 1j * pts[:, 1]) + 5
    c = atlas.query(np.column_stack([z.real, z.imag]), None, closed=True, k=3)
    assert c[0].row == 999 and c[0].err < 1e-5
    assert abs(c[0].A - 2 * np.exp(1j)) < 2e-3 * 2


def write_csv(path, pts):
    path.write_text("x,y\n" + "".join(f"{x},{y}\n" for x, y in pts))
    return path


@pytest.mark.parametrize("case", ["few-points", "nan", "no-build", "other-family", "other-version", "free-phase"])
def test_bad_synth_input_is_one_line_exit_2(case, atlas_path, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("EXPLORER_ATLAS_DIR", str(tmp_path / "empty"))
    good = write_csv(tmp_path / "t.csv", [(np.cos(a), np.sin(a)) for a in np.linspace(0, 6, 20)])
    argv = ["synth", good, "--closed", "--atlas", atlas_path, "-o", tmp_path / "o.h5"]
    words = ""
    if case == "few-points":
        argv[1] = write_csv(tmp_path / "few.csv", [(0, 0), (1, 0), (1, 1), (0, 2)])
        words = "4 points for a fourbar with 9 design parameters"
    elif case == "nan":
        (tmp_path / "nan.csv").write_text("x,y\n0,0\n1,nan\n2,0\n")
        argv[1] = tmp_path / "nan.csv"
        words = "non-finite"
    elif case == "no-build":
        argv = ["synth", good, "--mechanism", "watt6", "--no-build", "-o", tmp_path / "o.h5"]
        words = "no atlas of 'watt6'"
    elif case == "other-family":
        argv += ["--mechanism", "stephenson6"]
        words = "an atlas of 'fourbar', not of 'stephenson6'"
    elif case == "other-version":
        bad = tmp_path / "old.h5"
        bad.write_bytes(atlas_path.read_bytes())
        with h5py.File(bad, "a") as f:
            f.attrs["explorer_version"] = "0.0.1"
        argv[argv.index("--atlas") + 1] = bad
        words = "built by explorer '0.0.1'"
    else:
        argv += ["--free-phase"]
        words = "--free-phase applies to a timed target"
    code, out, err = cli(capsys, *argv)
    assert code == 2 and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert words in err, err
    assert not (tmp_path / "o.h5").exists()


def test_build_refuses_an_existing_atlas_and_bad_sizes(atlas_path):
    with pytest.raises(UserError, match="atlas exists"):
        build_atlas("fourbar", 10, output=atlas_path, progress=False)
    with pytest.raises(UserError, match="--designs"):
        build_atlas("fourbar", 0, output=atlas_path.with_name("x.h5"), progress=False)
