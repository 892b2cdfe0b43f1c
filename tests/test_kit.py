"""The build kit (issue 27): ``explorer export ... --format kit -o DIR``.

Everything is checked against plain computations here: hole spacings against the design's link lengths,
crank radius, body points and pivot positions × scale; copy counts against the walker's legs; the stack
layers by brute force over 360 crank angles; pin sizes from the single-shear formula."""

from __future__ import annotations

import io
import math
import xml.etree.ElementTree as ET
from collections import Counter

import numpy as np
import pytest

import explorer
from explorer.cli import main
from explorer.errors import UserError
from explorer.mechanism import load_mechanism
from explorer.view._kit import Material, build_kit, pin_diameter, write_kit

SVG = "{http://www.w3.org/2000/svg}"
BUILTIN_LEGS = ("jansen", "klann", "strider", "hoeken", "fourbar")
STANDARD = (2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)


# -- plain computations -----------------------------------------------------------------------------------
def design_parts(mech) -> dict[str, list[tuple[str, tuple[float, float]]]]:
    """{part: [(joint, point in model units)]} of the design, written out plainly: the frame (crank centre
    and the fixed pivots), the crank, each link, each body."""
    parts = {"frame": [("crank centre", mech.crank.center)] + [(v, mech.fixed[v]) for v in mech.fixed],
             "crank": [("crank centre", (0.0, 0.0)), (mech.crank.tip, (mech.crank.radius, 0.0))]}
    for link in mech.links:
        parts[link.name] = [(link.a, (0.0, 0.0)), (link.b, (link.length, 0.0))]
    for body in mech.bodies:
        parts[body.name] = list(zip(body.joints, body.points))
    return parts


def symmetric(points) -> bool:
    """Whether the labelled holes lie on one line (then the mirror image is the same part)."""
    (x0, y0), (x1, y1) = points[0], points[1]
    return all(abs((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)) < 1e-9 for x, y in points[2:])


def seg_dist(p, q, r, s) -> float:
    """Distance between segments p–q and r–s (plain)."""
    def pt(a, b, c):
        bx, by, cx, cy = b[0] - a[0], b[1] - a[1], c[0] - a[0], c[1] - a[1]
        L = bx * bx + by * by
        t = 0.0 if L == 0 else min(1.0, max(0.0, (cx * bx + cy * by) / L))
        return math.hypot(cx - t * bx, cy - t * by)

    def orient(a, b, c):
        return (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    if orient(p, q, r) * orient(p, q, s) < 0 and orient(r, s, p) * orient(r, s, q) < 0:
        return 0.0
    return min(pt(r, s, p), pt(r, s, q), pt(p, q, r), pt(p, q, s))


def inside(p, poly) -> bool:
    """Point in the convex polygon (either orientation)."""
    signs = [(b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) for a, b in zip(poly, poly[1:] + poly[:1])]
    return all(s >= 0 for s in signs) or all(s <= 0 for s in signs)


def hull(points):
    pts = sorted(set(points))
    if len(pts) <= 2:
        return pts

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    lo, up = [], []
    for p in pts:
        while len(lo) >= 2 and cross(lo[-2], lo[-1], p) <= 0:
            lo.pop()
        lo.append(p)
    for p in reversed(pts):
        while len(up) >= 2 and cross(up[-2], up[-1], p) <= 0:
            up.pop()
        up.append(p)
    return lo[:-1] + up[:-1]


def shape_dist(A, B) -> float:
    """Distance between two convex shapes (their corners), 0 where they overlap."""
    ea = [(A[i], A[(i + 1) % len(A)]) for i in range(len(A))] if len(A) > 1 else [(A[0], A[0])]
    eb = [(B[i], B[(i + 1) % len(B)]) for i in range(len(B))] if len(B) > 1 else [(B[0], B[0])]
    if (len(A) >= 3 and inside(B[0], A)) or (len(B) >= 3 and inside(A[0], B)):
        return 0.0
    return min(seg_dist(a, b, c, d) for a, b in ea for c, d in eb)


# -- pins -------------------------------------------------------------------------------------------------
def test_pin_diameter_from_a_force():
    # shear alone (a part thick enough that bearing does not decide): 125 N → √(4·125·3/(π·140)) = 1.85 mm → M2
    need = math.sqrt(4 * 125 * 3 / (math.pi * 140))
    expected = min(d for d in STANDARD if d >= need)
    name, d, req = pin_diameter(125.0, Material(pin_shear=140.0, safety_factor=3.0, thickness=9.0, bearing=60.0))
    assert 125 * 3 / (9.0 * 60.0) < need
    assert d == expected == 2.0 and name == "M2" and req == pytest.approx(need)
    # in 3 mm plywood bearing decides: 125·3 / (3·60) = 2.08 mm → M2.5
    bear = 125 * 3 / (3.0 * 60.0)
    assert bear > need
    name, d, req = pin_diameter(125.0, Material(thickness=3.0, bearing=60.0))
    assert d == min(d for d in STANDARD if d >= bear) == 2.5 and req == pytest.approx(bear)
    # a heavier joint in 3 mm plywood: 2 kN → bearing 2000·3/(3·60) = 33 mm, past M20: refused in one line
    with pytest.raises(UserError, match="2000 N joint needs a 33.3 mm pin"):
        pin_diameter(2000.0)
    # in 20 mm plywood (f_h 60 MPa): shear √(4·2000·3/(π·140)) = 7.4 mm, bearing 5 mm → M8
    hard = Material(thickness=20.0)
    need2 = max(math.sqrt(4 * 2000 * 3 / (math.pi * 140)), 2000 * 3 / (20.0 * 60.0))
    assert pin_diameter(2000.0, hard)[1] == min(d for d in STANDARD if d >= need2) == 8.0
    kit = build_kit(load_mechanism("jansen"), forces={"1": 2000.0, "2": 125.0}, material=hard)
    assert kit.pin("1").diameter == 8.0 and kit.pin("1").force == 2000.0
    # 125 N needs only M2 there, but no pin is smaller than the default M3 (a tenth of the 30 mm crank)
    assert kit.pin("2").diameter == 3.0 and kit.pin("3").force is None and kit.pin("3").diameter == 3.0
    for p in kit.parts:
        for j, d in zip(p.joints, p.diameters):
            if j == "1":
                assert d == 8.0


# -- one kit per built-in leg -----------------------------------------------------------------------------
def check_kit(kit, folder, raster: bool = True):
    import ezdxf

    mech, walker = kit.mechanism, kit.walker
    plain = design_parts(mech)
    assert {p.name for p in kit.parts} == set(plain)
    n_mirrored_legs = sum(walker.mirrored)
    # copies: one per leg; mirrored copies of the asymmetric parts for the mirrored legs
    by_part = Counter(pl.part for pl in kit.placements)
    mirrored = Counter(pl.part for pl in kit.placements if pl.mirrored)
    for name, holes in plain.items():
        assert by_part[name] == walker.legs, name
        sym = symmetric([p for _, p in holes])
        assert mirrored[name] == (0 if sym else n_mirrored_legs), name
        assert kit.part(name).copies == walker.legs

    # the SVG: every joint label once per hole of every copy; cut and engrave layers
    root = ET.parse(folder / "parts.svg").getroot()
    cut = root.find(f"{SVG}g[@id='cut']")
    eng = root.find(f"{SVG}g[@id='engrave']")
    assert cut is not None and eng is not None
    assert cut.get("{http://www.inkscape.org/namespaces/inkscape}label") == "cut"
    copies = cut.findall(f"{SVG}g[@class='part']")
    assert len(copies) == walker.legs * len(plain)
    for g in copies:
        name, copy = g.get("data-part"), g.get("data-copy")
        joints = sorted(j for j, _ in plain[name])
        assert sorted(c.get("data-joint") for c in g.findall(f"{SVG}circle")) == joints
        assert g.find(f"{SVG}path").get("stroke") == "#ff0000"
        lab = eng.find(f"{SVG}g[@data-part='{name}'][@data-copy='{copy}']")
        texts = lab.findall(f"{SVG}text[@class='joint']")
        assert sorted(t.get("data-joint") for t in texts) == joints
        for t in texts:
            assert t.text == ("shaft" if t.get("data-joint") == "crank centre" else t.get("data-joint"))
        title = lab.find(f"{SVG}text[@class='part']").text
        assert title == f"{name} #{copy}" + (" M" if g.get("data-mirrored") == "true" else "")
    assert any("50 mm" == (t.text or "") for t in eng.iter(f"{SVG}text"))

    # the DXF: hole spacings equal the design's dimensions × scale, on every copy
    doc = ezdxf.readfile(folder / "parts.dxf")
    assert {"CUT", "ENGRAVE"} <= {la.dxf.name for la in doc.layers}
    seen = Counter()
    for _, group in doc.groups:
        desc = group.dxf.description
        name = desc.split(" #")[0]
        seen[name] += 1
        circles = sorted((e for e in group if e.dxftype() == "CIRCLE"), key=lambda e: int(e.dxf.handle, 16))  # as written
        assert all(c.dxf.layer == "CUT" for c in circles)
        pts = [p for _, p in plain[name]]
        assert len(circles) == len(pts)
        got = sorted(math.dist(tuple(a.dxf.center)[:2], tuple(b.dxf.center)[:2]) for a in circles for b in circles)
        want = sorted(math.dist(a, b) * kit.scale for a in pts for b in pts)
        np.testing.assert_allclose(got, want, atol=1e-6)
        # the holes in order: a mirrored copy is a mirror image (its orientation flips), a plain one is not
        if len(pts) >= 3 and not symmetric(pts):
            c = [tuple(c.dxf.center) for c in circles]
            o_got = (c[1][0] - c[0][0]) * (c[2][1] - c[0][1]) - (c[1][1] - c[0][1]) * (c[2][0] - c[0][0])
            o_want = (pts[1][0] - pts[0][0]) * (pts[2][1] - pts[0][1]) - (pts[1][1] - pts[0][1]) * (pts[2][0] - pts[0][0])
            assert (o_got * o_want < 0) == desc.endswith(" M"), desc
    assert seen == Counter({n: walker.legs for n in plain})

    # every copy within its sheet
    W, H = kit.sheet_size
    for pl in kit.placements:
        for x, y in kit.placed_holes(pl):
            assert kit.width / 2 <= x <= W - kit.width / 2 and kit.width / 2 <= y <= H - kit.width / 2

    if raster:
        import cairosvg
        from PIL import Image
        ppm = 2.0  # pixels per mm
        TW = kit.sheets * W + (kit.sheets - 1) * 20.0
        png = cairosvg.svg2png(url=str(folder / "parts.svg"), output_width=round(TW * ppm), background_color="white")
        im = np.asarray(Image.open(io.BytesIO(png)).convert("L"))
        assert (im < 200).mean() > 0.001  # not blank
        for pl in kit.placements:
            P = kit.placed_holes(pl)
            dx = pl.sheet * (W + 20.0)
            x0 = min(p[0] for p in P) - kit.width / 2 + dx
            x1 = max(p[0] for p in P) + kit.width / 2 + dx
            y0, y1 = H - max(p[1] for p in P) - kit.width / 2, H - min(p[1] for p in P) + kit.width / 2
            box = im[int(y0 * ppm):int(math.ceil(y1 * ppm)) + 1, int(x0 * ppm):int(math.ceil(x1 * ppm)) + 1]
            assert (box < 200).sum() > 10, (pl.part, pl.copy)


def check_layers(kit):
    """Brute force: no two parts of one layer share a joint or come within the part width (outlines
    touching) at any of 360 crank angles."""
    mech = kit.mechanism
    cyc = explorer.simulate(mech, steps=360)
    assert cyc.ok
    P = np.asarray(cyc.positions)
    plain = design_parts(mech)

    def at(j, k):
        return tuple(mech.crank.center) if j == "crank centre" else tuple(P[k, mech.vertices.index(j)])
    clear = kit.width / kit.scale
    names = list(plain)
    assert kit.layers["frame"] == 0 and all(kit.layers[n] > 0 for n in names if n != "frame")
    for i, a in enumerate(names):
        for b in names[:i]:
            if kit.layers[a] != kit.layers[b]:
                continue
            assert not ({j for j, _ in plain[a]} & {j for j, _ in plain[b]}), (a, b)
            for k in range(360):
                A = hull([at(j, k) for j, _ in plain[a]])
                B = hull([at(j, k) for j, _ in plain[b]])
                assert shape_dist(A, B) >= clear - 1e-9, (a, b, k)
    # each pin's stack: the parts on that joint, by layer
    for pin in kit.pins:
        on = [n for n in names if pin.joint in {j for j, _ in plain[n]}]
        assert sorted(pin.stack) == sorted(on)
        assert [kit.layers[n] for n in pin.stack] == sorted(kit.layers[n] for n in on)


@pytest.mark.parametrize("name", BUILTIN_LEGS)
def test_kit_of_every_builtin_leg(name, tmp_path):
    mech = load_mechanism(name)
    kit = build_kit(mech)
    assert kit.scale == pytest.approx(30.0 / mech.crank.radius)  # the crank is 30 mm
    assert kit.walker == mech.walker and len(kit.legs) == mech.walker.legs
    assert [leg.mirrored for leg in kit.legs] == list(mech.walker.mirrored)
    np.testing.assert_allclose([leg.phase_deg for leg in kit.legs],
                               [math.degrees(p) % 360 for p in mech.walker.phases])
    paths = write_kit(kit, tmp_path / "kit")
    assert {p.name for p in paths} >= {"parts.svg", "parts.dxf", "bom.csv", "README.txt"}
    check_kit(kit, tmp_path / "kit")
    check_layers(kit)
    # default pins: M3 at a 30 mm crank; holes within the part less a wall
    assert all(d == 3.0 for p in kit.parts for d in p.diameters)
    assert kit.width - 3.0 >= 2 * 1.5


def test_kit_of_a_variant_with_moved_pivots_and_body_points(tmp_path):
    mech = load_mechanism("klann")
    params = mech.parameters()
    moved = mech.with_parameters({"11.x": params["11.x"] + 0.05, "9.y": params["9.y"] - 0.04,
                                  "leg.33.x": params["leg.33.x"] + 0.08, "connecting_rod.35.y":
                                  params["connecting_rod.35.y"] + 0.03, "crank": params["crank"] * 1.01})
    kit = build_kit(moved, crank_mm=25.0, sheet=(500.0, 350.0))
    assert kit.scale == pytest.approx(25.0 / moved.crank.radius)
    write_kit(kit, tmp_path / "kit")
    check_kit(kit, tmp_path / "kit", raster=False)
    # the moved points are the ones cut
    leg = next(b for b in moved.bodies if b.name == "leg")
    assert leg.points != next(b for b in mech.bodies if b.name == "leg").points


def test_the_path_driven_arm_is_refused(tmp_path, capsys):
    with pytest.raises(UserError, match="arm.*crank"):
        build_kit(load_mechanism("arm"))
    assert main(["export", "arm", "--format", "kit", "-o", str(tmp_path / "k")]) == 2
    assert "crank" in capsys.readouterr().err and not (tmp_path / "k").exists()


# -- bom and README ---------------------------------------------------------------------------------------
def test_bom_and_readme(tmp_path):
    import pandas as pd
    kit = build_kit(load_mechanism("jansen"), forces={"6": 300.0}, commands=("explorer export jansen ...",),
                    tolerance_note="yield 98 %")
    write_kit(kit, tmp_path / "k")
    text = (tmp_path / "k" / "bom.csv").read_text()
    assert "140 MPa" in text and "safety factor 3" in text
    bom = pd.read_csv(tmp_path / "k" / "bom.csv", comment="#")
    parts = bom[bom["item"] == "part"].set_index("name")
    assert (parts["count"] == 4).all() and set(parts.index) == set(design_parts(kit.mechanism))
    pins = bom[bom["item"] == "pin"].set_index("name")
    need = max(math.sqrt(4 * 300 * 3 / (math.pi * 140)), 300 * 3 / (3.0 * 60.0))  # shear, bearing in 3 mm
    assert pins.loc["6", "diameter_mm"] == max(3.0, min(d for d in STANDARD if d >= need))
    assert pins.loc["6", "required_d_mm"] == pytest.approx(need, rel=1e-2)
    assert (bom["item"] == "crankshaft").sum() == 1
    # pin length: the layers it spans × 3 mm + washers + one diameter + 2 mm, rounded up
    for joint, row in pins.iterrows():
        layers = [kit.layers[n] for n in kit.pin(str(joint)).stack]
        span = max(layers) - min(layers) + 1
        assert row["length_mm"] == math.ceil(span * 3.0 + (span - 1) * 0.5 + row["diameter_mm"] + 2.0)
        skipped = span - len(layers)
        spacers = bom[(bom["item"] == "spacer") & (bom["name"].astype(str) == str(joint))]
        assert spacers["count"].sum() == skipped * 4
    readme = (tmp_path / "k" / "README.txt").read_text()
    for s in ("1 model unit = 2 mm", "birch plywood", "yield 98 %", "explorer export jansen ...", "parts.svg",
              "leg 2: crank at   90.0 deg  mirrored"):
        assert s in readme, s


# -- the CLI and bad input --------------------------------------------------------------------------------
def test_cli_kit_from_a_mechanism_and_the_output_policy(tmp_path, capsys):
    out = tmp_path / "new" / "kit"
    assert main(["export", "hoeken", "--format", "kit", "-o", str(out), "--crank-mm", "20", "--sheet", "400x300"]) == 0
    assert (out / "parts.svg").is_file() and "1 model unit = 20 mm" in capsys.readouterr().out
    readme = (out / "README.txt").read_text()
    assert "--crank-mm 20" in readme and "yield" in readme
    before = (out / "bom.csv").read_text()
    assert main(["export", "hoeken", "--format", "kit", "-o", str(out), "--crank-mm", "25"]) == 2
    assert "file exists" in capsys.readouterr().err and (out / "bom.csv").read_text() == before
    assert main(["export", "hoeken", "--format", "kit", "-o", str(out), "--crank-mm", "25", "--force"]) == 0
    assert (out / "bom.csv").read_text() != before


@pytest.mark.parametrize("opts, part", [(["--sheet", "100x80"], "'1-3'"), (["--crank-mm", "2"], "'crank'")])
def test_a_part_that_cannot_be_made_is_a_one_line_error(tmp_path, capsys, opts, part):
    out = tmp_path / "kit"
    assert main(["export", "jansen", "--format", "kit", "-o", str(out), *opts]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"part {part}" in err
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_bad_kit_options(tmp_path, capsys):
    for opts, what in ((["--sheet", "600"], "--sheet"), (["--crank-mm", "-1"], "crank-mm"),
                       (["3"], "no variants")):
        assert main(["export", "jansen", *opts, "--format", "kit", "-o", str(tmp_path / "k")]) == 2
        assert what in capsys.readouterr().err
    assert main(["export", "jansen", "0", "--format", "svg", "-o", str(tmp_path / "a.svg"), "--sheet", "600x400"]) == 2
    assert not (tmp_path / "k").exists()


def test_cli_kit_from_a_results_variant_with_forces(tmp_path, capsys):
    """A small study of Jansen's plywood leg with forces: the variant's pin_force metrics size the pins."""
    import shutil
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent / "studies"
    shutil.copytree(root / "mechanisms", tmp_path / "mechanisms")
    text = (root / "jansen-forces.toml").read_text().replace("variants = 2000", "variants = 3")
    text = text.replace('path = "results/jansen-forces.h5"', f'path = "{tmp_path / "f.h5"}"')
    (tmp_path / "study.toml").write_text(text)
    assert main(["run", str(tmp_path / "study.toml")]) == 0
    capsys.readouterr()
    # the forces are those of the study's machine (1 model unit = 1 cm): the kit is built at that size, on
    # sheets it fits on
    assert main(["export", str(tmp_path / "f.h5"), "1", "--format", "kit", "-o", str(tmp_path / "kit"),
                 "--sheet", "1300x700"]) == 0
    with explorer.open_results(tmp_path / "f.h5") as res:
        row = res.frame().iloc[1]
        forces = {c[len("pin_force."):]: float(row[c]) for c in row.index if str(c).startswith("pin_force.")}
    assert forces
    import pandas as pd
    bom = pd.read_csv(tmp_path / "kit" / "bom.csv", comment="#")
    pins = bom[bom["item"] == "pin"].set_index(bom[bom["item"] == "pin"]["name"].astype(str))
    assert "1 model unit = 10 mm" in (tmp_path / "kit" / "bom.csv").read_text()
    floor = 16.0  # the standard size nearest a tenth of the 150 mm crank
    for j, f in forces.items():
        need = max(math.sqrt(4 * f * 3 / (math.pi * 140)), f * 3 / (3.0 * 60.0))
        assert pins.loc[j, "diameter_mm"] == max(floor, min(d for d in STANDARD + (12.0, 16.0, 20.0) if d >= need)), j
    assert "variant 1" in (tmp_path / "kit" / "README.txt").read_text()
