"""`explorer edit`, without a browser: what a drag does to a design, the branch kept, the API against the
library, bad input and the output policy (the page itself: tests/test_edit_browser.py).

References are plain: a dragged design's constraints are checked on the configuration shown with numpy
(distances, the bodies' shapes, the sliders' lines), Jansen's dragged leg is solved by the closed form of
tests/naive.py (sequential circle-circle intersections), and the walker metrics the API returns are
compared with tests/naive_walker.py on that closed form with finite-difference velocities.
"""

from __future__ import annotations

import base64
import json
import math
import os

import numpy as np
import pytest

import explorer
from explorer.edit import CRANK_CENTRE, EditSession, design_data, drag, parse_design, set_parameters
from explorer.errors import UserError
from naive import JANSEN_LINKS, JANSEN_VERTICES, cross, jansen_closed_form, jansen_signs
from naive_walker import legs_at, naive_walker

flask = pytest.importorskip("flask", reason="the edit extra: pip install 'explorer[edit]'")

STEPS = 360


def _constraint_errors(mech, P: np.ndarray) -> list[float]:
    """Every constraint of ``mech`` evaluated on positions P (n_vertices, 2), plainly: each link's
    length error, each body's pairwise-distance errors and the sign of its area (a body never mirrors),
    each ground slider's distance from its line, each slot's offset error."""
    at = {v: P[i] for i, v in enumerate(mech.vertices)}
    out = []
    for link in mech.links:
        out.append(abs(np.hypot(*(at[link.a] - at[link.b])) - link.length))
    for body in mech.bodies:
        pts = np.asarray(body.points)
        world = np.array([at[j] for j in body.joints])
        for a in range(len(pts)):
            for b in range(a):
                out.append(abs(np.hypot(*(world[a] - world[b])) - np.hypot(*(pts[a] - pts[b]))))
        if len(pts) >= 3:  # same orientation: the signed area of the first three joints keeps its sign
            s_body = cross(pts[1] - pts[0], pts[2] - pts[0])
            s_world = cross(world[1] - world[0], world[2] - world[0])
            out.append(0.0 if abs(s_body) < 1e-12 or np.sign(s_body) == np.sign(s_world) else 1.0)
    for s in mech.sliders:
        v = at[s.vertex]
        if s.ground:
            d = np.asarray(s.direction) / np.hypot(*s.direction)
            out.append(abs(cross(d, v - np.asarray(s.point))))
        else:
            a, b = at[s.line[0]], at[s.line[1]]
            out.append(abs(cross(b - a, v - a) / np.hypot(*(b - a)) - s.offset))
    if mech.crank is not None:
        tip = at[mech.crank.tip]
        out.append(abs(np.hypot(*(tip - np.asarray(mech.crank.center))) - mech.crank.radius))
    for v, xy in mech.fixed.items():
        out.append(float(np.max(np.abs(at[v] - np.asarray(xy)))))
    return out


def _draggable(mech):
    joints = [v for v in mech.vertices if v != mech.driven or mech.crank is not None]
    return joints + ([CRANK_CENTRE] if mech.crank is not None else [])


@pytest.mark.parametrize("name", explorer.builtin_mechanisms())
def test_a_drag_moves_one_joint_and_the_design_fits_the_configuration_shown(name):
    """Every draggable joint of every built-in (moving joints, ground pivots, the crank tip and centre,
    body joints, slider vertices): the configuration after the step has that joint where it was dragged
    and every other where it was; the new design's constraints hold on it; and explorer.simulate of the
    new design passes through it (the branch was carried to θ = 0)."""
    mech = explorer.load_mechanism(name)
    cyc = explorer.simulate(mech, STEPS)
    k = 30
    P = cyc.positions[k]
    assert np.all(np.isfinite(P))
    step = 0.01 * mech.size * np.array([1.0, -0.7])
    if mech.gears:  # a geared crank's tip turns with the crank: the editor refuses, saying so
        d = drag(mech, cyc.theta[k], mech.vertices[1], P[1] + step, near=P)
        assert d.design is None and "gears" in d.refused
        return
    for j in _draggable(mech):
        start = np.asarray(mech.crank.center) if j == CRANK_CENTRE else P[mech.vertex_index(j)]
        d = drag(mech, cyc.theta[k], j, start + step, near=P)
        assert d.design is not None, (name, j, d.refused)
        new = d.design
        scale = mech.size
        # the joint moved, nothing else did
        if j == CRANK_CENTRE:
            assert np.allclose(new.crank.center, start + step, rtol=0, atol=1e-12 * scale)
            assert np.allclose(d.config, P, rtol=0, atol=1e-9 * scale)
        else:
            i = mech.vertex_index(j)
            assert np.allclose(d.config[i], start + step, rtol=0, atol=1e-12 * scale)
            others = np.arange(len(mech.vertices)) != i
            assert np.allclose(d.config[others], P[others], rtol=0, atol=1e-9 * scale)
        assert max(_constraint_errors(new, d.config)) < 1e-9 * scale, (name, j)
        # explorer.simulate of the new design passes through the configuration shown
        c2 = explorer.simulate(new, STEPS)
        if mech.crank is None:
            k2 = k
        else:
            k2 = int(round(d.angle / (2 * math.pi / STEPS))) % STEPS
        if abs(d.angle - c2.theta[k2]) < 1e-12 and np.all(np.isfinite(c2.positions[k2])):
            assert np.allclose(c2.positions[k2], d.config, rtol=0, atol=1e-9 * scale), (name, j)
        elif mech.crank is not None and j in (CRANK_CENTRE, mech.driven):  # off the sample grid: θ itself
            tip = d.config[mech.vertex_index(mech.driven)] - np.asarray(new.crank.center)
            assert math.isclose(math.atan2(tip[1], tip[0]) % (2 * math.pi), d.angle, abs_tol=1e-12)


def test_the_branch_shown_wins_over_a_guess_that_picks_another():
    """A design whose guess puts foot 7 on its mirror side at θ = 0 (another branch than the leg the page
    shows): a drag keeps the branch shown, and the design returned carries it in its guess, so that
    explorer.simulate of it passes through the configuration shown (the continuation to θ = 0)."""
    from dataclasses import replace

    mech = explorer.load_mechanism("jansen")
    cyc = explorer.simulate(mech, STEPS)
    P0 = cyc.positions[0]
    i5, i6, i7 = (mech.vertex_index(v) for v in ("5", "6", "7"))
    other = replace(mech, guess={**dict(mech.guess), "7": tuple(_mirror(P0[i7], P0[i5], P0[i6]))})
    flipped = explorer.simulate(other, STEPS)
    assert flipped.ok and not np.allclose(flipped.positions[:, i7], cyc.positions[:, i7])  # another branch
    k = 90
    P = cyc.positions[k]
    d = drag(other, cyc.theta[k], "4", P[mech.vertex_index("4")] + [0.3, 0.2], near=P)
    assert d.design is not None
    again = explorer.simulate(d.design, STEPS)
    assert np.allclose(again.positions[k], d.config, rtol=0, atol=1e-9)
    side = lambda Q: np.sign(cross(Q[:, i6] - Q[:, i5], Q[:, i7] - Q[:, i5]))  # noqa: E731  7's dyad's branch
    assert np.array_equal(side(again.positions), side(cyc.positions))
    assert not np.array_equal(side(flipped.positions), side(cyc.positions))


def test_crank_tip_drag_sets_the_radius_and_the_angle():
    mech = explorer.load_mechanism("jansen")
    cyc = explorer.simulate(mech, STEPS)
    to = np.array([3.0, 17.0])
    d = drag(mech, cyc.theta[0], "1", to, near=cyc.positions[0])
    assert math.isclose(d.design.crank.radius, math.hypot(3.0, 17.0), rel_tol=1e-15)
    assert math.isclose(d.angle, math.atan2(17.0, 3.0), rel_tol=1e-15)
    assert np.array_equal(d.config[0], to)


def _mirror(p, a, b):
    """p reflected across the line a-b."""
    u = (b - a) / np.hypot(*(b - a))
    w = p - a
    return a + 2 * np.dot(w, u) * u - w


def test_a_drag_across_a_dyads_parents_is_refused_not_jumped():
    """Vertex 3 of Jansen's leg is placed by its two parents 1 and 2: dragged onto the mirror side of the
    line 1-2 it would put the leg on another branch; the step is refused, saying which vertex and line."""
    mech = explorer.load_mechanism("jansen")
    cyc = explorer.simulate(mech, STEPS)
    k = 0
    P = cyc.positions[k]
    p1, p2, p3 = (P[mech.vertex_index(v)] for v in ("1", "2", "3"))
    assert np.sign(cross(p2 - p1, p3 - p1)) == jansen_signs()["3"]  # the naive reference's branch
    d = drag(mech, cyc.theta[k], "3", _mirror(p3, p1, p2), near=P)
    assert d.design is None
    assert "3" in d.refused and "1–2" in d.refused and "mirror" in d.refused
    assert np.allclose(d.config, P, rtol=0, atol=1e-9)  # the design and the leg shown stay as they were
    # a drag toward the line that stays on this side is taken
    d = drag(mech, cyc.theta[k], "3", p3 + 0.5 * (_mirror(p3, p1, p2) - p3) * 0.9, near=P)
    assert d.design is not None
    # a vertex whose own dyad is downstream: moving 2 across the line 3-4 flips 4's dyad (3, 2)
    p4 = P[mech.vertex_index("4")]
    d = drag(mech, cyc.theta[k], "2", _mirror(p2, p3, p4), near=P)
    assert d.design is None and "refused" in d.refused


def _jansen_lengths(mech):
    by_pair = {frozenset((l.a, l.b)): l.length for l in mech.links}
    return np.array([by_pair[frozenset(pair)] for pair in JANSEN_LINKS])


def test_dragged_jansen_against_the_closed_form_and_the_naive_walker():
    """Joint 4 dragged by a known amount at θ = 36°: the design's lengths are the distances of the
    dragged configuration (plain numpy on the closed form's positions); the API's foot path equals the
    closed form of those lengths on the nominal's branch; its walker metrics equal the naive walker."""
    session = EditSession("jansen")
    mech = session.reference
    k = 36
    th = 2 * np.pi * np.arange(STEPS) / STEPS
    P0, ok, _ = jansen_closed_form(_jansen_lengths(mech), mech.crank.radius, th)
    assert ok.all()
    config = {v: list(P0[k, i]) for i, v in enumerate(JANSEN_VERTICES)}
    delta = np.array([2.5, -1.75])
    to = P0[k, 3] + delta
    res = session.drag(design_data(mech), float(th[k]), "4", list(to), config)
    assert "refused" not in res, res.get("refused")
    new = parse_design(res["design"])
    Pd = P0[k].copy()
    Pd[3] = to
    want = {("3", "4"), ("2", "4"), ("4", "5")}
    for (a, b), L in zip(JANSEN_LINKS, _jansen_lengths(new)):
        ia, ib = JANSEN_VERTICES.index(a), JANSEN_VERTICES.index(b)
        expected = np.hypot(*(Pd[ia] - Pd[ib])) if (a, b) in want else dict(zip(JANSEN_LINKS, _jansen_lengths(mech)))[(a, b)]
        assert math.isclose(L, expected, rel_tol=1e-13), (a, b)
    lengths = _jansen_lengths(new)
    ref, ok, _ = jansen_closed_form(lengths, new.crank.radius, th)
    assert ok.all()
    P = np.frombuffer(base64.b64decode(res["solve"]["positions"]), dtype="<f4").reshape(STEPS, 7, 2)  # as the page reads it
    assert np.allclose(P, ref, rtol=1e-6, atol=0)  # float32, to draw
    foot = np.array(session.solve(res["design"])["foot"], dtype=float)  # POST /api/solve's list
    assert np.allclose(foot, ref[:, 6], rtol=0, atol=1e-9)
    assert res["solve"]["status"] == "ok"

    def leg(theta):
        theta = np.asarray(theta, dtype=float)
        p = jansen_closed_form(lengths, new.crank.radius, theta)[0][:, 6]
        h = 1e-6
        v = (jansen_closed_form(lengths, new.crank.radius, theta + h)[0][:, 6]
             - jansen_closed_form(lengths, new.crank.radius, theta - h)[0][:, 6]) / (2 * h)
        return p, v

    w = new.walker
    Y, VX, VY = legs_at(leg, STEPS, w.phases, w.mirrored)
    naive = naive_walker(Y, VX, VY, new.crank.radius, w.drag, w.contact)
    got = res["solve"]["metrics"]
    for m in ("travel", "bob", "clearance", "peak_torque", "contact_fraction"):
        assert math.isclose(got[m], naive[m], rel_tol=1e-6, abs_tol=1e-9), (m, got[m], naive[m])
    assert math.isclose(got["slip"], naive["slip"], rel_tol=1e-4)


def test_api_solve_equals_explorer_simulate_for_every_builtin():
    """POST /api/solve on GET /api/design's data: the foot path, the status and the walker metrics of
    explorer.simulate and explorer.gait.compute_metrics on the same design, exactly."""
    from explorer.edit import make_app
    from explorer.gait import available_metrics, compute_metrics

    for name in explorer.builtin_mechanisms():
        session = EditSession(name)
        client = make_app(session).test_client()
        data = client.get("/api/design").get_json()
        assert data == json.loads(json.dumps(design_data(explorer.load_mechanism(name))))
        r = client.post("/api/solve", json=data)
        assert r.status_code == 200, r.get_json()
        got = r.get_json()
        mech = explorer.load_mechanism(name)
        cyc = explorer.simulate(mech, STEPS)
        assert got["status"] == ("ok" if cyc.ok else cyc.failure.kind)
        foot = cyc.path(mech.foot)
        assert np.array_equal(np.array(got["foot"], dtype=float), foot)
        names = [m for m, why in available_metrics(mech).items() if why is None and m != "path_error"]
        if names:
            want = compute_metrics(foot[None], cyc.velocity(mech.foot)[None], np.zeros(1, dtype=np.int64), names,
                                   mechanism=mech)
            for m in names:
                assert got["metrics"][m] == pytest.approx(float(want[m][0]), rel=0, abs=0) or (
                    math.isnan(want[m][0]) and got["metrics"][m] is None), (name, m)


@pytest.mark.parametrize("name", ["jansen", "klann", "hoeken", "strider"])
def test_screen_margins_agree_with_the_screen_of_a_results_frame(name):
    """The editor's one-design screen (no pandas: it is on every drag step) against explorer.gait's
    screen_columns on a one-row frame, for designs that pass and designs that fail some check."""
    import pandas as pd

    from explorer.edit import live_metrics, screen_margins
    from explorer.gait import Screen, screen_columns

    mech = explorer.load_mechanism(name)
    tight = Screen(min_transmission_angle=20.0, max_foot_speed=2.0)
    for factor in (1.0, 1.04, 1.3):
        for screen in (None, tight):
            m = mech.with_lengths({mech.links[0].name: mech.links[0].length * factor})
            cyc = explorer.simulate(m, STEPS)
            metrics, _ = live_metrics(m, cyc)
            status = "ok" if cyc.ok else cyc.failure.kind
            got = screen_margins(m, metrics, status, screen)
            df = pd.DataFrame({k: [np.nan if v is None else v] for k, v in metrics.items()})
            df["status"], df["crank"] = [status], [m.crank.radius]
            buildable, reasons, applied = screen_columns(df, screen)
            assert got["buildable"] == bool(buildable[0]) and got["reason"] == reasons[0], (name, factor)
            assert [c["check"] for c in got["checks"]] == applied


def test_set_parameters_keeps_the_branch():
    mech = explorer.load_mechanism("jansen")
    new = set_parameters(mech, {"1-3": 50.6, "2.y": -8.3})
    cyc = explorer.simulate(new, STEPS)
    lengths = _jansen_lengths(new)
    ref, ok, _ = jansen_closed_form(lengths, 15.0, 2 * np.pi * np.arange(STEPS) / STEPS, fixed2=(-38.0, -8.3))
    assert cyc.ok and ok.all()
    assert np.allclose(cyc.positions, ref, rtol=0, atol=1e-9)
    with pytest.raises(UserError, match="unknown design parameter"):
        set_parameters(mech, {"nope": 1.0})
    with pytest.raises(UserError, match="2-6"):
        set_parameters(mech, {"2-6": -1.0})


@pytest.fixture()
def client(tmp_path):
    from explorer.edit import make_app

    session = EditSession("jansen", folder=tmp_path)
    return make_app(session, {"127.0.0.1:8765"}).test_client(), session, tmp_path


def _post(c, path, body, **kw):
    return c.post(path, json=body, headers={"Host": "127.0.0.1:8765"}, **kw)


def _nested(n):
    x = [1.0]
    for _ in range(n):
        x = [x]
    return x


@pytest.mark.parametrize("mutate, words", [
    (lambda d: d["links"][0].update(length=-3.0), "links[0].length"),
    (lambda d: d["links"][0].update(length=10 ** 30), "links[0].length"),
    (lambda d: d.update(foot="99"), "foot"),
    (lambda d: d.pop("links"), "links"),
    (lambda d: d["links"][0].update(a=None), "null"),
    (lambda d: d.update(extra={"__import__": "os"}), "extra"),
    (lambda d: d["crank"].update(radius=_nested(20)), "nested"),
    (lambda d: d.update(name="x\u0000"), "control character"),
])
def test_bad_designs_are_one_clear_line(client, mutate, words):
    c, session, _ = client
    data = design_data(session.reference)
    mutate(data)
    r = _post(c, "/api/solve", data)
    assert r.status_code == 400
    err = r.get_json()["error"]
    assert words in err and "\n" not in err and "Traceback" not in err


def test_nan_and_huge_numbers_are_refused(client):
    c, session, _ = client
    text = json.dumps(design_data(session.reference)).replace("\"length\": 50.0", "\"length\": NaN", 1)
    r = c.post("/api/solve", data=text, content_type="application/json", headers={"Host": "127.0.0.1:8765"})
    assert r.status_code == 400 and "finite" in r.get_json()["error"]
    text = json.dumps(design_data(session.reference)).replace("\"length\": 50.0", "\"length\": 1" + "0" * 400, 1)
    r = c.post("/api/solve", data=text, content_type="application/json", headers={"Host": "127.0.0.1:8765"})
    assert r.status_code == 400 and "too large" in r.get_json()["error"]


def test_the_server_answers_only_its_own_host_origin_and_json(client):
    c, session, _ = client
    data = design_data(session.reference)
    assert c.get("/api/design", headers={"Host": "evil.example:8765"}).status_code == 403  # DNS rebinding
    assert c.post("/api/solve", json=data, headers={"Host": "127.0.0.1:8765",
                                                    "Origin": "http://evil.example"}).status_code == 403
    r = c.post("/api/solve", data="name=x", content_type="application/x-www-form-urlencoded",
               headers={"Host": "127.0.0.1:8765"})
    assert r.status_code == 415  # a form from another page cannot reach it without a preflight
    assert c.get("/static/..%2Fpyproject.toml", headers={"Host": "127.0.0.1:8765"}).status_code == 404
    assert c.get("/", headers={"Host": "127.0.0.1:8765"}).status_code == 200
    assert _post(c, "/api/drag", {"design": data, "angle": 0.0, "joint": "nope", "to": [0, 0]}).status_code == 400


def test_save_obeys_the_output_policy(client):
    c, session, folder = client
    data = design_data(session.reference)
    r = _post(c, "/api/save", {"design": data, "path": "leg.toml", "format": "toml", "check": True})
    assert r.get_json() == {"exists": []}
    r = _post(c, "/api/save", {"design": data, "path": "leg.toml", "format": "toml"})
    assert r.status_code == 200 and (folder / "leg.toml").exists()
    back = explorer.load_mechanism(folder / "leg.toml")
    assert back.parameters() == session.reference.parameters()
    before = (folder / "leg.toml").read_bytes()
    data2 = json.loads(json.dumps(data))
    data2["links"][0]["length"] = 50.5
    r = _post(c, "/api/save", {"design": data2, "path": "leg.toml", "format": "toml"})
    assert r.status_code == 409 and r.get_json()["exists"] and "exists" in r.get_json()["error"]
    assert (folder / "leg.toml").read_bytes() == before
    assert _post(c, "/api/save", {"design": data2, "path": "leg.toml", "check": True}).get_json()["exists"]
    r = _post(c, "/api/save", {"design": data2, "path": "leg.toml", "format": "toml", "force": True})
    assert r.status_code == 200
    assert explorer.load_mechanism(folder / "leg.toml").parameters()["1-3"] == 50.5
    os.symlink(folder / "leg.toml", folder / "link.toml")
    r = _post(c, "/api/save", {"design": data2, "path": "link.toml", "format": "toml", "force": True})
    assert r.status_code == 400 and "symbolic link" in r.get_json()["error"]
    r = _post(c, "/api/save", {"design": data2, "path": "parts.svg", "format": "svg"})
    assert r.status_code == 200 and (folder / "parts.svg").read_text().startswith("<?xml")


def test_handoff_writes_a_design_an_optimize_study_and_a_target(client):
    c, session, folder = client
    data = design_data(session.reference)
    r = _post(c, "/api/save", {"design": data, "path": "start", "format": "handoff"})
    assert r.status_code == 200, r.get_json()
    got = r.get_json()
    assert [os.path.basename(p) for p in got["written"]] == ["start.toml", "start-optimize.toml", "start-foot.csv"]
    study = explorer.load_study(folder / "start-optimize.toml")
    assert study.mech.parameters() == session.reference.parameters()
    foot = np.loadtxt(folder / "start-foot.csv", delimiter=",", skiprows=1)
    assert np.array_equal(foot, explorer.simulate(session.reference, STEPS).path("7"))
    assert any("explorer optimize" in cmd for cmd in got["commands"])
    r = _post(c, "/api/save", {"design": data, "path": "start", "format": "handoff"})
    assert r.status_code == 409  # nothing replaced without asking


def test_yield_on_demand_is_design_yield(client):
    from explorer.study import design_yield, robustness_from_dict

    c, session, _ = client
    mech = session.reference
    r = _post(c, "/api/yield", {"design": design_data(mech), "tolerance": 1, "unit": "%", "copies": 64})
    got = r.get_json()
    rob = robustness_from_dict({"tolerance": 1, "unit": "%", "copies": 64}, "t", mech)
    want = design_yield(mech, mech.lengths[None], np.array([mech.crank.radius]), robustness=rob)
    assert got["count"] == int(want.count[0]) and got["copies"] == 64
    assert 0.5 < got["yield"] <= 1.0
    r = _post(c, "/api/yield", {"design": design_data(mech), "tolerance": -1, "unit": "%", "copies": 64})
    assert r.status_code == 400 and "tolerance" in r.get_json()["error"]


@pytest.mark.slow
def test_results_file_ranking_and_a_variant_loaded(tmp_path):
    from explorer.edit import make_app
    from explorer.fabrication import variant_design

    out = explorer.run_study({"study": {"name": "ed", "mechanism": "jansen", "variants": 40, "seed": 3, "steps": 72},
                              "perturb": {"method": "uniform", "spread": 0.03}, "scene": {"metrics": True}},
                             output=tmp_path / "ed.h5", progress=False).path
    session = EditSession(out, 5)
    assert session.steps == 72
    with explorer.open_results(out) as res:
        assert session.reference.parameters() == variant_design(res, 5).parameters()
        ranked = res.rank(top=50)
        c = make_app(session).test_client()
        st = c.get("/api/study").get_json()
        assert [r["variant"] for r in st["ranking"]] == ranked["variant"].tolist()
        ok = res.frame()["status"].astype(str) == "ok"
        assert len(st["scatter"]["points"]) == int(ok.sum())
        info = c.post("/api/variant", json={"variant": int(ranked["variant"].iloc[0])}).get_json()
        assert parse_design(info["current"]["design"]).parameters() == variant_design(
            res, int(ranked["variant"].iloc[0])).parameters()


def test_cli_errors_are_one_line(capsys, monkeypatch, tmp_path):
    from explorer.cli import main

    assert main(["edit", "nope-not-here"]) == 2
    assert "no such mechanism file or built-in" in capsys.readouterr().err
    assert main(["edit", "jansen", "--variant", "3"]) == 2
    assert "needs a results file" in capsys.readouterr().err
    assert main(["edit", "jansen", "--port", "70000"]) == 2
    assert "--port" in capsys.readouterr().err
    monkeypatch.setitem(__import__("sys").modules, "flask", None)
    assert main(["edit", "jansen"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "pip install 'explorer[edit]'" in err


def test_server_listens_on_loopback_by_default():
    from explorer.edit import Server

    session = EditSession("fourbar")
    srv = Server(session, port=0).start()
    try:
        import urllib.request
        assert srv.url.startswith("http://127.0.0.1:")
        with urllib.request.urlopen(srv.url + "api/design", timeout=10) as r:
            assert json.loads(r.read()) == design_data(session.reference)
        assert srv._httpd.socket.getsockname()[0] == "127.0.0.1"
    finally:
        srv.stop()


def test_forces_in_si_where_the_design_has_an_operating_point(tmp_path):
    """studies/mechanisms/jansen-plywood.toml has [operating] unit and rpm: the solve carries the forces
    effect, explorer.simulate(..., forces=True)'s metrics; a design without one says why not."""
    from explorer.edit import solve_design

    path = os.path.join(os.path.dirname(__file__), "..", "studies", "mechanisms", "jansen-plywood.toml")
    session = EditSession(path)
    got = session.solve(design_data(session.reference))["forces"]
    want = explorer.simulate(explorer.load_mechanism(path), STEPS, forces=True)
    assert got["metrics"].keys() == want.force_metrics.keys()
    for k, v in want.force_metrics.items():
        assert got["metrics"][k] == v, k
    torque = np.frombuffer(base64.b64decode(got["torque"]), dtype="<f8")
    assert np.array_equal(torque, want.torque)
    assert "operating" in solve_design(explorer.load_mechanism("jansen"))["forces"]["note"]


@pytest.mark.slow
def test_svg_dxf_and_kit_saves(client):
    pytest.importorskip("ezdxf")
    c, session, folder = client
    data = design_data(session.reference)
    for fmt, path in (("dxf", "parts.dxf"), ("kit", "kit")):
        r = _post(c, "/api/save", {"design": data, "path": path, "format": fmt})
        assert r.status_code == 200, r.get_json()
    assert (folder / "parts.dxf").stat().st_size > 1000
    assert {"parts.svg", "bom.csv", "README.txt"} <= {p.name for p in (folder / "kit").iterdir()}
    assert _post(c, "/api/save", {"design": data, "path": "kit", "format": "kit", "check": True}).get_json()["exists"]
    r = _post(c, "/api/save", {"design": data, "path": "kit", "format": "kit"})
    assert r.status_code == 409  # a kit's files are not replaced without asking either


def test_the_save_menu_is_the_export_registry(client):
    """The editor saves in every export format that takes a design alone (explorer.fabrication.EXPORTS with
    needs_results False), read live: a format registered there is offered on the page and written by its
    own writer; one that needs a results file (csv) is not offered; handoff is the editor's own."""
    from explorer.fabrication import EXPORTS, ExportFormat, register_export
    c, session, folder = client
    offered = c.get("/api/session", headers={"Host": "127.0.0.1:8765"}).get_json()["save_formats"]
    assert list(offered)[0] == "toml" and list(offered)[-1] == "handoff"
    assert set(offered) == {n for n, f in EXPORTS.items() if not f.needs_results} | {"handoff"}
    assert "csv" in EXPORTS and "csv" not in offered

    def write_json(job):
        job.out.write_text(json.dumps({"source": job.source, "links": {k.name: k.length for k in job.mechanism.links}}))
        return f"wrote {job.out}"

    register_export(ExportFormat("toyjson", ".toyjson", "the design as toy JSON", write_json, needs_results=False))
    try:
        offered = c.get("/api/session", headers={"Host": "127.0.0.1:8765"}).get_json()["save_formats"]
        assert offered["toyjson"] == "the design as toy JSON"
        data = design_data(session.reference)
        r = _post(c, "/api/save", {"design": data, "path": "leg.toyjson", "format": "toyjson"})
        assert r.status_code == 200, r.get_json()
        assert r.get_json()["written"] == [str(folder / "leg.toyjson")]
        got = json.loads((folder / "leg.toyjson").read_text())
        assert got["links"] == {k.name: k.length for k in session.reference.links}
        assert got["source"].startswith("explorer edit")
        r = _post(c, "/api/save", {"design": data, "path": "leg.toyjson", "format": "toyjson"})
        assert r.status_code == 409  # the one output policy, for a format the editor never heard of too
    finally:
        del EXPORTS["toyjson"]
    r = _post(c, "/api/save", {"design": design_data(session.reference), "path": "t.csv", "format": "csv"})
    assert r.status_code == 400 and "expected one of" in r.get_json()["error"]
    for wrong in (["toml"], {"toml": 1}):  # not a format name at all: refused the same way, not an internal error
        r = _post(c, "/api/save", {"design": design_data(session.reference), "path": "t.toml", "format": wrong})
        assert r.status_code == 400 and "expected one of" in r.get_json()["error"], r.get_json()


@pytest.mark.slow
def test_the_command_serves_until_interrupted(tmp_path):
    """`explorer edit fourbar --no-browser --port 0`: prints its address on 127.0.0.1, answers GET
    /api/design with the mechanism's data, and stops on Ctrl-C with exit 0."""
    import signal
    import subprocess
    import sys
    import urllib.request

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(os.path.dirname(os.path.dirname(explorer.__file__))),
                                                                     os.environ.get("PYTHONPATH")])))
    p = subprocess.Popen([sys.executable, "-m", "explorer.cli", "edit", "fourbar", "--no-browser", "--port", "0"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=env)
    try:
        line = p.stdout.readline()
        assert line.startswith("explorer edit: fourbar at http://127.0.0.1:"), line
        url = line.split(" at ")[1].split()[0]
        with urllib.request.urlopen(url + "api/design", timeout=30) as r:
            assert json.loads(r.read()) == design_data(explorer.load_mechanism("fourbar"))
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
        assert p.returncode == 0, err
        assert "kernels ready" in err and "stopped" in err and "Traceback" not in err
    finally:
        if p.poll() is None:
            p.kill()
