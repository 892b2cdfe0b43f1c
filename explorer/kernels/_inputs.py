"""The kernels' named inputs: what one topology, one driver, one set of options, N designs and their
outputs are, as named tuples of arrays (Numba compiles attribute access on them to plain loads).

* :class:`Topology` — one plan, restricted to the blocks a study needs (shared by every variant).
* :class:`Drive` — the driver sampled at the study's steps (shared).
* :class:`Options` — the solve options (shared).
* :class:`Designs` — the per-variant numbers (N rows), derived from the design parameters by
  ``_design.designs``.
* :class:`Outputs` — the per-variant results (N rows), written in place.

The per-variant *block table* (:data:`BLOCK_DTYPE`) is a record array with one row per block, in
plan order: a block's kind and the numbers its kind reads, by name (each kind fills its own row:
``_kinds_array.block_table``).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..kinds import KINDS
from ..plan import Plan

Topology = namedtuple("Topology", [
    "kind",       # (nb,) int64, each block's kind (``explorer.kinds``), in solve order
    "blk",        # (nb, BLK_COLUMNS) int64, each block's row of the lowered plan: its kind's COLUMNS
                  # (a dyad's vertex, parents, equations and join; a body joint's base pair; ...), −1 after
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
    "slide",      # (n_slide, 3) int64, slider vertex p and line vertices a, b of each slide equation
                  # (a = b = −1: a ground line)
    "explicit",   # (n_explicit,) int64, the blocks whose kind places its vertex from the driver alone
                  # (``EXPLICIT``: a geared crank's tip); the dense method takes their vertices as known
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
    "extra",      # (N, n_extra) float64, the per-design numbers of the equation types beyond these
                  # (``explorer.kinds.extra_columns``: a geared crank's centre, radius, phase)
    "table",      # (N, nb) BLOCK_DTYPE, each design's block table (``_batch.setup``)
    "start",      # (N, n_vertices, 2) float64, each design's start: assembled at the first sample on the
                  # nominal's branch by the closed form where it can be (``_batch.setup``)
    "shortest",   # (N,) float64, the scale of the sweep's closing check (``_batch.setup``)
    "restart_at", # (N, 2) int64, the samples where the sweep resumes forward and backward (0: none): where the
                  # vectorised first pass (``_vector``) left off, its samples before (after) solved exactly
    "restart_pos",# (N, 2 or 0, n_vertices, 2) float64, the first pass's configurations at those samples
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

def _block_dtype() -> np.dtype:
    """The union of every kind's FIELDS (``explorer.kinds``), after the kind and the GENERAL slot."""
    fields = {"kind": "i8"}
    for k in KINDS:
        for name, dt in k.FIELDS:
            if fields.setdefault(name, dt) != dt:
                raise TypeError(f"block table field {name!r}: {k.NAME} wants {dt}, another kind {fields[name]}")
    return np.dtype([(n, np.dtype(dt)) for n, dt in fields.items()], align=True)


#: One row per block of the per-variant block table (``_batch.setup``): its kind and the numbers its
#: kind reads, by name: the union of the kinds' ``FIELDS`` (``explorer.kinds``).
BLOCK_DTYPE = _block_dtype()
#: Columns of ``Topology.blk``: the widest kind's.
BLK_COLUMNS = max(len(k.COLUMNS) for k in KINDS)


def topology(plan: Plan, blocks, moving, out_idx, crank: bool) -> Topology:
    """The :class:`Topology` of ``plan`` restricted to ``blocks`` (indices in solve order): each block
    lowered by its kind (``lower``), the coupled blocks' rows in CSR tables."""
    nb = len(blocks)
    kind = np.array([plan.blocks[k].kind for k in blocks], dtype=np.int64)
    blk = np.full((nb, BLK_COLUMNS), -1, dtype=np.int64)
    shared: dict = {}
    for i, k in enumerate(blocks):
        b = plan.blocks[k]
        row = KINDS[b.kind].lower(plan, b, crank, shared)
        blk[i, :len(row)] = row
    vptr, gv, rptr, gr = shared.get("gen", ([0], [], [0], []))  # the coupled blocks' CSR tables (kinds.general)
    explicit = [i for i, k in enumerate(blocks) if getattr(KINDS[plan.blocks[k].kind], "EXPLICIT", False)]
    return Topology(kind, blk, np.array(vptr, dtype=np.int64), np.array(gv, dtype=np.int64),
                    np.array(rptr, dtype=np.int64), np.array(gr, dtype=np.int64).reshape(-1, 2),
                    plan.link_a, plan.link_b, plan.attach, int(plan.tip), plan.fixed,
                    np.asarray(moving, dtype=np.int64), np.asarray(out_idx, dtype=np.int64),
                    np.ascontiguousarray(plan.slide, dtype=np.int64).reshape(-1, 3), np.array(explicit, dtype=np.int64))
