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
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..mechanism import BODY_MODELS
from ..plan import ATTACH, DYAD, GENERAL, ROW_ATTACH_X, ROW_ATTACH_Y, ROW_DIST, ROW_SLIDE, SLIDE, Plan
from ..kinds._common import lu_solve
from ..kinds.eq_slide import slide_curvature, slide_row
from ..kinds.general import _general_jacobian, general_rates as _general_rates, general_sign
from ._design import pair_coordinates
from ._legs import ground_contact, leg_feet, leg_samples

# The general-block solver the kinematics / reactions call (``_kin_general`` / ``_rea_general``); the
# copies jitted by :func:`_specialise` bind it, or bind a stub for plans without general blocks, so that
# the common dyad-and-body plans compile without it (measured: the reachable call made the whole
# dyad loop 2-4x slower).
general = None
# The kinematics and reactions the forces kernel calls; bound in the specialised copies.
kinematics = None
reactions = None

#: force-effect status codes written to ``code`` (0 ok); the caller turns them into statuses
F_OK, F_SINGULAR, F_NONFINITE = 0, 1, 2


@dataclass(frozen=True)
class ForceTables:
    """The plan as the forces kernel reads it (computed once per topology).

    blk_kind (nb,) DYAD / ATTACH / GENERAL; blk_v (nb,) a dyad's vertex; blk_e (nb, 2) a dyad's two
    distance rows (an attach block's attach row in column 0); blk_vp (nb+1,) / blk_verts: a general
    block's vertices; blk_rp (nb+1,) / gen_rows (n_rows, 2): its rows as the kernels write them
    (``_inputs.Topology.gen_rows``: ROW_DIST / ROW_ATTACH_X / ROW_ATTACH_Y, equation).
    dist_a, dist_b (n_dist,), att (n_att, 3) (joint, p, q) vertex indices.
    Incidences (one per member and pin): inc_vertex (K,); dinc (n_dist, 2) the incidence of each
    distance row's a and b ends; ainc (n_att, 3) of each attach row's j, p, q; body_pq (n_bodies, 2)
    base-pair vertices and body_inc (n_bodies, 2) their incidences; link_inc is dinc[:n_links];
    tip_inc the crank's incidence at the tip; fixed (n_fixed,) and fixed_inc; foot, foot_inc (the
    ground's incidence at the foot).
    """

    blk_kind: np.ndarray
    blk_v: np.ndarray
    blk_e: np.ndarray
    blk_vp: np.ndarray
    blk_verts: np.ndarray
    blk_rp: np.ndarray
    gen_rows: np.ndarray
    dist_a: np.ndarray
    dist_b: np.ndarray
    att: np.ndarray
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
    inc_member: tuple  # (K,) member names, for people: link / body name, "crank", "frame", "ground"
    slide: np.ndarray = None  # (n_slide, 3) each slide equation's p, a, b (``Plan.slide``)
    sinc: np.ndarray = None  # (n_slide, 3) the incidences of its guide (the frame, or the slot's member) at p, a, b


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
    nblk = plan.n_blocks
    blk_kind = np.array([b.kind for b in plan.blocks], dtype=np.int64)
    blk_v = np.array([b.vertices[0] for b in plan.blocks], dtype=np.int64)
    blk_e = np.full((nblk, 2), -1, dtype=np.int64)
    vp, verts, rp, rows = [0], [], [0], []
    for k, b in enumerate(plan.blocks):
        if b.kind == DYAD:
            blk_e[k] = b.links
        elif b.kind == ATTACH:
            blk_e[k, 0] = b.attaches[0][0]
        elif b.kind == SLIDE:
            blk_e[k] = b.links[0], b.slides[0]
        else:
            verts += list(b.vertices)
            for e in b.links:
                rows.append((ROW_DIST, e))
            for t, axis in b.attaches:
                rows.append((ROW_ATTACH_X if axis == 0 else ROW_ATTACH_Y, t))
            for t in b.slides:
                rows.append((ROW_SLIDE, t))
        vp.append(len(verts))
        rp.append(len(rows))
    i64 = lambda x: np.asarray(x, dtype=np.int64)  # noqa: E731
    return ForceTables(blk_kind, blk_v, blk_e, i64(vp), i64(verts), i64(rp), i64(rows).reshape(-1, 2),
                       i64(plan.link_a), i64(plan.link_b), i64(plan.attach).reshape(-1, 3), i64([v for _, v in inc]),
                       dinc, ainc, body_pq, body_inc, int(plan.tip), tip_inc, fixed, fixed_inc, foot, foot_inc,
                       tuple(m for m, _ in inc), i64(plan.slide).reshape(-1, 3), sinc)


# -- small dense solves -------------------------------------------------------------------------------
@njit(cache=True, nogil=True)
def _row_grad(kind, rid, axis, v, P, dist_a, dist_b, att, uv, out):
    """out[:] = ∂c/∂q_v (2,) of constraint row (kind, rid, axis) with respect to vertex v's position."""
    out[0] = 0.0
    out[1] = 0.0
    if kind == 0:
        a = dist_a[rid]
        b = dist_b[rid]
        if v == b:
            out[0] = P[b, 0] - P[a, 0]
            out[1] = P[b, 1] - P[a, 1]
        elif v == a:
            out[0] = P[a, 0] - P[b, 0]
            out[1] = P[a, 1] - P[b, 1]
    else:
        u = uv[rid, 0]
        w = uv[rid, 1]
        j = att[rid, 0]
        p = att[rid, 1]
        q = att[rid, 2]
        # c = j − (I − A) p − A q, A = [[u, −w], [w, u]]
        if v == j:
            out[axis] = 1.0
        if v == p:
            if axis == 0:
                out[0] -= 1.0 - u
                out[1] -= w
            else:
                out[0] -= -w
                out[1] -= 1.0 - u
        if v == q:
            if axis == 0:
                out[0] -= u
                out[1] -= -w
            else:
                out[0] -= w
                out[1] -= u


@njit(cache=True, nogil=True)
def _kin_general(k, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b, att, uv, P, V, A, loc, M, x, g, slide, sd):
    """Velocities and accelerations of general block k's vertices (see :func:`_kinematics`), by the
    kernels' own general-block rates (``_blocks._general_rates``); False if its Jacobian is singular."""
    verts = blk_verts[blk_vp[k]:blk_vp[k + 1]]
    rows = gen_rows[blk_rp[k]:blk_rp[k + 1]]
    if general_sign(P, verts, rows, dist_a, dist_b, att, uv, slide, sd, loc, M, x) == 0.0:
        return False
    for j in range(verts.shape[0]):
        loc[verts[j]] = j
    _general_rates(P, V, A, verts, rows, dist_a, dist_b, att, uv, slide, sd, loc, M, x, False)
    _general_rates(P, V, A, verts, rows, dist_a, dist_b, att, uv, slide, sd, loc, M, x, True)
    for j in range(verts.shape[0]):
        loc[verts[j]] = -1
    return True


def _kinematics(tb_kind, blk_v, blk_e, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b, att, uv,
                tip, cx, cy, P, V, A, loc, M, x, g, tol, slide, sd):
    """Velocities V and accelerations A (nv, 2), per radian and per radian², of every vertex at one
    sample from its positions P, block by block in plan order; fixed vertices still, the tip on its
    circle about (cx, cy). Returns the first block whose Jacobian is singular, or −1."""
    for v in range(V.shape[0]):  # loops, not slices: a slice is a view, a reference count to update
        V[v, 0] = 0.0
        V[v, 1] = 0.0
        A[v, 0] = 0.0
        A[v, 1] = 0.0
    V[tip, 0] = -(P[tip, 1] - cy)
    V[tip, 1] = P[tip, 0] - cx
    A[tip, 0] = -(P[tip, 0] - cx)
    A[tip, 1] = -(P[tip, 1] - cy)
    for k in range(tb_kind.shape[0]):
        kind = tb_kind[k]
        if kind == 0:  # DYAD: c_i · (V_v − V_a_i) = 0, c_i · (A_v − A_a_i) + |V_v − V_a_i|² = 0
            # (the dyad's frame is written out here and in _reactions: a shared helper returning it
            # measured 25-50 % slower for the whole forces kernel)
            v = blk_v[k]
            e1 = blk_e[k, 0]
            e2 = blk_e[k, 1]
            a1 = dist_a[e1] if dist_b[e1] == v else dist_b[e1]
            a2 = dist_a[e2] if dist_b[e2] == v else dist_b[e2]
            c1x = P[v, 0] - P[a1, 0]
            c1y = P[v, 1] - P[a1, 1]
            c2x = P[v, 0] - P[a2, 0]
            c2y = P[v, 1] - P[a2, 1]
            det = c1x * c2y - c1y * c2x
            if not (abs(det) > tol * (abs(c1x * c2y) + abs(c1y * c2x))):
                return k
            r1 = c1x * V[a1, 0] + c1y * V[a1, 1]
            r2 = c2x * V[a2, 0] + c2y * V[a2, 1]
            V[v, 0] = (r1 * c2y - r2 * c1y) / det
            V[v, 1] = (c1x * r2 - c2x * r1) / det
            d1x = V[v, 0] - V[a1, 0]
            d1y = V[v, 1] - V[a1, 1]
            d2x = V[v, 0] - V[a2, 0]
            d2y = V[v, 1] - V[a2, 1]
            r1 = c1x * A[a1, 0] + c1y * A[a1, 1] - (d1x * d1x + d1y * d1y)
            r2 = c2x * A[a2, 0] + c2y * A[a2, 1] - (d2x * d2x + d2y * d2y)
            A[v, 0] = (r1 * c2y - r2 * c1y) / det
            A[v, 1] = (c1x * r2 - c2x * r1) / det
        elif kind == 1:  # ATTACH: j = p + A (q − p), linear
            t = blk_e[k, 0]
            j = att[t, 0]
            p = att[t, 1]
            q = att[t, 2]
            u = uv[t, 0]
            w = uv[t, 1]
            gx = V[q, 0] - V[p, 0]
            gy = V[q, 1] - V[p, 1]
            V[j, 0] = V[p, 0] + u * gx - w * gy
            V[j, 1] = V[p, 1] + u * gy + w * gx
            gx = A[q, 0] - A[p, 0]
            gy = A[q, 1] - A[p, 1]
            A[j, 0] = A[p, 0] + u * gx - w * gy
            A[j, 1] = A[p, 1] + u * gy + w * gx
        elif kind == 3:  # SLIDE: (v − c)·(V_v − V_c) = 0 and the slide row J·V = 0 (see _fast.slide_rates)
            v = blk_v[k]
            e = blk_e[k, 0]
            s = blk_e[k, 1]
            c = dist_a[e] if dist_b[e] == v else dist_b[e]
            _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, s, slide, sd)
            jx, jy = _slide_partial(slide, s, v, jpx, jpy, jax, jay, jbx, jby)
            ex = P[v, 0] - P[c, 0]
            ey = P[v, 1] - P[c, 1]
            det = ex * jy - ey * jx
            if not (abs(det) > tol * (abs(ex * jy) + abs(ey * jx))):
                return k
            r1 = ex * V[c, 0] + ey * V[c, 1]
            r2 = -_slide_others(slide, s, v, V, jpx, jpy, jax, jay, jbx, jby)
            V[v, 0] = (r1 * jy - ey * r2) / det
            V[v, 1] = (ex * r2 - jx * r1) / det
            wx = V[v, 0] - V[c, 0]
            wy = V[v, 1] - V[c, 1]
            r1 = ex * A[c, 0] + ey * A[c, 1] - (wx * wx + wy * wy)
            r2 = -_slide_others(slide, s, v, A, jpx, jpy, jax, jay, jbx, jby) - slide_curvature(V, s, slide, sd)
            A[v, 0] = (r1 * jy - ey * r2) / det
            A[v, 1] = (ex * r2 - jx * r1) / det
        else:  # GENERAL: J_bb x_b = −J_bk x_k (− the quadratic terms of the distance rows, for A)
            if not general(k, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b, att, uv, P, V,
                                A, loc, M, x, g, slide, sd):
                return k
    return -1


@njit(cache=True, nogil=True)
def _slide_partial(slide, s, v, jpx, jpy, jax, jay, jbx, jby):
    """The slide row s's partial derivative in vertex v (one of its p, a, b)."""
    if slide[s, 0] == v:
        return jpx, jpy
    if slide[s, 1] == v:
        return jax, jay
    return jbx, jby


@njit(cache=True, nogil=True)
def _slide_others(slide, s, v, X, jpx, jpy, jax, jay, jbx, jby):
    """Σ ∂r/∂w · X[w] over slide row s's vertices w other than v."""
    out = 0.0
    if slide[s, 0] != v:
        out += jpx * X[slide[s, 0], 0] + jpy * X[slide[s, 0], 1]
    if slide[s, 1] >= 0:
        if slide[s, 1] != v:
            out += jax * X[slide[s, 1], 0] + jay * X[slide[s, 1], 1]
        if slide[s, 2] != v:
            out += jbx * X[slide[s, 2], 0] + jby * X[slide[s, 2], 1]
    return out


@njit(cache=True, nogil=True)
def _rea_general(k, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b, att, uv, P, R, loc, M, x, g, lam_d, lam_a,
                 slide, sd, lam_s):
    """The multipliers of general block k (see :func:`_reactions`): its Jacobian (the kernels' own,
    ``_blocks._general_jacobian``) transposed; False if it is singular."""
    verts = blk_verts[blk_vp[k]:blk_vp[k + 1]]
    rows = gen_rows[blk_rp[k]:blk_rp[k + 1]]
    nb = verts.shape[0]
    n = 2 * nb
    for j in range(nb):
        loc[verts[j]] = j
    _general_jacobian(P, verts, rows, dist_a, dist_b, att, uv, slide, sd, loc, M)
    for r in range(n):  # transpose in place
        for c in range(r + 1, n):
            t = M[r, c]
            M[r, c] = M[c, r]
            M[c, r] = t
    for j in range(nb):
        x[2 * j] = R[verts[j], 0]
        x[2 * j + 1] = R[verts[j], 1]
        R[verts[j], 0] = 0.0
        R[verts[j], 1] = 0.0
    if lu_solve(M, x, n) == 0.0:
        for j in range(nb):
            loc[verts[j]] = -1
        return False
    for r in range(n):  # store the multipliers; push what the rows put on vertices outside the block
        if rows[r, 0] == ROW_SLIDE:
            s = rows[r, 1]
            lam_s[s] = x[r]
            _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, s, slide, sd)
            for vv, gx, gy in ((slide[s, 0], jpx, jpy), (slide[s, 1], jax, jay), (slide[s, 2], jbx, jby)):
                if vv >= 0 and loc[vv] < 0:
                    R[vv, 0] -= gx * x[r]
                    R[vv, 1] -= gy * x[r]
            continue
        kind_r = 0 if rows[r, 0] == ROW_DIST else 1
        rid = rows[r, 1]
        ax = 0 if rows[r, 0] != ROW_ATTACH_Y else 1
        lam = 2.0 * x[r] if kind_r == 0 else x[r]  # the kernels' distance row is |p_b − p_a|² − d², ours half that
        if kind_r == 0:
            lam_d[rid] = lam
        else:
            lam_a[rid, ax] = lam
        for end in range(3):
            if kind_r == 0 and end == 2:
                break
            vv = (dist_a[rid] if end == 0 else dist_b[rid]) if kind_r == 0 else att[rid, end]
            if loc[vv] < 0:
                _row_grad(kind_r, rid, ax, vv, P, dist_a, dist_b, att, uv, g)
                R[vv, 0] -= g[0] * lam
                R[vv, 1] -= g[1] * lam
    for j in range(nb):
        loc[verts[j]] = -1
    return True


def _reactions(tb_kind, blk_v, blk_e, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b, att,
               uv, dinc, ainc, P, R, F, loc, M, x, g, lam_d, lam_a, slide, sd, sinc, lam_s):
    """Solve Φ_qᵀ λ = R block by block in reverse plan order. R (nv, 2) comes holding M q̈ − Q (with the
    members' own parts already written, negated, into the incidence forces F (K, 2)); it leaves holding
    what the plan's constraints do not carry: the crank's force on the tip and the frame's on each fixed
    vertex. Adds every row's (∂c/∂q_v)ᵀ λ to its member's incidence at v. Returns the first singular
    block or −1."""
    nblk = tb_kind.shape[0]
    for k in range(nblk - 1, -1, -1):
        kind = tb_kind[k]
        if kind == 0:
            v = blk_v[k]
            e1 = blk_e[k, 0]
            e2 = blk_e[k, 1]
            a1 = dist_a[e1] if dist_b[e1] == v else dist_b[e1]
            a2 = dist_a[e2] if dist_b[e2] == v else dist_b[e2]
            c1x = P[v, 0] - P[a1, 0]
            c1y = P[v, 1] - P[a1, 1]
            c2x = P[v, 0] - P[a2, 0]
            c2y = P[v, 1] - P[a2, 1]
            det = c1x * c2y - c1y * c2x
            if det == 0.0:
                return k
            rx = R[v, 0]
            ry = R[v, 1]
            l1 = (rx * c2y - ry * c2x) / det
            l2 = (c1x * ry - c1y * rx) / det
            lam_d[e1] = l1
            lam_d[e2] = l2
            R[v, 0] = 0.0
            R[v, 1] = 0.0
            R[a1, 0] += c1x * l1
            R[a1, 1] += c1y * l1
            R[a2, 0] += c2x * l2
            R[a2, 1] += c2y * l2
        elif kind == 1:
            t = blk_e[k, 0]
            j = att[t, 0]
            p = att[t, 1]
            q = att[t, 2]
            u = uv[t, 0]
            w = uv[t, 1]
            lx = R[j, 0]
            ly = R[j, 1]
            lam_a[t, 0] = lx
            lam_a[t, 1] = ly
            R[j, 0] = 0.0
            R[j, 1] = 0.0
            # Aᵀ λ with A = [[u, −w], [w, u]]
            atx = u * lx + w * ly
            aty = -w * lx + u * ly
            R[p, 0] += lx - atx
            R[p, 1] += ly - aty
            R[q, 0] += atx
            R[q, 1] += aty
        elif kind == 3:  # SLIDE: λ_d (v − c) + λ_s J = R_v
            v = blk_v[k]
            e = blk_e[k, 0]
            s = blk_e[k, 1]
            c = dist_a[e] if dist_b[e] == v else dist_b[e]
            _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, s, slide, sd)
            jx, jy = _slide_partial(slide, s, v, jpx, jpy, jax, jay, jbx, jby)
            ex = P[v, 0] - P[c, 0]
            ey = P[v, 1] - P[c, 1]
            det = ex * jy - ey * jx
            if det == 0.0:
                return k
            rx = R[v, 0]
            ry = R[v, 1]
            l1 = (rx * jy - ry * jx) / det
            l2 = (ex * ry - ey * rx) / det
            lam_d[e] = l1
            lam_s[s] = l2
            R[v, 0] = 0.0
            R[v, 1] = 0.0
            R[c, 0] += ex * l1
            R[c, 1] += ey * l1
            for vv, gx, gy in ((slide[s, 0], jpx, jpy), (slide[s, 1], jax, jay), (slide[s, 2], jbx, jby)):
                if vv >= 0 and vv != v:
                    R[vv, 0] -= gx * l2
                    R[vv, 1] -= gy * l2
        else:
            if not general(k, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b, att, uv, P, R,
                           loc, M, x, g, lam_d, lam_a, slide, sd, lam_s):
                return k
    # every row's pull on its member's pins: (∂c/∂q_v)ᵀ λ
    for e in range(dist_a.shape[0]):
        a = dist_a[e]
        b = dist_b[e]
        dx = (P[b, 0] - P[a, 0]) * lam_d[e]
        dy = (P[b, 1] - P[a, 1]) * lam_d[e]
        F[dinc[e, 1], 0] += dx
        F[dinc[e, 1], 1] += dy
        F[dinc[e, 0], 0] -= dx
        F[dinc[e, 0], 1] -= dy
    for t in range(att.shape[0]):
        u = uv[t, 0]
        w = uv[t, 1]
        lx = lam_a[t, 0]
        ly = lam_a[t, 1]
        atx = u * lx + w * ly
        aty = -w * lx + u * ly
        F[ainc[t, 0], 0] += lx
        F[ainc[t, 0], 1] += ly
        F[ainc[t, 1], 0] -= lx - atx
        F[ainc[t, 1], 1] -= ly - aty
        F[ainc[t, 2], 0] -= atx
        F[ainc[t, 2], 1] -= aty
    for s in range(slide.shape[0]):  # a slider's guide pushes normal to its line, no friction
        _, jpx, jpy, jax, jay, jbx, jby = slide_row(P, s, slide, sd)
        ls = lam_s[s]
        F[sinc[s, 0], 0] += jpx * ls
        F[sinc[s, 0], 1] += jpy * ls
        if slide[s, 1] >= 0:
            F[sinc[s, 1], 0] += jax * ls
            F[sinc[s, 1], 1] += jay * ls
            F[sinc[s, 2], 0] += jbx * ls
            F[sinc[s, 2], 1] += jby * ls
    return -1


@njit(cache=True, nogil=True, inline="always")
def _body_load(R, Fu, p, q, ip, iq, dpx, dpy, dqx, dqy):
    """A body's generalised load (dpx, dpy) on its base vertex p and (dqx, dqy) on q: into R, and, negated,
    into the body's incidence forces Fu at p (ip) and q (iq)."""
    R[p, 0] += dpx
    R[p, 1] += dpy
    R[q, 0] += dqx
    R[q, 1] += dqy
    Fu[ip, 0] -= dpx
    Fu[ip, 1] -= dpy
    Fu[iq, 0] -= dqx
    Fu[iq, 1] -= dqy


def _forces_kernel(blk_kind, blk_v, blk_e, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b,
                   att, inc_vertex, dinc, ainc, body_pq, body_inc, body_mass, tip, tip_inc, fixed, fixed_inc, foot,
                   foot_inc, sel, base, frac, sign, mirrored, drag, unit, omega, gravity, weight, out_idx, slide, sinc,
                   moving, load_mass,
                   P, status, uv, sdes, center, link_mass, body_cuv, body_J, crank_mass,
                   torque, fsel, finc, vout, aout, pin_peak, shake_peak, travel, code, code_sample, code_block,
                   body_acc, ground, contact):
    """Per variant i (rows last): positions P[i] (S, nv, 2), model units, of an ok variant (status 0)
    → torque[i] (S,) N·m, fsel[i] (S, n_sel, 2) N (leg 0's reaction at each joint in ``sel``),
    pin_peak[i] (nv,) N, shake_peak[i] N, travel[i] model units per turn, code[i] (F_OK, F_SINGULAR,
    F_NONFINITE) with code_sample / code_block where it failed; finc[i] (S, K, 2) leg 0's force of every
    member on every pin (incidence), when asked for (finc of shape (N, 0, K, 2) otherwise); vout[i],
    aout[i] (S, n_out, 2) the velocities (per radian) and accelerations (per radian²) of the vertices
    ``out_idx``, when asked for (second axis 0 otherwise). Shared: the :class:`ForceTables`
    arrays, body_mass (nb,) kg, sel (n_sel,), the walker's legs (base, frac, sign, mirrored), drag,
    unit (m per model unit), omega (rad/s), gravity (m/s²), weight (N on the contact foot: the load's weight),
    moving (the moving-body model, else the held frame), load_mass (kg, the walker's body); body_acc[i],
    ground[i] (S, 2) the body's acceleration (m/s², 0 when held) and the ground's force on the contact foot
    (N, the walker's frame), contact[i] (S,) the contact leg. Per row:
    uv (n_att, 2), sdes (n_slide, 6) the slide equations' lines (``Designs.slide``), center (2,), link_mass (n_links,) kg, body_cuv (nb, 2) centroids in base-pair
    coordinates, body_J (nb,) kg (the base-pair inertia, see the module), crank_mass kg."""
    N = P.shape[0]
    S = P.shape[1]
    nv = P.shape[2]
    K = inc_vertex.shape[0]
    L = base.shape[0]
    nl = link_mass.shape[1]
    nb = body_pq.shape[0]
    m = 2
    for k in range(blk_kind.shape[0]):
        if blk_kind[k] == 2:
            m = max(m, 2 * (blk_vp[k + 1] - blk_vp[k]))
    V = np.empty((S, nv, 2))
    A = np.empty((S, nv, 2))
    R = np.empty((nv, 2))
    # per-sample scratch: the block functions work on these rather than on views of the big arrays
    # (every view is a reference-count update, atomic and shared between threads: measured 2x slower
    # on two threads than on one)
    Pu = np.empty((nv, 2))
    Vu = np.empty((nv, 2))
    Au = np.empty((nv, 2))
    Fu = np.empty((K, 2))
    uvi = np.empty((att.shape[0], 2))
    sdi = np.empty((slide.shape[0], 6))
    lam_s = np.zeros(slide.shape[0])
    # zeros: without a load only the first right-hand side is ever written, and the others are read
    # with weight 0 (0 × uninitialised memory could be NaN). Held: inertia and weight, the load as a
    # plain leg carries it, as a mirrored one does; moving: inertia and weight, a unit acceleration of
    # the body along x, along y, a unit force of the ground on the foot along x, along y
    nr = 5 if moving else 3
    Fi = np.zeros((S, nr, K, 2))
    tau = np.zeros((S, nr))
    frame = np.zeros((S, nr, 2))
    loc = np.full(nv, -1, dtype=np.int64)
    M = np.empty((m, m))
    x = np.empty(m)
    g = np.empty(2)
    lam_d = np.empty(dist_a.shape[0])
    lam_a = np.empty((att.shape[0], 2))
    Y = np.empty((L, S))
    VX = np.empty((L, S))
    VY = np.empty((L, S))
    G = np.empty(S)
    C = np.empty(S, dtype=np.int64)
    fm = np.empty(K)
    vis_free = np.empty(S, dtype=np.bool_)
    vis_plain = np.empty(S, dtype=np.bool_)
    vis_mirr = np.empty(S, dtype=np.bool_)
    grid = True
    for j in range(L):
        if frac[j] != 0.0:
            grid = False
    d = 2.0 * math.pi / S
    s2 = unit * omega * omega  # per radian² of crank, model units → m/s²
    nrhs = 5 if moving else 3 if weight > 0.0 else 1
    for i in range(N):
        code[i] = F_OK
        code_sample[i] = -1
        code_block[i] = -1
        if status[i] != 0:
            continue
        Pi = P[i]
        for t in range(att.shape[0]):
            uvi[t, 0] = uv[i, t, 0]
            uvi[t, 1] = uv[i, t, 1]
        for t in range(slide.shape[0]):
            for c6 in range(6):
                sdi[t, c6] = sdes[i, t, c6]
        cx = center[i, 0]
        cy = center[i, 1]
        mc = crank_mass[i]
        weightless = mc == 0.0  # no member has mass: a body acceleration loads nothing (moving)
        for e in range(nl):
            if link_mass[i, e] != 0.0:
                weightless = False
        for bi in range(nb):
            if body_mass[bi] != 0.0:
                weightless = False
        failed = False
        # -- velocities and accelerations, block by block -------------------------------------------
        for u in range(S):
            for v in range(nv):
                Pu[v, 0] = Pi[u, v, 0]
                Pu[v, 1] = Pi[u, v, 1]
            blk = kinematics(blk_kind, blk_v, blk_e, blk_vp, blk_verts, blk_rp, gen_rows, dist_a,
                             dist_b, att, uvi, tip, cx, cy, Pu, Vu, Au, loc, M, x, g, 1e-13, slide, sdi)
            for v in range(nv):
                V[u, v, 0] = Vu[v, 0]
                V[u, v, 1] = Vu[v, 1]
                A[u, v, 0] = Au[v, 0]
                A[u, v, 1] = Au[v, 1]
            if vout.shape[1] > 0:
                for o in range(out_idx.shape[0]):
                    vout[i, u, o, 0] = Vu[out_idx[o], 0]
                    vout[i, u, o, 1] = Vu[out_idx[o], 1]
            if aout.shape[1] > 0:
                for o in range(out_idx.shape[0]):
                    aout[i, u, o, 0] = Au[out_idx[o], 0]
                    aout[i, u, o, 1] = Au[out_idx[o], 1]
            if blk >= 0:
                code[i] = F_SINGULAR
                code_sample[i] = u
                code_block[i] = blk
                failed = True
                break
        if failed:
            continue
        # -- which leg carries the load at each sample (the walker scene's contact convention) -----
        leg_feet(base, frac, sign, mirrored, Pi[:, foot, :], V[:, foot, :], Y, VX, VY)
        ground_contact(Y, G, C)
        sum_vx = 0.0
        for k in range(S):
            sum_vx += VX[C[k], k]
        travel[i] = abs(d * sum_vx)
        walk = 0.0
        if sum_vx < 0.0:
            walk = 1.0
        elif sum_vx > 0.0:
            walk = -1.0
        Fx = walk * drag * weight
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
                u0 = (sign[j] * k + base[j]) % S
                loaded = C[k] == j and nrhs >= 3
                for uu in range(2):
                    if uu == 1 and frac[j] == 0.0:
                        break
                    ux = (u0 + uu) % S
                    if not loaded:
                        vis_free[ux] = True
                    elif mirrored[j]:
                        vis_mirr[ux] = True
                    else:
                        vis_plain[ux] = True
        # -- the base leg at every sample: inertia and weight, then unit forces on the foot ---------
        for u in range(S):
            tx = Pi[u, tip, 0] - cx
            ty = Pi[u, tip, 1] - cy
            for v in range(nv):
                Pu[v, 0] = Pi[u, v, 0]
                Pu[v, 1] = Pi[u, v, 1]
            for rhs in range(nrhs):
                if not moving and rhs == 2 and vis_plain[u] and vis_mirr[u] and Fx == 0.0:  # the same load either way
                    tau[u, 2] = tau[u, 1]
                    frame[u, 2, 0] = frame[u, 1, 0]
                    frame[u, 2, 1] = frame[u, 1, 1]
                    for kk in range(K):
                        Fi[u, 2, kk, 0] = Fi[u, 1, kk, 0]
                        Fi[u, 2, kk, 1] = Fi[u, 1, kk, 1]
                    continue
                if (not moving and ((rhs == 1 and not vis_plain[u]) or (rhs == 2 and not vis_mirr[u]))) or \
                        (rhs >= 3 and not (vis_plain[u] or vis_mirr[u])) or \
                        (moving and rhs <= 2 and rhs >= 1 and weightless):  # only what some leg reads: zeros
                    tau[u, rhs] = 0.0
                    frame[u, rhs, 0] = 0.0
                    frame[u, rhs, 1] = 0.0
                    for kk in range(K):
                        Fi[u, rhs, kk, 0] = 0.0
                        Fi[u, rhs, kk, 1] = 0.0
                    continue
                for v in range(nv):
                    R[v, 0] = 0.0
                    R[v, 1] = 0.0
                for kk in range(K):
                    Fu[kk, 0] = 0.0
                    Fu[kk, 1] = 0.0
                if rhs == 0:
                    for e in range(nl):
                        me = link_mass[i, e]
                        if me > 0.0:
                            a = dist_a[e]
                            b = dist_b[e]
                            for ax in range(2):
                                aa = A[u, a, ax] * s2
                                ab = A[u, b, ax] * s2
                                da = me / 6.0 * (2.0 * aa + ab)
                                db = me / 6.0 * (aa + 2.0 * ab)
                                if ax == 1:
                                    da += 0.5 * me * gravity
                                    db += 0.5 * me * gravity
                                R[a, ax] += da
                                R[b, ax] += db
                                Fu[dinc[e, 0], ax] -= da
                                Fu[dinc[e, 1], ax] -= db
                    for bi in range(nb):
                        mb = body_mass[bi]
                        Jb = body_J[i, bi]
                        if mb > 0.0 or Jb > 0.0:
                            p = body_pq[bi, 0]
                            q = body_pq[bi, 1]
                            ub = body_cuv[i, bi, 0]
                            wb = body_cuv[i, bi, 1]
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
                            _body_load(R, Fu, p, q, body_inc[bi, 0], body_inc[bi, 1], dpx, dpy, dqx, dqy)
                elif moving and rhs <= 2:  # a unit acceleration of the body along x (1) or y (2): in its
                    # frame every member's mass × it (the d'Alembert force of the frame's acceleration)
                    ax = rhs - 1
                    for e in range(nl):
                        me = link_mass[i, e]
                        if me > 0.0:
                            R[dist_a[e], ax] += 0.5 * me
                            R[dist_b[e], ax] += 0.5 * me
                            Fu[dinc[e, 0], ax] -= 0.5 * me
                            Fu[dinc[e, 1], ax] -= 0.5 * me
                    for bi in range(nb):
                        mb = body_mass[bi]
                        if mb > 0.0:  # a uniform acceleration a of the base pair: m·Āᵀa on q, m·a minus that on p
                            p = body_pq[bi, 0]
                            q = body_pq[bi, 1]
                            ub = body_cuv[i, bi, 0]
                            wb = body_cuv[i, bi, 1]
                            fqx = mb * (ub if ax == 0 else wb)
                            fqy = mb * (-wb if ax == 0 else ub)
                            fpx = (mb if ax == 0 else 0.0) - fqx
                            fpy = (mb if ax == 1 else 0.0) - fqy
                            _body_load(R, Fu, p, q, body_inc[bi, 0], body_inc[bi, 1], fpx, fpy, fqx, fqy)
                elif moving:  # a unit force of the ground on the foot along x (3) or y (4)
                    R[foot, rhs - 3] -= 1.0
                    Fu[foot_inc, rhs - 3] += 1.0
                else:  # the load on the foot from the ground, as a plain leg (1) or a mirrored one (2) carries it
                    ex = Fx if rhs == 1 else -Fx
                    R[foot, 0] -= ex
                    R[foot, 1] -= Fy
                    Fu[foot_inc, 0] += ex
                    Fu[foot_inc, 1] += Fy
                blk = reactions(blk_kind, blk_v, blk_e, blk_vp, blk_verts, blk_rp, gen_rows, dist_a,
                                dist_b, att, uvi, dinc, ainc, Pu, R, Fu, loc, M, x, g, lam_d, lam_a, slide, sdi,
                                sinc, lam_s)
                if blk >= 0:
                    code[i] = F_SINGULAR
                    code_sample[i] = u
                    code_block[i] = blk
                    failed = True
                    break
                Fu[tip_inc, 0] += R[tip, 0]
                Fu[tip_inc, 1] += R[tip, 1]
                bx = R[tip, 0]
                by = R[tip, 1]
                t = (tx * R[tip, 1] - ty * R[tip, 0]) * unit
                if rhs == 0:
                    t += mc * gravity * tx * unit * 0.5
                    bx += -mc * omega * omega * unit * tx * 0.5
                    by += -mc * omega * omega * unit * ty * 0.5 + mc * gravity
                elif moving and rhs == 1:  # the crank's share of a unit body acceleration along x, then y
                    t -= mc * ty * unit * 0.5
                    bx += mc
                elif moving and rhs == 2:
                    t += mc * tx * unit * 0.5
                    by += mc
                tau[u, rhs] = t
                frame[u, rhs, 0] = -bx
                frame[u, rhs, 1] = -by
                for f in range(fixed.shape[0]):
                    Fu[fixed_inc[f], 0] += R[fixed[f], 0]
                    Fu[fixed_inc[f], 1] += R[fixed[f], 1]
                    frame[u, rhs, 0] -= R[fixed[f], 0]
                    frame[u, rhs, 1] -= R[fixed[f], 1]
                for kk in range(K):
                    Fi[u, rhs, kk, 0] = Fu[kk, 0]
                    Fi[u, rhs, kk, 1] = Fu[kk, 1]
            if failed:
                break
        if failed:
            continue
        for k in range(S):
            contact[i, k] = C[k]
        if moving:  # the body moves with the contact foot: every leg at every angle, its ground force
            first_bad = _moving_legs(i, A, C, foot, base, frac, sign, mirrored, inc_vertex, sel, Fi, tau, frame, s2,
                                     load_mass, gravity, walk * drag * weight, torque, fsel, finc, pin_peak,
                                     shake_peak, body_acc, ground, fm)
            if first_bad >= 0:
                code[i] = F_NONFINITE
                code_sample[i] = first_bad
            continue
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
            for u in range(S):
                for st_ in range(3):
                    # the weights of right-hand sides 1 (loaded, plain) and 2 (loaded, mirrored)
                    if st_ == 0:
                        if not vis_free[u]:
                            continue
                        lx = 0.0
                        ly = 0.0
                    elif st_ == 1:
                        if not vis_plain[u]:
                            continue
                        lx = 1.0
                        ly = 0.0
                    else:
                        if not vis_mirr[u]:
                            continue
                        lx = 0.0
                        ly = 1.0
                    poison = 0.0  # 0, or NaN once a force is not finite (inf·0 and NaN·0 are NaN)
                    for kk in range(K):
                        fx = Fi[u, 0, kk, 0]
                        fy = Fi[u, 0, kk, 1]
                        if st_ > 0:
                            fx += lx * Fi[u, 1, kk, 0] + ly * Fi[u, 2, kk, 0]
                            fy += lx * Fi[u, 1, kk, 1] + ly * Fi[u, 2, kk, 1]
                        mag2 = fx * fx + fy * fy  # squared: one square root per joint at the end
                        poison += mag2 * 0.0
                        v = inc_vertex[kk]
                        if mag2 > pin_peak[i, v]:
                            pin_peak[i, v] = mag2
                    if poison != 0.0 and first_bad < 0:
                        first_bad = u
            for v in range(nv):
                pin_peak[i, v] = math.sqrt(pin_peak[i, v])
        shake = 0.0
        for k in range(S):
            ttot = 0.0
            frx = 0.0
            fry = 0.0
            for j in range(L):
                f = frac[j]
                u0 = (sign[j] * k + base[j]) % S
                u1 = (u0 + 1) % S
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
                                    if inc_vertex[k2] == v and fm[k2] >= mag:
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
        if first_bad >= 0:  # forces that overflowed: a near-singular sample
            code[i] = F_NONFINITE
            code_sample[i] = first_bad


@njit(cache=True, nogil=True)
def _moving_legs(i, A, C, foot, base, frac, sign, mirrored, inc_vertex, sel, Fi, tau, frame, s2, load_mass, gravity,
                 drag_force, torque, fsel, finc, pin_peak, shake_peak, body_acc, ground, fm):
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
    (leg 0), body_acc[i] (m/s²) and ground[i] (N); returns the first sample with a non-finite force or −1."""
    S = C.shape[0]
    L = base.shape[0]
    K = inc_vertex.shape[0]
    for v in range(pin_peak.shape[1]):
        pin_peak[i, v] = 0.0
    first_bad = -1
    shake = 0.0
    for k in range(S):
        c = C[k]
        f = frac[c]
        u0 = (sign[c] * k + base[c]) % S
        u1 = (u0 + 1) % S
        ax = (1.0 - f) * A[u0, foot, 0]
        ay = (1.0 - f) * A[u0, foot, 1]
        if f != 0.0:
            ax += f * A[u1, foot, 0]
            ay += f * A[u1, foot, 1]
        abx = s2 * ax if mirrored[c] else -s2 * ax
        aby = -s2 * ay
        # the legs' force on the body with no ground force, and from it the ground's force on the foot
        sx = 0.0
        sy = 0.0
        for j in range(L):
            f = frac[j]
            u0 = (sign[j] * k + base[j]) % S
            u1 = (u0 + 1) % S
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
            u0 = (sign[j] * k + base[j]) % S
            u1 = (u0 + 1) % S
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
                if not (mag2 <= pin_peak[i, v]):
                    pin_peak[i, v] = mag2
                    if first_bad < 0 and not math.isfinite(mag2):
                        first_bad = k
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
                                if inc_vertex[k2] == v and fm[k2] >= mag:
                                    best = False
                            if best:
                                fsel[i, k, s_, 0] = mir * fx
                                fsel[i, k, s_, 1] = fy
        torque[i, k] = ttot
        if not math.isfinite(ttot) and first_bad < 0:
            first_bad = k
        sh = math.sqrt(frx * frx + fry * fry)
        if not (sh <= shake):
            shake = sh
    shake_peak[i] = shake
    for v in range(pin_peak.shape[1]):
        pin_peak[i, v] = math.sqrt(pin_peak[i, v])
    if first_bad < 0 and not math.isfinite(shake):
        first_bad = 0
    return first_bad


@njit(cache=True, nogil=True)
def _no_general(k, blk_vp, blk_verts, blk_rp, gen_rows, dist_a, dist_b, att, uv, P, X, loc, M, x, g,
                *rest):
    return False


def _specialise(fn, name: str, inline: str = "never", **bind):
    """A jitted copy of ``fn`` (its own name, so it caches) with globals rebound."""
    env = dict(fn.__globals__, **bind)
    copy = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
    copy.__qualname__ = f"{fn.__name__}_{name}"
    copy.__doc__ = fn.__doc__
    return njit(cache=True, nogil=True, inline=inline)(copy)


_kin_fast = _specialise(_kinematics, "fast", general=_no_general)
_kin_any = _specialise(_kinematics, "any", general=_kin_general)
_rea_fast = _specialise(_reactions, "fast", general=_no_general)
_rea_any = _specialise(_reactions, "any", general=_rea_general)
#: the kernel for plans of dyads and body joints only, and the one for plans with general blocks
forces_fast = _specialise(_forces_kernel, "fast", kinematics=_kin_fast, reactions=_rea_fast)
forces_any = _specialise(_forces_kernel, "any", kinematics=_kin_any, reactions=_rea_any)


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
    velocities, accelerations : (N, S, n_out, 2) of the vertices asked for (see :func:`solve_forces`).
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


def solve_forces(mech, plan: Plan, P: np.ndarray, status: np.ndarray, des, lengths: np.ndarray, scale: np.ndarray,
                 body_pts: list, operating, walker, joints=(), members: bool = False, out_idx=None,
                 velocities: bool = False, accelerations: bool = False) -> Forces:
    """The forces effect of N variants from their positions P (N, S, n_vertices, 2), model units.

    status (N,) (only 0 = ok rows are computed); des: the variants' ``_inputs.Designs`` (uv, centre);
    lengths (N, n_links) and scale (N,) crank radii, model units; body_pts: each body's joints in its
    frame (N, n_joints, 2) (``_design.body_points``); operating: :class:`~explorer.mechanism.Operating`
    with ``unit`` and ``rpm``; walker: :class:`~explorer.mechanism.Walker` (one leg: ``Walker(legs=1)``);
    joints: names of the joints whose reactions are returned; members: also every member's force on
    every pin (``Forces.members``); velocities, accelerations: also those of the vertices ``out_idx``
    (per radian and per radian², ``Forces.velocities`` / ``accelerations`` (N, S, n_out, 2)), from
    the same block-by-block linear solves the forces use.
    """
    from ._rows import parallel_rows

    key = (id(plan), mech.foot, mech.vertices)
    tb = _TABLES.get(key)
    if tb is None or tb[0] is not plan:
        tb = _TABLES[key] = (plan, force_tables(mech, plan))
    tb = tb[1]
    N, S, nv = P.shape[0], P.shape[1], P.shape[2]
    unit = float(operating.unit)
    nl = len(mech.links)
    density = mech.link_density or 0.0
    link_mass = np.empty((N, nl))
    for e, lk in enumerate(mech.links):
        link_mass[:, e] = lk.mass if lk.mass is not None else density * lengths[:, e] * unit
    cm = mech.crank.mass
    crank_mass = np.full(N, cm) if cm is not None else density * np.asarray(scale, dtype=np.float64) * unit
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
    moving = body == "moving"
    torque = np.zeros((N, S))
    body_acc = np.zeros((N, S, 2))
    ground = np.zeros((N, S, 2))
    contact = np.full((N, S), -1, dtype=np.int64)
    fsel = np.zeros((N, S, len(sel), 2))
    finc = np.zeros((N, S if members else 0, len(tb.inc_vertex), 2))
    out_idx = np.zeros(0, dtype=np.int64) if out_idx is None else np.asarray(out_idx, dtype=np.int64)
    vout = np.full((N, S if velocities else 0, len(out_idx), 2), np.nan)
    aout = np.full((N, S if accelerations else 0, len(out_idx), 2), np.nan)
    pin_peak = np.zeros((N, nv))
    shake = np.zeros(N)
    travel = np.zeros(N)
    code = np.zeros(N, dtype=np.int64)
    csample = np.full(N, -1, dtype=np.int64)
    cblock = np.full(N, -1, dtype=np.int64)
    shared = (tb.blk_kind, tb.blk_v, tb.blk_e, tb.blk_vp, tb.blk_verts, tb.blk_rp, tb.gen_rows,
              tb.dist_a, tb.dist_b, tb.att, tb.inc_vertex, tb.dinc, tb.ainc, tb.body_pq, tb.body_inc, body_mass,
              tb.tip, tb.tip_inc, tb.fixed, tb.fixed_inc, tb.foot, tb.foot_inc, sel, base, frac, sign, mirrored,
              float(walker.drag), unit, float(operating.omega), float(operating.gravity), weight, out_idx, tb.slide,
              tb.sinc, moving, float(operating.load))
    rows = (np.ascontiguousarray(P), np.ascontiguousarray(status), des.uv, des.slide, des.center, link_mass, body_cuv,
            body_J,
            crank_mass, torque, fsel, finc, vout, aout, pin_peak, shake, travel, code, csample, cblock, body_acc,
            ground, contact)
    kernel = forces_any if np.any(tb.blk_kind == GENERAL) else forces_fast
    parallel_rows(kernel, shared, rows)
    bad = (code != F_OK) | (status != 0)
    torque[bad] = np.nan
    body_acc[bad] = np.nan
    ground[bad] = np.nan
    contact[bad] = -1
    fsel[bad] = np.nan
    pin_peak[bad] = np.nan
    shake[bad] = np.nan
    travel[bad] = np.nan
    member_forces = {}
    if members:
        finc[bad] = np.nan
        member_forces = {(m, mech.vertices[v]): finc[:, :, k] for k, (m, v) in enumerate(zip(tb.inc_member,
                                                                                               tb.inc_vertex))}
    # the whole machine: every leg with its crank, and the body
    machine = walker.legs * (link_mass.sum(axis=1) + body_mass.sum() + crank_mass) + float(operating.load)
    return Forces(torque, {j: fsel[:, :, k] for k, j in enumerate(joints)}, pin_peak, shake, travel, code, csample,
                  cblock, member_forces, vout, aout, body, body_acc, ground, contact, machine, has_mass(mech, operating))


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
    leg and the body); cost_of_transport = energy_per_turn / (machine_mass·g·travel·unit).
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
            out["cost_of_transport"] = out["energy_per_turn"] / (out["machine_mass"] * operating.gravity
                                                                 * forces.travel * float(operating.unit))
        for k, v in enumerate(vertices):
            out[f"pin_force.{v}"] = forces.pin_peak[:, k].copy()
    return out
