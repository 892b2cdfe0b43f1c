"""A planar MuJoCo model (MJCF text) of one design's walker scene.

The machine, as the walker scene describes it, built from rigid members:

* the **body** (chassis): the ``[operating] load`` as its mass, its centre of mass at the crank centre;
  it slides in x (walking) and z (up, the model's y) and, with ``pitch = "free"``, turns about the
  crank centre (its inertia: a uniform rectangle spanning the crank centre and every ground pivot of
  both mirror sides, m·(w² + h²)/12, unless given);
* the **crankshaft**: one member hinged to the body at the crank centre carrying every leg's crank arm
  (leg j's at angle θ + φ_j, mirrored legs' too), driven at the stated rpm by a stiff, damped servo
  (a position servo on θ_ref = ω·t and a velocity servo on ω; the motor torque is their sum);
* every **leg** at its phase: each link and rigid body a member, placed at the leg's solved pose at
  θ = 0 (a mirrored leg as the mirror image of the leg at π − φ_j about the vertical through the crank
  centre). The pin joints form a graph of members; a breadth-first spanning tree from the body makes
  the members a kinematic tree of hinges (at the pins), and every pin the tree leaves out closes its
  loop with an equality constraint (``connect``, stiff: solref 2·timestep, solimp 0.99–0.9999);
* each **foot** a small sphere (radius ``foot_radius``) on the member that carries the foot vertex,
  with friction μ on a ground plane; the only contacts in the model are feet on the ground (the legs
  share one plane and pass through each other, as the kinematic scene's legs do).

Masses follow the one mass rule (:mod:`explorer.mechanism._mass`, the forces effect's too): a link's
``mass`` or ``link_density`` × length (a uniform bar), each body's ``mass``, ``centroid`` and ``inertia``, each
crank arm's ``mass`` or density × radius (a uniform bar from the centre to the tip). A member with no
mass gets :data:`MIN_MASS_FRACTION` of the body's mass (MuJoCo needs a positive mass on every moving
member); the model says how many (``info["massless"]``).

Coordinates: the mechanism's model units × ``unit`` = metres; its (x, y) is MuJoCo's (x, z); the hinge
axis is −y, so a positive angle is counter-clockwise in the mechanism's own drawing. All member frames
are aligned with the world at the start (qpos = 0 is the assembled machine at θ = 0, which is what a
``connect`` constraint needs).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import UserError
from ..mechanism import effective_mass

#: A member without mass data gets this fraction of the body's mass: MuJoCo needs positive masses, and legs
#: much lighter than that make the stiff loop constraints ill-conditioned (a massless Klann leg under an 8 kg
#: body at 1e-4 blew up; at 1e-3 a Hoeken walker's travel was 31 % short, at 1e-2 within 1 % of the figures
#: with real masses). Figures of such a design depend on it: give the mechanism its masses.
MIN_MASS_FRACTION = 1e-2
#: Default foot sphere radius, as a fraction of the crank radius.
FOOT_RADIUS = 0.05
#: Default friction coefficient of a foot on the ground.
FRICTION = 0.8


@dataclass(frozen=True)
class Settings:
    """How the physics check runs (everything a stored figure depends on).

    pitch : "held" (the body slides in x and z only) or "free" (it also turns about the crank centre).
    turns : whole crank turns measured after settling (≥ 1).
    settle : crank turns run first and not measured (≥ 0).
    timestep : s. foot_radius : fraction of the crank radius. friction : μ of a foot on the ground.
    body_inertia : kg·m² of the body about its centre of mass (pitch free); None: the rectangle rule.
    servo : the crank servo's stiffness, N·m/rad per (machine weight × crank radius) (its damping is
        critical for the crankshaft's effective inertia, estimated from the start's kinetic energy).
    loaded : a foot is *loaded* when it carries more than this fraction of the machine's weight.
    impact_window : crank angle (rad) after a foot lands in which its largest normal force is its impact.
    """

    pitch: str = "held"
    turns: int = 3
    settle: float = 0.5
    timestep: float = 5e-4
    foot_radius: float = FOOT_RADIUS
    friction: float = FRICTION
    body_inertia: float | None = None
    servo: float = 400.0
    loaded: float = 0.05
    impact_window: float = math.radians(10.0)

    def as_dict(self) -> dict:
        return {"pitch": self.pitch, "turns": int(self.turns), "settle": float(self.settle),
                "timestep": float(self.timestep), "foot_radius": float(self.foot_radius),
                "friction": float(self.friction), "body_inertia": self.body_inertia, "servo": float(self.servo),
                "loaded": float(self.loaded), "impact_window_deg": round(math.degrees(self.impact_window), 9)}


@dataclass
class Member:
    """One rigid member of the machine: its joints (vertex names, per leg), its mass (kg), centre of mass
    (world, m), inertia about it (kg·m², about the hinge axis) and what the tree makes of it."""

    name: str
    joints: tuple
    points: dict  # vertex -> world position (2,) m at the start
    mass: float
    com: np.ndarray
    inertia: float
    parent: int = -1
    pin: str | None = None  # the vertex of its hinge to the parent
    children: list = field(default_factory=list)
    massless: bool = False


def hermite(P: np.ndarray, V: np.ndarray, alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions and θ-derivatives (n, 2) at crank angle ``alpha`` from the samples P, V (S, n, 2) at
    θ_k = 2πk/S: the cubic Hermite interpolant (the sample itself when ``alpha`` falls on one)."""
    S = P.shape[0]
    d = 2.0 * math.pi / S
    u = (alpha / d) % S
    r = round(u)
    if abs(u - r) < 1e-9:
        k = int(r) % S
        return P[k].copy(), V[k].copy()
    k0 = int(math.floor(u)) % S
    k1 = (k0 + 1) % S
    f = u - math.floor(u)
    f2, f3 = f * f, f * f * f
    p = ((2 * f3 - 3 * f2 + 1) * P[k0] + (f3 - 2 * f2 + f) * d * V[k0] + (-2 * f3 + 3 * f2) * P[k1]
         + (f3 - f2) * d * V[k1])
    v = (((6 * f2 - 6 * f) / d) * P[k0] + (3 * f2 - 4 * f + 1) * V[k0] + ((-6 * f2 + 6 * f) / d) * P[k1]
         + (3 * f2 - 2 * f) * V[k1])
    return p, v


def leg_poses(mech, P: np.ndarray, V: np.ndarray, walker, theta0: float = 0.0):
    """Every leg's vertex positions and velocities (per radian of crank) at crank angle ``theta0`` in
    the body's frame (model units): two lists of L arrays (n_vertices, 2). A plain leg j is the leg at
    θ0 + φ_j; a mirrored one the mirror image of the leg at π − θ0 − φ_j, driven backwards."""
    cx = float(mech.crank.center[0])
    pos, vel = [], []
    for phi, mirrored in zip(walker.phases, walker.mirrored):
        if mirrored:
            p, v = hermite(P, V, math.pi - theta0 - phi)
            p[:, 0] = 2.0 * cx - p[:, 0]
            v[:, 1] = -v[:, 1]  # mirrored (x' → −x') and driven backwards (dα/dθ = −1)
        else:
            p, v = hermite(P, V, theta0 + phi)
        pos.append(p)
        vel.append(v)
    return pos, vel


def _bar(a: np.ndarray, b: np.ndarray, m: float) -> tuple[np.ndarray, float]:
    """Centre of mass and inertia about it of a uniform bar a–b of mass m (world, m)."""
    return 0.5 * (a + b), m * float(np.sum((b - a) ** 2)) / 12.0


def _combine(parts) -> tuple[float, np.ndarray, float]:
    """Mass, centre of mass and inertia about it of rigid parts [(m, com, I_com)]."""
    m = sum(p[0] for p in parts)
    if m <= 0:
        return 0.0, np.mean([p[1] for p in parts], axis=0), 0.0
    com = sum(p[0] * p[1] for p in parts) / m
    inertia = sum(p[2] + p[0] * float(np.sum((p[1] - com) ** 2)) for p in parts)
    return m, com, inertia


def _body_placement(points_local: np.ndarray, points_world: np.ndarray):
    """The rigid map local → world of a body (2-D rotation R and translation t) from its joints, fitted
    on all of them (they are placed exactly; the fit only averages round-off)."""
    a = points_local - points_local.mean(axis=0)
    b = points_world - points_world.mean(axis=0)
    h = a.T @ b
    ang = math.atan2(h[0, 1] - h[1, 0], h[0, 0] + h[1, 1])
    R = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
    t = points_world.mean(axis=0) - R @ points_local.mean(axis=0)
    return R, t


def _fmt(*xs) -> str:
    return " ".join(f"{float(x):.12g}" for x in xs)


@dataclass
class Model:
    """What :func:`build_model` gives: ``xml`` (MJCF text) and what the simulation needs to read it.

    qvel0 : the initial velocities (nv,) in MuJoCo's order (the kinematic machine's at θ = 0, with the
    contact foot planted); n_legs; walk : +1 or −1, the walking direction along x that the kinematic
    walker predicts; weight : the machine's weight (N); mass : its mass (kg); crank_radius (m);
    massless : members given :data:`MIN_MASS_FRACTION` of the body's mass; omega : rad/s; drag : N.
    """

    xml: str
    qvel0: np.ndarray
    n_legs: int
    walk: float
    weight: float
    mass: float
    crank_radius: float
    massless: int
    omega: float
    drag: float
    settings: Settings
    joint_names: list


def build_model(mech, P: np.ndarray, V: np.ndarray, walker, operating, settings: Settings) -> Model:
    """The MuJoCo model of ``mech``'s walker scene from its solved cycle P, V (S, n_vertices, 2) (model
    units, per radian of crank), ``walker`` (:class:`~explorer.mechanism.Walker`) and ``operating``
    (:class:`~explorer.mechanism.Operating`: ``unit``, ``rpm``, ``gravity``, ``load`` = the body's mass).
    See the module docstring."""
    unit = float(operating.unit)
    omega = float(operating.omega)
    g = float(operating.gravity)
    body_mass = float(operating.load)
    crank = mech.crank
    c = np.asarray(crank.center, dtype=np.float64)
    rc = float(crank.radius) * unit
    L = walker.legs
    pos, vel = leg_poses(mech, P, V, walker)
    # the lowest foot at θ = 0 stands on the ground (its sphere touching it)
    fi = mech.vertex_index(mech.foot)
    feet_y = [p[fi, 1] for p in pos]
    contact = int(np.argmin(feet_y))
    rho = settings.foot_radius * rc
    z0 = (c[1] - feet_y[contact]) * unit + rho

    def world(p):  # model units in the body's frame → world metres at the start
        return np.array([(p[0] - c[0]) * unit, (p[1] - c[1]) * unit + z0])

    floor = MIN_MASS_FRACTION * body_mass
    members: list[Member] = []
    massless = 0

    def add(name, joints, pts, parts):
        nonlocal massless
        m, com, inertia = _combine(parts)
        light = m <= 0
        if light:  # a massless member: a small uniform mass over its joints
            massless += 1
            xs = np.array(list(pts.values()))
            m, com = floor, xs.mean(axis=0)
            inertia = max(floor * float(np.mean(np.sum((xs - com) ** 2, axis=1))), floor * rc * rc * 1e-2)
        members.append(Member(name, tuple(joints), pts, m, com, max(inertia, 1e-12 * m), massless=light))
        return len(members) - 1

    # the body (root) and the crankshaft with every leg's crank arm
    frame_pts = {}
    for j in range(L):
        for v in mech.fixed:
            frame_pts[(j, v)] = world(pos[j][mech.vertex_index(v)])
    xs = np.array([world(c)] + list(frame_pts.values()))
    w, h = np.ptp(xs[:, 0]), np.ptp(xs[:, 1])
    body_inertia = settings.body_inertia if settings.body_inertia is not None else body_mass * (w * w + h * h) / 12.0
    members.append(Member("body", (), frame_pts, body_mass, world(c), max(body_inertia, 1e-9 * body_mass)))
    cm = effective_mass(mech, crank.mass, crank.radius, unit)  # the one mass rule (explorer.mechanism)
    tips = {(j, crank.tip): world(pos[j][mech.vertex_index(crank.tip)]) for j in range(L)}
    arm_parts = [(cm, *_bar(world(c), tips[(j, crank.tip)], cm)) for j in range(L)]
    crankshaft = add("crankshaft", (), tips, arm_parts)
    members[crankshaft].parent, members[crankshaft].pin = 0, None  # hinged at the crank centre

    # every leg's links and bodies
    incident: dict = {}  # (leg, vertex) -> member indices
    for j in range(L):
        for v in mech.fixed:
            incident.setdefault((j, v), []).append(0)
        incident.setdefault((j, crank.tip), []).append(crankshaft)
        for lk in mech.links:
            a, b = world(pos[j][mech.vertex_index(lk.a)]), world(pos[j][mech.vertex_index(lk.b)])
            m = effective_mass(mech, lk.mass, lk.length, unit)
            k = add(f"leg{j}_link_{lk.name}", (lk.a, lk.b), {(j, lk.a): a, (j, lk.b): b}, [(m, *_bar(a, b, m))])
            incident.setdefault((j, lk.a), []).append(k)
            incident.setdefault((j, lk.b), []).append(k)
        for bd in mech.bodies:
            pw = np.array([world(pos[j][mech.vertex_index(v)]) for v in bd.joints])
            loc = np.asarray(bd.points, dtype=np.float64) * unit
            if walker.mirrored[j]:  # the mirror image of the body: its local frame mirrored too
                loc = loc * np.array([-1.0, 1.0])
            R, t = _body_placement(loc, pw)
            G = np.asarray(bd.centroid, dtype=np.float64) * unit if bd.centroid is not None else None
            if G is not None and walker.mirrored[j]:
                G = G * np.array([-1.0, 1.0])
            gw = R @ G + t if G is not None else pw.mean(axis=0)
            if bd.inertia is not None:
                IG = float(bd.inertia)
            else:
                IG = bd.mass / len(bd.joints) * float(np.sum((pw - gw) ** 2))
            k = add(f"leg{j}_body_{bd.name}", bd.joints, {(j, v): pw[i] for i, v in enumerate(bd.joints)},
                    [(float(bd.mass), gw, IG)])
            for v in bd.joints:
                incident.setdefault((j, v), []).append(k)

    # a spanning tree of hinges from the body (breadth first); the pins it leaves out become connects
    order = [0, crankshaft]
    seen = {0, crankshaft}
    members[0].children.append(crankshaft)
    head = 0
    while head < len(order):
        mi = order[head]
        head += 1
        for key in members[mi].points:
            for other in incident.get(key, ()):
                if other in seen:
                    continue
                seen.add(other)
                members[other].parent, members[other].pin = mi, key
                members[mi].children.append(other)
                order.append(other)
    if len(seen) != len(members):
        lost = [members[i].name for i in range(len(members)) if i not in seen]
        raise UserError(f"{mech.source}: the physics check cannot attach {', '.join(lost[:3])} to the machine: "
                        f"no chain of pin joints leads to it from the frame or the crank")
    connects = []  # (member a, member b, key): a pin the tree does not close
    for key, ms in incident.items():
        # members at this pin joined through the tree at this very pin
        groups = {m: m for m in ms}

        def find(m):
            while groups[m] != m:
                m = groups[m]
            return m

        for m in ms:
            p = members[m].parent
            if members[m].pin == key and p in groups:
                groups[find(m)] = find(p)
        roots = []
        for m in ms:
            r = find(m)
            if r not in roots:
                roots.append(r)
        for r in roots[1:]:
            connects.append((roots[0], r, key))

    # -- initial velocities: the kinematic machine at θ = 0, the contact foot planted -------------------
    vc = vel[contact][fi] * unit * omega  # the contact foot's velocity relative to the body, m/s
    body_v = -vc  # the foot stays put: the body moves the other way
    ang = np.zeros(len(members))
    ang[crankshaft] = omega
    for k, mb in enumerate(members):
        if k in (0, crankshaft):
            continue
        (j0, a), (j1, b) = list(mb.points)[:2]
        pa, pb = pos[j0][mech.vertex_index(a)], pos[j1][mech.vertex_index(b)]
        va, vb = vel[j0][mech.vertex_index(a)], vel[j1][mech.vertex_index(b)]
        d, dv = pb - pa, vb - va
        ang[k] = (d[0] * dv[1] - d[1] * dv[0]) / float(d @ d) * omega
    # the kinematic walker's direction: the body moves against the contact foot over the whole turn
    walk = _walking_direction(mech, P, V, walker)

    # -- MJCF ---------------------------------------------------------------------------------------------
    dt = settings.timestep
    tc = 2.0 * dt
    total = sum(mb.mass for mb in members)
    weight = total * g
    held = settings.pitch == "held"
    kp = settings.servo * weight * rc
    # the crankshaft's effective inertia about its axis: 2 × kinetic energy / ω² at the start
    Jeff = members[crankshaft].inertia + members[crankshaft].mass * float(np.sum((members[crankshaft].com -
                                                                                  world(c)) ** 2))
    ke = 0.5 * body_mass * float(body_v @ body_v)
    for k, mb in enumerate(members):
        if k in (0, crankshaft):
            continue
        ke += 0.5 * mb.inertia * ang[k] ** 2  # (a lower bound: the translation of its centre left out)
    Jeff = max(Jeff + 2.0 * ke / (omega * omega), 1e-9)
    kv = 2.0 * math.sqrt(kp * Jeff)
    drag = float(walker.drag) * body_mass * g

    lines = ['<mujoco model="explorer-walker">',
             '  <compiler angle="radian" inertiafromgeom="false" autolimits="true"/>',
             f'  <option timestep="{dt:.9g}" gravity="0 0 {-g:.9g}" integrator="implicitfast" cone="elliptic" '
             f'impratio="1" iterations="100" tolerance="1e-10"/>',
             '  <default>',
             '    <geom contype="0" conaffinity="0" rgba=".8 .6 .4 1"/>',
             '    <joint axis="0 -1 0" damping="0" armature="0"/>',
             f'    <equality solref="{tc:.9g} 1" solimp="0.99 0.9999 0.001 0.5 2"/>',
             '  </default>',
             '  <worldbody>',
             f'    <geom name="ground" type="plane" size="0 0 1" contype="0" conaffinity="1" '
             f'friction="{settings.friction:.9g} 0.005 0.0001" solref="{tc:.9g} 1" solimp="0.99 0.9999 0.001 0.5 2" '
             f'rgba=".5 .6 .5 1"/>']
    joint_names = []

    def emit(k, origin, depth):
        mb = members[k]
        ind = "  " * (depth + 2)
        if k == 0:
            here = mb.com
        elif k == crankshaft:
            here = world(c)
        else:
            here = mb.points[mb.pin]
        rel = here - origin
        lines.append(f'{ind}<body name="{mb.name}" pos="{_fmt(rel[0], 0, rel[1])}">')
        if k == 0:
            lines.append(f'{ind}  <joint name="body_x" type="slide" axis="1 0 0"/>')
            lines.append(f'{ind}  <joint name="body_z" type="slide" axis="0 0 1"/>')
            joint_names.extend(["body_x", "body_z"])
            if not held:
                lines.append(f'{ind}  <joint name="body_pitch" type="hinge"/>')
                joint_names.append("body_pitch")
            lines.append(f'{ind}  <site name="body" pos="0 0 0"/>')
        else:
            lines.append(f'{ind}  <joint name="{mb.name}_hinge" type="hinge"/>')
            joint_names.append(f"{mb.name}_hinge")
        cl = mb.com - here
        lines.append(f'{ind}  <inertial pos="{_fmt(cl[0], 0, cl[1])}" mass="{mb.mass:.12g}" '
                     f'diaginertia="{_fmt(mb.inertia, mb.inertia, mb.inertia)}"/>')
        pts = list(mb.points.values())
        if k not in (0,):
            for a, b in (zip(pts[:-1], pts[1:]) if len(pts) > 1 else ()):
                pa, pb = a - here, b - here
                if float(np.hypot(*(pb - pa))) < 1e-6 * rc:  # two joints at one place (drawn as nothing)
                    continue
                lines.append(f'{ind}  <geom type="capsule" fromto="{_fmt(pa[0], 0, pa[1], pb[0], 0, pb[1])}" '
                             f'size="{0.1 * rc:.6g}"/>')
        for key, pw in mb.points.items():
            j, v = key
            if v == mech.foot and k != 0 and _foot_owner(members, incident, key) == k:
                pl = pw - here
                lines.append(f'{ind}  <geom name="foot{j}" type="sphere" pos="{_fmt(pl[0], 0, pl[1])}" '
                             f'size="{rho:.9g}" contype="1" conaffinity="0" friction="{settings.friction:.9g} '
                             f'0.005 0.0001" solref="{tc:.9g} 1" solimp="0.99 0.9999 0.001 0.5 2" '
                             f'rgba=".2 .2 .2 1"/>')
                lines.append(f'{ind}  <site name="foot{j}" pos="{_fmt(pl[0], 0, pl[1])}"/>')
        for ch in mb.children:
            emit(ch, here, depth + 1)
        lines.append(f'{ind}</body>')

    emit(0, np.zeros(2), 0)
    lines.append('  </worldbody>')
    lines.append('  <equality>')
    for a, b, key in connects:
        ma = members[a]
        anchor = ma.points[key] - (ma.com if a == 0 else world(c) if a == crankshaft else ma.points[ma.pin])
        lines.append(f'    <connect body1="{ma.name}" body2="{members[b].name}" anchor="{_fmt(anchor[0], 0, anchor[1])}"/>')
    lines.append('  </equality>')
    lines.append('  <actuator>')
    lines.append(f'    <position name="servo_position" joint="crankshaft_hinge" kp="{kp:.9g}"/>')
    lines.append(f'    <velocity name="servo_velocity" joint="crankshaft_hinge" kv="{kv:.9g}"/>')
    lines.append('    <motor name="drag" joint="body_x" gear="1"/>')
    lines.append('  </actuator>')
    lines.append('  <sensor>')
    lines.append('    <actuatorfrc actuator="servo_position"/>')
    lines.append('    <actuatorfrc actuator="servo_velocity"/>')
    for j in range(L):
        lines.append(f'    <contact geom1="ground" geom2="foot{j}" data="found force" reduce="netforce" num="1"/>')
        lines.append(f'    <framelinvel objtype="site" objname="foot{j}"/>')
        lines.append(f'    <frameangvel objtype="site" objname="foot{j}"/>')
    lines.append('  </sensor>')
    lines.append('</mujoco>')

    # initial qvel in joint order (tree order of emit = depth-first)
    qvel0 = []
    hinge_of = {}

    def vel_of(k):
        mb = members[k]
        if k == 0:
            out = [body_v[0], body_v[1]] + ([] if held else [0.0])
        else:
            out = [ang[k] - (ang[mb.parent] if mb.parent not in (0,) else 0.0)]
        hinge_of[k] = out
        return out

    def walk_tree(k):
        qvel0.extend(vel_of(k))
        for ch in members[k].children:
            walk_tree(ch)

    walk_tree(0)
    return Model("\n".join(lines) + "\n", np.array(qvel0, dtype=np.float64), L, walk, weight, total, rc, massless,
                 omega, drag, settings, joint_names)


def _foot_owner(members, incident, key) -> int:
    """The member that carries leg ``key[0]``'s foot sphere: the first incident member in tree order."""
    return min(k for k in incident[key] if k != 0)


def _walking_direction(mech, P, V, walker) -> float:
    """+1 when the kinematic walker moves along +x, −1 along −x: the body moves against its contact
    foot, u = −sign(Σ_k x'_c(θ_k)) (explorer.gait._walker)."""
    from ..kernels import ground_contact, leg_feet, leg_samples
    S = P.shape[0]
    fi = mech.vertex_index(mech.foot)
    base, frac, sign = leg_samples(walker, S)
    mirrored = np.array(walker.mirrored, dtype=np.bool_)
    L = walker.legs
    Y, VX, VY = np.empty((L, S)), np.empty((L, S)), np.empty((L, S))
    leg_feet(base, frac, sign, mirrored, np.ascontiguousarray(P[:, fi]), np.ascontiguousarray(V[:, fi]), Y, VX, VY)
    G, C = np.empty(S), np.empty(S, dtype=np.int64)
    ground_contact(Y, G, C)
    s = float(np.sum(VX[C, np.arange(S)]))
    return 1.0 if s < 0 else -1.0
