"""`explorer edit` in headless Chromium (Debian's chromium and chromedriver, through selenium): the page loads
with no console error; a joint dragged by a known amount gives the design whose lengths are the distances of
the dragged configuration (plain numpy), and the figures shown are explorer.simulate's and the naive
walker's of that design; a drag into a region where the leg does not assemble shows where (angle, joint,
reason); a drag that would flip a branch is refused and says so; undo, redo, reset, exact parameter
fields, a link that holds the design, saving that asks before it overwrites, every built-in, a results
file's ranking. Screenshots are written to EDIT_PNGS (default /work/briefs/edit-pngs when it exists, else a
temporary folder) to be looked at.
"""

from __future__ import annotations

import json
import math
import os
import urllib.request
from pathlib import Path

import numpy as np
import pytest

import explorer
from browser import chromium, severe, wait
from explorer.edit import parse_design
from naive import JANSEN_LINKS, JANSEN_VERTICES, cross, jansen_closed_form
from naive_walker import legs_at, naive_walker

pytest.importorskip("flask", reason="the edit extra: pip install 'explorer[edit]'")
pytestmark = pytest.mark.slow  # a browser and a server: seconds each

STEPS = 360


@pytest.fixture(scope="module")
def pngs(tmp_path_factory):
    folder = os.environ.get("EDIT_PNGS") or ("/work/briefs/edit-pngs" if os.path.isdir("/work/briefs") else "")
    out = Path(folder) if folder else tmp_path_factory.mktemp("edit-pngs")
    out.mkdir(parents=True, exist_ok=True)
    return out


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    from explorer.edit import EditSession, Server

    folder = tmp_path_factory.mktemp("edit")
    session = EditSession("jansen", folder=folder)
    session.warm()
    srv = Server(session, port=0).start()
    drv = chromium("1400,950")
    yield session, srv, drv, folder
    drv.quit()
    srv.stop()


def _api(srv, path, body=None):
    req = urllib.request.Request(srv.url + path.lstrip("/"), data=None if body is None else json.dumps(body).encode(),
                                 headers={"Content-Type": "application/json"}, method="GET" if body is None else "POST")
    with urllib.request.urlopen(req, timeout=60) as r:
        return json.loads(r.read())


@pytest.fixture()
def page(served):
    """The page on Jansen's nominal leg, freshly loaded."""
    session, srv, drv, folder = served
    _api(srv, "/api/mechanism", {"name": "jansen"})
    drv.get(srv.url)
    assert wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
    assert not severe(drv)
    return session, srv, drv, folder


def _text(drv, selector):
    return drv.execute_script("var e = document.querySelector(arguments[0]); return e ? e.textContent : null", selector)


def _shown_metrics(drv) -> dict:
    return drv.execute_script("var o = {}; document.querySelectorAll('[data-metric]').forEach(function (e) {"
                              "o[e.getAttribute('data-metric')] = e.textContent; }); return o;")


def _drag(drv, selector, dx, dy):
    """Press on the handle, move the pointer by (dx, dy) CSS pixels, release; wait for the redraw."""
    from selenium.webdriver.common.action_chains import ActionChains

    handle = drv.find_element("css selector", selector)
    n = drv.execute_script("return window.editTimings.length")
    ActionChains(drv, duration=0).click_and_hold(handle).move_by_offset(dx, dy).release().perform()
    assert wait(drv, f"return window.editTimings.length > {n} && !window.editState.inflight") is True


def _ctm(drv):
    """The drawing's model-to-screen scale (a, d): CSS pixels per model unit (d < 0: y up)."""
    return drv.execute_script("var m = document.getElementById('world').getScreenCTM(); return [m.a, m.d, m.e, m.f];")


def _handle_xy(drv, joint):
    return np.array(drv.execute_script(
        "var c = document.querySelector('[data-joint=\"' + arguments[0] + '\"]');"
        "return [Number(c.getAttribute('cx')), Number(c.getAttribute('cy'))];", joint))


def _close(text, value, rel=2e-6):
    """A figure's text (7 significant digits) against a number."""
    if value is None or not math.isfinite(value):
        return text in ("–", "n/a")
    return math.isclose(float(text), value, rel_tol=rel, abs_tol=1e-12)


def _library_metrics(mech) -> dict:
    from explorer.gait import available_metrics, compute_metrics

    cyc = explorer.simulate(mech, STEPS)
    names = [m for m, why in available_metrics(mech).items() if why is None and m != "path_error"]
    got = compute_metrics(cyc.path(mech.foot)[None], cyc.velocity(mech.foot)[None],
                          np.array([0 if cyc.ok else 1]), names, mechanism=mech)
    return {m: float(v[0]) for m, v in got.items()}, cyc


def test_page_shows_the_librarys_figures_with_no_console_error(page, pngs):
    session, srv, drv, _ = page
    mech = explorer.load_mechanism("jansen")
    joints = drv.execute_script("return Array.from(document.querySelectorAll('svg [data-joint]'))"
                                ".map(function (e) { return e.getAttribute('data-joint'); })")
    assert joints == list(mech.vertices)
    assert drv.execute_script("return document.querySelectorAll('[data-pivot=\"crank\"]').length") == 1
    want, cyc = _library_metrics(mech)
    shown = _shown_metrics(drv)
    for m in ("travel", "bob", "clearance", "slip", "peak_torque", "min_transmission_angle", "foot_headroom"):
        assert _close(shown[m], want[m]), (m, shown[m], want[m])
    assert _text(drv, "[data-status]") == "ok: turns all round"
    assert drv.execute_script("return document.querySelector('[data-status]').getAttribute('data-status')") == "ok"
    # a foot path of the whole turn is drawn
    assert drv.execute_script("return document.getElementById('foot-path').getAttribute('d').split('L').length") == STEPS
    drv.save_screenshot(str(pngs / "jansen.png"))
    assert not severe(drv)


def _jansen_lengths(mech):
    by_pair = {frozenset((l.a, l.b)): l.length for l in mech.links}
    return np.array([by_pair[frozenset(p)] for p in JANSEN_LINKS])


def test_drag_a_joint_by_a_known_amount(page, pngs):
    """Joint 4 dragged 36 px right and 24 px down at θ = 0: it moves by that amount in model units (the
    drawing's scale, to a pixel), the design's three links at 4 take the distances of the configuration
    shown, the others keep theirs, and every figure shown is explorer.simulate's of that design (and the
    naive walker's on the closed form)."""
    session, srv, drv, _ = page
    nominal = explorer.load_mechanism("jansen")
    th = 2 * np.pi * np.arange(STEPS) / STEPS
    P0 = jansen_closed_form(_jansen_lengths(nominal), 15.0, th)[0][0]  # θ = 0, the angle the page opens at
    a, d, _, _ = _ctm(drv)
    before = _handle_xy(drv, "4")
    assert np.allclose(before, P0[3], atol=1e-5)
    _drag(drv, '[data-joint="4"]', 36, 24)
    after = _handle_xy(drv, "4")
    assert np.allclose(after - before, [36 / a, 24 / d], atol=1.0 / abs(a))  # the known amount, to a pixel
    for i, v in enumerate(JANSEN_VERTICES):  # every other joint stayed
        if v != "4":
            assert np.allclose(_handle_xy(drv, v), P0[i], atol=1e-5), v
    design = _api(srv, "/api/design")
    mech = parse_design(design)
    Pd = P0.copy()
    Pd[3] = after
    for (u, w), L, L0 in zip(JANSEN_LINKS, _jansen_lengths(mech), _jansen_lengths(nominal)):
        iu, iw = JANSEN_VERTICES.index(u), JANSEN_VERTICES.index(w)
        want = np.hypot(*(Pd[iu] - Pd[iw])) if "4" in (u, w) else L0
        assert math.isclose(L, want, rel_tol=1e-9), (u, w, L, want)
    # the figures shown: the library's on this design ...
    want, cyc = _library_metrics(mech)
    shown = _shown_metrics(drv)
    assert cyc.ok
    for m, v in want.items():
        assert _close(shown[m], v), (m, shown[m], v)
    # ... and the naive walker's on the closed form of those lengths (finite-difference velocities)
    lengths = _jansen_lengths(mech)

    def leg(theta):
        p = jansen_closed_form(lengths, 15.0, theta)[0][:, 6]
        h = 1e-6
        v = (jansen_closed_form(lengths, 15.0, theta + h)[0][:, 6] - jansen_closed_form(lengths, 15.0, theta - h)[0][:, 6]) / (2 * h)
        return p, v

    Y, VX, VY = legs_at(leg, STEPS, mech.walker.phases, mech.walker.mirrored)
    naive = naive_walker(Y, VX, VY, 15.0, mech.walker.drag, mech.walker.contact)
    for m in ("travel", "bob", "clearance", "peak_torque"):
        assert _close(shown[m], naive[m], rel=1e-5), (m, shown[m], naive[m])
    # the change against the ghost (the nominal) in %
    ref = _library_metrics(nominal)[0]["travel"]
    change = float(_text(drv, '[data-change="travel"]').rstrip(" %"))
    pct = 100 * (want["travel"] - ref) / ref
    assert math.isclose(change, pct, abs_tol=0.0051 if abs(pct) < 10 else 0.051)  # 2 decimals, 1 from 10 %
    drv.find_element("id", "show-walker").click()
    drv.save_screenshot(str(pngs / "jansen-dragged-walker.png"))
    assert not severe(drv)


def test_a_drag_into_a_region_that_does_not_assemble_shows_where(page, pngs):
    """The crank tip dragged outward (a crank of about 28 instead of 15): the leg no longer turns all
    round; the status shows explorer.simulate's failure of the design (joint, angle, reason), the
    drawing marks the joint and the angles it cannot reach."""
    session, srv, drv, _ = page
    _drag(drv, '[data-joint="1"]', 60, 0)
    mech = parse_design(_api(srv, "/api/design"))
    assert mech.crank.radius > 20
    cyc = explorer.simulate(mech, STEPS)
    assert not cyc.ok
    status = _text(drv, "[data-status]")
    assert status == cyc.failure.message and f"vertex {cyc.failure.vertex}" in status and "θ =" in status
    assert drv.execute_script("return document.querySelector('[data-status]').getAttribute('data-status')") == status
    label = _text(drv, "#labels .label.fail")
    assert label.startswith(f"{cyc.failure.vertex}: {cyc.failure.kind} at θ = {math.degrees(cyc.failure.theta):.1f}°")
    assert drv.execute_script("return document.getElementById('fail-arc').getAttribute('d')").startswith("M")
    assert _text(drv, '[data-metric="travel"]') == "–"  # no walker figure for a leg that does not turn
    drv.save_screenshot(str(pngs / "jansen-does-not-assemble.png"))
    assert not severe(drv)


def test_a_drag_that_would_flip_a_branch_is_refused(page):
    """Joint 3 moved in one step onto the mirror side of the line 1-2 through its parents: refused with a
    message; the design and the drawing stay as they were."""
    session, srv, drv, _ = page
    before = _api(srv, "/api/design")
    p1, p2, p3 = (_handle_xy(drv, v) for v in ("1", "2", "3"))
    u = (p2 - p1) / np.hypot(*(p2 - p1))
    mirror = p1 + 2 * np.dot(p3 - p1, u) * u - (p3 - p1)
    assert np.sign(cross(p2 - p1, mirror - p1)) != np.sign(cross(p2 - p1, p3 - p1))
    a, d, _, _ = _ctm(drv)
    dx, dy = (mirror - p3) * [a, d]
    _drag(drv, '[data-joint="3"]', int(round(dx)), int(round(dy)))
    msg = _text(drv, "[data-message]")
    assert "refused" in msg and "mirror" in msg and "3" in msg, msg
    assert _api(srv, "/api/design") == before
    assert np.allclose(_handle_xy(drv, "3"), p3)
    assert _text(drv, "[data-status]") == "ok: turns all round"
    assert not severe(drv)


def test_undo_redo_reset_and_an_exact_parameter(page):
    session, srv, drv, _ = page
    nominal = _api(srv, "/api/design")
    _drag(drv, '[data-joint="5"]', -20, 10)
    dragged = _api(srv, "/api/design")
    assert dragged != nominal
    drv.find_element("id", "undo").click()
    assert wait(drv, "return document.getElementById('undo').disabled") is True
    assert _api(srv, "/api/design") == nominal
    drv.find_element("id", "redo").click()
    assert wait(drv, "return document.getElementById('redo').disabled") is True
    assert _api(srv, "/api/design") == dragged
    # an exact value in the parameter panel
    field = drv.find_element("css selector", '[data-param-field="2-6"]')
    field.clear()
    field.send_keys("39.75\n")
    drv.execute_script("document.querySelector('[data-param-field=\"2-6\"]').blur()")
    assert wait(drv, "return window.editState.params.find(function (p) { return p[0] === '2-6'; })[1]", 39.75) == 39.75
    mech = parse_design(_api(srv, "/api/design"))
    assert mech.parameters()["2-6"] == 39.75
    want, _ = _library_metrics(mech)
    assert _close(_text(drv, '[data-metric="bob"]'), want["bob"])
    drv.find_element("id", "reset").click()
    assert wait(drv, "return document.querySelector('[data-param-field=\"2-6\"]').value", "39.3") == "39.3"
    assert _api(srv, "/api/design") == nominal
    assert not severe(drv)


def test_a_link_holds_the_whole_design(page):
    session, srv, drv, _ = page
    _drag(drv, '[data-joint="6"]', 15, -12)
    design = _api(srv, "/api/design")
    drv.find_element("id", "save-panel").click()
    drv.find_element("id", "copy-link").click()
    link = drv.execute_script("return document.getElementById('link').value")
    assert "#design=" in link
    _api(srv, "/api/mechanism", {"name": "jansen"})  # the server forgets it
    drv.get("about:blank")
    drv.get(link)
    assert wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
    assert wait(drv, "return document.getElementById('title').textContent.length > 0") is True
    assert _api(srv, "/api/design") == design
    assert not [e for e in severe(drv) if "clipboard" not in e["message"].lower()]
    # a broken link: one clear message in the page, nothing else goes
    drv.get(srv.url + "#design=" + link.split("#design=")[1][:-40] + "AAAA")
    assert wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
    assert wait(drv, "return document.querySelector('[data-status]').textContent.startsWith('error:')") is True
    errors = [e for e in severe(drv) if e["source"] != "network"]  # (the refused PUT is logged as a 400)
    assert not errors, errors


def _alert(drv):
    from selenium.webdriver.support import expected_conditions
    from selenium.webdriver.support.ui import WebDriverWait

    return WebDriverWait(drv, 30).until(expected_conditions.alert_is_present())


def test_save_asks_before_it_overwrites(page):
    session, srv, drv, folder = page
    (folder / "mine.toml").write_text("# mine\n")
    drv.find_element("id", "save-panel").click()
    path = drv.find_element("id", "save-path")
    path.clear()
    path.send_keys("mine.toml")
    drv.find_element("id", "save").click()
    alert = _alert(drv)
    assert "already exists" in alert.text
    alert.dismiss()
    assert wait(drv, "return document.getElementById('save-result').textContent", "not saved") == "not saved"
    assert (folder / "mine.toml").read_text() == "# mine\n"
    drv.find_element("id", "save").click()
    _alert(drv).accept()
    assert wait(drv, "return document.getElementById('save-result').textContent.startsWith('written')") is True
    assert explorer.load_mechanism(folder / "mine.toml").parameters() == explorer.load_mechanism("jansen").parameters()
    assert not severe(drv)


def test_every_builtin_opens_draws_and_solves(page, pngs):
    """Each built-in through the page's own "Open mechanism": a handle per joint, the status of
    explorer.simulate, its figures; bodies (klann, strider, hoeken) and sliders (slidercrank, whitworth)
    drawn; the path-driven arm scrubbed in time."""
    from selenium.webdriver.support.ui import Select

    session, srv, drv, _ = page
    drv.find_element("id", "study-panel").click()
    for name in explorer.builtin_mechanisms():
        Select(drv.find_element("id", "mech-select")).select_by_value(name)
        drv.find_element("id", "mech-open").click()
        assert wait(drv, f"return document.getElementById('title').textContent.startsWith('{name} ')") is True, name
        mech = explorer.load_mechanism(name)
        n = drv.execute_script("return document.querySelectorAll('svg [data-joint]').length")
        assert n == len(mech.vertices), name
        want, cyc = _library_metrics(mech)
        status = _text(drv, "[data-status]")
        assert status == ("ok: turns all round" if cyc.ok else cyc.failure.message), name
        shown = _shown_metrics(drv)
        for m, v in want.items():
            assert _close(shown[m], v), (name, m, shown[m], v)
        bodies = drv.execute_script("return document.querySelectorAll('#bodies polygon[visibility=\"visible\"]').length")
        assert bodies == len(mech.bodies), name
        assert drv.execute_script("return document.querySelectorAll('#guides line').length") == len(mech.sliders)
        if name in ("klann", "whitworth", "arm"):
            drv.save_screenshot(str(pngs / f"{name}.png"))
        assert not severe(drv), name


def test_a_body_joint_and_a_slider_drag_in_the_page(page):
    """Klann's leg body: its foot dragged (a point of a rigid body); Whitworth's ram (a ground slider's
    vertex) dragged off its line: the line moves through it. The design's constraints hold on the
    configuration shown."""
    session, srv, drv, _ = page
    for name, joint in (("klann", "33"), ("whitworth", "C")):
        _api(srv, "/api/mechanism", {"name": name})
        drv.get(srv.url)
        assert wait(drv, "return document.body.getAttribute('data-ready')", "1") == "1"
        before = _handle_xy(drv, joint)
        _drag(drv, f'[data-joint="{joint}"]', 10, 14)
        assert not np.allclose(_handle_xy(drv, joint), before), (name, drv.execute_script(
            "return document.querySelector('[data-message]').textContent"))
        mech = parse_design(_api(srv, "/api/design"))
        P = {v: _handle_xy(drv, v) for v in mech.vertices}
        for b in mech.bodies:
            for i, j in [(i, j) for i in range(len(b.joints)) for j in range(i)]:
                want = np.hypot(*(np.subtract(b.points[i], b.points[j])))
                assert math.isclose(np.hypot(*(P[b.joints[i]] - P[b.joints[j]])), want, rel_tol=1e-6), (name, b.name)
        for s in mech.sliders:
            if s.ground:
                u = np.asarray(s.direction) / np.hypot(*s.direction)
                assert abs(cross(u, P[s.vertex] - np.asarray(s.point))) < 1e-6 * mech.size, name
        assert not severe(drv), name


def test_a_results_files_ranking_loads_a_design(page, pngs, tmp_path_factory):
    from explorer.fabrication import variant_design

    session, srv, drv, _ = page
    root = tmp_path_factory.mktemp("edit-study")
    out = explorer.run_study({"study": {"name": "ed", "mechanism": "jansen", "variants": 60, "seed": 2, "steps": 72},
                              "perturb": {"method": "uniform", "spread": 0.03}, "scene": {"metrics": True}},
                             output=root / "ed.h5", progress=False).path
    drv.find_element("id", "study-panel").click()
    box = drv.find_element("id", "study-path")
    box.clear()
    box.send_keys(str(out))
    drv.find_element("id", "study-open").click()
    assert wait(drv, "return document.querySelectorAll('#study-body tr[data-variant]').length > 0") is True
    with explorer.open_results(out) as res:
        ranked = res.rank(top=50)["variant"].tolist()
        listed = drv.execute_script("return Array.from(document.querySelectorAll('#study-body tr[data-variant]'))"
                                    ".map(function (r) { return Number(r.getAttribute('data-variant')); })")
        assert listed == ranked
        points = drv.execute_script("return document.querySelectorAll('#scatter circle[data-variant]').length")
        assert points == int((res.frame()["status"].astype(str) == "ok").sum())
        v = next(x for x in ranked if x != 0)  # another design than the one open
        drv.find_element("css selector", f'#study-body tr[data-variant="{v}"]').click()
        assert wait(drv, f"return document.getElementById('title').textContent.indexOf('variant {v} of') >= 0") is True
        assert parse_design(_api(srv, "/api/design")).parameters() == variant_design(res, v).parameters()
    drv.save_screenshot(str(pngs / "study.png"))
    assert not severe(drv)


def test_play_and_scrub(page):
    session, srv, drv, _ = page
    drv.find_element("id", "play").click()
    assert wait(drv, "return window.editState.k > 10") is True
    drv.find_element("id", "play").click()
    drv.execute_script("var s = document.getElementById('scrub'); s.value = 90; s.dispatchEvent(new Event('input'));")
    assert _text(drv, "#angle") == "θ = 90.0°"
    cyc = explorer.simulate(explorer.load_mechanism("jansen"), STEPS)
    assert np.allclose(_handle_xy(drv, "7"), cyc.path("7")[90], atol=1e-4)  # float32 to draw
    assert not severe(drv)


def test_forces_in_si_and_yield_on_demand(page, pngs):
    """A mechanism file with a build ([mass], [operating]): motor torque and pin forces shown in N·m and N,
    explorer.simulate(forces=True)'s; the yield at ±1 % on demand, explorer.study.design_yield's."""
    from explorer.study import design_yield, robustness_from_dict

    session, srv, drv, _ = page
    path = str(Path(__file__).resolve().parents[1] / "studies" / "mechanisms" / "jansen-plywood.toml")
    drv.find_element("id", "study-panel").click()
    box = drv.find_element("id", "mech-path")
    box.clear()
    box.send_keys(path)
    drv.find_element("id", "mech-open").click()
    assert wait(drv, "return document.getElementById('title').textContent.startsWith('jansen-plywood ')") is True
    mech = explorer.load_mechanism(path)
    want = explorer.simulate(mech, STEPS, forces=True).force_metrics
    shown = _shown_metrics(drv)
    for m in ("motor_torque_peak", "motor_power_peak", "flywheel_inertia", "pin_force_max", "pin_force.2"):
        assert _close(shown[m], want[m]), (m, shown[m], want[m])
    assert "N·m" in _text(drv, '#forces tr[data-row="motor_torque_peak"]')
    drv.find_element("id", "yield-panel").click()
    copies = drv.find_element("id", "yield-copies")
    copies.clear()
    copies.send_keys("64")
    drv.find_element("id", "yield-run").click()
    assert wait(drv, "return document.querySelector('[data-metric=\"yield\"]').textContent.indexOf('.') > 0") is True
    rob = robustness_from_dict({"tolerance": 1.0, "unit": "%", "copies": 64}, "t", mech)
    y = design_yield(mech, mech.lengths[None], np.array([mech.crank.radius]), robustness=rob)
    assert _close(_text(drv, '[data-metric="yield"]'), float(y.share[0]))
    drv.save_screenshot(str(pngs / "jansen-plywood-forces.png"))
    assert not severe(drv)
