"""The editor's state and every action the page asks for, without the web layer (testable as plain Python).

An :class:`EditSession` holds the *reference* design (what the editor was opened with: a built-in, a
mechanism file, or one variant of a results file; drawn as the ghost, and what "reset" returns to), the
*current* design (what ``GET /api/design`` returns), the samples per turn, the buildability screen's
thresholds, an open results file, and the folder files are saved to. Every method takes and returns
JSON-ready data; every design it receives goes through :func:`~explorer.edit._design.parse_design` (the
mechanism loader's validation). Numerics are serialised by one lock: the server answers requests on
threads.
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism, builtin_mechanisms, load_mechanism
from ._design import CRANK_CENTRE, design_data, drag, parse_design, set_parameters
from ._solve import encode, solve_design
from ._study import Study, is_results_file, yield_data

#: The editor's own save format, beside the export formats that take a design alone.
HANDOFF = "a design file, an optimize study over it and its foot path as a target CSV"


class _SaveFormats(Mapping):
    """{format: what it writes} of a save: every export format that writes a design alone
    (``explorer.fabrication.EXPORTS`` whose ``needs_results`` is False, the mechanism file first: the
    page's default), read live, so that a format registered there is offered here; then ``handoff``."""

    def _all(self) -> dict:
        from ..fabrication import EXPORTS
        names = sorted((n for n, f in EXPORTS.items() if not f.needs_results), key=lambda n: n != "toml")
        return {**{n: EXPORTS[n].help for n in names}, "handoff": HANDOFF}

    def __getitem__(self, name):
        return self._all()[name]

    def __iter__(self):
        return iter(self._all())

    def __len__(self):
        return len(self._all())

    def __repr__(self):
        return repr(self._all())


#: Save formats: what each writes (a live view of the export registry, and ``handoff``).
SAVE_FORMATS: Mapping[str, str] = _SaveFormats()
#: Most copies the page may ask the yield of.
MAX_YIELD_COPIES = 4096


class EditSession:
    """See the module docstring. ``target``: a built-in name or a mechanism file (``variant`` None), or a
    results file with ``variant``; ``steps``: samples per turn (default 360, or the results' own);
    ``folder``: where relative save paths go (default: the current folder)."""

    def __init__(self, target="jansen", variant=None, *, steps: int | None = None, folder=None):
        self.lock = threading.RLock()
        self.folder = Path(folder) if folder is not None else Path.cwd()
        self.study: Study | None = None
        self.screen = None
        if is_results_file(target):
            self.study = Study(target)
            self.screen = self.study.screen
            v = 0 if variant is None else variant
            mech = self.study.design(v)
            label = f"variant {int(v)} of {Path(target).name}"
            steps = steps or self.study.steps
        else:
            if variant is not None:
                raise UserError(f"{target}: --variant needs a results file (.h5); this is a mechanism")
            mech = load_mechanism(target)
            label = str(target) if str(target) in builtin_mechanisms() else Path(str(target)).name
        self.steps = int(steps or 360)
        if self.steps < 12 or self.steps > 20000:
            raise UserError(f"--steps: expected a whole number from 12 to 20000, got {self.steps}")
        self._set_reference(mech, label)

    # -- designs ------------------------------------------------------------------------------------------
    def _set_reference(self, mech: Mechanism, label: str) -> None:
        self.reference = parse_design(design_data(mech), label)  # as the page will send it back
        self.reference_label = label
        self.current = self.reference

    def parse(self, data) -> Mechanism:
        return parse_design(data, "design")

    def payload(self, mech: Mechanism) -> dict:
        """A design and its solve, as the page takes them."""
        with self.lock:
            solve = solve_design(mech, self.steps, screen=self.screen, foot=False)
        return {"design": design_data(mech), "parameters": parameters(mech), "size": mech.size, "driven": mech.driven,
                "solve": solve}

    def info(self) -> dict:
        """What the page needs first: the reference design and its solve, the metric table, the session's
        settings (GET /api/session)."""
        from .. import __version__
        from ..gait import TABLE

        ref = self.payload(self.reference)
        return {"version": __version__, "label": self.reference_label, "steps": self.steps,
                "reference": ref, "current": self.payload(self.current) if self.current is not self.reference else ref,
                "metrics": {m.name: {"unit": m.unit, "direction": m.direction, "group": m.group,
                                     "description": m.description} for m in TABLE},
                "builtins": list(builtin_mechanisms()), "folder": str(self.folder), "save_formats": dict(SAVE_FORMATS),
                "crank_centre": CRANK_CENTRE, "study": self.study_summary() if self.study is not None else None,
                "screen": self.screen.as_dict() if self.screen is not None else None}

    def warm(self) -> float:
        """Run every numerical path the page uses once on the reference (solve, metrics, forces, a drag step,
        a parameter edit), so that Numba compiles or loads its kernels now, not on the first drag; the
        kernels stay warm in this process. Returns the seconds it took."""
        t = time.perf_counter()
        mech = self.reference
        self.payload(mech)
        cyc_angle = 0.0 if mech.crank is None else 2 * math.pi * (self.steps // 12) / self.steps
        with self.lock:
            from ._design import configuration
            P, angle, _ = configuration(mech, cyc_angle, None, self.steps)
            moving = [v for v in mech.guess]
            if P is not None and moving:
                v = moving[-1]
                p = P[mech.vertex_index(v)]
                d = drag(mech, angle, v, (p[0] + 1e-3 * mech.size, p[1]), near=P, steps=self.steps)
                if d.design is not None:
                    solve_design(d.design, self.steps, screen=self.screen)
            name, value = next(iter(mech.parameters().items()))
            try:
                set_parameters(mech, {name: value}, self.steps)
            except UserError:
                pass
        return time.perf_counter() - t

    def solve(self, data, steps=None) -> dict:
        """POST /api/solve: ``explorer.simulate`` of the design, its metrics (:func:`solve_design`); pure."""
        mech = self.parse(data)
        n = self.steps if steps is None else _whole(steps, "steps", 3, 20000)
        with self.lock:
            return solve_design(mech, n, screen=self.screen)

    def set_design(self, data) -> dict:
        """PUT /api/design: make ``data`` the current design (undo, redo, reset, a shared link)."""
        mech = self.parse(data)
        self.current = mech
        return self.payload(mech)

    def drag(self, data, angle, joint, to, config=None) -> dict:
        """POST /api/drag: one drag step (:func:`~explorer.edit._design.drag`). Returns the new design,
        the angle and configuration shown and its solve, or ``refused`` (the design unchanged)."""
        mech = self.parse(data)
        angle = _number(angle, "angle")
        to = _pair(to, "to")
        near = _config(mech, config) if config is not None else None
        t0 = time.perf_counter()
        with self.lock:
            d = drag(mech, angle, str(joint), to, near=near, steps=self.steps)
            t1 = time.perf_counter()
            if d.design is None:
                return {"refused": d.refused, "angle": d.angle, "config": _config_out(d.config),
                        "ms": {"drag": 1e3 * (t1 - t0)}}
            solve = solve_design(d.design, self.steps, screen=self.screen, foot=False, cycle=d.cycle)
        self.current = d.design
        solve["ms"]["drag"] = 1e3 * (t1 - t0)
        return {"design": d.data, "parameters": parameters(d.design), "size": d.design.size,
                "driven": d.design.driven, "angle": d.angle,
                "config": _config_out(d.config), "note": d.note, "solve": solve}

    def edit(self, data, values) -> dict:
        """POST /api/edit: set design parameters by name, on the design's branch."""
        mech = self.parse(data)
        if not isinstance(values, dict) or not values:
            raise UserError("parameters: expected {name: value, ...}")
        with self.lock:
            new = set_parameters(mech, values, self.steps)
        self.current = new
        return self.payload(new)

    def reset(self) -> dict:
        self.current = self.reference
        return self.payload(self.reference)

    def open_mechanism(self, name) -> dict:
        """POST /api/mechanism: open a built-in or a mechanism file as the new reference."""
        if not isinstance(name, str) or not name.strip():
            raise UserError("mechanism: expected a built-in name or a mechanism file's path")
        path = name if name in builtin_mechanisms() else str(self._resolve(name))
        if is_results_file(path):
            return self.open_study(path)
        mech = load_mechanism(path)
        self._set_reference(mech, name if name in builtin_mechanisms() else Path(path).name)
        return self.info()

    # -- a study ------------------------------------------------------------------------------------------
    def _resolve(self, path) -> Path:
        if not isinstance(path, str) or not path.strip() or "\0" in path:
            raise UserError(f"path: expected a file name, got {path!r}")
        p = Path(os.path.expanduser(path))
        return p if p.is_absolute() else self.folder / p

    def open_study(self, path) -> dict:
        """POST /api/study: open a results file (read-only); its variant 0 becomes the reference."""
        p = self._resolve(path)
        study = Study(p)
        if self.study is not None:
            self.study.close()
        self.study = study
        self.screen = study.screen
        self._set_reference(study.design(0), f"variant 0 of {p.name}")
        return self.info()

    def study_summary(self, x=None, y=None) -> dict:
        if self.study is None:
            raise UserError("no results file is open: open one first (explorer edit RESULTS, or the Study panel)")
        return self.study.summary(x, y)

    def load_variant(self, variant) -> dict:
        """POST /api/variant: a variant of the open results file becomes the reference and current design."""
        if self.study is None:
            raise UserError("no results file is open")
        v = _whole(variant, "variant", 0, self.study.results.n_variants - 1)
        self._set_reference(self.study.design(v), f"variant {v} of {self.study.path.name}")
        return self.info()

    # -- on demand ----------------------------------------------------------------------------------------
    def design_yield(self, data, tolerance, unit="%", copies=256) -> dict:
        """POST /api/yield: the design's yield at ±tolerance (unit "%", "mm" or "model")."""
        mech = self.parse(data)
        if mech.crank is None:
            raise UserError("yield: a path-driven mechanism has no crank turn to survive")
        copies = _whole(copies, "copies", 16, MAX_YIELD_COPIES)
        with self.lock:
            return yield_data(mech, tolerance, unit, copies, self.steps, self.screen)

    def toml(self, data) -> dict:
        """POST /api/toml: the design as the text of a mechanism file."""
        from ..mechanism import mechanism_toml
        mech = self.parse(data)
        return {"text": mechanism_toml(mech, _header(mech)), "name": mech.name}

    def save(self, data, path, fmt="toml", force=False, check=False) -> dict:
        """POST /api/save: write the design by the one output policy (an existing file is replaced only
        with ``force``, which the page asks the user for; never a link, a folder or a device). ``fmt``:
        one of :data:`SAVE_FORMATS`: an export format (``explorer.fabrication.export_design``, what
        ``explorer export`` writes) or ``handoff``. Returns {"written": [paths]} (and an export's
        "summary" line, a handoff's "commands"); with ``check``, writes nothing and returns {"exists":
        [the paths it would replace]}."""
        from .._files import output_path
        from ..fabrication import export_design, export_toml

        mech = self.parse(data)
        if not isinstance(fmt, str) or fmt not in SAVE_FORMATS:  # (a list or an object: not a format either)
            raise UserError(f"format: expected one of {', '.join(SAVE_FORMATS)}, got {fmt!r}")
        force = force is True
        p = self._resolve(path)
        if check is True:
            return {"exists": [str(f) for f in _targets(p, fmt) if os.path.lexists(f)]}
        if fmt != "handoff":  # an export format (explorer.fabrication): what `explorer export` writes
            with self.lock:
                summary = export_design(mech, fmt, p, source=f"explorer edit ({mech.name})", force=force)
            return {"written": [str(f) for f in _targets(p, fmt)], "summary": summary}
        # handoff: the design, an optimize study that starts from it, and its foot path as a target
        files = dict(zip(("design", "study", "target"), _targets(p, fmt)))
        for f in files.values():
            output_path(f, force)  # every check first: nothing is written if one of them is refused
        with self.lock:
            from ..kernels import simulate
            cyc = simulate(mech, self.steps)
        foot = cyc.path(mech.foot)
        if not np.all(np.isfinite(foot)):
            raise UserError("handoff: the design does not turn a full cycle, so it has no foot path to hand on; "
                            "save it as toml instead")
        written = [str(export_toml(mech, files["design"], force=force, header=_header(mech)))]
        study = optimize_study(mech, files["design"].name, files["design"].stem, self.steps)
        written.append(str(_write_text(files["study"], study, force)))
        csv = "x,y\n" + "".join(f"{x!r},{y!r}\n" for x, y in foot.tolist())
        written.append(str(_write_text(files["target"], csv, force)))
        return {"written": written, "commands": handoff_commands(files)}


def _targets(p: Path, fmt: str) -> list[Path]:
    """The paths a save writes (a format that writes a folder, the kit: the files in it)."""
    from ..fabrication import EXPORTS
    if fmt == "handoff":
        stem = p.with_suffix("") if p.suffix == ".toml" else p
        return [stem.with_name(stem.name + ".toml"), stem.with_name(stem.name + "-optimize.toml"),
                stem.with_name(stem.name + "-foot.csv")]
    if EXPORTS[fmt].extension is None:
        return sorted(p.iterdir()) if p.is_dir() else [p]
    return [p]


def handoff_commands(files: dict) -> list[str]:
    """The command lines that take a design on: optimize from it, synthesise its foot path."""
    return [f"explorer optimize {files['study']}      # search around the design (it is variant 0)",
            f"explorer run {files['design']}          # or any study with [study] mechanism = \"{files['design'].name}\"",
            f"explorer synth {files['target']} --mechanism any   # another linkage that draws this foot path "
            f"(explorer synth, issue 41)"]


def optimize_study(mech: Mechanism, design_file: str, name: str, steps: int) -> str:
    """An ``explorer optimize`` study over every length of ``design_file`` (±5 %), starting from it:
    the walker's travel, bob and peak torque as objectives where they apply, else the first metric that
    does."""
    from ..gait import available_metrics
    from ..mechanism import dumps_toml

    avail = available_metrics(mech)
    objectives = [m for m in ("travel", "bob", "peak_torque") if avail.get(m, "") is None] or \
        [m for m, why in avail.items() if why is None][:1]
    params = list(mech.link_names) + (["crank"] if mech.crank is not None else [])
    data = {"study": {"name": f"{name}-optimize", "mechanism": design_file, "seed": 1, "steps": int(steps)},
            "optimize": {"algorithm": "auto", "population": 64, "generations": 30, "objectives": objectives,
                         "screen": True, "spread": 0.05, "parameters": params},
            "scene": {"vertices": [mech.foot], "velocities": False},
            "output": {"path": f"results/{name}-optimize.h5"}}
    head = (f"# Search around the design {mech.name!r} (written by explorer edit): every length within ±5 %.\n"
            f"#   explorer optimize {name}-optimize.toml\n\n")
    return head + dumps_toml(data)


def _write_text(path: Path, text: str, force: bool) -> Path:
    from .._files import output_path, write_replacing
    p = output_path(path, force)
    return write_replacing(p, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def _header(mech: Mechanism) -> str:
    from .. import __version__
    return f"{mech.name}: written by explorer edit (explorer {__version__})"


_KINDS: dict = {}


def parameters(mech: Mechanism) -> list:
    """[[name, value, kind], ...] of every design parameter (``Mechanism.parameters`` order)."""
    items = mech.parameter_items()
    key = tuple(k for k, _ in items)
    if key not in _KINDS:  # the kinds depend on the names alone: once per topology
        _KINDS[key] = [mech.parameter_kind(k) for k in key]
    return [[k, v, kind] for (k, v), kind in zip(items, _KINDS[key])]


def _number(x, what: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        raise UserError(f"{what}: expected a finite number, got {x!r}")
    return float(x)


def _whole(x, what: str, lo: int, hi: int) -> int:
    if isinstance(x, bool) or not isinstance(x, int) or not lo <= x <= hi:
        raise UserError(f"{what}: expected a whole number from {lo} to {hi}, got {x!r}")
    return int(x)


def _pair(x, what: str) -> tuple[float, float]:
    if not isinstance(x, (list, tuple)) or len(x) != 2:
        raise UserError(f"{what}: expected [x, y], got {x!r}")
    return _number(x[0], what), _number(x[1], what)


def _config(mech: Mechanism, config) -> dict:
    """{vertex: (x, y)} from the page's configuration (a dict of vertex names); vertices it lacks or gives
    as null are left to the design's guess."""
    if not isinstance(config, dict):
        raise UserError("config: expected {vertex: [x, y]}")
    out = {}
    for v, xy in config.items():
        if v in mech.guess and xy is not None:
            out[v] = _pair(xy, f"config.{v}")
    return {**dict(mech.guess), **out}


def _config_out(P: np.ndarray) -> str:
    return encode(P)
