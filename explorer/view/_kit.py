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

from dataclasses import dataclass

from ..mechanism import Mechanism, Walker


@dataclass(frozen=True)
class Material:
    """What the parts and pins are made of (stated in bom.csv and README.txt).

    name : the sheet material of the parts; thickness : its thickness, mm (one stack layer).
    pin_material : what the pins are; pin_shear : its allowable shear stress, MPa (default 140 MPa:
    the shear strength of S235 structural steel, ≈ 0.6 × 235 MPa); safety_factor : applied to the peak
    joint force when a pin is sized from it.
    """

    name: str = "birch plywood"
    thickness: float = 3.0
    pin_material: str = "steel (S235)"
    pin_shear: float = 140.0
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


def build_kit(design: Mechanism, *, crank_mm: float = 30.0, scale: float | None = None, width: float | None = None,
              hole: float | None = None, sheet: tuple[float, float] = (600.0, 400.0), material: Material = Material(),
              forces: dict[str, float] | None = None, source: str = "", commands=(),
              tolerance_note: str | None = None) -> Kit:
    """The build kit of ``design`` (being written; see the module docstring)."""
    raise NotImplementedError


def write_kit(kit: Kit, folder, force: bool = False) -> list:
    """Write the kit folder (being written; see the module docstring)."""
    raise NotImplementedError
