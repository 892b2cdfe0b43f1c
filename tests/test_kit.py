"""The build kit (issues 27, 37): ``explorer export ... --format kit -o DIR``.

Everything is checked against plain computations written here: a clearance checker over 3,600 crank angles
(the distance from every pin's path to every part's segments, from kit.json and the motion), hole spacings
against the design's link lengths × scale, kit.json against the DXF hole by hole, the pin and crankshaft
sizes from the shear, bearing and torsion formulas, copy counts against the walker's legs."""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET
from collections import Counter
from itertools import combinations

import numpy as np
import pytest

import explorer
from explorer.cli import main
from explorer.errors import UserError
from explorer.mechanism import load_mechanism
from explorer.testing import Material, build_kit, kit_data, pin_diameter, shaft_diameter, write_kit

SVG = "{http://www.w3.org/2000/svg}"
BUILTIN_LEGS = ("jansen", "klann", "strider", "hoeken", "fourbar")
STANDARD = (2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0)
CENTRE = "crank centre"
#: Klann with its pivots and body points moved (a variant a study could hand the kit).
KLANN_MOVED = {"11.x": 0.05, "9.y": -0.04, "leg.33.x": 0.08, "connecting_rod.35.y": 0.03}


# -- plain geometry ---------------------------------------------------------------------------------------
def point_seg(p, a, b):
    """Distance from points p (S, 2) to segments a–b (each (S, 2))."""
    v, w = b - a, p - a
    vv = (v * v).sum(axis=1)
    t = np.clip(np.where(vv > 0, (w * v).sum(axis=1) / np.where(vv > 0, vv, 1.0), 0.0), 0.0, 1.0)
    return np.hypot(*(a + t[:, None] * v - p).T)


def cross(o, a, b):
    return (a[:, 0] - o[:, 0]) * (b[:, 1] - o[:, 1]) - (a[:, 1] - o[:, 1]) * (b[:, 0] - o[:, 0])


def seg_seg(a, b, c, d):
    """Distance between segments a–b and c–d, each end (S, 2): 0 where they cross."""
    crossing = (cross(a, b, c) * cross(a, b, d) < 0) & (cross(c, d, a) * cross(c, d, b) < 0)
    dist = np.minimum.reduce([point_seg(a, c, d), point_seg(b, c, d), point_seg(c, a, b), point_seg(d, a, b)])
    return np.where(crossing, 0.0, dist)


def in_triangle(p, a, b, c):
    s1, s2, s3 = cross(a, b, p), cross(b, c, p), cross(c, a, p)
    return ((s1 >= 0) & (s2 >= 0) & (s3 >= 0)) | ((s1 <= 0) & (s2 <= 0) & (s3 <= 0))


def point_shape(p, corners):
    """Distance from p (S, 2) to the convex hull of the points ``corners`` (each (S, 2)): the least distance
    to any segment between two of them (the hull's edges among them), 0 inside any triangle of them."""
    if len(corners) == 1:
        return np.hypot(*(p - corners[0]).T)
    d = np.min([point_seg(p, a, b) for a, b in combinations(corners, 2)], axis=0)
    for a, b, c in combinations(corners, 3):
        d = np.where(in_triangle(p, a, b, c), 0.0, d)
    return d


def shape_shape(A, B):
    """Distance between the convex hulls of the point sets A and B (lists of (S, 2)), 0 where they meet."""
    if len(A) == 1:
        return point_shape(A[0], B)
    if len(B) == 1:
        return point_shape(B[0], A)
    d = np.min([seg_seg(a, b, c, e) for a, b in combinations(A, 2) for c, e in combinations(B, 2)], axis=0)
    for q in A:
        d = np.where(point_shape(q, B) == 0.0, 0.0, d)
    for q in B:
        d = np.where(point_shape(q, A) == 0.0, 0.0, d)
    return d


# -- the clearance checker --------------------------------------------------------------------------------
def clearances(mech, data, steps: int = 3600):
    """Every clearance of the kit described by ``data`` (kit.json) over ``steps`` crank angles, written plainly:
    [(margin mm, what, a, b, layer)]: the least distance less what the two need (radius or half widths plus
    the running clearance). A pin occupies the layers it spans and the one below and above (its head and its
    nut, one pin diameter in radius, as its spacers are); the shaft its layers (its spacers one shaft
    diameter in radius). Standoffs: every moving part on every layer, the mirrored leg too."""
    cyc = explorer.simulate(mech, steps=steps)
    assert cyc.ok
    s = data["scale_mm_per_unit"]
    P = (np.asarray(cyc.positions) - np.asarray(mech.crank.center)) * s

    def at(j):
        return np.zeros((steps, 2)) if j == CENTRE else P[:, mech.vertices.index(j)]

    c = data["clearance"]["running"]
    parts = {}
    for p in data["parts"]:
        if p["copy"] != 1 or p["layer"] is None or p["kind"] == "frame":
            continue
        joints = [h["joint"] for h in p["holes"]]
        parts[p["name"]] = (p["layer"], set(joints), [at(j) for j in joints], 0.5 * p["width"])
    top = max(v[0] for v in parts.values())
    out = []
    for pin in data["pins"]:
        if pin["kind"] == "standoff":
            continue
        carried = {parts[n][0] for n in pin["stack"] if n in parts} | ({0} if "frame" in pin["stack"] else set())
        if pin["kind"] == "shaft":  # on past the leg's top layer to the next leg (where the top pins' nuts are)
            occupied, R = set(pin["layers"]) | ({top + 1} if data["shaft"]["mode"] != "outboard" else set()), \
                pin["diameter"]
        else:
            lo, hi = pin["layers"][0], pin["layers"][-1]
            occupied, R = set(range(max(0, lo - 1), hi + 2)), pin["diameter"]
        path = at(pin["joint"])
        for name, (layer, joints, corners, half) in parts.items():
            if layer in occupied and layer not in carried and pin["joint"] not in joints:
                m = float(np.min(point_shape(path, corners))) - (half + R + c)
                out.append((m, "pin", pin["joint"], name, layer))
    names = list(parts)
    for a, b in combinations(names, 2):
        if parts[a][0] == parts[b][0]:
            assert not (parts[a][1] & parts[b][1]), (a, b)  # two parts of one pin are on two layers
            m = float(np.min(shape_shape(parts[a][2], parts[b][2]))) - (parts[a][3] + parts[b][3] + c)
            out.append((m, "parts", a, b, parts[a][0]))
    bare = {}
    for pin in data["pins"]:
        if pin["kind"] == "standoff":
            continue
        carried = {parts[n][0] for n in pin["stack"] if n in parts} | ({0} if "frame" in pin["stack"] else set())
        if pin["kind"] == "shaft":
            occ = set(pin["layers"]) | ({top + 1} if data["shaft"]["mode"] != "outboard" else set())
        else:
            occ = set(range(max(0, pin["layers"][0] - 1), pin["layers"][-1] + 2))
        bare[pin["joint"]] = (occ - carried, pin["diameter"])
    for a, b in combinations(bare, 2):
        common = bare[a][0] & bare[b][0]
        if common:
            m = float(np.min(np.hypot(*(at(a) - at(b)).T))) - (bare[a][1] + bare[b][1] + c)
            out.append((m, "pins", a, b, min(common)))
    standoffs = []
    mirrored = any(p["mirrored"] for p in data["parts"])
    so_r = data["chassis"]["standoff_diameter"]
    for so in data["chassis"]["standoffs"]:
        q = np.tile([so["x"], so["y"]], (steps, 1))
        for name, (layer, joints, corners, half) in parts.items():
            for sign in ((1, -1) if mirrored else (1,)):
                C = [x * np.array([sign, 1.0]) for x in corners]
                m = float(np.min(point_shape(q, C))) - (half + so_r + c)
                standoffs.append((m, "standoff", so["name"], name, layer))
    return sorted(out), sorted(standoffs)


# -- the kits ---------------------------------------------------------------------------------------------
_KITS: dict = {}


def design(name):
    if name == "klann-moved":
        m = load_mechanism("klann")
        return m.with_parameters({k: m.parameters()[k] + v for k, v in KLANN_MOVED.items()})
    return load_mechanism(name)


def kit_of(name, tmp_path_factory):
    """(mechanism, kit, folder) of a design's default kit, built and written once per session."""
    if name not in _KITS:
        mech = design(name)
        kit = build_kit(mech, source=f"test:{name}")
        folder = tmp_path_factory.mktemp(f"kit_{name}")
        write_kit(kit, folder / "kit")
        _KITS[name] = (mech, kit, folder / "kit")
    return _KITS[name]


def design_parts(mech) -> dict[str, list[tuple[str, tuple[float, float]]]]:
    """{part: [(joint, point in model units)]} of the design, plainly: the frame's pivots, the crank, each link,
    each body."""
    parts = {"frame": [(CENTRE, mech.crank.center)] + [(v, mech.fixed[v]) for v in mech.fixed],
             "crank": [(CENTRE, (0.0, 0.0)), (mech.crank.tip, (mech.crank.radius, 0.0))]}
    for link in mech.links:
        parts[link.name] = [(link.a, (0.0, 0.0)), (link.b, (link.length, 0.0))]
    for body in mech.bodies:
        parts[body.name] = list(zip(body.joints, body.points))
    return parts


# -- the clearance of every built-in leg, a moved Klann and a ±2 % study's designs --------------------------
@pytest.mark.slow
@pytest.mark.parametrize("name", BUILTIN_LEGS + ("klann-moved",))
def test_nothing_sweeps_through_a_pin_or_the_shaft(name, tmp_path_factory):
    mech, kit, folder = kit_of(name, tmp_path_factory)
    data = json.loads((folder / "kit.json").read_text())
    got, standoffs = clearances(mech, data)
    assert got and standoffs
    worst = got[0]
    assert worst[0] >= 0.0, worst  # every part clear of every pin, spacer, nut, the shaft, its layer's parts
    assert standoffs[0][0] >= 0.0, standoffs[0]
    # the kit says the same worst margin (its own check, over the same angles)
    assert data["clearance"]["worst"]["margin"] == pytest.approx(worst[0], abs=1e-6)
    assert f"worst margin {worst[0]:.2f} mm" in (folder / "README.txt").read_text()
    # the crank pin's parts cross the shaft's axis in every built-in leg: the shaft is a crank with throws,
    # and those parts turn between the webs
    tip = mech.crank.tip
    pin = next(p for p in data["pins"] if p["joint"] == tip)
    layers = {p["name"]: p["layer"] for p in data["parts"] if p["copy"] == 1}
    assert data["shaft"]["mode"] == "throws"
    inner, outer = layers["crank"], layers["crank-outer"]
    assert pin["layers"] == list(range(inner, outer + 1))
    for n in pin["stack"]:
        if n not in ("crank", "crank-outer"):
            assert inner < layers[n] < outer, n
    assert not set(data["shaft"]["layers"]) & set(range(inner + 1, outer))


def test_the_issue_s_sweeps_are_found(tmp_path_factory):
    """Links 1-3 and 1-6 of Jansen's leg pass within 0.01 mm of the shaft's axis at a 30 mm crank (θ = 303.4° and
    65.2°; issue 37 saw 0.3 and 0.2 mm at its sampling): the kit's stack never puts them on a shaft layer."""
    mech = load_mechanism("jansen")
    s = 2.0
    cyc = explorer.simulate(mech, steps=3600)
    P = (np.asarray(cyc.positions) - np.asarray(mech.crank.center)) * s
    ix = mech.vertices.index
    zero = np.zeros((3600, 2))
    d13 = point_shape(zero, [P[:, ix("1")], P[:, ix("3")]])
    d16 = point_shape(zero, [P[:, ix("1")], P[:, ix("6")]])
    assert d13.min() < 0.01 and d16.min() < 0.01
    assert abs(np.argmin(d13) / 10 - 303.4) < 0.5 and abs(np.argmin(d16) / 10 - 65.2) < 0.5
    _, kit, _ = kit_of("jansen", tmp_path_factory)
    assert kit.shaft.mode == "throws"  # the stack's own check refuses a through shaft
    for n in ("1-3", "1-6"):  # they turn between the webs, on layers the shaft does not reach
        assert kit.layers["crank"] < kit.layers[n] < kit.layers["crank-outer"]
        assert kit.layers[n] not in kit.shaft.layers


@pytest.mark.slow
def test_designs_of_a_2pct_study_are_clear(tmp_path, capsys):
    """Designs of a ±2 % uniform study of Jansen's leg, as `explorer export RESULTS V --format kit` cuts them."""
    study = tmp_path / "s.toml"
    study.write_text(f'[study]\nname = "j2"\nmechanism = "jansen"\nvariants = 4\nseed = 7\nsteps = 90\n'
                     f'[perturb]\nmethod = "uniform"\nspread = 0.02\n[output]\npath = "{tmp_path / "r.h5"}"\n')
    assert main(["run", str(study)]) == 0
    capsys.readouterr()
    with explorer.open_results(tmp_path / "r.h5") as res:
        ok = [v for v in range(1, res.n_variants) if res.frame().iloc[v]["status"] == "ok"][:2]
        designs = [explorer.fabrication.variant_design(res, v) for v in ok]
    assert len(designs) == 2
    for v, mech in zip(ok, designs):
        kit = build_kit(mech)
        data = kit_data(kit)
        got, standoffs = clearances(mech, data)
        assert got[0][0] >= 0 and standoffs[0][0] >= 0, (v, got[0], standoffs[0])
        assert data["clearance"]["worst"]["margin"] == pytest.approx(got[0][0], abs=1e-6)


# -- kit.json against the DXF, and the design --------------------------------------------------------------
def dxf_holes(group):
    """[(centre (x, y), diameter)] of a DXF group's holes in the order written: CIRCLEs, and D-holes (closed
    LWPOLYLINEs on CUT with three vertices: two arcs and the flat; the centre from the first arc's bulge)."""
    out = []
    for e in sorted(group, key=lambda e: int(e.dxf.handle, 16)):
        if e.dxf.layer != "CUT":
            continue
        if e.dxftype() == "CIRCLE":
            out.append(((e.dxf.center[0], e.dxf.center[1]), 2 * e.dxf.radius, False))
        elif e.dxftype() == "LWPOLYLINE" and len(e) == 3:
            (x0, y0, _, _, b), (x1, y1, *_) = e[0], e[1]
            theta = 4 * math.atan(b)  # the arc from vertex 0 to vertex 1, counter-clockwise
            chord = math.hypot(x1 - x0, y1 - y0)
            r = chord / (2 * math.sin(theta / 2))
            mx, my = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
            h = r * math.cos(theta / 2)
            nx, ny = -(y1 - y0) / chord, (x1 - x0) / chord
            out.append(((mx + h * nx, my + h * ny), 2 * r, True))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name", BUILTIN_LEGS)
def test_kit_json_against_the_dxf_and_the_design(name, tmp_path_factory):
    import ezdxf
    mech, kit, folder = kit_of(name, tmp_path_factory)
    data = json.loads((folder / "kit.json").read_text())
    s = data["scale_mm_per_unit"]
    assert s == pytest.approx(30.0 / mech.crank.radius) and data["crank_mm"] == pytest.approx(30.0)
    assert data["design"]["parameters"] == pytest.approx(mech.parameters())
    copies = {(p["name"], p["copy"]): p for p in data["parts"]}
    doc = ezdxf.readfile(folder / "parts.dxf")
    seen = set()
    for gname, group in doc.groups:
        name_, rest = gname.split(" #")
        copy = int(rest.split()[0])
        part = copies[(name_, copy)]
        assert gname == f"{name_} #{copy}" + (" M" if part["mirrored"] else "")  # named after the part
        seen.add((name_, copy))
        holes = dxf_holes(group)
        assert len(holes) == len(part["holes"])
        for (c, d, is_d), h in zip(holes, part["holes"]):
            assert d == pytest.approx(h["diameter"], abs=1e-9)
            assert is_d == ("d_flat" in h)
        # every spacing, and the handedness (a mirrored copy is the mirror image of kit.json's plain holes)
        for (a, ha), (b, hb) in combinations(zip(holes, part["holes"]), 2):
            assert math.dist(a[0], b[0]) == pytest.approx(math.hypot(ha["x"] - hb["x"], ha["y"] - hb["y"]), abs=1e-5)
        if len(holes) >= 3:
            P = [np.array(h[0]) for h in holes[:3]]
            Q = [np.array([h["x"], h["y"]]) for h in part["holes"][:3]]
            o1 = (P[1] - P[0])[0] * (P[2] - P[0])[1] - (P[1] - P[0])[1] * (P[2] - P[0])[0]
            o2 = (Q[1] - Q[0])[0] * (Q[2] - Q[0])[1] - (Q[1] - Q[0])[1] * (Q[2] - Q[0])[0]
            assert o1 * o2 > 0 or abs(o2) < 1e-6  # both as kit.json says (mirrored copies' x negated there)
    assert seen == set(copies)
    # kit.json's holes are the design's dimensions × scale
    plain = design_parts(mech)
    for p in data["parts"]:
        if p["name"] in ("crank", "crank-outer"):
            want = plain["crank"]
        elif p["name"] in plain:
            want = plain[p["name"]]
        else:
            continue
        got = {h["joint"]: (h["x"], h["y"]) for h in p["holes"]}
        for (ja, pa), (jb, pb) in combinations(want, 2):
            assert math.dist(got[ja], got[jb]) == pytest.approx(math.dist(pa, pb) * s, abs=1e-5), (p["name"], ja, jb)
    # copies: one per leg; mirrored copies of the asymmetric parts for the mirrored legs
    walker = mech.walker
    count = Counter(p["name"] for p in data["parts"])
    mirrored = Counter(p["name"] for p in data["parts"] if p["mirrored"])
    for n in plain:
        if n == "crank":
            assert count["crank"] == walker.legs
            continue
        assert count[n] == walker.legs
        pts = [q for _, q in plain[n]]
        sym = len(pts) < 3 or all(abs((pts[1][0] - pts[0][0]) * (q[1] - pts[0][1]) - (pts[1][1] - pts[0][1])
                                      * (q[0] - pts[0][0])) < 1e-9 for q in pts[2:])
        assert mirrored[n] == (0 if sym and n != "frame" else sum(walker.mirrored)) or n == "frame", n
    # every frame plate, plain or mirrored, has the hole named after a standoff where that standoff stands
    so = {x["name"]: (x["x"], x["y"]) for x in data["chassis"]["standoffs"]}
    for p in data["parts"]:
        if p["kind"] in ("frame", "motor", "end"):
            for h in p["holes"]:
                if h["joint"] in so:
                    assert (h["x"], h["y"]) == pytest.approx(so[h["joint"]], abs=1e-6), (p["name"], p["copy"])
        # the crank arms: copy k is leg k's, its D-flat's normal at minus the leg's phase
    for p in data["parts"]:
        if p["kind"] == "crank":
            phase = math.degrees(walker.phases[p["copy"] - 1]) % 360
            assert p["holes"][0]["d_flat"]["normal_deg"] == pytest.approx((-phase) % 360, abs=1e-6)
    assert [leg["phase_deg"] for leg in data["crank"]["legs"]] == pytest.approx(
        [math.degrees(ph) % 360 for ph in walker.phases])
    # every pin: the layers it spans, bottom to top, and a spacer on each layer of them it carries no part on
    layer = {p["name"]: p["layer"] for p in data["parts"] if p["copy"] == 1}
    for pin in data["pins"]:
        if pin["kind"] in ("pin", "crank pin"):
            ls = [layer[n] for n in pin["stack"]]
            assert ls == sorted(ls) and pin["layers"] == list(range(ls[0], ls[-1] + 1))
            assert pin["spacers"] == [k for k in pin["layers"] if k not in ls]
            span = len(pin["layers"])
            assert pin["length"] == math.ceil(span * 3.0 + (span - 1) * 0.5 + pin["diameter"] + 2.0)
        elif pin["kind"] == "shaft":
            assert pin["spacers"] == [k for k in pin["layers"] if k not in {layer[n] for n in pin["stack"]}]


# -- the SVG ------------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_the_svg_labels_and_holes(tmp_path_factory):
    """Every joint label once per hole of every copy; a part's label clear of its holes (the Hoeken coupler's
    B-C-P holes are in a line: its label stays off C)."""
    mech, kit, folder = kit_of("hoeken", tmp_path_factory)
    from explorer.testing import CHAR_W, copy_labels
    root = ET.parse(folder / "parts.svg").getroot()
    cut = root.find(f"{SVG}g[@id='cut']")
    assert len(cut.findall(f"{SVG}g[@class='part']")) == len(kit.placements)
    for pl in kit.placements:
        part = kit.part(pl.part)
        holes = kit.placed_holes(pl)
        lab = next(x for x in copy_labels(kit, pl) if x["kind"] == "part")
        a = math.radians(lab["angle"])
        u, n = np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
        half_w, half_h = 0.5 * CHAR_W * lab["size"] * len(lab["text"]), 0.5 * lab["size"]
        for (x, y), d in zip(holes, part.diameters):
            v = np.array([x - lab["x"], y - lab["y"]])
            # the nearest point of the label's box to the hole's centre is farther than its radius
            along, across = float(v @ u), float(v @ n)
            gap = math.hypot(max(abs(along) - half_w, 0.0), max(abs(across) - half_h, 0.0))
            assert gap > 0.5 * d, (pl.part, pl.copy)
    # the D-holes are cut: one per crank arm copy
    d_holes = [e for e in cut.iter(f"{SVG}path") if "d-hole" in (e.get("class") or "")]
    assert len(d_holes) == sum(p.copies for p in kit.parts if p.kind == "crank")


# -- sizes ------------------------------------------------------------------------------------------------
def test_pin_diameter_from_a_force():
    need = math.sqrt(4 * 125 * 3 / (math.pi * 140))  # single shear, SF 3, 140 MPa
    name, d, req = pin_diameter(125.0, Material(pin_shear=140.0, safety_factor=3.0, thickness=9.0, bearing=60.0))
    assert 125 * 3 / (9.0 * 60.0) < need and d == 2.0 and name == "M2" and req == pytest.approx(need)
    bear = 125 * 3 / (3.0 * 60.0)  # bearing in 3 mm plywood decides
    name, d, req = pin_diameter(125.0, Material(thickness=3.0, bearing=60.0))
    assert bear > need and d == 2.5 and req == pytest.approx(bear)
    with pytest.raises(UserError, match="2000 N joint needs a 33.3 mm pin"):
        pin_diameter(2000.0)


def test_crankshaft_from_torsion_and_bending():
    """The issue's case: an M3 rod carrying 2.84 N·m is at 16 T / (π d³) = 535 MPa, far past 140 MPa / 3; the
    shaft the rule gives keeps 16 √(M² + T²) / (π d_core³) within 140 / 3 MPa, d_core = d less the flat."""
    T = 2.84
    assert 16 * T * 1000 / (math.pi * 3.0 ** 3) == pytest.approx(535.7, abs=0.1)
    for M in (0.0, 1.5, 4.0):
        name, d, req = shaft_diameter(T, M, Material())
        flat = 0.5 if d <= 10 else 1.0
        core = (16 * 3 * math.hypot(M * 1000, T * 1000) / (math.pi * 140)) ** (1 / 3)
        assert req == pytest.approx(core + flat)
        assert 16 * math.hypot(M, T) * 1000 / (math.pi * (d - flat) ** 3) <= 140 / 3 + 1e-9
        smaller = [s for s in STANDARD if s < d]
        if smaller:
            s = smaller[-1]
            sf = 0.5 if s <= 10 else 1.0
            assert 16 * math.hypot(M, T) * 1000 / (math.pi * (s - sf) ** 3) > 140 / 3
    assert shaft_diameter(T, 0.0)[1] == 8.0


@pytest.mark.slow
def test_kit_sized_from_forces_and_the_hole_rule():
    """A kit given forces and a torque: every pin from its force, the crank pin also carrying the torque between
    the webs (T / r), the shaft from T and the crank pin's bending at the web's distance from a bushing."""
    mech = load_mechanism("jansen")
    forces = {"1": 60.0, "2": 300.0, "6": 90.0}
    kit = build_kit(mech, forces=forces, torque=2.84, material=Material(thickness=3.0))
    m = kit.material
    for j, f in forces.items():
        pin = kit.pin(j)
        F = f + (2.84 * 1000 / 30.0 if j == mech.crank.tip else 0.0)
        need = max(math.sqrt(4 * F * 3 / (math.pi * 140)), F * 3 / (3.0 * 60.0))
        assert pin.required == pytest.approx(need)
        assert pin.diameter == max(3.0, min(d for d in STANDARD if d >= need - 1e-12)), j
    sh = kit.shaft
    F_arm = 60.0 + 2.84 * 1000 / 30.0
    assert sh.arm_force == pytest.approx(F_arm) and sh.bending == pytest.approx(F_arm * sh.arm / 1000)
    p = m.thickness + 0.5
    webs = [kit.layers["crank"], kit.layers["crank-outer"]]
    top = max(kit.layers.values())
    gap = 2 * max(pin.diameter for pin in kit.pins if pin.kind in ("pin", "crank pin")) + 2.0 + 0.5
    assert sh.arm == pytest.approx(max(min(c * p, (top - c) * p + m.thickness + gap) for c in webs))
    assert sh.diameter == max(6.0, shaft_diameter(2.84, sh.bending, m)[1])
    # a --hole below what a force needs: refused in one line, unless undersized
    need2 = max(math.sqrt(4 * 300 * 3 / (math.pi * 140)), 300 * 3 / (3.0 * 60.0))
    with pytest.raises(UserError, match=f"--hole: 2.5 mm is below the {need2:.3g} mm pin 2 needs for its 300 N"):
        build_kit(mech, forces=forces, torque=2.84, hole=2.5)
    kit = build_kit(mech, forces=forces, torque=2.84, hole=2.5, undersized=True)
    assert any("UNDERSIZED" in n and "pin 2" in n for n in kit.notes)


# -- [build], the forces of the parts cut, --plates -----------------------------------------------------------
@pytest.mark.slow
def test_build_table_gives_link_masses_and_the_kit_defaults():
    from importlib import resources

    from explorer.mechanism import mechanism_from_dict, parse_toml
    base = (resources.files("explorer.mechanism") / "builtin" / "jansen.toml").read_text(encoding="utf-8")

    def load(extra):
        return mechanism_from_dict(parse_toml(base + "\n" + extra, "j.toml"), "j.toml")
    mech = load('[build]\nmaterial = "poplar plywood"\nthickness = 6\npart_width = 20\npin_material = '
                '"stainless (A2-70)"\n')
    assert mech.link_density == pytest.approx(450 * 6 * 20 / 1e6)  # poplar's density × t × w, kg/m
    kit = build_kit(mech)
    assert kit.material.thickness == 6 and kit.width == 20 and kit.material.pin_shear == 270
    assert kit.material.bearing == 40 and kit.material.shaft_material == "stainless (A2-70)"
    full = "[build]\nthickness = 6\npart_width = 20\ndensity = 500\nunit = 0.01\n"
    for extra, what in ((full + "[mass]\nlink_density = 0.3\n", "link_density = 0.3"),
                        (full + "[operating]\nunit = 0.02\n", "build.unit"),
                        ("[build]\nx = 1\n", "j.toml: build.x")):
        with pytest.raises(UserError, match=what):
            load(extra)
    assert load(full + "[mass]\nlink_density = 0.06\n").link_density == pytest.approx(0.06)  # the same: fine
    for key, val in (("thickness", "0"), ("part_width", "-1"), ("density", "nan"), ("material", '"oak"'),
                     ("unit", "1e400"), ("pin_material", "3")):
        with pytest.raises(UserError, match=f"j.toml: build.{key}: .*got"):
            load(f"[build]\n{key} = {val}\n")


@pytest.mark.slow
def test_a_kit_at_another_width_recomputes_the_forces(tmp_path, capsys):
    """jansen-plywood states its build (9 mm plywood, 30 mm strips): the kit cuts 9 mm parts by default and its
    pins come from forces computed for its parts; at --width 48 the links weigh 1.6 times as much and the
    forces are computed again (the motor torque peak grows), and README.txt and bom.csv say so."""
    from pathlib import Path
    mech_path = Path(__file__).resolve().parent.parent / "studies" / "mechanisms" / "jansen-plywood.toml"
    mech = load_mechanism(mech_path)
    out = {}
    for w in (None, "48"):
        folder = tmp_path / f"k{w}"
        args = ["export", str(mech_path), "--as", "kit", "-o", str(folder), "--sheet", "1220x610"]
        assert main(args + (["--width", w] if w else [])) == 0
        data = json.loads((folder / "kit.json").read_text())
        out[w] = data
        assert data["build"]["thickness"] == 9.0
        readme, bom = (folder / "README.txt").read_text(), (folder / "bom.csv").read_text()
        width = 30.0 if w is None else 48.0
        assert data["build"]["part_width"] == width
        note = f"links {width:g} mm wide: {680 * 9 * width / 1e6:.4g} kg/m"
        assert note in readme and note in bom
    capsys.readouterr()
    # the forces, plainly: explorer.simulate with the links' mass of each width
    from dataclasses import replace
    for w, data in out.items():
        width = 30.0 if w is None else 48.0
        cyc = explorer.simulate(replace(mech, link_density=680 * 9 * width / 1e6), forces=True)
        assert data["loads"]["motor_torque_peak_Nm"] == pytest.approx(cyc.force_metrics["motor_torque_peak"])
        for j, f in data["loads"]["pin_forces_N"].items():
            assert f == pytest.approx(cyc.force_metrics[f"pin_force.{j}"])
    assert out["48"]["loads"]["motor_torque_peak_Nm"] > 1.1 * out[None]["loads"]["motor_torque_peak_Nm"]


@pytest.mark.slow
def test_plates_for_rigid_triangles(tmp_path):
    mech = load_mechanism("jansen")
    kit = build_kit(mech, plates=True)
    names = {p.name for p in kit.parts}
    assert {"2-3-4", "5-6-7"} <= names and not {"2-3", "3-4", "2-4", "5-6", "6-7", "5-7"} & names
    L = {lk.name: lk.length * kit.scale for lk in mech.links}
    for plate, links in (("2-3-4", ("2-3", "3-4", "2-4")), ("5-6-7", ("5-6", "6-7", "5-7"))):
        p = kit.part(plate)
        H = dict(zip(p.joints, p.holes))
        for ln in links:
            a, b = ln.split("-")
            assert math.dist(H[a], H[b]) == pytest.approx(L[ln], abs=1e-9)
        assert p.mirrored == sum(mech.walker.mirrored)  # a triangle is not its own mirror image
    data = kit_data(kit)
    got, standoffs = clearances(mech, data)
    assert got[0][0] >= 0 and standoffs[0][0] >= 0


# -- refusals and bad input ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ("whitworth", "slidercrank"))
def test_sliders_are_refused(name, tmp_path, capsys):
    assert main(["export", name, "--as", "kit", "-o", str(tmp_path / "k")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "slot or a guide" in err and not (tmp_path / "k").exists()


def test_the_path_driven_arm_is_refused(tmp_path, capsys):
    with pytest.raises(UserError, match="arm.*crank"):
        build_kit(load_mechanism("arm"))
    assert main(["export", "arm", "--as", "kit", "-o", str(tmp_path / "k")]) == 2
    assert "crank" in capsys.readouterr().err and not (tmp_path / "k").exists()


BAD = [(["--sheet", "600"], "--sheet", "600"), (["--sheet", "0x400"], "--sheet", "0x400"),
       (["--sheet", "6000x400"], "--sheet", "6000x400"), (["--sheet", "nanx400"], "--sheet", "nanx400"),
       (["--crank-mm", "-1"], "--crank-mm", "-1"), (["--crank-mm", "0"], "--crank-mm", "0"),
       (["--crank-mm", "nan"], "--crank-mm", "nan"), (["--crank-mm", "6000"], "--crank-mm", "6000"),
       (["--scale", "0"], "--scale", "0"), (["--scale", "inf"], "--scale", "inf"),
       (["--width", "-3"], "--width", "-3"), (["--width", "abc"], "--width", "abc"),
       (["--hole", "0"], "--hole", "0"), (["--hole", "NaN"], "--hole", "NaN"),
       (["--thickness", "0"], "--thickness", "0"), (["--thickness", "-9"], "--thickness", "-9"),
       (["--motor-shaft", "0"], "--motor-shaft", "0"), (["--motor-shaft", "40"], "--motor-shaft", "40"),
       (["--motor-holes", "6xM3"], "--motor-holes", "6xM3"), (["--motor-holes", "40xM3@31"], "--motor-holes", "40xM3@31"),
       (["--clearance", "0"], "--clearance", "0"),
       (["--scale", "2", "--crank-mm", "30"], "--scale", "2"),
       (["--undersized"], "--undersized", "")]


@pytest.mark.parametrize("opts, option, value", BAD)
def test_bad_kit_options(opts, option, value, tmp_path, capsys):
    """Every kit option out of range: one line naming the option and the value, exit 2, nothing written."""
    out = tmp_path / "k"
    assert main(["export", "jansen", "--as", "kit", "-o", str(out), *opts]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and option in err and value in err, err
    assert not out.exists() and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("opts, part", [(["--sheet", "100x80"], "'"), (["--crank-mm", "2"], "'crank'")])
def test_a_part_that_cannot_be_made_is_a_one_line_error(tmp_path, capsys, opts, part):
    out = tmp_path / "kit"
    assert main(["export", "jansen", "--as", "kit", "-o", str(out), *opts]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"part {part}" in err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_kit_options_go_with_the_kit(tmp_path, capsys):
    for opt in (["--sheet", "600x400"], ["--motor-shaft", "6"], ["--plates"]):
        assert main(["export", "x.h5", "--variant", "0", "--as", "svg", "-o", str(tmp_path / "a.svg"), *opt]) == 2
        assert opt[0] in capsys.readouterr().err


# -- bom, README, the CLI's output policy ---------------------------------------------------------------------
def test_bom_and_readme(tmp_path_factory):
    import pandas as pd
    mech, kit, folder = kit_of("jansen", tmp_path_factory)
    text = (folder / "bom.csv").read_text()
    assert "140 MPa" in text and "safety factor 3" in text and "cbrt(16 SF sqrt(M^2 + T^2)" in text
    bom = pd.read_csv(folder / "bom.csv", comment="#")
    parts = bom[bom["item"] == "part"].set_index("name")
    assert set(parts.index) == {p.name for p in kit.parts}
    assert parts.loc["1-3", "count"] == 4 and parts.loc["motor plate", "count"] == 1
    assert (bom["item"] == "crankshaft").sum() == 1 and (bom["item"] == "bushing").sum() == 1
    assert bom.loc[bom["item"] == "bushing", "count"].iloc[0] == mech.walker.legs + 1  # frames and the end plate
    assert bom.loc[bom["item"] == "standoff", "count"].sum() == len(kit.chassis.standoffs)
    for pin in kit.pins:  # a spacer on each empty layer of every pin, on every leg
        rows = bom[(bom["item"] == "spacer") & (bom["name"].astype(str) == pin.joint)]
        assert rows["count"].sum() == len(pin.spacers) * (mech.walker.legs if pin.kind != "standoff" else 1)
    readme = (folder / "README.txt").read_text()
    for s in ("1 model unit = 2 mm", "birch plywood", "kit.json", "leg 2: crank at   90.0 deg",
              "a crank with throws", "D-flat", "standoffs", "worst margin"):
        assert s in readme, s


@pytest.mark.slow
def test_cli_kit_from_a_mechanism_and_the_output_policy(tmp_path, capsys):
    out = tmp_path / "new" / "kit"
    assert main(["export", "hoeken", "--as", "kit", "-o", str(out), "--crank-mm", "20", "--sheet", "400x300"]) == 0
    assert (out / "kit.json").is_file() and "1 model unit = 20 mm" in capsys.readouterr().out
    readme = (out / "README.txt").read_text()
    assert "--crank-mm 20" in readme and "yield" in readme
    before = (out / "bom.csv").read_text()
    assert main(["export", "hoeken", "--as", "kit", "-o", str(out), "--crank-mm", "25"]) == 2
    assert "file exists" in capsys.readouterr().err and (out / "bom.csv").read_text() == before
    assert main(["export", "hoeken", "--as", "kit", "-o", str(out), "--crank-mm", "25", "--force"]) == 0
    assert (out / "bom.csv").read_text() != before


@pytest.mark.slow
def test_cli_kit_from_a_results_variant_with_forces(tmp_path, capsys):
    """A small study of Jansen's plywood leg with forces: the kit is built at the study's size from its
    [build], its pins from the study's own forces (the build matches) by the BOM's rule in 9 mm plywood."""
    import shutil
    from pathlib import Path

    import pandas as pd
    root = Path(__file__).resolve().parent.parent / "studies"
    shutil.copytree(root / "mechanisms", tmp_path / "mechanisms")
    text = (root / "jansen-forces.toml").read_text().replace("variants = 2000", "variants = 3")
    text = text.replace('path = "results/jansen-forces.h5"', f'path = "{tmp_path / "f.h5"}"')
    (tmp_path / "study.toml").write_text(text)
    assert main(["run", str(tmp_path / "study.toml")]) == 0
    capsys.readouterr()
    assert main(["export", str(tmp_path / "f.h5"), "--variant", "1", "--as", "kit", "-o", str(tmp_path / "kit"),
                 "--sheet", "1300x700"]) == 0
    assert "the study's own forces" in capsys.readouterr().out
    with explorer.open_results(tmp_path / "f.h5") as res:
        row = res.frame().iloc[1]
        forces = {c[len("pin_force."):]: float(row[c]) for c in row.index if str(c).startswith("pin_force.")}
        torque = float(row["motor_torque_peak"])
    data = json.loads((tmp_path / "kit" / "kit.json").read_text())
    assert data["scale_mm_per_unit"] == pytest.approx(10.0) and data["build"]["thickness"] == 9.0
    assert data["loads"]["motor_torque_peak_Nm"] == pytest.approx(torque)
    bom = pd.read_csv(tmp_path / "kit" / "bom.csv", comment="#")
    pins = bom[bom["item"].isin(["pin", "crank pin"])].set_index(
        bom[bom["item"].isin(["pin", "crank pin"])]["name"].astype(str))
    floor = 16.0  # the standard size nearest a tenth of the ~150 mm crank
    r = data["crank_mm"]
    for j, f in forces.items():
        F = f + (torque * 1000 / r if j == "1" else 0.0)  # the crank pin carries the torque between the webs
        need = max(math.sqrt(4 * F * 3 / (math.pi * 140)), F * 3 / (9.0 * 60.0))
        assert pins.loc[j, "diameter_mm"] == max(floor, min(d for d in STANDARD if d >= need)), j
    assert "variant 1" in (tmp_path / "kit" / "README.txt").read_text()


@pytest.mark.slow
def test_no_stack_is_refused_naming_the_part_the_pin_and_the_angle(tmp_path, capsys):
    """At a 60 mm running clearance nothing fits between the webs: refused in one line, nothing written."""
    out = tmp_path / "k"
    assert main(["export", "jansen", "--as", "kit", "-o", str(out), "--clearance", "60", "--sheet",
                 "2000x2000"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "part '" in err and "crankshaft" in err and "θ = " in err, err
    assert not out.exists()
