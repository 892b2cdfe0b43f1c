"""`explorer export RESULTS VARIANT --format svg|dxf|csv|toml -o PATH`: one design, taken away.

Each export is checked against references computed here, plainly, from the results file and the
mechanism, never from the exporter's own helpers:

* toml: the file read back by ``load_mechanism`` has every design parameter of the variant's row
  exactly (==), the same topology, and ``simulate`` of it gives the stored paths of that variant within
  1e-9 of the mechanism's size; for Jansen with moved pivots, Hoeken, Klann and Strider with every
  parameter moved (bodies included), and the path-driven arm.
* svg: parsed as XML (width/height in mm, a viewBox in mm, every number finite and inside it), hole
  centres where the link lengths and body-frame joint positions put them (× scale, y flipped: SVG's y
  points down), the outline at exactly half the part width from the part's joints (so every hole,
  narrower than the part, lies inside it), no two parts overlapping; and *rendered*: cairosvg (pip, on
  the system libcairo2 that this machine kind ships; a test extra) rasterises it, and the pixels at the
  hole centres are empty while the hole rims, the outlines and the labels are drawn in their colours.
  matplotlib cannot read SVG, so the rasteriser is what shows that the file renders.
* dxf: ezdxf reads the file back and its auditor finds no error; circles have the hole radius and sit
  link length × scale apart (body-frame offsets × scale for a body); ezdxf's own reading of each
  outline polyline's bulges gives arcs centred on the holes with radius width / 2 and lines at that
  distance from the part's joints; labels are TEXT on layer LABELS.
* csv: pandas reads it; the columns are named as documented and hold the stored arrays bit for bit.
* errors: one line, exit 2, through the CLI.
"""

from __future__ import annotations

import io
import itertools
import math
import tomllib
import xml.etree.ElementTree as ET

import numpy as np
import pandas as pd
import pytest

import explorer
from explorer.cli import main
from explorer.mechanism import mechanism_from_dict
from explorer.fabrication import mechanism_toml

SVG = "{http://www.w3.org/2000/svg}"
STEPS = 48


def _study(mech, **perturb):
    return {"study": {"name": f"export-{mech}", "mechanism": mech, "variants": 6, "seed": 1, "steps": STEPS},
            "perturb": {"spread": 0.01, **perturb}, "scene": {"vertices": "all", "metrics": False}}


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """Small studies: Jansen with every parameter moved (pivots and crank centre too), only the foot and
    joint 4 stored, with accelerations, and a 6-legged walker instead of the leg's own 4; Hoeken, Klann,
    Strider with every parameter moved (bodies' joints too); the path-driven arm (some variants cannot
    assemble)."""
    root = tmp_path_factory.mktemp("export")
    jansen = _study("jansen", spread=0.02, parameters="all")
    jansen["scene"] = {"vertices": ["7", "4"], "velocities": True, "accelerations": True, "metrics": False}
    jansen["walker"] = {"legs": 6}
    specs = {"jansen": jansen, "hoeken": _study("hoeken", parameters="all"),
             "klann": _study("klann", parameters="all"), "strider": _study("strider", parameters="all"),
             "arm": _study("arm")}
    out = {}
    for name, d in specs.items():
        out[name] = explorer.run_study(d, output=root / f"{name}.h5", progress=False).path
    return out


def cli(capsys, *args):
    code = main([str(a) for a in args])
    o = capsys.readouterr()
    return code, o.out, o.err


def one_line_error(code, err, *words):
    assert code == 2, err
    assert err.startswith("explorer: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err


def frame_row(path, v):
    with explorer.open_results(path) as r:
        return r.frame().iloc[v], r.mechanism


def ok_variants(path):
    with explorer.open_results(path) as r:
        df = r.frame()
    return [int(v) for v in df.loc[df["status"] == "ok", "variant"] if v != 0]


def expected_parameters(path, v):
    """The variant's design: the nominal's parameters with the ones its frame row holds."""
    row, nominal = frame_row(path, v)
    return {k: (float(row[k]) if k in row.index else x) for k, x in nominal.parameters().items()}, nominal


# -- toml --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["jansen", "hoeken", "klann", "strider", "arm"])
def test_toml_reads_back_to_the_same_design(studies, name, tmp_path, capsys):
    path = studies[name]
    variants = ok_variants(path)
    assert len(variants) >= 2, "the study must have ok variants to export"
    for v in variants[:2]:
        out = tmp_path / f"{name}-{v}.toml"
        code, msg, err = cli(capsys, "export", path, "--variant", v, "--as", "toml", "-o", out)
        assert code == 0, err
        assert f"wrote {out}" in msg
        data = tomllib.loads(out.read_text())
        for key in ("name", "description", "foot", "fixed", "guess", "links"):
            assert key in data
        mech = explorer.load_mechanism(out)
        want, nominal = expected_parameters(path, v)
        assert mech.parameters() == want  # exactly: floats are written repr-exact
        assert ("crank" in data) == (nominal.crank is not None) and ("driver" in data) == (nominal.path is not None)
        assert ("walker" in data) == (nominal.crank is not None)
        assert ("bodies" in data) == bool(nominal.bodies)
        # the same topology: vertices in the same order, links between the same joints, the same bodies
        assert mech.vertices == nominal.vertices and mech.foot == nominal.foot and mech.driven == nominal.driven
        assert [(l.name, l.a, l.b) for l in mech.links] == [(l.name, l.a, l.b) for l in nominal.links]
        assert [(b.name, b.joints) for b in mech.bodies] == [(b.name, b.joints) for b in nominal.bodies]
        assert mech.path == nominal.path  # the arm's [driver] written back (None for the cranks)
        # the re-read design moves as the study solved it: every stored path, within 1e-9 of the size
        cyc = explorer.simulate(mech, STEPS)
        assert cyc.ok
        with explorer.open_results(path) as r:
            for vertex in r.vertices:
                err = np.abs(cyc.path(vertex) - r.path(v, vertex)).max()
                assert err <= 1e-9 * mech.size, (name, v, vertex, err)


def test_toml_walker_guess_and_nominal(studies, tmp_path, capsys):
    # a study that changed the walker: the exported leg carries the walker the metrics describe
    assert cli(capsys, "export", studies["jansen"], "--variant", 1, "-o", tmp_path / "j.toml")[0] == 0
    j = explorer.load_mechanism(tmp_path / "j.toml")
    assert j.walker.legs == 6 and j.walker.phases == tuple(math.radians(60.0 * k) for k in range(6))
    # the guess is the variant's solved configuration at θ = 0 where the file stores the vertex (7, 4)
    with explorer.open_results(studies["jansen"]) as r:
        for vertex in ("7", "4"):
            assert j.guess[vertex] == tuple(r.path(1, vertex)[0])
    # variant 0 of a study that kept the mechanism's walker reads back as the nominal itself
    assert cli(capsys, "export", studies["klann"], "--variant", "0", "-o", tmp_path / "k.toml")[0] == 0
    k, nominal = explorer.load_mechanism(tmp_path / "k.toml"), explorer.load_mechanism("klann")
    assert k.name == "klann" and k.walker == nominal.walker
    for field in ("vertices", "links", "crank", "fixed", "foot", "path", "bodies"):
        assert getattr(k, field) == getattr(nominal, field), field


def test_mechanism_toml_writes_every_driver_and_any_string():
    """An arc and a spline driver (angles in degrees, read back to the same radians), a [walker] with
    uneven phases, names and a description that need escaping: read back equal, field by field."""
    base = {"name": 'arm "two" \\ ü', "description": "line one\nline\ttwo \x7f end", "foot": "T",
            "fixed": {"O": [0.0, 0.0]}, "guess": {"E": [-0.6, 1.9]},
            "links": [{"name": "up.per+1", "a": "O", "b": "E", "length": 2.0},
                      {"a": "E", "b": "T", "length": 1.0 / 3.0}]}
    drivers = [{"vertex": "T", "path": "arc", "center": [0.1, 0.2], "radius": 1.7, "start_angle": 33.3,
                "end_angle": 201.7, "duration": 2.5, "timing": "quintic"},
               {"vertex": "T", "path": "points", "points": [[-1.0, 1.0], [0.5, 1.25], [2.0, 1.0]], "duration": 3.0}]
    for driver in drivers:
        m = mechanism_from_dict({**base, "driver": driver}, "test")
        back = mechanism_from_dict(tomllib.loads(mechanism_toml(m)), "test")
        for field in ("name", "description", "vertices", "links", "path", "fixed", "guess", "foot", "walker"):
            assert getattr(back, field) == getattr(m, field), field
    crank = {**base, "crank": {"center": [0.0, 0.0], "radius": 0.7, "tip": "T"}, "guess": {"E": [-0.6, 1.9]},
             "walker": {"legs": 3, "phases": [0, 121.7, 250.03], "mirrored": [False, True, False], "drag": 0.1,
                        "contact": 0.02}}
    crank["links"] = [{"name": "a", "a": "O", "b": "E", "length": 2.0}, {"a": "E", "b": "T", "length": 1.9}]
    m = mechanism_from_dict(crank, "test")
    text = mechanism_toml(m, header="made here\nsecond line")
    assert text.startswith("# made here\n# second line\n")
    back = mechanism_from_dict(tomllib.loads(text), "test")
    assert back.walker == m.walker and back.crank == m.crank and back.parameters() == m.parameters()


# -- svg ---------------------------------------------------------------------------------------------------
def ground_points(mech):
    pts = ([("crank centre", mech.crank.center)] if mech.crank is not None else [])
    return pts + [(v, mech.fixed[v]) for v in mech.vertices if v in mech.fixed]


def reference_parts(mech):
    """{part name: {joint: (x, y) in model units}} as the README describes the parts (any translation)."""
    parts = {}
    ground = ground_points(mech)
    if len(ground) >= 2:
        parts["frame"] = dict(ground)
    if mech.crank is not None:
        parts["crank"] = {"crank centre": (0.0, 0.0), mech.crank.tip: (mech.crank.radius, 0.0)}
    for l in mech.links:
        parts[l.name] = {l.a: (0.0, 0.0), l.b: (l.length, 0.0)}
    for b in mech.bodies:
        parts[b.name] = dict(zip(b.joints, b.points))
    return parts


def default_width(parts, scale):
    """20 % of the shortest distance between two holes of one part, mm."""
    return 0.2 * scale * min(math.dist(p, q) for pts in parts.values() for p, q in itertools.combinations(pts.values(), 2))


def seg_distance(p, a, b):
    p, a, b = map(np.asarray, (p, a, b))
    ab = b - a
    t = 0.0 if not ab.any() else float(np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0))
    return float(np.hypot(*(p - (a + t * ab))))


def hull_distance(p, holes):
    """Distance from a point outside the joints' convex hull to it: the least distance to a segment
    between two joints (the hull's edges are among them, the other segments lie inside)."""
    return min(seg_distance(p, a, b) for a, b in itertools.combinations(holes, 2))


def sample_svg_path(d, holes, r):
    """Points along an SVG path of M, L, A (arcs of radius r centred on one of ``holes``) and Z."""
    tokens = d.replace(",", " ").split()
    pts, cur, i = [], None, 0
    while i < len(tokens):
        cmd = tokens[i]
        if cmd == "M":
            cur = (float(tokens[i + 1]), float(tokens[i + 2]))
            pts.append(cur)
            i += 3
        elif cmd == "L":
            nxt = (float(tokens[i + 1]), float(tokens[i + 2]))
            pts += [(cur[0] + t * (nxt[0] - cur[0]), cur[1] + t * (nxt[1] - cur[1])) for t in np.linspace(0, 1, 20)[1:]]
            cur, i = nxt, i + 3
        elif cmd == "A":
            rx, ry, rot, large, sweep = map(float, tokens[i + 1:i + 6])
            nxt = (float(tokens[i + 6]), float(tokens[i + 7]))
            assert rx == ry == pytest.approx(r, abs=1e-6) and large == 0
            c = min(holes, key=lambda h: abs(math.dist(h, cur) - r) + abs(math.dist(h, nxt) - r))
            a0 = math.atan2(cur[1] - c[1], cur[0] - c[0])
            a1 = math.atan2(nxt[1] - c[1], nxt[0] - c[0])
            # sweep-flag 0: decreasing angle in SVG's y-down coordinates
            span = (a0 - a1) % (2 * math.pi) if sweep == 0 else -((a1 - a0) % (2 * math.pi))
            pts += [(c[0] + r * math.cos(a0 - t * span), c[1] + r * math.sin(a0 - t * span))
                    for t in np.linspace(0, 1, 20)[1:]]
            cur, i = nxt, i + 8
        elif cmd == "Z":
            i += 1
        else:
            raise AssertionError(f"unexpected path command {cmd!r}")
    return np.array(pts)


def inside(point, polygon) -> bool:
    """Even-odd ray casting."""
    x, y = point
    n, hit = len(polygon), False
    for k in range(n):
        (x0, y0), (x1, y1) = polygon[k], polygon[(k + 1) % n]
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            hit = not hit
    return hit


@pytest.mark.slow
@pytest.mark.parametrize("name, scale, v", [("jansen", 1.0, None), ("hoeken", 20.0, None), ("hoeken", 20.0, 0),
                                            ("klann", 10.0, None), ("strider", 8.0, None), ("arm", 25.0, None)])
def test_svg_parts_holes_and_outlines(studies, name, scale, v, tmp_path, capsys):
    """Variant 0 of Hoeken: its coupler's three joints on one line (a straight part through its end
    joints, the middle hole inside it)."""
    import cairosvg
    from PIL import Image

    v = ok_variants(studies[name])[0] if v is None else v
    out = tmp_path / f"{name}.svg"
    code, msg, err = cli(capsys, "export", studies[name], "--variant", v, "-o", out, "--scale", scale)
    assert code == 0, err
    want, nominal = expected_parameters(studies[name], v)
    parts = reference_parts(nominal.with_parameters(want))
    w = default_width(parts, scale)
    hole = 0.4 * w
    root = ET.parse(out).getroot()
    assert root.tag == f"{SVG}svg"
    W, H = (float(root.get(k).removesuffix("mm")) for k in ("width", "height"))
    assert root.get("width").endswith("mm") and root.get("viewBox").split() == ["0", "0", root.get("width")[:-2],
                                                                                root.get("height")[:-2]]
    groups = {g.get("data-part"): g for g in root.iter(f"{SVG}g")}
    assert set(groups) == set(parts)
    boxes = {}
    for pname, joints in parts.items():
        g = groups[pname]
        circles = g.findall(f"{SVG}circle")
        assert [c.get("data-joint") for c in circles] == list(joints)
        centres = [(float(c.get("cx")), float(c.get("cy"))) for c in circles]
        for c in circles:
            assert float(c.get("r")) == pytest.approx(hole / 2, abs=1e-6)
        # hole centres: the joints' positions × scale, translated only; SVG's y axis points down
        (x0, y0), (cx0, cy0) = next(iter(joints.values())), centres[0]
        for (x, y), (cx, cy) in zip(joints.values(), centres):
            assert cx - cx0 == pytest.approx((x - x0) * scale, abs=2e-6)
            assert cy - cy0 == pytest.approx(-(y - y0) * scale, abs=2e-6)
        # the outline: every point at w/2 from the joints' hull; the holes inside it, clear of it
        outline = sample_svg_path(g.find(f"{SVG}path").get("d"), centres, w / 2)
        assert np.isfinite(outline).all()
        assert ((outline >= 0) & (outline <= [W, H])).all()
        for p in outline:
            assert hull_distance(p, centres) == pytest.approx(w / 2, abs=1e-5)
        for c in centres:
            assert inside(c, outline) and np.hypot(*(outline - c).T).min() > hole / 2
            assert hole / 2 <= c[0] <= W - hole / 2 and hole / 2 <= c[1] <= H - hole / 2
        assert g.find(f"{SVG}text").text == pname
        boxes[pname] = (*outline.min(axis=0), *outline.max(axis=0))
    for (a, ba), (b, bb) in itertools.combinations(boxes.items(), 2):  # laid out without overlap
        assert ba[2] < bb[0] or bb[2] < ba[0] or ba[3] < bb[1] or bb[3] < ba[1], (a, b)

    # it renders: cairosvg rasterises it at 20 px/mm
    ppm = 20.0
    png = cairosvg.svg2png(url=str(out), output_width=round(W * ppm), output_height=round(H * ppm))
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGBA")).astype(int)
    assert img.shape[:2] == (round(H * ppm), round(W * ppm))
    red = (img[..., 0] > 150) & (img[..., 1] < 100) & (img[..., 2] < 100) & (img[..., 3] > 100)
    blue = (img[..., 2] > 150) & (img[..., 0] < 100) & (img[..., 3] > 100)
    assert blue.any()  # the labels

    def near(mask, x, y, rad=1):
        i, j = round(y * ppm), round(x * ppm)
        return mask[max(i - rad, 0):i + rad + 1, max(j - rad, 0):j + rad + 1].any()

    for pname in parts:
        g = groups[pname]
        for c in g.findall(f"{SVG}circle"):
            x, y, r = float(c.get("cx")), float(c.get("cy")), float(c.get("r"))
            assert img[round(y * ppm), round(x * ppm), 3] == 0  # a hole is not filled
            for a in np.linspace(0, 2 * math.pi, 8, endpoint=False):  # its rim is drawn, red
                assert near(red, x + r * math.cos(a), y + r * math.sin(a))
        centres = [(float(c.get("cx")), float(c.get("cy"))) for c in g.findall(f"{SVG}circle")]
        for x, y in sample_svg_path(g.find(f"{SVG}path").get("d"), centres, w / 2)[::5]:
            assert near(red, x, y)  # the outline is drawn where it should be, red


# -- dxf ---------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name, opts", [("jansen", ()), ("hoeken", ("--scale", "25", "--width", "4", "--hole", "1.5")),
                                        ("klann", ("--scale", "10")), ("strider", ("--scale", "2.5")), ("arm", ())])
def test_dxf_audits_clean_and_holds_the_parts(studies, name, opts, tmp_path, capsys):
    import ezdxf

    v = ok_variants(studies[name])[-1]
    out = tmp_path / f"{name}.dxf"
    code, _, err = cli(capsys, "export", studies[name], "--variant", v, "--as", "dxf", "-o", out, *opts)
    assert code == 0, err
    o = dict(zip(opts[::2], opts[1::2]))
    scale = float(o.get("--scale", 1.0))
    want, nominal = expected_parameters(studies[name], v)
    mech = nominal.with_parameters(want)
    parts = reference_parts(mech)
    w = float(o["--width"]) if "--width" in o else default_width(parts, scale)
    hole = float(o["--hole"]) if "--hole" in o else 0.4 * w

    doc = ezdxf.readfile(out)
    auditor = doc.audit()
    assert not auditor.has_errors, [str(e) for e in auditor.errors]
    assert doc.header["$INSUNITS"] == 4  # millimetres
    assert {"CUT", "LABELS"} <= {layer.dxf.name for layer in doc.layers}
    groups = {g.dxf.description: g for _, g in doc.groups}
    assert set(groups) == set(parts)
    msp = list(doc.modelspace())
    for pname, joints in parts.items():
        handles = {e.dxf.handle for e in groups[pname]}
        ents = [e for e in msp if e.dxf.handle in handles]  # in file order: the holes in joint order
        assert len(ents) == len(handles)
        circles = [e for e in ents if e.dxftype() == "CIRCLE"]
        polys = [e for e in ents if e.dxftype() == "LWPOLYLINE"]
        texts = [e for e in ents if e.dxftype() == "TEXT"]
        assert len(circles) == len(joints) and len(polys) == 1 and len(texts) == 1
        assert texts[0].dxf.text == pname and texts[0].dxf.layer == "LABELS"
        assert all(c.dxf.layer == "CUT" and c.dxf.radius == pytest.approx(hole / 2, abs=1e-9) for c in circles)
        centres = [(c.dxf.center.x, c.dxf.center.y) for c in circles]
        (x0, y0), (cx0, cy0) = next(iter(joints.values())), centres[0]
        for (x, y), (cx, cy) in zip(joints.values(), centres):  # DXF's y points up: no flip
            assert (cx - cx0, cy - cy0) == pytest.approx(((x - x0) * scale, (y - y0) * scale), abs=1e-9)
        if pname in mech.link_names:
            length = mech.links[mech.link_index(pname)].length
            assert math.dist(*centres) == pytest.approx(length * scale, rel=1e-12)
        if pname == "crank":
            assert math.dist(*centres) == pytest.approx(mech.crank.radius * scale, rel=1e-12)
        poly = polys[0]
        assert poly.closed and poly.dxf.layer == "CUT"
        # ezdxf's own reading of the bulges: arcs on the holes' centres, radius w/2; lines w/2 off the hull
        pieces = list(poly.virtual_entities())
        arcs = [e for e in pieces if e.dxftype() == "ARC"]
        assert len(arcs) >= 2 and len(arcs) <= len(joints)
        for a in arcs:
            assert a.dxf.radius == pytest.approx(w / 2, rel=1e-9)
            assert min(math.dist((a.dxf.center.x, a.dxf.center.y), c) for c in centres) < 1e-9
        for line in (e for e in pieces if e.dxftype() == "LINE"):
            for p in (line.dxf.start, line.dxf.end, (line.dxf.start + line.dxf.end) / 2):
                assert hull_distance((p.x, p.y), centres) == pytest.approx(w / 2, abs=1e-9)
        from ezdxf import path as dxfpath
        drawn = [(p.x, p.y) for p in dxfpath.make_path(poly).flattening(distance=1e-4 * w)]
        for c in centres:  # every hole inside the outline as ezdxf draws it, clear of it
            assert inside(c, drawn) and min(math.dist(c, p) for p in drawn) > hole / 2


# -- csv ---------------------------------------------------------------------------------------------------
def test_csv_columns_and_values(studies, tmp_path, capsys):
    out = tmp_path / "j.csv"
    code, msg, err = cli(capsys, "export", studies["jansen"], "--variant", 2, "-o", out)
    assert code == 0, err
    df = pd.read_csv(out)
    assert list(df.columns) == ["theta", "7.x", "7.y", "7.vx", "7.vy", "7.ax", "7.ay",
                                "4.x", "4.y", "4.vx", "4.vy", "4.ax", "4.ay"]  # the foot first, then vertex order
    with explorer.open_results(studies["jansen"]) as r:
        assert len(df) == r.steps and np.array_equal(df["theta"].to_numpy(), r.theta)
        for vtx in ("7", "4"):
            assert np.array_equal(df[[f"{vtx}.x", f"{vtx}.y"]].to_numpy(), r.path(2, vtx))
            assert np.array_equal(df[[f"{vtx}.vx", f"{vtx}.vy"]].to_numpy(), r.velocity(2, vtx))
            assert np.array_equal(df[[f"{vtx}.ax", f"{vtx}.ay"]].to_numpy(), r.acceleration(2, vtx))
    # a path driver's samples are times, in seconds
    v = ok_variants(studies["arm"])[0]
    assert cli(capsys, "export", studies["arm"], "--variant", v, "--as", "csv", "-o", tmp_path / "arm.csv")[0] == 0
    arm = pd.read_csv(tmp_path / "arm.csv")
    assert list(arm.columns[:5]) == ["t", "T.x", "T.y", "T.vx", "T.vy"]
    with explorer.open_results(studies["arm"]) as r:
        T, S = r.mechanism.path.duration, r.steps  # the solver's samples: t_k = T k / (S - 1), seconds
        assert np.array_equal(arm["t"].to_numpy(), T * np.arange(S) / (S - 1)) and arm["t"].iloc[-1] == T
        assert {c.split(".")[0] for c in arm.columns[1:]} == set(r.vertices)
        assert np.array_equal(arm[["E.x", "E.y"]].to_numpy(), r.path(v, "E"))


# -- a failed variant, and every error ---------------------------------------------------------------------
def test_a_failed_variant_exports_its_design_but_no_path(studies, tmp_path, capsys):
    with explorer.open_results(studies["arm"]) as r:
        df = r.frame()
    failed = df.loc[df["status"] != "ok", "variant"].tolist()
    assert failed, "the arm study must have a failed variant"
    v = int(failed[0])
    status = str(df.loc[v, "status"])
    code, _, err = cli(capsys, "export", studies["arm"], "--variant", v, "-o", tmp_path / "f.csv")
    one_line_error(code, err, f"variant {v} failed ({status}", "no full path", "toml, svg or dxf")
    assert not (tmp_path / "f.csv").exists()
    code, msg, err = cli(capsys, "export", studies["arm"], "--variant", v, "-o", tmp_path / "f.toml")
    assert code == 0 and "did not solve over its whole cycle" in msg, err
    mech = explorer.load_mechanism(tmp_path / "f.toml")
    assert mech.parameters() == expected_parameters(studies["arm"], v)[0]
    cyc = explorer.simulate(mech, STEPS)
    assert not cyc.ok and cyc.failure.kind == status  # it fails as the study found
    for fmt in ("svg", "dxf"):
        assert cli(capsys, "export", studies["arm"], "--variant", v, "-o", tmp_path / f"f.{fmt}")[0] == 0


def test_errors_are_one_line(studies, tmp_path, capsys):
    res = studies["hoeken"]
    one_line_error(*cli(capsys, "export", tmp_path / "none.h5", "--variant", 1, "-o", tmp_path / "a.svg")[::2], "no such results file")
    one_line_error(*cli(capsys, "export", res, "--variant", 6, "-o", tmp_path / "a.svg")[::2], "variant 6 out of range")
    one_line_error(*cli(capsys, "export", res, "--variant", "x", "-o", tmp_path / "a.svg")[::2], "expected a whole number")
    # a missing folder is created (the verbs' one output policy, issue 26)
    assert cli(capsys, "export", res, "--variant", 1, "-o", tmp_path / "no" / "a.svg")[0] == 0
    assert (tmp_path / "no" / "a.svg").is_file()
    (tmp_path / "file").write_text("")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "-o", tmp_path / "file" / "a.svg")[::2], "is not a folder")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "--as", "svg", "-o", tmp_path)[::2], "it is a folder")
    # never overwrite without --force; never the results file, even with it
    target = tmp_path / "keep.toml"
    target.write_text("mine")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "-o", target)[::2], "file exists", "--force")
    assert target.read_text() == "mine"
    assert cli(capsys, "export", res, "--variant", 1, "-o", target, "--force")[0] == 0
    assert explorer.load_mechanism(target).parameters() == expected_parameters(res, 1)[0]
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "--as", "csv", "-o", res, "--force")[::2], "results file")
    assert explorer.open_results(res).n_variants == 6
    # what to write, and options that do not go with it
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "-o", tmp_path / "a")[::2], "--as")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "--as", "dxf", "-o", tmp_path / "a.svg")[::2], "--as dxf")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "-o", tmp_path / "a.csv", "--scale", "2")[::2], "--scale")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "-o", tmp_path / "a.svg", "--width", "1", "--hole", "1")[::2],
                   "does not fit")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "-o", tmp_path / "a.svg", "--hole", "2", "--width", "3")[::2],
                   "would overlap")
    one_line_error(*cli(capsys, "export", res, "--variant", 1, "-o", tmp_path / "a.dxf", "--scale", "0")[::2], "scale")
    assert not any(p.suffix in (".svg", ".dxf", ".csv") for p in tmp_path.iterdir())


def test_help(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["export", "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and "20 % of" in out and "%%" not in out and "--force" in out


def test_a_mechanism_exports_as_a_design_file_and_a_cut_sheet(tmp_path, capsys):
    """svg, dxf and toml take a design alone (a built-in or a .toml), as the kit does: the toml reads back as
    the same design; csv (a variant's stored trajectories) still needs a results file, said in one line."""
    from explorer import load_mechanism
    from explorer.cli import main
    assert main(["export", "jansen", "--as", "toml", "-o", str(tmp_path / "j.toml")]) == 0
    assert load_mechanism(tmp_path / "j.toml").parameters() == load_mechanism("jansen").parameters()
    assert "Exported by explorer" in (tmp_path / "j.toml").read_text().splitlines()[0]
    assert main(["export", str(tmp_path / "j.toml"), "-o", str(tmp_path / "j.svg")]) == 0
    assert (tmp_path / "j.svg").read_text().startswith("<?xml")
    out = capsys.readouterr().out
    assert "design 'jansen'" in out and "variant None" not in out
    assert main(["export", "jansen", "--as", "csv", "-o", str(tmp_path / "j.csv")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "not a results file" in err and not (tmp_path / "j.csv").exists()
