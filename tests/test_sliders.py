"""Sliders (prismatic joints, issue 30): the file shape and its errors, the plan's SLIDE blocks and
slide rows in coupled blocks, and the solved positions, velocities and accelerations against plain-numpy
closed forms and a plain Newton written here: the offset slider-crank, Whitworth's quick-return (a slot
in a moving arm, its line and the ram's through a ground pivot), a slot inside a coupled loop, and a
linear actuator."""

from __future__ import annotations

import math
from importlib import resources

import numpy as np
import pytest

from explorer import UserError, load_mechanism, simulate, simulate_batch
from explorer.kernels import plan_for
from explorer.mechanism import mechanism_from_dict, mechanism_toml, parse_toml
from explorer.plan import GENERAL, ROW_SLIDE, SLIDE

TIGHT = 1e-12  # of the mechanism's size: the SLIDE blocks place exactly


def slider_crank_x(theta, a=1.4, b=4.0, c=1.0):
    """The offset slider-crank's piston: x = a cos θ + sqrt(b² − (a sin θ − c)²), and dx/dθ, d²x/dθ²."""
    s = a * np.sin(theta) - c
    w = np.sqrt(b * b - s * s)
    ds = a * np.cos(theta)
    x = a * np.cos(theta) + w
    dx = -a * np.sin(theta) - s * ds / w
    ddx = -a * np.cos(theta) - (ds * ds - s * a * np.sin(theta)) / w - (s * ds) ** 2 / w ** 3
    return x, dx, ddx


def d4(f, h):
    """Fourth-order central difference of a periodic sampled series (axis 0), step h."""
    return (-np.roll(f, -2, 0) + 8 * np.roll(f, -1, 0) - 8 * np.roll(f, 1, 0) + np.roll(f, 2, 0)) / (12 * h)


# -- the offset slider-crank -----------------------------------------------------------------------
def test_slidercrank_plan_is_one_slide_block():
    mech = load_mechanism("slidercrank")
    plan = plan_for(mech)
    assert [b.kind for b in plan.blocks] == [SLIDE]
    assert plan.slide.tolist() == [[mech.vertex_index("B"), -1, -1]]


@pytest.mark.parametrize("method", ["block", "dense", "closed", "auto"])
def test_slidercrank_matches_closed_form(method):
    mech = load_mechanism("slidercrank")
    cyc = simulate(mech, steps=360, method=method, accelerations=method != "closed")
    assert cyc.ok
    x, dx, ddx = slider_crank_x(cyc.theta)
    B = cyc.path("B")
    tol = TIGHT * mech.size if method != "dense" else 1e-11 * mech.size
    assert np.max(np.abs(B[:, 0] - x)) <= tol
    assert np.max(np.abs(B[:, 1] - 1.0)) <= tol
    if method != "closed":
        V, Acc = cyc.velocity("B"), cyc.accelerations[:, mech.vertex_index("B")]
        assert np.max(np.abs(V[:, 0] - dx)) <= 1e-12 * mech.size
        assert np.max(np.abs(V[:, 1])) <= 1e-12 * mech.size
        assert np.max(np.abs(Acc[:, 0] - ddx)) <= 1e-11 * mech.size
        # and both against finite differences of the closed form (not of the code's output)
        h = 1e-4
        fd = (slider_crank_x(cyc.theta + h)[0] - slider_crank_x(cyc.theta - h)[0]) / (2 * h)
        assert np.max(np.abs(V[:, 0] - fd)) <= 1e-7


def test_slidercrank_variants_move_the_line():
    """Per-variant slider parameters (its point and direction): a zero offset puts the line through the
    crank centre (a ground pivot), a tilted line is the offset slider-crank turned."""
    mech = load_mechanism("slidercrank")
    N = 4
    offs = np.array([1.0, 0.0, -0.5, 0.3])
    tilt = np.array([0.0, 0.0, 0.0, 0.4])  # radians: the line turned about the crank centre
    # the point (0, c) turned with the line, the direction (cos, sin)
    geometry = {"piston.x": -offs * np.sin(tilt), "piston.y": offs * np.cos(tilt),
                "piston.dx": 3.0 * np.cos(tilt), "piston.dy": 3.0 * np.sin(tilt)}
    batch = simulate_batch(mech, np.tile(mech.lengths, (N, 1)), np.full(N, 1.4), steps=90, geometry=geometry,
                           vertices=["B"])
    assert (batch.status == 0).all()
    for i in range(N):
        x, _, _ = slider_crank_x(batch.theta - tilt[i], c=offs[i])  # in the turned frame
        n = np.array([np.cos(tilt[i]), np.sin(tilt[i])])
        p0 = np.array([-offs[i] * np.sin(tilt[i]), offs[i] * np.cos(tilt[i])])
        along = (batch.paths["B"][i] - p0) @ n + p0 @ n
        across = (batch.paths["B"][i] - p0) @ np.array([-n[1], n[0]])
        assert np.max(np.abs(along - x)) <= TIGHT * 10 * mech.size
        assert np.max(np.abs(across)) <= TIGHT * 10 * mech.size


def test_slidercrank_assembly_gap_between_samples_is_found():
    """A rod just too short to reach the line near θ = 90°: with 7 samples (51.4° apart) the
    unreachable range [83.2°, 96.8°] lies between two samples; the sweep still finds its start."""
    mech = load_mechanism("slidercrank").with_parameters({"rod": 2.39, "piston.y": -1.0})
    cyc = simulate(mech, steps=7)
    assert not cyc.ok and cyc.failure.kind == "assembly"
    start = math.asin((2.39 - 1.0) / 1.4)
    assert abs(cyc.failure.theta - start) <= 2 * math.pi / 7 / 2 ** 15
    assert abs(cyc.failure.theta_end - (math.pi - start)) <= 2 * math.pi / 7 / 2 ** 15


# -- Whitworth's quick-return: a slot in a moving arm, both lines through the ground pivot O4 ----------
def whitworth_closed_form(theta, r=2.0, d=1.0, R=3.5, ell=7.0):
    A = np.stack([r * np.cos(theta), d + r * np.sin(theta)], axis=-1)
    phi = np.arctan2(A[:, 1], A[:, 0])
    B = R * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    C = np.stack([B[:, 0] + np.sqrt(ell ** 2 - B[:, 1] ** 2), np.zeros_like(phi)], axis=-1)
    return A, B, C


def test_whitworth_matches_closed_form():
    mech = load_mechanism("whitworth")
    plan = plan_for(mech)
    assert [b.kind for b in plan.blocks] == [SLIDE, SLIDE]  # the arm about O4 through A, then the ram
    cyc = simulate(mech, steps=720, accelerations=True)
    assert cyc.ok
    _, B, C = whitworth_closed_form(cyc.theta)
    assert np.max(np.abs(cyc.path("B") - B)) <= TIGHT * mech.size
    assert np.max(np.abs(cyc.path("C") - C)) <= TIGHT * mech.size
    h = 2 * np.pi / 720
    for v, ref in (("B", B), ("C", C)):
        assert np.max(np.abs(cyc.velocity(v) - d4(ref, h))) <= 1e-7 * mech.size
        acc = cyc.accelerations[:, mech.vertex_index(v)]
        assert np.max(np.abs(acc - d4(d4(ref, h), h))) <= 1e-5 * mech.size
    dense = simulate(mech, steps=720, method="dense", accelerations=True)
    assert dense.ok and np.max(np.abs(dense.accelerations - cyc.accelerations)) <= 1e-9 * mech.size


BODY_ARM = """[[bodies]]
name = "arm"
joints = { O4 = [0.0, 0.0], K = [1.0, 0.0], B = [3.5, 0.0] }
"""


def test_slot_in_a_body_with_an_offset():
    """Whitworth with its arm a three-joint body and the slot along two of its joints (O4, K), shifted
    0.3 to the left: cross(K − O4, A − O4)/|K − O4| = 0.3, so the arm's angle is φ = atan2(A − O4) −
    asin(0.3/|A − O4|) (the root on A's side), B = 3.5 (cos φ, sin φ)."""
    text = builtin_text("whitworth")
    arm = text[text.index("[[links]]\nname = \"arm\""):text.index("[[links]]\nname = \"rod\"")]
    text = (text.replace(arm, BODY_ARM).replace('line = ["O4", "B"]', 'line = ["O4", "K"]\noffset = 0.3')
            .replace("[guess]", "[guess]\nK = [0.9, 0.5]", 1))
    mech = mechanism_from_dict(parse_toml(text, "w.toml"), "w.toml")
    assert SLIDE in [b.kind for b in plan_for(mech).blocks]
    cyc = simulate(mech, steps=360, accelerations=True)
    assert cyc.ok
    A = cyc.path("A")
    phi = np.arctan2(A[:, 1], A[:, 0]) - np.arcsin(0.3 / np.hypot(A[:, 0], A[:, 1]))
    B = 3.5 * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    C = np.stack([B[:, 0] + np.sqrt(49.0 - B[:, 1] ** 2), np.zeros_like(phi)], axis=-1)
    assert np.max(np.abs(cyc.path("B") - B)) <= TIGHT * mech.size
    assert np.max(np.abs(cyc.path("C") - C)) <= TIGHT * mech.size
    assert np.max(np.abs(cyc.velocity("C") - d4(C, 2 * np.pi / 360))) <= 1e-5 * mech.size  # d4: O(h⁴)
    # the offset is a design parameter: moved back to 0 it is the built-in's arm
    back = simulate(mech.with_parameters({"block.offset": 0.0}), steps=90)
    _, B0, _ = whitworth_closed_form(back.theta)
    assert np.max(np.abs(back.path("B") - B0)) <= TIGHT * mech.size


def test_swinging_block_slot_through_a_ground_pivot():
    """The oscillating-cylinder inversion: the rod A-E slides through a block pivoted at the ground pivot
    O4, i.e. the slot A-E's line passes through O4 always: E = A + 5 (O4 − A)/|O4 − A|."""
    mech = mechanism_from_dict({
        "name": "swing", "foot": "E", "crank": {"center": [0.0, 0.0], "radius": 1.0, "tip": "A"},
        "fixed": {"O4": [3.0, 0.0]}, "guess": {"E": [5.5, 0.5]},
        "links": [{"a": "A", "b": "E", "length": 5.0}],
        "sliders": [{"name": "block", "vertex": "O4", "line": ["A", "E"]}]})
    assert [b.kind for b in plan_for(mech).blocks] == [SLIDE]
    cyc = simulate(mech, steps=360, accelerations=True)
    assert cyc.ok
    A = cyc.path("A")
    g = np.array([3.0, 0.0]) - A
    E = A + 5.0 * g / np.linalg.norm(g, axis=1)[:, None]
    assert np.max(np.abs(cyc.path("E") - E)) <= TIGHT * mech.size
    h = 2 * np.pi / 360
    assert np.max(np.abs(cyc.velocity("E") - d4(E, h))) <= 1e-6 * mech.size
    acc = cyc.accelerations[:, mech.vertex_index("E")]
    assert np.max(np.abs(acc - d4(d4(E, h), h))) <= 1e-5 * mech.size
    dense = simulate(mech, steps=360, method="dense")
    assert dense.ok and np.max(np.abs(dense.positions - cyc.positions)) <= 1e-11 * mech.size


def test_whitworth_quick_return_ratio():
    """The ram's cutting stroke (along −x, the line's direction) takes (π + 2β) of crank, the return
    (π − 2β), β = arcsin(O2O4 / O2A): a ratio of 2, read off the solved ram's dead centres."""
    mech = load_mechanism("whitworth")
    steps = 3600
    cyc = simulate(mech, steps=steps, velocities=False)
    x = cyc.path("C")[:, 0]
    t_max, t_min = cyc.theta[np.argmax(x)], cyc.theta[np.argmin(x)]
    cutting = (t_min - t_max) % (2 * np.pi)  # from the right dead centre to the left one
    beta = math.asin(1.0 / 2.0)
    assert abs(cutting - (np.pi + 2 * beta)) <= 2 * (2 * np.pi / steps)
    ratio = cutting / (2 * np.pi - cutting)
    assert abs(ratio - 2.0) <= 0.01


def test_quick_return_metric():
    """The metric from the one table: a slider-crank's outward stroke takes π + asin(c/(a + b)) −
    asin(c/(b − a)) of crank, Whitworth's cutting stroke π + 2β; not applicable to a foot off a slider."""
    from explorer.gait import available_metrics, compute_metrics

    for name, forward in (("slidercrank", np.pi + math.asin(1 / 5.4) - math.asin(1 / 2.6)),
                          ("whitworth", np.pi + 2 * math.asin(0.5))):
        mech = load_mechanism(name)
        cyc = simulate(mech, steps=720)
        got = compute_metrics(cyc.path(mech.foot)[None], cyc.velocity(mech.foot)[None], [0], ["quick_return"],
                              mechanism=mech)["quick_return"][0]
        assert got == pytest.approx(forward / (2 * np.pi - forward), rel=1e-4), name
    assert "no foot on a ground slider" in available_metrics(load_mechanism("fourbar"))["quick_return"]


# -- a slot on a moving link inside a coupled loop: one GENERAL block with slide rows -----------------
def slot_loop():
    return {"name": "slotloop", "foot": "F",
            "crank": {"center": [0.0, 0.0], "radius": 1.0, "tip": "A"},
            "fixed": {"D": [4.0, 3.0]}, "guess": {"E": [0.5, 3.0], "F": [0.5, -3.0]},
            "links": [{"a": "D", "b": "E", "length": 4.0}, {"a": "E", "b": "F", "length": 7.0}],
            "sliders": [{"name": "slot", "vertex": "A", "line": ["E", "F"]},
                        {"name": "shoe", "vertex": "F", "point": [0.0, -3.0], "direction": [1.0, 0.0]}]}


def slot_loop_newton(theta):
    """Plain Newton on the loop's four equations in (E, F), continued from the guess, per sample."""
    D = np.array([4.0, 3.0])
    z = np.array([0.5, 3.0, 0.5, -3.0])
    out = []
    for t in theta:
        A = np.array([np.cos(t), np.sin(t)])
        for _ in range(60):
            E, F = z[:2], z[2:]
            g = F - E
            res = np.array([(E - D) @ (E - D) - 16.0, g @ g - 49.0,
                            (g[0] * (A[1] - E[1]) - g[1] * (A[0] - E[0])) / 7.0, F[1] + 3.0])
            J = np.zeros((4, 4))
            J[0, :2] = 2 * (E - D)
            J[1, :2], J[1, 2:] = -2 * g, 2 * g
            J[2, :2] = np.array([F[1] - A[1], A[0] - F[0]]) / 7.0
            J[2, 2:] = np.array([A[1] - E[1], E[0] - A[0]]) / 7.0
            J[3, 3] = 1.0
            step = np.linalg.solve(J, -res)
            z = z + step
            if np.max(np.abs(step)) < 1e-15:
                break
        out.append(z.copy())
    return np.array(out)


def test_slot_inside_a_loop_is_a_general_block():
    mech = mechanism_from_dict(slot_loop())
    plan = plan_for(mech)
    assert [b.kind for b in plan.blocks] == [GENERAL]
    from explorer.testing import topology
    topo = topology(plan, range(plan.n_blocks), [], [], True)
    assert sorted(topo.gen_rows[:, 0].tolist()).count(ROW_SLIDE) == 2
    cyc = simulate(mech, steps=360, accelerations=True, tolerance=1e-12)
    assert cyc.ok
    ref = slot_loop_newton(cyc.theta)
    assert np.max(np.abs(cyc.path("E") - ref[:, :2])) <= 1e-10 * mech.size
    assert np.max(np.abs(cyc.path("F") - ref[:, 2:])) <= 1e-10 * mech.size
    h = 2 * np.pi / 360
    assert np.max(np.abs(cyc.velocity("E") - d4(ref[:, :2], h))) <= 1e-5 * mech.size
    assert np.max(np.abs(cyc.velocity("F") - d4(ref[:, 2:], h))) <= 1e-5 * mech.size
    dense = simulate(mech, steps=360, method="dense", accelerations=True, tolerance=1e-12)
    assert dense.ok and np.max(np.abs(dense.accelerations - cyc.accelerations)) <= 1e-8 * mech.size
    acc = cyc.accelerations[:, mech.vertex_index("E")]
    assert np.max(np.abs(acc - d4(cyc.velocity("E"), h))) <= 1e-4 * mech.size


# -- a linear actuator pushing a slider --------------------------------------------------------------
ACTUATED = """
name = "lift"
foot = "Q"
[driver]
slider = "ram"
stroke = [2.0, 4.0]
duration = 5.0
timing = "quintic"
[fixed]
D = [3.0, 3.0]
[guess]
Q = [3.0, 0.5]
[[links]]
a = "P"
b = "Q"
length = 2.0
[[links]]
a = "D"
b = "Q"
length = 2.5
[[sliders]]
name = "ram"
vertex = "P"
point = [0.0, 0.0]
direction = [1.0, 0.0]
"""


def test_linear_actuator_drives_its_slider():
    mech = mechanism_from_dict(parse_toml(ACTUATED, "lift.toml"), "lift.toml")
    assert "ram.dx" not in mech.parameters() and "ram.x" in mech.parameters()
    cyc = simulate(mech, steps=201)
    assert cyc.ok
    tau = cyc.theta / 5.0
    s = 2.0 + 2.0 * tau ** 3 * (10 - 15 * tau + 6 * tau ** 2)
    P = cyc.path("P")
    assert np.max(np.abs(P[:, 0] - s)) <= TIGHT * mech.size and np.max(np.abs(P[:, 1])) <= TIGHT * mech.size
    # Q: the circles about P (2) and D (2.5), on the side of P → D the guess takes
    D = np.array([3.0, 3.0])
    g = D - P
    d = np.linalg.norm(g, axis=1)
    x = (4.0 - 6.25 + d * d) / (2 * d)
    y = np.sqrt(4.0 - x * x)
    u = g / d[:, None]
    Q = P + x[:, None] * u - y[:, None] * np.stack([-u[:, 1], u[:, 0]], axis=1)
    assert np.max(np.abs(cyc.path("Q") - Q)) <= 1e-11 * mech.size
    # a variant with the line moved: the actuator's path moves with it
    moved = simulate(mech.with_parameters({"ram.y": 0.25}), steps=51)
    assert moved.ok and np.max(np.abs(moved.path("P")[:, 1] - 0.25)) <= TIGHT
    batch = simulate_batch(mech, np.tile(mech.lengths, (2, 1)), steps=51, geometry={"ram.y": [0.0, 0.25]},
                           vertices=["P", "Q"])
    assert np.max(np.abs(batch.paths["Q"][1] - moved.path("Q"))) <= 1e-11 * mech.size
    # the file round-trips through the TOML writer
    again = mechanism_from_dict(parse_toml(mechanism_toml(mech), "again.toml"), "again.toml")
    assert again.path == mech.path and again.sliders == mech.sliders


def test_sliders_round_trip_and_parameters():
    mech = load_mechanism("whitworth")
    again = mechanism_from_dict(parse_toml(mechanism_toml(mech), "w.toml"), "w.toml")
    assert again.sliders == mech.sliders and again.parameters() == mech.parameters()
    assert mech.parameters()["block.offset"] == 0.0 and mech.parameters()["ram.dx"] == -1.0
    assert mech.parameter_kind("ram.y") == "coordinate"


def energy_torque(theta, pos, vel, bars, unit, omega, g):
    """Plain energy balance with a frictionless slider and constant crank speed: τ = d(KE + PE)/dθ, KE of
    uniform bars m/6·(|ȧ|² + ȧ·ḃ + |ḃ|²), PE = m g (y_a + y_b)/2; pos/vel {vertex: (S, 2)} per radian."""
    E = np.zeros(len(theta))
    for a, b, m in bars:
        va, vb = vel[a] * unit * omega, vel[b] * unit * omega
        E += m / 6 * (np.sum(va * va, 1) + np.sum(va * vb, 1) + np.sum(vb * vb, 1))
        E += m * g * unit * (pos[a][:, 1] + pos[b][:, 1]) / 2
    return d4(E[:, None], theta[1] - theta[0])[:, 0]


def test_forces_through_a_ground_slider_balance_energy():
    """A heavy connecting rod, gravity on, the crank at 120 rpm: the motor torque is the rate of change of
    the rod's energy (the guide is frictionless and does no work), and the guide pushes normal to its
    line only."""
    text = builtin_text("slidercrank").replace('length = 4.0', 'length = 4.0\nmass = 0.5')
    mech = mechanism_from_dict(parse_toml(text, "s.toml"), "s.toml")
    op = {"unit": 0.05, "rpm": 120, "gravity": 9.81}
    cyc = simulate(mech, steps=720, forces=True, operating=op)
    assert cyc.ok
    th = cyc.theta
    x, dx, _ = slider_crank_x(th)
    pos = {"A": 1.4 * np.stack([np.cos(th), np.sin(th)], 1), "B": np.stack([x, np.ones_like(x)], 1)}
    vel = {"A": 1.4 * np.stack([-np.sin(th), np.cos(th)], 1), "B": np.stack([dx, np.zeros_like(x)], 1)}
    ref = energy_torque(th, pos, vel, [("A", "B", 0.5)], 0.05, 120 * 2 * np.pi / 60, 9.81)
    assert np.max(np.abs(cyc.torque - ref)) <= 1e-6 * np.max(np.abs(ref))
    guide = cyc.member_forces[("frame", "B")]
    assert np.max(np.abs(guide[:, 0])) == 0.0 and np.max(np.abs(guide[:, 1])) > 0.1


def test_forces_through_a_slot_inside_a_loop_balance_energy():
    """The coupled block's slide rows in the forces effect: heavy links, energy from the plain Newton."""
    data = slot_loop()
    data["links"][0]["mass"], data["links"][1]["mass"] = 0.3, 0.7
    mech = mechanism_from_dict(data)
    cyc = simulate(mech, steps=720, forces=True, operating={"unit": 0.1, "rpm": 30, "gravity": 9.81},
                   tolerance=1e-12)
    assert cyc.ok
    th = cyc.theta
    ref = slot_loop_newton(th)
    h = th[1] - th[0]
    D = np.broadcast_to(np.array([4.0, 3.0]), ref[:, :2].shape)
    pos = {"D": D, "E": ref[:, :2], "F": ref[:, 2:]}
    vel = {"D": np.zeros_like(D), "E": d4(ref[:, :2], h), "F": d4(ref[:, 2:], h)}
    want = energy_torque(th, pos, vel, [("D", "E", 0.3), ("E", "F", 0.7)], 0.1, np.pi, 9.81)
    assert np.max(np.abs(cyc.torque - want)) <= 1e-4 * np.max(np.abs(want))


def test_forces_through_a_slot_balance_energy():
    """Whitworth with a heavy arm and rod: the slot and the ram's guide do no work."""
    text = builtin_text("whitworth").replace('length = 3.5', 'length = 3.5\nmass = 0.8').replace(
        'length = 7.0', 'length = 7.0\nmass = 1.2')
    mech = mechanism_from_dict(parse_toml(text, "w.toml"), "w.toml")
    op = {"unit": 0.02, "rpm": 60, "gravity": 9.81}
    cyc = simulate(mech, steps=1440, forces=True, operating=op)
    assert cyc.ok
    th = cyc.theta
    _, B, C = whitworth_closed_form(th)
    h = th[1] - th[0]
    pos = {"O4": np.zeros_like(B), "B": B, "C": C}
    vel = {"O4": np.zeros_like(B), "B": d4(B, h), "C": d4(C, h)}
    ref = energy_torque(th, pos, vel, [("O4", "B", 0.8), ("B", "C", 1.2)], 0.02, 2 * np.pi, 9.81)
    assert np.max(np.abs(cyc.torque - ref)) <= 1e-4 * np.max(np.abs(ref))
    # the block in the slot: the arm's push on the crank pin is normal to the arm
    push = cyc.member_forces[("arm", "A")]
    arm = B / np.linalg.norm(B, axis=1)[:, None]
    assert np.max(np.abs(np.sum(push * arm, 1))) <= 1e-9 * np.max(np.abs(push))


# -- errors name the file, the key and the value -----------------------------------------------------
def builtin_text(name):
    return (resources.files("explorer.mechanism") / "builtin" / f"{name}.toml").read_text(encoding="utf-8")


@pytest.mark.parametrize("change, key, words", [
    ({"line": ["A", "B"]}, "sliders[0]", "either point and direction"),
    ({"direction": [0.0, 0.0]}, "sliders[0].direction", "[0.0, 0.0]"),
    ({"vertex": "Z"}, "sliders[0].vertex", "'Z'"),
    ({"offset": 1.0}, "sliders[0].offset", "1.0"),
    ({"name": "rod"}, "sliders[0].name", "'rod'"),
])
def test_slider_errors(change, key, words):
    data = parse_toml(builtin_text("slidercrank"), "s.toml")
    data["sliders"][0].update(change)
    with pytest.raises(UserError) as err:
        mechanism_from_dict(data, "s.toml")
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"s.toml: {key}") and words in msg


def test_slot_errors():
    data = parse_toml(builtin_text("whitworth"), "w.toml")
    data["sliders"][0]["line"] = ["O4", "C"]
    with pytest.raises(UserError, match=r"w.toml: sliders\[0\].line: O4 and C are not held at a fixed distance"):
        mechanism_from_dict(data, "w.toml")
    data = parse_toml(ACTUATED, "lift.toml")
    data["driver"]["slider"] = "nope"
    with pytest.raises(UserError, match=r"lift.toml: driver.slider: no \[\[sliders\]\] table is called 'nope'"):
        mechanism_from_dict(data, "lift.toml")
