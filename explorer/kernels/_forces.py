"""The forces effect: motor torque, joint reactions and frame forces from solved positions (inverse dynamics).

Model (the contract)
--------------------
The crank turns at the constant speed ω = rpm·2π/60 (rad/s). Coordinates are every vertex's position
(the vertex formulation of seed 000); the constraints are the plan's distance equations
φ = ½(|p_b − p_a|² − d²) (links, then each body's base pair), its attach equations
j − p − (u·I + w·R)(q − p) = 0 (a body joint from its base pair; R the quarter turn), its slide
equations (``_blocks.slide_eval``: a slider's signed distance from its line; the multiplier times the
equation's gradient is its guide's push — the frame's for a ground line, the slotted member's for a
slot — normal to the line: no friction) and, outside the plan, the fixed vertices and the crank tip
(prescribed). Masses enter through a constant mass matrix on those coordinates:

* a link of mass m (a uniform bar) adds m/6·[[2, 1], [1, 2]] on its two ends and m·g/2 of weight
  on each end (exact for a rigid uniform bar: its kinetic energy is m/6·(|ȧ|² + ȧ·ḃ + |ḃ|²));
* a body of mass m, centroid G = p + (ū·I + w̄·R)(q − p) and inertia I_G about G is written on its
  base pair (p, q) in natural coordinates: with g = q − p, J = (I_G + m|G − p|²)/|g|², the
  generalised inertia forces are m·Āᵀ·p̈ + J·g̈ on q and m·a_G minus that on p, the weight
  −m·g·(w̄, ū) on q and −m·g·(−w̄, 1 − ū) on p;
* the crank (a uniform bar from centre to tip) turns at constant speed: it enters only the motor
  torque (its weight's moment) and the bearing force.

Velocities and accelerations come block by block in plan order from the positions (each block's
constraint equations differentiated once and twice: linear solves with the block's Jacobian). The
Lagrange equations Φ_qᵀ·λ = M·q̈ − Q are then solved for the multipliers block by block in *reverse*
plan order (the Jacobian is block-lower-triangular, so its transpose is block-upper-triangular):
each block's own Jacobian transposed, 2x2 for a dyad or a pin–slider (SLIDE) block, the identity for a
body joint. What is left on the fixed vertices is the frame's force on the mechanism; on the crank tip, the crank's force f on
the tip pin, whence the motor torque τ = (tip − c) × f + m_c·g·(tip − c)_x / 2 (positive when the
motor does positive work: along the crank's counter-clockwise turn).

The force member m puts on pin v is f_{m→v} = Σ_{c∈m} (∂c/∂q_v)ᵀ·λ_c − (M^(m)·q̈ − Q^(m))_v; the
frame, the crank and the ground (the load on the contact foot) are members too. A joint's reaction
is the largest of its members' forces (the one that sets the pin's shear).

Walker: the leg is replicated on one crankshaft (``_legs``); the contact foot is the lowest (ties to
the lower leg), as for the walker metrics; the body's mass is ``[operating] load``, its weight W =
load·g, its drag D = drag·W against the walking direction u. Two models (``[operating] body``):

* **held** (the frame still in space): the legs hang from the frame, and the ground pushes the contact
  foot with the walker scene's force F = (u·D, W) alone; the legs' weight and inertia go to the frame
  (the shaking force). Everything is linear in the load, so each sample of the base leg is solved for
  inertia and weight, and, only where some leg reads that sample while it carries the load, for the
  load alone (F as a plain leg carries it, the mirror image (−F_x, F_y) as a mirrored leg does; one
  solve when there is no drag).
* **moving** (the default): the body moves with the planted contact foot p_c (body frame), so its
  acceleration is a_b = −ω²·d²p_c/dθ² (x and y; it does not pitch). The legs are solved in the body's
  frame, which accelerates without turning: effective gravity g − a_b on every member (a d'Alembert
  force −m·a_b). The body itself is carried by the legs: their force on it is m_b·(a_b − g⃗) − drag;
  the ground's force G on the contact foot is whatever makes that so, G = m_b·(a_b − g⃗) − drag −
  Σ_legs (their force on the body with no ground force), i.e. the whole machine's weight, drag and
  momentum change (a leg in equilibrium passes a force on its foot to the frame unchanged). Each sample
  of the base leg is solved for inertia and weight, for a unit body acceleration along x and y, and,
  where some leg reads it while carrying the walker, for a unit ground force along x and y; every leg
  at every angle combines them with its a_b (and G) in its own frame. The shaking force is then the
  legs' force on the body.
  Handovers: a_b is that of the foot carrying the walker at each sample, so it switches between two
  samples (or at a sample where two feet are exactly level, e.g. a plain leg and a mirrored one
  reading the same sample: the lower leg carries, as the walker metrics say). When the contact foot
  changes, the landing foot's velocity relative to the body generally differs from the lifting
  foot's, so the body's velocity jumps: an impact whose impulse the sampled model does not carry (its
  peak force depends on the contact's stiffness; on the nominal Jansen walker the jump is 0.03–0.04
  m/s, some 0.3 % of the energy per turn). Before and after a handover the model is exact; the peaks
  are taken over the samples on either side.

Every leg at every crank angle is read off the base leg's sums: a plain leg at θ + φ_j, a mirrored
leg as the mirror image of the base leg at π − θ − φ_j with the mirrored loads, its torque negated
(it is driven backwards). A phase between two samples is interpolated linearly. The motor torque,
the frame force and the pin reactions are those of the whole walker; the stored joint forces are
leg 0's.
"""

from __future__ import annotations

import math
import types
from collections import namedtuple
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..kinds import eq_attach, eq_distance, eq_slide
from ..mechanism import BODY_MODELS, crank_masses, link_masses
from ..plan import Plan
from ._design import pair_coordinates
from ._kinds_array import reactions_any, reactions_closed, singular_any, singular_closed
from ._legs import contact_stroke, ground_contact, leg_feet, leg_samples

# The kinds' forces code the per-design function calls (``_kinds_array``: each block's singularity
# check and reactions, rendered from the kinds); bound in the specialised copies (:func:`_specialise`),
# so that plans without coupled blocks compile without the general block's solver.
singular = None
reactions = None
#: the base leg at every sample (:func:`_base_leg` specialised, or code generated per topology)
base_leg = None

#: force-effect status codes written to ``code`` (0 ok); the caller turns them into statuses
F_OK, F_SINGULAR, F_NONFINITE = 0, 1, 2
#: a dyad's or a slider's Jacobian with |det| at most this times the sum of its terms' sizes is singular
SINGULAR_TOL = 1e-13
#: A joint's stored reaction is its most heavily loaded member's force on it; members whose forces agree
#: in size to within 1e-9 (the two members of a two-member pin, whose forces are equal and opposite) are
#: a tie, which the first member (in incidence order) wins: rounding does not pick the sign.
PIN_TIE = 1.0 - 1e-9


@dataclass(frozen=True)
class ForceTables:
    """The members as the forces effect reads them (computed once per topology): one *incidence* per
    member and pin.

    inc_vertex (K,) each incidence's vertex; dinc (n_dist, 2) the incidences of each distance
    equation's a and b ends; ainc (n_att, 3) of each attach equation's j, p, q; body_pq (n_bodies, 2)
    base-pair vertices and body_inc (n_bodies, 2) their incidences; tip_inc the crank's incidence at
    the tip; fixed (n_fixed,) and fixed_inc; foot, foot_inc (the ground's incidence at the foot);
    sinc (n_slide, 3) the incidences of each slide equation's guide (the frame, or the slot's member)
    at p, a, b; inc_member (K,) member names, for people: link / body name, "crank", "frame", "ground".
    """

    inc_vertex: np.ndarray
    dinc: np.ndarray
    ainc: np.ndarray
    body_pq: np.ndarray
    body_inc: np.ndarray
    tip: int
    tip_inc: int
    fixed: np.ndarray
    fixed_inc: np.ndarray
    foot: int
    foot_inc: int
    inc_member: tuple
    sinc: np.ndarray


def force_tables(mech, plan: Plan) -> ForceTables:
    """The :class:`ForceTables` of ``mech``'s plan."""
    nl, nb = plan.n_links, len(mech.bodies)
    inc: dict[tuple[str, int], int] = {}

    def incidence(member: str, v: int) -> int:
        return inc.setdefault((member, int(v)), len(inc))

    n_dist = len(plan.link_a)
    dinc = np.empty((n_dist, 2), dtype=np.int64)
    for e in range(n_dist):
        member = mech.links[e].name if e < nl else mech.bodies[e - nl].name
        dinc[e] = incidence(member, plan.link_a[e]), incidence(member, plan.link_b[e])
    ainc = np.empty((len(plan.attach), 3), dtype=np.int64)
    for t, (j, p, q) in enumerate(plan.attach):
        member = mech.bodies[plan.attach_body[t]].name
        ainc[t] = incidence(member, j), incidence(member, p), incidence(member, q)
    body_pq = np.empty((nb, 2), dtype=np.int64)
    body_inc = np.empty((nb, 2), dtype=np.int64)
    for bi, b in enumerate(mech.bodies):
        pq = [mech.vertex_index(b.joints[k]) for k in plan.body_base[bi]]
        body_pq[bi] = pq
        body_inc[bi] = [incidence(b.name, v) for v in pq]
    tip_inc = incidence("crank", plan.tip)
    fixed = np.asarray(plan.fixed, dtype=np.int64)
    fixed_inc = np.array([incidence("frame", v) for v in fixed], dtype=np.int64)
    foot = mech.vertex_index(mech.foot)
    foot_inc = incidence("ground", foot)
    sinc = np.full((len(plan.slide), 3), -1, dtype=np.int64)
    for k, (si, pab) in enumerate(zip(plan.slide_slider, plan.slide)):
        sl = mech.sliders[si]
        if sl.ground:  # the guide is the frame
            sinc[k, 0] = incidence("frame", pab[0])
            continue
        pair = frozenset(sl.line)
        member = next((lk.name for lk in mech.links if frozenset((lk.a, lk.b)) == pair), None) \
            or next(b.name for b in mech.bodies if pair <= set(b.joints))
        sinc[k] = [incidence(member, v) for v in pab]
    return ForceTables(np.array([v for _, v in inc], dtype=np.int64), dinc, ainc, body_pq, body_inc, int(plan.tip),
                       tip_inc, fixed, fixed_inc, foot, foot_inc, tuple(m for m, _ in inc), sinc)


ForceModel = namedtuple("ForceModel", [
    # shared by every variant of a call (the forces effect's named inputs)
    "inc_vertex", "dinc", "ainc", "body_pq", "body_inc", "tip_inc", "fixed", "fixed_inc", "foot", "foot_inc",
    "sinc",       # the incidences (:class:`ForceTables`)
    "body_mass",  # (nb,) kg
    "sel",        # (n_sel,) the joints whose reactions are stored (leg 0's)
    "base", "frac", "sign", "mirrored",  # the walker's legs (``_legs.leg_samples``)
    "drag",       # the drag, a fraction of the load's weight
    "unit",       # m per model unit
    "omega",      # rad/s
    "gravity",    # m/s²
    "weight",     # N, the load's weight
    "moving",     # bool, the moving-body model (else the frame held)
    "load_mass",  # kg, the walker's body
    "out_idx",    # (n_out,) the vertices whose rows a caller stores
])

ForceRows = namedtuple("ForceRows", [
    # per variant (N rows): inputs
    "link_mass",  # (N, n_links) kg
    "body_cuv",   # (N, nb, 2) each body's centroid in its base pair's coordinates
    "body_J",     # (N, nb) kg, each body's base-pair inertia (see the module)
    "crank_mass", # (N,) kg
    # outputs
    "torque",     # (N, S) N·m, the walker's motor torque
    "fsel",       # (N, S, n_sel, 2) N, leg 0's reaction at each joint of ``sel``
    "finc",       # (N, S or 0, K, 2) N, leg 0's force of every member on every pin (when asked for)
    "pin_peak",   # (N, n_vertices) N
    "shake",      # (N,) N
    "travel",     # (N,) model units per turn
    "code", "sample", "block",  # (N,) F_OK / F_SINGULAR / F_NONFINITE, where
    "body_acc",   # (N, S, 2) m/s²
    "ground",     # (N, S, 2) N
    "contact",    # (N, S) the contact leg
])

ForceScratch = namedtuple("ForceScratch", [
    "pos", "vel", "acc",  # (S, n_vertices, 2) the design's every vertex, stored by the sweep
    "Pu",                 # (n_vertices, 2) one sample's positions
    "R",                  # (nr, n_vertices, 2) the loads, one per right-hand side
    "Rc", "Fc",           # (nr, n_vertices, 2), (nr, K, 2) the loads and incidence forces that are the same
                          # at every sample (right-hand sides 1 …)
    "Fi", "tau", "frame",  # (S, nr, K, 2), (S, nr), (S, nr, 2) the base leg's, per sample and right-hand side
    "act",                # (nr,) bool, the right-hand sides solved at a sample
    "lam_d", "lam_a", "lam_s",  # (nr, n_dist), (nr, n_att, 2), (nr, n_slide) the multipliers
    "loc", "M", "x",      # a coupled block's scratch
    "Y", "VX", "VY",      # (L, S) every leg's foot
    "G", "C",             # (S,) the ground, the contact leg
    "fm",                 # (K,)
    "vis_free", "vis_plain", "vis_mirr",  # (S,) bool
    "pk",                 # (K,) each incidence's running peak of its squared force
    "Gl",                 # (L, 2K) each leg's incidence forces at one base-leg sample
    "link6", "linkg",     # (n_dist,) each link's mass / 6 and half its weight (the first n_links)
])


@njit(cache=True, nogil=True)
def force_scratch(S, nv, fm, topo):
    """A kernel's :class:`ForceScratch` for S samples of a mechanism of nv vertices (``fm``: the
    :class:`ForceModel`; ``topo``: the lowered plan, for the equations' counts and the largest coupled
    block). The per-sample sums start at zero: without a load only the first right-hand side is ever
    written, and the others are read with weight 0 (0 × uninitialised memory could be NaN)."""
    K = fm.inc_vertex.shape[0]
    nr = 5 if fm.moving else 3
    m = 2
    for g in range(topo.gen_vptr.shape[0] - 1):
        m = max(m, 2 * (topo.gen_vptr[g + 1] - topo.gen_vptr[g]))
    L = fm.base.shape[0]
    return ForceScratch(np.empty((S, nv, 2)), np.empty((S, nv, 2)), np.empty((S, nv, 2)), np.empty((nv, 2)),
                        np.zeros((nr, nv, 2)), np.zeros((nr, nv, 2)), np.zeros((nr, K, 2)), np.zeros((S, nr, K, 2)),
                        np.zeros((S, nr)),
                        np.zeros((S, nr, 2)), np.zeros(nr, dtype=np.bool_), np.zeros((nr, topo.dist_a.shape[0])),
                        np.zeros((nr, topo.att_vpq.shape[0], 2)), np.zeros((nr, topo.slide.shape[0])),
                        np.full(nv, -1, dtype=np.int64), np.empty((m, m)), np.empty(m), np.empty((L, S)),
                        np.empty((L, S)), np.empty((L, S)), np.empty(S), np.empty(S, dtype=np.int64), np.empty(K),
                        np.empty(S, dtype=np.bool_), np.empty(S, dtype=np.bool_), np.empty(S, dtype=np.bool_),
                        np.empty(K), np.empty((L, 2 * K)), np.empty(topo.dist_a.shape[0]),
                        np.empty(topo.dist_a.shape[0]))


@njit(cache=True, nogil=True, inline="always")
def _reads(sg, b, k, S):
    """The base-leg samples (u0, u0 + 1 mod S) that a leg (``_legs.leg_samples``: sign sg, base b) reads
    at sample k: (sg·k + b) mod S, which lies in (−S, 2S), by a comparison instead of a division."""
    u0 = sg * k + b
    if u0 >= S:
        u0 -= S
    elif u0 < 0:
        u0 += S
    u1 = u0 + 1
    if u1 == S:
        u1 = 0
    return u0, u1


@njit(cache=True, nogil=True, inline="always")
def _body_load(R, Fu, r, p, q, ip, iq, dpx, dpy, dqx, dqy):
    """A body's generalised load (dpx, dpy) on its base vertex p and (dqx, dqy) on q: into R[r], and,
    negated, into the body's incidence forces Fu[r] at p (ip) and q (iq)."""
    R[r, p, 0] += dpx
    R[r, p, 1] += dpy
    R[r, q, 0] += dqx
    R[r, q, 1] += dqy
    Fu[r, ip, 0] -= dpx
    Fu[r, ip, 1] -= dpy
    Fu[r, iq, 0] -= dqx
    Fu[r, iq, 1] -= dqy


@njit(cache=True, nogil=True, inline="always")
def active(u, Fu, fs, nrhs, moving, Fx, weightless):
    """Which right-hand sides the base leg's sample u solves (``fs.act``): only what some leg reads (the
    others' torque, frame force and incidence forces (Fu (nr, K, 2): ``fs.Fi[u]``) set to zero); returns whether right-hand side 2 is right-hand side 1's copy (held, no drag,
    read loaded by a plain and a mirrored leg)."""
    tau = fs.tau
    frame = fs.frame
    act = fs.act
    K = Fu.shape[1]
    copy21 = False
    for rhs in range(act.shape[0]):
        act[rhs] = False
    for rhs in range(nrhs):
        if not moving and rhs == 2 and fs.vis_plain[u] and fs.vis_mirr[u] and Fx == 0.0:  # the same load either way
            copy21 = True
        elif (not moving and ((rhs == 1 and not fs.vis_plain[u]) or (rhs == 2 and not fs.vis_mirr[u]))) or \
                (rhs >= 3 and not (fs.vis_plain[u] or fs.vis_mirr[u])) or \
                (moving and rhs <= 2 and rhs >= 1 and weightless):  # only what some leg reads: zeros
            tau[u, rhs] = 0.0
            frame[u, rhs, 0] = 0.0
            frame[u, rhs, 1] = 0.0
            for kk in range(K):
                Fu[rhs, kk, 0] = 0.0
                Fu[rhs, kk, 1] = 0.0
        else:
            act[rhs] = True
    return copy21


@njit(cache=True, nogil=True, inline="always")
def copy_21(u, Fu, fs):
    """Right-hand side 2 of the base leg's sample u made a copy of right-hand side 1 (see :func:`active`;
    Fu: its incidence forces)."""
    tau = fs.tau
    frame = fs.frame
    tau[u, 2] = tau[u, 1]
    frame[u, 2, 0] = frame[u, 1, 0]
    frame[u, 2, 1] = frame[u, 1, 1]
    for kk in range(Fu.shape[1]):
        Fu[2, kk, 0] = Fu[1, kk, 0]
        Fu[2, kk, 1] = Fu[1, kk, 1]


@njit(cache=True, nogil=True, inline="always")
def _held_peaks(u, Fu, fs):
    """The held walker's running peaks fs.pk (K,) (squared) after the base leg's sample u (Fu (nr, K, 2)) in
    each state some leg reads it in (free, carrying as a plain leg, as a mirrored one: ``fs.vis_*``).
    Returns whether every peak is still finite."""
    pk = fs.pk
    for st_ in range(3):
        # the weights of right-hand sides 1 (loaded, plain) and 2 (loaded, mirrored)
        if st_ == 0:
            if not fs.vis_free[u]:
                continue
            lx = 0.0
            ly = 0.0
        elif st_ == 1:
            if not fs.vis_plain[u]:
                continue
            lx = 1.0
            ly = 0.0
        else:
            if not fs.vis_mirr[u]:
                continue
            lx = 0.0
            ly = 1.0
        for kk in range(pk.shape[0]):
            fx = Fu[0, kk, 0]
            fy = Fu[0, kk, 1]
            if st_ > 0:
                fx += lx * Fu[1, kk, 0] + ly * Fu[2, kk, 0]
                fy += lx * Fu[1, kk, 1] + ly * Fu[2, kk, 1]
            pk[kk] = _peak(pk[kk], fx * fx + fy * fy)  # squared: one square root per joint at the end
    return _finite(pk)


def _design_forces(i, table, topo, uv, sd, cx, cy, fm, fr, fs):
    """The forces effect of design i (an ok sweep, every vertex's samples in fs.pos, fs.vel, fs.acc:
    (S, n_vertices, 2), per radian and per radian²): the walker's motor torque, every pin's peak
    reaction, the shaking force, travel, and leg 0's reactions at the selected joints (and every
    member's when ``fr.finc`` has samples), into row i of ``fr`` (:class:`ForceRows`); table: its
    block table; topo: the lowered plan; uv, sd: its attach and slide numbers; (cx, cy): its crank
    centre; fm: :class:`ForceModel`; fs: :class:`ForceScratch`. Its code is F_SINGULAR (with the
    sample and block) where a block's Jacobian is singular at a sample, F_NONFINITE where forces
    overflow."""
    nrhs, Fx, Fy, walk, weightless, grid = _forces_setup(i, fm, fr, fs, topo)
    blk, u = base_leg(i, table, topo, uv, sd, cx, cy, fm, fr, fs, nrhs, Fx, weightless)
    if blk >= 0:  # a Jacobian singular at sample u: its reactions are unbounded
        fr.code[i] = F_SINGULAR
        fr.sample[i] = u
        fr.block[i] = blk
        return
    _forces_legs(i, fm, fr, fs, nrhs, Fx, Fy, walk, grid)


@njit(cache=True, nogil=True)
def _forces_setup(i, fm, fr, fs, topo):
    """:func:`_design_forces` before the base leg's samples: design i's travel, the contact leg at every
    sample, the samples some leg reads while carrying the load (``fs.vis_*``), each link's m/6 and half
    weight (``fs.link6``, ``fs.linkg``) and the right-hand sides whose loads do not change with the sample
    (``fs.Rc``, ``fs.Fc``). Returns (nrhs: the right-hand sides solved, Fx, Fy: the load on the foot as a
    plain leg carries it (held), walk: the walking direction ±1 or 0, weightless: no member has mass,
    grid: every leg reads whole samples)."""
    pos = fs.pos
    S = pos.shape[0]
    nv = pos.shape[1]
    K = fm.inc_vertex.shape[0]
    nl = fr.link_mass.shape[1]
    nb = fm.body_pq.shape[0]
    L = fm.base.shape[0]
    dist_a = topo.dist_a
    dist_b = topo.dist_b
    foot = fm.foot
    moving = fm.moving
    weight = fm.weight
    gravity = fm.gravity
    base = fm.base
    frac = fm.frac
    sign = fm.sign
    mirrored = fm.mirrored
    vis_free = fs.vis_free
    vis_plain = fs.vis_plain
    vis_mirr = fs.vis_mirr
    fr.code[i] = F_OK
    fr.sample[i] = -1
    fr.block[i] = -1
    grid = True
    for j in range(L):
        if frac[j] != 0.0:
            grid = False
    d = 2.0 * math.pi / S
    nrhs = 5 if moving else 3 if weight > 0.0 else 1
    mc = fr.crank_mass[i]
    weightless = mc == 0.0  # no member has mass: a body acceleration loads nothing (moving)
    for e in range(nl):
        if fr.link_mass[i, e] != 0.0:
            weightless = False
    for bi in range(nb):
        if fm.body_mass[bi] != 0.0:
            weightless = False
    # -- which leg carries the load at each sample (the walker scene's contact convention) -----
    Y = fs.Y
    VX = fs.VX
    C = fs.C
    leg_feet(base, frac, sign, mirrored, pos[:, foot, :], fs.vel[:, foot, :], Y, VX, fs.VY)
    ground_contact(Y, fs.G, C)
    sum_vx, _ = contact_stroke(VX, C)  # exactly 0 for a walker that does not travel
    fr.travel[i] = abs(d * sum_vx)
    walk = 0.0
    if sum_vx < 0.0:
        walk = 1.0
    elif sum_vx > 0.0:
        walk = -1.0
    Fx = walk * fm.drag * weight
    Fy = weight
    # which samples of the base leg some leg reads while it carries the load (only those need the
    # unit-force right-hand sides), and in which states every sample is read: free, loaded plain,
    # loaded mirrored
    for u in range(S):
        vis_free[u] = False
        vis_plain[u] = False
        vis_mirr[u] = False
    for k in range(S):
        for j in range(L):
            u0, u1 = _reads(sign[j], base[j], k, S)
            loaded = C[k] == j and nrhs >= 3
            for uu in range(2):
                if uu == 1 and frac[j] == 0.0:
                    break
                ux = u0 if uu == 0 else u1
                if not loaded:
                    vis_free[ux] = True
                elif mirrored[j]:
                    vis_mirr[ux] = True
                else:
                    vis_plain[ux] = True
    # -- the right-hand sides whose loads do not change with the sample, built once (Rc, Fc): moving, a
    # unit acceleration of the body along x (1), along y (2), a unit force of the ground on the foot along
    # x (3), along y (4); held, the load on the foot as a plain leg (1) and as a mirrored one (2) carries it
    Rc = fs.Rc
    Fc = fs.Fc
    link6 = fs.link6
    linkg = fs.linkg
    for e in range(nl):  # each link's inertia m/6 (on its ends: m/6·(2a + b), m/6·(a + 2b)) and half weight
        me = fr.link_mass[i, e]
        link6[e] = me / 6.0
        linkg[e] = 0.5 * me * gravity
    for rhs in range(1, nrhs):
        for v in range(nv):
            Rc[rhs, v, 0] = 0.0
            Rc[rhs, v, 1] = 0.0
        for kk in range(K):
            Fc[rhs, kk, 0] = 0.0
            Fc[rhs, kk, 1] = 0.0
        if moving and rhs <= 2:  # a unit acceleration of the body along x (1) or y (2): in its
            # frame every member's mass × it (the d'Alembert force of the frame's acceleration)
            ax = rhs - 1
            for e in range(nl):
                me = fr.link_mass[i, e]
                if me > 0.0:
                    Rc[rhs, dist_a[e], ax] += 0.5 * me
                    Rc[rhs, dist_b[e], ax] += 0.5 * me
                    Fc[rhs, fm.dinc[e, 0], ax] -= 0.5 * me
                    Fc[rhs, fm.dinc[e, 1], ax] -= 0.5 * me
            for bi in range(nb):
                mb = fm.body_mass[bi]
                if mb > 0.0:  # a uniform acceleration a of the base pair: m·Āᵀa on q, m·a minus that on p
                    p = fm.body_pq[bi, 0]
                    q = fm.body_pq[bi, 1]
                    ub = fr.body_cuv[i, bi, 0]
                    wb = fr.body_cuv[i, bi, 1]
                    fqx = mb * (ub if ax == 0 else wb)
                    fqy = mb * (-wb if ax == 0 else ub)
                    fpx = (mb if ax == 0 else 0.0) - fqx
                    fpy = (mb if ax == 1 else 0.0) - fqy
                    _body_load(Rc, Fc, rhs, p, q, fm.body_inc[bi, 0], fm.body_inc[bi, 1], fpx, fpy, fqx, fqy)
        elif moving:  # a unit force of the ground on the foot along x (3) or y (4)
            Rc[rhs, foot, rhs - 3] -= 1.0
            Fc[rhs, fm.foot_inc, rhs - 3] += 1.0
        else:  # the load on the foot from the ground, as a plain leg (1) or a mirrored one (2) carries it
            ex = Fx if rhs == 1 else -Fx
            Rc[rhs, foot, 0] -= ex
            Rc[rhs, foot, 1] -= Fy
            Fc[rhs, fm.foot_inc, 0] += ex
            Fc[rhs, fm.foot_inc, 1] += Fy
    return nrhs, Fx, Fy, walk, weightless, grid


def _base_leg(i, table, topo, uv, sd, cx, cy, fm, fr, fs, nrhs, Fx, weightless):
    """The base leg of design i at every sample, table-driven (any plan; the kinds' forces code bound as
    ``singular`` and ``reactions``): every right-hand side's incidence forces ``fs.Fi``, torque ``fs.tau``
    and frame force ``fs.frame`` (S, nr, ...) from the sweep's positions and accelerations (``fs.pos``,
    ``fs.acc``), the loads of :func:`_forces_setup`. Returns (block, sample) of the first singular
    Jacobian, or (−1, −1). The code generated per topology (``_forces_scalar``) does the same in scalars."""
    pos = fs.pos
    A = fs.acc
    S = pos.shape[0]
    nv = pos.shape[1]
    K = fm.inc_vertex.shape[0]
    nl = fr.link_mass.shape[1]
    nb = fm.body_pq.shape[0]
    dist_a = topo.dist_a
    dist_b = topo.dist_b
    tip = topo.tip
    moving = fm.moving
    gravity = fm.gravity
    unit = fm.unit
    omega = fm.omega
    Pu = fs.Pu
    R = fs.R
    Fi = fs.Fi
    tau = fs.tau
    frame = fs.frame
    act = fs.act
    nr = R.shape[0]
    Rc = fs.Rc
    Fc = fs.Fc
    lam_d = fs.lam_d
    link6 = fs.link6
    linkg = fs.linkg
    s2 = unit * omega * omega
    mc = fr.crank_mass[i]
    # -- the base leg at every sample: every right-hand side at once (each block's inverse taken once) --
    # held: inertia and weight, the load as a plain leg carries it, as a mirrored one does; moving:
    # inertia and weight, a unit acceleration of the body along x, along y, a unit force of the ground
    # on the foot along x, along y. The incidence forces are written in place, Fu = Fi[u].
    for u in range(S):
        tx = pos[u, tip, 0] - cx
        ty = pos[u, tip, 1] - cy
        for v in range(nv):
            Pu[v, 0] = pos[u, v, 0]
            Pu[v, 1] = pos[u, v, 1]
        # a Jacobian singular at a sample: its reactions are unbounded
        blk = singular(table, topo, uv, sd, Pu, fs.loc, fs.M, fs.x, SINGULAR_TOL)
        if blk >= 0:
            return blk, u
        Fu = Fi[u]
        copy21 = active(u, Fu, fs, nrhs, moving, Fx, weightless)
        for rhs in range(1, nr):
            if act[rhs]:
                for v in range(nv):
                    R[rhs, v, 0] = Rc[rhs, v, 0]
                    R[rhs, v, 1] = Rc[rhs, v, 1]
                for kk in range(K):
                    Fu[rhs, kk, 0] = Fc[rhs, kk, 0]
                    Fu[rhs, kk, 1] = Fc[rhs, kk, 1]
        if act[0]:  # inertia and weight
            for v in range(nv):
                R[0, v, 0] = 0.0
                R[0, v, 1] = 0.0
            for kk in range(K):
                Fu[0, kk, 0] = 0.0
                Fu[0, kk, 1] = 0.0
            for e in range(nl):
                if fr.link_mass[i, e] > 0.0:
                    a = dist_a[e]
                    b = dist_b[e]
                    ia = fm.dinc[e, 0]
                    ib = fm.dinc[e, 1]
                    m6 = link6[e]
                    aa = A[u, a, 0] * s2
                    ab = A[u, b, 0] * s2
                    da = m6 * (2.0 * aa + ab)
                    db = m6 * (aa + 2.0 * ab)
                    R[0, a, 0] += da
                    R[0, b, 0] += db
                    Fu[0, ia, 0] -= da
                    Fu[0, ib, 0] -= db
                    aa = A[u, a, 1] * s2
                    ab = A[u, b, 1] * s2
                    da = m6 * (2.0 * aa + ab) + linkg[e]
                    db = m6 * (aa + 2.0 * ab) + linkg[e]
                    R[0, a, 1] += da
                    R[0, b, 1] += db
                    Fu[0, ia, 1] -= da
                    Fu[0, ib, 1] -= db
            for bi in range(nb):
                mb = fm.body_mass[bi]
                Jb = fr.body_J[i, bi]
                if mb > 0.0 or Jb > 0.0:
                    p = fm.body_pq[bi, 0]
                    q = fm.body_pq[bi, 1]
                    ub = fr.body_cuv[i, bi, 0]
                    wb = fr.body_cuv[i, bi, 1]
                    apx = A[u, p, 0] * s2
                    apy = A[u, p, 1] * s2
                    agx = A[u, q, 0] * s2 - apx
                    agy = A[u, q, 1] * s2 - apy
                    aGx = apx + ub * agx - wb * agy
                    aGy = apy + ub * agy + wb * agx
                    fqx = mb * (ub * apx + wb * apy) + Jb * agx
                    fqy = mb * (-wb * apx + ub * apy) + Jb * agy
                    fpx = mb * aGx - fqx
                    fpy = mb * aGy - fqy
                    dqx = fqx + mb * gravity * wb
                    dqy = fqy + mb * gravity * ub
                    dpx = fpx - mb * gravity * wb
                    dpy = fpy + mb * gravity * (1.0 - ub)
                    _body_load(R, Fu, 0, p, q, fm.body_inc[bi, 0], fm.body_inc[bi, 1], dpx, dpy, dqx, dqy)
        blk = reactions(table, topo, uv, sd, Pu, R, act, lam_d, fs.lam_a, fs.lam_s, fs.loc, fs.M, fs.x)
        if blk >= 0:
            return blk, u
        # every row's pull on its member's pins, (∂c/∂q_v)ᵀ λ, by its equation type, equation by equation
        # (its numbers read once) for every right-hand side
        for e in range(dist_a.shape[0]):
            ia = fm.dinc[e, 0]
            ib = fm.dinc[e, 1]
            for rhs in range(nr):
                if act[rhs]:
                    eq_distance.pull(Pu, e, dist_a, dist_b, lam_d[rhs, e], Fu, rhs, ia, ib)
        for t in range(topo.att_vpq.shape[0]):
            for rhs in range(nr):
                if act[rhs]:
                    eq_attach.pull(t, uv, fs.lam_a[rhs, t, 0], fs.lam_a[rhs, t, 1], Fu, rhs, fm.ainc[t, 0],
                                   fm.ainc[t, 1], fm.ainc[t, 2])
        for s in range(topo.slide.shape[0]):  # a slider's guide pushes normal to its line, no friction
            for rhs in range(nr):
                if act[rhs]:
                    eq_slide.pull(Pu, s, topo.slide, sd, fs.lam_s[rhs, s], Fu, rhs, fm.sinc)
        for rhs in range(nr):
            if not act[rhs]:
                continue
            Fu[rhs, fm.tip_inc, 0] += R[rhs, tip, 0]
            Fu[rhs, fm.tip_inc, 1] += R[rhs, tip, 1]
            bx = R[rhs, tip, 0]
            by = R[rhs, tip, 1]
            t_ = (tx * R[rhs, tip, 1] - ty * R[rhs, tip, 0]) * unit
            if rhs == 0:
                t_ += mc * gravity * tx * unit * 0.5
                bx += -mc * omega * omega * unit * tx * 0.5
                by += -mc * omega * omega * unit * ty * 0.5 + mc * gravity
            elif moving and rhs == 1:  # the crank's share of a unit body acceleration along x, then y
                t_ -= mc * ty * unit * 0.5
                bx += mc
            elif moving and rhs == 2:
                t_ += mc * tx * unit * 0.5
                by += mc
            tau[u, rhs] = t_
            frame[u, rhs, 0] = -bx
            frame[u, rhs, 1] = -by
            for f in range(fm.fixed.shape[0]):
                Fu[rhs, fm.fixed_inc[f], 0] += R[rhs, fm.fixed[f], 0]
                Fu[rhs, fm.fixed_inc[f], 1] += R[rhs, fm.fixed[f], 1]
                frame[u, rhs, 0] -= R[rhs, fm.fixed[f], 0]
                frame[u, rhs, 1] -= R[rhs, fm.fixed[f], 1]
        if copy21:
            copy_21(u, Fu, fs)
    return -1, -1


@njit(cache=True, nogil=True)
def _forces_legs(i, fm, fr, fs, nrhs, Fx, Fy, walk, grid):
    """:func:`_design_forces` after the base leg's samples: every leg at every crank angle read off them
    (``_moving_legs`` or ``_held_legs``), into row i of ``fr``; arguments as :func:`_forces_setup` returns."""
    S = fs.pos.shape[0]
    C = fs.C
    Fi = fs.Fi
    tau = fs.tau
    frame = fs.frame
    base = fm.base
    frac = fm.frac
    sign = fm.sign
    mirrored = fm.mirrored
    gravity = fm.gravity
    weight = fm.weight
    s2 = fm.unit * fm.omega * fm.omega  # per radian² of crank, model units → m/s²
    for k in range(S):
        fr.contact[i, k] = C[k]
    if fm.moving:  # the body moves with the contact foot: every leg at every angle, its ground force
        first_bad = _moving_legs(i, fs.acc, C, fm.foot, base, frac, sign, mirrored, fm.inc_vertex, fm.sel, Fi, tau, frame, s2,
                                 fm.load_mass, gravity, walk * fm.drag * weight, fr.torque, fr.fsel, fr.finc,
                                 fr.pin_peak, fr.shake, fr.body_acc, fr.ground, fs.fm, fs.pk, fs.Gl)
    else:  # held: the frame still, the load on the contact foot
        first_bad = _held_legs(i, C, base, frac, sign, mirrored, fm.inc_vertex, fm.sel, Fi, tau, frame, nrhs, Fx, Fy,
                               grid, fr.torque, fr.fsel, fr.finc, fr.pin_peak, fr.shake, fr.body_acc, fr.ground, fs.fm,
                               fs)
    if first_bad >= 0:  # forces that overflowed: a near-singular sample
        fr.code[i] = F_NONFINITE
        fr.sample[i] = first_bad


@njit(cache=True, nogil=True, inline="always")
def _peak(m, mag2):
    """The running peak ``m`` of a squared force after ``mag2``: the larger, NaN once either is NaN (so
    that a non-finite force is seen at the end of its sample, whatever the legs after it read)."""
    return mag2 if m == m and not (mag2 <= m) else m


@njit(cache=True, nogil=True)
def _finite(pk):
    """Whether every running peak is finite."""
    n = 0
    for kk in range(pk.shape[0]):
        n += pk[kk] < math.inf
    return n == pk.shape[0]


@njit(cache=True, nogil=True)
def _pin_peaks(pk, inc_vertex, out):
    """Each vertex's peak reaction out (n_vertices,), N: the square root of the largest squared peak pk
    (K,) of its incidences (0 for a vertex without one)."""
    for v in range(out.shape[0]):
        out[v] = 0.0
    for kk in range(pk.shape[0]):
        v = inc_vertex[kk]
        if not (pk[kk] <= out[v]):
            out[v] = pk[kk]
    for v in range(out.shape[0]):
        out[v] = math.sqrt(out[v])


@njit(cache=True, nogil=True)
def _held_legs(i, C, base, frac, sign, mirrored, inc_vertex, sel, Fi, tau, frame, nrhs, Fx, Fy, grid, torque, fsel,
               finc, pin_peak, shake_peak, body_acc, ground, fm, fs):
    """The held walker of variant i (the frame still), read off the base leg's right-hand sides
    (inertia and weight; the load as a plain leg and as a mirrored leg carries it: Fi (S, 3, K, 2),
    tau (S, 3), frame (S, 3, 2)) at the samples each leg reads (contact legs C (S,); ``vis_*``: the
    states each sample is read in; ``grid``: every leg reads whole samples). Writes torque[i],
    pin_peak[i], shake_peak[i], fsel[i] / finc[i] (leg 0), body_acc[i] (zero) and ground[i] (the
    load's weight and drag, (Fx, Fy)); returns the first sample with a non-finite force or −1. fs: the
    :class:`ForceScratch` (its states each sample is read in, ``vis_*``, and the peaks' scratch ``pk``)."""
    S = C.shape[0]
    L = base.shape[0]
    K = inc_vertex.shape[0]
    nv = pin_peak.shape[1]
    for k in range(S):  # held: the frame still, the load on the contact foot
        body_acc[i, k, 0] = 0.0
        body_acc[i, k, 1] = 0.0
        ground[i, k, 0] = Fx
        ground[i, k, 1] = Fy
    # -- every leg at every crank angle --------------------------------------------------------
    for v in range(nv):
        pin_peak[i, v] = 0.0
    first_bad = -1
    if grid:  # each leg reads whole samples: every pin's peak over the states each sample is read in
        for kk in range(K):
            fs.pk[kk] = 0.0
        for u in range(S):
            if not _held_peaks(u, Fi[u], fs) and first_bad < 0:  # a force not finite here (the peaks keep it)
                first_bad = u
        _pin_peaks(fs.pk, inc_vertex, pin_peak[i])
    shake = 0.0
    for k in range(S):
        ttot = 0.0
        frx = 0.0
        fry = 0.0
        for j in range(L):
            f = frac[j]
            u0, u1 = _reads(sign[j], base[j], k, S)
            w0 = 1.0 - f
            lx = 0.0
            ly = 0.0
            if C[k] == j and nrhs == 3:  # this leg carries the load: right-hand side 2 if mirrored, else 1
                if mirrored[j]:
                    ly = 1.0
                else:
                    lx = 1.0
            tj = w0 * (tau[u0, 0] + lx * tau[u0, 1] + ly * tau[u0, 2])
            fjx = w0 * (frame[u0, 0, 0] + lx * frame[u0, 1, 0] + ly * frame[u0, 2, 0])
            fjy = w0 * (frame[u0, 0, 1] + lx * frame[u0, 1, 1] + ly * frame[u0, 2, 1])
            if f != 0.0:
                tj += f * (tau[u1, 0] + lx * tau[u1, 1] + ly * tau[u1, 2])
                fjx += f * (frame[u1, 0, 0] + lx * frame[u1, 1, 0] + ly * frame[u1, 2, 0])
                fjy += f * (frame[u1, 0, 1] + lx * frame[u1, 1, 1] + ly * frame[u1, 2, 1])
            if mirrored[j]:
                ttot -= tj
                frx -= fjx
            else:
                ttot += tj
                frx += fjx
            fry += fjy
            if grid and not (j == 0 and (sel.shape[0] > 0 or finc.shape[1] > 0)):
                continue
            for kk in range(K):
                fx = w0 * (Fi[u0, 0, kk, 0] + lx * Fi[u0, 1, kk, 0] + ly * Fi[u0, 2, kk, 0])
                fy = w0 * (Fi[u0, 0, kk, 1] + lx * Fi[u0, 1, kk, 1] + ly * Fi[u0, 2, kk, 1])
                if f != 0.0:
                    fx += f * (Fi[u1, 0, kk, 0] + lx * Fi[u1, 1, kk, 0] + ly * Fi[u1, 2, kk, 0])
                    fy += f * (Fi[u1, 0, kk, 1] + lx * Fi[u1, 1, kk, 1] + ly * Fi[u1, 2, kk, 1])
                mag = math.sqrt(fx * fx + fy * fy)
                fm[kk] = mag
                v = inc_vertex[kk]
                if not math.isfinite(mag) and first_bad < 0:
                    first_bad = k
                if not grid and not (mag <= pin_peak[i, v]):
                    pin_peak[i, v] = mag
                if j == 0 and finc.shape[1] > 0:
                    finc[i, k, kk, 0] = -fx if mirrored[0] else fx
                    finc[i, k, kk, 1] = fy
                if j == 0:
                    for s_ in range(sel.shape[0]):
                        if sel[s_] == v:
                            # the member that loads this pin most, at this sample
                            best = True
                            for k2 in range(kk):
                                if inc_vertex[k2] == v and fm[k2] >= PIN_TIE * mag:
                                    best = False
                            if best:
                                fsel[i, k, s_, 0] = -fx if mirrored[0] else fx
                                fsel[i, k, s_, 1] = fy
        torque[i, k] = ttot
        sh = math.sqrt(frx * frx + fry * fry)
        if not (sh <= shake):
            shake = sh
    shake_peak[i] = shake
    for k in range(S):
        if not math.isfinite(torque[i, k]) and first_bad < 0:
            first_bad = k
    if first_bad < 0 and not math.isfinite(shake):
        first_bad = 0
    return first_bad


@njit(cache=True, nogil=True)
def _moving_legs(i, A, C, foot, base, frac, sign, mirrored, inc_vertex, sel, Fi, tau, frame, s2, load_mass, gravity,
                 drag_force, torque, fsel, finc, pin_peak, shake_peak, body_acc, ground, fm, pk, G):
    """The moving-body walker of variant i, read off the base leg's five right-hand sides (inertia and
    weight; a unit body acceleration along x, y; a unit ground force on the foot along x, y: Fi (S, 5,
    K, 2), tau (S, 5), frame (S, 5, 2)) and its accelerations A (S, nv, 2) per radian², contact legs
    C (S,). At each crank sample k: the body's acceleration a_b = −ω²·d²p_c/dθ² (s2 = ω²·unit) of
    the contact foot p_c (the walker's frame; a mirrored leg's x reflected); the ground's force G on
    the contact foot from the body's balance, legs' force on the body = m_b·(a_b − g) − drag
    (drag_force = the ground's share of the drag, +x when walking towards +x): the legs' force on the
    body under a unit foot force is that force (the leg is in equilibrium), so G = m_b·(a_b − g) −
    drag − Σ_legs (their force on the body with no ground force); then every leg with a_b (and G on the
    contact leg) in its own frame. Writes torque[i], pin_peak[i], shake_peak[i], fsel[i] / finc[i]
    (leg 0), body_acc[i] (m/s²) and ground[i] (N); returns the first sample with a non-finite force or −1.

    Where every leg reads whole samples, the pins' peaks are taken base-leg sample by sample
    (:func:`_moving_peaks`) after the walk; a non-finite force there has the walk taken again, sample
    by sample with every leg's pins, for the sample it appears at. pk (K,), G (L, 2K): scratch."""
    grid = True
    for j in range(frac.shape[0]):
        if frac[j] != 0.0:
            grid = False
    first_bad = _moving_walk(i, A, C, foot, base, frac, sign, mirrored, inc_vertex, sel, Fi, tau, frame, s2, load_mass,
                             gravity, drag_force, torque, fsel, finc, shake_peak, body_acc, ground, fm, pk, not grid)
    if grid:
        _moving_peaks(C, base, sign, mirrored, Fi, body_acc[i], ground[i], pk, G)
        if not _finite(pk):
            first_bad = _moving_walk(i, A, C, foot, base, frac, sign, mirrored, inc_vertex, sel, Fi, tau, frame, s2,
                                     load_mass, gravity, drag_force, torque, fsel, finc, shake_peak, body_acc, ground,
                                     fm, pk, True)
    _pin_peaks(pk, inc_vertex, pin_peak[i])
    return first_bad


@njit(cache=True, nogil=True)
def _moving_peaks(C, base, sign, mirrored, Fi, body_acc, ground, pk, G):
    """Every incidence's largest squared force over the legs and the turn, pk (K,), the legs reading
    whole samples: base-leg sample u by sample, each leg j at the crank sample k it reads u at, with
    that sample's body acceleration body_acc[k] (S, 2) and, on the contact leg (C (S,)), the ground's
    force ground[k] (S, 2), as :func:`_moving_walk` combines them (the same arithmetic; the peaks, a
    maximum, do not depend on the order). G (L, 2K): scratch, each leg's forces at u."""
    S = C.shape[0]
    L = base.shape[0]
    K = pk.shape[0]
    Ff = Fi.reshape((S, Fi.shape[1], 2 * K))
    for kk in range(K):
        pk[kk] = 0.0
    for u in range(S):
        F0 = Ff[u, 0]
        F1 = Ff[u, 1]
        F2 = Ff[u, 2]
        F3 = Ff[u, 3]
        F4 = Ff[u, 4]
        for j in range(L):
            k, _ = _reads(sign[j], -sign[j] * base[j], u, S)  # u = sign·k + base (mod S)
            mir = -1.0 if mirrored[j] else 1.0
            c1 = mir * body_acc[k, 0]
            c2 = body_acc[k, 1]
            g = G[j]
            for q in range(2 * K):
                g[q] = F0[q] + c1 * F1[q] + c2 * F2[q]
            if C[k] == j:  # the ground pushes the contact leg's foot only
                c3 = mir * ground[k, 0]
                c4 = ground[k, 1]
                for q in range(2 * K):
                    g[q] += c3 * F3[q] + c4 * F4[q]
            for kk in range(K):
                pk[kk] = _peak(pk[kk], g[2 * kk] * g[2 * kk] + g[2 * kk + 1] * g[2 * kk + 1])


@njit(cache=True, nogil=True, inline="always")
def _body_acc(k, C, A, foot, base, frac, sign, mirrored, s2):
    """The walker body's acceleration (x, y) at crank sample k, m/s²: −ω²·d²p_c/dθ² (s2 = ω²·unit) of
    the contact foot p_c (contact legs C (S,); a mirrored leg's x reflected), A (S, nv, 2) per radian²."""
    S = C.shape[0]
    c = C[k]
    f = frac[c]
    u0, u1 = _reads(sign[c], base[c], k, S)
    ax = (1.0 - f) * A[u0, foot, 0]
    ay = (1.0 - f) * A[u0, foot, 1]
    if f != 0.0:
        ax += f * A[u1, foot, 0]
        ay += f * A[u1, foot, 1]
    abx = s2 * ax if mirrored[c] else -s2 * ax
    aby = -s2 * ay
    return abx, aby


@njit(cache=True, nogil=True)
def _moving_walk(i, A, C, foot, base, frac, sign, mirrored, inc_vertex, sel, Fi, tau, frame, s2, load_mass, gravity,
                 drag_force, torque, fsel, finc, shake_peak, body_acc, ground, fm, pk, peaks):
    """:func:`_moving_legs`' walk, crank sample by sample: the body's acceleration, the ground's force,
    the torque, the shaking force and leg 0's reactions (``fsel``, ``finc``), and with ``peaks`` every
    leg's pins' running peaks pk (K,) (squared). Returns the first sample with a non-finite force or −1."""
    S = C.shape[0]
    L = base.shape[0]
    K = inc_vertex.shape[0]
    for kk in range(K):
        pk[kk] = 0.0
    lean = sel.shape[0] == 0 and finc.shape[1] == 0  # leg 0's reactions not stored
    first_bad = -1
    shake = 0.0
    for k in range(S):
        c = C[k]
        abx, aby = _body_acc(k, C, A, foot, base, frac, sign, mirrored, s2)
        # the legs' force on the body with no ground force, and from it the ground's force on the foot
        sx = 0.0
        sy = 0.0
        for j in range(L):
            f = frac[j]
            u0, u1 = _reads(sign[j], base[j], k, S)
            lx = -abx if mirrored[j] else abx
            fjx = (1.0 - f) * (frame[u0, 0, 0] + lx * frame[u0, 1, 0] + aby * frame[u0, 2, 0])
            fjy = (1.0 - f) * (frame[u0, 0, 1] + lx * frame[u0, 1, 1] + aby * frame[u0, 2, 1])
            if f != 0.0:
                fjx += f * (frame[u1, 0, 0] + lx * frame[u1, 1, 0] + aby * frame[u1, 2, 0])
                fjy += f * (frame[u1, 0, 1] + lx * frame[u1, 1, 1] + aby * frame[u1, 2, 1])
            sx += -fjx if mirrored[j] else fjx
            sy += fjy
        gx = load_mass * abx + drag_force - sx
        gy = load_mass * (aby + gravity) - sy
        body_acc[i, k, 0] = abx
        body_acc[i, k, 1] = aby
        ground[i, k, 0] = gx
        ground[i, k, 1] = gy
        ttot = 0.0
        frx = 0.0
        fry = 0.0
        for j in range(L):
            f = frac[j]
            w0 = 1.0 - f
            u0, u1 = _reads(sign[j], base[j], k, S)
            mir = -1.0 if mirrored[j] else 1.0
            c1 = mir * abx
            c2 = aby
            c3 = mir * gx if j == c else 0.0  # the ground pushes the contact leg's foot only
            c4 = gy if j == c else 0.0
            tj = w0 * (tau[u0, 0] + c1 * tau[u0, 1] + c2 * tau[u0, 2] + c3 * tau[u0, 3] + c4 * tau[u0, 4])
            fjx = w0 * (frame[u0, 0, 0] + c1 * frame[u0, 1, 0] + c2 * frame[u0, 2, 0] + c3 * frame[u0, 3, 0]
                        + c4 * frame[u0, 4, 0])
            fjy = w0 * (frame[u0, 0, 1] + c1 * frame[u0, 1, 1] + c2 * frame[u0, 2, 1] + c3 * frame[u0, 3, 1]
                        + c4 * frame[u0, 4, 1])
            if f != 0.0:
                tj += f * (tau[u1, 0] + c1 * tau[u1, 1] + c2 * tau[u1, 2] + c3 * tau[u1, 3] + c4 * tau[u1, 4])
                fjx += f * (frame[u1, 0, 0] + c1 * frame[u1, 1, 0] + c2 * frame[u1, 2, 0] + c3 * frame[u1, 3, 0]
                            + c4 * frame[u1, 4, 0])
                fjy += f * (frame[u1, 0, 1] + c1 * frame[u1, 1, 1] + c2 * frame[u1, 2, 1] + c3 * frame[u1, 3, 1]
                            + c4 * frame[u1, 4, 1])
            ttot += mir * tj
            frx += mir * fjx
            fry += fjy
            if not peaks and (lean or j != 0):  # the peaks come later (_moving_peaks)
                continue
            for kk in range(K):
                fx = Fi[u0, 0, kk, 0] + c1 * Fi[u0, 1, kk, 0] + c2 * Fi[u0, 2, kk, 0]
                fy = Fi[u0, 0, kk, 1] + c1 * Fi[u0, 1, kk, 1] + c2 * Fi[u0, 2, kk, 1]
                if j == c:
                    fx += c3 * Fi[u0, 3, kk, 0] + c4 * Fi[u0, 4, kk, 0]
                    fy += c3 * Fi[u0, 3, kk, 1] + c4 * Fi[u0, 4, kk, 1]
                if f != 0.0:
                    gx_ = Fi[u1, 0, kk, 0] + c1 * Fi[u1, 1, kk, 0] + c2 * Fi[u1, 2, kk, 0]
                    gy_ = Fi[u1, 0, kk, 1] + c1 * Fi[u1, 1, kk, 1] + c2 * Fi[u1, 2, kk, 1]
                    if j == c:
                        gx_ += c3 * Fi[u1, 3, kk, 0] + c4 * Fi[u1, 4, kk, 0]
                        gy_ += c3 * Fi[u1, 3, kk, 1] + c4 * Fi[u1, 4, kk, 1]
                    fx = w0 * fx + f * gx_
                    fy = w0 * fy + f * gy_
                mag2 = fx * fx + fy * fy  # squared: one square root per joint at the end
                v = inc_vertex[kk]
                pk[kk] = _peak(pk[kk], mag2)
                if j == 0:
                    mag = math.sqrt(mag2)
                    fm[kk] = mag
                    if finc.shape[1] > 0:
                        finc[i, k, kk, 0] = mir * fx
                        finc[i, k, kk, 1] = fy
                    for s_ in range(sel.shape[0]):
                        if sel[s_] == v:  # the member that loads this pin most, at this sample
                            best = True
                            for k2 in range(kk):
                                if inc_vertex[k2] == v and fm[k2] >= PIN_TIE * mag:
                                    best = False
                            if best:
                                fsel[i, k, s_, 0] = mir * fx
                                fsel[i, k, s_, 1] = fy
        torque[i, k] = ttot
        if first_bad < 0 and not (math.isfinite(ttot) and _finite(pk)):
            first_bad = k
        sh = math.sqrt(frx * frx + fry * fry)
        if not (sh <= shake):
            shake = sh
    shake_peak[i] = shake
    if first_bad < 0 and not math.isfinite(shake):
        first_bad = 0
    return first_bad


def _specialise(fn, name: str, **bind):
    """A jitted copy of ``fn`` (its own name, so it caches) with globals rebound."""
    env = dict(fn.__globals__, **bind)
    copy = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
    copy.__qualname__ = f"{fn.__name__}_{name}"
    copy.__doc__ = fn.__doc__
    return njit(cache=True, nogil=True)(copy)


def _inlined(fn):
    """The kinds' forces function ``fn`` compiled into its caller: called once per sample, a call passes
    (and counts references to) every array of the lowered plan, which cost more than its arithmetic."""
    return njit(nogil=True, inline="always")(fn.py_func)


#: the forces effect of one design, for plans without coupled blocks and for any plan
base_leg_fast = _specialise(_base_leg, "fast", singular=_inlined(singular_closed), reactions=_inlined(reactions_closed))
base_leg_any = _specialise(_base_leg, "any", singular=singular_any, reactions=reactions_any)
design_forces_fast = _specialise(_design_forces, "fast", base_leg=base_leg_fast)
design_forces_any = _specialise(_design_forces, "any", base_leg=base_leg_any)


def design_forces_with(base_leg, name: str):
    """The forces effect of one design with ``base_leg`` (a per-topology generated one, ``_forces_scalar``)
    in place of the table-driven :func:`_base_leg`; ``name`` (unique per generated function) names the
    jitted copy, so that its cache entry is its own."""
    return _specialise(_design_forces, name, base_leg=base_leg)


# -- the wrapper ------------------------------------------------------------------------------------
_TABLES: dict = {}


@dataclass(frozen=True)
class Forces:
    """The forces effect of N variants over S crank samples (SI units).

    torque : (N, S) motor torque of the whole walker, N·m, positive when the motor does positive work.
    joint_forces : {joint: (N, S, 2)} leg 0's reaction at that joint, N: the force its most heavily
        loaded member puts on the pin (see the module's docstring).
    pin_peak : (N, n_vertices) each joint's largest reaction over the legs and the turn, N.
    shaking_peak : (N,) the largest resultant force the legs put on the frame, N.
    travel : (N,) the walker's travel per crank turn, model units.
    code, sample, block : (N,) F_OK / F_SINGULAR / F_NONFINITE, the crank sample and plan block where
        the Jacobian was singular (−1 otherwise).
    members : {(member, joint): (N, S, 2)} leg 0's force of each member (a link or body by name,
        "crank", "frame", "ground") on each of its pins, N; empty unless asked for.
    velocities, accelerations : None (the sweep's, which the forces read, are the Batch's).
    body : the walker's force model, "moving" or "held" (``[operating] body``).
    body_acceleration : (N, S, 2) the walker body's acceleration, m/s² (zero when held).
    ground_force : (N, S, 2) the ground's force on the contact foot, N, in the walker's frame (moving:
        the whole machine's; held: the load's weight and drag).
    contact : (N, S) the leg whose foot carries the walker at each sample (−1 where not computed).
    machine_mass : (N,) kg, the whole machine: every leg (links, bodies, crank) and the body (``load``).
    massive : whether the machine has any mass at all (:func:`has_mass`: a load or a mass given).
    """

    torque: np.ndarray
    joint_forces: dict
    pin_peak: np.ndarray
    shaking_peak: np.ndarray
    travel: np.ndarray
    code: np.ndarray
    sample: np.ndarray
    block: np.ndarray
    members: dict
    velocities: np.ndarray | None = None
    accelerations: np.ndarray | None = None
    body: str = "held"
    body_acceleration: np.ndarray | None = None
    ground_force: np.ndarray | None = None
    contact: np.ndarray | None = None
    machine_mass: np.ndarray | None = None
    massive: bool = False


def force_inputs(mech, plan: Plan, lengths: np.ndarray, scale: np.ndarray, body_pts: list, operating, walker,
                 S: int, joints=(), members: bool = False, out_idx=None) -> tuple:
    """The forces effect's named inputs for N variants over S crank samples: (:class:`ForceModel`,
    :class:`ForceRows` with its outputs allocated, :class:`ForceTables`).

    lengths (N, n_links) and scale (N,) crank radii, model units; body_pts: each body's joints in its
    frame (N, n_joints, 2) (``_design.body_points``); operating: :class:`~explorer.mechanism.Operating`
    with ``unit`` and ``rpm``; walker: :class:`~explorer.mechanism.Walker` (one leg: ``Walker(legs=1)``);
    joints: names of the joints whose reactions are returned; members: also every member's force on
    every pin (``Forces.members``); out_idx: the vertices whose rows the caller stores."""
    key = (id(plan), mech.foot, mech.vertices)
    tb = _TABLES.get(key)
    if tb is None or tb[0] is not plan:
        tb = _TABLES[key] = (plan, force_tables(mech, plan))
    tb = tb[1]
    N, nv = lengths.shape[0], len(mech.vertices)
    unit = float(operating.unit)
    link_mass = link_masses(mech, lengths, unit)
    crank_mass = crank_masses(mech, scale, unit)
    nb = len(mech.bodies)
    body_mass = np.array([b.mass for b in mech.bodies], dtype=np.float64)
    body_cuv = np.zeros((N, nb, 2))
    body_J = np.zeros((N, nb))
    for bi, b in enumerate(mech.bodies):
        pts = body_pts[bi]  # (N, nj, 2)
        G = np.broadcast_to(np.asarray(b.centroid, dtype=np.float64), (N, 2)) if b.centroid is not None \
            else pts.mean(axis=1)
        if b.inertia is not None:
            IG = np.full(N, b.inertia)
        else:  # the mass shared equally among the joints
            IG = b.mass / pts.shape[1] * np.sum((pts - G[:, None, :]) ** 2, axis=(1, 2)) * unit ** 2
        p, q = plan.body_base[bi]
        body_cuv[:, bi, 0], body_cuv[:, bi, 1] = pair_coordinates(pts[:, p], pts[:, q], G)
        e2 = np.sum((pts[:, q] - pts[:, p]) ** 2, axis=1)
        body_J[:, bi] = (IG + b.mass * np.sum((G - pts[:, p]) ** 2, axis=1) * unit ** 2) / (e2 * unit ** 2)
    sel = np.array([mech.vertex_index(j) for j in joints], dtype=np.int64)
    base, frac, sign = leg_samples(walker, S)
    mirrored = np.array(walker.mirrored, dtype=np.bool_)
    weight = float(operating.load) * float(operating.gravity)
    body = operating.body or "moving"
    if body not in BODY_MODELS:
        raise ValueError(f"operating.body: expected one of {BODY_MODELS}, got {body!r}")
    out_idx = np.zeros(0, dtype=np.int64) if out_idx is None else np.asarray(out_idx, dtype=np.int64)
    model = ForceModel(tb.inc_vertex, tb.dinc, tb.ainc, tb.body_pq, tb.body_inc, tb.tip_inc, tb.fixed, tb.fixed_inc,
                       tb.foot, tb.foot_inc, tb.sinc, body_mass, sel, base, frac, sign, mirrored, float(walker.drag),
                       unit, float(operating.omega), float(operating.gravity), weight, body == "moving",
                       float(operating.load), out_idx)
    K = len(tb.inc_vertex)
    rows = ForceRows(link_mass, body_cuv, body_J, crank_mass, np.zeros((N, S)), np.zeros((N, S, len(sel), 2)),
                     np.zeros((N, S if members else 0, K, 2)), np.zeros((N, nv)), np.zeros(N), np.zeros(N),
                     np.zeros(N, dtype=np.int64), np.full(N, -1, dtype=np.int64), np.full(N, -1, dtype=np.int64),
                     np.zeros((N, S, 2)), np.zeros((N, S, 2)), np.full((N, S), -1, dtype=np.int64))
    return model, rows, tb


def collect(mech, operating, walker, model, rows, tb, status, joints=(), members: bool = False) -> Forces:
    """The :class:`Forces` of N variants from the kernels' outputs (``rows``), NaN where a variant's
    sweep or its forces failed (``status`` (N,) the sweep's, 0 = ok)."""
    bad = (rows.code != F_OK) | (status != 0)
    torque, body_acc, ground, contact = rows.torque, rows.body_acc, rows.ground, rows.contact
    torque[bad] = np.nan
    body_acc[bad] = np.nan
    ground[bad] = np.nan
    contact[bad] = -1
    rows.fsel[bad] = np.nan
    rows.pin_peak[bad] = np.nan
    rows.shake[bad] = np.nan
    rows.travel[bad] = np.nan
    member_forces = {}
    if members:
        rows.finc[bad] = np.nan
        member_forces = {(m, mech.vertices[v]): rows.finc[:, :, k] for k, (m, v) in enumerate(zip(tb.inc_member,
                                                                                                    tb.inc_vertex))}
    # the whole machine: every leg with its crank, and the body
    machine = walker.legs * (rows.link_mass.sum(axis=1) + model.body_mass.sum() + rows.crank_mass) \
        + float(operating.load)
    return Forces(torque, {j: rows.fsel[:, :, k] for k, j in enumerate(joints)}, rows.pin_peak, rows.shake,
                  rows.travel, rows.code, rows.sample, rows.block, member_forces, None, None,
                  "moving" if model.moving else "held", body_acc, ground, contact, machine, has_mass(mech, operating))


def has_mass(mech, operating) -> bool:
    """Whether the machine weighs anything: a load, or a mass of a link, the crank or a body, or a link
    density (then every link weighs something). Decided by the files alone, so that every chunk of a
    study computes the same metrics."""
    return bool(operating.load > 0 or (mech.link_density or 0.0) > 0 or any(lk.mass for lk in mech.links)
                or (mech.crank is not None and mech.crank.mass) or any(b.mass for b in mech.bodies))


def no_forces(N: int, S: int, nv: int, joints=(), massive: bool = False) -> Forces:
    """The :class:`Forces` of N variants none of which could be solved: every figure NaN (``massive``:
    :func:`has_mass` of the machine, which decides the metrics computed)."""
    nan = np.full(N, np.nan)
    fail = np.full(N, F_SINGULAR, dtype=np.int64)
    return Forces(np.full((N, S), np.nan), {j: np.full((N, S, 2), np.nan) for j in joints}, np.full((N, nv), np.nan),
                  nan, nan.copy(), fail, np.full(N, -1, dtype=np.int64), np.full(N, -1, dtype=np.int64), {},
                  machine_mass=nan.copy(), massive=massive)


def force_metrics(forces: Forces, operating, vertices) -> dict:
    """{metric: (N,)} in SI units, the forces group of the metric table (``gait._table``) then
    ``pin_force.<joint>`` for each of ``vertices`` (names, in order); ``cost_of_transport`` only with
    gravity and a machine that weighs something (``forces.massive``). NaN where the forces are not
    computed.

    With τ_k the walker's motor torque at θ_k = 2πk/S, Δ = 2π/S and ω the crank speed:
    motor_torque_peak = max |τ_k|; motor_torque_rms = √(mean τ_k²); motor_power_peak = max τ_k·ω (the
    most power the motor delivers); energy_per_turn = Σ max(τ_k, 0)·Δ (J, the positive work per turn);
    flywheel_inertia = ΔE / (C_s·ω²) with E_k = Σ_{m<k} (τ_m − mean τ)·Δ and ΔE = max E − min E (on
    the crank); flywheel_inertia_motor = flywheel_inertia / N² (N = gear_ratio: on the motor shaft);
    pin_force_max = max over joints of pin_force.<joint>; shaking_force_peak; machine_mass (kg, every
    leg and the body); cost_of_transport = energy_per_turn / (machine_mass·g·travel·unit), inf for a
    machine that does not travel (the contact feet's net stroke within 1e-9 of their total stroke).
    """
    tau = forces.torque
    S = tau.shape[1]
    d = 2.0 * math.pi / S
    w = float(operating.omega)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = {
            "motor_torque_peak": np.max(np.abs(tau), axis=1),
            "motor_torque_rms": np.sqrt(np.mean(tau * tau, axis=1)),
            "motor_power_peak": np.max(tau, axis=1) * w,
        }
        out["energy_per_turn"] = np.sum(np.maximum(tau, 0.0), axis=1) * d
        E = np.concatenate([np.zeros((tau.shape[0], 1)), np.cumsum((tau - tau.mean(axis=1, keepdims=True)) * d,
                                                                   axis=1)], axis=1)
        out["flywheel_inertia"] = (E.max(axis=1) - E.min(axis=1)) / (float(operating.speed_fluctuation) * w * w)
        out["flywheel_inertia_motor"] = out["flywheel_inertia"] / float(operating.gear_ratio) ** 2
        out["pin_force_max"] = np.max(forces.pin_peak, axis=1)
        out["shaking_force_peak"] = forces.shaking_peak.copy()
        out["machine_mass"] = np.where(np.isfinite(forces.travel), forces.machine_mass, np.nan)
        if operating.gravity > 0 and forces.massive:
            # a machine that does not travel (its contact feet return to where they started) has no finite
            # cost of transport: inf, which ranks last under "min"
            cot = out["energy_per_turn"] / (out["machine_mass"] * operating.gravity
                                            * forces.travel * float(operating.unit))
            out["cost_of_transport"] = np.where(forces.travel == 0.0, np.inf, cot)
        for k, v in enumerate(vertices):
            out[f"pin_force.{v}"] = forces.pin_peak[:, k].copy()
    return out
