"""A design as the editor holds it, and what a drag does to it.

A design travels between the page and the server as the data of its mechanism file: the dict that
``tomllib`` reads from :func:`explorer.mechanism.mechanism_toml` of it (:func:`design_data`), as JSON.
What the server receives goes through the mechanism loader's validation (:func:`parse_design`), never
through anything that runs it.

**A drag** moves one joint of the configuration the page shows (the leg at a crank angle) and leaves
every other joint where it is. The design that makes the new configuration valid is the answer:

* a moving joint: every link that holds it takes the new distance to its other end, every body that
  holds it the new position in its own frame (read through the body's placement by two of its other
  joints), every slider on it its new line (a ground line moves sideways through it; a slot's offset is
  its new distance from the slot's line), every slot whose line it carries its new offset;
* a ground pivot: its coordinates, and the same for the links, bodies and slots that hold it;
* the crank tip: the crank radius and the angle shown (the tip goes where it is dragged), and the links
  and bodies at the tip;
* the crank centre (the axle): its coordinates, the crank radius and the angle shown (the tip stays).

The branch is kept, never changed silently: the configuration after the step must have the sign of
every block of the plan that the configuration before it had (:func:`explorer.kernels.branch_signs`);
a step that would flip one (a joint carried across the line through its two parents, or onto it: a
toggle) is refused with a message that says which, and the design stays as it was. The new design's
``[guess]`` (its positions at θ = 0, which pick the branch) is the dragged configuration followed
around the crank to θ = 0 by the solver itself (the design turned about the crank centre so that the
angle shown is its θ = 0, solved, and turned back), so ``explorer.simulate`` of the design it returns
passes through the configuration shown.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism, mechanism_from_dict, mechanism_toml

#: The pseudo-joint name of the crank centre (the axle) in a drag: no vertex can have it (a space).
CRANK_CENTRE = "crank centre"
#: Deepest nesting a design's JSON may have (a mechanism file needs 4: orientation keyframes).
MAX_DEPTH = 16
#: Largest whole number a design may hold (beyond it a float cannot hold it exactly).
MAX_INT = 2 ** 53


def design_data(mech: Mechanism) -> dict:
    """``mech`` as the data of its mechanism file (what ``tomllib`` reads from ``mechanism_toml(mech)``):
    every key of the mechanism format, floats exact. JSON-ready (strings, numbers, booleans, lists,
    dicts)."""
    return tomllib.loads(mechanism_toml(mech))


def parse_design(data, source: str = "design") -> Mechanism:
    """A design's data (the mechanism file's shape, as :func:`design_data` gives it) → a validated
    :class:`~explorer.mechanism.Mechanism`. One-line :class:`~explorer.errors.UserError` naming
    ``source`` and the key on anything the mechanism loader refuses, and on what JSON can hold and TOML
    cannot: a number that is not finite or a whole number too large for a float, ``null``, nesting
    deeper than :data:`MAX_DEPTH`."""
    if not isinstance(data, dict):
        raise UserError(f"{source}: expected the mechanism file's data (a JSON object with name, foot, links, ...), "
                        f"got {type(data).__name__}")
    _check_values(data, source, "", 0)
    try:
        return mechanism_from_dict(data, source)
    except UserError:
        raise
    except (TypeError, ValueError, KeyError, AttributeError, OverflowError, RecursionError) as exc:
        # a shape the loader did not foresee (JSON can hold what TOML cannot): still one line, never a crash
        raise UserError(f"{source}: not a valid mechanism ({type(exc).__name__}: {' '.join(str(exc).split())[:200]})") \
            from None


def _check_values(value, source: str, key: str, depth: int) -> None:
    if depth > MAX_DEPTH:
        raise UserError(f"{source}: {key or 'design'}: nested deeper than {MAX_DEPTH} levels")
    if value is None:
        raise UserError(f"{source}: {key}: null is not a value a mechanism file can hold")
    if isinstance(value, bool) or isinstance(value, str):
        return
    if isinstance(value, int):
        if abs(value) > MAX_INT:
            raise UserError(f"{source}: {key}: the whole number {value if value.bit_length() < 200 else '(huge)'} "
                            f"is too large (at most 2**53)")
        return
    if isinstance(value, float):
        if not math.isfinite(value):
            raise UserError(f"{source}: {key}: expected a finite number, got {value!r}")
        return
    if isinstance(value, list):
        for i, v in enumerate(value):
            _check_values(v, source, f"{key}[{i}]", depth + 1)
        return
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str):
                raise UserError(f"{source}: {key}: keys must be strings, got {k!r}")
            _check_values(v, source, f"{key}.{k}" if key else k, depth + 1)
        return
    raise UserError(f"{source}: {key}: unexpected value of type {type(value).__name__}")


# -- the design turned about its crank centre ----------------------------------------------------------
def _rotation(phi: float) -> np.ndarray:
    c, s = math.cos(phi), math.sin(phi)
    return np.array([[c, -s], [s, c]])


def rotated(mech: Mechanism, phi: float, guess: dict | None = None) -> Mechanism:
    """``mech`` turned by ``phi`` radians (counter-clockwise) about its crank centre: ground pivots,
    ground sliders' lines and the guess (or ``guess``, {vertex: (x, y)} already turned) turn with it;
    bodies' shapes, lengths and slots' offsets do not change. Its θ is the original's θ + phi, so its
    configuration at θ = 0 is the original's at θ = −phi, turned."""
    c = np.asarray(mech.crank.center, dtype=np.float64)
    R = _rotation(phi)

    def turn(p):
        q = c + R @ (np.asarray(p, dtype=np.float64) - c)
        return float(q[0]), float(q[1])

    sliders = tuple(replace(s, point=turn(s.point), direction=tuple(float(x) for x in R @ np.asarray(s.direction)))
                    if s.ground else s for s in mech.sliders)
    return replace(mech, fixed={v: turn(p) for v, p in mech.fixed.items()},
                   guess=guess if guess is not None else {v: turn(p) for v, p in mech.guess.items()}, sliders=sliders)


def turn_positions(P: np.ndarray, center, phi: float) -> np.ndarray:
    """Positions (..., 2) turned by ``phi`` about ``center``."""
    c = np.asarray(center, dtype=np.float64)
    return c + (np.asarray(P, dtype=np.float64) - c) @ _rotation(phi).T


def assemble_at(mech: Mechanism, angle: float, near=None) -> tuple[np.ndarray | None, str | None]:
    """The configuration (n_vertices, 2) of a crank-driven ``mech`` at crank angle ``angle`` (radians) on
    the branch of ``near`` (positions (n_vertices, 2) or {vertex: (x, y)}: each dyad on the side of its
    parents ``near`` has it, a coupled block by Newton from it; default the mechanism's guess, which is
    a configuration at θ = 0), by :func:`explorer.kernels.assemble` of the design turned so that
    ``angle`` is its θ = 0. Returns (positions, None), or (None, why) where it does not assemble."""
    from ..kernels import assemble

    near_map = _as_map(mech, near) if near is not None else dict(mech.guess)
    c = mech.crank.center
    guess = {v: tuple(turn_positions(np.asarray(near_map.get(v, mech.guess[v])), c, -angle)) for v in mech.guess}
    P, fail = assemble(rotated(mech, -angle, guess))
    if fail is not None:
        who = f"vertex {fail.vertex}" if fail.vertex else "the design"
        return None, f"{who} cannot be placed at θ = {math.degrees(angle % (2 * math.pi)):.2f}° ({fail.kind})"
    return turn_positions(P, c, angle), None


def _as_map(mech: Mechanism, near) -> dict:
    if isinstance(near, dict):
        return {str(k): (float(v[0]), float(v[1])) for k, v in near.items()}
    P = np.asarray(near, dtype=np.float64)
    return {v: (float(P[i, 0]), float(P[i, 1])) for i, v in enumerate(mech.vertices)}


# -- a drag ------------------------------------------------------------------------------------------------
@dataclass
class Drag:
    """What one drag step gives.

    design : the dragged design (its guess on the branch shown), or None when the step is refused;
        data : :func:`design_data` of it.
    angle : the crank angle it is shown at, radians (changed only by dragging the crank tip or centre;
        a path driver's time in seconds).
    config : (n_vertices, 2) the configuration shown after the step (before it, when refused).
    refused : None, or one line saying why the step was refused (the design is unchanged).
    note : None, or one line about the design (for example: θ = 0 cannot be reached from the angle
        shown, so its guess cannot hold this branch).
    cycle : the design's :class:`explorer.Cycle` at ``steps`` where the drag solved it on the way (its
        guess is that cycle's positions at θ = 0, so ``explorer.simulate`` of the design gives it again),
        else None.
    """

    design: Mechanism | None
    angle: float
    config: np.ndarray
    refused: str | None = None
    note: str | None = None
    data: dict | None = None  # design_data(design), made once
    cycle: object = None  # explorer.simulate(design, steps) when the drag already solved it, else None


def _angle_text(mech: Mechanism, angle: float) -> str:
    if mech.crank is None:
        return f"t = {angle:.4g} s"
    return f"θ = {math.degrees(angle % (2 * math.pi)):.1f}°"


def configuration(mech: Mechanism, angle: float, near=None, steps: int = 360):
    """(positions (n_vertices, 2) or None, the angle, why not): the configuration the editor shows at
    ``angle``: crank-driven, assembled at that angle on the branch of ``near`` (:func:`assemble_at`); a
    path driver, the solved sample nearest the time ``angle``."""
    if mech.crank is not None:
        P, why = assemble_at(mech, angle, near)
        return P, angle, why
    from ..kernels import simulate

    cyc = simulate(mech, steps)
    k = int(np.argmin(np.abs(cyc.theta - angle)))
    P = cyc.positions[k]
    if not np.all(np.isfinite(P)):
        return None, float(cyc.theta[k]), f"the design is not solved at {_angle_text(mech, cyc.theta[k])}"
    return P, float(cyc.theta[k]), None


def drag(mech: Mechanism, angle: float, joint: str, to, near=None, steps: int = 360) -> Drag:
    """Move ``joint`` (a vertex name, or :data:`CRANK_CENTRE`) of ``mech``'s configuration at ``angle``
    (crank angle, radians; a path driver's time, s) to ``to`` = (x, y), model units, every other joint
    staying where it is, and return the design that makes it valid (see the module docstring).

    near : the configuration the page shows (positions (n_vertices, 2) or {vertex: (x, y)}): it picks
    the branch the design is assembled on at ``angle`` (default: the design's own, from its guess).
    steps : the samples per turn the design is solved at to carry its branch to θ = 0.
    """
    from ..kernels import branch_signs

    x, y = (float(to[0]), float(to[1]))
    if not (math.isfinite(x) and math.isfinite(y)):
        raise UserError(f"drag: expected a finite position, got {to!r}")
    C, angle, why = configuration(mech, angle, near, steps)
    nv = len(mech.vertices)
    if mech.gears:  # a geared crank's tip moves with the crank's angle: no drag keeps the other joints still
        return Drag(None, angle, np.full((nv, 2), np.nan) if C is None else C,
                    refused="the editor does not drag geared mechanisms ([[gears]]) yet; edit the mechanism file")
    if C is None:
        return Drag(None, angle, np.full((nv, 2), np.nan),
                    refused=f"cannot drag here: {why}; move the crank to an angle where the leg is drawn")
    joint = str(joint)
    crank = mech.crank
    driven = mech.driven
    C1 = C.copy()
    values: dict[str, float] = {}
    new_angle = angle
    if joint == CRANK_CENTRE:
        if crank is None:
            raise UserError("drag: this mechanism is driven along a path; it has no crank centre")
        tip = C[mech.vertex_index(driven)]
        r = math.hypot(tip[0] - x, tip[1] - y)
        values.update({"crank": r, "crank.x": x, "crank.y": y})
        new_angle = math.atan2(tip[1] - y, tip[0] - x) % (2 * math.pi)
        moved = None
    else:
        i = mech.vertex_index(joint)  # UserError naming the known vertices
        if joint == driven:
            if crank is None:
                return Drag(None, angle, C, refused=f"vertex {joint} is driven along its prescribed path; change the "
                                                    f"path in the mechanism file")
            cx, cy = crank.center
            values["crank"] = math.hypot(x - cx, y - cy)
            new_angle = math.atan2(y - cy, x - cx) % (2 * math.pi)
        elif joint in mech.fixed:
            values.update({f"{joint}.x": x, f"{joint}.y": y})
        C1[i] = (x, y)
        moved = joint
    if "crank" in values and not values["crank"] > 1e-9 * max(1.0, mech.size):
        return Drag(None, angle, C, refused="the crank tip would sit on the crank centre (a crank of length 0)")
    if moved is not None:
        values.update(_members(mech, C1, moved))
    try:
        data = design_data(mech.with_parameters(values))
        moved_mech = parse_design(data, "design")  # every check of a mechanism file
    except UserError as exc:
        return Drag(None, angle, C, refused=f"the design would be invalid: {exc}")
    # -- the branch: every block keeps its sign ----------------------------------------------------------
    s0, s1 = branch_signs(mech, C), branch_signs(moved_mech, C1)
    flip = next((k for k in range(len(s0)) if s0[k] != 0.0 and s1[k] != s0[k]), None)
    if flip is not None:
        return Drag(None, angle, C, refused=_flip_text(mech, flip, on_line=s1[flip] == 0.0, joint=joint))
    # -- the guess: this configuration followed to θ = 0 --------------------------------------------------
    guess, note, cycle = _guess_at_zero(moved_mech, new_angle, C1, s1, steps)
    data["guess"] = {v: [x, y] for v, (x, y) in guess.items()}  # as mechanism_toml writes it: vertex order
    return Drag(replace(moved_mech, guess=guess), new_angle, C1, note=note, data=data, cycle=cycle)


def _members(mech: Mechanism, C1: np.ndarray, v: str) -> dict[str, float]:
    """The design parameters of the members that hold vertex ``v`` (links, bodies, sliders and slots),
    so that the configuration C1, where ``v`` has moved, is valid."""
    P = {name: C1[i] for i, name in enumerate(mech.vertices)}
    out: dict[str, float] = {}
    for link in mech.links:
        if v in (link.a, link.b):
            out[link.name] = float(math.dist(P[link.a], P[link.b]))
    for body in mech.bodies:
        if v in body.joints:
            bx, by = _body_point(body, v, P)
            out[f"{body.name}.{v}.x"], out[f"{body.name}.{v}.y"] = bx, by
    actuated = mech.path.slider if mech.path is not None else None
    for s in mech.sliders:
        if s.ground and s.vertex == v and s.name != actuated:
            ux, uy = s.unit()
            d = np.asarray(P[v]) - np.asarray(s.point)
            along = d[0] * ux + d[1] * uy
            nx, ny = d[0] - along * ux, d[1] - along * uy  # the line moves sideways through the vertex
            out[f"{s.name}.x"], out[f"{s.name}.y"] = float(s.point[0] + nx), float(s.point[1] + ny)
        elif not s.ground and v in (s.vertex, *s.line):
            out[f"{s.name}.offset"] = signed_offset(P[s.line[0]], P[s.line[1]], P[s.vertex])
    return out


def signed_offset(a, b, p) -> float:
    """The signed distance of ``p`` from the line a → b, positive to its left (a slot's ``offset``)."""
    g = np.asarray(b, dtype=np.float64) - np.asarray(a, dtype=np.float64)
    w = np.asarray(p, dtype=np.float64) - np.asarray(a, dtype=np.float64)
    return float((g[0] * w[1] - g[1] * w[0]) / math.hypot(g[0], g[1]))


def _body_point(body, v: str, P: dict) -> tuple[float, float]:
    """Joint ``v``'s position in ``body``'s own frame once it sits at P[v], the body's other joints
    staying where P has them: through the body's placement by the two of them farthest apart (a body
    of two joints keeps the direction of its joint in its frame and takes the new distance)."""
    pts = {j: np.asarray(p, dtype=np.float64) for j, p in zip(body.joints, body.points)}
    others = [j for j in body.joints if j != v]
    if len(others) == 1:
        u = others[0]
        d = pts[v] - pts[u]
        dist = float(math.dist(P[v], P[u]))
        q = pts[u] + d / math.hypot(d[0], d[1]) * dist
        return float(q[0]), float(q[1])
    u, w = max(((a, b) for ia, a in enumerate(others) for b in others[ia + 1:]),
               key=lambda ab: math.dist(pts[ab[0]], pts[ab[1]]))
    gb, gw = pts[w] - pts[u], np.asarray(P[w]) - np.asarray(P[u])
    turn = math.atan2(gw[1], gw[0]) - math.atan2(gb[1], gb[0])
    q = pts[u] + _rotation(-turn) @ (np.asarray(P[v]) - np.asarray(P[u]))
    return float(q[0]), float(q[1])


def _flip_text(mech: Mechanism, k: int, on_line: bool, joint: str) -> str:
    from ..kernels import plan_for
    from ..plan import DYAD

    plan = plan_for(mech)
    blk = plan.blocks[k]
    names = [mech.vertices[i] for i in blk.vertices]
    what = "dragging the crank centre" if joint == CRANK_CENTRE else f"dragging {joint}"
    if blk.kind == DYAD:
        v = blk.vertices[0]
        a, b = (int(plan.link_b[e] if plan.link_a[e] == v else plan.link_a[e]) for e in blk.links)
        line = f"the line {mech.vertices[a]}–{mech.vertices[b]} through its two parents"
        if on_line:
            return (f"{what} there puts vertex {names[0]} on {line}: a toggle (dead centre); the step is refused, "
                    f"drag back")
        return (f"{what} there would flip vertex {names[0]} to its mirror assembly (across {line}): the design "
                f"would jump to another branch; the step is refused, drag back")
    group = ", ".join(names)
    if on_line:
        return f"{what} there puts the group {group} at a toggle (a singular point); the step is refused, drag back"
    return (f"{what} there would flip the group {group} to another assembly (branch); the step is refused, "
            f"drag back")


def _guess_at_zero(mech: Mechanism, angle: float, C1: np.ndarray, signs: np.ndarray, steps: int):
    """(guess, note, cycle): the guess (positions at θ = 0 of every guessed vertex) that keeps the branch
    of configuration C1 (block signs ``signs``) at ``angle``; a note where θ = 0 cannot be reached from
    it; the design solved with that guess where that solve was needed to find it (else None).

    First the design is solved from its guess as it is (the design before the step: a drag step is small,
    so at θ = 0 it picks the same sides): where that cycle passes through the sample nearest ``angle`` on
    C1's branch (every block's sign the same), its own positions at θ = 0 are the guess. Otherwise (a
    large step, a toggle near θ = 0) C1 is followed to θ = 0 by solving the design turned about its
    crank centre so that ``angle`` is its θ = 0."""
    from ..kernels import branch_signs, simulate

    idx = {v: mech.vertex_index(v) for v in mech.guess}
    rows = list(idx.values())

    def guess_of(P):
        return {v: (float(P[i, 0]), float(P[i, 1])) for v, i in idx.items()}

    cyc = simulate(mech, steps)
    k = int(np.argmin(np.abs(((cyc.theta - angle + math.pi) % (2 * math.pi)) - math.pi))) if mech.crank is not None \
        else int(np.argmin(np.abs(cyc.theta - angle)))
    Pk, P0 = cyc.positions[k], cyc.positions[0]
    if np.all(np.isfinite(Pk)) and np.all(np.isfinite(P0[rows])) and np.array_equal(branch_signs(mech, Pk), signs):
        return guess_of(P0), None, cyc
    if mech.crank is None:  # a path driver: the branch at t = 0 is the one its guess picks
        return (guess_of(P0) if np.all(np.isfinite(P0[rows])) else dict(mech.guess)), None, None
    c = mech.crank.center
    turned = turn_positions(C1, c, -angle)
    cyc = simulate(rotated(mech, -angle, {v: tuple(turned[i]) for v, i in idx.items()}), steps)
    j0 = int(round(((-angle) % (2 * math.pi)) / (2 * math.pi / steps))) % steps
    X = cyc.positions[j0]
    if np.all(np.isfinite(X[rows])):
        return guess_of(turn_positions(X, c, angle)), None, None
    # θ = 0 is out of reach from the configuration shown: the file's guess cannot hold this branch
    f = cyc.failure
    lo = (angle + (f.theta_end if f.theta_end is not None else f.theta)) % (2 * math.pi)
    hi = (angle + f.theta) % (2 * math.pi)
    note = (f"from the angle shown the leg turns only from θ = {math.degrees(lo):.1f}° to {math.degrees(hi):.1f}° "
            f"(vertex {f.vertex}: {f.kind}); θ = 0, where a mechanism file's guess picks the branch, is out of reach")
    return guess_of(C1), note, None


def set_parameters(mech: Mechanism, values: dict, steps: int = 360) -> Mechanism:
    """``mech`` with some design parameters (by name, :meth:`~explorer.mechanism.Mechanism.parameters`)
    set, on its branch: its guess becomes its own solved positions at θ = 0 (t = 0), where they are
    finite, so the closed form places every dyad of the new design on the side the old one had (as a
    study's variants keep the nominal's branch). UserError for an unknown name or an invalid value."""
    from ..kernels import simulate

    clean = {}
    for k, v in dict(values).items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise UserError(f"design parameter {k!r}: expected a finite number, got {v!r}")
        clean[str(k)] = float(v)
    new = mech.with_parameters(clean)
    cyc = simulate(mech, steps)
    P0 = cyc.positions[0]
    guess = {v: (float(P0[mech.vertex_index(v), 0]), float(P0[mech.vertex_index(v), 1]))
             for v in mech.guess if np.all(np.isfinite(P0[mech.vertex_index(v)]))}
    new = replace(new, guess={**dict(mech.guess), **guess})
    return parse_design(design_data(new), "design")
