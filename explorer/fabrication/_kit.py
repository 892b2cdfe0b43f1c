"""A build kit of one design: everything a maker takes to a laser cutter and a workbench (issues 27, 37).

:func:`build_kit` turns a crank-driven :class:`~explorer.mechanism.Mechanism` (with its walker: legs, crank
phases, mirrored legs) into a :class:`Kit` that turns:

* **the parts**: every part once per leg (the frame plate, the crank arm, each link, each body, or a plate
  for each rigid triangle of links with ``plates=True``), the chassis' motor plate and end plate;
* **the stack** (:mod:`explorer.fabrication._kit_stack`): the layer of every part, chosen so that over the whole
  turn no part comes near a part of its layer, nor a pin, spacer, head, nut or the crankshaft on its
  layer, by more than the running clearance; the crankshaft runs through every layer (*through*), ends at
  an outboard crank arm (one leg), or is a crank with *throws* (an inner and an outer crank web per leg,
  the crank pin between them);
* **the crank**: crank arms (webs) fixed to the shaft by a D-flat, each at its leg's phase (the D-hole is
  turned in the arm by the phase, the shaft's flat is one straight flat); the legs one after the other
  along the shaft from the motor's end;
* **the chassis** (:mod:`explorer.fabrication._kit_chassis`): threaded-rod standoffs through every plate where
  nothing turns, a motor plate with the motor's hole pattern, a shaft coupler, flanged bushings where
  the shaft passes a plate;
* **the sizes**: pins from their joints' peak reactions, the crankshaft from the peak motor torque and the
  bending of the crank pin's reaction, by one safety-factor rule (:func:`pin_diameter`,
  :func:`shaft_diameter`).

:func:`write_kit` writes the kit folder: ``kit.json`` (the kit as data: the contract other tools read),
``parts.svg``, ``parts.dxf``, ``bom.csv`` (made from kit.json), ``README.txt`` and ``assembly.pdf``.

Units: every length of the kit is in mm (``scale`` mm per model unit), every angle in degrees, forces in
N, torques in N·m, stresses in MPa.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism, Walker
from ._export import CRANK_CENTRE
from ._kit_sheet import Placement
from ._kit_stack import WASHER, clearance_line


@dataclass(frozen=True)
class Material:
    """What the parts, pins and crankshaft are made of (stated in bom.csv, README.txt and kit.json).

    name : the sheet material of the parts; thickness : its thickness, mm (one stack layer); density :
    kg/m³ (the link masses of the forces). pin_material, shaft_material : what the pins and the crankshaft
    are; pin_shear, shaft_shear : their allowable shear stresses, MPa (default 140 MPa: S235 structural
    steel, 0.6 × 235 MPa); bearing : the embedment (bearing) strength of the part material against a pin,
    MPa (default 60 MPa: birch plywood, 0.11·ρ_k with ρ_k ≈ 600 kg/m³ after EN 1995-1-1 8.5.1, the
    small-diameter limit); safety_factor : applied to every peak load a pin or the shaft is sized from.
    """

    name: str = "birch plywood"
    thickness: float = 3.0
    pin_material: str = "steel (S235)"
    pin_shear: float = 140.0
    bearing: float = 60.0
    safety_factor: float = 3.0
    shaft_material: str = "steel (S235)"
    shaft_shear: float = 140.0
    density: float = 680.0


def material_of(build, thickness: float | None = None) -> Material:
    """The :class:`Material` of a ``[build]`` (:class:`explorer.mechanism.Build`, or None: the defaults), with
    ``thickness`` (mm) over the build's."""
    from ..mechanism._build import (DEFAULT_MATERIAL, DEFAULT_PIN_MATERIAL, DEFAULT_THICKNESS, rod_material,
                                    sheet_material)
    b = build
    name = (b.material if b is not None and b.material else DEFAULT_MATERIAL)
    sm = sheet_material(name)
    pin = (b.pin_material if b is not None and b.pin_material else DEFAULT_PIN_MATERIAL)
    shaft = (b.shaft_material if b is not None and b.shaft_material else pin)
    t = thickness if thickness is not None else (b.thickness if b is not None and b.thickness else DEFAULT_THICKNESS)
    rho = b.sheet_density() if b is not None and b.sheet_density() is not None else sm.density
    return Material(name=name, thickness=float(t), pin_material=pin, pin_shear=rod_material(pin).shear,
                    bearing=sm.bearing, shaft_material=shaft, shaft_shear=rod_material(shaft).shear,
                    density=float(rho))


@dataclass(frozen=True)
class KitPart:
    """One part of the kit (cut ``copies`` times).

    name : unique: "frame", "crank" (or "crank@90" per crank phase; "crank-outer…" the outer web of a
    throw), a link's name ("2-6"), a body's name ("leg"), a plate's joints ("2-3-4"), "motor plate",
    "end plate"; kind : "frame" | "crank" | "link" | "body" | "plate" | "motor" | "end"; joints : the joint
    at each hole, in hole order; holes : (H, 2) hole centres in the part's own frame, mm, y up; diameters :
    (H,) each hole's diameter, mm; copies : how many to cut in all (plain + mirrored); mirrored : of those,
    how many are mirror images; symmetric : whether the part equals its own mirror image; layer : its stack
    layer (None: a chassis plate); width : mm, the part's width (its holes' hull grown by width / 2);
    flats : per hole, None (round) or the direction of the D-flat's outward normal, degrees counter-
    clockwise in the part's frame (the flat is :func:`flat_depth` deep); legs : the leg (1-based) of each
    copy, in copy order (() for a chassis plate).
    """

    name: str
    kind: str
    joints: tuple[str, ...]
    holes: tuple[tuple[float, float], ...]
    diameters: tuple[float, ...]
    copies: int
    mirrored: int
    symmetric: bool
    layer: int | None = None
    width: float = 0.0
    flats: tuple = ()
    legs: tuple[int, ...] = ()

    def flat(self, i: int, copy: int = 1):
        """The D-flat of hole i of copy ``copy`` (1-based): its normal's direction, degrees, or None."""
        if copy - 1 >= len(self.flats):
            return None
        f = self.flats[copy - 1]
        return f[i] if i < len(f) else None


@dataclass(frozen=True)
class KitPin:
    """The pin of one joint (or the crankshaft, or a standoff). stack : the part names on it, bottom (frame
    side) to top; diameter, length : mm; count : pins of this kind in the whole machine; force : the
    joint's peak reaction, N (None where not computed); layers : the layers it spans, bottom to top;
    spacers : the layers of its span it carries no part on (a spacer there); kind : "pin", "crank pin",
    "shaft", "standoff"; required : the diameter its load needs, mm (None: not sized from a load)."""

    joint: str
    stack: tuple[str, ...]
    diameter: float
    length: float
    count: int
    force: float | None
    layers: tuple[int, ...] = ()
    spacers: tuple[int, ...] = ()
    kind: str = "pin"
    required: float | None = None


@dataclass(frozen=True)
class KitLeg:
    """One leg of the walker on the crankshaft: index (0-based), its crank phase, degrees, whether it is the
    mirrored leg (built from the mirrored copies), its crank arm part, and z, mm: where its frame plate's
    lower face sits along the shaft from the motor plate's."""

    index: int
    phase_deg: float
    mirrored: bool
    crank: str = "crank"
    z: float = 0.0


@dataclass(frozen=True)
class KitShaft:
    """The crankshaft. mode : "through" | "outboard" | "throws"; diameter, length (of rod in all), mm;
    segments : ((z from, z to), …) mm along the machine: one rod, or the pieces between the throws' webs;
    layers : the layers of a leg it runs through; torque : the peak motor torque, N·m (None: no forces);
    bending : the largest bending moment, N·m, from the crank pin's reaction ``arm_force`` (N) at
    ``arm`` mm from the nearest bushing; required : the diameter they need, mm (the flat included);
    bushing_od : the bushings' outer diameter, mm (the plates' shaft holes); flat : the D-flat's depth, mm."""

    mode: str
    diameter: float
    length: float
    segments: tuple
    layers: tuple[int, ...]
    torque: float | None
    bending: float | None
    arm_force: float | None
    arm: float
    required: float | None
    bushing_od: float
    flat: float


@dataclass(frozen=True)
class KitChassis:
    """The chassis: standoffs ((name, x, y), …) mm from the crank centre; standoff_d, standoff_length, mm;
    motor_shaft, mm; motor_holes (count, diameter mm, pitch circle mm); motor_boss : the motor plate's
    centre hole, mm; plates : ((name, z), …) every plate along the shaft (z of its lower face, mm);
    length : the machine's length along the shaft, mm."""

    standoffs: tuple
    standoff_d: float
    standoff_length: float
    motor_shaft: float
    motor_holes: tuple
    motor_boss: float
    plates: tuple
    length: float


@dataclass
class Kit:
    """A build kit (see the module docstring). mechanism, walker : the design and its legs; scale : mm per
    model unit; width : the links' width, mm; material : :class:`Material`; parts, pins, legs : the kit's
    parts, pins and legs; layers : part name → stack layer (0 = the frame plate); sheet_size : (width,
    height) of one sheet, mm; placements : where each copy is cut; source : where the design came from;
    commands : the commands that made the kit; tolerance_note : the tolerance the design needs, if
    known; shaft, chassis : :class:`KitShaft`, :class:`KitChassis`; clearance : the checks over the turn
    (:class:`explorer.fabrication._kit_stack.Check`, worst first); samples, bound, running : how (samples of
    the turn; mm a distance may shrink between two; the running clearance, mm); torque : the peak motor
    torque, N·m, the sizes come from (None: none); notes : lines README.txt and bom.csv carry (where the
    forces come from, what was refused or undersized); forces : the joints' peak reactions, N, the pins come
    from (the crank pin of a throw also carries the torque, :attr:`KitPin.force`)."""

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
    shaft: KitShaft | None = None
    chassis: KitChassis | None = None
    clearance: tuple = ()
    samples: int = 0
    bound: float = 0.0
    running: float = 0.0
    torque: float | None = None
    notes: list[str] = field(default_factory=list)
    forces: dict = field(default_factory=dict)

    def part(self, name: str) -> KitPart:
        """The part called ``name``."""
        for p in self.parts:
            if p.name == name:
                return p
        raise KeyError(name)

    def outline(self, part) -> list[tuple]:
        """The outline of ``part`` (a KitPart or its name) in its own frame: the hull of its holes grown by its
        width / 2, a closed chain of ("arc", centre, radius, start, end) (counter-clockwise, radians, end >
        start) and ("line", p, q), mm, y up (as :meth:`explorer.view.Sheet.outline`)."""
        from ._export import _hull, _outline
        if isinstance(part, str):
            part = self.part(part)
        return _outline(_hull(part.holes), 0.5 * part.width)

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

    def mirror_joint(self, joint: str) -> str:
        """The name a hole of a mirrored copy takes: a standoff's mirror partner (the standoff set is mirrored
        about the shaft, so the hole of "standoff 2" of a mirrored frame takes the rod at "standoff 2"'s mirror
        image), any other joint its own."""
        if self.chassis is None or not joint.startswith("standoff "):
            return joint
        for name, x, y in self.chassis.standoffs:
            if name == joint:
                for other, x2, y2 in self.chassis.standoffs:
                    if abs(x2 + x) < 1e-6 and abs(y2 - y) < 1e-6:
                        return other
        return joint

    @property
    def worst(self):
        """The worst clearance checked over the turn (a :class:`~explorer.fabrication._kit_stack.Check`) or None."""
        return self.clearance[0] if self.clearance else None


# -- sizes ---------------------------------------------------------------------------------------------------
#: Standard metric pin (bolt, rod) sizes: (name, diameter mm).
STANDARD_PINS = (("M2", 2.0), ("M2.5", 2.5), ("M3", 3.0), ("M4", 4.0), ("M5", 5.0), ("M6", 6.0), ("M8", 8.0),
                 ("M10", 10.0), ("M12", 12.0), ("M16", 16.0), ("M20", 20.0))
#: Least wall of material around a hole, each side, and between two holes of one part, mm.
WALL = 1.5
#: Default pin diameter as a fraction of the crank radius in mm (an M3 pin on a 30 mm crank), rounded to
#: the nearest standard size.
DEFAULT_PIN = 0.1
#: Default crankshaft diameter as a fraction of the crank radius in mm (6 mm on a 30 mm crank), nearest
#: standard size, never below the pins'.
DEFAULT_SHAFT = 0.2
#: Default part width as a multiple of the largest pin diameter (a wall of one diameter each side).
DEFAULT_WIDTH = 3.0
#: Spare length of a pin past its stack, mm, besides one diameter (a lock nut or a collar and circlip).
SPARE = 2.0
#: Length of the crankshaft past the last plate, mm (a shaft collar).
SHAFT_ENDS = 10.0
#: The running clearance every part keeps from every pin, spacer, head, nut, the shaft and the parts of
#: its layer, over the whole turn, mm.
RUNNING_CLEARANCE = 1.0
#: Samples of the crank turn the clearances are checked at (every 0.1°).
CHECK_STEPS = 3600
#: The largest sheet, part or crank a kit takes, mm.
MAX_MM = 5000.0
#: The default motor: a 37 mm metal gearmotor (6 mm D-shaft; six M3 holes on a 31 mm circle; a 12 mm
#: bearing boss).
MOTOR_SHAFT = 6.0
MOTOR_HOLES = "6xM3@31"
#: The least standoff (threaded rod) diameter, mm.
STANDOFF_MIN = 4.0


def spacer_od(d: float) -> float:
    """A spacer's outer diameter on a d mm pin (nylon or brass tube), mm: 2 d."""
    return 2.0 * d


def bushing_od(d: float) -> float:
    """The outer diameter of a flanged sleeve bushing for a d mm shaft, mm: d + 2 up to 10 mm, else d + 4."""
    return d + 2.0 if d <= 10.0 else d + 4.0


def flat_depth(d: float) -> float:
    """How deep the D-flat of a d mm shaft is cut, mm: 0.5 up to 10 mm, else 1.0."""
    return 0.5 if d <= 10.0 else 1.0


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


def shaft_diameter(torque: float, bending: float, material: Material = Material()) -> tuple[str, float, float]:
    """(name, diameter mm, required diameter mm) of a solid round crankshaft carrying a peak torque T (N·m)
    and a bending moment M (N·m): the maximum shear stress 16 √(M² + T²) / (π d³) (Tresca) kept under
    τ_allow / SF (material.shaft_shear, MPa; the same safety factor as the pins), so d = ∛(16 · SF ·
    √(M² + T²) / (π · τ_allow)), plus the D-flat's depth; rounded up to the next standard size."""
    T, M = 1000.0 * float(torque), 1000.0 * float(bending)  # N·mm
    core = (16.0 * material.safety_factor * math.hypot(M, T) / (math.pi * material.shaft_shear)) ** (1.0 / 3.0)
    for name, d in STANDARD_PINS:
        if d - flat_depth(d) >= core - 1e-12:
            return name, d, core + flat_depth(d)
    raise UserError(f"torque: {torque:.3g} N·m with {bending:.3g} N·m of bending needs a {core:.1f} mm crankshaft, "
                    f"larger than {STANDARD_PINS[-1][0]}; use a stronger shaft material ([build] shaft_material)")


def _standard_name(d: float) -> str:
    for name, dd in STANDARD_PINS:
        if abs(dd - d) < 1e-9:
            return name
    return f"{d:g} mm"


def _nearest_standard(d: float) -> float:
    return min((dd for _, dd in STANDARD_PINS), key=lambda dd: (abs(math.log(dd / d)), dd))


def _next_standard(d: float) -> float:
    for _, dd in STANDARD_PINS:
        if dd >= d - 1e-12:
            return dd
    return d


def _collinear(points) -> bool:
    from ._export import _hull
    return len(_hull(points)) <= 2


def _mm(name: str, value, lo: float = 0.0, hi: float = MAX_MM, what: str = "mm") -> float:
    """A size option: a finite number in (lo, hi]; UserError naming the option and the value."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise UserError(f"{name}: expected {what}, a number > {lo:g} and at most {hi:g}, got {value!r}") from None
    if isinstance(value, bool) or not math.isfinite(v) or not lo < v <= hi:
        raise UserError(f"{name}: expected {what}, a number > {lo:g} and at most {hi:g}, got {value!r}")
    return v


# -- the design's parts ----------------------------------------------------------------------------------------
def rigid_triangles(mech: Mechanism) -> list[tuple[tuple[str, str, str], tuple[str, str, str]]]:
    """Triangles of links: [((a, b, c), (link ab, link bc, link ca))], each link in one triangle at most (the
    first found in file order): three links pinned into a triangle are one rigid piece."""
    by_pair = {frozenset((lk.a, lk.b)): lk.name for lk in mech.links}
    used: set[str] = set()
    out = []
    for lk in mech.links:
        a, b = lk.a, lk.b
        for c in mech.vertices:
            if c in (a, b):
                continue
            bc, ca = by_pair.get(frozenset((b, c))), by_pair.get(frozenset((c, a)))
            names = (lk.name, bc, ca)
            if bc is None or ca is None or used & set(names):
                continue
            used |= set(names)
            out.append(((a, b, c), names))
            break
    return out


def _plate_points(mech: Mechanism, tri, P0) -> list[tuple[float, float]]:
    """The holes of a triangle plate in its own frame, model units: a at the origin, b on +x at |ab|, c where
    its two links put it, on the side the design's assembly has it."""
    (a, b, c), (ab, bc, ca) = tri
    L = {lk.name: lk.length for lk in mech.links}
    dab, dbc, dca = L[ab], L[bc], L[ca]
    x = (dab * dab + dca * dca - dbc * dbc) / (2.0 * dab)
    y = math.sqrt(max(dca * dca - x * x, 0.0))
    pa, pb, pc = (P0[mech.vertex_index(v)] for v in (a, b, c))
    side = (pb[0] - pa[0]) * (pc[1] - pa[1]) - (pb[1] - pa[1]) * (pc[0] - pa[0])
    return [(0.0, 0.0), (dab, 0.0), (x, y if side >= 0 else -y)]


@dataclass
class _Raw:
    name: str
    kind: str
    joints: list
    pts: list          # model units, the part's own frame (the frame: from the crank centre)
    role: str = "part"


def _design_parts(mech: Mechanism, plates: bool) -> list[_Raw]:
    from ._export import _raw_parts
    raw = []
    tris = []
    if plates:
        from ..kernels import assemble
        P0, fail = assemble(mech)
        if fail is not None:
            raise UserError(f"{mech.name}: the design does not assemble at θ = 0 ({fail}); a kit needs one that does")
        tris = rigid_triangles(mech)
    in_plate = {n for _, names in tris for n in names}
    cx, cy = mech.crank.center
    for name, kind, joints, pts in _raw_parts(mech):
        if name in in_plate:
            continue
        if kind == "frame":
            pts = [(x - cx, y - cy) for x, y in pts]
        role = "frame" if kind == "frame" else ("crank" if kind == "crank" else "part")
        raw.append(_Raw(name, kind, list(joints), [tuple(map(float, p)) for p in pts], role))
    for tri in tris:  # named and holed in the design's vertex order ("2-3-4")
        pts = dict(zip(tri[0], _plate_points(mech, tri, P0)))
        order = sorted(tri[0], key=mech.vertex_index)
        raw.append(_Raw("-".join(order), "plate", order, [pts[v] for v in order]))
    return raw


# -- the loads -------------------------------------------------------------------------------------------------
def kit_loads(mech: Mechanism, walker: Walker, operating, scale: float, link_density: float | None,
              steps: int = 360) -> tuple[dict[str, float], float]:
    """The joint forces ({joint: peak reaction N}) and the peak motor torque (N·m) of ``mech`` built at
    ``scale`` mm per model unit with links of ``link_density`` kg per metre (None: the design's own), run at
    ``operating`` (its unit replaced by the build's), for ``walker``: through :func:`explorer.simulate`
    (``forces=True``), so the forces model of this explorer sizes the kit."""
    from .. import simulate
    m = replace(mech, link_density=link_density) if link_density is not None else mech
    op = replace(operating, unit=float(scale) / 1000.0)
    cyc = simulate(m, steps=steps, forces=True, operating=op, walker=walker)
    if not cyc.ok:
        raise UserError(f"{mech.name}: the forces of the kit's build cannot be computed: {cyc.failure}")
    fm = cyc.force_metrics
    forces = {k[len("pin_force."):]: float(v) for k, v in fm.items() if k.startswith("pin_force.")}
    return forces, float(fm["motor_torque_peak"])


# -- the kit -------------------------------------------------------------------------------------------------
def build_kit(design: Mechanism, *, crank_mm: float | None = None, scale: float | None = None,
              width: float | None = None, hole: float | None = None, sheet: tuple[float, float] = (600.0, 400.0),
              material: Material | None = None, forces: dict[str, float] | None = None, torque: float | None = None,
              plates: bool = False, undersized: bool = False, motor_shaft: float | None = None,
              motor_holes: str | None = None, clearance: float = RUNNING_CLEARANCE, source: str = "", commands=(),
              tolerance_note: str | None = None, notes=(), loads=None) -> Kit:
    """The build kit of ``design`` (a crank-driven Mechanism without sliders; its walker gives the legs).

    Size: ``scale`` mm per model unit, or ``crank_mm`` (the crank radius, mm; not both), else the design's
    ``[build] unit`` (or ``[operating] unit``), else a 30 mm crank. width : the links' width, mm (default:
    the build's part_width, else :data:`DEFAULT_WIDTH` × the largest pin). material : :class:`Material`
    (default: the design's ``[build]``, :func:`material_of`). hole : every pin's diameter, mm (default:
    the standard size nearest :data:`DEFAULT_PIN` × the crank radius in mm, larger where ``forces``,
    {joint: peak reaction N}, need it; a ``hole`` below what a joint's force needs is refused unless
    ``undersized``). torque : the peak motor torque, N·m (sizes the crankshaft, :func:`shaft_diameter`;
    with the crank pin's force its bending). loads : instead of ``forces`` and ``torque``, a callable
    (scale mm per model unit, link width mm) → (forces, torque, note or None) that computes them for the
    parts the kit cuts (:func:`kit_loads`); it is called again if the links' width changes with the pins
    it sizes, and its note goes into README.txt and bom.csv. plates : cut each rigid triangle of links as
    one plate.
    motor_shaft (mm), motor_holes ("6xM3@31") : the motor plate (default :data:`MOTOR_SHAFT`,
    :data:`MOTOR_HOLES`). clearance : the running clearance, mm. sheet : (W, H) of one sheet, mm.

    One-line UserError naming the option, or the part (and the pin and the angle), for: a size out of
    range, a hole that leaves less than :data:`WALL` mm of wall, two holes of one part too close, a part
    larger than a sheet, no stack that keeps every part clear over the turn, a design driven along a
    path or with sliders (the kit draws no slots or guides yet).
    """
    from ._kit_chassis import MOTOR_GAP, motor_pattern, standoff_points
    from ._kit_sheet import nest
    from ._kit_stack import MODES, Problem, StackPart, StackPin, clearance_checks, sample_bound, solve_stack

    mech = design
    if mech.crank is None:
        raise UserError(f"{mech.name}: a build kit needs a crank-driven design (this one is driven along a "
                        f"path); export its parts with --as svg or dxf")
    if mech.sliders:
        names = ", ".join(sl.name for sl in mech.sliders)
        raise UserError(f"{mech.name}: its sliders ({names}) need a slot or a guide, which the kit cannot draw yet; "
                        f"export its parts with --as svg or dxf")
    if scale is not None and crank_mm is not None:
        raise UserError(f"--scale {scale:g} and --crank-mm {crank_mm:g}: each sets the size; give one")
    r = mech.crank.radius
    build = mech.build
    if scale is not None:
        scale = _mm("--scale", scale, hi=1e9, what="mm per model unit")
    elif crank_mm is not None:
        scale = _mm("--crank-mm", crank_mm, what="the crank radius in mm") / r
    elif build is not None and build.unit is not None:
        scale = 1000.0 * build.unit
    elif mech.operating is not None and mech.operating.unit is not None:
        scale = 1000.0 * mech.operating.unit
    else:
        scale = 30.0 / r
    crank_r = r * scale
    if not crank_r <= MAX_MM:
        raise UserError(f"--scale: a {crank_r:.4g} mm crank is larger than a kit takes ({MAX_MM:g} mm)")
    W, H = (_mm("--sheet", sheet[0], what="a sheet width in mm"), _mm("--sheet", sheet[1], what="a sheet height in mm"))
    material = material or material_of(build)
    _mm("--thickness", material.thickness, hi=100.0, what="the sheet thickness in mm")
    clearance = _mm("clearance", clearance, lo=-1e-300, hi=100.0, what="the running clearance in mm")
    if width is None and build is not None and build.part_width is not None:
        width = build.part_width
    if width is not None:
        width = _mm("--width", width, hi=1000.0, what="the part width in mm")
    if hole is not None:
        hole = _mm("--hole", hole, hi=100.0, what="the pin (hole) diameter in mm")
    m_shaft = MOTOR_SHAFT if motor_shaft is None else _mm("--motor-shaft", motor_shaft, hi=100.0,
                                                          what="the motor's shaft diameter in mm")
    if motor_shaft is not None and m_shaft >= crank_r:
        raise UserError(f"--motor-shaft: a {m_shaft:g} mm motor shaft is not smaller than the {crank_r:.3g} mm crank")
    m_holes = motor_pattern(MOTOR_HOLES if motor_holes is None else motor_holes, m_shaft)
    walker = mech.walker if mech.walker is not None else Walker(legs=1)
    n_legs = walker.legs
    mirrored_legs = {j + 1 for j, m in enumerate(walker.mirrored) if m}
    phases = [math.degrees(phi) % 360.0 for phi in walker.phases]
    notes = list(notes)

    # loads: given, or computed for the parts the kit cuts (again if the links' width follows the pins)
    t = material.thickness
    default_d = max(STANDARD_PINS[0][1], _nearest_standard(DEFAULT_PIN * crank_r))
    tip = mech.crank.tip

    def clean(forces, torque):
        forces = {str(k): float(v) for k, v in (forces or {}).items()
                  if v is not None and math.isfinite(float(v)) and float(v) >= 0}
        if torque is not None and not (math.isfinite(float(torque)) and float(torque) >= 0):
            torque = None
        return forces, (None if torque is None else float(torque))

    load_note = None
    w_loads = None

    def load_at(w):
        got = loads(scale, w)
        return clean(got[0], got[1]) + ((got[2] if len(got) > 2 else None),)

    if loads is not None:
        w_loads = width
        if w_loads is None:  # the links' width follows the pins the forces size: a fixed point
            w_loads = DEFAULT_WIDTH * default_d
            for _ in range(4):
                forces, T, load_note = load_at(w_loads)
                ds = [hole] if hole is not None else [default_d] + [pin_diameter(f, material)[1]
                                                                   for f in forces.values()]
                if abs(DEFAULT_WIDTH * max(ds) - w_loads) < 1e-9:
                    break
                w_loads = DEFAULT_WIDTH * max(ds)
        forces, T, load_note = load_at(w_loads)
    else:
        forces, T = clean(forces, torque)

    # the motion, once: every joint over the turn, mm from the crank centre
    from .. import simulate
    cyc = simulate(mech, steps=CHECK_STEPS)
    if not cyc.ok:
        raise UserError(f"{mech.name}: the design does not turn through a full cycle ({cyc.failure}); a kit needs "
                        f"one that does")
    centre = np.asarray(mech.crank.center, dtype=np.float64)
    Pmm = (np.asarray(cyc.positions, dtype=np.float64) - centre) * scale
    bound = sample_bound(np.asarray(cyc.velocities) * scale, CHECK_STEPS)
    S = CHECK_STEPS

    def path(j: str) -> np.ndarray:
        if j == CRANK_CENTRE:
            return np.zeros((S, 2))
        return Pmm[:, mech.vertex_index(j)]

    raw = _design_parts(mech, plates)
    shaft_default = max(default_d, _nearest_standard(DEFAULT_SHAFT * crank_r))

    def pin_need(j: str, extra: float = 0.0):
        f = forces.get(j)
        if f is None and not extra:
            return None, None
        f = (f or 0.0) + extra
        return f, pin_diameter(f, material)[2]

    # sizes, then the stack; again with larger sizes if the stack's mode or arms need them
    mode_hint = None
    d_shaft = shaft_default
    lay = prob = None
    for _ in range(8):
        F_tip = forces.get(tip)
        extra_tip = (T * 1000.0 / crank_r) if (T is not None and mode_hint == "throws") else 0.0
        dia, need, load = {}, {}, {}
        for j in mech.vertices:
            f, req = pin_need(j, extra_tip if j == tip else 0.0)
            load[j], need[j] = f, req
            if hole is not None:
                dia[j] = hole
            elif req is not None:
                dia[j] = max(default_d, _next_standard(req))
            else:
                dia[j] = default_d
        if hole is not None and not undersized:
            short = [(j, need[j]) for j in mech.vertices if need[j] is not None and need[j] > hole + 1e-9]
            if short:
                j, req = max(short, key=lambda t: t[1])
                raise UserError(f"--hole: {hole:g} mm is below the {req:.3g} mm pin {j} needs for its {load[j]:.4g} N "
                                f"(the BOM's rule); pass --undersized to cut it anyway")
        w_links = width if width is not None else DEFAULT_WIDTH * max(dia.values())
        if loads is not None and abs(w_links - w_loads) > 1e-9:  # the forces of the parts as cut
            w_loads = w_links
            forces, T, load_note = load_at(w_loads)
            continue
        bush = bushing_od(d_shaft)
        # the parts of one leg, mm
        parts = []
        for rp in raw:
            holes = tuple((x * scale, y * scale) for x, y in rp.pts)
            diam = []
            for j in rp.joints:
                if rp.role == "frame" and CRANK_CENTRE in j.split("+"):
                    diam.append(bush)
                elif j == CRANK_CENTRE:
                    diam.append(d_shaft)
                else:
                    diam.append(max(dia.get(x, default_d) for x in j.split("+")))
            big = max(diam)
            w = w_links
            if rp.role in ("frame", "crank"):
                w = max(w_links, big + 2.0 * max(WALL, 0.5 * big if rp.role == "crank" else WALL))
            parts.append((rp, holes, tuple(diam), w))
        for rp, holes, diam, w in parts:
            for j, d in zip(rp.joints, diam):
                if d > w - 2 * WALL + 1e-9:
                    raise UserError(f"part {rp.name!r}: its {d:g} mm hole at joint {j} leaves less than a {WALL:g} mm "
                                    f"wall in a {w:.3g} mm wide part; use a larger --width or a smaller --hole")
            for a in range(len(holes)):
                for b in range(a):
                    dist = math.dist(holes[a], holes[b])
                    if dist < 0.5 * (diam[a] + diam[b]) + WALL:
                        raise UserError(f"part {rp.name!r}: holes {rp.joints[b]} and {rp.joints[a]} are {dist:.3g} mm "
                                        f"apart, too close for {diam[b]:g} and {diam[a]:g} mm pins and a {WALL:g} mm "
                                        f"wall between them; use a larger --crank-mm (or --scale) or a smaller --hole")
        # the stack problem
        from ._export import _hull
        sparts = []
        for rp, holes, diam, w in parts:
            hull = _hull(holes)
            idx = [holes.index(p) for p in hull if p in holes] or list(range(len(holes)))
            singles = tuple(x for j in rp.joints for x in j.split("+"))
            sparts.append(StackPart(rp.name, singles, [path(rp.joints[i].split("+")[0]) for i in idx], 0.5 * w,
                                    rp.role))
        crank_part = next(sp for sp in sparts if sp.role == "crank")
        sparts.append(StackPart("crank-outer", crank_part.joints, crank_part.corners, crank_part.half, "crank-outer"))
        on = {}
        for sp in sparts:
            for j in sp.joints:
                on.setdefault(j, []).append(sp.name)
        spins = [StackPin(CRANK_CENTRE, np.zeros((S, 2)), 0.5 * spacer_od(d_shaft), shaft=True)]
        for j in mech.vertices:
            if len([n for n in on.get(j, []) if n != "crank-outer"]) >= 2:
                spins.append(StackPin(j, path(j), 0.5 * max(spacer_od(dia[j]), 2.0 * dia[j])))
        prob = Problem(sparts, spins, clearance, bound)
        lay = solve_stack(prob, n_legs, MODES)
        # what the layout needs: the crank pin carries the torque between the webs of a throw
        grew = False
        if lay.mode == "throws" and mode_hint != "throws" and T is not None:
            mode_hint = "throws"
            grew = True
        p = t + WASHER
        gap = 2.0 * max(dia.values()) + SPARE + WASHER
        arms = [lay.layers["crank"]] + ([lay.layers["crank-outer"]] if lay.mode == "throws" else [])
        if lay.mode == "outboard":
            arm = arms[0] * p
        else:
            arm = max(min(c * p, (lay.top - c) * p + t + gap) for c in arms)
        F_arm = None
        if F_tip is not None or T is not None:
            F_arm = (F_tip or 0.0) + (T * 1000.0 / crank_r if (T is not None and lay.mode == "throws") else 0.0)
        if T is not None:
            M = (F_arm or 0.0) * arm / 1000.0
            _, d_req_std, d_req = shaft_diameter(T, M, material)
            want = max(shaft_default, d_req_std)
            if want > d_shaft + 1e-9:
                d_shaft = want
                grew = True
        if not grew:
            break
    assert lay is not None and prob is not None
    if load_note:
        notes.append(load_note)
    checks = clearance_checks(prob, lay)
    if checks and checks[0].margin < bound - 1e-9:  # the program's conflicts guarantee it; say so if not
        c = checks[0]
        raise UserError(f"part {c.b!r} comes within {c.margin:.3g} mm of the room {c.a!r} needs at θ = "
                        f"{c.theta_deg:.1f}° (layer {c.layer}); no stack keeps it clear")

    # the shaft's load and size, as the layout has it
    M_shaft = None
    d_required = None
    if T is not None:
        M_shaft = (F_arm or 0.0) * arm / 1000.0
        _, _, d_required = shaft_diameter(T, M_shaft, material)

    if m_shaft >= crank_r:
        raise UserError(f"--motor-shaft: the default motor's {m_shaft:g} mm shaft is not smaller than the "
                        f"{crank_r:.3g} mm crank; give a smaller --motor-shaft or a larger --crank-mm")
    # the chassis: standoffs where nothing turns
    so_d = max(STANDOFF_MIN, default_d)
    moving = []
    for sp in prob.parts:
        if sp.role == "frame" or sp.name not in lay.layers:
            continue
        moving.append((sp.corners, sp.half))
    for sp in spins:
        moving.append(([sp.path], sp.radius))
    frame_raw = next(rp for rp, *_ in parts if rp.role == "frame")
    frame_pts = [(x * scale, y * scale) for x, y in frame_raw.pts]
    standoffs = standoff_points(moving, frame_pts, so_d, clearance, bound, bool(mirrored_legs))
    so_names = [f"standoff {i + 1}" for i in range(len(standoffs))]

    # the parts, as cut
    legs_all = tuple(range(1, n_legs + 1))
    kparts: list[KitPart] = []
    layers: dict[str, int] = {}
    for rp, holes, diam, w in parts:
        if rp.role == "crank":
            continue
        joints = tuple(rp.joints)
        if rp.role == "frame":
            joints = joints + tuple(so_names)
            holes = holes + tuple(standoffs)
            diam = diam + (so_d,) * len(standoffs)
        sym = _collinear(holes)
        mir = 0 if sym else len(mirrored_legs)
        layers[rp.name] = lay.layers[rp.name]
        kparts.append(KitPart(rp.name, rp.kind, joints, holes, diam, n_legs, mir, sym, lay.layers[rp.name], w,
                              (), legs_all))
    crank_rp, crank_holes, crank_diam, crank_w = next(t4 for t4 in parts if t4[0].role == "crank")
    crank_parts = []
    fd = flat_depth(d_shaft)
    webs = ["crank"] + (["crank-outer"] if lay.mode == "throws" else [])
    for name in webs:  # copy k is leg k's: its D-hole turned by the leg's phase
        layers[name] = lay.layers[name]
        flats = tuple(((-phases[j]) % 360.0, None) for j in range(n_legs))
        crank_parts.append(KitPart(name, "crank", tuple(crank_rp.joints), crank_holes, crank_diam, n_legs, 0, False,
                                   lay.layers[name], crank_w, flats, legs_all))
    kparts[1:1] = crank_parts
    # chassis plates: the motor plate and (unless the crank arm is outboard) the end plate
    n, dh, pcd = m_holes
    boss = 2.0 * m_shaft
    mh = [(0.5 * pcd * math.cos(2 * math.pi * i / n), 0.5 * pcd * math.sin(2 * math.pi * i / n)) for i in range(n)]
    plate_w = max(w_links, boss + 2 * WALL, so_d + 2 * WALL)
    motor = KitPart("motor plate", "motor", ("motor",) + tuple(f"motor hole {i + 1}" for i in range(n)) + tuple(so_names),
                    ((0.0, 0.0),) + tuple(mh) + tuple(standoffs), (boss,) + (dh,) * n + (so_d,) * len(standoffs),
                    1, 0, False, None, plate_w, (), ())
    chassis_parts = [motor]
    if lay.mode != "outboard":
        bush = bushing_od(d_shaft)
        chassis_parts.append(KitPart("end plate", "end", (CRANK_CENTRE,) + tuple(so_names),
                                     ((0.0, 0.0),) + tuple(standoffs), (bush,) + (so_d,) * len(standoffs), 1, 0,
                                     False, None, max(plate_w, bush + 2 * WALL), (), ()))
    for cp in chassis_parts:
        for a in range(len(cp.holes)):
            for b in range(a):
                dist = math.dist(cp.holes[a], cp.holes[b])
                if dist < 0.5 * (cp.diameters[a] + cp.diameters[b]) + WALL:
                    raise UserError(f"part {cp.name!r}: holes {cp.joints[b]} and {cp.joints[a]} are {dist:.3g} mm "
                                    f"apart, too close; choose another --motor-holes pattern")
    kparts += chassis_parts

    # along the shaft: the motor plate at z = 0, then each leg, then the end plate
    p = t + WASHER
    depth = (lay.top + 1) * t + lay.top * WASHER
    gap = 2.0 * max(dia.values()) + SPARE + WASHER
    z0 = t + MOTOR_GAP
    leg_z = [z0 + i * (depth + gap) for i in range(n_legs)]
    plates_z = [("motor plate", 0.0)] + [(f"frame (leg {i + 1})", z) for i, z in enumerate(leg_z)]
    z_end = leg_z[-1] + depth + gap
    if lay.mode != "outboard":
        plates_z.append(("end plate", z_end))
        length = z_end + t
    else:
        length = leg_z[-1] + depth
    z_coupler = t + 0.5 * MOTOR_GAP
    if lay.mode == "throws":
        A, B = lay.layers["crank"], lay.layers["crank-outer"]
        segs = [(z_coupler, leg_z[0] + A * p + t)]
        for i in range(n_legs - 1):
            segs.append((leg_z[i] + B * p, leg_z[i + 1] + A * p + t))
        segs.append((leg_z[-1] + B * p, z_end + t + SHAFT_ENDS))
    elif lay.mode == "through":
        segs = [(z_coupler, z_end + t + SHAFT_ENDS)]
    else:
        segs = [(z_coupler, leg_z[0] + lay.layers["crank"] * p + t)]
    segs = tuple((round(a, 3), round(b, 3)) for a, b in segs)
    shaft_len = float(sum(math.ceil(b - a) for a, b in segs))
    shaft = KitShaft(lay.mode, d_shaft, shaft_len, segs, lay.shaft_layers, T, M_shaft, F_arm, arm, d_required,
                     bushing_od(d_shaft), fd)
    so_len = float(math.ceil(length + 2 * (so_d + SPARE)))
    chassis = KitChassis(tuple((nm, float(x), float(y)) for nm, (x, y) in zip(so_names, standoffs)), so_d, so_len,
                         m_shaft, m_holes, boss, tuple(plates_z), length)

    # the pins
    def display(name: str) -> list[str]:
        return [name]
    pins = []
    shaft_stack = tuple(n for n in sorted(prob.on[CRANK_CENTRE], key=lambda n: lay.layers.get(n, -1))
                        if n in lay.layers)
    pins.append(KitPin(CRANK_CENTRE, tuple(x for n in shaft_stack for x in display(n)), d_shaft, shaft_len, 1, None,
                       lay.shaft_layers, tuple(k for k in lay.shaft_layers if k not in
                                                {lay.layers[n] for n in shaft_stack}), "shaft", d_required))
    for sp in spins:
        if sp.shaft:
            continue
        j = sp.joint
        stack_names = sorted((n for n in prob.on[j] if n in lay.layers), key=lambda n: lay.layers[n])
        lo, hi = lay.spans[j]
        span = hi - lo + 1
        carried = {lay.layers[n] for n in stack_names}
        d = dia[j]
        length_mm = float(math.ceil(span * t + (span - 1) * WASHER + d + SPARE))
        kind = "crank pin" if j == tip else "pin"
        pins.append(KitPin(j, tuple(x for n in stack_names for x in display(n)), d, length_mm, n_legs, load[j],
                           tuple(range(lo, hi + 1)), tuple(k for k in range(lo, hi + 1) if k not in carried), kind,
                           need[j]))
    for nm, *_ in chassis.standoffs:
        pins.append(KitPin(nm, tuple(n for n, _ in plates_z), so_d, so_len, 1, None, (), (), "standoff", None))

    legs = tuple(KitLeg(j, phases[j], (j + 1) in mirrored_legs, "crank", round(leg_z[j], 3)) for j in range(n_legs))
    if hole is not None and undersized:
        short = [(j, need[j]) for j in mech.vertices if need[j] is not None and need[j] > hole + 1e-9]
        for j, req in short:
            notes.append(f"UNDERSIZED (--undersized): pin {j} is {hole:g} mm, below the {req:.3g} mm its "
                         f"{load[j]:.4g} N needs by the BOM's rule")
    kparts = tuple(kparts)
    placements = nest(kparts, (W, H), mirrored_legs)
    kit = Kit(mech, walker, float(scale), float(w_links), material, kparts, tuple(pins), legs, layers, (W, H),
              placements, source or (mech.source or mech.name), tuple(commands), tolerance_note, shaft, chassis,
              tuple(checks), S, float(bound), float(clearance), T, notes, dict(forces))
    return kit


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


# -- kit.json: the kit as data ---------------------------------------------------------------------------------
#: The files of a kit folder, in the order written (assembly.pdf only where explorer.fabrication._kit_pdf exists).
KIT_FILES = ("kit.json", "parts.svg", "parts.dxf", "bom.csv", "README.txt", "assembly.pdf")
#: kit.json's format name and version (checks outside this repository read it).
KIT_FORMAT = ("explorer build kit", 1)


def _r(x, nd: int = 6):
    return None if x is None else round(float(x), nd)


def kit_data(kit: Kit) -> dict:
    """The kit as data (``kit.json``): every copy of every part (name, kind, copy, leg, mirrored, layer, width,
    its holes with joint names, positions in the part's own frame as cut (a mirrored copy's x negated) and
    diameters, and a D-flat's normal and depth), every pin, the shaft and the standoffs (joint, kind, layers
    spanned bottom to top, stack, spacers, diameter, length, count, force, required diameter), the crank
    arrangement, the chassis, the clearance checked over the turn, the scale in mm per model unit, the
    build, the design's parameters, the loads the sizes come from and the notes. Lengths in mm, angles in
    degrees, forces in N, torques and moments in N·m."""
    m = kit.material
    mech = kit.mechanism
    parts = []
    for p in kit.parts:
        mirrored_legs = {leg.index + 1 for leg in kit.legs if leg.mirrored}
        for k in range(p.copies):
            leg = p.legs[k] if k < len(p.legs) else None
            mir = bool(p.mirrored) and leg in mirrored_legs
            holes = []
            for i, (j, (x, y), d) in enumerate(zip(p.joints, p.holes, p.diameters)):
                fl = p.flat(i, k + 1)
                h = {"joint": kit.mirror_joint(j) if mir else j, "x": _r(-x if mir else x), "y": _r(y),
                     "diameter": _r(d)}
                if fl is not None:
                    h["d_flat"] = {"normal_deg": _r((180.0 - fl) % 360.0 if mir else fl),
                                   "depth": _r(kit.shaft.flat if kit.shaft else flat_depth(d))}
                holes.append(h)
            parts.append({"name": p.name, "kind": p.kind, "copy": k + 1, "leg": leg, "mirrored": mir,
                          "layer": p.layer, "width": _r(p.width), "holes": holes})
    pins = []
    for pin in kit.pins:
        pins.append({"joint": pin.joint, "kind": pin.kind, "layers": list(pin.layers), "stack": list(pin.stack),
                     "spacers": list(pin.spacers), "diameter": _r(pin.diameter), "length": _r(pin.length),
                     "count": pin.count, "force_N": _r(pin.force), "required_diameter": _r(pin.required)})
    sh, ch = kit.shaft, kit.chassis
    crank = {"mode": sh.mode, "fixing": "D-flat",
             "flat_depth": _r(sh.flat),
             "note": ("copy k of every crank arm (web) is leg k's: its D-hole is turned by the leg's phase (the flat's "
                      "normal at minus the phase from the arm), so slid onto the shaft's one flat, engraved face away "
                      "from the frame plate, it points at its phase"),
             "order": [leg.index + 1 for leg in sorted(kit.legs, key=lambda lg: lg.z)],
             "legs": [{"leg": leg.index + 1, "phase_deg": _r(leg.phase_deg), "mirrored": leg.mirrored,
                       "part": leg.crank, "z": _r(leg.z, 3),
                       "copy": leg.index + 1, "d_flat_normal_deg": _r((-leg.phase_deg) % 360.0),
                       "layers": [kit.layers["crank"]] + ([kit.layers["crank-outer"]] if sh.mode == "throws" else [])}
                      for leg in kit.legs]}
    shaft = {"joint": CRANK_CENTRE, "mode": sh.mode, "diameter": _r(sh.diameter), "length": _r(sh.length),
             "material": m.shaft_material, "allowable_shear_MPa": m.shaft_shear, "layers": list(sh.layers),
             "segments": [{"from_z": _r(a, 3), "to_z": _r(b, 3), "length": math.ceil(b - a)} for a, b in sh.segments],
             "torque_Nm": _r(sh.torque), "bending_Nm": _r(sh.bending), "arm_force_N": _r(sh.arm_force),
             "arm": _r(sh.arm, 3), "required_diameter": _r(sh.required), "bushing_od": _r(sh.bushing_od),
             "flat_depth": _r(sh.flat)}
    chassis = {"standoffs": [{"name": n, "x": _r(x), "y": _r(y)} for n, x, y in ch.standoffs],
               "standoff_diameter": _r(ch.standoff_d), "standoff_length": _r(ch.standoff_length),
               "plates": [{"name": n, "z": _r(z, 3)} for n, z in ch.plates], "length": _r(ch.length, 3),
               "motor": {"shaft_diameter": _r(ch.motor_shaft), "holes": ch.motor_holes[0],
                         "hole_diameter": _r(ch.motor_holes[1]), "pitch_circle": _r(ch.motor_holes[2]),
                         "boss_hole": _r(ch.motor_boss)}}
    worst = kit.worst
    clearance = {"running": _r(kit.running), "samples": kit.samples, "bound": _r(kit.bound),
                 "rule": ("least distance over the turn from each pin's (spacer's, head's, nut's, the shaft's) "
                          "centre to each part's outline on a layer it occupies without carrying that part, "
                          "less the radius and the running clearance; two parts of a layer; two bare pins"),
                 "checks": [{"what": c.what, "a": c.a, "b": c.b, "layer": c.layer, "margin": _r(c.margin),
                             "theta_deg": _r(c.theta_deg, 2)} for c in kit.clearance],
                 "worst": None if worst is None else {"what": worst.what, "a": worst.a, "b": worst.b,
                                                      "layer": worst.layer, "margin": _r(worst.margin),
                                                      "theta_deg": _r(worst.theta_deg, 2)}}
    build = {"material": m.name, "thickness": m.thickness, "part_width": _r(kit.width),
             "density_kg_m3": m.density, "link_density_kg_m": _r(m.density * m.thickness * kit.width / 1e6, 9),
             "pin_material": m.pin_material, "pin_allowable_shear_MPa": m.pin_shear,
             "shaft_material": m.shaft_material, "shaft_allowable_shear_MPa": m.shaft_shear,
             "bearing_MPa": m.bearing, "safety_factor": m.safety_factor, "unit_m": _r(kit.scale / 1000.0, 12)}
    return {"format": KIT_FORMAT[0], "version": KIT_FORMAT[1],
            "design": {"name": mech.name, "source": kit.source, "parameters": {k: float(v) for k, v in
                                                                                mech.parameters().items()}},
            "scale_mm_per_unit": kit.scale, "crank_mm": _r(kit.scale * mech.crank.radius),
            "build": build, "sheet": {"width": kit.sheet_size[0], "height": kit.sheet_size[1], "count": kit.sheets},
            "legs": kit.walker.legs, "parts": parts, "pins": pins, "shaft": shaft, "crank": crank,
            "chassis": chassis, "clearance": clearance,
            "loads": {"motor_torque_peak_Nm": _r(kit.torque),
                      "pin_forces_N": {j: _r(f) for j, f in kit.forces.items()}},
            "notes": list(kit.notes), "tolerance": kit.tolerance_note, "commands": list(kit.commands)}


# -- bom.csv and README.txt, from kit.json ----------------------------------------------------------------------
def bom_rows(kit_or_data) -> list[dict]:
    """The bill of materials from the kit's data (:func:`kit_data`; a Kit is turned into it), one dict per line:
    item ("part", "pin", "crank pin", "crankshaft", "spacer", "washer", "retainer", "bushing", "coupler",
    "shaft collar", "standoff", "nut", "motor"), name, count, material, thickness_mm, diameter_mm, length_mm,
    force_N, required_d_mm, note."""
    data = kit_data(kit_or_data) if isinstance(kit_or_data, Kit) else kit_or_data
    b = data["build"]
    rows = []

    def row(item, name, count, material="", thickness="", diameter="", length="", force="", need="", note=""):
        rows.append({"item": item, "name": name, "count": count, "material": material, "thickness_mm": thickness,
                     "diameter_mm": diameter, "length_mm": length, "force_N": force, "required_d_mm": need,
                     "note": note})

    def g(x):
        return "" if x is None else f"{x:g}"

    names = list(dict.fromkeys(p["name"] for p in data["parts"]))
    for n in names:
        copies = [p for p in data["parts"] if p["name"] == n]
        mir = sum(p["mirrored"] for p in copies)
        first = copies[0]
        how = f"{len(copies) - mir} plain + {mir} mirrored (marked M)" if mir else f"{len(copies)} as drawn"
        flat = any("d_flat" in h for h in first["holes"])
        extra = "; a D-hole for the crankshaft, turned by each copy's leg phase (copy k: leg k)" if flat else ""
        layer = "chassis" if first["layer"] is None else f"layer {first['layer']}"
        row("part", n, len(copies), b["material"], g(b["thickness"]), "", "", "", "",
            f"{first['kind']}; {layer}; {g(first['width'])} mm wide; holes "
            f"{', '.join(h['joint'] for h in first['holes'])}; {how}{extra}")
    sh = data["shaft"]
    t = b["thickness"]
    for pin in data["pins"]:
        size = _standard_name(pin["diameter"])
        stack = ", ".join(pin["stack"])
        force = "" if pin["force_N"] is None else f"{pin['force_N']:.4g}"
        need = "" if pin["required_diameter"] is None else f"{pin['required_diameter']:.3g}"
        if pin["kind"] == "shaft":
            segs = sh["segments"]
            pieces = (f"{len(segs)} pieces of {', '.join(str(s['length']) for s in segs)} mm (between the throws' "
                      f"webs)" if len(segs) > 1 else "one rod")
            row("crankshaft", pin["joint"], len(segs), b["shaft_material"], "", g(pin["diameter"]), g(pin["length"]),
                "", need, f"{size} rod with a {g(sh['flat_depth'])} mm D-flat along it, {pieces}; {sh['mode']}; "
                f"torque {g(sh['torque_Nm'])} N·m, bending {g(sh['bending_Nm'])} N·m; runs through layers "
                f"{', '.join(map(str, pin['layers']))} of every leg")
            row("bushing", pin["joint"], sum(1 for p in data["chassis"]["plates"] if p["name"] != "motor plate"),
                "sintered bronze", "", g(pin["diameter"]), "", "", "",
                f"flanged sleeve, bore {g(pin['diameter'])} mm, outer {g(sh['bushing_od'])} mm: one in every frame "
                f"plate and the end plate")
            row("coupler", "motor", 1, "aluminium", "", g(pin["diameter"]), "25", "", "",
                f"shaft coupler from the motor's {g(data['chassis']['motor']['shaft_diameter'])} mm shaft to the "
                f"{g(pin['diameter'])} mm crankshaft")
            row("shaft collar", pin["joint"], 2, "steel", "", g(pin["diameter"]), "", "", "",
                "set-screw collars, one each side of the chassis: they hold the shaft along its axis")
            n_legs = data["legs"]
        elif pin["kind"] == "standoff":
            row("standoff", pin["joint"], 1, "steel (threaded rod)", "", g(pin["diameter"]), g(pin["length"]), "", "",
                f"{size} threaded rod through every plate ({stack})")
            row("nut", pin["joint"], 2 * len(pin["stack"]), "steel", "", g(pin["diameter"]), "", "", "",
                f"{size} nuts, one on each side of each plate, on {pin['joint']}")
            continue
        else:
            n_legs = pin["count"]
            row("crank pin" if pin["kind"] == "crank pin" else "pin", pin["joint"], pin["count"], b["pin_material"],
                "", g(pin["diameter"]), g(pin["length"]), force, need,
                f"{size}, one per leg; layers {pin['layers'][0]}-{pin['layers'][-1]}, bottom to top: {stack}")
        if pin["spacers"]:
            row("spacer", pin["joint"], len(pin["spacers"]) * n_legs, "nylon or brass tube", g(t), g(pin["diameter"]),
                g(t), "", "", f"inner diameter {g(pin['diameter'])} mm, outer {g(spacer_od(pin['diameter']))} mm; on "
                f"{pin['joint']} at layer{'s' if len(pin['spacers']) > 1 else ''} "
                f"{', '.join(map(str, pin['spacers']))} (no part there)")
        gaps = len(pin["layers"]) - 1
        if gaps > 0:
            row("washer", pin["joint"], gaps * n_legs, "steel or nylon", g(WASHER), g(pin["diameter"]), "", "", "",
                f"between every two layers on {pin['joint']}")
        if pin["kind"] in ("pin", "crank pin"):
            row("retainer", pin["joint"], pin["count"], b["pin_material"], "", g(pin["diameter"]), "", "", "",
                f"lock nut ({size}) or collar and circlip, one per pin")
    mo = data["chassis"]["motor"]
    row("motor", "motor", 1, "", "", g(mo["shaft_diameter"]), "", "", "",
        f"gearmotor with a {g(mo['shaft_diameter'])} mm shaft and {mo['holes']} M{g(mo['hole_diameter'])} holes on a "
        f"{g(mo['pitch_circle'])} mm circle" + (f"; at least {data['loads']['motor_torque_peak_Nm']:.3g} N·m peak"
                                                if data["loads"]["motor_torque_peak_Nm"] is not None else ""))
    return rows


def bom_text(kit: Kit) -> str:
    """``bom.csv``: comment lines (#) stating the material, the sizing rules, the allowable stresses, the
    safety factor and the notes, then a CSV table of :func:`bom_rows` (``pandas.read_csv(path,
    comment="#")``)."""
    import csv
    import io

    data = kit_data(kit)
    m = kit.material
    forces = any(p.force is not None for p in kit.pins)
    head = [
        f"# bill of materials of the {kit.mechanism.name} kit: {kit.walker.legs} legs, 1 model unit = {kit.scale:.6g} mm",
        f"# parts: {m.thickness:g} mm {m.name}, links {kit.width:.3g} mm wide; pins: {m.pin_material}; crankshaft: "
        f"{m.shaft_material}",
        f"# pin sizing: the larger of single shear, d = sqrt(4 F SF / (pi tau)), tau = allowable shear stress of "
        f"the pin {m.pin_shear:g} MPa, and bearing in one part, d = F SF / (t f_h), t = {m.thickness:g} mm, f_h = "
        f"bearing strength of the {m.name} {m.bearing:g} MPa; SF = safety factor {m.safety_factor:g}; rounded up "
        f"to the next of {', '.join(n for n, _ in STANDARD_PINS)}",
        f"# crankshaft sizing: d = cbrt(16 SF sqrt(M^2 + T^2) / (pi tau)) + the flat, tau = {m.shaft_shear:g} MPa, T = "
        f"the peak motor torque, M = the crank pin's peak reaction times its distance from the nearest bushing; "
        f"same SF",
        ("# F = the joint's peak reaction from the forces (force_N); required_d_mm = the d it needs; a pin is "
         "never smaller than the default size, the standard size nearest a tenth of the crank radius (stiffness)"
         if forces else "# no joint forces were computed for this design: every pin is the default size "
                        "(the standard size nearest a tenth of the crank radius), not sized from a load"),
        f"# pin length = stack of layers x {m.thickness:g} mm + a {WASHER:g} mm washer between layers + one "
        f"diameter + {SPARE:g} mm (lock nut), rounded up to a whole mm",
    ] + [f"# NOTE: {n}" for n in kit.notes]
    buf = io.StringIO()
    rows = bom_rows(data)
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    return "\n".join(head) + "\n" + buf.getvalue()


def readme_text(kit: Kit, pdf: bool) -> str:
    """``README.txt`` of the kit folder (see :func:`write_kit`)."""
    m = kit.material
    mech = kit.mechanism
    legs = kit.legs
    sh, ch = kit.shaft, kit.chassis
    crank = next(p for p in kit.parts if p.kind == "crank")
    lines = [
        f"Build kit: {mech.name}" + (f" ({mech.description})" if mech.description else ""),
        f"Design: {kit.source}",
        "",
        f"Scale: 1 model unit = {kit.scale:.6g} mm (the crank is {math.dist(*crank.holes[:2]):.4g} mm from the shaft "
        f"to its pin).",
        f"Material: parts cut from {m.thickness:g} mm {m.name}, links {kit.width:.3g} mm wide; pins {m.pin_material}; "
        f"crankshaft {m.shaft_material}.",
        f"Sheets: {kit.sheets} of {kit.sheet_size[0]:g} x {kit.sheet_size[1]:g} mm.",
        "",
        f"Clearance: {clearance_line(kit)}. Every part keeps that clearance from every pin, spacer, head, nut and the "
        f"crankshaft on its layer, and from the other parts of its layer, over the whole turn.",
        "",
        "Files",
        "  kit.json    the kit as data: every part copy with its holes (joint, position in the part's frame, diameter),",
        "              every pin and the shaft (layers bottom to top, diameter, length), the crank arrangement, the",
        "              chassis, the clearances checked, the scale and the design's parameters. The other files are",
        "              made from it.",
        "  parts.svg   every part to cut, once per copy, nested on the sheets (side by side, 1 unit = 1 mm).",
        "              Layer 'cut' (red hairlines): outlines and pin holes (a D-hole for the crankshaft in each",
        "              crank arm). Layer 'engrave' (blue): each hole's joint name, each part's name and copy number",
        "              (M = a mirrored copy), a 50 mm scale bar and the sheet's title. Grey: the sheets' edges.",
        "  parts.dxf   the same in DXF (mm): layers CUT, ENGRAVE and SHEET; round holes are CIRCLEs at their exact",
        "              centres, a D-hole a closed polyline; each copy's entities form a group named after it",
        "              (\"2-6 #3\", \"leg #2 M\").",
        "  bom.csv     bill of materials: parts, pins, spacers, washers, retainers, the crankshaft, bushings,",
        "              the coupler, standoffs and nuts, the motor.",
        ("  assembly.pdf  assembly drawings: the leg at crank angle 0 with every joint and the stack order on\n"
         "              each pin; the crankshaft and the chassis from the side (the legs' order along the shaft,\n"
         "              the throws, the plates and standoffs); the motor plate; one page per part."
         if pdf else "  (assembly.pdf is not part of this kit: this explorer has no assembly drawing writer)"),
        "  README.txt  this file.",
        "",
        "Before cutting: check the scale bar measures 50 mm on the cut sheet. The holes are drawn at the pins'",
        "diameters: add your cutter's kerf allowance for a snug fit (and a running fit where a part turns).",
        "",
        "Copies: every part is cut once per leg (copy k belongs to leg k); one frame plate per leg. A part that",
        "is not its own mirror image (a frame or body with holes not in a line) is cut mirrored (marked M) for",
        "the mirrored legs. Crank arm copy k is leg k's: its D-hole is turned by the leg's crank phase, so all",
        "slide onto the shaft's one flat (engraved face away from the frame plate) and point at their phases.",
        "",
        f"Crankshaft: {sh.diameter:g} mm {m.shaft_material} with a {sh.flat:g} mm deep D-flat along it; " + {
            "through": "one straight rod through every leg's frame plate (a bushing) and crank arm.",
            "outboard": "it ends at the crank arm, outboard of the parts on layers below it; the parts on the "
                        "crank pin turn beyond its end.",
            "throws": "a crank with throws: in every leg an inner and an outer crank web with the crank pin between "
                      "them (the parts on the crank pin turn there, where there is no shaft); the shaft is cut into "
                      f"{len(sh.segments)} pieces that join the webs.",
        }[sh.mode],
    ]
    if sh.torque is not None:
        lines.append(f"  sized for the peak motor torque {sh.torque:.3g} N·m and {sh.bending:.3g} N·m of bending (the "
                     f"crank pin's {sh.arm_force:.4g} N at {sh.arm:.3g} mm from the nearest bushing): it needs "
                     f"{sh.required:.3g} mm, the flat included.")
    else:
        lines.append("  not sized from a load (no forces for this design): the standard size nearest a fifth of the "
                     "crank radius.")
    lines += ["",
              "Legs along the shaft, from the motor's end (crank phase: the direction of each leg's crank arm, degrees",
              "counter-clockwise from +x in the drawing of the design, when the crank of leg 1 points along +x):"]
    for leg in sorted(legs, key=lambda lg: lg.z):
        lines.append(f"  leg {leg.index + 1}: crank at {leg.phase_deg:6.1f} deg, arm {leg.crank}, frame plate at "
                     f"z = {leg.z:.1f} mm" + ("  mirrored (its parts marked M where not symmetric)" if leg.mirrored
                                              else ""))
    if any(leg.mirrored for leg in legs):
        lines.append("A mirrored leg is the mirror image of the drawing about the vertical through the shaft; its "
                     "crank arm sits at the same phase.")
    lines += ["", "Chassis: the motor plate, every leg's frame plate" + ("" if sh.mode == "outboard" else
                                                                          " and the end plate")
              + f" on {len(ch.standoffs)} standoffs ({ch.standoff_d:g} mm threaded rod, {ch.standoff_length:g} mm, a nut "
              f"each side of each plate) at " + ", ".join(f"({x:.1f}, {y:.1f})" for _, x, y in ch.standoffs)
              + " mm from the shaft, where no part passes; the motor "
              f"({ch.motor_shaft:g} mm shaft, {ch.motor_holes[0]} holes of {ch.motor_holes[1]:g} mm on a "
              f"{ch.motor_holes[2]:g} mm circle) on the motor plate, a coupler to the crankshaft."]
    lines += ["", "Stack order (layer 0 = the frame plate, the motor's side; parts of one layer never touch):"]
    for n, k in sorted(kit.layers.items(), key=lambda t: (t[1], t[0])):
        lines.append(f"  layer {k}: {n}")
    lines += ["Pins, bottom to top (see bom.csv for diameters and lengths; a spacer on every layer of a pin's",
              "span that it carries no part on):"]
    for pin in kit.pins:
        if pin.kind == "standoff":
            continue
        lines.append(f"  {pin.joint}: {' / '.join(pin.stack)}" + (f"  (spacers at {', '.join(map(str, pin.spacers))})"
                                                                 if pin.spacers else ""))
    forces = any(p.force is not None for p in kit.pins)
    lines += ["",
              f"Pins: the larger of single shear, d = sqrt(4 F SF / (pi tau)) with the allowable shear stress of the "
              f"pin tau = {m.pin_shear:g} MPa ({m.pin_material}), and bearing in one {m.thickness:g} mm part, d = F SF "
              f"/ (t f_h) with the {m.name}'s bearing strength f_h = {m.bearing:g} MPa; safety factor SF = "
              f"{m.safety_factor:g}; rounded up to a standard size. " + (
                  "F is each joint's peak reaction; no pin is smaller than the default size, the standard size nearest "
                  "a tenth of the crank radius (stiffness and handling)." if forces else
                  "No joint forces were computed for this design: every pin is the default, the standard size "
                  "nearest a tenth of the crank radius.")]
    if kit.notes:
        lines += ["", "Notes:"] + [f"  {n}" for n in kit.notes]
    lines += ["",
              "Tolerance: " + (kit.tolerance_note or "not computed; `explorer tolerance MECHANISM` finds the spread "
                               "the design takes."),
              "",
              "Made by:"]
    lines += [f"  {c}" for c in kit.commands] or ["  explorer.fabrication.write_kit (from Python)"]
    return "\n".join(lines) + "\n"


def _pdf_writer():
    try:
        from ._kit_pdf import write_assembly_pdf
    except ImportError:
        return None
    return write_assembly_pdf


def write_kit(kit: Kit, folder, force: bool = False) -> list[Path]:
    """Write the kit folder ``folder``: kit.json, parts.svg, parts.dxf, bom.csv, README.txt, and assembly.pdf
    where :mod:`explorer.fabrication._kit_pdf` exists. The folder (and its parents) is created if missing; a file of
    the kit already there is kept (UserError naming it) unless ``force``. Everything is written to a
    temporary folder first and moved into place at the end: a failure leaves nothing half-written.
    Returns the paths written."""
    import json
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
    texts = {"kit.json": json.dumps(kit_data(kit), indent=1, ensure_ascii=False) + "\n", "parts.svg": svg_text(kit),
             "bom.csv": bom_text(kit), "README.txt": readme_text(kit, pdf is not None)}
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
