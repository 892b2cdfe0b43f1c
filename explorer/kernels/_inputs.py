"""The kernels' named inputs: what one topology, one driver, one set of options, N designs and their
outputs are, as named tuples of arrays (Numba compiles attribute access on them to plain loads).

* :class:`Topology` — one plan, restricted to the blocks a study needs (shared by every variant).
* :class:`Drive` — the driver sampled at the study's steps (shared).
* :class:`Options` — the solve options (shared).
* :class:`Designs` — the per-variant numbers (N rows), derived from the design parameters by
  ``_design.designs``.
* :class:`Outputs` — the per-variant results (N rows), written in place.

The per-variant *block table* (:data:`BLOCK_DTYPE`) is a record array with one row per block, in
plan order: a block's kind and the numbers its kernel reads, by name (``_step.block_table``).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..plan import ATTACH, DYAD, GENERAL, ROW_ATTACH_X, ROW_ATTACH_Y, ROW_DIST, ROW_SLIDE, SLIDE, Plan

Topology = namedtuple("Topology", [
    "kind",       # (nb,) int64, each block's kind (plan._kinds), in solve order
    "dyad",       # (nb, 5) int64, a DYAD block's vertex, parents a and b, and distance equations to a and b
    "join",       # (nb,) int64, a DYAD: the distance equation joining its parents (their distance is then
                  # constant), −2 if they are the crank tip and a fixed vertex, −1 otherwise
    "attach",     # (nb,) int64, an ATTACH block's attach equation (index into att_vpq), else −1
    "gen",        # (nb,) int64, a GENERAL block's index into gen_vptr / gen_rptr, else −1
    "gen_vptr",   # (n_general + 1,) int64, CSR pointers into gen_verts
    "gen_verts",  # int64, the vertices of each GENERAL block
    "gen_rptr",   # (n_general + 1,) int64, CSR pointers into gen_rows
    "gen_rows",   # (n_rows, 2) int64, each row's type (ROW_DIST / ROW_ATTACH_X / ROW_ATTACH_Y / ROW_SLIDE) and equation
    "dist_a",     # (n_dist,) int64, first vertex of each distance equation (links, then body base pairs)
    "dist_b",     # (n_dist,) int64, second vertex
    "att_vpq",    # (n_attach, 3) int64, joint, base p, base q of each attach equation
    "tip",        # int, the driven vertex (crank tip)
    "fixed",      # (n_fixed,) int64, the fixed vertices
    "moving",     # int64, vertices whose state the sweep carries from step to step
    "out_idx",    # (n_out,) int64, the vertices written to the outputs, in output order
    "slid",       # (nb, 4) int64, a SLIDE block's vertex, the known vertex it keeps its distance to, that
                  # distance equation and its slide equation (index into ``slide``), else −1
    "slide",      # (n_slide, 3) int64, slider vertex p and line vertices a, b of each slide equation
                  # (a = b = −1: a ground line)
])

Drive = namedtuple("Drive", [
    "kind",       # int, CRANK / LINE / ARC / SPLINE (``_drive``)
    "prm",        # float64, the driver's parameters (``_drive``)
    "table",      # (S, 6) float64, unit position, velocity, acceleration at each sample
    "params",     # (S,) float64, the sample parameters (crank angle rad, or time s)
    "t_end",      # float, 2π for a crank, the duration for a path
    "closed",     # bool, a crank (periodic) rather than a path
])

Options = namedtuple("Options", [
    "method",     # int, BLOCK or DENSE (``_step``)
    "maxit",      # int, Newton iterations per block and step
    "want_vel",   # bool, store velocities
    "want_acc",   # bool, store accelerations
])

Designs = namedtuple("Designs", [
    "dist",       # (N, n_dist) float64, length of each distance equation (links, then body base pairs);
                  # NaN marks a design that is invalid (non-finite or out-of-range parameters)
    "uv",         # (N, n_attach, 2) float64, (u, v) of each attach equation
    "fixed",      # (N, n_fixed, 2) float64, the fixed vertices' positions
    "center",     # (N, 2) float64, the crank centre (0 for a path driver)
    "scale",      # (N,) float64, the crank radius (1 for a path driver)
    "tol",        # (N,) float64, Newton's stopping distance, model units
    "slide",      # (N, n_slide, 6) float64, each slide equation's line: a ground line's point (x, y) and
                  # unit direction (nx, ny), then the offset and the slot's length |b − a| (1 for a ground line)
])

Outputs = namedtuple("Outputs", [
    "pos",        # (N, S, n_out, 2) float64, positions (NaN where not reached)
    "vel",        # (N, S or 0, n_out, 2) float64, velocities per unit of driver parameter
    "acc",        # (N, S or 0, n_out, 2) float64, accelerations
    "status",     # (N,) int8, STATUS_* codes
    "fail_t",     # (N,) float64, where a sweep failed (NaN when ok)
    "fail_end",   # (N,) float64, the other end of an unreachable crank range (NaN)
    "fail_block", # (N,) int64, the failing block (−1)
    "iters",      # (N,) int64, Newton iterations
])

#: One row per block of the per-variant block table (``_step.block_table``): its kind and, for the
#: closed-form kinds, the numbers its kernel reads. DYAD: vertex, parents a, b, squared lengths to
#: them, the squared limits of their distance (hi2 = (da+db)², lo2 = (da−db)²), the squared largest
#: move per step, and whether the between-sample gap check is needed. ATTACH: vertex (the joint),
#: a, b (the base pair), u, v. GENERAL: ``slot`` indexes ``Topology.gen_vptr``. SLIDE: vertex, a (= b)
#: the known vertex at distance √da2, hi2 = da2 and lo2 = −da2 (the limits of the squared distance
#: from a to the vertex's line), lim2, then its slide equation: slider vertex sp, line vertices sa, sb
#: (−1: ground), which of them the block places (role 0, 1, 2), and the line's numbers (``Designs.slide``:
#: lx, ly, nx, ny, off, sl).
BLOCK_DTYPE = np.dtype([
    ("kind", np.int64), ("vertex", np.int64), ("a", np.int64), ("b", np.int64), ("slot", np.int64),
    ("da2", np.float64), ("db2", np.float64), ("hi2", np.float64), ("lo2", np.float64), ("lim2", np.float64),
    ("gap", np.int64), ("u", np.float64), ("v", np.float64),
    ("sp", np.int64), ("sa", np.int64), ("sb", np.int64), ("role", np.int64),
    ("lx", np.float64), ("ly", np.float64), ("nx", np.float64), ("ny", np.float64), ("off", np.float64),
    ("sl", np.float64),
], align=True)


def _other(plan: Plan, e: int, v: int) -> int:
    return int(plan.link_b[e] if plan.link_a[e] == v else plan.link_a[e])


def topology(plan: Plan, blocks, moving, out_idx, crank: bool) -> Topology:
    """The :class:`Topology` of ``plan`` restricted to ``blocks`` (indices in solve order)."""
    nb = len(blocks)
    kind = np.array([plan.blocks[k].kind for k in blocks], dtype=np.int64)
    dyad = np.full((nb, 5), -1, dtype=np.int64)
    join = np.full(nb, -1, dtype=np.int64)
    attach = np.full(nb, -1, dtype=np.int64)
    gen = np.full(nb, -1, dtype=np.int64)
    slid = np.full((nb, 4), -1, dtype=np.int64)
    gv, gr, vptr, rptr = [], [], [0], [0]
    fixed = set(plan.fixed.tolist())
    pairs = {frozenset((int(a), int(b))): e for e, (a, b) in enumerate(zip(plan.link_a, plan.link_b))}
    for i, k in enumerate(blocks):
        blk = plan.blocks[k]
        if blk.kind == DYAD:
            v = blk.vertices[0]
            la, lb = blk.links
            pa, pb = _other(plan, la, v), _other(plan, lb, v)
            dyad[i] = (v, pa, pb, la, lb)
            if frozenset((pa, pb)) in pairs:
                join[i] = pairs[frozenset((pa, pb))]
            elif crank and plan.tip in (pa, pb) and ({pa, pb} - {plan.tip}) <= fixed:
                join[i] = -2
        elif blk.kind == ATTACH:
            attach[i] = blk.attaches[0][0]
        elif blk.kind == SLIDE:
            v = blk.vertices[0]
            slid[i] = (v, _other(plan, blk.links[0], v), blk.links[0], blk.slides[0])
        else:
            gen[i] = len(vptr) - 1
            gv.extend(blk.vertices)
            gr.extend((ROW_DIST, e) for e in blk.links)
            gr.extend((ROW_ATTACH_X if ax == 0 else ROW_ATTACH_Y, t) for t, ax in blk.attaches)
            gr.extend((ROW_SLIDE, t) for t in blk.slides)
            vptr.append(len(gv))
            rptr.append(len(gr))
    assert all(int(kd) in (DYAD, ATTACH, GENERAL, SLIDE) for kd in kind)
    return Topology(kind, dyad, join, attach, gen, np.array(vptr, dtype=np.int64), np.array(gv, dtype=np.int64),
                    np.array(rptr, dtype=np.int64), np.array(gr, dtype=np.int64).reshape(-1, 2),
                    plan.link_a, plan.link_b, plan.attach, int(plan.tip), plan.fixed,
                    np.asarray(moving, dtype=np.int64), np.asarray(out_idx, dtype=np.int64), slid,
                    np.ascontiguousarray(plan.slide, dtype=np.int64).reshape(-1, 3))

