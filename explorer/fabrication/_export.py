"""Exports of one design: a cutting sheet (SVG, DXF), its trajectories (CSV) and its mechanism file (TOML).

* :func:`variant_design` — the :class:`~explorer.mechanism.Mechanism` of one variant of a results file,
  ready to be written back: its design parameters, a guess at its own solved positions at θ = 0 (t = 0)
  so it assembles on the branch the study solved, and the walker scene the study's metrics describe.
* :func:`mechanism_toml` — a mechanism as the text of a mechanism file that
  :func:`explorer.load_mechanism` reads back to the same design (floats written repr-exact).
* :func:`cut_sheet` — the parts of a design laid out for cutting: the frame (the crank centre and the
  ground pivots), the crank, each link and each rigid body, each part by itself (never assembled),
  as an outline with a pin hole at each joint, in rows without overlap, labelled with its name.
* :func:`export_svg`, :func:`export_dxf` — that sheet as SVG (built with :mod:`xml.etree`) or DXF
  (built with ezdxf), in millimetres: 1 model unit = ``scale`` mm (default 1).
* :func:`export_csv` — a variant's stored trajectories, one row per sample.
* :func:`export_toml` — :func:`mechanism_toml` written to a file.

Every writer refuses to replace an existing file unless ``force=True`` (the CLI's ``--force``), writes
to a temporary file beside the target and renames it into place (a failed export leaves nothing
half-written), and raises one-line :class:`~explorer.errors.UserError` on a path it cannot write.

Part geometry. A link of length L is a stadium (a slot with rounded ends) of width ``width`` around its
centre line, holes at its two ends, L × scale apart; the crank is such a link from its centre to its
tip. A body is the convex hull of its joints (in the body's own frame) grown by width / 2, which rounds
every corner, with a hole at each joint: a collinear body is a stadium through its end joints. The frame
is the same shape over the crank centre and the ``[fixed]`` pivots at their design positions (left out
when there are fewer than two distinct ground points, as for the arm). Parts are only translated
on the sheet, never turned or mirrored, so the holes of a body sit at its body-frame points × scale.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism, Walker

#: Default part width, as a fraction of the shortest distance between two holes of one part (the crank
#: radius, the shortest link, the closest two joints of a body or of the frame).
DEFAULT_WIDTH = 0.2
#: Default hole diameter, as a fraction of the part width.
DEFAULT_HOLE = 0.4
#: Label text height, as a fraction of the part width.
TEXT_HEIGHT = 0.8
#: Colours: cut lines red, labels blue (the usual laser-cutter convention: red cuts, blue engraves or
#: is left off); DXF layers CUT (red, ACI 1) and LABELS (blue, ACI 5).
CUT_COLOR, LABEL_COLOR = "#ff0000", "#0000ff"
#: Stroke width of the SVG cut lines, mm (a hairline, as laser software expects).
STROKE_MM = 0.1
#: The frame part's hole at the crank centre (no vertex sits there).
CRANK_CENTRE = "crank centre"


# -- the design of one variant ---------------------------------------------------------------------------
def _results(obj):
    """(results, close?) for a Results object or a results file path."""
    from ..store import is_results
    if is_results(obj):
        return obj, False
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    return open_results(obj), True


def variant_design(results, variant) -> Mechanism:
    """The mechanism of one variant of a results file (an open :class:`~explorer.store.Results` or a
    path), as :func:`export_toml` writes it.

    Design parameters: the variant's row (``variant_mechanism``). Guess: the variant's solved positions
    at the first sample (θ = 0, or t = 0 for a path driver) where the results store that vertex (and it
    is finite there), else the variant assembled at θ = 0 from the nominal's configuration (the branch
    the study kept), else the nominal's configuration: the guess only picks the branch. Walker: the
    study's ``[walker]`` over the mechanism's (the scene the stored metrics describe; the mechanism's
    own table, exactly, when the study did not change it). Name: the nominal's, with ``-vN`` for a
    variant other than 0; the description says where it came from.
    A variant that has no valid design (a non-positive or non-finite length) raises UserError; a
    failed variant (it does not turn through a full cycle) still has one and is returned.
    """
    from ..kernels import assemble
    from ..store import check_variant, variant_mechanism

    res, close = _results(results)
    try:
        v = check_variant(res, variant)
        nominal = res.mechanism
        mech = variant_mechanism(res, v)
        guess = dict(mech.guess)
        P, fail = assemble(mech)
        if fail is None:
            guess = {name: (float(P[mech.vertex_index(name)][0]), float(P[mech.vertex_index(name)][1]))
                     for name in guess}
        for name in guess:
            if name in res.vertices:
                p = np.asarray(res.path(v, name)[0], dtype=np.float64)
                if np.all(np.isfinite(p)):
                    guess[name] = (float(p[0]), float(p[1]))
        walker = _study_walker(res, nominal)
        study = (res.study.get("study") or {}).get("name", "?")
        what = f"variant {v} of {Path(res.filename).name} (study {study!r})"
        desc = f"{what}: {nominal.description}" if nominal.description else what
        name = nominal.name if v == 0 else f"{nominal.name}-v{v}"
        return replace(mech, name=name, description=desc, guess=guess, walker=walker,
                       source=f"{res.filename} (variant {v})")
    finally:
        if close:
            res.close()


def _study_walker(res, mech: Mechanism) -> Walker | None:
    """The walker scene of the results' study (its [walker] over the mechanism's); the mechanism's own
    Walker object when they agree (the stored study rounds phases to 12 decimals of a degree)."""
    if mech.crank is None:
        return None
    from ..mechanism import walker_from_dict
    spec = (res.study or {}).get("walker") or {}
    try:
        w = walker_from_dict(spec, f"{res.filename} (study)", "walker", base=mech.walker)
    except UserError:
        return mech.walker
    base = mech.walker if mech.walker is not None else Walker()
    same = (w.legs == base.legs and w.mirrored == base.mirrored and w.drag == base.drag
            and w.contact == base.contact and all(abs(a - b) <= 1e-9 for a, b in zip(w.phases, base.phases)))
    return mech.walker if same else w


# -- TOML ------------------------------------------------------------------------------------------------
# the mechanism-file writer lives beside the loader (explorer/mechanism/_toml.py)
from ..mechanism import mechanism_toml  # noqa: E402,F401


# -- writing files ---------------------------------------------------------------------------------------
def check_export_path(path, force: bool = False, protect=()) -> Path:
    """``path`` as a Path if a file can be written there, by the one output policy
    (:func:`explorer._files.output_path`): not a folder, not one of ``protect`` (such as the results file
    read) even with ``force``, an existing file only with ``force``; missing folders are created.
    UserError otherwise."""
    from .._files import output_path
    return output_path(path, force, protect=protect)


def _write(path: Path, write) -> Path:
    """Call ``write(tmp_path)`` on a temporary file beside ``path``, then rename it onto ``path`` (a link
    there is replaced, never written through): :func:`explorer._files.write_replacing`."""
    from .._files import write_replacing
    return write_replacing(path, write)


def export_toml(mech: Mechanism, path, *, force: bool = False, header: str = "") -> Path:
    """Write :func:`mechanism_toml` of ``mech`` to ``path`` (UserError if it exists, unless ``force``)."""
    p = check_export_path(path, force)
    text = mechanism_toml(mech, header)
    return _write(p, lambda tmp: tmp.write_text(text, encoding="utf-8"))


# -- CSV -------------------------------------------------------------------------------------------------
def trajectory_frame(results, variant):
    """The variant's stored trajectories as a DataFrame, one row per sample: ``theta`` (crank angle,
    rad; ``t``, seconds, for a path driver), then for each stored vertex (the foot first, then the
    mechanism's order) ``V.x``, ``V.y`` (model units), ``V.vx``, ``V.vy`` if velocities are stored and
    ``V.ax``, ``V.ay`` if accelerations are (per radian / radian² of crank; per second / s² for a path
    driver). UserError for a variant that failed or was not run: it has no full path."""
    import pandas as pd

    from ..store import check_variant, variant_row
    res, close = _results(results)
    try:
        v = check_variant(res, variant)
        row = variant_row(res, v)
        status = str(row["status"])
        if status != "ok":
            if status == "not-run":
                why = "was not run (the study was interrupted; finish it with explorer run --resume)"
            else:
                th = float(row["fail_theta"])
                at = "" if not math.isfinite(th) else (f" at t = {th:.6g} s" if res.mechanism.crank is None
                                                       else f" at θ = {math.degrees(th):.2f}°")
                why = f"failed ({status}{at})"
            raise UserError(f"{res.filename}: variant {v} {why}: it has no full path to export as CSV "
                            f"(its design still exports as toml, svg or dxf)")
        if not res.vertices:
            raise UserError(f"{res.filename}: no paths stored (the study's [scene] vertices is empty)")
        mech = res.mechanism
        order = sorted(res.vertices, key=lambda n: (n != mech.foot, mech.vertices.index(n)
                                                    if n in mech.vertices else len(mech.vertices)))
        if mech.crank is not None:
            cols = {"theta": np.asarray(res.theta, dtype=np.float64)}
        else:  # the samples' times, t_k = T k / (S − 1), as the solver took them (the file's /theta holds
            S = int(res.steps)  # crank angles 2πk/S whatever the driver)
            cols = {"t": mech.path.duration * np.arange(S, dtype=np.float64) / (S - 1)}
        groups = [("paths", ("x", "y"), res.path)]
        stored = res.series_groups
        if "velocities" in stored:
            groups.append(("velocities", ("vx", "vy"), res.velocity))
        if "accelerations" in stored:
            groups.append(("accelerations", ("ax", "ay"), res.acceleration))
        for name in order:  # every stored vertex has every stored group (a lean file: re-solved)
            for group, (cx, cy), read in groups:
                a = np.asarray(read(v, name), dtype=np.float64)
                cols[f"{name}.{cx}"], cols[f"{name}.{cy}"] = a[:, 0], a[:, 1]
        return pd.DataFrame(cols)
    finally:
        if close:
            res.close()


def export_csv(results, variant, path, *, force: bool = False) -> Path:
    """Write :func:`trajectory_frame` of one variant to ``path`` as CSV (a header row, no index, floats
    repr-exact; ``pandas.read_csv(path)`` reads it back). UserError for a failed variant, an existing
    ``path`` without ``force``, or a path that cannot be written."""
    p = check_export_path(path, force)
    df = trajectory_frame(results, variant)
    return _write(p, lambda tmp: df.to_csv(tmp, index=False))


# -- the cutting sheet -----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Part:
    """One part on the sheet. name : its label; kind : "frame", "crank", "link" or "body"; joints :
    the joint at each hole; holes : (x, y) of each hole centre on the sheet, mm, y up; hull : the
    convex hull of the holes, counter-clockwise (two points for a straight part); label_at : where
    the label's baseline starts, mm."""

    name: str
    kind: str
    joints: tuple[str, ...]
    holes: tuple[tuple[float, float], ...]
    hull: tuple[tuple[float, float], ...]
    label_at: tuple[float, float]


@dataclass(frozen=True)
class Sheet:
    """A cutting sheet: ``parts`` laid out in rows; ``size`` (width, height), mm; ``scale`` mm per model
    unit; ``width`` the part width and ``hole`` the hole diameter, mm; ``text_height`` of the labels, mm;
    ``pitch`` the shortest distance between two holes of one part, mm."""

    parts: tuple[Part, ...]
    size: tuple[float, float]
    scale: float
    width: float
    hole: float
    text_height: float
    pitch: float
    name: str = ""

    def outline(self, part: Part) -> list[tuple]:
        """The part's outline: its hull grown by width / 2, as a closed chain of ("arc", centre, radius,
        start, end) (counter-clockwise, radians, end > start) and ("line", p, q), mm, y up."""
        return _outline(part.hull, 0.5 * self.width)


def _hull(points) -> list[tuple[float, float]]:
    """Convex hull (Andrew's monotone chain), counter-clockwise, collinear points dropped; two points
    for a collinear set."""
    pts = sorted(set((float(x), float(y)) for x, y in points))
    if len(pts) <= 2:
        return pts
    span = max(math.dist(pts[0], p) for p in pts)
    eps = 1e-12 * span * span

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower, upper = [], []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= eps:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= eps:
            upper.pop()
        upper.append(p)
    hull = lower[:-1] + upper[:-1]
    return hull if len(hull) >= 2 else [pts[0], pts[-1]]


def _outline(hull, r: float) -> list[tuple]:
    m = len(hull)
    normals = []
    for i in range(m):
        (x0, y0), (x1, y1) = hull[i], hull[(i + 1) % m]
        d = math.hypot(x1 - x0, y1 - y0)
        normals.append(((y1 - y0) / d, -(x1 - x0) / d))  # outward: right of a counter-clockwise edge
    out = []
    for i in range(m):
        p, n_in, n_out = hull[i], normals[i - 1], normals[i]
        a0 = math.atan2(n_in[1], n_in[0])
        a1 = a0 + (math.atan2(n_out[1], n_out[0]) - a0) % (2.0 * math.pi)
        if m == 2:
            a1 = a0 + math.pi  # a straight part's ends: half turns, whatever the rounding
        out.append(("arc", p, r, a0, a1))
        q = hull[(i + 1) % m]
        out.append(("line", (p[0] + r * n_out[0], p[1] + r * n_out[1]), (q[0] + r * n_out[0], q[1] + r * n_out[1])))
    return out


def _raw_parts(mech: Mechanism) -> list[tuple[str, str, list[str], list[tuple[float, float]]]]:
    """(name, kind, joints, points in model units) of every part: frame, crank, links, bodies."""
    parts = []
    ground = []
    if mech.crank is not None:
        ground.append((CRANK_CENTRE, mech.crank.center))
    ground += [(v, mech.fixed[v]) for v in mech.vertices if v in mech.fixed]
    merged: list[tuple[str, tuple[float, float]]] = []
    for name, p in ground:  # a pivot on the crank centre (or on another pivot) is one hole
        for i, (n2, q) in enumerate(merged):
            if math.dist(p, q) <= 1e-9 * mech.size:
                merged[i] = (f"{n2}+{name}", q)
                break
        else:
            merged.append((name, (float(p[0]), float(p[1]))))
    taken = set(mech.link_names) | {b.name for b in mech.bodies}
    if len(merged) >= 2:
        label = "frame" if "frame" not in taken else "frame (ground)"
        parts.append((label, "frame", [n for n, _ in merged], [p for _, p in merged]))
    if mech.crank is not None:
        parts.append(("crank", "crank", [CRANK_CENTRE, mech.crank.tip], [(0.0, 0.0), (mech.crank.radius, 0.0)]))
    for link in mech.links:
        parts.append((link.name, "link", [link.a, link.b], [(0.0, 0.0), (link.length, 0.0)]))
    for body in mech.bodies:
        parts.append((body.name, "body", list(body.joints), [tuple(map(float, p)) for p in body.points]))
    return parts


def _positive(name: str, value, what: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UserError(f"{name}: expected {what}, got {value!r}") from None
    if isinstance(value, bool) or not math.isfinite(v) or v <= 0:
        raise UserError(f"{name}: expected {what}, got {value!r}")
    return v


def cut_sheet(mech: Mechanism, scale: float = 1.0, width: float | None = None, hole: float | None = None) -> Sheet:
    """The parts of ``mech`` laid out for cutting (see the module docstring), in mm.

    scale : mm per model unit (default 1). width : part width, mm (default :data:`DEFAULT_WIDTH` × the
    shortest distance between two holes of one part). hole : hole diameter, mm (default
    :data:`DEFAULT_HOLE` × width). UserError if the holes would not fit: a hole as wide as its part,
    or two holes of one part that would overlap.
    """
    scale = _positive("scale", scale, "mm per model unit, a finite number > 0")
    raw = _raw_parts(mech)
    pitch, where = math.inf, ""
    for name, _, joints, pts in raw:
        for i in range(len(pts)):
            for j in range(i):
                d = math.dist(pts[i], pts[j]) * scale
                if d < pitch:
                    pitch, where = d, f"{name} ({joints[j]}, {joints[i]})"
    w = DEFAULT_WIDTH * pitch if width is None else _positive("width", width, "a part width in mm, a finite number > 0")
    h = DEFAULT_HOLE * w if hole is None else _positive("hole", hole, "a hole diameter in mm, a finite number > 0")
    if h >= w:
        raise UserError(f"hole: a {h:g} mm hole does not fit in a {w:g} mm wide part (the hole must be narrower)")
    if h >= pitch:
        raise UserError(f"hole: {h:g} mm holes would overlap in part {where}, {pitch:g} mm apart; use a smaller "
                        f"--hole or a larger --scale")
    r = 0.5 * w
    th = TEXT_HEIGHT * w
    gap = max(w, th)
    # each part in its own frame, mm; then cells of (part box + label band), packed in rows
    cells = []
    for name, kind, joints, pts in raw:
        P = [(x * scale, y * scale) for x, y in pts]
        hull = _hull(P)
        xs, ys = [p[0] for p in hull], [p[1] for p in hull]
        box = (min(xs) - r, min(ys) - r, max(xs) + r, max(ys) + r)
        bw, bh = box[2] - box[0], box[3] - box[1]
        cw, ch = max(bw, 0.6 * th * len(name)), bh + 1.5 * th
        cells.append((name, kind, joints, P, hull, box, cw, ch))
    area = sum(c[6] * c[7] for c in cells)
    limit = max(max(c[6] for c in cells), 1.6 * math.sqrt(area))
    rows: list[list] = []
    row_w: list[float] = []
    for c in cells:  # first fit: the first row with room, else a new row below
        for k, row in enumerate(rows):
            if row_w[k] + gap + c[6] <= limit:
                row.append(c)
                row_w[k] += gap + c[6]
                break
        else:
            rows.append([c])
            row_w.append(c[6])
    row_h = [max(c[7] for c in row) for row in rows]
    W = 2 * gap + max(row_w)
    H = 2 * gap + sum(row_h) + gap * (len(rows) - 1)
    parts = []
    top = H - gap
    for row, rh in zip(rows, row_h):
        bottom = top - rh
        x = gap
        for name, kind, joints, P, hull, box, cw, ch in row:
            dx, dy = x - box[0], bottom + 1.5 * th - box[1]
            holes = tuple((px + dx, py + dy) for px, py in P)
            parts.append(Part(name, kind, tuple(joints), holes, tuple((px + dx, py + dy) for px, py in hull),
                              (x, bottom + 0.4 * th)))
            x += cw + gap
        top = bottom - gap
    return Sheet(tuple(parts), (W, H), scale, w, h, th, pitch, mech.name)


def svg_path(segs, H: float, dx: float = 0.0) -> str:
    """The SVG path data of an outline (``Sheet.outline``'s chain of arcs and lines, mm, y up), shifted
    right by ``dx`` mm and flipped into SVG's y-down frame of a sheet ``H`` mm high."""
    d = []
    for k, seg in enumerate(segs):
        if seg[0] == "arc":
            _, c, rr, a0, a1 = seg
            p0 = (c[0] + rr * math.cos(a0), c[1] + rr * math.sin(a0))
            p1 = (c[0] + rr * math.cos(a1), c[1] + rr * math.sin(a1))
            if k == 0:
                d.append(f"M {_f(p0[0] + dx)} {_f(H - p0[1])}")
            # counter-clockwise with y up is sweep-flag 0 once y points down; every arc is <= 180°
            d.append(f"A {_f(rr)} {_f(rr)} 0 0 0 {_f(p1[0] + dx)} {_f(H - p1[1])}")
        else:
            d.append(f"L {_f(seg[2][0] + dx)} {_f(H - seg[2][1])}")
    d.append("Z")
    return " ".join(d)


def _f(x: float) -> str:
    """A coordinate for SVG, to the nanometre."""
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


#: characters XML 1.0 cannot hold, escaped or not (C0 controls but tab, newline and return; surrogates;
#: U+FFFE and U+FFFF)
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")


def xml_safe(root) -> None:
    """Replace, in every text and attribute of the ElementTree ``root``, the characters XML cannot hold by
    U+FFFD, so that the document is well-formed whatever a name holds (the mechanism loader refuses such
    names; a Mechanism built in Python is not checked)."""
    for el in root.iter():
        for attr in ("text", "tail"):
            v = getattr(el, attr)
            if v and _NOT_XML.search(v):
                setattr(el, attr, _NOT_XML.sub("\ufffd", v))
        for k, v in el.attrib.items():
            if _NOT_XML.search(v):
                el.attrib[k] = _NOT_XML.sub("\ufffd", v)


def svg_text(sheet: Sheet) -> str:
    """The sheet as an SVG document: width and height in mm, viewBox in mm (1 user unit = 1 mm, y down,
    so a point (x, y) of the sheet is drawn at (x, H − y)); one ``<g class="part" data-part=NAME>`` per
    part holding its outline (``<path class="outline">``: lines and arcs), its holes (``<circle
    class="hole" data-joint=J>``) and its label (``<text class="label">``)."""
    import xml.etree.ElementTree as ET

    W, H = sheet.size
    ns = "http://www.w3.org/2000/svg"
    root = ET.Element("svg", {"xmlns": ns, "version": "1.1", "width": f"{_f(W)}mm", "height": f"{_f(H)}mm",
                              "viewBox": f"0 0 {_f(W)} {_f(H)}"})
    ET.SubElement(root, "title").text = f"{sheet.name}: parts for cutting"
    ET.SubElement(root, "desc").text = (
        f"explorer export: 1 model unit = {sheet.scale:g} mm; part width {sheet.width:g} mm, holes "
        f"{sheet.hole:g} mm; red lines are cuts, blue text labels")
    for part in sheet.parts:
        g = ET.SubElement(root, "g", {"class": "part", "data-part": part.name, "data-kind": part.kind})
        ET.SubElement(g, "path", {"class": "outline", "d": svg_path(sheet.outline(part), H), "fill": "none",
                                  "stroke": CUT_COLOR,
                                  "stroke-width": _f(STROKE_MM)})
        for j, (x, y) in zip(part.joints, part.holes):
            ET.SubElement(g, "circle", {"class": "hole", "data-joint": j, "cx": _f(x), "cy": _f(H - y),
                                        "r": _f(0.5 * sheet.hole), "fill": "none", "stroke": CUT_COLOR,
                                        "stroke-width": _f(STROKE_MM)})
        t = ET.SubElement(g, "text", {"class": "label", "x": _f(part.label_at[0]), "y": _f(H - part.label_at[1]),
                                      "font-family": "sans-serif", "font-size": _f(sheet.text_height),
                                      "fill": LABEL_COLOR})
        t.text = part.name
    xml_safe(root)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def export_svg(mech: Mechanism, path, *, scale: float = 1.0, width: float | None = None,
               hole: float | None = None, force: bool = False) -> Path:
    """Write the cutting sheet of ``mech`` (:func:`cut_sheet`) as SVG to ``path``; returns the path."""
    p = check_export_path(path, force)
    text = svg_text(cut_sheet(mech, scale, width, hole))
    return _write(p, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def dxf_document(sheet: Sheet):
    """The sheet as an ezdxf document (DXF R2010, units mm): each part's outline a closed LWPOLYLINE
    (arcs as bulges) and its holes CIRCLEs (in the part's joint order) on layer CUT, its label a TEXT on
    layer LABELS, the three in a DXF group whose description is the part's name."""
    from .._extras import require
    ezdxf = require("ezdxf", "DXF export (explorer export --as dxf)")
    from ezdxf import units

    doc = ezdxf.new("R2010")
    doc.units = units.MM
    doc.header["$MEASUREMENT"] = 1  # metric
    doc.layers.add("CUT", color=1)
    doc.layers.add("LABELS", color=5)
    msp = doc.modelspace()
    for i, part in enumerate(sheet.parts):
        pts = []
        for seg in sheet.outline(part):
            if seg[0] == "arc":
                _, c, rr, a0, a1 = seg
                pts.append((c[0] + rr * math.cos(a0), c[1] + rr * math.sin(a0), math.tan((a1 - a0) / 4.0)))
                pts.append((c[0] + rr * math.cos(a1), c[1] + rr * math.sin(a1), 0.0))
        outline = msp.add_lwpolyline(pts, format="xyb", close=True, dxfattribs={"layer": "CUT"})
        holes = [msp.add_circle((x, y), radius=0.5 * sheet.hole, dxfattribs={"layer": "CUT"}) for x, y in part.holes]
        label = msp.add_text(part.name, height=sheet.text_height, dxfattribs={"layer": "LABELS"})
        label.set_placement(part.label_at)
        group = doc.groups.new(f"PART{i}", description=part.name)
        group.extend([outline, *holes, label])
    return doc


def export_dxf(mech: Mechanism, path, *, scale: float = 1.0, width: float | None = None,
               hole: float | None = None, force: bool = False) -> Path:
    """Write the cutting sheet of ``mech`` (:func:`cut_sheet`) as DXF to ``path``; returns the path."""
    from .._extras import require
    require("ezdxf", "DXF export (explorer export --as dxf)")  # before the path is checked
    p = check_export_path(path, force)
    doc = dxf_document(cut_sheet(mech, scale, width, hole))
    return _write(p, lambda tmp: doc.saveas(tmp))
