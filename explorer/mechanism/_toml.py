"""Writing TOML: a mechanism as the text of its file (:func:`mechanism_toml`), and a study-shaped dict
(:func:`dumps_toml`). The readers are ``_load`` (mechanisms) and ``explorer.study`` (studies); both
writers keep every number repr-exact, so what is written reads back the same."""

from __future__ import annotations

import json
import math
import re

from ..errors import UserError
from ._model import Mechanism


# -- mechanism files -------------------------------------------------------------------------------------
def _num(x) -> str:
    """A float as TOML, repr-exact (tomllib reads back the very same double)."""
    x = float(x)
    if not math.isfinite(x):
        raise UserError(f"cannot write a non-finite number ({x!r}) in a mechanism file")
    return repr(x)


def _str(s) -> str:
    """A TOML basic string."""
    out = []
    for ch in str(s):
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch in "\n\t\r\b\f":
            out.append({"\n": "\\n", "\t": "\\t", "\r": "\\r", "\b": "\\b", "\f": "\\f"}[ch])
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04X}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def _point(p) -> str:
    return f"[{_num(p[0])}, {_num(p[1])}]"


def _degrees(rad: float) -> float:
    """Degrees d with ``math.radians(d) == rad`` exactly where such a double lies within a few ulps of
    ``math.degrees(rad)`` (the loader reads angles in degrees), else the nearest."""
    d = math.degrees(rad)
    if math.radians(d) == rad:
        return d
    lo = hi = d
    for _ in range(8):
        lo, hi = math.nextafter(lo, -math.inf), math.nextafter(hi, math.inf)
        for c in (lo, hi):
            if math.radians(c) == rad:
                return c
    return d


def mechanism_toml(mech: Mechanism, header: str = "") -> str:
    """``mech`` as the text of a mechanism file: name, description, foot, ``[crank]`` or ``[driver]``,
    ``[fixed]``, ``[guess]``, ``[[links]]`` (each with its name), ``[[bodies]]`` and ``[walker]`` (when
    the mechanism has them), vertices in the mechanism's order. Floats are written as Python's repr, so
    :func:`explorer.load_mechanism` reads back every design parameter exactly; angles (the arc driver's
    and the walker's phases, stored in radians, written in degrees) round-trip exactly where a double
    in degrees does (else to the nearest bit). ``header``: comment lines to put first."""
    clean = ["".join(c if c == "\t" or (ord(c) >= 0x20 and ord(c) != 0x7F) else "?" for c in h)
             for h in header.splitlines()]  # a TOML comment takes no control characters
    lines = [f"# {h}" if h else "#" for h in clean]
    lines += [f"name = {_str(mech.name)}", f"description = {_str(mech.description)}", f"foot = {_str(mech.foot)}"]
    if not mech.links:
        lines.append("links = []             # a mechanism of rigid bodies only")
    lines.append("")
    if mech.crank is not None:
        c = mech.crank
        lines += ["[crank]", f"center = {_point(c.center)}", f"radius = {_num(c.radius)}", f"tip = {_str(c.tip)}"]
        if c.mass is not None:
            lines.append(f"mass = {_num(c.mass)}   # kg")
    elif mech.path.slider is not None:  # a linear actuator
        d = mech.path
        lines += ["[driver]", f"slider = {_str(d.slider)}", f"stroke = {_point(d.stroke)}   # along its line",
                  f"duration = {_num(d.duration)}   # seconds", f"timing = {_str(d.timing)}"]
    else:
        d = mech.path
        lines += ["[driver]", f"vertex = {_str(d.vertex)}", f"path = {_str(d.kind)}"]
        if d.kind == "line":
            lines += [f"start = {_point(d.points[0])}", f"end = {_point(d.points[1])}"]
        elif d.kind == "arc":
            lines += [f"center = {_point(d.center)}", f"radius = {_num(d.radius)}",
                      f"start_angle = {_num(_degrees(d.start_angle))}   # degrees",
                      f"end_angle = {_num(_degrees(d.end_angle))}   # degrees"]
        else:
            lines.append("points = [" + ", ".join(_point(p) for p in d.points) + "]")
        lines += [f"duration = {_num(d.duration)}   # seconds", f"timing = {_str(d.timing)}"]
        if d.orientation is not None:
            lines += _orientation_lines(d.orientation)
    lines += ["", "[fixed]"]
    lines += [f"{_str(v)} = {_point(mech.fixed[v])}" for v in mech.vertices if v in mech.fixed]
    lines += ["", "[guess]                # positions at the first sample: they pick the assembly (branch)"]
    lines += [f"{_str(v)} = {_point(mech.guess[v])}" for v in mech.vertices if v in mech.guess]
    for link in mech.links:
        lines += ["", "[[links]]", f"name = {_str(link.name)}", f"a = {_str(link.a)}", f"b = {_str(link.b)}",
                  f"length = {_num(link.length)}"]
        if link.mass is not None:
            lines.append(f"mass = {_num(link.mass)}   # kg")
    for body in mech.bodies:
        joints = ", ".join(f"{_str(j)} = {_point(p)}" for j, p in zip(body.joints, body.points))
        lines += ["", "[[bodies]]", f"name = {_str(body.name)}", f"joints = {{ {joints} }}"]
        if body.mass:
            lines.append(f"mass = {_num(body.mass)}   # kg")
        if body.centroid is not None:
            lines.append(f"centroid = {_point(body.centroid)}")
        if body.inertia is not None:
            lines.append(f"inertia = {_num(body.inertia)}   # kg·m² about the centroid")
    for sl in mech.sliders:
        lines += ["", "[[sliders]]", f"name = {_str(sl.name)}", f"vertex = {_str(sl.vertex)}"]
        if sl.ground:
            lines += [f"point = {_point(sl.point)}", f"direction = {_point(sl.direction)}"]
        else:
            lines += [f"line = [{_str(sl.line[0])}, {_str(sl.line[1])}]", f"offset = {_num(sl.offset)}"]
    for g in mech.gears:
        lines += ["", "[[gears]]", f"name = {_str(g.name)}", f"center = {_point(g.center)}", f"radius = {_num(g.radius)}",
                  f"tip = {_str(g.tip)}", f"ratio = {int(g.ratio)}", f"phase = {_num(g.phase)}   # degrees"]
    from ._build import derived_link_density
    if mech.link_density is not None and not derived_link_density(mech):
        lines += ["", "[mass]", f"link_density = {_num(mech.link_density)}   # kg per metre of link"]
    if mech.build is not None:
        lines += ["", "[build]"] + [f"{k} = {_str(v) if isinstance(v, str) else _num(v)}"
                                    for k, v in mech.build.as_dict().items()]
    if mech.operating is not None:
        lines += ["", "[operating]"] + [f"{k} = {_str(v) if isinstance(v, str) else _num(v)}"
                                        for k, v in mech.operating.as_dict().items()]
    if mech.walker is not None:
        w = mech.walker
        lines += ["", "[walker]", f"legs = {int(w.legs)}",
                  "phases = [" + ", ".join(_num(_degrees(p)) for p in w.phases) + "]   # degrees",
                  "mirrored = [" + ", ".join("true" if m else "false" for m in w.mirrored) + "]",
                  f"drag = {_num(w.drag)}", f"contact = {_num(w.contact)}"]
    return "\n".join(lines) + "\n"


# -- study-shaped tables -----------------------------------------------------------------------------
def dumps_toml(data: dict) -> str:
    """A TOML text for a study-shaped dict (tables of strings, numbers, booleans and lists of them)."""
    lines = []
    for sec, table in data.items():
        if not isinstance(table, dict):
            lines.append(f"{sec} = {_toml_value(table)}")
            continue
        lines.append(f"[{sec}]")
        lines.extend(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in table.items())
        lines.append("")
    return "\n".join(lines)


def _toml_key(k) -> str:
    k = str(k)
    return k if re.match(r"^[A-Za-z0-9_-]+$", k) else json.dumps(k)


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v) if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return json.dumps(str(v))


def _orientation_lines(o) -> list[str]:
    """The [driver] orientation keys of an :class:`Orientation`: Euler keyframes as written, the others as
    matrices (floats as repr: read back exactly)."""
    frames = []
    for M, g in zip(o.keyframes, o.euler or (None,) * len(o.keyframes)):
        if g is not None:
            unit = "" if g[2] else ", degrees = false"
            frames.append(f"{{ euler = [{', '.join(_num(a) for a in g[1])}], seq = {_str(g[0])}{unit} }}")
        else:
            frames.append("[" + ", ".join("[" + ", ".join(_num(x) for x in M[3 * r:3 * r + 3]) + "]" for r in range(3)) + "]")
    lines = ["orientation = [", *(f"    {f}," for f in frames), "]",
             f"interpolation = {_str(o.interpolation)}", f"wrist = {_str(o.wrist)}   # the wrist's joint axes (intrinsic)",
             f"wrist_branch = {o.branch}"]
    if o.euler_seq:
        lines.append(f"euler_seq = {_str(o.euler_seq)}")
    if o.euler_set != 1:
        lines.append(f"euler_set = {o.euler_set}")
    return lines
