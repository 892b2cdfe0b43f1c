"""A build kit of one design: everything a maker takes to a laser cutter and a workbench (issue 27).

:func:`build_kit` turns a :class:`~explorer.mechanism.Mechanism` (with its walker: legs, crank phases,
mirrored legs) into a :class:`Kit`: every part once per copy needed, the stack layer of each part on its
pins (so links cross where they should), the pins with diameters and lengths, the legs' crank phases,
and the copies nested on sheets. :func:`write_kit` writes the kit folder: ``parts.svg``, ``parts.dxf``,
``bom.csv``, ``README.txt`` and, where :mod:`explorer.view._kit_pdf` exists, ``assembly.pdf``.

Units: every length of the kit is in mm (``scale`` mm per model unit), every angle in degrees, forces
in N, stresses in MPa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from ..errors import UserError
from ..mechanism import Mechanism, Walker
from ._export import CRANK_CENTRE


@dataclass(frozen=True)
class Material:
    """What the parts and pins are made of (stated in bom.csv and README.txt).

    name : the sheet material of the parts; thickness : its thickness, mm (one stack layer).
    pin_material : what the pins are; pin_shear : its allowable shear stress, MPa (default 140 MPa:
    the shear strength of S235 structural steel, ≈ 0.6 × 235 MPa); bearing : the embedment (bearing)
    strength of the part material against a pin, MPa (default 60 MPa: birch plywood, 0.11·ρ_k with
    ρ_k ≈ 600 kg/m³ after EN 1995-1-1 8.5.1 for plywood, the small-diameter limit); safety_factor :
    applied to the peak joint force when a pin is sized from it.
    """

    name: str = "birch plywood"
    thickness: float = 3.0
    pin_material: str = "steel (S235)"
    pin_shear: float = 140.0
    bearing: float = 60.0
    safety_factor: float = 3.0


@dataclass(frozen=True)
class KitPart:
    """One part of the kit (cut ``copies`` times).

    name : unique: "frame", "crank", a link's name ("2-6"), a body's name ("leg");
    kind : "frame" | "crank" | "link" | "body"; joints : the joint at each hole, in hole order;
    holes : (H, 2) hole centres in the part's own frame, mm, y up; diameters : (H,) each hole's
    diameter, mm (the pin's); copies : how many to cut in all (plain + mirrored); mirrored : of those,
    how many are mirror images (0 where the part is symmetric: its mirror image is the same part);
    symmetric : whether the part equals its own mirror image (links, the crank, a collinear body).
    """

    name: str
    kind: str
    joints: tuple[str, ...]
    holes: tuple[tuple[float, float], ...]
    diameters: tuple[float, ...]
    copies: int
    mirrored: int
    symmetric: bool


@dataclass(frozen=True)
class KitPin:
    """The pin of one joint. stack : the part names on it, bottom (frame side) to top; diameter, length :
    mm; count : pins of this joint in the whole machine; force : the joint's peak reaction, N (the
    forces study), None where not computed."""

    joint: str
    stack: tuple[str, ...]
    diameter: float
    length: float
    count: int
    force: float | None


@dataclass(frozen=True)
class KitLeg:
    """One leg of the walker on the crankshaft: index (0-based), its crank phase, degrees, and whether it
    is the mirrored leg (built from the mirrored copies)."""

    index: int
    phase_deg: float
    mirrored: bool


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


@dataclass
class Kit:
    """A build kit (see the module docstring). mechanism, walker : the design and its legs; scale : mm
    per model unit; width : part width, mm; material : :class:`Material`; parts, pins, legs : the
    kit's parts, pins and legs; layers : part name → stack layer (0 = the frame side); sheet_size :
    (width, height) of one sheet, mm; placements : where each copy is cut; source : where the design
    came from; commands : the commands that made the kit; tolerance_note : the tolerance the design
    needs, if known."""

    mechanism: Mechanism
    walker: Walker
    scale: float
    width: float
    material: Material
    parts: tuple[KitPart, ...]
    pins: tuple[KitPin, ...]
    legs: tuple[KitLeg, ...]
    layers: dict[str, int]
    sheet_size: tuple[float, float]
    placements: tuple[Placement, ...]
    source: str = ""
    commands: tuple[str, ...] = ()
    tolerance_note: str | None = None

    def part(self, name: str) -> KitPart:
        """The part called ``name``."""
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(name)

    def outline(self, part) -> list[tuple]:
        """The outline of ``part`` (a KitPart or its name) in its own frame: the hull of its holes grown by
        width / 2, a closed chain of ("arc", centre, radius, start, end) (counter-clockwise, radians,
        end > start) and ("line", p, q), mm, y up (as :meth:`explorer.view.Sheet.outline`)."""
        from ._export import _hull, _outline
        if isinstance(part, str):
            part = self.part(part)
        return _outline(_hull(part.holes), 0.5 * self.width)

    @property
    def sheets(self) -> int:
        """Number of sheets the copies are nested on."""
        return 1 + max((p.sheet for p in self.placements), default=0)


    def placed_holes(self, pl: Placement) -> list[tuple[float, float]]:
        """The hole centres of a placed copy, sheet mm (y up, the sheet's lower left at (0, 0))."""
        from ._kit_sheet import place
        return place(self.part(pl.part).holes, pl)

    def pin(self, joint: str) -> KitPin:
        """The pin of ``joint`` (the crank centre's is the crankshaft)."""
        for p in self.pins:
            if p.joint == joint:
                return p
        raise KeyError(joint)


# -- sizes ---------------------------------------------------------------------------------------------------
#: Standard metric pin (bolt) sizes: (name, diameter mm).
STANDARD_PINS = (("M2", 2.0), ("M2.5", 2.5), ("M3", 3.0), ("M4", 4.0), ("M5", 5.0), ("M6", 6.0), ("M8", 8.0),
                 ("M10", 10.0), ("M12", 12.0), ("M16", 16.0), ("M20", 20.0))
#: Least wall of material around a hole, each side, and between two holes of one part, mm.
WALL = 1.5
#: Default pin diameter as a fraction of the crank radius in mm (an M3 pin on a 30 mm crank), rounded to
#: the nearest standard size.
DEFAULT_PIN = 0.1
#: Default part width as a multiple of the largest pin diameter (a wall of one diameter each side).
DEFAULT_WIDTH = 3.0
#: The largest sheet a kit is nested on, mm, each side (the bed of a big laser or CNC router is about 3 m;
#: a larger "sheet" is a typing slip, and would make drawings nobody can print).
SHEET_MAX = 10_000.0
#: A washer between two parts on a pin, mm thick (so they turn freely).
WASHER = 0.5
#: Spare length of a pin past its stack, mm, besides one diameter (a lock nut or a collar and circlip).
SPARE = 2.0
#: Length of the crankshaft past the outermost legs, mm, each end (a bearing, a handle or a motor).
SHAFT_ENDS = 10.0


def pin_diameter(force: float, material: Material = Material()) -> tuple[str, float, float]:
    """(name, diameter mm, required diameter mm) of the pin for a peak joint force ``force`` (N): the
    larger of single shear of the pin, d = √(4 · F · SF / (π · τ_allow)) (τ_allow = material.pin_shear,
    MPa = N/mm²), and bearing of one part on it, d = F · SF / (t · f_h) (t = material.thickness, mm, the
    thinnest part a pin carries the force into; f_h = material.bearing, MPa); SF = the material's
    safety_factor; rounded up to the next of :data:`STANDARD_PINS` (UserError past the largest)."""
    shear = math.sqrt(4.0 * float(force) * material.safety_factor / (math.pi * material.pin_shear))
    bearing = float(force) * material.safety_factor / (material.thickness * material.bearing)
    need = max(shear, bearing)
    for name, d in STANDARD_PINS:
        if d >= need - 1e-12:
            return name, d, need
    raise UserError(f"force: a {force:g} N joint needs a {need:.1f} mm pin, larger than "
                    f"{STANDARD_PINS[-1][0]}; cut the parts from thicker sheet (--thickness) or use a stronger pin")


def _standard_name(d: float) -> str:
    for name, dd in STANDARD_PINS:
        if abs(dd - d) < 1e-9:
            return name
    return f"{d:g} mm"


def _nearest_standard(d: float) -> float:
    return min((dd for _, dd in STANDARD_PINS), key=lambda dd: (abs(math.log(dd / d)), dd))


def _collinear(points) -> bool:
    from ._export import _hull
    return len(_hull(points)) <= 2


def build_kit(design: Mechanism, *, crank_mm: float = 30.0, scale: float | None = None, width: float | None = None,
              hole: float | None = None, sheet: tuple[float, float] = (600.0, 400.0), material: Material = Material(),
              forces: dict[str, float] | None = None, source: str = "", commands=(),
              tolerance_note: str | None = None) -> Kit:
    """The build kit of ``design`` (a crank-driven Mechanism; its walker gives the legs).

    crank_mm : the crank radius of the build, mm (sets the scale unless ``scale``, mm per model unit, is
    given). width : part width, mm (default :data:`DEFAULT_WIDTH` × the largest pin). hole : every pin's
    diameter, mm (default: the standard size nearest :data:`DEFAULT_PIN` × the crank radius in mm, a pin
    stiff enough to handle at that size; larger where ``forces``, {joint: peak reaction N}, need it, see
    :func:`pin_diameter`).
    sheet : (W, H) of one sheet, mm. Every part is cut once per leg (the frame plate and the crank arm
    too); a part that is not symmetric is cut mirrored for the mirrored legs.

    One-line UserError naming the part for a hole that leaves less than :data:`WALL` mm of wall, two
    holes of one part closer than their radii plus a wall, or a part that does not fit on a sheet; and
    for a design without a crank (the path-driven arm has no crankshaft to build around).
    """
    from ._export import _hull, _positive, _raw_parts
    from ._kit_sheet import MARGIN, STRIP, nest
    from ._kit_stack import stack_layers

    if design.crank is None:
        raise UserError(f"{design.name}: a build kit needs a crank-driven design (this one is driven along a "
                        f"path); export its parts with --format svg or dxf")
    crank_mm = _positive("crank-mm", crank_mm, "the crank radius in mm, a finite number > 0")
    if scale is None:
        scale = crank_mm / design.crank.radius
    scale = _positive("scale", scale, "mm per model unit, a finite number > 0")
    try:
        W, H = (float(sheet[0]), float(sheet[1]))
    except (TypeError, ValueError, IndexError):
        raise UserError(f"sheet: expected (width, height) in mm, got {sheet!r}") from None
    for what, v, least in (("width", W, 2 * MARGIN), ("height", H, 2 * MARGIN + STRIP)):
        _positive("sheet", v, f"a sheet {what} in mm > 0")
        if not least < v <= SHEET_MAX:
            raise UserError(f"sheet: expected a sheet {what} in mm over {least:g} (its margins) and at most "
                            f"{SHEET_MAX:,.0f}, got {v:g}")
    walker = design.walker if design.walker is not None else Walker(legs=1)
    legs = tuple(KitLeg(j, math.degrees(phi) % 360.0, bool(m))
                 for j, (phi, m) in enumerate(zip(walker.phases, walker.mirrored)))
    n_legs = len(legs)
    mirrored_legs = sum(leg.mirrored for leg in legs)

    # pin diameters, per joint
    forces = {str(k): float(v) for k, v in (forces or {}).items()
              if v is not None and math.isfinite(float(v)) and float(v) >= 0}
    default_d = max(STANDARD_PINS[0][1], _nearest_standard(DEFAULT_PIN * design.crank.radius * scale))
    if hole is not None:
        hole = _positive("hole", hole, "a hole (pin) diameter in mm, a finite number > 0")
    dia: dict[str, float] = {}
    for j in design.vertices:
        if hole is not None:
            dia[j] = hole
        elif j in forces:
            dia[j] = max(default_d, pin_diameter(forces[j], material)[1])  # never below the handling size
        else:
            dia[j] = default_d
    dia[CRANK_CENTRE] = hole if hole is not None else max([default_d] + [dia[j] for j in forces if j in dia])

    def d_of(joint: str) -> float:
        return max(dia.get(x, default_d) for x in joint.split("+"))

    width = (DEFAULT_WIDTH * max(d_of(j) for j in dia) if width is None
             else _positive("width", width, "a part width in mm, a finite number > 0"))

    raw = _raw_parts(design)
    cx, cy = design.crank.center
    parts = []
    stack_in = []
    for name, kind, joints, pts in raw:
        if kind == "frame":
            pts = [(x - cx, y - cy) for x, y in pts]
        holes = tuple((float(x) * scale, float(y) * scale) for x, y in pts)
        diam = tuple(d_of(j) for j in joints)
        for j, d in zip(joints, diam):  # holes and walls
            if d > width - 2 * WALL + 1e-9:
                raise UserError(f"part {name!r}: its {d:g} mm hole at joint {j} leaves less than a {WALL:g} mm wall "
                                f"in a {width:.3g} mm wide part; use a larger --width or a smaller --hole")
        for a in range(len(holes)):
            for b in range(a):
                dist = math.dist(holes[a], holes[b])
                if dist < 0.5 * (diam[a] + diam[b]) + WALL:
                    raise UserError(f"part {name!r}: holes {joints[b]} and {joints[a]} are {dist:.3g} mm apart, too "
                                    f"close for {diam[b]:g} and {diam[a]:g} mm pins and a {WALL:g} mm wall between "
                                    f"them; use a larger --crank-mm (or --scale) or a smaller --hole")
        sym = _collinear(holes)
        parts.append(KitPart(name, kind, tuple(joints), holes, diam, n_legs, 0 if sym else mirrored_legs, sym))
        hull = _hull(holes)
        stack_in.append((name, kind, list(joints), [holes.index(p) for p in hull if p in holes]
                         or list(range(len(holes)))))
    parts = tuple(parts)
    layers = stack_layers(design, stack_in, width / scale)

    # pins: the parts on each joint, bottom to top
    on: dict[str, list[str]] = {}
    for part in parts:
        for j in part.joints:
            for x in j.split("+"):
                on.setdefault(x, []).append(part.name)
    order = [CRANK_CENTRE] + list(design.vertices)
    t = material.thickness
    depth = (max(layers.values()) + 1) * t + max(layers.values()) * WASHER  # one leg's stack, mm
    pins = []
    for j in order:
        if j not in on:
            continue
        stack = tuple(sorted(on[j], key=lambda n: layers[n]))
        d = dia[j]
        if j == CRANK_CENTRE:
            length = n_legs * (depth + WASHER) + 2 * SHAFT_ENDS
            pins.append(KitPin(j, stack, d, float(math.ceil(length)), 1, None))
            continue
        lo, hi = layers[stack[0]], layers[stack[-1]]
        span = hi - lo + 1
        length = span * t + (span - 1) * WASHER + d + SPARE
        pins.append(KitPin(j, stack, d, float(math.ceil(length)), n_legs, forces.get(j)))

    mirrored_copies = frozenset(leg.index + 1 for leg in legs if leg.mirrored)
    placements = nest(parts, width, (W, H), mirrored_copies)
    return Kit(design, walker, float(scale), float(width), material, parts, tuple(pins), legs, layers, (W, H),
               placements, source or (design.source or design.name), tuple(commands), tolerance_note)


def design_yield_note(mech: Mechanism, tolerance: float = 0.5, copies: int = 256) -> str:
    """One line on the tolerance ``mech`` needs: its yield (the share of copies cut with a uniform error of
    ±``tolerance`` % on every design parameter that still turn and pass the buildability screen,
    :func:`explorer.study.design_yield`; a few seconds)."""
    from ..study import Robustness, design_yield
    # the design is the mechanism itself: its lengths, and (geometry None) its own crank and coordinates
    y = design_yield(mech, mech.lengths[None, :], robustness=Robustness(float(tolerance), copies=int(copies)))
    p, se = float(y.share[0]), float(y.se[0])
    return (f"yield {100 * p:.1f} % ± {100 * se:.1f} % at ±{tolerance:g} % on every design parameter (lengths "
            f"relatively, pivots and body points by {tolerance:g} % of the design's size; {copies} copies, "
            f"uniform errors): the share of copies cut that still turn a full crank turn and pass the "
            f"buildability screen")


# -- the kit folder ------------------------------------------------------------------------------------------
#: The files of a kit folder, in the order written (assembly.pdf only where explorer.view._kit_pdf exists).
KIT_FILES = ("parts.svg", "parts.dxf", "bom.csv", "README.txt", "assembly.pdf")


def _pdf_writer():
    try:
        from ._kit_pdf import write_assembly_pdf
    except ImportError:
        return None
    return write_assembly_pdf


def bom_rows(kit: Kit) -> list[dict]:
    """The bill of materials, one dict per line: item ("part", "pin", "crankshaft", "spacer", "washer",
    "retainer"), name, count, material, thickness_mm, diameter_mm, length_mm, force_N, required_d_mm
    (single shear, as :func:`pin_diameter`), note."""
    m = kit.material
    rows = []

    def row(item, name, count, material="", thickness="", diameter="", length="", force="", need="", note=""):
        rows.append({"item": item, "name": name, "count": count, "material": material, "thickness_mm": thickness,
                     "diameter_mm": diameter, "length_mm": length, "force_N": force, "required_d_mm": need,
                     "note": note})

    for p in kit.parts:
        how = (f"{p.copies - p.mirrored} plain + {p.mirrored} mirrored (marked M)" if p.mirrored
               else "symmetric: the same part for every leg" if p.symmetric else f"{p.copies} plain")
        row("part", p.name, p.copies, m.name, f"{m.thickness:g}", "", "", "", "",
            f"{p.kind}; layer {kit.layers[p.name]}; holes {', '.join(p.joints)}; {how}")
    t = m.thickness
    for pin in kit.pins:
        force = "" if pin.force is None else f"{pin.force:.4g}"
        need = "" if pin.force is None else f"{pin_diameter(pin.force, m)[2]:.3g}"
        size = _standard_name(pin.diameter)
        stack = ", ".join(f"{n} (layer {kit.layers[n]})" for n in pin.stack)
        shaft = pin.joint == CRANK_CENTRE
        if shaft:
            row("crankshaft", pin.joint, 1, m.pin_material, "", f"{pin.diameter:g}", f"{pin.length:g}", "", "",
                f"{size} rod through every leg's frame plate and crank arm (bottom to top: {stack}); each crank arm "
                f"fixed to it at its leg's phase; {SHAFT_ENDS:g} mm spare each end")
        else:
            row("pin", pin.joint, pin.count, m.pin_material, "", f"{pin.diameter:g}", f"{pin.length:g}", force, need,
                f"{size}, one per leg; stack bottom to top: {stack}")
        layers = [kit.layers[n] for n in pin.stack]
        skipped = [k for k in range(min(layers), max(layers) + 1) if k not in layers]
        n_pins = kit.walker.legs if shaft else pin.count
        if skipped:
            row("spacer", pin.joint, len(skipped) * n_pins, "nylon or brass tube",
                f"{t:g}", f"{pin.diameter:g}", f"{t:g}", "", "",
                f"inner diameter {pin.diameter:g} mm, outer about {2 * pin.diameter:g} mm; on pin {pin.joint} at "
                f"layer{'s' if len(skipped) > 1 else ''} {', '.join(map(str, skipped))} (no part there)")
        gaps = max(layers) - min(layers)
        if gaps:
            row("washer", pin.joint, gaps * n_pins, "steel or nylon", f"{WASHER:g}", f"{pin.diameter:g}", "", "", "",
                f"between every two layers on pin {pin.joint}")
        if not shaft:
            row("retainer", pin.joint, pin.count, m.pin_material, "", f"{pin.diameter:g}", "", "", "",
                f"lock nut ({size}) or collar and circlip, one per pin")
    return rows


def bom_text(kit: Kit) -> str:
    """``bom.csv``: comment lines (#) stating the material, the pin sizing rule, the allowable shear stress
    and the safety factor, then a CSV table of :func:`bom_rows` (``pandas.read_csv(path, comment="#")``)."""
    import csv
    import io

    m = kit.material
    forces = any(p.force is not None for p in kit.pins)
    head = [
        f"# bill of materials of the {kit.mechanism.name} kit: {kit.walker.legs} legs, 1 model unit = {kit.scale:.6g} mm",
        f"# parts: {m.thickness:g} mm {m.name}, {kit.width:.3g} mm wide; pins: {m.pin_material}",
        f"# pin sizing: the larger of single shear, d = sqrt(4 F SF / (pi tau)), tau = allowable shear stress of "
        f"the pin {m.pin_shear:g} MPa, and bearing in one part, d = F SF / (t f_h), t = {m.thickness:g} mm, f_h = "
        f"bearing strength of the {m.name} {m.bearing:g} MPa; SF = safety factor {m.safety_factor:g}; rounded up "
        f"to the next of {', '.join(n for n, _ in STANDARD_PINS)}",
        ("# F = the joint's peak reaction from the study's forces (force_N); required_d_mm = the d it needs; a pin is "
         "never smaller than the default size, the standard size nearest a tenth of the crank radius (stiffness)"
         if forces else "# no joint forces were computed for this design: every pin is the default size "
                        "(the standard size nearest a tenth of the crank radius), not sized from a load"),
        f"# pin length = stack of layers x {m.thickness:g} mm + a {WASHER:g} mm washer between layers + one "
        f"diameter + {SPARE:g} mm (lock nut), rounded up to a whole mm",
    ]
    buf = io.StringIO()
    rows = bom_rows(kit)
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return "\n".join(head) + "\n" + buf.getvalue()


def readme_text(kit: Kit, pdf: bool) -> str:
    """``README.txt`` of the kit folder (see :func:`write_kit`)."""
    m = kit.material
    mech = kit.mechanism
    legs = kit.legs
    mir = [leg for leg in legs if leg.mirrored]
    crank = next(p for p in kit.parts if p.kind == "crank")
    lines = [
        f"Build kit: {mech.name}" + (f" ({mech.description})" if mech.description else ""),
        f"Design: {kit.source}",
        "",
        f"Scale: 1 model unit = {kit.scale:.6g} mm (the crank is {math.dist(*crank.holes):.4g} mm from the shaft "
        f"to its pin).",
        f"Material: parts cut from {m.thickness:g} mm {m.name}, {kit.width:.3g} mm wide; pins {m.pin_material}.",
        f"Sheets: {kit.sheets} of {kit.sheet_size[0]:g} x {kit.sheet_size[1]:g} mm.",
        "",
        "Files",
        "  parts.svg   every part to cut, once per copy, nested on the sheets (side by side, 1 unit = 1 mm).",
        "              Layer 'cut' (red hairlines): outlines and pin holes. Layer 'engrave' (blue): each hole's",
        "              joint name, each part's name and copy number (M = a mirrored copy), a 50 mm scale bar",
        "              and the sheet's title. Grey rectangles are the sheets' edges (not cut).",
        "  parts.dxf   the same in DXF (mm): layers CUT, ENGRAVE and SHEET; holes are CIRCLEs at their exact",
        "              centres; each copy's entities form a group named after it.",
        "  bom.csv     bill of materials: parts with copies and material, pins per joint with diameter and",
        "              length, spacers, washers, retainers and the crankshaft.",
        ("  assembly.pdf  assembly drawings: the leg at crank angle 0 with every joint, the stack order on each\n"
         "              pin, each leg's crank phase, the frame's pivots dimensioned, one page per part."
         if pdf else "  (assembly.pdf is not part of this kit: this explorer has no assembly drawing writer)"),
        "  README.txt  this file.",
        "",
        "Before cutting: check the scale bar measures 50 mm on the cut sheet. The holes are drawn at the pins'",
        "diameters: add your cutter's kerf allowance for a snug fit.",
        "",
        "Copies: every part is cut once per leg (copy k belongs to leg k); one frame plate and one crank arm",
        "per leg too. A part that is not its own mirror image (a frame or body with holes not in a line) is",
        "cut mirrored (marked M) for the mirrored legs; links, cranks and straight bodies are the same part",
        "for every leg (turned over as needed).",
        "",
        "Legs on the crankshaft (crank phase: the direction of each leg's crank arm, degrees counter-clockwise",
        "from +x in the drawing of the design, when the crank of leg 1 points along +x):",
    ]
    for leg in legs:
        lines.append(f"  leg {leg.index + 1}: crank at {leg.phase_deg:6.1f} deg" +
                     ("  mirrored (its parts marked M where not symmetric)" if leg.mirrored else ""))
    if mir:
        lines.append("A mirrored leg is the mirror image of the drawing about the vertical through the shaft; its "
                     "crank arm sits at the same phase.")
    lines += ["", "Stack order (layer 0 = the frame plate; parts of one layer never touch over the crank turn):"]
    for n, k in sorted(kit.layers.items(), key=lambda t: (t[1], t[0])):
        lines.append(f"  layer {k}: {n}")
    lines += ["Pins, bottom to top (see bom.csv for diameters and lengths):"]
    for pin in kit.pins:
        lines.append(f"  {pin.joint}: {' / '.join(pin.stack)}")
    forces = any(p.force is not None for p in kit.pins)
    lines += ["",
              f"Pins: the larger of single shear, d = sqrt(4 F SF / (pi tau)) with the allowable shear stress of the "
              f"pin tau = {m.pin_shear:g} MPa ({m.pin_material}), and bearing in one {m.thickness:g} mm part, d = F SF "
              f"/ (t f_h) with the {m.name}'s bearing strength f_h = {m.bearing:g} MPa; safety factor SF = "
              f"{m.safety_factor:g}; rounded up to a standard size. " + ("F is each joint's peak reaction from the study's forces; no pin is smaller than the "
                                         "default size, the standard size nearest a tenth of the crank radius "
                                         "(stiffness and handling)." if forces else
                                         "No joint forces were computed for this design: every pin is the "
                                         "default, the standard size nearest a tenth of the crank radius."),
              "",
              "Tolerance: " + (kit.tolerance_note or "not computed; `explorer tolerance MECHANISM` finds the spread "
                               "the design takes."),
              "",
              "Made by:"]
    lines += [f"  {c}" for c in kit.commands] or ["  explorer.view.write_kit (from Python)"]
    return "\n".join(lines) + "\n"


def write_kit(kit: Kit, folder, force: bool = False) -> list[Path]:
    """Write the kit folder ``folder``: parts.svg, parts.dxf, bom.csv, README.txt, and assembly.pdf where
    :mod:`explorer.view._kit_pdf` exists. The folder (and its parents) is created if missing; a file of
    the kit already there is kept (UserError naming it) unless ``force``. Everything is written to a
    temporary folder first and moved into place at the end: a failure leaves nothing half-written.
    Returns the paths written."""
    import os
    import shutil
    import tempfile

    from ._kit_sheet import dxf_document, svg_text

    folder = Path(os.fspath(folder))
    if folder.exists() and not folder.is_dir():
        raise UserError(f"{folder}: cannot write the kit: it is a file, not a folder")
    pdf = _pdf_writer()
    names = [n for n in KIT_FILES if n != "assembly.pdf" or pdf is not None]
    if folder.is_dir() and not force:
        for n in names:
            if (folder / n).exists():
                raise UserError(f"{folder / n}: file exists; pass --force to overwrite it")
    texts = {"parts.svg": svg_text(kit), "bom.csv": bom_text(kit), "README.txt": readme_text(kit, pdf is not None)}
    doc = dxf_document(kit)
    parent = folder.parent if str(folder.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.", suffix=".tmp", dir=parent))
    except OSError as exc:
        raise UserError(f"{folder}: cannot write: {exc.strerror or exc}") from None
    try:
        for n, text in texts.items():
            (tmp / n).write_text(text, encoding="utf-8")
        doc.saveas(tmp / "parts.dxf")
        if pdf is not None:
            pdf(kit, tmp / "assembly.pdf")
        for n in names:
            os.chmod(tmp / n, 0o644)
        if not folder.exists():
            os.replace(tmp, folder)
        else:
            for n in names:
                os.replace(tmp / n, folder / n)
    except OSError as exc:
        raise UserError(f"{folder}: cannot write: {exc.strerror or exc}") from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return [folder / n for n in names]
