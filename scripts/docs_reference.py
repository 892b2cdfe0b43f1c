"""The study-file and mechanism-file references of the docs site, generated from the validators' key tables.

The keys and their order come from the code that validates the files (``explorer.study.STUDY_KEYS``,
``explorer.mechanism.MECHANISM_KEYS``); choice lists and defaults are filled in from the code's own
constants and dataclasses (``{...}`` fields below). What each key means is written here, once. A key the
loader accepts with no words here, or words for a key it no longer accepts, stops the docs build
(``scripts/mkdocs_hooks.py`` calls :func:`pages`) and fails ``tests/test_docs.py``: the reference
cannot drift from the loader.

    python scripts/docs_reference.py OUT_DIR    # write study-file.md and mechanism-file.md there
    python scripts/docs_reference.py --check    # exit 1 naming every undocumented or stale key
"""

from __future__ import annotations

import sys
from dataclasses import fields
from pathlib import Path

#: the pages, by their path under docs/
STUDY_PAGE = "reference/study-file.md"
MECHANISM_PAGE = "reference/mechanism-file.md"


def _choices(values) -> str:
    return ", ".join(f"`{v}`" for v in values)


def _facts() -> dict:
    """The code's own constants the descriptions quote (choices, defaults, ranges)."""
    from explorer.gait import IGNORES, MATCHES, PHASES, Screen
    from explorer.kernels import DEFAULT_TOLERANCE, TOLERANCE_RANGE
    from explorer.mechanism import BODY_MODELS, PIN_MATERIALS, SHEET_MATERIALS, Operating, Walker
    from explorer.mechanism._model import INTERPOLATIONS
    from explorer.study import ALGORITHMS, PERTURB_METHODS, SOLVE_METHODS
    from explorer.study._spec import COMPRESSIONS, STORES
    from explorer.study._yield import DEFAULT_COPIES, DISTRIBUTIONS, UNITS

    screen = Screen()
    op = Operating()
    walker = {f.name: f.default for f in fields(Walker)}
    return {
        "PERTURB_METHODS": _choices(PERTURB_METHODS), "SOLVE_METHODS": _choices(SOLVE_METHODS),
        "COMPRESSIONS": _choices(COMPRESSIONS), "STORES": _choices(STORES), "ALGORITHMS": _choices(ALGORITHMS),
        "MATCHES": _choices(MATCHES), "IGNORES": _choices(IGNORES), "PHASES": _choices(PHASES), "BODY_MODELS": _choices(BODY_MODELS),
        "SHEET_MATERIALS": _choices(SHEET_MATERIALS), "PIN_MATERIALS": _choices(PIN_MATERIALS),
        "ROBUSTNESS_UNITS": _choices(UNITS), "DISTRIBUTIONS": _choices(DISTRIBUTIONS),
        "DEFAULT_COPIES": DEFAULT_COPIES, "INTERPOLATIONS": _choices(INTERPOLATIONS),
        "TOLERANCE": f"{DEFAULT_TOLERANCE:g}", "TOL_LO": f"{TOLERANCE_RANGE[0]:g}", "TOL_HI": f"{TOLERANCE_RANGE[1]:g}",
        "S_ANGLE": f"{screen.min_transmission_angle:g}", "S_HEAD": f"{screen.min_foot_headroom:g}",
        "S_SPEED": f"{screen.max_foot_speed:g}", "S_CROSS": screen.max_self_crossings,
        "O_GRAVITY": f"{op.gravity:g}", "O_LOAD": f"{op.load:g}", "O_FLUCT": f"{op.speed_fluctuation:g}",
        "O_GEAR": f"{op.gear_ratio:g}",
        "W_LEGS": walker.get("legs"), "W_DRAG": walker.get("drag"), "W_CONTACT": walker.get("contact"),
    }


# -- what each key means --------------------------------------------------------------------------------
#: the walker, operating and build tables read the same in a study and in a mechanism file
_WALKER = {
    "legs": "Legs on one crankshaft (default {W_LEGS}).",
    "phases": "Crank phase offset of each leg, degrees (default: evenly spaced).",
    "mirrored": "`true`: odd legs mirrored; or a list of `true`/`false`, one per leg (default: none).",
    "drag": "Drag on the body as a fraction of its weight, for the torque metrics (default {W_DRAG}).",
    "contact": "A foot within `contact` × crank radius of the ground touches it (default {W_CONTACT}).",
}
_OPERATING = {
    "unit": "Metres per model unit (Jansen's numbers are centimetres: 0.01). Required by the forces effect, "
            "`--units si` and `[robustness] unit = \"mm\"`.",
    "rpm": "The crank's constant speed, revolutions per minute (> 0). Required by the forces effect.",
    "gravity": "m/s² along −y (0: off; default {O_GRAVITY}).",
    "load": "kg: the walker's body (frame, motor, battery: everything but the legs), riding on the contact "
            "foot (default {O_LOAD}).",
    "speed_fluctuation": "The crank speed's allowed total fluctuation (ω_max − ω_min)/ω_mean that sizes the "
                         "flywheel (default {O_FLUCT}: ±2.5 %).",
    "body": "The force model: {BODY_MODELS} (default `moving`; `held` for a foot on a ground slider).",
    "gear_ratio": "Motor turns per crank turn: the motor-side flywheel is I/N² (default {O_GEAR}).",
}
_BUILD = {
    "material": "The sheet the parts are cut from: {SHEET_MATERIALS}: its density and bearing strength.",
    "thickness": "mm: one stack layer.",
    "part_width": "mm: the width of every link.",
    "density": "kg/m³ (default: the material's); links without a `mass` weigh density × thickness × part_width.",
    "unit": "Metres per model unit (as `[operating] unit`): the machine's size.",
    "pin_material": "The pins: {PIN_MATERIALS}.",
    "shaft_material": "The crankshaft: {PIN_MATERIALS}.",
}

STUDY = {
    "study": {
        "name": "Required. Letters, digits, `.`, `_`, `-`; the results file is `results/<name>.h5` by default.",
        "mechanism": "Required. A built-in name or the path of a mechanism `.toml` (looked up beside the study "
                     "file first, then in the working directory).",
        "variants": "Random methods: the number of variants N (variant 0 is always the nominal; default 10000); "
                    "`oat` and `grid`: levels per parameter (default 11); `saltelli`: base samples N "
                    "(N·(k + 2) + 1 variants; default 1024).",
        "seed": "Integer ≥ 0 (default 0): the variants are reproducible from (seed, method, spread) alone.",
        "steps": "Crank samples per cycle, ≥ 3 (default 360).",
        "tolerance": "Every solved position within tolerance × the longest link of the exact one (default "
                     "{TOLERANCE}; {TOL_LO} … {TOL_HI}).",
        "method": "The solver: {SOLVE_METHODS}.",
    },
    "perturb": {
        "method": "How the variants are drawn: {PERTURB_METHODS}.",
        "spread": "Relative, in [0, 1): ±spread (uniform, lhs, sobol, saltelli), sigma (normal), span (oat, grid). "
                  "A coordinate moves by spread × the mechanism's size.",
        "links": "`\"all\"` or a list of link names to perturb (default `\"all\"` when `parameters` is absent).",
        "crank": "Perturb the crank radius too (default true when `parameters` is absent).",
        "parameters": "Any design parameters by name (`\"2.x\"`, `\"coupler.P.y\"`, `\"piston.dx\"`, …) or "
                      "`\"all\"`; see [design parameters](../studies.md#design-parameters).",
    },
    "scene": {
        "vertices": "Vertices whose paths are stored (`\"all\"` allowed; default: the foot).",
        "velocities": "Store dV/dθ (default true).",
        "accelerations": "Store d²V/dθ² (default false).",
        "band": "Stance band of the single-leg metrics, a fraction of the path height, in (0, 1) (default 0.01).",
        "metrics": "`true` (every metric that applies), `false`, or a list of metric names.",
        "forces": "Compute the forces effect (motor torque, joint reactions, flywheel; needs `[operating] unit` "
                  "and `rpm`).",
        "force_joints": "Joints whose reactions over the turn are stored as `/forces/<joint>`.",
        "store": "{STORES}: `metrics` is a lean study, no series stored (readers re-solve them).",
    },
    "walker": _WALKER,
    "operating": _OPERATING,
    "screen": {
        "min_transmission_angle": "Degrees, in [0, 90): the crank-driven four-bar loops keep this far from "
                                  "toggle (default {S_ANGLE}).",
        "min_foot_headroom": "Model units the foot's highest point stays below the crank axle and every ground "
                             "pivot (default {S_HEAD}).",
        "max_foot_speed": "Largest peak foot speed, crank radii per radian of crank (default {S_SPEED}).",
        "max_self_crossings": "Crossings of the foot path allowed, a whole number ≥ 0 (default {S_CROSS}).",
    },
    "output": {
        "path": "The results file (default `results/<name>.h5`, relative to the working directory).",
        "compression": "Filter of the series: {COMPRESSIONS} (default `blosc`).",
    },
    "optimize": {
        "algorithm": "{ALGORITHMS} (default `auto`: DE for one objective, NSGA-II for several).",
        "population": "Designs per generation: one batch solve each.",
        "generations": "Generations to run (or `evaluations`).",
        "evaluations": "Designs to evaluate, rounded up to whole generations (instead of `generations`).",
        "objectives": "Metrics to optimise, each in its natural direction.",
        "constraints": "Conditions in the `--where` language over metrics and parameters, e.g. "
                       "`\"clearance >= 1\"`.",
        "screen": "Designs the buildability screen removes are infeasible (default true).",
        "spread": "Bounds of the listed parameters: ±spread of each length, ±spread × the size for a coordinate.",
        "parameters": "The design parameters searched.",
        "bounds": "A table of explicit bounds in model units, `\"1-3\" = [47.0, 52.0]` (over the spread).",
        "polish": "Polish the result: least squares on the path residuals (one objective `path_error`), or "
                  "SLSQP along the front (several objectives).",
        "restarts": "Answers finished beyond the best, 0 … population − 1 (default 4).",
        "polish_starts": "The round's best distinct designs the polish starts from, 0 … 100,000 (default 64; 0: off).",
        "rounds": "Restart rounds (one objective): each a fresh search from its own seed and its polish (default 1).",
        "seconds": "A round begins only while the run has taken less than this many seconds (default: no limit).",
        "repeat": "The rounds stop once this many have reached the same best value (0: never; default 3).",
        "atlas": "Polish starts from the mechanism's cached curve atlas too: `\"auto\"` (default), an atlas file, "
                 "or false.",
    },
    "target": {
        "points": "The target path: `[[x, y], ...]` in model units.",
        "csv": "Or a CSV file of the points (header `x,y`, optionally `angle_deg`), relative to the study file.",
        "angles_deg": "Prescribed crank angles, degrees, one per point (then `match` defaults to `timed`).",
        "match": "How points meet the foot path: {MATCHES}.",
        "ignore": "What the error ignores: a list of {IGNORES}.",
        "phase": "{PHASES}: with `free` (timed points) the angles are known up to a common shift.",
        "closed": "True when the points go once round a closed curve (the polish matches them in order).",
    },
    "robustness": {
        "tolerance": "± this much on every design parameter, in `unit` (the `yield` metric).",
        "unit": "{ROBUSTNESS_UNITS}: `%` lengths relatively and coordinates in % of the size; `mm` needs "
                "`[operating] unit`.",
        "distribution": "{DISTRIBUTIONS}: uniform on ±tolerance, or normal with σ = tolerance / 3.",
        "copies": "Copies per design (default {DEFAULT_COPIES}).",
        "seed": "Seed of the errors (common random numbers: every design gets the same cuts).",
        "parameters": "`\"all\"` (default) or a list of design parameter names to cut.",
    },
    "build": _BUILD,
}

MECHANISM = {
    "": {
        "name": "Required. The mechanism's name.",
        "description": "One line of text.",
        "foot": "Required. The vertex whose path is the gait (a moving vertex).",
        "crank": "The driver: a `[crank]` table (or a `[driver]` table, not both).",
        "driver": "The driver: a prescribed path or a linear actuator (instead of `[crank]`).",
        "fixed": "Ground pivots: `name = [x, y]`.",
        "guess": "Rough positions of the moving vertices at θ = 0, `name = [x, y]`: they choose the assembly "
                 "(branch).",
        "links": "Rigid links, one `[[links]]` table each.",
        "bodies": "Rigid bodies of three or more joints, one `[[bodies]]` table each.",
        "sliders": "Prismatic joints, one `[[sliders]]` table each.",
        "gears": "Grounded cranks geared to the driving crank, one `[[gears]]` table each.",
        "walker": "The leg's default walker scene (a study's `[walker]` overrides it key by key).",
        "mass": "Masses for the forces effect.",
        "operating": "The default operating point (a study's `[operating]` overrides it key by key).",
        "build": "How the design is made (a study's `[build]` overrides it key by key).",
    },
    "crank": {
        "center": "`[x, y]`: the crank's centre.",
        "radius": "The crank radius, model units.",
        "tip": "The vertex driven around the circle, θ counter-clockwise from +x.",
        "mass": "kg: a uniform bar from the centre to the tip (forces).",
    },
    "fixed": {},
    "guess": {},
    "links": {
        "a": "Required. One end vertex.",
        "b": "Required. The other end vertex.",
        "length": "Required. Model units, a finite number from 1e-9 to 1e9.",
        "name": "The link's name (default `\"a-b\"`): it names a design parameter and a column.",
        "mass": "kg: a uniform bar (forces).",
    },
    "bodies": {
        "name": "Required. Letters, digits, `_ + -`: it names parameters such as `coupler.P.x`.",
        "joints": "Required. `{{ B = [0, 0], C = [2.5, 0], P = [5, 0] }}`: the joints in the body's own frame "
                  "(only the shape counts; they may be collinear).",
        "mass": "kg (forces).",
        "centroid": "`[x, y]` in the body's frame (default: the mean of its joints).",
        "inertia": "kg·m² about the centroid (default: the mass shared equally among its joints).",
    },
    "sliders": {
        "name": "Required. Letters, digits, `_ + -`: it names parameters such as `piston.x`, `block.offset`.",
        "vertex": "Required. The vertex that slides.",
        "point": "A ground line: a point on it …",
        "direction": "… and its direction (only the direction counts).",
        "line": "A slot instead: `[a, b]`, two vertices one link or body holds at a fixed distance.",
        "offset": "A slot's offset, model units to the left of a → b (default 0).",
    },
    "gears": {
        "name": "Required. Letters, digits, `_ + -`: it names parameters `gear` (the radius), `gear.x`, `gear.y`.",
        "center": "Required. The geared crank's ground pivot `[x, y]`, model units.",
        "radius": "Required. Its radius, model units.",
        "tip": "Required. Its tip: a new vertex, placed exactly from the crank's angle.",
        "ratio": "Required. A nonzero integer from −64 to 64: its turns per turn of the crank (negative: the other way).",
        "phase": "Degrees added to ratio × θ (default 0).",
    },
    "driver": {
        "vertex": "A path driver: the vertex driven along the path.",
        "path": "`line` (start, end), `arc` (center, radius, start_angle, end_angle) or `points`.",
        "start": "`path = \"line\"`: its start `[x, y]`.",
        "end": "`path = \"line\"`: its end `[x, y]`.",
        "center": "`path = \"arc\"`: its centre `[x, y]`.",
        "radius": "`path = \"arc\"`: its radius.",
        "start_angle": "`path = \"arc\"`: degrees.",
        "end_angle": "`path = \"arc\"`: degrees.",
        "points": "`path = \"points\"`: `[[x, y], ...]`, followed by a natural cubic spline.",
        "duration": "Seconds the move takes; velocities are then per second.",
        "timing": "`linear` or `quintic` (rest-to-rest).",
        "slider": "A linear actuator instead: the `[[sliders]]` table (a ground line) whose vertex it drives.",
        "stroke": "The actuator's `[from, to]`, model units along the line from its point.",
        "orientation": "A spherical wrist's keyframes: rotation matrices, `{{euler = [a, b, c], seq = \"ZYX\"}}` "
                       "or `{{axis = [x, y, z], angle = a}}`; see "
                       "[orientation paths](../mechanisms.md#orientation-paths-the-arms-spherical-wrist-seed-004-problem-1).",
        "interpolation": "Between keyframes: {INTERPOLATIONS} (default `slerp`).",
        "wrist": "The wrist's joint axes, an upper-case (intrinsic) sequence (default `ZYZ`).",
        "wrist_branch": "1 or 2: the wrist's joint solution at the start.",
        "euler_seq": "For `interpolation = \"euler\"`: the sequence (default: the wrist's).",
        "euler_set": "For `interpolation = \"euler\"`: the first keyframe's solution set.",
    },
    "walker": _WALKER,
    "mass": {
        "link_density": "kg per metre of link, for every link (and the crank) without its own `mass`.",
    },
    "operating": _OPERATING,
    "build": _BUILD,
}


def _accepted() -> tuple[dict, dict]:
    from explorer.mechanism import MECHANISM_KEYS
    from explorer.study import STUDY_KEYS
    return ({k: tuple(v) for k, v in STUDY_KEYS.items()},
            {k: tuple(v) for k, v in MECHANISM_KEYS.items()})


def problems() -> list[str]:
    """Every key the loaders accept with no words here, and every key described that they no longer accept."""
    out = []
    study, mechanism = _accepted()
    for what, accepted, words in (("study", study, STUDY), ("mechanism", mechanism, MECHANISM)):
        for table, keys in accepted.items():
            doc = words.get(table)
            if doc is None:
                out.append(f"{what} file: table [{table or 'top level'}] is not described")
                continue
            out += [f"{what} file: [{table or 'top level'}] {k} is not described" for k in keys if k not in doc]
            out += [f"{what} file: [{table or 'top level'}] {k} is described but not accepted" for k in doc
                    if k not in keys]
        out += [f"{what} file: [{t}] is described but not accepted" for t in words if t not in accepted]
    return out


def _table(title: str, keys, words: dict, facts: dict) -> list[str]:
    order = [k for k in words if k in keys] + [k for k in keys if k not in words]
    rows = [f"## {title}", ""]
    if not order:
        return rows
    rows += ["| key | meaning |", "|---|---|"]
    for k in order:
        text = words.get(k, "**not described**").format(**facts)
        assert "|" not in text, text  # a pipe would split the table's cell
        rows.append(f"| `{k}` | {text} |")
    return rows + [""]


def study_page() -> str:
    facts = _facts()
    accepted, _ = _accepted()
    lines = ["# Study file reference", "",
             "Generated from the study validator's key tables (`explorer.study.STUDY_KEYS`) by "
             "`scripts/docs_reference.py` each time the site is built: every key a study file may hold, "
             "with the choices and defaults the code holds. Every key is checked: an unknown key, a wrong "
             "type or a value out of range is a one-line error naming the file, the key and what is allowed "
             "(exit 2). A guided tour is in [Studies](../studies.md).", ""]
    for sec, keys in accepted.items():
        lines += _table(f"[{sec}]", keys, STUDY.get(sec, {}), facts)
    return "\n".join(lines).rstrip() + "\n"


def mechanism_page() -> str:
    facts = _facts()
    _, accepted = _accepted()
    lines = ["# Mechanism file reference", "",
             "Generated from the mechanism loader's key tables (`explorer.mechanism.MECHANISM_KEYS`) by "
             "`scripts/docs_reference.py` each time the site is built. Every mistake in a file is one line "
             "naming the file, the key and the value (exit 2). A guided tour is in "
             "[Mechanisms are data](../mechanisms.md); `[fixed]` and `[guess]` take vertex names as keys.", ""]
    names = {"": "Top level", "links": "[[links]]", "bodies": "[[bodies]]", "sliders": "[[sliders]]",
             "gears": "[[gears]]"}
    for table, keys in accepted.items():
        lines += _table(names.get(table, f"[{table}]"), keys, MECHANISM.get(table, {}), facts)
        if table in ("fixed", "guess"):
            lines += ["Keys are vertex names (1–64 letters, digits or `_ . + -`), values `[x, y]` in model units.",
                      ""]
    return "\n".join(lines).rstrip() + "\n"


def pages() -> dict[str, str]:
    """{path under docs/: markdown} of the generated pages; RuntimeError naming every undescribed or stale key."""
    bad = problems()
    if bad:
        raise RuntimeError("the file references are out of date with the loaders (scripts/docs_reference.py): "
                           + "; ".join(bad))
    return {STUDY_PAGE: study_page(), MECHANISM_PAGE: mechanism_page()}


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv == ["--check"]:
        bad = problems()
        print("\n".join(bad) or "every key the loaders accept is described")
        return 1 if bad else 0
    if len(argv) != 1:
        print(__doc__)
        return 2
    out = Path(argv[0])
    for name, text in pages().items():
        (out / Path(name).name).parent.mkdir(parents=True, exist_ok=True)
        (out / Path(name).name).write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
