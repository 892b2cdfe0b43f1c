"""Rigid bodies ([[bodies]]): file shape and errors, the plan (DYAD + ATTACH, or a coupled block), and
the solved positions and velocities against plain-numpy references written here."""

from __future__ import annotations

import numpy as np
import pytest

from explorer import UserError, make_plan, simulate, simulate_batch
from explorer.mechanism import mechanism_from_dict
from explorer.plan import ATTACH, DYAD, GENERAL


def body_leg(points=None, guess_p=(1.5, -4.5)):
    """A Hoeken-like leg: crank 1 about (0, 0), rocker 2.5 from (2, 0) to C, and one body B, C, P
    (``points``: the body's joints in its own frame; default collinear, P 5 from B through C)."""
    points = points or {"B": [0.0, 0.0], "C": [2.5, 0.0], "P": [5.0, 0.0]}
    return {
        "name": "bodyleg", "foot": "P",
        "crank": {"center": [0.0, 0.0], "radius": 1.0, "tip": "B"},
        "fixed": {"R": [2.0, 0.0]},
        "guess": {"C": [1.2, -2.0], "P": list(guess_p)},
        "links": [{"a": "R", "b": "C", "length": 2.5}],
        "bodies": [{"name": "coupler", "joints": points}],
    }


def body_leg_closed_form(theta, points, crank=1.0, center=(0.0, 0.0), pivot=(2.0, 0.0), rocker=2.5):
    """Plain numpy: B on the crank circle, C where the circles about B (radius |BC| in the body) and the
    pivot (the rocker) meet below the line B → pivot's left side as at θ = 0, and every other joint
    by the rotation that takes the body's B→C onto the world's B→C."""
    pts = {k: np.asarray(v, dtype=float) for k, v in points.items()}
    B = np.stack([center[0] + crank * np.cos(theta), center[1] + crank * np.sin(theta)], axis=-1)
    R = np.broadcast_to(np.asarray(pivot, dtype=float), B.shape)
    bc = np.linalg.norm(pts["C"] - pts["B"])
    g = R - B
    d = np.linalg.norm(g, axis=-1)
    x = (bc ** 2 - rocker ** 2 + d ** 2) / (2 * d)
    y = np.sqrt(bc ** 2 - x ** 2)
    u = g / d[:, None]
    perp = np.stack([-u[:, 1], u[:, 0]], axis=-1)
    C = B + x[:, None] * u - y[:, None] * perp  # the side of C at θ = 0: below the axis, right of B→R
    out = {"B": B, "C": C, "R": R}
    e_body = pts["C"] - pts["B"]
    ang = np.arctan2(C[:, 1] - B[:, 1], C[:, 0] - B[:, 0]) - np.arctan2(e_body[1], e_body[0])
    rot = np.stack([np.stack([np.cos(ang), -np.sin(ang)], -1), np.stack([np.sin(ang), np.cos(ang)], -1)], -2)
    for k, p in pts.items():
        if k not in out:
            out[k] = B + np.einsum("nij,j->ni", rot, p - pts["B"])
    return out


THETA = 2 * np.pi * np.arange(360) / 360


@pytest.mark.parametrize("points", [
    {"B": [0.0, 0.0], "C": [2.5, 0.0], "P": [5.0, 0.0]},               # collinear: Hoeken's coupler
    {"B": [1.0, 1.0], "C": [1.0, 3.5], "P": [1.0, 6.0]},               # the same shape in another frame
    {"B": [0.0, 0.0], "C": [2.5, 0.0], "P": [4.0, -1.2]},              # a triangle
])
def test_body_leg_matches_its_closed_form(points):
    mech = mechanism_from_dict(body_leg(points))
    cyc = simulate(mech, 360, accelerations=True)
    assert cyc.ok
    ref = body_leg_closed_form(THETA, points)
    for v in ("B", "C", "P"):
        assert np.max(np.abs(cyc.path(v) - ref[v])) < 1e-9 * mech.size, v
    # velocities and accelerations against central differences of the closed form
    h = 1e-5
    plus, minus = body_leg_closed_form(THETA + h, points), body_leg_closed_form(THETA - h, points)
    fd = (plus["P"] - minus["P"]) / (2 * h)
    assert np.max(np.abs(cyc.velocity("P") - fd)) < 1e-6 * mech.size
    fd2 = (plus["P"] - 2 * ref["P"] + minus["P"]) / h ** 2
    acc = cyc.accelerations[:, mech.vertex_index("P")]
    assert np.max(np.abs(acc - fd2)) < 1e-3 * mech.size


def test_body_placed_by_two_joints_is_an_attach_block():
    mech = mechanism_from_dict(body_leg())
    plan = make_plan(mech)
    kinds = [b.kind for b in plan.blocks]
    assert kinds == [DYAD, ATTACH]
    assert mech.vertices[plan.blocks[0].vertices[0]] == "C"
    assert mech.vertices[plan.blocks[1].vertices[0]] == "P"
    # the dyad uses the body's B–C distance, the base pair; P hangs from it
    j, p, q = plan.attach[0]
    assert {mech.vertices[p], mech.vertices[q]} == {"B", "C"} and mech.vertices[j] == "P"


def test_methods_agree_on_a_body_leg():
    mech = mechanism_from_dict(body_leg({"B": [0.0, 0.0], "C": [2.5, 0.0], "P": [4.0, -1.2]}))
    block = simulate(mech, 360)
    for method in ("dense", "closed"):
        other = simulate(mech, 360, method=method)
        assert other.ok
        assert np.max(np.abs(other.positions - block.positions)) < 1e-9 * mech.size, method


def triad_body():
    """A ternary body C, D, E hung from the crank tip (link B–C) and two ground pivots (links R1–D,
    R2–E): an Assur triad whose middle link is a body, so one coupled block of three vertices. The
    link lengths are those of a consistent placement at θ = 0 (the body unturned, C at (0.3, −2.5))."""
    body = {"C": [0.0, 0.0], "D": [-1.8, -1.0], "E": [1.7, -1.2]}
    at0 = {k: np.array([0.3, -2.5]) + v for k, v in body.items()}
    B, R1, R2 = np.array([0.3, 0.0]), np.array([-4.0, -3.2]), np.array([3.5, -1.5])
    return {
        "name": "bodytriad", "foot": "E",
        "crank": {"center": [0.0, 0.0], "radius": 0.3, "tip": "B"},
        "fixed": {"R1": R1.tolist(), "R2": R2.tolist()},
        "guess": {k: v.tolist() for k, v in at0.items()},
        "links": [{"a": "B", "b": "C", "length": float(np.linalg.norm(at0["C"] - B))},
                  {"a": "R1", "b": "D", "length": float(np.linalg.norm(at0["D"] - R1))},
                  {"a": "R2", "b": "E", "length": float(np.linalg.norm(at0["E"] - R2))}],
        "bodies": [{"name": "plate", "joints": body}],
    }


def test_body_inside_a_loop_joins_a_coupled_block():
    mech = mechanism_from_dict(triad_body())
    plan = make_plan(mech)
    assert [b.kind for b in plan.blocks] == [GENERAL]
    assert len(plan.blocks[0].vertices) == 3 and len(plan.blocks[0].attaches) == 2
    cyc = simulate(mech, 360, accelerations=True)
    assert cyc.ok, cyc.failure
    P = {v: cyc.path(v) for v in mech.vertices}
    # every link and every pair of the body's joints keeps its length (brute force over the cycle)
    for l in mech.links:
        assert np.max(np.abs(np.linalg.norm(P[l.b] - P[l.a], axis=1) - l.length)) < 1e-9 * mech.size
    body = mech.bodies[0]
    pts = dict(zip(body.joints, np.asarray(body.points)))
    for a in body.joints:
        for b in body.joints:
            if a < b:
                d = np.linalg.norm(pts[b] - pts[a])
                assert np.max(np.abs(np.linalg.norm(P[b] - P[a], axis=1) - d)) < 1e-9 * mech.size
    # ... and never mirrors: the orientation of C, D, E stays the body's
    def orient(c, d, e):
        return np.sign((d[..., 0] - c[..., 0]) * (e[..., 1] - c[..., 1]) - (d[..., 1] - c[..., 1]) * (e[..., 0] - c[..., 0]))
    assert np.all(orient(P["C"], P["D"], P["E"]) == orient(pts["C"], pts["D"], pts["E"]))
    # velocities against central differences of positions solved at θ ± h
    h = 1e-4
    fine = simulate(mech, 3600, tolerance=1e-12)
    k = np.arange(0, 3600, 10)  # the 360 samples, and their neighbours one fine step away
    hh = 2 * np.pi / 3600
    fd = (fine.path("E")[(k + 1) % 3600] - fine.path("E")[k - 1]) / (2 * hh)
    assert np.max(np.abs(cyc.velocity("E") - fd)) < 1e-4 * mech.size * (1 + h)
    dense = simulate(mech, 360, method="dense", accelerations=True)
    assert np.max(np.abs(dense.positions - cyc.positions)) < 1e-9 * mech.size
    assert np.max(np.abs(dense.velocities - cyc.velocities)) < 1e-8 * mech.size
    assert np.max(np.abs(dense.accelerations - cyc.accelerations)) < 1e-7 * mech.size


def test_body_coordinates_are_design_parameters():
    points = {"B": [0.0, 0.0], "C": [2.5, 0.0], "P": [5.0, 0.0]}
    mech = mechanism_from_dict(body_leg(points))
    assert [n for n in mech.parameters() if n.startswith("coupler.")] == [
        "coupler.B.x", "coupler.B.y", "coupler.C.x", "coupler.C.y", "coupler.P.x", "coupler.P.y"]
    py = np.array([0.0, 0.3, -0.4])
    bx = np.array([0.0, 0.1, 0.05])
    batch = simulate_batch(mech, np.tile(mech.lengths, (3, 1)), geometry={"coupler.P.y": py, "coupler.B.x": bx},
                           vertices="all")
    assert list(batch.status) == [0, 0, 0]
    for i in range(3):
        pts = {"B": [bx[i], 0.0], "C": [2.5, 0.0], "P": [5.0, py[i]]}
        ref = body_leg_closed_form(THETA, pts)
        assert np.max(np.abs(batch.paths["P"][i] - ref["P"])) < 1e-9 * mech.size
    # the same variant through with_parameters and simulate
    one = simulate(mech.with_parameters({"coupler.P.y": 0.3, "coupler.B.x": 0.1}))
    assert np.max(np.abs(one.path("P") - batch.paths["P"][1])) < 1e-9 * mech.size


def test_a_body_that_cannot_be_a_body_is_invalid_not_a_crash():
    mech = mechanism_from_dict(body_leg())
    # B moved onto C: the base pair coincides; NaN: not a number
    batch = simulate_batch(mech, np.tile(mech.lengths, (3, 1)),
                           geometry={"coupler.B.x": np.array([0.0, 2.5, np.nan])})
    assert [int(s) for s in batch.status] == [0, 4, 4]
    assert np.all(np.isnan(batch.paths["P"][1:]))


@pytest.mark.parametrize("edit, key, text", [
    (lambda d: d["bodies"][0].update(joints={"B": [0, 0]}), "bodies[0].joints", "two or more joints"),
    (lambda d: d["bodies"][0]["joints"].update(Q=[1, 1]), "bodies[0].joints.Q", "neither driven, fixed"),
    (lambda d: d["bodies"][0]["joints"].update(P=[2.5, 0.0]), "bodies[0].joints.P", "same point"),
    (lambda d: d["bodies"][0]["joints"].update(P=[1e200, 0.0]), "bodies[0].joints.P", "up to 1e+09"),
    (lambda d: d["bodies"][0].update(name="a.b"), "bodies[0].name", "no '.'"),
    (lambda d: d["bodies"][0].update(colour="red"), "bodies[0].colour", "unknown key"),
    (lambda d: d["links"].append({"a": "B", "b": "P", "length": 5.0}), "bodies[0].joints", "over-constrained"),
    (lambda d: d["links"].append({"a": "R", "b": "P", "length": 3.0}), "links", "degrees of freedom"),
    (lambda d: d["links"][0].update(name="R.x"), "links[0].name", "two design parameters would be called 'R.x'"),
    (lambda d: d["fixed"].update(crank=d["fixed"].pop("R")) or d["links"][0].update(a="crank"), "fixed.crank",
     "'crank.x'"),
    (lambda d: d["links"].clear() or d["bodies"][0]["joints"].update(R=[1.0, 1.0]), "bodies[0].joints",
     "two driven or fixed"),
])
def test_bad_bodies_are_one_line_errors(edit, key, text):
    d = body_leg()
    edit(d)
    with pytest.raises(UserError) as exc:
        mechanism_from_dict(d, "leg.toml")
    msg = str(exc.value)
    assert "\n" not in msg and msg.startswith("leg.toml: ") and text in msg, msg
    assert key.split(".")[0] in msg


def test_a_frame_by_name_in_any_column_order_does_what_it_says():
    """simulate_batch reads a DataFrame by column name: its columns reversed (and a metric column that
    names no parameter) give the same designs, and the designs are those the columns say (the closed
    form with each row's crank radius, pivot and foot hole)."""
    import pandas as pd

    mech = mechanism_from_dict(body_leg())
    rows = pd.DataFrame({"R-C": [2.5, 2.52, 2.47], "crank": [1.0, 0.98, 1.03], "R.x": [2.0, 2.03, 1.98],
                         "coupler.P.y": [0.0, 0.2, -0.1], "travel": [1.0, 2.0, 3.0]})
    ordered = simulate_batch(mech, rows, steps=360)
    flipped = simulate_batch(mech, rows[rows.columns[::-1]], steps=360)
    assert list(ordered.status) == [0, 0, 0]
    np.testing.assert_array_equal(ordered.paths["P"], flipped.paths["P"])
    for i, r in rows.iterrows():
        ref = body_leg_closed_form(THETA, {"B": [0.0, 0.0], "C": [2.5, 0.0], "P": [5.0, r["coupler.P.y"]]},
                                   crank=r["crank"], pivot=(r["R.x"], 0.0), rocker=r["R-C"])
        assert np.max(np.abs(ordered.paths["P"][i] - ref["P"])) < 1e-9 * mech.size


# -- a collinear coupler written as a triangle of links (issue 40) -------------------------------------------
def _hoeken_of_links(bp: float) -> dict:
    """Hoeken's leg with its coupler B–C–P written as three links (B-C 2.5, C-P 2.5, B-P ``bp``)."""
    return {"name": "hk", "foot": "P", "crank": {"center": [0.0, 0.0], "radius": 1.0, "tip": "B"},
            "fixed": {"D": [2.0, 0.0]}, "guess": {"C": [1.5, -2.45], "P": [2.0, -4.9]},
            "links": [{"a": "D", "b": "C", "length": 2.5}, {"a": "B", "b": "C", "length": 2.5},
                      {"a": "C", "b": "P", "length": 2.5}, {"a": "B", "b": "P", "length": bp}]}


def test_a_flat_triangle_of_links_is_refused_in_one_line(tmp_path, capsys):
    """The docs say a collinear coupler written as a triangle of links is refused; it was loaded, and its
    nominal then failed to assemble at θ = 0. Now the file is refused, naming the links (2.5 + 2.5 = 5:
    the three joints on one line, checked here by the triangle's area, which is zero)."""
    import math
    import tomllib

    a, b, c = 2.5, 2.5, 5.0
    s = (a + b + c) / 2
    assert math.sqrt(max(s * (s - a) * (s - b) * (s - c), 0.0)) == 0.0   # Heron: no area, a line
    with pytest.raises(UserError, match=r"links\[3\]: links 'B-C', 'C-P', 'B-P' make a flat triangle"):
        mechanism_from_dict(_hoeken_of_links(5.0), "hk.toml")
    # a thin triangle that is not flat is a design like any other (and turns)
    assert simulate(mechanism_from_dict(_hoeken_of_links(4.9), "hk.toml"), steps=36).ok
    # from the command line: exit 2, one line naming the file and the key
    from clihelp import cli
    path = tmp_path / "hk.toml"
    d = _hoeken_of_links(5.0)
    lines = [f'name = "{d["name"]}"', f'foot = "{d["foot"]}"', "[crank]", "center = [0.0, 0.0]", "radius = 1.0",
             'tip = "B"', "[fixed]", "D = [2.0, 0.0]", "[guess]", "C = [1.5, -2.45]", "P = [2.0, -4.9]"]
    for ln in d["links"]:
        lines += ["[[links]]", f'a = "{ln["a"]}"', f'b = "{ln["b"]}"', f"length = {ln['length']}"]
    path.write_text("\n".join(lines) + "\n")
    assert tomllib.loads(path.read_text())["links"] == d["links"]
    code, out, err = cli(capsys, "describe", path)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1
    assert f"{path}: links[3]:" in err and "flat triangle" in err and "[[bodies]]" in err
