"""``explorer describe MECHANISM [--format table|json]``: what a mechanism is, for a person: its joints and
their roles, the driver, links and bodies, design parameters, default walker scene and buildability screen,
masses and operating point, and the plan that solves it (nothing is simulated)."""

from __future__ import annotations

import json

FORMATS = ("text", "json")


def register(sub) -> None:
    from ._args import add_format

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
    add_format(p, ("table", "json"), "json: the same as one JSON object", old={"text": "table"})
    p.set_defaults(func=run)


def _builtins() -> str:
    try:
        from ..mechanism import builtin_mechanisms
        return ", ".join(builtin_mechanisms())
    except Exception:  # pragma: no cover - the help text must never fail
        return "jansen, ..."


# -- the description as data: explorer.view.describe (its home) ------------------------------------------------
def describe(mech) -> dict:
    """:func:`explorer.view.describe` (imported when used: ``explorer --help`` stays light)."""
    from ..view import describe as what_it_is
    return what_it_is(mech)


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


def _lookups(d: dict) -> tuple[dict, dict, set]:
    """The links, sliders (by name) and fixed joints of :func:`describe`'s dict, for :func:`_meaning`."""
    return ({lk["name"]: lk for lk in d["links"]}, {sl["name"]: sl for sl in d.get("sliders", ())},
            {j["name"] for j in d["joints"] if j["role"] == "fixed"})


def _meaning(d: dict, p: str, lookups: tuple | None = None) -> str:
    """What design parameter ``p`` is, in words (``lookups``: :func:`_lookups` of ``d``, made once for a
    table of every parameter)."""
    links, sliders, fixed = lookups or _lookups(d)
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
    if head in sliders:
        sl = sliders[head]
        if axis == "offset":
            return f"offset of slider {head}'s slot {'-'.join(sl['line'])} (to its left)"
        what = "direction" if axis in ("dx", "dy") else "point"
        return f"slider {head}'s line: its {what} {axis[-1]}"
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
    lookups = _lookups(d)
    rows += [(p, _g(v), d["parameter_kinds"][p], _meaning(d, p, lookups)) for p, v in d["parameters"].items()]
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
    from ..mechanism import load_mechanism

    mech = load_mechanism(args.mechanism)
    d = describe(mech)
    if args.format == "json":
        print(json.dumps(d, indent=2, ensure_ascii=False, allow_nan=False))
    else:
        print(text(d))
    return 0
