"""The export-format registry: what ``explorer export`` (and :func:`export_variant`) can write (public as
``explorer.fabrication.EXPORTS``, ``register_export``, ...; kept light here, so that ``explorer --help`` builds its
``--as`` choices without loading the plotting and kit code, which each format's writer imports when it runs).

Each format is one :class:`ExportFormat` entry of :data:`EXPORTS`: its name (``--as NAME``), its file
extension (what ``-o``'s extension selects; None for a folder), a line of help, the options it takes, and its
code (``write(job) -> summary line``). The command line builds ``--as``'s choices and help from this table,
and dispatches through it; adding a format is one :func:`register_export` call and its code::

    def write_json(job):
        path = write_replacing(job.out, ...)        # the variant's design, job.mechanism
        return f"wrote {path}"

    register_export(ExportFormat("json", ".json", "the design as JSON", write_json))
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ..errors import UserError


@dataclass(frozen=True)
class ExportFormat:
    """One export format. name : ``--as NAME``; extension : the file extension that selects it (``".svg"``; None:
    the output is a folder); help : one line for ``--help``; write : ``write(job: ExportJob) -> str`` writes
    ``job.out`` and returns the summary line the command prints; options : the format's own options (keys of
    ``ExportJob.options``, e.g. ``scale``); needs_results : it reads a results file's stored data (not a
    design alone), so a mechanism cannot be exported this way; needs_crank : the design must be crank-driven."""

    name: str
    extension: str | None
    help: str
    write: Callable
    options: frozenset = field(default_factory=frozenset)
    needs_results: bool = True
    needs_crank: bool = False


@dataclass
class ExportJob:
    """What a format's ``write`` gets. results : the open :class:`~explorer.store.Results` (None for a
    mechanism); variant : the variant (None for a mechanism); mechanism : the design to export; status :
    the variant's status name ("ok" for a mechanism); source : where the design comes from, in words;
    out : the path to write; force : replace what exists; options : the format's options (None = default);
    command : the command line that wrote it (for a kit's README)."""

    results: object
    variant: int | None
    mechanism: object
    status: str
    source: str
    out: Path
    force: bool = False
    options: dict = field(default_factory=dict)
    command: str = ""

    @property
    def note(self) -> str:
        """"; note: ..." for a variant that did not solve over its whole cycle, else ""."""
        if self.status == "ok":
            return ""
        return (f"; note: variant {self.variant} did not solve over its whole cycle ({self.status}), its design is "
                f"exported all the same")


#: The registry: format name -> :class:`ExportFormat`, in the order ``--help`` lists them.
EXPORTS: dict[str, ExportFormat] = {}


def register_export(fmt: ExportFormat) -> ExportFormat:
    """Add ``fmt`` to :data:`EXPORTS` (a name or an extension taken by another format is refused)."""
    if fmt.name in EXPORTS:
        raise ValueError(f"export format {fmt.name!r} is already registered")
    if fmt.extension is not None and any(f.extension == fmt.extension for f in EXPORTS.values()):
        raise ValueError(f"export extension {fmt.extension!r} is already registered")
    EXPORTS[fmt.name] = fmt
    return fmt


class _Extensions(Mapping):
    """{format name: extension} of the file formats (not folders), read live from :data:`EXPORTS`."""

    def __getitem__(self, name):
        ext = EXPORTS[name].extension
        if ext is None:
            raise KeyError(name)
        return ext

    def __iter__(self):
        return (n for n, f in EXPORTS.items() if f.extension is not None)

    def __len__(self):
        return sum(1 for _ in self)

    def __repr__(self):
        return repr(dict(self))


#: Export formats that write one file and their extensions (a live view of :data:`EXPORTS`).
EXPORT_FORMATS: Mapping[str, str] = _Extensions()


def export_format(name: str | None, output) -> ExportFormat:
    """The format ``name`` (``--as``), else the one ``output``'s extension selects; a one-line UserError when
    neither says, or they disagree."""
    ext = Path(os.fspath(output)).suffix.lower()
    by_ext = {f.extension: f for f in EXPORTS.values() if f.extension is not None}
    names = "|".join(EXPORTS)
    if name is None:
        if ext not in by_ext:
            raise UserError(f"{output}: say what to write with --as {names} (the extension "
                            f"{Path(os.fspath(output)).suffix or '(none)'!r} does not say)")
        return by_ext[ext]
    if name not in EXPORTS:
        raise UserError(f"--as: expected one of {', '.join(EXPORTS)}, got {name!r}")
    fmt = EXPORTS[name]
    if ext in by_ext and by_ext[ext] is not fmt:
        raise UserError(f"{output}: --as {name} into a {ext} file; name it {fmt.extension or 'a folder'} or drop --as")
    return fmt


def export_variant(target, variant: int | None, output, *, as_: str | None = None, force: bool = False,
                   options: dict | None = None, command: str = "") -> str:
    """Export ``variant`` of a results file ``target`` (a path), or the design of a mechanism ``target`` (a
    built-in name or a .toml; ``variant`` None) in the format ``as_`` (else ``output``'s extension) to
    ``output``; returns the summary line. ``options``: the format's options (its :attr:`ExportFormat.options`;
    another format's is a one-line UserError)."""
    from ..store import FILE_STATUS_NAMES
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    from ._export import variant_design

    fmt = export_format(as_, output)
    given = {k: v for k, v in (options or {}).items() if v is not None and v is not False}
    foreign = [k for k in given if k not in fmt.options]
    if foreign:
        owners = [n for n, f in EXPORTS.items() if set(foreign) <= f.options]
        raise UserError(f"export: {', '.join('--' + k.replace('_', '-') for k in foreign)} "
                        f"go{'es' if len(foreign) == 1 else ''} with --as {' or '.join(owners) or 'another format'}, "
                        f"not {fmt.name}")
    out = Path(os.fspath(output))
    _check_output(fmt, out, force, target)  # the one output policy, before any work
    if _is_results_file(target):
        if variant is None:
            raise UserError(f"export: say which variant: explorer export {target} --variant N -o {output}")
        with open_results(target) as res:
            v = res.check_variant(variant)
            code = int(res.file["status"][v])
            status = FILE_STATUS_NAMES.get(code, f"code {code}")
            mech = variant_design(res, v)
            job = ExportJob(res, v, mech, status, f"{res.filename}, variant {v} (status {status})", out, force,
                            dict(options or {}), command)
            _check_crank(fmt, mech, target)
            return fmt.write(job)
    if fmt.needs_results:
        raise UserError(f"{target}: not a results file: --as {fmt.name} exports a variant of a results file "
                        f"(formats that take a mechanism: {', '.join(n for n, f in EXPORTS.items() if not f.needs_results)})")
    if variant is not None:
        raise UserError(f"{target}: a mechanism has no variants; drop --variant {variant} (a variant goes with a "
                        f"results file)")
    from ..mechanism import load_mechanism
    mech = load_mechanism(target)
    source = f"mechanism {target}" + (f" ({mech.source})" if mech.source and mech.source != str(target) else "")
    return _write_design(fmt, mech, source, out, force, dict(options or {}), command, target)


def export_design(mech, name: str, output, *, source: str, force: bool = False, options: dict | None = None) -> str:
    """Write the design ``mech`` (a :class:`~explorer.mechanism.Mechanism`, no results file) in the export
    format ``name`` (one whose ``needs_results`` is False) to ``output``, by the one output policy (an
    existing file replaced only with ``force``); ``source`` says where the design comes from, in words (a
    toml's header, a kit's README). Returns the format's summary line. What ``explorer edit`` saves."""
    if name not in EXPORTS or EXPORTS[name].needs_results:
        raise UserError(f"format: expected one of {', '.join(n for n, f in EXPORTS.items() if not f.needs_results)}, "
                        f"got {name!r}")
    out = Path(os.fspath(output))
    fmt = EXPORTS[name]
    _check_output(fmt, out, force, None)
    return _write_design(fmt, mech, source, out, force, dict(options or {}), "", mech.name)


def _write_design(fmt: ExportFormat, mech, source: str, out: Path, force: bool, options: dict, command: str,
                  target) -> str:
    _check_crank(fmt, mech, target)
    return fmt.write(ExportJob(None, None, mech, "ok", source, out, force, options, command))


def _is_results_file(path) -> bool:
    """Whether ``path`` names a results file (an HDF5 file, or a missing .h5 the reader then names), not a
    mechanism's name or .toml."""
    p = Path(os.fspath(path))
    if not p.is_file():
        return p.suffix.lower() in (".h5", ".hdf5")
    with open(p, "rb") as fh:
        return fh.read(8) == b"\x89HDF\r\n\x1a\n"


def _check_output(fmt: ExportFormat, out: Path, force: bool, target) -> None:
    from .._files import output_path
    protect = [target] if target is not None else []
    if fmt.extension is not None:
        output_path(out, force, protect=protect)
        return
    if not str(out).strip():
        raise UserError(f"-o: expected a folder name, got {str(out)!r}")
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: cannot write the {fmt.name}: it is a file, not a folder")
    if fmt.name == "kit" and out.is_dir():  # the kit's files already there: each under the one policy
        from ._kit import KIT_FILES
        for name in KIT_FILES:
            if os.path.lexists(out / name):
                output_path(out / name, force, protect=protect)


def _check_crank(fmt: ExportFormat, mech, target) -> None:
    if fmt.needs_crank and mech.crank is None:
        raise UserError(f"{target}: mechanism {mech.name!r} is driven along a path, not by a crank: --as {fmt.name} "
                        f"needs a crankshaft (export its parts with --as svg or dxf)")


# -- the formats ------------------------------------------------------------------------------------------
SHEET_OPTIONS = frozenset({"scale", "width", "hole"})


def _sheet_writer(kind: str):
    """The writer of the cut sheet as ``kind`` ("svg" or "dxf")."""
    def write(job: ExportJob) -> str:
        from ._export import cut_sheet, export_dxf, export_svg
        opts = {k: job.options.get(k) for k in ("scale", "width", "hole")}
        if opts["scale"] is None:
            opts["scale"] = 1.0
        sheet = cut_sheet(job.mechanism, **opts)
        path = (export_svg if kind == "svg" else export_dxf)(job.mechanism, job.out, force=job.force, **opts)
        W, H = sheet.size
        return (f"wrote {os.fspath(path)}: {len(sheet.parts)} parts of {_what(job)} on a {W:.1f} × {H:.1f} "
                f"mm sheet (1 model unit = {sheet.scale:g} mm; parts {sheet.width:.3g} mm wide, holes "
                f"{sheet.hole:.3g} mm){job.note}")
    return write


def _write_csv(job: ExportJob) -> str:
    import pandas as pd

    from ._export import export_csv
    path = export_csv(job.results, job.variant, job.out, force=job.force)
    cols = list(pd.read_csv(path, nrows=0).columns)
    return (f"wrote {os.fspath(path)}: variant {job.variant}, {job.results.steps} samples × {len(cols)} columns "
            f"({', '.join(cols[:5])}{', …' if len(cols) > 5 else ''})")


def _what(job: ExportJob) -> str:
    """What is exported, in words: "variant N", or a design without results "design NAME"."""
    return f"variant {job.variant}" if job.results is not None else f"design {job.mechanism.name!r}"


def _write_toml(job: ExportJob) -> str:
    from .. import __version__
    from ._export import export_toml
    mech = job.mechanism
    whence = (f"variant {job.variant} of {job.results.filename} (status {job.status})" if job.results is not None
              else job.source)
    header = (f"Exported by explorer {__version__}: {whence}.\nRead it with explorer.load_mechanism(PATH), or run a "
              f"study on it ([study] mechanism = PATH).")
    path = export_toml(mech, job.out, force=job.force, header=header)
    return (f"wrote {os.fspath(path)}: {_what(job)} as mechanism {mech.name!r} ({len(mech.parameters())} "
            f"design parameters){job.note}")


#: The kit's own options (sizes in mm; ``sheet`` (W, H) mm; ``motor_holes`` text; ``plates``, ``undersized``).
KIT_OPTIONS = frozenset({"scale", "width", "hole", "thickness", "crank_mm", "sheet", "motor_shaft", "motor_holes",
                         "clearance", "plates", "undersized"})


def _write_kit(job: ExportJob) -> str:
    """The build kit of the design (:func:`explorer.fabrication.build_kit`, :func:`explorer.fabrication.write_kit`): the
    pins and crankshaft sized from the study's stored forces where they are this build's, else from forces
    computed again for it."""
    from ..store import variant_peak_forces, variant_row, variant_torque
    from ._kit import build_kit, design_yield_note, kit_loads, material_of, write_kit

    o = job.options
    out, mech = job.out, job.mechanism
    stored: dict[str, float] = {}
    stored_torque = None
    tolerance_note = None
    study_unit = None
    if job.results is not None:
        res, v = job.results, job.variant
        stored = variant_peak_forces(res, v)
        stored_torque = variant_torque(res, v)
        row = variant_row(res, v)
        try:
            y = float(row.get("yield")) if "yield" in row.index else None
        except (TypeError, ValueError):
            y = None
        if y is not None and y == y:
            rob = (res.study or {}).get("robustness") or {}
            tolerance_note = (f"yield {100 * y:.1f} % (stored by the study: the share of copies cut within "
                              f"±{rob.get('tolerance', '?')} {rob.get('unit', '%')} of every design parameter "
                              f"that still work)")
        operating = res.operating
        study_unit = operating.unit if operating is not None else None
    else:
        operating = mech.operating
    note = "" if job.status == "ok" else f"; note: variant {job.variant} did not solve over its whole cycle ({job.status})"
    material = material_of(mech.build, thickness=o.get("thickness"))
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

    sheet = o.get("sheet") or (600.0, 400.0)
    kit = build_kit(mech, crank_mm=o.get("crank_mm"), scale=o.get("scale"), material=material, width=o.get("width"),
                    hole=o.get("hole"), sheet=sheet, loads=loads, source=job.source, plates=bool(o.get("plates")),
                    undersized=bool(o.get("undersized")), motor_shaft=o.get("motor_shaft"),
                    motor_holes=o.get("motor_holes"),
                    clearance=1.0 if o.get("clearance") is None else o["clearance"],
                    commands=(job.command,) if job.command else ())
    if tolerance_note is None:
        try:
            tolerance_note = design_yield_note(mech)
        except UserError as exc:  # the kit does not depend on it: README.txt says why it is missing
            tolerance_note = f"not computed ({exc}); `explorer tolerance` finds the spread the design takes"
    if tolerance_note is not None and "explorer tolerance" not in tolerance_note:
        tolerance_note += "; `explorer tolerance` finds the spread it takes"
    kit.tolerance_note = tolerance_note
    paths = write_kit(kit, out, force=job.force)
    n = sum(p.copies for p in kit.parts)
    worst = kit.worst
    lines = [f"wrote {os.fspath(out)}: {', '.join(p.name for p in paths)}; {n} parts for {kit.walker.legs} legs on "
             f"{kit.sheets} sheet(s) of {sheet[0]:g} x {sheet[1]:g} mm; scale: 1 model unit = {kit.scale:.4g} mm "
             f"(crank {kit.scale * mech.crank.radius:.3g} mm, links {kit.width:.3g} mm wide); crankshaft "
             f"{kit.shaft.diameter:g} mm ({kit.shaft.mode}); worst clearance margin "
             f"{'-' if worst is None else f'{worst.margin:.2f}'} mm{note}"]
    lines += [f"note: {line}" for line in kit.notes]
    return "\n".join(lines)


register_export(ExportFormat("svg", ".svg", "the design's parts laid out for a laser cutter (mm; 1 model unit = "
                             "--scale mm)", _sheet_writer("svg"), SHEET_OPTIONS, needs_results=False))
register_export(ExportFormat("dxf", ".dxf", "the same parts as DXF (layers CUT and LABELS)", _sheet_writer("dxf"),
                             SHEET_OPTIONS, needs_results=False))
register_export(ExportFormat("csv", ".csv", "the variant's stored trajectories, one row per sample", _write_csv))
register_export(ExportFormat("toml", ".toml", "the design as a mechanism file (explorer run, load_mechanism)",
                             _write_toml, needs_results=False))
register_export(ExportFormat("kit", None, "a build kit folder: cut sheets, kit.json, bill of materials, assembly.pdf, "
                             "README.txt", _write_kit, KIT_OPTIONS, needs_results=False, needs_crank=True))
