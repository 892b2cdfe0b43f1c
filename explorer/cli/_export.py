"""``explorer export RESULTS VARIANT --format svg|dxf|csv|toml -o PATH``: one design, to cut, to plot or to
run again; ``explorer export RESULTS VARIANT --format kit -o DIR`` (or ``explorer export MECHANISM --format kit
-o DIR``): its build kit, a folder of cut sheets, a bill of materials and a README (issue 27)."""

from __future__ import annotations

import os
from pathlib import Path


def register(sub) -> None:
    from ._args import add_variant_arguments

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
                    "and 3 mm plywood; RESULTS may then also be a mechanism (a built-in name or a .toml) with no "
                    "VARIANT. "
                    "An existing PATH (or a kit's file in DIR) is never replaced without --force; missing folders "
                    "are created.")
    p.add_argument("results", metavar="RESULTS",
                   help="results file (.h5) written by `explorer run`; with --format kit also a mechanism (built-in "
                        "name or .toml)")
    add_variant_arguments(p, "as `explorer show --variant` takes it")
    p.add_argument("--format", dest="fmt", choices=("svg", "dxf", "csv", "toml", "kit"), default=None,
                   help="what to write (default: from the extension of -o; kit: a folder)")
    p.add_argument("-o", "--output", metavar="PATH", required=True, help="the file to write (kit: the folder)")
    p.add_argument("--force", action="store_true", help="overwrite PATH if it exists (never done without it)")
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


def _format(args) -> str:
    from ..errors import UserError
    from ..view import EXPORT_FORMATS
    ext = Path(args.output).suffix.lower()
    by_ext = {e: f for f, e in EXPORT_FORMATS.items()}
    if args.fmt is None:
        if ext not in by_ext:
            raise UserError(f"{args.output}: say what to write with --format svg|dxf|csv|toml|kit (the extension "
                            f"{Path(args.output).suffix or '(none)'!r} does not say)")
        return by_ext[ext]
    if ext in by_ext and by_ext[ext] != args.fmt:
        raise UserError(f"{args.output}: --format {args.fmt} into a {ext} file; name it {EXPORT_FORMATS[args.fmt]} "
                        f"or drop --format")
    return args.fmt


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


def _is_results(path) -> bool:
    p = Path(path)
    if not p.is_file():
        return False
    with open(p, "rb") as fh:
        return fh.read(8) == b"\x89HDF\r\n\x1a\n"


def _variant_forces(res, v: int) -> dict[str, float]:
    """{joint: peak reaction, N} of variant v: its ``pin_force.<joint>`` metrics, else the peak magnitude of
    the stored ``/forces/<joint>``."""
    import math

    import numpy as np

    from ..store import variant_row
    row = variant_row(res, v)
    out = {}
    for col, val in row.items():
        if str(col).startswith("pin_force."):
            try:
                f = float(val)
            except (TypeError, ValueError):
                continue
            if math.isfinite(f):
                out[str(col)[len("pin_force."):]] = f
    if not out:
        for j in res.force_joints:
            a = np.asarray(res.force(v, j), dtype=np.float64)
            m = np.hypot(a[:, 0], a[:, 1])
            if np.any(np.isfinite(m)):
                out[j] = float(np.nanmax(m))
    return out


def _kit_command(args, chosen) -> str:
    import shlex
    words = ["explorer", "export", args.results] + ([str(chosen)] if chosen is not None else [])
    words += ["--format", "kit", "-o", str(args.output)]
    for opt, val in (("--sheet", args.sheet), ("--crank-mm", args.crank_mm), ("--thickness", args.thickness),
                     ("--scale", args.scale), ("--width", args.width), ("--hole", args.hole),
                     ("--motor-shaft", args.motor_shaft), ("--motor-holes", args.motor_holes),
                     ("--clearance", args.clearance)):
        if val is not None:
            words += [opt, str(val)]
    words += [f for f, on in (("--plates", args.plates), ("--undersized", args.undersized)) if on]
    return " ".join(shlex.quote(w) for w in words)


def _variant_torque(res, v: int) -> float | None:
    """The variant's stored motor_torque_peak (N·m), or None."""
    import math

    from ..store import variant_row
    row = variant_row(res, v)
    try:
        f = float(row.get("motor_torque_peak")) if "motor_torque_peak" in row.index else math.nan
    except (TypeError, ValueError):
        f = math.nan
    return f if math.isfinite(f) else None


def kit_options(args) -> dict:
    """Every kit option checked (one line naming the option and the value, before anything is read or written)."""
    from ..errors import UserError
    from ..view._kit_chassis import motor_pattern
    out = {attr: parse_mm(opt, getattr(args, attr), hi, what) for opt, attr, hi, what in KIT_SIZES}
    if out["scale"] is not None and out["crank_mm"] is not None:
        raise UserError(f"--scale {args.scale} and --crank-mm {args.crank_mm}: each sets the build's size; give one")
    out["sheet"] = parse_sheet(args.sheet) if args.sheet is not None else (600.0, 400.0)
    if args.motor_holes is not None:
        from ..view._kit import MOTOR_SHAFT
        motor_pattern(args.motor_holes, MOTOR_SHAFT if out["motor_shaft"] is None else out["motor_shaft"])
    if args.undersized and out["hole"] is None:
        raise UserError("--undersized: it goes with --hole (a pin diameter below what a joint's force needs)")
    return out


def run_kit(args) -> int:
    """``--format kit``: the build kit of a variant of a results file, or of a mechanism."""
    import math

    from ..errors import UserError
    from ..mechanism import load_mechanism
    from ..view import build_kit, design_yield_note, write_kit
    from ..view._kit import kit_loads, material_of

    opts = kit_options(args)
    sheet = opts["sheet"]
    out = Path(args.output)
    if not str(args.output).strip():
        raise UserError(f"-o: expected a folder name, got {str(args.output)!r}")
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: cannot write the kit: it is a file, not a folder")
    if out.is_dir():  # the kit's files already there: the verbs' one policy, each (before any work)
        from ..view._kit import KIT_FILES
        from ._args import output_path
        for name in KIT_FILES:
            if os.path.lexists(out / name):
                output_path(out / name, args.force, protect=[args.results])
    chosen = args.variant if args.variant is not None else args.variant_opt
    stored: dict[str, float] = {}
    stored_torque = None
    note = ""
    tolerance_note = None
    study_unit = None
    if _is_results(args.results):
        from ..store import FILE_STATUS_NAMES, open_results, variant_row
        from ..view import variant_design
        from ._args import chosen_variant, parse_variant
        chosen = chosen_variant(args, "export", "explorer export RESULTS VARIANT --format kit -o DIR")
        with open_results(args.results) as res:
            v = parse_variant(chosen, res.n_variants, res.filename)
            code = int(res.file["status"][v])
            status = FILE_STATUS_NAMES.get(code, f"code {code}")
            mech = variant_design(res, v)
            stored = _variant_forces(res, v)
            stored_torque = _variant_torque(res, v)
            row = variant_row(res, v)
            y = row.get("yield") if "yield" in row.index else None
            try:
                y = float(y)
            except (TypeError, ValueError):
                y = None
            if y is not None and y == y:
                rob = (res.study or {}).get("robustness") or {}
                tolerance_note = (f"yield {100 * y:.1f} % (stored by the study: the share of copies cut within "
                                  f"±{rob.get('tolerance', '?')} {rob.get('unit', '%')} of every design parameter "
                                  f"that still work)")
            source = f"{res.filename}, variant {v} (status {status})"
            operating = res.operating
            study_unit = operating.unit if operating is not None else None
        if status != "ok":
            note = f"; note: variant {v} did not solve over its whole cycle ({status})"
    else:
        if chosen is not None:
            raise UserError(f"{args.results}: a mechanism has no variants; drop {chosen!r} (a VARIANT goes with a "
                            f"results file)")
        mech = load_mechanism(args.results)
        operating = mech.operating
        source = f"mechanism {args.results}" + (f" ({mech.source})" if mech.source and mech.source != args.results else "")
    if mech.crank is None:
        raise UserError(f"{args.results}: mechanism {mech.name!r} is driven along a path, not by a crank: a build kit needs a "
                        f"crankshaft (export its parts with --format svg or dxf)")
    material = material_of(mech.build, thickness=opts["thickness"])
    walker = mech.walker
    can_compute = operating is not None and operating.rpm is not None

    def loads(scale, width):
        """The forces of the parts the kit cuts: the study's own where it computed them for this build, else
        computed again (explorer.simulate with forces) for it."""
        density = material.density * material.thickness * width / 1e6
        same_size = study_unit is not None and math.isclose(scale / 1000.0, study_unit, rel_tol=1e-9)
        same_mass = mech.link_density is not None and math.isclose(mech.link_density, density, rel_tol=1e-6)
        if stored and stored_torque is not None and same_size and same_mass:
            return stored, stored_torque, (f"pins and crankshaft sized from the study's own forces (its build: "
                                           f"{scale:.4g} mm per model unit, links of {density:.4g} kg/m)")
        if not can_compute:
            if stored:
                return {}, None, ("the study's forces are those of another build (its size or its links' mass) and "
                                  "there is no operating speed to compute them again: pins and shaft are the "
                                  "default sizes, not sized from a load")
            return {}, None, None
        forces, torque = kit_loads(mech, walker, operating, scale, density)
        why = ("" if not stored else f"; the study's were for {1000 * study_unit:.4g} mm per model unit and links of "
               f"{(mech.link_density or 0.0):.4g} kg/m" if study_unit else "")
        return forces, torque, (f"pins and crankshaft sized from forces computed for this build ({scale:.4g} mm per "
                                f"model unit, {material.thickness:g} mm {material.name} links {width:.4g} mm wide: "
                                f"{density:.4g} kg/m; {operating.rpm:g} rpm){why}")

    kit = build_kit(mech, crank_mm=opts["crank_mm"], scale=opts["scale"], material=material, width=opts["width"],
                    hole=opts["hole"], sheet=sheet, loads=loads, source=source, plates=args.plates,
                    undersized=args.undersized, motor_shaft=opts["motor_shaft"], motor_holes=args.motor_holes,
                    clearance=1.0 if opts["clearance"] is None else opts["clearance"],
                    commands=(_kit_command(args, chosen),))
    if tolerance_note is None:
        try:
            tolerance_note = design_yield_note(mech)
        except UserError as exc:  # the kit does not depend on it: README.txt says why it is missing
            tolerance_note = f"not computed ({exc}); `explorer tolerance` finds the spread the design takes"
    if tolerance_note is not None and "explorer tolerance" not in tolerance_note:
        tolerance_note += "; `explorer tolerance` finds the spread it takes"
    kit.tolerance_note = tolerance_note
    paths = write_kit(kit, out, force=args.force)
    n = sum(p.copies for p in kit.parts)
    worst = kit.worst
    print(f"wrote {os.fspath(out)}: {', '.join(p.name for p in paths)}; {n} parts for {kit.walker.legs} legs on "
          f"{kit.sheets} sheet(s) of {sheet[0]:g} x {sheet[1]:g} mm; scale: 1 model unit = {kit.scale:.4g} mm "
          f"(crank {kit.scale * mech.crank.radius:.3g} mm, links {kit.width:.3g} mm wide); crankshaft "
          f"{kit.shaft.diameter:g} mm ({kit.shaft.mode}); worst clearance margin "
          f"{'-' if worst is None else f'{worst.margin:.2f}'} mm{note}")
    for line in kit.notes:
        print(f"note: {line}")
    return 0


def run(args) -> int:
    from ..errors import UserError
    from ..store import open_results
    from ..store import FILE_STATUS_NAMES
    from ..view import cut_sheet, export_csv, export_dxf, export_svg, export_toml, variant_design
    from ._args import output_path as check_export_path
    from ._args import chosen_variant, output_path, parse_variant

    if args.fmt == "kit":
        return run_kit(args)
    given = [o for o, v in (("--sheet", args.sheet), ("--crank-mm", args.crank_mm), ("--thickness", args.thickness),
                            ("--motor-shaft", args.motor_shaft), ("--motor-holes", args.motor_holes),
                            ("--clearance", args.clearance), ("--plates", args.plates or None),
                            ("--undersized", args.undersized or None))
             if v is not None]
    if given:
        raise UserError(f"export: {', '.join(given)} go{'es' if len(given) == 1 else ''} with --format kit")
    chosen = chosen_variant(args, "export", "explorer export RESULTS VARIANT --format FORMAT -o PATH")
    fmt = _format(args)
    sheet_opts = {"scale": parse_mm("--scale", args.scale, 1e9, "mm per model unit"),
                  "width": parse_mm("--width", args.width, 1000.0, "the part width in mm"),
                  "hole": parse_mm("--hole", args.hole, 100.0, "the hole diameter in mm")}
    if fmt in ("csv", "toml"):
        given = [f"--{k}" for k, v in sheet_opts.items() if v is not None]
        if given:
            raise UserError(f"export: {', '.join(given)} go{'es' if len(given) == 1 else ''} with --format svg or dxf, "
                            f"not {fmt}")
    if args.scale is None:
        sheet_opts["scale"] = 1.0
    output_path(args.output, args.force, protect=[args.results])  # the verbs' one policy: fails before any work
    out = check_export_path(args.output, args.force, protect=[args.results])
    with open_results(args.results) as res:
        v = parse_variant(chosen, res.n_variants, res.filename)
        code = int(res.file["status"][v])
        status = FILE_STATUS_NAMES.get(code, f"code {code}")
        if fmt == "csv":
            path = export_csv(res, v, out, force=args.force)
            import pandas as pd
            cols = list(pd.read_csv(path, nrows=0).columns)
            print(f"wrote {os.fspath(path)}: variant {v}, {res.steps} samples × {len(cols)} columns "
                  f"({', '.join(cols[:5])}{', …' if len(cols) > 5 else ''})")
            return 0
        mech = variant_design(res, v)
        filename = res.filename
    note = "" if status == "ok" else (f"; note: variant {v} did not solve over its whole cycle ({status}), its design "
                                      f"is exported all the same")
    if fmt == "toml":
        from .. import __version__
        header = (f"Exported by explorer {__version__}: variant {v} of {filename} (status {status}).\n"
                  f"Read it with explorer.load_mechanism(PATH), or run a study on it ([study] mechanism = PATH).")
        path = export_toml(mech, out, force=args.force, header=header)
        print(f"wrote {os.fspath(path)}: variant {v} as mechanism {mech.name!r} ({len(mech.parameters())} design "
              f"parameters){note}")
        return 0
    sheet = cut_sheet(mech, **sheet_opts)
    write = export_svg if fmt == "svg" else export_dxf
    path = write(mech, out, force=args.force, **sheet_opts)
    W, H = sheet.size
    print(f"wrote {os.fspath(path)}: {len(sheet.parts)} parts of variant {v} on a {W:.1f} × {H:.1f} mm sheet "
          f"(1 model unit = {sheet.scale:g} mm; parts {sheet.width:.3g} mm wide, holes {sheet.hole:.3g} mm){note}")
    return 0
