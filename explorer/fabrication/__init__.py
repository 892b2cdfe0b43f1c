"""Fabrication: what leaves the program to be made or read elsewhere, for one design.

The export-format registry (:mod:`explorer.fabrication._exports`): ``EXPORTS``, ``register_export``,
``export_variant`` — what ``explorer export`` can write; the command line builds ``--as``'s choices and
help from it, and each format's writer imports its code when it runs.

Exports of one design (:mod:`explorer.fabrication._export`): ``export_svg(mech, "parts.svg")`` and
``export_dxf(mech, "parts.dxf")`` (its parts laid out for cutting, mm), ``export_csv(results, variant,
"paths.csv")`` (its stored trajectories), ``mechanism_toml(mech)`` / ``export_toml(mech, "leg.toml")`` (a
mechanism file that ``load_mechanism`` reads back), ``variant_design(results, variant)`` (the Mechanism
of one variant, as written).

Build kit of one design (:mod:`explorer.fabrication._kit`): ``write_kit(build_kit(mech, crank_mm=30),
"kit/")`` — kit.json (the kit as data, ``kit_data(kit)``), parts.svg / parts.dxf (every part once per leg,
nested on sheets, labelled), bom.csv, README.txt and assembly.pdf; a stack that keeps every part clear of
every pin, spacer and the crankshaft over the turn (``_kit_stack``), crank arms on a D-flat at the legs'
phases, a standoff chassis (``_kit_chassis``), the sheets (``_kit_sheet``) and the assembly PDF
(``_kit_pdf``).

It sits after :mod:`explorer.study` and :mod:`explorer.analysis` (a kit notes its design's yield) and
before :mod:`explorer.view`, which re-exported these names until issue 40 and still forwards them for one
release.
"""

from ._export import (Sheet, cut_sheet, export_csv, export_dxf, export_svg, export_toml, mechanism_toml,
                      trajectory_frame, variant_design)
from ._exports import (EXPORT_FORMATS, EXPORTS, ExportFormat, ExportJob, export_design, export_format, export_variant,
                       register_export)
from ._kit import (MOTOR_SHAFT, Kit, KitLeg, KitPart, KitPin, Material, Placement, build_kit, design_yield_note,
                   kit_data, pin_diameter, shaft_diameter, write_kit)
from ._kit_chassis import motor_pattern

__all__ = ["EXPORTS", "EXPORT_FORMATS", "ExportFormat", "ExportJob", "export_design", "export_format", "export_variant",
           "register_export", "Sheet", "cut_sheet", "export_csv", "export_dxf", "export_svg", "export_toml",
           "mechanism_toml", "trajectory_frame", "variant_design", "MOTOR_SHAFT", "Kit", "KitLeg", "KitPart",
           "KitPin", "Material", "Placement", "build_kit", "design_yield_note", "kit_data", "pin_diameter",
           "shaft_diameter", "write_kit", "motor_pattern"]
