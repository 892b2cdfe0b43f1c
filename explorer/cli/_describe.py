"""``explorer describe MECHANISM [--format text|json]``: what a mechanism is, for a person: its joints and
their roles, the driver, links and bodies, design parameters, default walker scene and buildability screen,
masses and operating point, and the plan that solves it (nothing is simulated)."""

from __future__ import annotations

import json
import math

FORMATS = ("text", "json")


def register(sub) -> None:
    p = sub.add_parser(
        "describe", help="what a mechanism is: joints and their roles, links, bodies, parameters, walker, solve plan",
        description="Print a mechanism (a built-in or a mechanism .toml) for a person, without simulating it: its "
                    "name and description; every joint with its role (the crank tip or path-driven vertex, a "
                    "fixed ground pivot with its coordinates, a moving joint with its guess at θ = 0, the foot), "
                    "the links and bodies it belongs to, and the step of the solve plan that places it; the "
                    "crank (centre, radius) or the path driver; every link with its ends and length; every body "
                    "with its joints' coordinates in the body's frame; every design parameter (the names a "
                    "study's [perturb] table and `explorer show` use) with its nominal value and kind (length or "
                    "coordinate); the default walker scene (the file's [walker] table, else the generic "
                    "default); the buildability screen's default thresholds; the masses and the [operating] "
                    "table where the file gives them; and the solve plan: the blocks solved one after another "
                    "(DYAD: one joint from two distances, closed form; ATTACH: a body joint placed rigidly from "
                    "its body's two known joints; GENERAL: several joints solved together by Newton; SLIDE: one "
                    "joint from a distance and a slider's line, closed form). "
                    "--format json prints the same as one JSON object.",
        epilog="examples: explorer describe jansen; explorer describe klann --format json; "
               "explorer describe my-leg.toml")
    p.add_argument("mechanism", metavar="MECHANISM",
                   help=f"built-in mechanism name or a mechanism .toml (built-ins: {_builtins()})")
    p.add_argument("--format", metavar="FORMAT", default="text", help="text (default) or json")
    p.set_defaults(func=run)


def _builtins() -> str:
    try:
        from ..mechanism import builtin_mechanisms
        return ", ".join(builtin_mechanisms())
    except Exception:  # pragma: no cover - the help text must never fail
        return "jansen, ..."


# -- the description as data ----------------------------------------------------------------------------

def _kind_name(kind: int) -> str:
    from ..plan import BlockKind
    return BlockKind(int(kind)).name


def _pt(p) -> list[float]:
    return [float(p[0]), float(p[1])]


def _driver(mech) -> dict:
    if mech.crank is not None:
        c = mech.crank
        return {"kind": "crank", "tip": c.tip, "center": _pt(c.center), "radius": float(c.radius),
                "mass": None if c.mass is None else float(c.mass)}
    d = mech.path
    out = {"kind": "path", "vertex": d.vertex, "path": d.kind, "duration": float(d.duration), "timing": d.timing}
    if d.kind == "arc":
        out.update(center=_pt(d.center), radius=float(d.radius), start_angle=math.degrees(d.start_angle),
                   end_angle=math.degrees(d.end_angle))
    else:
        out["points"] = [_pt(p) for p in d.points]
    if getattr(d, "orientation", None) is not None:
        out["wrist"] = _wrist(mech)
    return out


def _wrist(mech) -> dict:
    """The spherical wrist of a path driver with [driver] orientation: its joints, interpolation, keyframes
    (the wrist's angles, degrees) and the gimbal locks on its path (at 1,001 samples)."""
    from scipy.spatial.transform import Rotation

    from ..kernels import wrist_for

    o = mech.path.orientation
    w = wrist_for(mech)
    lock = [{"t": g.t, "middle_deg": math.degrees(g.middle), "from_lock_deg": math.degrees(g.distance),
             "sets": list(g.sets), "text": str(g)} for g in w.locks]
    c = w.closest
    return {"joints": o.wrist, "branch": o.branch, "interpolation": o.interpolation,
            "keyframes_deg": [list(Rotation.from_matrix(M).as_euler(o.wrist, degrees=True)) for M in o.matrices()],
            "end_deg": [math.degrees(a) for a in w.angles[-1]], "gimbal_locks": lock,
            "closest_to_lock": None if c is None else {"t": c.t, "from_lock_deg": math.degrees(c.distance)},
            "path_deg": math.degrees(w.path_angle), "geodesic_deg": math.degrees(w.geodesic_angle)}


def _plan(mech) -> tuple[list[dict], dict]:
    """The plan's blocks (steps numbered from 1) and, for each vertex it places, its step."""
    from ..kernels import plan_for
    from ..kinds import EQUATION_BY_NAME

    plan = plan_for(mech)
    names = mech.vertices
    steps, placed_by = [], {}
    for i, b in enumerate(plan.blocks):
        kind = _kind_name(b.kind)
        placed = [names[v] for v in b.vertices]
        equations, used = [], set()
        for typ, e in dict.fromkeys((typ, int(e)) for typ, e, _ax in b.rows):  # each equation once, in words
            used.update(int(v) for v in plan.tables[typ][e] if v >= 0)
            equations.append(EQUATION_BY_NAME[typ].describe(mech, plan, e))
        known = [names[v] for v in sorted(used - set(b.vertices))]
        steps.append({"step": i + 1, "kind": kind, "places": placed, "from": known, "equations": equations,
                      "after": [int(d) + 1 for d in b.depends]})
        for v in placed:
            placed_by[v] = i + 1
    return steps, placed_by


def describe(mech) -> dict:
    """Everything ``explorer describe`` prints, as one JSON-ready dict."""
    from ..gait import Screen
    from ..mechanism import Walker

    steps, placed_by = _plan(mech)
    op = mech.operating
    unit = op.unit if op is not None else None
    density = mech.link_density

    joints = []
    for v in mech.vertices:
        if v == mech.driven:
            role = "crank_tip" if mech.crank is not None else "driven"
        elif v in mech.fixed:
            role = "fixed"
        else:
            role = "moving"
        j = {"name": v, "role": role, "foot": v == mech.foot}
        if role == "fixed":
            j["position"] = _pt(mech.fixed[v])
        elif role == "moving":
            j["guess"] = _pt(mech.guess[v])
        j["links"] = [lk.name for lk in mech.links if v in (lk.a, lk.b)]
        j["bodies"] = [b.name for b in mech.bodies if v in b.joints]
        j["placed_by_step"] = placed_by.get(v)
        joints.append(j)

    from ..mechanism import effective_mass

    links = [{"name": lk.name, "a": lk.a, "b": lk.b, "length": float(lk.length),
              "mass": None if lk.mass is None else float(lk.mass),
              "effective_mass": effective_mass(mech, lk.mass, lk.length, unit)}
             for lk in mech.links]
    bodies = [{"name": b.name, "joints": {j: _pt(p) for j, p in zip(b.joints, b.points)}, "span": b.span,
               "mass": float(b.mass), "centroid": None if b.centroid is None else _pt(b.centroid),
               "inertia": None if b.inertia is None else float(b.inertia)} for b in mech.bodies]
    driver = _driver(mech)
    if mech.crank is not None:
        driver["effective_mass"] = effective_mass(mech, mech.crank.mass, mech.crank.radius, unit)

    params = mech.parameters()
    walker = None
    if mech.crank is not None:
        w = mech.walker if mech.walker is not None else Walker()
        walker = {"from": "file" if mech.walker is not None else "default", **w.as_dict()}
    masses_given = (density is not None or any(lk.mass is not None for lk in mech.links)
                    or (mech.crank is not None and mech.crank.mass is not None)
                    or any(b.mass or b.centroid is not None or b.inertia is not None for b in mech.bodies))
    return {
        "name": mech.name,
        "description": mech.description,
        "source": mech.source,
        "foot": mech.foot,
        "size": mech.size,
        "driver": driver,
        "joints": joints,
        "links": links,
        "bodies": bodies,
        "sliders": [{"name": sl.name, "vertex": sl.vertex, "ground": sl.ground,
                     "point": _pt(sl.point) if sl.ground else None,
                     "direction": _pt(sl.direction) if sl.ground else None,
                     "line": list(sl.line) if not sl.ground else None, "offset": float(sl.offset)}
                    for sl in mech.sliders],
        "gears": [{"name": g.name, "center": _pt(g.center), "radius": float(g.radius), "tip": g.tip,
                   "ratio": int(g.ratio), "phase": float(g.phase)} for g in mech.gears],
        "parameters": params,
        "parameter_kinds": {p: mech.parameter_kind(p) for p in params},
        "walker": walker,
        "screen": Screen().as_dict() if mech.crank is not None else None,
        "mass": {"given": bool(masses_given), "link_density": None if density is None else float(density)},
        "operating": None if op is None else op.as_dict(),
        "plan": steps,
    }


# -- the description as text ----------------------------------------------------------------------------

def _g(x) -> str:
    return f"{float(x):.6g}"


def _xy(p) -> str:
    return f"({_g(p[0])}, {_g(p[1])})"


def _table(rows, right=()) -> list[str]:
    widths = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
    return ["  " + "  ".join(c.rjust(w) if j in right else c.ljust(w)
                             for j, (c, w) in enumerate(zip(r, widths))).rstrip() for r in rows]


def _kg(m) -> str:
    return "-" if m is None else f"{_g(m)} kg"


def _meaning(d: dict, p: str) -> str:
    """What design parameter ``p`` is, in words."""
    links = {lk["name"]: lk for lk in d["links"]}
    if p in links:
        return f"length of link {links[p]['a']}-{links[p]['b']}"
    if p == "crank":
        return "crank radius"
    if p in ("crank.x", "crank.y"):
        return f"crank centre {p[-1]}"
    gears = {g["name"]: g for g in d.get("gears", ())}
    if p in gears:
        return f"radius of geared crank {p} (tip {gears[p]['tip']})"
    head, axis = p.rsplit(".", 1)
    if head in gears:
        return f"geared crank {head}'s centre {axis}"
    sliders = {sl["name"]: sl for sl in d.get("sliders", ())}
    if head in sliders:
        sl = sliders[head]
        if axis == "offset":
            return f"offset of slider {head}'s slot {'-'.join(sl['line'])} (to its left)"
        what = "direction" if axis in ("dx", "dy") else "point"
        return f"slider {head}'s line: its {what} {axis[-1]}"
    fixed = {j["name"] for j in d["joints"] if j["role"] == "fixed"}
    if head in fixed:
        return f"ground pivot {head} {axis}"
    body, _, joint = head.partition(".")
    return f"joint {joint} {axis} in body {body}'s frame"


def text(d: dict) -> str:
    """The person's view of :func:`describe`'s dict."""
    drv = d["driver"]
    crank = drv["kind"] == "crank"
    out = [f"{d['name']}: {d['description']}" if d["description"] else d["name"],
           f"source: {d['source']}",
           f"{len(d['joints'])} joints, {len(d['links'])} links, {len(d['bodies'])} bodies; "
           f"{'driven by a crank' if crank else 'driven along a path'}; foot {d['foot']}; "
           f"size {_g(d['size'])} model units (the longest link or body span)"]

    # joints
    role_text = {"crank_tip": "crank tip (driven)", "driven": "driven vertex (path)",
                 "fixed": "fixed ground pivot", "moving": "moving"}
    rows = [("joint", "role", "position", "links", "bodies", "solved")]
    for j in d["joints"]:
        role = role_text[j["role"]] + (", foot" if j["foot"] else "")
        if j["role"] == "fixed":
            pos = f"fixed at {_xy(j['position'])}"
        elif j["role"] == "moving":
            pos = f"guess {_xy(j['guess'])}"
        elif crank:
            c, r = drv["center"], drv["radius"]
            pos = f"θ = 0: {_xy((c[0] + r, c[1]))}"
        else:
            pos = f"t = 0: {_xy(drv['points'][0])}" if "points" in drv else "on the arc"
        if j["placed_by_step"] is not None:
            solved = f"step {j['placed_by_step']}"
        else:
            solved = "by the crank" if j["role"] == "crank_tip" else ("by the path" if j["role"] == "driven"
                                                                        else "-")
        rows.append((j["name"], role, pos, ", ".join(j["links"]) or "-", ", ".join(j["bodies"]) or "-", solved))
    out += ["", f"joints ({len(d['joints'])}; a moving joint's guess at θ = 0 picks the assembly)"] + _table(rows)

    # driver
    out.append("")
    if crank:
        out.append(f"crank: centre {_xy(drv['center'])}, radius {_g(drv['radius'])}, tip {drv['tip']} "
                   f"(θ counter-clockwise from +x; the centre is a ground pivot too)")
        for g in d.get("gears", ()):
            out.append(f"geared crank {g['name']}: centre {_xy(g['center'])}, radius {_g(g['radius'])}, tip {g['tip']}, "
                       f"angle {g['ratio']:+d} × θ + {_g(g['phase'])}° (geared to the crank)")
    else:
        what = {"line": lambda: f"a straight line from {_xy(drv['points'][0])} to {_xy(drv['points'][1])}",
                "arc": lambda: f"an arc about {_xy(drv['center'])}, radius {_g(drv['radius'])}, from "
                               f"{_g(drv['start_angle'])}° to {_g(drv['end_angle'])}°",
                "points": lambda: f"a cubic spline through {len(drv['points'])} points"}[drv["path"]]()
        out.append(f"path driver: vertex {drv['vertex']} along {what} in {_g(drv['duration'])} s "
                   f"({drv['timing']} timing)")
        if "wrist" in drv:
            w = drv["wrist"]
            frames = "; ".join(", ".join(f"{a:.2f}" for a in k) for k in w["keyframes_deg"])
            out.append(f"wrist: spherical, joints {w['joints']} (branch {w['branch']}), {w['interpolation']} through "
                       f"{len(w['keyframes_deg'])} keyframes ({w['joints']} angles, °: {frames}); it sweeps "
                       f"{w['path_deg']:.2f}° (geodesic {w['geodesic_deg']:.2f}°) and ends at "
                       f"{', '.join(f'{a:.2f}' for a in w['end_deg'])}°")
            for g in w["gimbal_locks"]:
                out.append(f"wrist: {g['text']}")
            if not w["gimbal_locks"] and w["closest_to_lock"] is not None:
                c = w["closest_to_lock"]
                out.append(f"wrist: no gimbal lock (closest {c['from_lock_deg']:.2f}° from it, at t = {c['t']:.4g} s)")

    # links and bodies
    rows = [("link", "a", "b", "length")] + [(lk["name"], lk["a"], lk["b"], _g(lk["length"])) for lk in d["links"]]
    out += ["", f"links ({len(d['links'])})"] + (_table(rows, right=(3,)) if d["links"] else ["  none"])
    out += ["", f"bodies ({len(d['bodies'])}; joint coordinates in the body's own frame)"]
    if not d["bodies"]:
        out.append("  none")
    for b in d["bodies"]:
        out.append(f"  {b['name']}: " + ", ".join(f"{j} {_xy(p)}" for j, p in b["joints"].items())
                   + f"; span {_g(b['span'])}")

    # parameters
    rows = [("parameter", "nominal", "kind", "what")]
    rows += [(p, _g(v), d["parameter_kinds"][p], _meaning(d, p)) for p, v in d["parameters"].items()]
    out += ["", f"design parameters ({len(d['parameters'])}; a length is varied relatively, a coordinate by a "
                f"distance)"] + _table(rows, right=(1,))

    # walker and screen
    out.append("")
    w = d["walker"]
    rail = next((sl for sl in d.get("sliders", ()) if sl["ground"] and sl["vertex"] == d["foot"]), None)
    if w is None:
        out.append("walker scene: none (a walker needs a crank; this mechanism is driven along a path)")
        out.append("buildability screen: not applicable (no gait: the mechanism is driven along a path)")
    else:
        src = "the file's [walker] table" if w["from"] == "file" else "the generic default; no [walker] table"
        out.append(f"walker scene ({src}; a study's [walker] table overrides it)")
        out.append(f"  legs {w['legs']}; phases {', '.join(_g(p) + '°' for p in w['phases'])}")
        mir = [str(i) for i, m in enumerate(w["mirrored"]) if m]
        out.append(f"  mirrored legs: {', '.join(mir) if mir else 'none'} (of 0 to {w['legs'] - 1}); "
                   f"drag {_g(w['drag'])} × weight; contact within {_g(w['contact'])} × crank radius of the ground")
        s = d["screen"]
    if w is not None and rail is not None:  # the legs still set what the forces effect drives
        out.append(f"walker, leg and screen metrics: not applicable (the foot {d['foot']} runs on the ground slider "
                   f"{rail['name']}: a stroke along a fixed line; quick_return applies)")
    elif w is not None:
        out.append("buildability screen (default thresholds; a study's [screen] table overrides them)")
        out.append(f"  min_transmission_angle {_g(s['min_transmission_angle'])}°; "
                   f"min_foot_headroom {_g(s['min_foot_headroom'])}; "
                   f"max_foot_speed {_g(s['max_foot_speed'])} crank radii/rad; "
                   f"max_self_crossings {s['max_self_crossings']}")

    # masses and operating point
    out.append("")
    if not d["mass"]["given"]:
        out.append("masses: none given (the forces effect treats the linkage as massless)")
    else:
        dens = d["mass"]["link_density"]
        out.append("masses" + (f" (link_density {_g(dens)} kg per metre of link: a link or crank without a mass of "
                               f"its own weighs link_density × length × unit)" if dens is not None else ""))
        rows = [("member", "given", "effective")]
        rows += [(f"link {lk['name']}", _kg(lk["mass"]), _kg(lk["effective_mass"])) for lk in d["links"]]
        if crank:
            rows.append(("crank", _kg(drv["mass"]), _kg(drv["effective_mass"])))
        out += _table(rows)
        if dens is not None and (d["operating"] or {}).get("unit") is None:
            out.append("  (effective masses need [operating] unit, the metres per model unit)")
        for b in d["bodies"]:
            cen = _xy(b["centroid"]) if b["centroid"] is not None else "the mean of its joints"
            ine = f"{_g(b['inertia'])} kg·m²" if b["inertia"] is not None else "its mass shared among its joints"
            out.append(f"  body {b['name']}: mass {_g(b['mass'])} kg, centroid {cen}, inertia {ine}")
    op = d["operating"]
    if op is None:
        out.append("operating point: none in the file (a study's [operating] table gives it for the forces effect)")
    else:
        units = {"unit": " m per model unit", "rpm": "", "gravity": " m/s²",
                 "load": " kg (the body's mass: frame, motor, battery, everything but the legs)",
                 "speed_fluctuation": "", "gear_ratio": " (motor turns per crank turn)"}
        out.append("operating point ([operating]): " + ", ".join(f"{k} {v!r}" if isinstance(v, str) else
                                                                 f"{k} {_g(v)}{units.get(k, '')}"
                                                                 for k, v in op.items()))
        out.append("  forces: body = \"moving\" (the default) moves the body with the planted contact foot, the ground "
                   "carrying the whole machine; \"held\" holds the frame still, the legs hanging from it (the default "
                   "for a foot on a ground slider)")

    # plan
    counts = {}
    for s in d["plan"]:
        counts[s["kind"]] = counts.get(s["kind"], 0) + 1
    n = len(d["plan"])
    out += ["", f"solve plan ({n} step{'s' if n != 1 else ''}: " + ", ".join(f"{n} {k}" for k, n in counts.items())
            + "; each step after the steps it reads from)"]
    for s in d["plan"]:
        after = f"; after step {', '.join(map(str, s['after']))}" if s["after"] else ""
        out.append(f"  {s['step']}. {s['kind']:<7} places {', '.join(s['places'])} from "
                   f"{', '.join(s['from']) or '-'}: {'; '.join(s['equations'])}{after}")
    from ..plan import KIND_TEXT
    for k in counts:
        out.append(f"  ({k}: {KIND_TEXT.get(k, '')})")
    return "\n".join(out)


def run(args) -> int:
    from ..errors import UserError
    from ..mechanism import load_mechanism

    if args.format not in FORMATS:
        raise UserError(f"--format: expected one of {', '.join(FORMATS)}, got {args.format!r}")
    mech = load_mechanism(args.mechanism)
    d = describe(mech)
    if args.format == "json":
        print(json.dumps(d, indent=2, ensure_ascii=False, allow_nan=False))
    else:
        print(text(d))
    return 0
