"""The build kit's assembly.pdf (issue 27): page count, the text a maker reads on each page (joint names,
pin stacks, crank phases, hole-to-hole distances, frame pivot dimensions) against plain computations from
the mechanism, and ink on every page (rasterised with pypdfium2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from explorer import load_mechanism
from explorer.mechanism import Walker
from explorer.view._export import CRANK_CENTRE, _raw_parts
from explorer.view._kit import Kit, KitLeg, KitPart, KitPin, Material

pdfium = pytest.importorskip("pypdfium2")

LEGS = ("jansen", "klann", "strider", "hoeken", "fourbar")


# -- test fixture: a Kit built by hand (a stand-in for build_kit) -------------------------------------------
def hand_kit(name: str, crank_mm: float = 30.0, width: float = 6.0, hole: float = 3.0) -> Kit:
    """A Kit of the built-in ``name`` made plainly: scale = crank_mm / crank radius, parts from
    ``_raw_parts`` × scale, every part on its own layer (file order), one pin per joint holding the parts
    that have a hole there, the walker's legs at its phases."""
    mech = load_mechanism(name)
    walker = mech.walker or Walker()
    scale = crank_mm / mech.crank.radius
    n_mirrored = sum(walker.mirrored)
    parts = []
    for pname, kind, joints, pts in _raw_parts(mech):
        P = np.asarray(pts, dtype=float) * scale
        collinear = len(P) < 3 or all(
            abs((P[1][0] - P[0][0]) * (P[i][1] - P[0][1]) - (P[1][1] - P[0][1]) * (P[i][0] - P[0][0])) < 1e-9
            for i in range(2, len(P)))
        symmetric = kind != "body" or collinear
        copies = 1 if kind == "frame" else walker.legs
        parts.append(KitPart(pname, kind, tuple(joints), tuple(map(tuple, P)), (hole,) * len(P), copies,
                             0 if symmetric else n_mirrored, symmetric))
    layers = {p.name: i for i, p in enumerate(parts)}
    holders: dict[str, list[str]] = {}
    for p in parts:
        for j in p.joints:
            for single in j.split("+"):
                holders.setdefault(single, []).append(p.name)
    pins = tuple(KitPin(j, tuple(sorted(ps, key=layers.get)), hole, 5.0 * len(ps), walker.legs, None)
                 for j, ps in holders.items() if len(ps) >= 2)
    legs = tuple(KitLeg(i, math.degrees(ph), m) for i, (ph, m) in enumerate(zip(walker.phases, walker.mirrored)))
    return Kit(mech, walker, scale, width, Material(), tuple(parts), pins, legs, layers, (600.0, 400.0), (),
               source=f"builtin:{name} (test fixture)", tolerance_note="±0.5 % on every length (test fixture)")


# -- reading the PDF -------------------------------------------------------------------------------------
def pages_text(path) -> list[str]:
    """The text of every page (pypdfium2's text page)."""
    doc = pdfium.PdfDocument(str(path))
    try:
        return [doc[i].get_textpage().get_text_range() for i in range(len(doc))]
    finally:
        doc.close()


def pages_ink(path, scale: float = 0.5) -> list[float]:
    """Fraction of non-white pixels of every page rasterised at ``scale`` × 72 dpi, in the drawing area
    (the page less 12 % at the top and 8 % at the bottom: title and footer)."""
    doc = pdfium.PdfDocument(str(path))
    try:
        out = []
        for i in range(len(doc)):
            img = np.asarray(doc[i].render(scale=scale).to_pil().convert("L"), dtype=float)
            h = img.shape[0]
            area = img[int(0.12 * h):int(0.92 * h)]
            out.append(float(np.mean(area < 200)))
        return out
    finally:
        doc.close()


def flat(s: str) -> str:
    """Text with line breaks and runs of spaces collapsed (the text page breaks lines)."""
    return " ".join(s.split())


# -- expected strings, computed plainly --------------------------------------------------------------------
def f1(x: float) -> str:
    s = f"{x:.1f}"
    return "0.0" if s == "-0.0" else s


def expected_distances(mech, pname: str, scale: float) -> list[float]:
    """Hole-to-hole distances of one part, mm, from the mechanism: a link's length, the crank radius, a
    body's point distances, the frame's pivot distances; × scale."""
    links = {ln.name: ln for ln in mech.links}
    bodies = {b.name: b for b in mech.bodies}
    if pname == "crank":
        return [mech.crank.radius * scale]
    if pname in links:
        return [links[pname].length * scale]
    if pname in bodies:
        pts = bodies[pname].points
    else:  # the frame: the crank centre and the fixed pivots
        pts = [mech.crank.center] + [mech.fixed[v] for v in mech.vertices if v in mech.fixed]
    return [math.dist(pts[i], pts[j]) * scale for i in range(len(pts)) for j in range(i + 1, len(pts))]


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    """name → (kit, pdf path, page texts), for every built-in leg."""
    from explorer.view._kit_pdf import write_assembly_pdf
    out = {}
    folder = tmp_path_factory.mktemp("kit_pdf")
    for name in LEGS:
        kit = hand_kit(name)
        path = write_assembly_pdf(kit, folder / f"{name}.pdf")
        out[name] = (kit, path, pages_text(path))
    return out


@pytest.mark.parametrize("name", LEGS)
def test_page_count_is_one_plus_parts(written, name):
    kit, path, texts = written[name]
    assert len(texts) == 1 + len(_raw_parts(kit.mechanism))


@pytest.mark.parametrize("name", LEGS)
def test_assembly_page_names_every_joint_pin_stack_and_phase(written, name):
    kit, _, texts = written[name]
    page = flat(texts[0])
    mech = kit.mechanism
    for v in mech.vertices:
        assert v in page, v
    assert CRANK_CENTRE in page
    for pin in kit.pins:
        for part in pin.stack:
            assert part in page, (pin.joint, part)
    for i, (ph, mir) in enumerate(zip(mech.walker.phases, mech.walker.mirrored)):
        deg = round(math.degrees(ph) % 360.0, 1) % 360.0
        want = f"leg {i + 1}: {deg:.1f}°" + (", mirrored" if mir else "")
        assert want in page, want
    assert f"{kit.scale:g} mm per model unit" in page
    assert "test fixture" in page  # the source and the tolerance note


@pytest.mark.parametrize("name", LEGS)
def test_frame_pivot_dimensions_from_the_crank_centre(written, name):
    kit, _, texts = written[name]
    mech = kit.mechanism
    page = flat(texts[0])
    cx, cy = mech.crank.center
    for v, (x, y) in mech.fixed.items():
        want = f"{v}: x = {f1((x - cx) * kit.scale)} mm, y = {f1((y - cy) * kit.scale)} mm"
        assert want in page, want
        d = math.hypot(x - cx, y - cy) * kit.scale
        assert f"{CRANK_CENTRE} – {v}: {f1(d)} mm" in page
    frame_page = flat(texts[1 + [p.kind for p in kit.parts].index("frame")])
    for d in expected_distances(mech, "frame", kit.scale):
        assert f"{f1(d)} mm" in frame_page


@pytest.mark.parametrize("name", LEGS)
def test_part_pages_name_holes_and_distances(written, name):
    kit, _, texts = written[name]
    mech = kit.mechanism
    for part, text in zip(kit.parts, texts[1:]):
        page = flat(text)
        assert part.name in page
        for j in part.joints:
            assert j in page, (part.name, j)
        for d in expected_distances(mech, part.name, kit.scale):
            assert f"{f1(d)} mm" in page, (part.name, d)
        assert f"cut {part.copies}" in page
        if part.mirrored:
            assert f"{part.mirrored} mirrored" in page


@pytest.mark.parametrize("name", ["jansen", "klann"])
def test_pages_are_not_blank(written, name):
    _, path, _ = written[name]
    ink = pages_ink(path)
    assert all(f > 0.003 for f in ink), ink
