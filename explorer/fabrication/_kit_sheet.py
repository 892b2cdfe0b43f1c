"""The cutting sheets of a kit (issue 27): every copy of every part nested on sheets, its holes and outline
cut, its name, copy number and joint names engraved, as SVG and DXF.

Nesting: each copy is turned so its two farthest holes lie along x (a mirrored copy is mirrored first,
x → −x in the part's own frame), turned a further 90° if it is then wider than the sheet, and placed by
shelf packing (tallest first, each into the first row with room, rows from the top down, a new sheet when
one is full), with
:data:`GAP` mm between parts and :data:`MARGIN` mm at the edges; a strip of :data:`STRIP` mm at the
bottom of each sheet holds the scale bar and the sheet's title.

Engraving: each hole's joint name on the part next to the hole, towards the part's farthest hole; the
part's name and copy number ("2-6 #3", "leg #2 M" for a mirrored copy) midway between the two holes
with the most room between them, shrunk to fit. Text is never mirrored. The crank centre's hole is
engraved :data:`SHAFT_LABEL`.
"""

from __future__ import annotations

import math

from dataclasses import dataclass

from ..errors import UserError
from ._export import CRANK_CENTRE, CUT_COLOR, LABEL_COLOR, STROKE_MM, _f, _hull, _outline, svg_path, xml_safe

#: mm between two parts on a sheet (kerf and a margin), and between the parts and the sheet's edges.
GAP, MARGIN = 3.0, 5.0
#: Height of the strip at the bottom of each sheet for the scale bar and the title, mm.
STRIP = 12.0
#: The scale bar's length, mm (10 mm on a sheet too narrow for it).
SCALE_BAR = 50.0
#: What the crank centre's hole is engraved (the crankshaft goes through it).
SHAFT_LABEL = "shaft"
#: Width of a character of the engraved text, as a fraction of its height (sans-serif, on average).
CHAR_W = 0.62
SHEET_COLOR = "#999999"


def joint_label(joint: str) -> str:
    """The engraved name of a hole's joint: the crank centre is :data:`SHAFT_LABEL`, a standoff "S1", a motor's
    mounting hole nothing (its pattern says what it is)."""
    if joint.startswith("standoff "):
        return "S" + joint[len("standoff "):]
    if joint.startswith("motor hole "):
        return ""
    return "+".join(SHAFT_LABEL if j == CRANK_CENTRE else j for j in joint.split("+"))


def _turn(points, mirrored: bool, angle_deg: float, x: float = 0.0, y: float = 0.0):
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    out = []
    for px, py in points:
        if mirrored:
            px = -px
        out.append((x + c * px - s * py, y + s * px + c * py))
    return out


def place(points, pl):
    """Points of a part's own frame (mm) where they lie on its sheet for placement ``pl``."""
    return _turn(points, pl.mirrored, pl.angle_deg, pl.x, pl.y)


def _base_angle(holes, mirrored: bool) -> float:
    """The turn, degrees, that lays the part's two farthest holes along +x."""
    P = _turn(holes, mirrored, 0.0)
    best, pair = -1.0, (0, 1)
    for i in range(len(P)):
        for j in range(i):
            d = math.dist(P[i], P[j])
            if d > best + 1e-9:
                best, pair = d, (j, i)
    (x0, y0), (x1, y1) = P[pair[0]], P[pair[1]]
    return -math.degrees(math.atan2(y1 - y0, x1 - x0))


def _box(holes, mirrored, angle, r):
    P = _turn(holes, mirrored, angle)
    xs, ys = [p[0] for p in P], [p[1] for p in P]
    return min(xs) - r, min(ys) - r, max(xs) + r, max(ys) + r


@dataclass(frozen=True)
class Placement:
    """Where one copy of a part sits: on sheet ``sheet`` (0-based), copy number ``copy`` (1-based) of part
    ``part``, a mirror image if ``mirrored``; the part's own frame is turned by ``angle_deg`` (counter-
    clockwise, after mirroring x → −x) and its origin put at (x, y), mm, y up, sheet's lower left = (0, 0)."""

    sheet: int
    part: str
    copy: int
    mirrored: bool
    x: float
    y: float
    angle_deg: float


def nest(parts, sheet: tuple[float, float], mirrored_legs=frozenset()):
    """Placements of every copy of ``parts`` (KitPart) on sheets of ``sheet`` (W, H) mm (see the module
    docstring); UserError naming a part that does not fit on one sheet. Copy k (1-based) of a part is the
    one of leg ``part.legs[k - 1]``; it is mirrored where that leg is in ``mirrored_legs`` and the part is
    not symmetric."""
    W, H = sheet
    room_w, room_h = W - 2 * MARGIN, H - 2 * MARGIN - STRIP
    items = []
    for part in parts:
        for k in range(part.copies):
            leg = part.legs[k] if k < len(part.legs) else None
            items.append((part, k + 1, bool(part.mirrored) and leg in mirrored_legs))
    laid = []
    for part, copy, mirrored in items:
        r = 0.5 * part.width
        a = _base_angle(part.holes, mirrored)
        box = _box(part.holes, mirrored, a, r)
        w, h = box[2] - box[0], box[3] - box[1]
        if w > room_w + 1e-9 or h > room_h + 1e-9:
            a += 90.0
            box = _box(part.holes, mirrored, a, r)
            w, h = box[2] - box[0], box[3] - box[1]
        if w > room_w + 1e-9 or h > room_h + 1e-9:
            L = max(w, h)
            raise UserError(f"part {part.name!r}: {L:.1f} mm long, does not fit on a {W:g} x {H:g} mm sheet "
                            f"({room_w:g} x {room_h:g} mm usable); use a larger --sheet or a smaller --crank-mm/--scale")
        laid.append((part, copy, mirrored, a, box, w, h))
    laid.sort(key=lambda t: (-round(t[6], 6), t[0].name, t[1]))
    out = []
    shelves = []  # [sheet, top y of the shelf, its height, x where the next part goes]
    for part, copy, mirrored, a, box, w, h in laid:
        for sh in shelves:  # first fit: the first shelf with room (it is as tall as the part, or taller)
            if sh[3] + w <= MARGIN + room_w + 1e-9:
                break
        else:
            last = shelves[-1] if shelves else None
            if last is not None and last[1] - last[2] - GAP - h >= MARGIN + STRIP - 1e-9:
                sh = [last[0], last[1] - last[2] - GAP, h, MARGIN]
            else:  # a new sheet
                sh = [last[0] + 1 if last else 0, H - MARGIN, h, MARGIN]
            shelves.append(sh)
        x, top = sh[3], sh[1]
        out.append(Placement(sh[0], part.name, copy, mirrored, x - box[0], top - h - box[1], a))
        sh[3] += w + GAP
    out.sort(key=lambda p: (p.sheet, [q.name for q in parts].index(p.part), p.copy))
    return tuple(out)


# -- engraving -----------------------------------------------------------------------------------------------
def _upright(dx, dy) -> float:
    """The angle of direction (dx, dy), degrees, turned by 180° if the text would read upside down."""
    a = math.degrees(math.atan2(dy, dx))
    if a > 90.0 + 1e-6:
        a -= 180.0
    elif a <= -90.0 + 1e-6:
        a += 180.0
    return a


def copy_label(pl) -> str:
    """A placed copy's engraved name, also its DXF group's name: "2-6 #3", "leg #2 M" (a mirrored copy)."""
    return f"{pl.part} #{pl.copy}" + (" M" if pl.mirrored else "")


def hole_segments(centre, d: float, normal_deg=None, depth: float = 0.0) -> list[tuple]:
    """A hole's outline on the sheet (mm, y up) as :func:`explorer.fabrication._export.svg_path` takes it: a circle
    (two half arcs), or a D-hole (``normal_deg``: the direction of the flat's outward normal, degrees; the
    flat ``depth`` mm inside the circle): two arcs of at most 180° and the flat's chord."""
    r = 0.5 * d
    if normal_deg is None:
        return [("arc", centre, r, 0.0, math.pi), ("arc", centre, r, math.pi, 2.0 * math.pi)]
    n = math.radians(normal_deg)
    a = math.acos(max(-1.0, min(1.0, (r - depth) / r)))
    a0, a1 = n + a, n + 2.0 * math.pi - a
    mid = n + math.pi
    p1 = (centre[0] + r * math.cos(a1), centre[1] + r * math.sin(a1))
    p0 = (centre[0] + r * math.cos(a0), centre[1] + r * math.sin(a0))
    return [("arc", centre, r, a0, mid), ("arc", centre, r, mid, a1), ("line", p1, p0)]


def placed_flat(part, i: int, pl):
    """The D-flat normal of hole i of a placed copy, degrees in the sheet's frame (None: a round hole)."""
    fl = part.flat(i, pl.copy)
    if fl is None:
        return None
    return ((180.0 - fl) if pl.mirrored else fl) + pl.angle_deg


def copy_labels(kit, pl) -> list[dict]:
    """The engraved texts of one placed copy, sheet mm: dicts of text, x, y (the text's centre), angle
    (degrees, counter-clockwise), size (height, mm), kind ("joint" or "part") and joint (the joint's
    name for a hole's label, else None)."""
    part = kit.part(pl.part)
    P = place(part.holes, pl)
    w = part.width
    text = copy_label(pl)
    hj = min(0.42 * w, 4.0)
    if pl.mirrored:  # a mirrored copy's standoff holes take their mirror partners' rods
        from dataclasses import replace
        part = replace(part, joints=tuple(kit.mirror_joint(j) for j in part.joints))
    while True:  # the joint labels shrink (to 1.5 mm at least) until the part's label is as tall as them
        out = _labels(part, P, hj, text, w)
        if out[-1]["size"] >= 0.9 * hj or hj <= 1.5:
            return out
        hj = max(1.5, 0.9 * hj)


def _labels(part, P, hj, text, w):
    pad = 0.25 * hj
    out = []
    used = []  # how far along from each hole its label reaches, mm
    for i, (p, j, d) in enumerate(zip(P, part.joints, part.diameters)):
        far = max(range(len(P)), key=lambda k: (math.dist(P[k], p), -k))
        L = math.dist(P[far], p)
        ux, uy = (P[far][0] - p[0]) / L, (P[far][1] - p[1]) / L
        label = joint_label(j)
        if not label:
            used.append(0.5 * d + pad)
            continue
        tl = CHAR_W * hj * len(label)
        off = 0.5 * d + pad + 0.5 * tl
        out.append({"text": label, "x": p[0] + ux * off, "y": p[1] + uy * off, "angle": _upright(ux, uy),
                    "size": hj, "kind": "joint", "joint": j})
        used.append(0.5 * d + 2 * pad + tl)
    # the part's label: in the widest free stretch between two holes, clear of every other hole (and its
    # label) near that line
    best = None
    for i in range(len(P)):
        for k in range(i):
            L = math.dist(P[i], P[k])
            ux, uy = (P[i][0] - P[k][0]) / L, (P[i][1] - P[k][1]) / L
            blocks = []
            for h in range(len(P)):
                if h in (i, k):
                    continue
                vx, vy = P[h][0] - P[k][0], P[h][1] - P[k][1]
                along, across = vx * ux + vy * uy, abs(vx * uy - vy * ux)
                if across < 0.25 * w + 0.5 * part.diameters[h] + pad:
                    blocks.append((along - used[h], along + used[h]))
            free = [(used[k], L - used[i])]
            for b0, b1 in blocks:
                free = [piece for a0, a1 in free for piece in ((a0, min(a1, b0)), (max(a0, b1), a1)) if piece[1] > piece[0]]
            for a0, a1 in free:
                if best is None or a1 - a0 > best[0] + 1e-9:
                    best = (a1 - a0, k, i, 0.5 * (a0 + a1), ux, uy)
    if best is None:  # no free stretch: the first pair's midpoint
        L = math.dist(P[1], P[0])
        best = (0.0, 0, 1, 0.5 * L, (P[1][0] - P[0][0]) / L, (P[1][1] - P[0][1]) / L)
    room, k, i, mid, ux, uy = best
    size = max(1.0, min(0.5 * w, room / (CHAR_W * len(text) + 0.5)))
    out.append({"text": text, "x": P[k][0] + ux * mid, "y": P[k][1] + uy * mid, "angle": _upright(ux, uy),
                "size": size, "kind": "part", "joint": None})
    return out



def _sheet_dx(kit, s: int) -> float:
    return s * (kit.sheet_size[0] + 20.0)


def sheet_marks(kit, s: int) -> list[dict]:
    """The scale bar and title of sheet ``s`` in sheet mm: dicts kind "line" (p, q) or "text" (as
    :func:`copy_labels`)."""
    W, H = kit.sheet_size
    bar = SCALE_BAR if W - 2 * MARGIN >= SCALE_BAR + 40 else 10.0
    x0, y0 = MARGIN, MARGIN + 2.0
    marks = [{"kind": "line", "p": (x0, y0), "q": (x0 + bar, y0)}]
    for k in range(int(bar // 10) + 1):
        marks.append({"kind": "line", "p": (x0 + 10 * k, y0), "q": (x0 + 10 * k, y0 + (3.0 if k % 5 == 0 else 1.5))})
    marks.append({"kind": "text", "text": f"{bar:g} mm", "x": x0 + bar + 8.0, "y": y0 + 1.5, "angle": 0.0,
                  "size": 3.0, "joint": None})
    title = (f"{kit.mechanism.name} kit, sheet {s + 1} of {kit.sheets}: {W:g} x {H:g} mm, "
             f"{kit.material.thickness:g} mm {kit.material.name}; 1 model unit = {kit.scale:.4g} mm")
    size = min(3.0, (W - 2 * MARGIN - bar - 20.0) / (CHAR_W * len(title)))
    if size >= 1.0:
        marks.append({"kind": "text", "text": title, "x": x0 + bar + 20.0 + 0.5 * CHAR_W * size * len(title),
                      "y": y0 + 1.5, "angle": 0.0, "size": size, "joint": None})
    return marks


# -- SVG ----------------------------------------------------------------------------------------------------
def placed_outline(kit, pl) -> list[tuple]:
    """The outline of a placed copy, sheet mm (as :meth:`Kit.outline`)."""
    part = kit.part(pl.part)
    return _outline(_hull(place(part.holes, pl)), 0.5 * part.width)


def svg_text(kit) -> str:
    """``parts.svg``: every sheet side by side (20 mm apart), 1 user unit = 1 mm; three groups: ``sheets``
    (the sheets' edges, grey, not cut), ``cut`` (red hairlines: one ``<g class="part">`` per copy with
    data-part, data-copy, data-mirrored, data-sheet, holding its outline and its ``<circle class="hole"
    data-joint>``) and ``engrave`` (blue: per copy its ``<text class="joint" data-joint>`` and ``<text
    class="part">``; per sheet its scale bar and title); ``cut`` and ``engrave`` are Inkscape layers."""
    import xml.etree.ElementTree as ET

    W, H = kit.sheet_size
    n = kit.sheets
    TW = n * W + (n - 1) * 20.0
    ns, ink = "http://www.w3.org/2000/svg", "http://www.inkscape.org/namespaces/inkscape"
    ET.register_namespace("", ns)
    ET.register_namespace("inkscape", ink)
    q = f"{{{ns}}}"
    root = ET.Element(q + "svg", {"version": "1.1", "width": f"{_f(TW)}mm", "height": f"{_f(H)}mm",
                                  "viewBox": f"0 0 {_f(TW)} {_f(H)}"})
    ET.SubElement(root, q + "title").text = f"{kit.mechanism.name}: build kit, parts for cutting"
    ET.SubElement(root, q + "desc").text = (
        f"explorer export --as kit: {n} sheet(s) of {W:g} x {H:g} mm side by side; 1 model unit = "
        f"{kit.scale:.6g} mm; links {kit.width:.3g} mm wide; red = cut, blue = engrave, grey = sheet edge (not cut)")
    g_sheets = ET.SubElement(root, q + "g", {"id": "sheets", f"{{{ink}}}groupmode": "layer",
                                             f"{{{ink}}}label": "sheets (not cut)"})
    for s in range(n):
        ET.SubElement(g_sheets, q + "rect", {"x": _f(_sheet_dx(kit, s)), "y": "0", "width": _f(W), "height": _f(H),
                                             "fill": "none", "stroke": SHEET_COLOR, "stroke-width": "0.3"})
    g_cut = ET.SubElement(root, q + "g", {"id": "cut", f"{{{ink}}}groupmode": "layer", f"{{{ink}}}label": "cut"})
    g_eng = ET.SubElement(root, q + "g", {"id": "engrave", f"{{{ink}}}groupmode": "layer",
                                          f"{{{ink}}}label": "engrave"})
    line = {"fill": "none", "stroke": CUT_COLOR, "stroke-width": _f(STROKE_MM)}

    def text(parent, lab, dx, cls):
        x, y = lab["x"] + dx, H - lab["y"]
        attrs = {"class": cls, "x": "0", "y": _f(0.35 * lab["size"]), "font-family": "sans-serif",
                 "font-size": _f(lab["size"]), "text-anchor": "middle", "fill": LABEL_COLOR,
                 "transform": f"translate({_f(x)} {_f(y)}) rotate({_f(-lab['angle'])})"}
        if lab.get("joint") is not None:
            attrs["data-joint"] = lab["joint"]
        ET.SubElement(parent, q + "text", attrs).text = lab["text"]

    for pl in kit.placements:
        dx = _sheet_dx(kit, pl.sheet)
        part = kit.part(pl.part)
        data = {"data-part": pl.part, "data-copy": str(pl.copy), "data-mirrored": "true" if pl.mirrored else "false",
                "data-sheet": str(pl.sheet + 1)}
        g = ET.SubElement(g_cut, q + "g", {"class": "part", "data-kind": part.kind, **data})
        ET.SubElement(g, q + "path", {"class": "outline", "d": svg_path(placed_outline(kit, pl), H, dx), **line})
        for i, (j, (x, y), d) in enumerate(zip(part.joints, place(part.holes, pl), part.diameters)):
            j = kit.mirror_joint(j) if pl.mirrored else j
            fl = placed_flat(part, i, pl)
            if fl is None:
                ET.SubElement(g, q + "circle", {"class": "hole", "data-joint": j, "cx": _f(x + dx), "cy": _f(H - y),
                                                "r": _f(0.5 * d), **line})
            else:
                ET.SubElement(g, q + "path", {"class": "hole d-hole", "data-joint": j, "data-cx": _f(x + dx),
                                              "data-cy": _f(H - y), "data-d": _f(d),
                                              "d": svg_path(hole_segments((x, y), d, fl, kit.shaft.flat), H, dx),
                                              **line})
        ge = ET.SubElement(g_eng, q + "g", {"class": "labels", **data})
        for lab in copy_labels(kit, pl):
            text(ge, lab, dx, lab["kind"])
    for s in range(n):
        dx = _sheet_dx(kit, s)
        gs = ET.SubElement(g_eng, q + "g", {"class": "scale-bar", "data-sheet": str(s + 1)})
        for m in sheet_marks(kit, s):
            if m["kind"] == "line":
                ET.SubElement(gs, q + "line", {"x1": _f(m["p"][0] + dx), "y1": _f(H - m["p"][1]),
                                               "x2": _f(m["q"][0] + dx), "y2": _f(H - m["q"][1]),
                                               "stroke": LABEL_COLOR, "stroke-width": "0.3"})
            else:
                text(gs, m, dx, "title")
    xml_safe(root)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


# -- DXF ----------------------------------------------------------------------------------------------------
def dxf_document(kit):
    """``parts.dxf`` (ezdxf, R2010, mm), the sheets side by side as in the SVG: outlines (closed
    LWPOLYLINEs, arcs as bulges) and holes (CIRCLEs at the exact hole centres, diameter the pin's) on
    layer CUT (red); labels (TEXT, middle-centred), scale bars and titles on layer ENGRAVE (blue); the
    sheets' edges on layer SHEET (grey, not to be cut). Each copy's outline, holes and labels form a DXF
    group named after the copy (and so described): "2-6 #3", "leg #2 M". A D-hole (a crank arm's, for the
    crankshaft's flat) is a closed LWPOLYLINE: two arcs (bulges) and the flat."""
    from .._extras import require
    ezdxf = require("ezdxf", "the kit's DXF (explorer export --as kit)")
    from ezdxf import units
    from ezdxf.enums import TextEntityAlignment

    doc = ezdxf.new("R2010")
    doc.units = units.MM
    doc.header["$MEASUREMENT"] = 1
    doc.layers.add("CUT", color=1)
    doc.layers.add("ENGRAVE", color=5)
    doc.layers.add("SHEET", color=8)
    msp = doc.modelspace()
    W, H = kit.sheet_size

    def text(lab, dx):
        t = msp.add_text(lab["text"], height=lab["size"], rotation=lab["angle"], dxfattribs={"layer": "ENGRAVE"})
        t.set_placement((lab["x"] + dx, lab["y"]), align=TextEntityAlignment.MIDDLE_CENTER)
        return t

    for s in range(kit.sheets):
        dx = _sheet_dx(kit, s)
        msp.add_lwpolyline([(dx, 0), (dx + W, 0), (dx + W, H), (dx, H)], close=True, dxfattribs={"layer": "SHEET"})
        for m in sheet_marks(kit, s):
            if m["kind"] == "line":
                msp.add_line((m["p"][0] + dx, m["p"][1]), (m["q"][0] + dx, m["q"][1]), dxfattribs={"layer": "ENGRAVE"})
            else:
                text(m, dx)
    for i, pl in enumerate(kit.placements):
        dx = _sheet_dx(kit, pl.sheet)
        part = kit.part(pl.part)
        pts = []
        for seg in placed_outline(kit, pl):
            if seg[0] == "arc":
                _, c, rr, a0, a1 = seg
                pts.append((c[0] + dx + rr * math.cos(a0), c[1] + rr * math.sin(a0), math.tan((a1 - a0) / 4.0)))
                pts.append((c[0] + dx + rr * math.cos(a1), c[1] + rr * math.sin(a1), 0.0))
        ents = [msp.add_lwpolyline(pts, format="xyb", close=True, dxfattribs={"layer": "CUT"})]
        for h, ((x, y), d) in enumerate(zip(place(part.holes, pl), part.diameters)):
            fl = placed_flat(part, h, pl)
            if fl is None:
                ents.append(msp.add_circle((x + dx, y), radius=0.5 * d, dxfattribs={"layer": "CUT"}))
                continue
            pts = []
            for seg in hole_segments((x + dx, y), d, fl, kit.shaft.flat):
                if seg[0] == "arc":
                    _, c, rr, a0, a1 = seg
                    pts.append((c[0] + rr * math.cos(a0), c[1] + rr * math.sin(a0), math.tan((a1 - a0) / 4.0)))
                else:
                    pts.append((seg[1][0], seg[1][1], 0.0))
            ents.append(msp.add_lwpolyline(pts, format="xyb", close=True, dxfattribs={"layer": "CUT"}))
        ents += [text(lab, dx) for lab in copy_labels(kit, pl)]
        label = copy_label(pl)
        doc.groups.new(label, description=label).extend(ents)
    return doc
