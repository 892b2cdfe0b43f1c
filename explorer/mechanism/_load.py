"""Reading and validating mechanism TOML files (the file shape is a public contract)."""

from __future__ import annotations

import math
import tomllib
import unicodedata
from dataclasses import replace
from importlib import resources
from pathlib import Path

from ..errors import UserError, where
from ._build import BUILD_KEYS
from ._model import (BODY_MODELS, LENGTH_RANGE, NAME_RE, Body, Crank, Gear, Link, Mechanism, Operating, PathDriver, Slider,
                     Walker, _check_length, _short, actuator_path, bounded_number)

_TOP_KEYS = {"name", "description", "foot", "crank", "driver", "fixed", "guess", "links", "walker", "bodies", "mass",
             "operating", "sliders", "build", "gears"}
#: Keys of an [operating] table (in a study, or a mechanism file's default), see :class:`Operating`.
OPERATING_KEYS = ("unit", "rpm", "gravity", "load", "speed_fluctuation", "body", "gear_ratio")
#: Keys of a [walker] table (in a mechanism file: the leg's default walker; in a study: overrides).
WALKER_KEYS = ("legs", "phases", "mirrored", "drag", "contact")
#: Most legs a walker may have.
MAX_LEGS = 64
_DRIVER_KEYS = {"vertex", "path", "start", "end", "center", "radius", "start_angle", "end_angle", "points",
                "duration", "timing", "slider", "stroke"}
_PATH_KEYS = {"line": {"start", "end"}, "arc": {"center", "radius", "start_angle", "end_angle"}, "points": {"points"}}
#: A path driver's orientation keys (a spherical wrist on its vertex, seed 004 problem 1).
_ORIENTATION_KEYS = {"orientation", "interpolation", "wrist", "wrist_branch", "euler_seq", "euler_set"}
_DRIVER_KEYS = _DRIVER_KEYS | _ORIENTATION_KEYS
_CRANK_KEYS = {"center", "radius", "tip", "mass"}
_LINK_KEYS = {"a", "b", "length", "name", "mass"}
_BODY_KEYS = {"name", "joints", "mass", "centroid", "inertia"}
_SLIDER_KEYS = {"name", "vertex", "point", "direction", "line", "offset"}
_GEAR_KEYS = {"name", "center", "radius", "tip", "ratio", "phase"}
#: A linear actuator's [driver] keys (``slider`` instead of ``vertex`` and ``path``).
_ACTUATOR_KEYS = {"slider", "stroke", "duration", "timing"}
_MASS_KEYS = {"link_density"}
#: Every table of a mechanism file and the keys it accepts ("" is the top level; [fixed] and [guess] take
#: vertex names): what the docs' mechanism-file reference is generated from.
MECHANISM_KEYS = {"": _TOP_KEYS, "crank": _CRANK_KEYS, "fixed": set(), "guess": set(), "links": _LINK_KEYS,
                  "bodies": _BODY_KEYS, "sliders": _SLIDER_KEYS, "driver": _DRIVER_KEYS, "walker": set(WALKER_KEYS),
                  "mass": _MASS_KEYS, "operating": set(OPERATING_KEYS), "build": set(BUILD_KEYS),
                  "gears": _GEAR_KEYS}
#: Largest mass (kg) or inertia (kg·m²) accepted: beyond it the forces overflow long before any build.
_MAX_MASS = 1e12


def builtin_mechanisms() -> tuple[str, ...]:
    """Names of the mechanisms shipped with explorer (``jansen``, ``fourbar``, ...)."""
    folder = resources.files("explorer.mechanism") / "builtin"
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml")))


def load_mechanism(name_or_path) -> Mechanism:
    """Load a built-in mechanism by name (``"jansen"``) or any mechanism ``.toml`` file by path.

    Raises :class:`~explorer.errors.UserError` with a one-line message naming the file and key for
    malformed files, unknown vertices, duplicate links, non-positive or non-finite lengths, a missing
    guess, or a graph that does not have exactly one degree of freedom driven by the crank.
    """
    text, source = _read(name_or_path)
    data = parse_toml(text, source)
    return mechanism_from_dict(data, source)


def parse_toml(text: str, source: str) -> dict:
    """tomllib.loads with one-line errors: invalid TOML, or nesting too deep for the parser. A leading
    byte-order mark (what Windows editors write at the start of a UTF-8 file) is not part of the TOML."""
    try:
        return tomllib.loads(text[1:] if text.startswith("\ufeff") else text)
    except tomllib.TOMLDecodeError as exc:
        raise UserError(f"{source}: not valid TOML: {exc}") from None
    except RecursionError:
        raise UserError(f"{source}: not valid TOML here: arrays or tables nested too deeply") from None


def _read(name_or_path) -> tuple[str, str]:
    s = str(name_or_path)
    # a built-in name wins unless a *file* of that name exists (a folder called "jansen" in the
    # working directory must not hide the built-in)
    if s in builtin_mechanisms() and not Path(s).is_file():
        res = resources.files("explorer.mechanism") / "builtin" / f"{s}.toml"
        return res.read_text(encoding="utf-8"), f"builtin:{s}"
    path = Path(s)
    if not path.is_file():
        raise UserError(
            f"{s}: no such mechanism file or built-in (built-ins: {', '.join(builtin_mechanisms())})"
        )
    try:
        return path.read_text(encoding="utf-8"), str(path)
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{s}: cannot read: {exc}") from None


def _point(source: str, key: str, value) -> tuple[float, float]:
    ok = isinstance(value, list) and len(value) == 2 and all(
        isinstance(c, (int, float)) and not isinstance(c, bool) for c in value
    )
    if not ok or not all(math.isfinite(float(c)) for c in value):
        raise UserError(f"{where(source, key)}: expected [x, y] with two finite numbers, got {value!r}")
    return float(value[0]), float(value[1])


def _string(source: str, key: str, value) -> str:
    if not isinstance(value, str) or not value:
        raise UserError(f"{where(source, key)}: expected a non-empty string, got {value!r}")
    _printable(source, key, value)
    return value


def _printable(source: str, key: str, value: str, text: bool = False) -> None:
    """UserError if ``value`` holds a control character or a character that XML cannot hold: names are
    printed, and written into SVG, DXF and HTML files. A ``text`` (the description) may hold tab, newline
    and the controls XML allows (DEL, C1); a name none."""
    for c in value:
        if text and (c in "\t\n\r" or ord(c) >= 0x7F):
            bad = unicodedata.category(c) == "Cs" or c in "\ufffe\uffff"
        else:
            bad = unicodedata.category(c) in ("Cc", "Cs") or c in "\ufffe\uffff"
        if bad:
            raise UserError(f"{where(source, key)}: {value!r} holds the control character U+{ord(c):04X}; names "
                            f"and descriptions must be printable (they are shown, and written into SVG, DXF and "
                            f"HTML files)")


def _table(source: str, key: str, value) -> dict:
    if not isinstance(value, dict):
        raise UserError(f"{where(source, key)}: expected a table, got {value!r}")
    return value


def _unknown_keys(source: str, prefix: str, table: dict, allowed: set[str]) -> None:
    for k in table:
        if k not in allowed:
            raise UserError(
                f"{where(source, prefix + k)}: unknown key (allowed: {', '.join(sorted(allowed))})"
            )


#: A triangle of links whose two shorter sides sum to the longest within this fraction of it is flat.
FLAT_TRIANGLE = 1e-9


def _flat_triangles(source: str, links: list[Link]) -> None:
    """Refuse three links that close a triangle with its three joints on one line (a + b = c, to
    :data:`FLAT_TRIANGLE`; a triangle that cannot close, a + b < c, is the solver's to report): such a
    triangle sits on a fold, where its two assemblies meet, and a collinear coupler is one [[bodies]]
    table instead (its joints may be collinear)."""
    index = {frozenset((ln.a, ln.b)): i for i, ln in enumerate(links)}
    around: dict[str, set] = {}
    for ln in links:
        around.setdefault(ln.a, set()).add(ln.b)
        around.setdefault(ln.b, set()).add(ln.a)
    for i, ln in enumerate(links):
        for c in sorted(around[ln.a] & around[ln.b]):
            three = sorted((i, index[frozenset((ln.a, c))], index[frozenset((ln.b, c))]))
            if i != three[0]:
                continue  # each triangle once, from its first link
            sides = sorted(three, key=lambda j: links[j].length)
            a, b, longest = (links[j].length for j in sides)
            if abs(a + b - longest) <= FLAT_TRIANGLE * longest:
                names = ", ".join(repr(links[j].name) for j in three)
                raise UserError(
                    f"{where(source, f'links[{sides[2]}]')}: links {names} make a flat triangle ({a:g} + {b:g} "
                    f"= {longest:g}): its three joints lie on one line, on a fold "
                    f"where the solver cannot tell its two assemblies apart; write a collinear coupler as one "
                    f"[[bodies]] table (its joints may lie on a line)")


def mechanism_from_dict(data: dict, source: str = "<dict>") -> Mechanism:
    """Validate a parsed mechanism table (the TOML shape) and build a :class:`Mechanism`."""
    _table(source, "", data)
    _unknown_keys(source, "", data, _TOP_KEYS)
    for k in ("name", "foot", "links"):
        if k not in data:
            raise UserError(f"{where(source, k)}: missing required key")
    if ("crank" in data) == ("driver" in data):
        raise UserError(f"{where(source, 'crank')}: give exactly one driver: a [crank] table or a [driver] path table")
    name = _string(source, "name", data["name"])
    description = data.get("description", "")
    if not isinstance(description, str):
        raise UserError(f"{where(source, 'description')}: expected a string, got {description!r}")
    _printable(source, "description", description, text=True)

    crank, path = (_crank(source, data["crank"]), None) if "crank" in data else (None, _driver(source, data["driver"]))
    if path is not None and path.slider is not None:  # a linear actuator drives its slider's vertex
        path = replace(path, vertex=_actuated_vertex(source, data.get("sliders"), path.slider))
    tip = crank.tip if crank is not None else path.vertex
    fixed = {
        str(k): _point(source, f"fixed.{k}", v)
        for k, v in _table(source, "fixed", data.get("fixed", {})).items()
    }
    guess = {
        str(k): _point(source, f"guess.{k}", v)
        for k, v in _table(source, "guess", data.get("guess", {})).items()
    }
    for key, names in (("fixed", fixed), ("guess", guess), ("crank.tip" if crank is not None else "driver.vertex", [tip])):
        for v in names:
            if not NAME_RE.fullmatch(v):
                k = key if key in ("crank.tip", "driver.vertex") else f"{key}.{v}"
                raise UserError(f"{where(source, k)}: vertex name {v!r} must be 1 to 64 letters, digits or _ . + - "
                                f"(it names datasets in results files)")
    if tip in fixed:
        raise UserError(f"{where(source, 'fixed.' + tip)}: vertex {tip!r} is the driven vertex and cannot be fixed")
    for v in guess:
        if v in fixed or v == tip:
            raise UserError(f"{where(source, 'guess.' + v)}: vertex {v!r} is fixed or driven and takes no guess")

    gears = _gears(source, data.get("gears", []), crank, fixed, guess)
    guess.update({g.tip: g.tip_at(0.0) for g in gears})  # a geared crank's tip: its exact place at θ = 0

    raw_links = data["links"]
    if raw_links == [] and data.get("bodies"):
        raw_links = None  # a mechanism of bodies only
    elif not isinstance(raw_links, list) or not raw_links:
        raise UserError(f"{where(source, 'links')}: expected one or more [[links]] tables, got {raw_links!r}")
    vertices = [tip, *fixed, *guess]
    known = set(vertices)
    links: list[Link] = []
    seen_names: set[str] = set()
    seen_pairs: dict[frozenset, str] = {}
    for i, lt in enumerate(raw_links or []):
        key = f"links[{i}]"
        _table(source, key, lt)
        _unknown_keys(source, key + ".", lt, _LINK_KEYS)
        for k in ("a", "b", "length"):
            if k not in lt:
                raise UserError(f"{where(source, f'{key}.{k}')}: missing required key")
        a = _string(source, f"{key}.a", lt["a"])
        b = _string(source, f"{key}.b", lt["b"])
        for end, v in (("a", a), ("b", b)):
            if v not in known:
                raise UserError(
                    f"{where(source, f'{key}.{end}')}: vertex {v!r} is neither driven, fixed, nor in "
                    f"[guess] (a missing guess or an unknown vertex)"
                )
        if a == b:
            raise UserError(f"{where(source, key)}: link joins vertex {a!r} to itself")
        lname = _string(source, f"{key}.name", lt.get("name", f"{a}-{b}"))
        if not NAME_RE.fullmatch(lname):
            raise UserError(f"{where(source, f'{key}.name')}: link name {lname!r} must be 1 to 64 letters, digits or "
                            f"_ . + - (it names a column of results)")
        length = _check_length(source, f"{key}.length", lt["length"])
        if lname in seen_names:
            raise UserError(f"{where(source, f'{key}.name')}: duplicate link name {lname!r}")
        pair = frozenset((a, b))
        if pair in seen_pairs:
            raise UserError(f"{where(source, key)}: duplicate link {a}-{b} (already given as {seen_pairs[pair]!r})")
        seen_names.add(lname)
        seen_pairs[pair] = lname
        mass = _mass(source, f"{key}.mass", lt["mass"]) if "mass" in lt else None
        links.append(Link(lname, a, b, length, mass))

    _flat_triangles(source, links)
    bodies = _bodies(source, data.get("bodies", []), known, fixed, seen_pairs, seen_names)
    sliders = _sliders(source, data.get("sliders", []), known, fixed, tip, seen_pairs, seen_names,
                       path.slider if path is not None else None)
    if path is not None and path.slider is not None:
        path = actuator_path(path, next(s for s in sliders if s.name == path.slider))
    foot = _string(source, "foot", data["foot"])
    if foot not in known:
        raise UserError(f"{where(source, 'foot')}: unknown vertex {foot!r} (known: {', '.join(vertices)})")
    if foot in fixed:
        raise UserError(f"{where(source, 'foot')}: vertex {foot!r} is fixed; the foot must be a moving vertex")
    _check_degrees_of_freedom(source, tip, "crank.tip" if crank is not None else "driver.vertex", fixed, guess, links,
                              bodies, [s for s in sliders if path is None or s.name != path.slider], gears)
    walker = None
    if "walker" in data:
        if crank is None:
            raise UserError(f"{where(source, 'walker')}: a walker needs a crank; this mechanism is driven by a path")
        walker = walker_from_dict(data["walker"], source, "walker")
    link_density = None
    if "mass" in data:
        mt = _table(source, "mass", data["mass"])
        _unknown_keys(source, "mass.", mt, _MASS_KEYS)
        if "link_density" in mt:
            link_density = _mass(source, "mass.link_density", mt["link_density"], "a density in kg per metre of link")
    operating = operating_from_dict(data["operating"], source) if "operating" in data else None
    if operating is not None and operating.load and crank is None:
        raise UserError(f"{where(source, 'operating.load')}: a load is carried by a walker's contact foot; this "
                        f"mechanism is driven by a path, got {_short(operating.load)}")
    mech = Mechanism(name, description, tuple(vertices), tuple(links), crank, fixed, guess, foot, source, path,
                     walker, bodies, link_density, operating, sliders, gears)
    if "build" in data:  # the design's build: its link masses and size (explorer.mechanism._build)
        from ._build import apply_build, build_from_dict
        mech = apply_build(mech, build_from_dict(data["build"], source), source, explicit_density=link_density)
    _check_parameter_names(mech)
    if operating is not None and operating.body is not None:
        walker_body(mech, operating, source)
    return mech


def walker_body(mech: Mechanism, operating: Operating, source: str, key: str = "operating") -> Operating:
    """``operating`` with its ``body`` force model resolved for ``mech``: as given, else "moving", or
    "held" for a foot that runs on a ground slider (it is guided by the frame: no body walks on it).
    UserError naming ``source``, ``key.body`` and the value for "moving" on such a foot."""
    rail = next((sl for sl in mech.sliders if sl.ground and sl.vertex == mech.foot), None)
    if operating.body is None:
        return replace(operating, body="held" if rail is not None else "moving")
    if operating.body == "moving" and rail is not None:
        raise UserError(f"{where(source, key + '.body')}: the foot {mech.foot!r} runs on the ground slider "
                        f"{rail.name!r}, so no body walks on it; use body = \"held\", got 'moving'")
    return operating


def _named_table(source: str, key: str, t, allowed, required, seen_names: set, what: str, example: str,
                 clash: str) -> str:
    """Check one ``[[bodies]]`` or ``[[sliders]]`` table's keys and name (a parameter prefix, unique among
    links, bodies and sliders: added to ``seen_names``); returns the name."""
    _table(source, key, t)
    _unknown_keys(source, key + ".", t, allowed)
    for k in required:
        if k not in t:
            raise UserError(f"{where(source, f'{key}.{k}')}: missing required key")
    name = _string(source, f"{key}.name", t["name"])
    if not NAME_RE.fullmatch(name) or "." in name:
        raise UserError(f"{where(source, f'{key}.name')}: {what} name {name!r} must be 1 to 64 letters, digits or "
                        f"_ + - (no '.': it names parameters such as {example.format(name)})")
    if name in seen_names:
        raise UserError(f"{where(source, f'{key}.name')}: {name!r} already names {clash}")
    seen_names.add(name)
    return name


def _bodies(source: str, raw, known: set, fixed: dict, seen_pairs: dict, seen_names: set) -> tuple[Body, ...]:
    """The ``[[bodies]]`` tables: a name and ``joints = { J = [x, y], ... }`` in the body's own frame."""
    if not isinstance(raw, list):
        raise UserError(f"{where(source, 'bodies')}: expected [[bodies]] tables, got {raw!r}")
    out = []
    for i, bt in enumerate(raw):
        key = f"bodies[{i}]"
        bname = _named_table(source, key, bt, _BODY_KEYS, ("name", "joints"), seen_names, "body", "{}.P.x",
                             "a link or another body")
        jt = _table(source, f"{key}.joints", bt["joints"])
        if len(jt) < 2:
            raise UserError(f"{where(source, f'{key}.joints')}: a body carries two or more joints, got {len(jt)}")
        joints, points = [], []
        for j, xy in jt.items():
            if j not in known:
                raise UserError(f"{where(source, f'{key}.joints.{j}')}: vertex {j!r} is neither driven, fixed, nor in "
                                f"[guess] (a missing guess or an unknown vertex)")
            joints.append(str(j))
            points.append(_point(source, f"{key}.joints.{j}", xy))
        for a in range(len(points)):
            for b in range(a):
                d = math.dist(points[a], points[b])
                if not d >= LENGTH_RANGE[0]:
                    raise UserError(f"{where(source, f'{key}.joints.{joints[a]}')}: joints {joints[b]} and {joints[a]} "
                                    f"sit at the same point of the body")
                if not d <= LENGTH_RANGE[1]:
                    raise UserError(f"{where(source, f'{key}.joints.{joints[a]}')}: joints {joints[b]} and {joints[a]} "
                                    f"are {d:g} apart; a body's dimensions, like lengths, go up to "
                                    f"{LENGTH_RANGE[1]:g} model units")
                pair = frozenset((joints[a], joints[b]))
                if pair in seen_pairs:
                    raise UserError(f"{where(source, f'{key}.joints')}: joints {joints[b]} and {joints[a]} are already "
                                    f"held at a fixed distance by {seen_pairs[pair]!r} (over-constrained)")
                seen_pairs[pair] = f"body {bname}"
        n_fixed = sum(j in fixed for j in joints)
        if n_fixed > 1:
            raise UserError(f"{where(source, f'{key}.joints')}: body {bname!r} has {n_fixed} fixed joints: it is the "
                            f"ground; list its joints under [fixed] instead")
        mass = _mass(source, f"{key}.mass", bt["mass"]) if "mass" in bt else 0.0
        centroid = None
        if "centroid" in bt:
            centroid = _point(source, f"{key}.centroid", bt["centroid"])
            span = max(math.dist(a, b) for a in points for b in points)
            near = min(math.dist(centroid, p) for p in points)
            if near > span:
                raise UserError(f"{where(source, f'{key}.centroid')}: {list(centroid)} is {near:g} model units from the "
                                f"nearest joint, farther than the body's own span ({span:g}): a centre of mass lies "
                                f"within its body (coordinates in the body's frame, like its joints)")
        inertia = _mass(source, f"{key}.inertia", bt["inertia"], "an inertia in kg·m² about the centroid") \
            if "inertia" in bt else None
        out.append(Body(bname, tuple(joints), tuple(points), mass, centroid, inertia))
    return tuple(out)


def _actuated_vertex(source: str, raw, name: str) -> str:
    """The vertex of the ``[[sliders]]`` table called ``name`` (a linear actuator's), before the sliders
    are validated: it is the driven vertex."""
    for i, st in enumerate(raw if isinstance(raw, list) else []):
        if isinstance(st, dict) and st.get("name") == name:
            if "point" not in st or "line" in st:
                raise UserError(f"{where(source, 'driver.slider')}: a linear actuator pushes a slider on a ground line "
                                f"(with point and direction); {name!r} is a slot, got {name!r}")
            return _string(source, f"sliders[{i}].vertex", st.get("vertex"))
    raise UserError(f"{where(source, 'driver.slider')}: no [[sliders]] table is called {name!r}")


def _sliders(source: str, raw, known: set, fixed: dict, tip: str, seen_pairs: dict, seen_names: set,
             actuated: str | None) -> tuple[Slider, ...]:
    """The ``[[sliders]]`` tables: a vertex on a ground line (``point``, ``direction``) or in a slot
    (``line = [a, b]``, two vertices one link or body holds, and an ``offset``)."""
    if not isinstance(raw, list):
        raise UserError(f"{where(source, 'sliders')}: expected [[sliders]] tables, got {raw!r}")
    out = []
    for i, st in enumerate(raw):
        key = f"sliders[{i}]"
        name = _named_table(source, key, st, _SLIDER_KEYS, ("name", "vertex"), seen_names, "slider", "{}.x",
                            "a link, body or slider")
        v = _string(source, f"{key}.vertex", st["vertex"])
        if v not in known:
            raise UserError(f"{where(source, f'{key}.vertex')}: vertex {v!r} is neither driven, fixed, nor in [guess] "
                            f"(a missing guess or an unknown vertex)")
        ground = "point" in st or "direction" in st
        if ground == ("line" in st):
            raise UserError(f"{where(source, key)}: give either point and direction (a line fixed to the ground) or "
                            f"line = [a, b] (a slot in a moving link or body), got keys {', '.join(sorted(st))}")
        if ground and v in fixed:  # (a fixed vertex in a slot is a swinging block: the slot turns through it)
            raise UserError(f"{where(source, f'{key}.vertex')}: vertex {v!r} is fixed; a slider on a ground line moves")
        if ground:
            for k in ("point", "direction"):
                if k not in st:
                    raise UserError(f"{where(source, f'{key}.{k}')}: missing required key for a ground slider")
            if "offset" in st:
                raise UserError(f"{where(source, f'{key}.offset')}: a ground line takes no offset (move its point), "
                                f"got {_short(st['offset'])}")
            point = _point(source, f"{key}.point", st["point"])
            direction = _point(source, f"{key}.direction", st["direction"])
            if not LENGTH_RANGE[0] <= math.hypot(*direction) <= LENGTH_RANGE[1]:
                raise UserError(f"{where(source, f'{key}.direction')}: a direction must have a length from "
                                f"{LENGTH_RANGE[0]:g} to {LENGTH_RANGE[1]:g}, got {st['direction']!r}")
            if v == tip and name != actuated:
                raise UserError(f"{where(source, f'{key}.vertex')}: vertex {v!r} is the driven vertex; a ground line "
                                f"through it would lock the driver (use [driver] slider = {name!r} for an actuator)")
            out.append(Slider(name, v, point=point, direction=direction))
            continue
        line = st["line"]
        if not (isinstance(line, list) and len(line) == 2 and all(isinstance(x, str) for x in line)):
            raise UserError(f"{where(source, f'{key}.line')}: expected [a, b], two vertex names, got {line!r}")
        for x in line:
            if x not in known:
                raise UserError(f"{where(source, f'{key}.line')}: vertex {x!r} is neither driven, fixed, nor in [guess]")
        a, b = line
        if v in line or a == b:
            raise UserError(f"{where(source, f'{key}.line')}: a slot is the line through two other vertices than the "
                            f"slider's own {v!r}, got {line!r}")
        if frozenset(line) not in seen_pairs:
            raise UserError(f"{where(source, f'{key}.line')}: {a} and {b} are not held at a fixed distance by one link "
                            f"or body; a slot runs along a rigid member (a link's ends or two joints of one body)")
        offset = st.get("offset", 0.0)
        if isinstance(offset, bool) or not isinstance(offset, (int, float)) or not math.isfinite(offset) \
                or abs(offset) > LENGTH_RANGE[1]:
            raise UserError(f"{where(source, f'{key}.offset')}: expected a finite number of model units, "
                            f"got {_short(offset)}")
        out.append(Slider(name, v, line=(a, b), offset=float(offset)))
    return tuple(out)


def _check_parameter_names(mech: Mechanism) -> None:
    """Design parameters share one namespace (link names, "crank", "crank.x", "2.x", "body.J.x"): two
    that would share a name are refused, naming where the second comes from."""
    seen = set()
    for name, _ in mech.parameter_items():
        if name in seen:
            key = next((f"links[{i}].name" for i, l in enumerate(mech.links) if l.name == name),
                       next((f"fixed.{v}" for v in mech.fixed if name in (f"{v}.x", f"{v}.y")),
                            next((f"sliders[{i}].name" for i, sl in enumerate(mech.sliders)
                                  if name.startswith(sl.name + ".")),
                                 next((f"gears[{i}].name" for i, g in enumerate(mech.gears)
                                       if name == g.name or name.startswith(g.name + ".")), "bodies"))))
            raise UserError(f"{where(mech.source, key)}: two design parameters would be called {name!r} (a link, the "
                            f"crank's or a ground pivot's coordinates, a body joint's, a slider's); rename the link or vertex")
        seen.add(name)


def walker_from_dict(table, source: str, key: str = "walker", base: Walker | None = None) -> Walker:
    """Validate a ``[walker]`` table (keys :data:`WALKER_KEYS`; phases in degrees) into a :class:`Walker`.

    Keys it leaves out come from ``base`` (default: :class:`Walker`'s defaults); giving ``legs``
    without ``phases`` or ``mirrored`` resets those to evenly spaced, none mirrored.
    One-line UserError naming ``source``, the key and the value on anything invalid.
    """
    t = _table(source, key, table)
    _unknown_keys(source, key + ".", t, set(WALKER_KEYS))
    base = base if base is not None else Walker()

    def fail(k, allowed, value):
        raise UserError(f"{where(source, f'{key}.{k}')}: expected {allowed}, got {value!r}")

    legs = t.get("legs", base.legs)
    if isinstance(legs, bool) or not isinstance(legs, int) or not 1 <= legs <= MAX_LEGS:
        fail("legs", f"a whole number of legs from 1 to {MAX_LEGS}", legs)
    keep = "legs" not in t or legs == base.legs
    phases = base.phases if keep else ()
    if "phases" in t:
        p = t["phases"]
        if (not isinstance(p, list) or len(p) != legs
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in p)):
            fail("phases", f"a list of {legs} finite crank phase offsets in degrees, one per leg", p)
        phases = tuple(math.radians(x) for x in p)
    mirrored = base.mirrored if keep else ()
    if "mirrored" in t:
        m = t["mirrored"]
        if isinstance(m, bool):
            mirrored = tuple(m and j % 2 == 1 for j in range(legs))
        elif isinstance(m, list) and len(m) == legs and all(isinstance(x, bool) for x in m):
            mirrored = tuple(m)
        else:
            fail("mirrored", f"true (odd legs mirrored), false, or a list of {legs} true/false, one per leg", m)
    drag = t.get("drag", base.drag)
    if isinstance(drag, bool) or not isinstance(drag, (int, float)) or not (math.isfinite(drag) and drag >= 0):
        fail("drag", "a drag force as a fraction of the weight, a finite number >= 0", drag)
    contact = t.get("contact", base.contact)
    if isinstance(contact, bool) or not isinstance(contact, (int, float)) or not (0 < contact <= 10):
        fail("contact", "a contact tolerance as a fraction of the crank radius, a number in (0, 10]", contact)
    return Walker(legs, phases, mirrored, float(drag), float(contact))


def _gears(source: str, raw, crank, fixed: dict, guess: dict) -> tuple[Gear, ...]:
    """The ``[[gears]]`` tables: a grounded crank (``center``, ``radius``) whose tip ``tip`` (a new
    vertex) turns ``ratio`` × the driving crank's angle + ``phase`` (degrees); ``ratio`` a nonzero
    integer, so the mechanism repeats every crank turn."""
    if not isinstance(raw, list):
        raise UserError(f"{where(source, 'gears')}: expected [[gears]] tables, got {raw!r}")
    if raw and crank is None:
        raise UserError(f"{where(source, 'gears')}: a geared crank turns with the driving crank; this mechanism is "
                        f"driven by a path")
    out, names, tips = [], set(), set()
    for i, gt in enumerate(raw):
        key = f"gears[{i}]"
        gname = _named_table(source, key, gt, _GEAR_KEYS, ("name", "center", "radius", "tip", "ratio"), names,
                             "geared crank", "{}.x", "another geared crank")
        tip = _string(source, f"{key}.tip", gt["tip"])
        if not NAME_RE.fullmatch(tip):
            raise UserError(f"{where(source, f'{key}.tip')}: vertex name {tip!r} must be 1 to 64 letters, digits or "
                            f"_ . + - (it names datasets in results files)")
        if tip == crank.tip or tip in fixed or tip in tips:
            raise UserError(f"{where(source, f'{key}.tip')}: vertex {tip!r} is already the driving crank's tip, fixed, "
                            f"or another geared crank's tip")
        ratio = gt["ratio"]
        if isinstance(ratio, bool) or not isinstance(ratio, int) or ratio == 0 or abs(ratio) > 64:
            raise UserError(f"{where(source, f'{key}.ratio')}: expected a nonzero integer from −64 to 64 (turns per "
                            f"turn of the driving crank; negative: the other way), got {_short(ratio)}")
        phase = gt.get("phase", 0.0)
        if isinstance(phase, bool) or not isinstance(phase, (int, float)) or not math.isfinite(phase) \
                or abs(phase) > 1e6:
            raise UserError(f"{where(source, f'{key}.phase')}: expected an angle in degrees, got {_short(phase)}")
        tips.add(tip)
        out.append(Gear(gname, _point(source, f"{key}.center", gt["center"]),
                        _check_length(source, f"{key}.radius", gt["radius"]), tip, int(ratio), float(phase)))
    return tuple(out)


def _crank(source: str, value) -> Crank:
    crank_t = _table(source, "crank", value)
    _unknown_keys(source, "crank.", crank_t, _CRANK_KEYS)
    for k in sorted(_CRANK_KEYS - {"mass"}):
        if k not in crank_t:
            raise UserError(f"{where(source, 'crank.' + k)}: missing required key")
    return Crank(
        center=_point(source, "crank.center", crank_t["center"]),
        radius=_check_length(source, "crank.radius", crank_t["radius"]),
        tip=_string(source, "crank.tip", crank_t["tip"]),
        mass=_mass(source, "crank.mass", crank_t["mass"]) if "mass" in crank_t else None,
    )


def _mass(source: str, key: str, value, what: str = "a mass in kg") -> float:
    """A mass (kg), inertia (kg·m²) or density given in a file: a finite number > 0, as documented (a
    member without mass leaves the key out: 0 would read as a mass someone measured)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise UserError(f"{where(source, key)}: expected {what}, a number > 0, got {_short(value)}")
    v = float(value) if abs(value) < 1e300 else math.inf
    if not math.isfinite(v) or v <= 0 or v > _MAX_MASS:
        raise UserError(f"{where(source, key)}: expected {what}, a finite number > 0 and at most {_MAX_MASS:g} "
                        f"(leave the key out for none), got {_short(value)}")
    return v


def operating_from_dict(table, source: str, key: str = "operating", base: Operating | None = None) -> Operating:
    """Validate an ``[operating]`` table (keys :data:`OPERATING_KEYS`) into an :class:`Operating`; keys
    it leaves out keep ``base``'s values (the mechanism file's default), else the defaults."""
    t = _table(source, key, table)
    _unknown_keys(source, key + ".", t, set(OPERATING_KEYS))
    base = base or Operating()
    out = {}
    rules = {  # key: (lowest, allow it, highest, what)
        "unit": (0.0, False, 1e6, "metres per model unit, a number > 0 (0.01 for a mechanism in centimetres)"),
        "rpm": (0.0, False, 1e6, "the crank speed in revolutions per minute, a number > 0"),
        "gravity": (0.0, True, 1e4, "m/s² along −y, a number ≥ 0 (0 turns gravity off)"),
        "load": (0.0, True, 1e9, "the mass of the walker's body (frame, motor, battery: everything but the legs) "
                 "in kg, a number ≥ 0"),
        "speed_fluctuation": (0.0, False, 2.0, "the crank speed's allowed fluctuation (ω_max − ω_min)/ω_mean, "
                              "a number in (0, 2]"),
        "gear_ratio": (0.0, False, 1e6, "the motor's turns per crank turn, a number > 0 (1: the motor drives the "
                       "crank directly)"),
    }
    if "body" in t:
        if t["body"] not in BODY_MODELS:
            raise UserError(f"{where(source, f'{key}.body')}: expected one of {', '.join(map(repr, BODY_MODELS))} "
                            f"(the walker's body moving with its contact foot, or the frame held still), got "
                            f"{_short(t['body'])}")
        out["body"] = t["body"]
    for k, (lo, lo_ok, hi, what) in rules.items():
        if k in t:
            out[k] = bounded_number(source, f"{key}.{k}", t[k], lo, lo_ok, hi, what)
    return Operating(**{**{k: getattr(base, k) for k in OPERATING_KEYS}, **out})


def _driver(source: str, value) -> PathDriver:
    """A [driver] table: one vertex on a line, an arc or a spline through points, with a timing law."""
    t = _table(source, "driver", value)
    _unknown_keys(source, "driver.", t, _DRIVER_KEYS)
    if "slider" in t:
        return _actuator(source, t)
    for k in ("vertex", "path", "duration"):
        if k not in t:
            raise UserError(f"{where(source, 'driver.' + k)}: missing required key")
    kind = t["path"]
    if kind not in _PATH_KEYS:
        raise UserError(f"{where(source, 'driver.path')}: expected one of {', '.join(_PATH_KEYS)}, got {kind!r}")
    other = _DRIVER_KEYS - {"vertex", "path", "duration", "timing"} - _PATH_KEYS[kind] - _ORIENTATION_KEYS
    for k in sorted(_PATH_KEYS[kind]):
        if k not in t:
            raise UserError(f"{where(source, 'driver.' + k)}: missing required key for path = {kind!r}")
    for k in sorted(other & set(t)):
        raise UserError(f"{where(source, 'driver.' + k)}: not used by path = {kind!r} (it takes {', '.join(sorted(_PATH_KEYS[kind]))})")
    timing = t.get("timing", "linear")
    if timing not in ("linear", "quintic"):
        raise UserError(f"{where(source, 'driver.timing')}: expected 'linear' or 'quintic', got {timing!r}")
    fields = dict(vertex=_string(source, "driver.vertex", t["vertex"]), kind=kind, timing=timing,
                  duration=_check_length(source, "driver.duration", t["duration"]))
    if kind == "line":
        fields["points"] = (_point(source, "driver.start", t["start"]), _point(source, "driver.end", t["end"]))
    elif kind == "arc":
        fields["center"] = _point(source, "driver.center", t["center"])
        fields["radius"] = _check_length(source, "driver.radius", t["radius"])
        for k in ("start_angle", "end_angle"):
            a = t[k]
            if isinstance(a, bool) or not isinstance(a, (int, float)) or not math.isfinite(a):
                raise UserError(f"{where(source, 'driver.' + k)}: expected a finite angle in degrees, got {a!r}")
            fields[k] = math.radians(a)
    else:
        pts = t["points"]
        if not isinstance(pts, list) or len(pts) < 2:
            raise UserError(f"{where(source, 'driver.points')}: expected a list of two or more [x, y] points")
        fields["points"] = tuple(_point(source, f"driver.points[{i}]", p) for i, p in enumerate(pts))
    if _ORIENTATION_KEYS & set(t):
        fields["orientation"] = _orientation(source, t)
    return PathDriver(**fields)


def _actuator(source: str, t: dict) -> PathDriver:
    """A linear actuator's [driver] table: ``slider`` (a ground slider's name), ``stroke = [s0, s1]``
    (model units along its line from its point), ``duration`` and ``timing``; its path is set once the
    slider is read (``_model.actuator_path``)."""
    for k in sorted(set(t) - _ACTUATOR_KEYS):
        raise UserError(f"{where(source, 'driver.' + k)}: not used by a linear actuator (it takes "
                        f"{', '.join(sorted(_ACTUATOR_KEYS))})")
    for k in ("slider", "stroke", "duration"):
        if k not in t:
            raise UserError(f"{where(source, 'driver.' + k)}: missing required key for a linear actuator")
    stroke = _point(source, "driver.stroke", t["stroke"])
    if not LENGTH_RANGE[0] <= abs(stroke[1] - stroke[0]) <= LENGTH_RANGE[1]:
        raise UserError(f"{where(source, 'driver.stroke')}: expected [start, end], two different positions along the "
                        f"slider's line (model units), got {t['stroke']!r}")
    timing = t.get("timing", "linear")
    if timing not in ("linear", "quintic"):
        raise UserError(f"{where(source, 'driver.timing')}: expected 'linear' or 'quintic', got {timing!r}")
    return PathDriver(vertex="", kind="line", duration=_check_length(source, "driver.duration", t["duration"]),
                      timing=timing, slider=_string(source, "driver.slider", t["slider"]), stroke=stroke)


def _check_degrees_of_freedom(source, tip, tip_key, fixed, guess, links, bodies=(), sliders=(), gears=()) -> None:
    """Count check: 2 unknowns per guessed vertex, one equation per link that moves something and
    2n − 3 per body of n joints (a rigid shape of n points has 2n coordinates less 3 for its place).

    With the crank tip's and fixed vertices' coordinate equations this is seed 000's square system,
    leaving exactly the one degree of freedom that the crank drives.
    """
    grounded = {tip, *fixed}
    for i, l in enumerate(links):
        if l.a in grounded and l.b in grounded:
            raise UserError(
                f"{where(source, f'links[{i}]')}: link {l.name!r} joins two driven or fixed vertices "
                f"({l.a}, {l.b}); it would lock the crank or duplicate the ground"
            )
    for i, b in enumerate(bodies):
        if sum(j in grounded for j in b.joints) > 1:
            raise UserError(f"{where(source, f'bodies[{i}].joints')}: body {b.name!r} holds two driven or fixed "
                            f"vertices; it would lock the crank or duplicate the ground")
    touched = {v for l in links for v in (l.a, l.b)} | {j for b in bodies for j in b.joints} \
        | {s.vertex for s in sliders} | {g.tip for g in gears}
    if tip not in touched:
        raise UserError(f"{where(source, tip_key)}: vertex {tip!r} is on no link; the driver would move nothing")
    for v in guess:
        if v not in touched:
            raise UserError(f"{where(source, 'guess.' + v)}: vertex {v!r} is on no link")
    for v in fixed:
        if v not in touched:
            raise UserError(f"{where(source, 'fixed.' + v)}: vertex {v!r} is on no link")
    n_eq = len(links) + sum(2 * len(b.joints) - 3 for b in bodies) + len(sliders) + 2 * len(gears)
    n_unknown = 2 * len(guess)
    if n_eq != n_unknown:
        dof = n_unknown - n_eq + 1
        what = "link, body and slider equations" if bodies or sliders else "link equations"
        raise UserError(
            f"{where(source, 'links')}: {n_eq} {what} for {n_unknown} unknown coordinates gives "
            f"{dof} degrees of freedom; a linkage with one driver needs exactly 1 "
            f"(add or remove {abs(n_unknown - n_eq)} link(s))"
        )


def _orientation(source: str, t: dict):
    """The [driver] orientation keys: keyframes (matrices, Euler angles with a sequence, axis-angle),
    interpolation, wrist, wrist_branch, euler_seq, euler_set (see :class:`Orientation`)."""
    import numpy as np

    from ._model import INTERPOLATIONS, Orientation, valid_sequence

    if "orientation" not in t:
        for k in sorted(_ORIENTATION_KEYS & set(t)):
            raise UserError(f"{where(source, 'driver.' + k)}: only used with driver.orientation (the wrist's keyframes)")
    frames = t["orientation"]
    if not isinstance(frames, list) or len(frames) < 2:
        raise UserError(f"{where(source, 'driver.orientation')}: expected a list of two or more keyframes "
                        f"(3x3 matrices, {{euler = [a, b, c], seq = \"ZYX\"}} or {{axis = [x, y, z], angle = a}}), "
                        f"got {_short(frames)}")

    def seq_of(key, value, upper=False):
        if not valid_sequence(value) or (upper and not value.isupper()):
            what = "an intrinsic (upper-case) Euler sequence" if upper else "an Euler sequence"
            raise UserError(f"{where(source, key)}: expected {what} such as 'ZYZ' or 'ZYX' (three of X/Y/Z, no "
                            f"axis twice in a row{'' if upper else '; lower case: extrinsic'}), got {_short(value)}")
        return value

    def numbers(key, value, n):
        if not (isinstance(value, list) and len(value) == n and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for c in value)):
            raise UserError(f"{where(source, key)}: expected {n} finite numbers, got {_short(value)}")
        return [float(c) for c in value]

    def flag(key, value):
        if not isinstance(value, bool):
            raise UserError(f"{where(source, key)}: expected true or false, got {_short(value)}")
        return value

    from scipy.spatial.transform import Rotation

    mats, given = [], []
    for i, f in enumerate(frames):
        key = f"driver.orientation[{i}]"
        if isinstance(f, dict):
            kind = "euler" if "euler" in f else "axis" if ("axis" in f or "angle" in f) else None
            allowed = {"euler": {"euler", "seq", "degrees"}, "axis": {"axis", "angle", "degrees"}}.get(kind)
            if kind is None:
                raise UserError(f"{where(source, key)}: expected a 3x3 matrix, {{euler = [a, b, c], seq = \"ZYX\"}} "
                                f"or {{axis = [x, y, z], angle = a}}, got {_short(f)}")
            _unknown_keys(source, key + ".", f, allowed)
            deg = flag(key + ".degrees", f.get("degrees", True))
            if kind == "euler":
                if "seq" not in f:
                    raise UserError(f"{where(source, key + '.seq')}: missing required key (the Euler sequence, e.g. 'ZYX')")
                seq = seq_of(key + ".seq", f["seq"])
                raw = numbers(key + ".euler", f["euler"], 3)
                mats.append(Rotation.from_euler(seq, raw, degrees=deg).as_matrix())
                given.append((seq, tuple(raw), deg))
            else:
                for k in ("axis", "angle"):
                    if k not in f:
                        raise UserError(f"{where(source, key + '.' + k)}: missing required key for an axis-angle keyframe")
                ax = np.array(numbers(key + ".axis", f["axis"], 3))
                a = f["angle"]
                if isinstance(a, bool) or not isinstance(a, (int, float)) or not math.isfinite(a):
                    raise UserError(f"{where(source, key + '.angle')}: expected a finite angle, got {_short(a)}")
                n = float(np.linalg.norm(ax))
                if n == 0.0:
                    raise UserError(f"{where(source, key + '.axis')}: the axis must not be [0, 0, 0]")
                mats.append(Rotation.from_rotvec(ax / n * (math.radians(a) if deg else float(a))).as_matrix())
                given.append(None)
        else:
            ok = isinstance(f, list) and len(f) == 3 and all(isinstance(r, list) and len(r) == 3 for r in f) and all(
                isinstance(c, (int, float)) and not isinstance(c, bool) and math.isfinite(c) for r in f for c in r)
            if not ok:
                raise UserError(f"{where(source, key)}: expected a 3x3 rotation matrix [[..], [..], [..]], "
                                f"{{euler = [a, b, c], seq = \"ZYX\"}} or {{axis = [x, y, z], angle = a}}, got {_short(f)}")
            M = np.array(f, dtype=np.float64)
            g = M.T @ M - np.eye(3)
            defect, det = float(np.sqrt((g * g).sum())), float(np.linalg.det(M))
            if defect > 1e-3 or det <= 0.0:
                raise UserError(f"{where(source, key)}: not a rotation matrix (||R^T R - I|| = {defect:.3g}, det = "
                                f"{det:.6g}; a rotation has 0 and 1, within 1e-3)")
            if defect > 1e-12:  # a matrix printed to a few digits: its nearest rotation
                U, _, Vt = np.linalg.svd(M)
                M = U @ Vt
            mats.append(M)
            given.append(None)
    interp = t.get("interpolation", "slerp")
    if interp not in INTERPOLATIONS:
        raise UserError(f"{where(source, 'driver.interpolation')}: expected one of {', '.join(INTERPOLATIONS)}, "
                        f"got {_short(interp)}")
    wrist = seq_of("driver.wrist", t.get("wrist", "ZYZ"), upper=True)
    euler_seq = seq_of("driver.euler_seq", t["euler_seq"]) if "euler_seq" in t else ""
    out = {}
    for k in ("wrist_branch", "euler_set"):
        v = t.get(k, 1)
        if isinstance(v, bool) or v not in (1, 2):
            raise UserError(f"{where(source, 'driver.' + k)}: expected 1 or 2, got {_short(v)}")
        out[k] = int(v)
    return Orientation(tuple(tuple(float(x) for x in M.ravel()) for M in mats), interp, wrist, out["wrist_branch"],
                       euler_seq, out["euler_set"], tuple(given))
