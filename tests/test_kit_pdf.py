"""The build kit's assembly.pdf (issue 27): page count, the text a maker reads on each page (joint names,
pin stacks, crank phases, hole-to-hole distances, frame pivot dimensions) against plain computations from
the mechanism, and ink on every page (rasterised with pypdfium2)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from explorer import load_mechanism
from explorer.fabrication import build_kit

pdfium = pytest.importorskip("pypdfium2")

CRANK_CENTRE = "crank centre"  # the frame's hole at the crank centre, as labelled

LEGS = ("jansen",) + tuple(pytest.param(n, marks=pytest.mark.slow)  # one in the quick loop
                           for n in ("klann", "strider", "hoeken", "fourbar", "klann-moved"))
#: A variant with its crank centre, a ground pivot and body points moved (the frame's dimensions are then
#: not the built-in's).
MOVED = {"crank.x": 0.1, "11.x": -6.8, "leg.33.y": -5.5, "connecting_rod.35.x": 12.1}


def design(name: str):
    if name == "klann-moved":
        return load_mechanism("klann").with_parameters(MOVED)
    return load_mechanism(name)


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
    if pname not in bodies and pname != "frame":  # a plate for a triangle of links
        return []
    if pname in bodies:
        pts = bodies[pname].points
    else:  # the frame: the crank centre and the fixed pivots
        pts = [mech.crank.center] + [mech.fixed[v] for v in mech.vertices if v in mech.fixed]
    return [math.dist(pts[i], pts[j]) * scale for i in range(len(pts)) for j in range(i + 1, len(pts))]


_CACHE: dict = {}


@pytest.fixture(params=LEGS)
def written(request, tmp_path_factory):
    """(kit, pdf path, page texts) of build_kit's kit of one built-in leg (at its default walker), written
    once per test session."""
    from explorer.testing import write_assembly_pdf
    name = request.param
    if name not in _CACHE:
        kit = build_kit(design(name), source=f"builtin:{name} (test)", tolerance_note="±0.5 % on every length (test)")
        path = write_assembly_pdf(kit, tmp_path_factory.mktemp("kit_pdf") / "assembly.pdf")
        _CACHE[name] = (kit, path, pages_text(path))
    return _CACHE[name]


def test_page_count_is_two_plus_parts(written):
    kit, path, texts = written
    mech = kit.mechanism  # the assembly, the chassis; the frame, the crank and its outer web, each link, each
    # body, the motor plate and the end plate
    assert len(texts) == 2 + 3 + len(mech.links) + len(mech.bodies) + 2


def test_assembly_page_names_every_joint_pin_stack_and_phase(written):
    kit, _, texts = written
    page = flat(texts[0])
    mech = kit.mechanism
    for v in mech.vertices:
        assert v in page, v
    assert CRANK_CENTRE in page
    for pin in kit.pins:  # bottom to top, each part with its layer
        if pin.kind == "standoff":
            continue
        stack = " · ".join(f"{part} [{kit.layers[part]}]" for part in pin.stack)
        if pin.kind == "shaft":
            assert f"{pin.joint} (the crankshaft, {kit.shaft.mode}): Ø{f1(pin.diameter)}" in page
        else:
            assert f"{pin.joint}: Ø{f1(pin.diameter)} × {f1(pin.length)} mm" in page, pin
        assert stack in page, (pin.joint, stack)
    for i, (ph, mir) in enumerate(zip(mech.walker.phases, mech.walker.mirrored)):
        deg = round(math.degrees(ph) % 360.0, 1) % 360.0
        want = f"leg {i + 1}: {deg:.1f}°" + (", mirrored" if mir else "")
        assert want in page, want
    assert f"{kit.scale:g} mm per model unit" in page
    assert f"Design: builtin:{mech.name}" in page and "Tolerance: ±0.5 % on every length (test)" in page


def test_frame_pivot_dimensions_from_the_crank_centre(written):
    kit, _, texts = written
    mech = kit.mechanism
    page = flat(texts[0])
    cx, cy = mech.crank.center
    for v, (x, y) in mech.fixed.items():
        want = f"{v}: x = {f1((x - cx) * kit.scale)} mm, y = {f1((y - cy) * kit.scale)} mm"
        assert want in page, want
        d = math.hypot(x - cx, y - cy) * kit.scale
        assert f"{CRANK_CENTRE} – {v}: {f1(d)} mm" in page
    frame_page = flat(texts[2 + [p.kind for p in kit.parts].index("frame")])
    for d in expected_distances(mech, "frame", kit.scale):
        assert f"{f1(d)} mm" in frame_page
    for v, (x, y) in mech.fixed.items():
        assert f"{v}: x = {f1((x - cx) * kit.scale)} mm, y = {f1((y - cy) * kit.scale)} mm" in frame_page


def test_part_pages_name_holes_and_distances(written):
    kit, _, texts = written
    mech = kit.mechanism
    names = [p.name for p in kit.parts]
    assert {ln.name for ln in mech.links} | {b.name for b in mech.bodies} | {"frame", "crank"} <= set(names)
    for part, text in zip(kit.parts, texts[2:]):
        page = flat(text)
        assert part.name in page
        for j in part.joints:
            assert j in page, (part.name, j)
        if part.kind in ("motor", "end"):
            assert part.copies == 1
            continue
        for d in expected_distances(mech, "crank" if part.kind == "crank" else part.name, kit.scale):
            assert f"{f1(d)} mm" in page, (part.name, d)
        assert f"{part.kind} · cut {part.copies}" in page  # the page's subtitle: this part's page
        assert part.copies == mech.walker.legs
        if part.mirrored:
            assert f"{part.mirrored} mirrored" in page
        if part.kind == "crank":  # each copy's D-hole, turned by its leg's phase
            for c, ph in enumerate(mech.walker.phases):
                deg = math.degrees(ph) % 360
                want = f"copy {c + 1}: leg {c + 1} at {f1(round(deg, 1) % 360)}°, flat normal at " \
                       f"{f1(round((-deg) % 360, 1) % 360)}°"
                assert want in page, want


def test_the_chassis_page(written):
    """Page 2: the legs' order along the shaft with their phases and webs, the shaft's sizing, the standoffs,
    the motor plate and the worst clearance."""
    from explorer.testing import clearance_line
    kit, _, texts = written
    page = flat(texts[1])
    assert "crankshaft and chassis" in page
    for leg in kit.legs:
        deg = round(leg.phase_deg % 360, 1) % 360
        assert f"leg {leg.index + 1} at z = {f1(leg.z)} mm: crank {deg:.1f}°" in page
    assert f"crankshaft: Ø{f1(kit.shaft.diameter)} mm" in page and "motor plate" in page
    assert f"{len(kit.chassis.standoffs)} × M" in page
    assert flat(clearance_line(kit))[:60] in page


def test_pages_are_not_blank(written):
    _, path, _ = written
    ink = pages_ink(path)
    assert all(f > 0.003 for f in ink), ink


@pytest.mark.slow
def test_a_part_too_big_for_the_page_is_drawn_at_a_stated_reduction(tmp_path):
    """At a 90 mm crank the Jansen leg's longest link (5-7, 65.7 × 6 = 394.2 mm) cannot be drawn true size
    on A4 landscape (297 mm): its page states a reduction 1:k with 394.2 / k under the page width; the
    crank (90 mm) stays true size."""
    from explorer.testing import write_assembly_pdf
    kit = build_kit(load_mechanism("jansen"), crank_mm=90.0)
    texts = pages_text(write_assembly_pdf(kit, tmp_path / "assembly.pdf"))
    names = [p.name for p in kit.parts]
    long_page = flat(texts[2 + names.index("5-7")])
    assert f"{f1(65.7 * 6.0)} mm" in long_page
    k = float(long_page.split("drawn at 1:")[1].split(" ")[0])
    assert k > 1 and 65.7 * 6.0 / k < 297.0
    assert "true size (1:1)" in flat(texts[2 + names.index("crank")])
