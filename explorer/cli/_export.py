"""``explorer export RESULTS VARIANT --format svg|dxf|csv|toml -o PATH``: one design, to cut, to plot or to
run again."""

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
                    "exists) but not as csv (it has no full path). An existing PATH is never replaced without "
                    "--force; missing folders are created.")
    p.add_argument("results", metavar="RESULTS", help="results file (.h5) written by `explorer run`")
    add_variant_arguments(p, "as `explorer show --variant` takes it")
    p.add_argument("--format", dest="fmt", choices=("svg", "dxf", "csv", "toml"), default=None,
                   help="what to write (default: from the extension of -o)")
    p.add_argument("-o", "--output", metavar="PATH", required=True, help="the file to write")
    p.add_argument("--force", action="store_true", help="overwrite PATH if it exists (never done without it)")
    p.add_argument("--scale", type=float, default=None, metavar="MM",
                   help="svg, dxf: millimetres per model unit (default: 1, one model unit = 1 mm)")
    p.add_argument("--width", type=float, default=None, metavar="MM",
                   help="svg, dxf: width of every part, mm (default: 20 %% of the shortest distance between two "
                        "holes of one part: the crank radius or the shortest link, usually)")
    p.add_argument("--hole", type=float, default=None, metavar="MM",
                   help="svg, dxf: diameter of the pin holes, mm (default: 40 %% of the part width)")
    p.set_defaults(func=run)


def _format(args) -> str:
    from ..errors import UserError
    from ..view._export import EXPORT_FORMATS
    ext = Path(args.output).suffix.lower()
    by_ext = {e: f for f, e in EXPORT_FORMATS.items()}
    if args.fmt is None:
        if ext not in by_ext:
            raise UserError(f"{args.output}: say what to write with --format svg|dxf|csv|toml (the extension "
                            f"{Path(args.output).suffix or '(none)'!r} does not say)")
        return by_ext[ext]
    if ext in by_ext and by_ext[ext] != args.fmt:
        raise UserError(f"{args.output}: --format {args.fmt} into a {ext} file; name it {EXPORT_FORMATS[args.fmt]} "
                        f"or drop --format")
    return args.fmt


def run(args) -> int:
    from ..errors import UserError
    from ..store import open_results
    from ..store import FILE_STATUS_NAMES
    from ..view._export import (check_export_path, cut_sheet, export_csv, export_dxf, export_svg, export_toml,
                                variant_design)
    from ._args import chosen_variant, output_path, parse_variant

    chosen = chosen_variant(args, "export", "explorer export RESULTS VARIANT --format FORMAT -o PATH")
    fmt = _format(args)
    sheet_opts = {"scale": args.scale, "width": args.width, "hole": args.hole}
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
