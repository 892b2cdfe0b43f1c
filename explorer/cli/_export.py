"""``explorer export RESULTS --variant N -o PATH [--as svg|dxf|csv|toml]``: one design, to cut, to plot or to
run again; ``explorer export RESULTS --variant N --as kit -o DIR`` (or ``explorer export MECHANISM --as kit
-o DIR``): its build kit, a folder of cut sheets, a bill of materials and a README (issue 27)."""

from __future__ import annotations



def register(sub) -> None:
    from ..fabrication import EXPORTS
    from ._args import add_old, add_old_positional_variant, add_output, add_variant

    alone = ", ".join(n for n, f in EXPORTS.items() if not f.needs_results)  # the formats that take a design alone
    p = sub.add_parser(
        "export", help="export one variant: its parts for a laser cutter (SVG, DXF), its trajectories (CSV), or "
                       "its design as a mechanism file (TOML)",
        description="Export one variant of a results file. svg, dxf: the design's parts laid out for cutting, each "
                    "by itself (frame, crank, links, rigid bodies) as an outline with a pin hole at each joint and "
                    "its name as a label, in mm (1 model unit = --scale mm, default 1). csv: the variant's stored "
                    "trajectories, one row per sample: theta (rad; t in s for a path driver), then V.x, V.y (and "
                    "V.vx, V.vy / V.ax, V.ay when stored) of each stored vertex, the foot first. toml: the design "
                    "as a mechanism file (`explorer run`, `explorer.load_mechanism`), its guess at the variant's "
                    "own positions at the first sample. A failed variant exports as svg, dxf and toml (its design "
                    "exists) but not as csv (it has no full path). kit: a folder DIR for a laser cutter and a "
                    "workbench, a machine that turns: every part keeps --clearance from every pin, spacer, nut and "
                    "the crankshaft on its layer over the whole turn (a crank with throws where parts cross the "
                    "shaft's axis); kit.json (the kit as data), parts.svg and parts.dxf (every part once per leg, "
                    "mirrored copies marked M, crank arms with a D-hole at their leg's phase, frame, motor and end "
                    "plates on standoffs, nested on --sheet sheets), bom.csv (made from kit.json: pins and the "
                    "crankshaft sized from the forces of the parts cut, spacers, bushings, standoffs, the motor), "
                    "assembly.pdf, README.txt (scale, material, the worst clearance, the command); the size and "
                    "the material come from the design's [build] table, else a 30 mm crank (--crank-mm or --scale) "
                    f"and 3 mm plywood. {alone} also take a design alone: RESULTS may then be a "
                    "mechanism (a built-in name or a .toml) with no VARIANT. "
                    "An existing PATH (or a kit's file in DIR) is never replaced without --force; missing folders "
                    "are created.")
    p.add_argument("results", metavar="RESULTS",
                   help=f"results file (.h5) written by `explorer run`; for {alone} also a "
                        "mechanism (built-in name or .toml)")
    add_variant(p, "the variant of RESULTS to export, 0 to N-1 (0 = the nominal design)")
    add_old_positional_variant(p)
    p.add_argument("--as", dest="fmt", choices=tuple(EXPORTS), default=None, metavar="FORMAT",
                   help="what to write (default: from the extension of -o): " + "; ".join(
                       f"{f.name}: {f.help}" + (f" ({f.extension})" if f.extension else " (a folder)")
                       for f in EXPORTS.values()))
    add_old(p, "--format", "--as {}", dest="fmt")
    add_output(p, "the file to write (a folder for a format that writes one, such as kit)", required=True)
    p.add_argument("--scale", default=None, metavar="MM",
                   help="svg, dxf, kit: millimetres per model unit (default: 1, one model unit = 1 mm; kit: the "
                        "design's [build] unit, else the scale that makes the crank --crank-mm; not with --crank-mm)")
    p.add_argument("--width", default=None, metavar="MM",
                   help="width of every part, mm (svg, dxf default: 20 %% of the shortest distance between two "
                        "holes of one part: the crank radius or the shortest link, usually; kit: the design's [build] "
                        "part_width, else 3 pin diameters)")
    p.add_argument("--hole", default=None, metavar="MM",
                   help="svg, dxf, kit: diameter of the pin holes, mm (default: 40 %% of the part width; kit: every "
                        "pin sized from its joint's force, else M3 at a 30 mm crank, scaled; a kit refuses a hole "
                        "below what a force needs unless --undersized)")
    p.add_argument("--thickness", default=None, metavar="MM",
                   help="kit: the thickness of the sheet the parts are cut from, mm (default: the design's [build] "
                        "thickness, else 3); one stack layer, and the bearing length that sizes a pin")
    p.add_argument("--crank-mm", dest="crank_mm", default=None, metavar="MM",
                   help="kit: the crank radius of the build, mm (default 30 where the design states no size; sets "
                        "the scale; not with --scale)")
    p.add_argument("--sheet", default=None, metavar="WxH",
                   help="kit: the size of the sheets to cut from, mm, each side at most 5000 (default 600x400)")
    p.add_argument("--motor-shaft", dest="motor_shaft", default=None, metavar="MM",
                   help="kit: the gearmotor's shaft diameter, mm (default 6: a 37 mm metal gearmotor); smaller than "
                        "the crank")
    p.add_argument("--motor-holes", dest="motor_holes", default=None, metavar="NxD@PCD",
                   help="kit: the motor's mounting holes: count x size @ pitch circle, mm (default 6xM3@31)")
    p.add_argument("--clearance", default=None, metavar="MM",
                   help="kit: the running clearance every part keeps from every pin, spacer, nut, the shaft and "
                        "the parts of its layer over the whole turn, mm (default 1)")
    p.add_argument("--plates", action="store_true",
                   help="kit: cut every rigid triangle of links (three links pinned into a triangle, as Jansen's "
                        "2-3-4 and 5-6-7) as one plate")
    p.add_argument("--undersized", action="store_true",
                   help="kit: cut a --hole below what a joint's force needs (the kit says so in README.txt and "
                        "bom.csv)")
    p.set_defaults(func=run)


def parse_sheet(text) -> tuple[float, float]:
    """``--sheet WxH`` (mm) → (W, H)."""
    import math

    from ..errors import UserError
    parts = str(text).lower().replace("×", "x").split("x")
    try:
        W, H = (float(parts[0]), float(parts[1])) if len(parts) == 2 else (math.nan, math.nan)
    except ValueError:
        W = H = math.nan
    if not (math.isfinite(W) and math.isfinite(H) and 0 < W <= 5000 and 0 < H <= 5000):
        raise UserError(f"--sheet: expected WIDTHxHEIGHT in mm such as 600x400, each side > 0 and at most 5000, "
                        f"got {text!r}")
    return W, H


#: The kit's size options: (option, attribute, highest, what): one-line errors naming the option and value.
KIT_SIZES = (("--scale", "scale", 1e9, "mm per model unit"), ("--crank-mm", "crank_mm", 5000.0, "the crank radius in mm"),
             ("--width", "width", 1000.0, "the part width in mm"), ("--hole", "hole", 100.0, "the pin diameter in mm"),
             ("--thickness", "thickness", 100.0, "the sheet thickness in mm"),
             ("--motor-shaft", "motor_shaft", 100.0, "the motor's shaft diameter in mm"),
             ("--clearance", "clearance", 100.0, "the running clearance in mm"))


def parse_mm(option: str, text, hi: float, what: str) -> float | None:
    """A size option's text → a finite number in (0, hi], or a one-line UserError naming the option and value."""
    import math

    from ..errors import UserError
    if text is None:
        return None
    try:
        v = float(str(text).strip())
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and 0 < v <= hi):
        raise UserError(f"{option}: expected {what}, a number > 0 and at most {hi:g}, got {text!r}")
    return v


def _kit_command(args, chosen) -> str:
    import shlex
    words = ["explorer", "export", args.results] + (["--variant", str(chosen)] if chosen is not None else [])
    words += ["--as", "kit", "-o", str(args.output)]
    for opt, val in (("--sheet", args.sheet), ("--crank-mm", args.crank_mm), ("--thickness", args.thickness),
                     ("--scale", args.scale), ("--width", args.width), ("--hole", args.hole),
                     ("--motor-shaft", args.motor_shaft), ("--motor-holes", args.motor_holes),
                     ("--clearance", args.clearance)):
        if val is not None:
            words += [opt, str(val)]
    words += [f for f, on in (("--plates", args.plates), ("--undersized", args.undersized)) if on]
    return " ".join(shlex.quote(w) for w in words)


def kit_options(args) -> dict:
    """Every kit option checked (one line naming the option and the value, before anything is read or written)."""
    from ..errors import UserError
    from ..fabrication import motor_pattern
    out = {attr: parse_mm(opt, getattr(args, attr), hi, what) for opt, attr, hi, what in KIT_SIZES}
    if out["scale"] is not None and out["crank_mm"] is not None:
        raise UserError(f"--scale {args.scale} and --crank-mm {args.crank_mm}: each sets the build's size; give one")
    out["sheet"] = parse_sheet(args.sheet) if args.sheet is not None else (600.0, 400.0)
    if args.motor_holes is not None:
        from ..fabrication import MOTOR_SHAFT
        motor_pattern(args.motor_holes, MOTOR_SHAFT if out["motor_shaft"] is None else out["motor_shaft"])
    if args.undersized and out["hole"] is None:
        raise UserError("--undersized: it goes with --hole (a pin diameter below what a joint's force needs)")
    return out


def run(args) -> int:
    from ..fabrication import EXPORTS, export_format, export_variant
    from ._args import chosen_variant

    fmt = export_format(args.fmt, args.output)
    options = kit_options(args) if fmt.name == "kit" else {}
    sheet = {"scale": parse_mm("--scale", args.scale, 1e9, "mm per model unit"),
             "width": parse_mm("--width", args.width, 1000.0, "the part width in mm"),
             "hole": parse_mm("--hole", args.hole, 100.0, "the hole diameter in mm")}
    given = {**sheet, "sheet": args.sheet, "crank_mm": args.crank_mm, "thickness": args.thickness,
             "motor_shaft": args.motor_shaft, "motor_holes": args.motor_holes, "clearance": args.clearance,
             "plates": args.plates, "undersized": args.undersized}
    options = {**{k: v for k, v in given.items() if k in EXPORTS[fmt.name].options or v not in (None, False)},
               **options}
    variant = None
    if args.variant is not None or args.old_variant is not None:
        variant = chosen_variant(args, "export", "explorer export RESULTS --variant N -o PATH")
    print(export_variant(args.results, variant, args.output, as_=fmt.name, force=args.force, options=options,
                         command=_kit_command(args, variant) if fmt.name == "kit" else ""))
    return 0
