"""What a mechanism is, as data (``explorer describe`` prints it; ``--format json`` is this dict): its joints
and their roles, the driver, links and bodies, design parameters, the default walker scene and buildability
screen, masses and operating point, and the plan that solves it. Nothing is simulated."""

from __future__ import annotations

import math


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

    from ..wrist import wrist_for

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

    # each joint's links and bodies, indexed once (a scan of every link per joint was quadratic)
    on_links: dict = {}
    for lk in mech.links:
        for v in dict.fromkeys((lk.a, lk.b)):
            on_links.setdefault(v, []).append(lk.name)
    on_bodies: dict = {}
    for b in mech.bodies:
        for v in dict.fromkeys(b.joints):
            on_bodies.setdefault(v, []).append(b.name)
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
        j["links"] = on_links.get(v, [])
        j["bodies"] = on_bodies.get(v, [])
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
        "parameter_kinds": dict(mech.parameter_kinds()),
        "walker": walker,
        "screen": Screen().as_dict() if mech.crank is not None else None,
        "mass": {"given": bool(masses_given), "link_density": None if density is None else float(density)},
        "operating": None if op is None else op.as_dict(),
        "plan": steps,
    }
