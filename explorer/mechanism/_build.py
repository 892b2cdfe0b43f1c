"""The ``[build]`` table: how a design is made (issue 37). One build, as data: the sheet the parts are cut
from, how wide they are, what the pins and the crankshaft are, and the machine's size.

In a mechanism file (the design's build) or a study (over the mechanism's, key by key)::

    [build]
    material = "birch plywood"   # the sheet the parts are cut from (SHEET_MATERIALS)
    thickness = 9.0              # mm: one stack layer
    part_width = 30.0            # mm: the width of every link
    density = 680.0              # kg/m³ (default: the material's)
    unit = 0.01                  # metres per model unit (as [operating] unit): the machine's size
    pin_material = "steel (S235)"     # PIN_MATERIALS
    shaft_material = "steel (S235)"

Every key is optional. The link masses of the forces effect come from it when links have no ``mass`` of
their own and the file gives no ``[mass] link_density``: density × thickness × part_width, kg per metre
of link (:meth:`Build.link_density`). The build kit (``explorer export --as kit``) takes its defaults
from it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

from ..errors import UserError, where

#: Keys of a [build] table.
BUILD_KEYS = ("material", "thickness", "part_width", "density", "unit", "pin_material", "shaft_material")


@dataclass(frozen=True)
class SheetMaterial:
    """A sheet the parts are cut from: density, kg/m³; bearing (embedment) strength against a pin, MPa;
    where the figure comes from."""

    density: float
    bearing: float
    note: str


@dataclass(frozen=True)
class RodMaterial:
    """What the pins or the crankshaft are made of: the allowable shear stress, MPa (0.6 × the yield
    strength, the shear yield by von Mises' 1/√3 ≈ 0.58, rounded up as usual), and its source."""

    shear: float
    note: str


#: The sheet materials a build may name (case does not matter).
SHEET_MATERIALS = {
    "birch plywood": SheetMaterial(680.0, 60.0, "EN 1995-1-1 8.5.1: f_h = 0.11·ρ_k, ρ_k ≈ 600 kg/m³, the "
                                                "small-diameter limit"),
    "poplar plywood": SheetMaterial(450.0, 40.0, "EN 1995-1-1 8.5.1: f_h = 0.11·ρ_k, ρ_k ≈ 380 kg/m³"),
    "aluminium 5052": SheetMaterial(2680.0, 190.0, "EN 573 5052-H32: the yield strength, 193 MPa (no "
                                                   "bearing bonus)"),
}
#: The pin and shaft materials a build may name (case does not matter; "steel" is S235).
PIN_MATERIALS = {
    "steel (S235)": RodMaterial(140.0, "EN 10025 S235: 0.6 × 235 MPa"),
    "steel (8.8)": RodMaterial(384.0, "ISO 898-1 property class 8.8: 0.6 × 640 MPa"),
    "stainless (A2-70)": RodMaterial(270.0, "ISO 3506 A2-70: 0.6 × 450 MPa"),
    "aluminium (6061-T6)": RodMaterial(165.0, "EN 573 6061-T6: 0.6 × 276 MPa"),
}
_ALIASES = {"steel": "steel (S235)"}
#: The kit's defaults where neither the design nor the command line says.
DEFAULT_MATERIAL = "birch plywood"
DEFAULT_THICKNESS = 3.0
DEFAULT_PIN_MATERIAL = "steel (S235)"
#: Bounds of the [build] numbers: (lowest, exclusive, highest, what).
_RULES = {
    "thickness": (0.0, 100.0, "the sheet thickness in mm, a number > 0"),
    "part_width": (0.0, 1000.0, "the width of the parts in mm, a number > 0"),
    "density": (0.0, 30000.0, "the sheet's density in kg/m³, a number > 0"),
    "unit": (0.0, 1e6, "metres per model unit, a number > 0 (0.01 for a design in centimetres)"),
}


def _name(table: dict, choice: str) -> str:
    low = {k.lower(): k for k in table}
    c = str(choice).strip().lower()
    c = _ALIASES.get(c, c).lower()
    return low.get(c, "")


def sheet_material(name: str) -> SheetMaterial:
    """The :class:`SheetMaterial` called ``name`` (KeyError if unknown)."""
    return SHEET_MATERIALS[_name(SHEET_MATERIALS, name) or name]


def rod_material(name: str) -> RodMaterial:
    """The :class:`RodMaterial` called ``name`` (KeyError if unknown)."""
    return PIN_MATERIALS[_name(PIN_MATERIALS, name) or name]


@dataclass(frozen=True)
class Build:
    """A validated ``[build]`` table (see the module docstring); None where a key is not given.

    material : a key of :data:`SHEET_MATERIALS`; thickness, part_width : mm; density : kg/m³; unit :
    metres per model unit; pin_material, shaft_material : keys of :data:`PIN_MATERIALS`.
    """

    material: str | None = None
    thickness: float | None = None
    part_width: float | None = None
    density: float | None = None
    unit: float | None = None
    pin_material: str | None = None
    shaft_material: str | None = None

    def sheet_density(self) -> float | None:
        """kg/m³: ``density``, else the material's, else None."""
        if self.density is not None:
            return self.density
        return sheet_material(self.material).density if self.material is not None else None

    def link_density(self) -> float | None:
        """kg per metre of link: density × thickness × part_width (mm → m), None unless all three are known."""
        rho = self.sheet_density()
        if rho is None or self.thickness is None or self.part_width is None:
            return None
        return rho * self.thickness * self.part_width / 1e6

    def over(self, base: "Build | None") -> "Build":
        """This build's keys over ``base``'s (the study over the mechanism)."""
        if base is None:
            return self
        return replace(base, **{f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None})

    def as_dict(self) -> dict:
        """The TOML shape (keys not given are left out)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}


def build_from_dict(table, source: str, key: str = "build", base: Build | None = None) -> Build:
    """Validate a ``[build]`` table (keys :data:`BUILD_KEYS`) into a :class:`Build` over ``base``; a one-line
    UserError naming the file, the key and the value for anything else."""
    if not isinstance(table, dict):
        raise UserError(f"{where(source, key)}: expected a table [{key}], got {table!r}")
    for k in table:
        if k not in BUILD_KEYS:
            raise UserError(f"{where(source, f'{key}.{k}')}: unknown key (allowed: {', '.join(BUILD_KEYS)})")
    out = {}
    for k, choices in (("material", SHEET_MATERIALS), ("pin_material", PIN_MATERIALS),
                       ("shaft_material", PIN_MATERIALS)):
        if k in table:
            v = table[k]
            name = _name(choices, v) if isinstance(v, str) else ""
            if not name:
                raise UserError(f"{where(source, f'{key}.{k}')}: expected one of {', '.join(repr(c) for c in choices)}, "
                                f"got {v!r}")
            out[k] = name
    from ._model import bounded_number
    for k, (lo, hi, what) in _RULES.items():
        if k in table:
            out[k] = bounded_number(source, f"{key}.{k}", table[k], lo, False, hi, what)
    return Build(**out).over(base)


def derived_link_density(mech) -> bool:
    """Whether ``mech.link_density`` is its build's (density × thickness × part_width), not a [mass] table's."""
    b = mech.build
    ld = b.link_density() if b is not None else None
    return ld is not None and mech.link_density is not None and math.isclose(ld, mech.link_density, rel_tol=1e-12)


def apply_build(mech, build: Build | None, source: str, key: str = "build", explicit_density: float | None = None):
    """``mech`` with ``build`` as its build: its link density from the build where it gives one (a UserError if
    the mechanism's own ``[mass] link_density`` says otherwise), its operating unit from ``build.unit`` where
    the mechanism gives none (a UserError if it gives another). ``explicit_density``: the [mass] link_density
    the file gives (None: the mechanism's, when it is not its old build's)."""
    if build is None:
        return mech
    if explicit_density is None and mech.link_density is not None and not derived_link_density(mech):
        explicit_density = mech.link_density
    ld = build.link_density()
    density = mech.link_density if not derived_link_density(mech) else None
    if ld is not None:
        if explicit_density is not None and not math.isclose(ld, explicit_density, rel_tol=1e-6):
            raise UserError(f"{where(source, key)}: density × thickness × part_width = {ld:.6g} kg per metre of link, "
                            f"but [mass] link_density = {explicit_density:.6g}: give one of them (the build's parts "
                            f"are the links the forces weigh)")
        density = ld
    elif explicit_density is not None:
        density = explicit_density
    op = mech.operating
    if build.unit is not None:
        if op is not None and op.unit is not None and not math.isclose(op.unit, build.unit, rel_tol=1e-12):
            raise UserError(f"{where(source, key + '.unit')}: {build.unit:g} m per model unit, but [operating] unit = "
                            f"{op.unit:g}: one machine has one size (give it once)")
        from ._model import Operating
        op = replace(op or Operating(), unit=build.unit)
    return replace(mech, build=build, link_density=density, operating=op)
