"""The batch loop's array form: rendered from ``_sweep_template.batch`` by ``_sweep.batch_module_source``; do not edit.

Edit the template (``_sweep_template.batch``) or the dialect (``_sweep.batch_array_dialect``), then
rewrite this file: ``python -c "from explorer.kernels import _sweep; _sweep.write_array_module()"``
(tests/test_sweep_template.py fails while it differs from a fresh rendering). ``_batch`` jits copies
of :func:`batch_plain` and :func:`batch_forces` with the globals ``run_sweep``, ``make_context`` and
``design_forces`` bound.
"""

import numpy as np

from ._forces import force_scratch
from ._sweep import sweep_scratch
from ._sweep_template import STATUS_OK, invalid_design, valid_lengths

# Bound in each jitted copy (``_batch``): the sweep, the step's context of design i, the forces effect,
# the resumable sweep.
run_sweep = None
make_context = None
design_forces = None
run_resumable = None


def batch_plain(topo, drv, opts, signs, designs, outs):
    """Every design (row) of ``designs`` through the sweep, serially, writing ``outs`` in place (and,
    with forces, the forces effect of each design into ``frows``): the one per-design loop of every
    sweep kernel, rendered calling the sweep (the array form), or calling the resumable sweep and a
    topology's generated loop of whole steps by turns (``_sweep.batch_whole_dialect``).

    topo, drv, opts, designs, outs: the ``_inputs`` named tuples (``designs`` set up by
    ``_batch.setup``); signs (n_blocks,): the nominal's branch of each block; fmodel, frows: the
    forces effect's shared inputs and per-row inputs and outputs (``_forces.ForceModel`` and
    ``ForceRows``; without forces the kernel takes neither). The per-row arguments come last
    (``designs``, ``outs``, ``frows``), for ``_rows.parallel_rows``. A design with a length outside the valid range is
    "invalid", its rows NaN. With forces (section ``forces``) the sweep stores every vertex's
    position, tangent and second derivative in per-design scratch, the forces effect reads them
    there when the design is ok, and the requested rows (``fmodel.out_idx``) are copied out: a forces
    study holds no position array it does not store.
    """
    nf_ = topo.fixed.shape[0]
    known = np.empty(nf_ + 1 + topo.explicit.shape[0], dtype=np.int64)
    known[0] = topo.tip
    for f_ in range(nf_):
        known[f_ + 1] = topo.fixed[f_]
    for f_ in range(topo.explicit.shape[0]):  # an explicit block's vertex: its first column
        known[nf_ + 1 + f_] = topo.blk[topo.explicit[f_], 0]
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            invalid_design(outs, i)
            continue
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        shortest = designs.shortest[i]
        tol = designs.tol[i]
        out_pos = outs.pos[i]
        out_vel = outs.vel[i]
        out_acc = outs.acc[i]
        status, fail_t, fail_end, fail_block, iters = run_sweep(
            make_context(opts, topo, designs, i, known), topo, drv, opts, designs.start[i], designs.restart_at[i],
            designs.restart_pos[i], signs, cx, cy, scale, shortest, tol, out_pos, out_vel, out_acc)
        outs.status[i] = status
        outs.fail_t[i] = fail_t
        outs.fail_end[i] = fail_end
        outs.fail_block[i] = fail_block
        outs.iters[i] = iters


def batch_forces(topo, drv, opts, signs, fmodel, designs, outs, frows):
    """Every design (row) of ``designs`` through the sweep, serially, writing ``outs`` in place (and,
    with forces, the forces effect of each design into ``frows``): the one per-design loop of every
    sweep kernel, rendered calling the sweep (the array form), or calling the resumable sweep and a
    topology's generated loop of whole steps by turns (``_sweep.batch_whole_dialect``).

    topo, drv, opts, designs, outs: the ``_inputs`` named tuples (``designs`` set up by
    ``_batch.setup``); signs (n_blocks,): the nominal's branch of each block; fmodel, frows: the
    forces effect's shared inputs and per-row inputs and outputs (``_forces.ForceModel`` and
    ``ForceRows``; without forces the kernel takes neither). The per-row arguments come last
    (``designs``, ``outs``, ``frows``), for ``_rows.parallel_rows``. A design with a length outside the valid range is
    "invalid", its rows NaN. With forces (section ``forces``) the sweep stores every vertex's
    position, tangent and second derivative in per-design scratch, the forces effect reads them
    there when the design is ok, and the requested rows (``fmodel.out_idx``) are copied out: a forces
    study holds no position array it does not store.
    """
    nf_ = topo.fixed.shape[0]
    known = np.empty(nf_ + 1 + topo.explicit.shape[0], dtype=np.int64)
    known[0] = topo.tip
    for f_ in range(nf_):
        known[f_ + 1] = topo.fixed[f_]
    for f_ in range(topo.explicit.shape[0]):  # an explicit block's vertex: its first column
        known[nf_ + 1 + f_] = topo.blk[topo.explicit[f_], 0]
    fs = force_scratch(drv.table.shape[0], designs.start.shape[1], fmodel, topo)
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            invalid_design(outs, i)
            continue
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        shortest = designs.shortest[i]
        tol = designs.tol[i]
        out_pos = fs.pos
        out_vel = fs.vel
        out_acc = fs.acc
        status, fail_t, fail_end, fail_block, iters = run_sweep(
            make_context(opts, topo, designs, i, known), topo, drv, opts, designs.start[i], designs.restart_at[i],
            designs.restart_pos[i], signs, cx, cy, scale, shortest, tol, out_pos, out_vel, out_acc)
        if status == STATUS_OK:
            design_forces(i, designs.table[i], topo, designs.uv[i], designs.slide[i], cx, cy, fmodel, frows, fs)
        # the requested rows of the scratch, as the plain sweep stores them
        oi = fmodel.out_idx
        for r_ in range(outs.pos.shape[1]):
            for j_ in range(oi.shape[0]):
                v_ = oi[j_]
                outs.pos[i, r_, j_, 0] = fs.pos[r_, v_, 0]
                outs.pos[i, r_, j_, 1] = fs.pos[r_, v_, 1]
        for r_ in range(outs.vel.shape[1]):
            for j_ in range(oi.shape[0]):
                v_ = oi[j_]
                outs.vel[i, r_, j_, 0] = fs.vel[r_, v_, 0]
                outs.vel[i, r_, j_, 1] = fs.vel[r_, v_, 1]
        for r_ in range(outs.acc.shape[1]):
            for j_ in range(oi.shape[0]):
                v_ = oi[j_]
                outs.acc[i, r_, j_, 0] = fs.acc[r_, v_, 0]
                outs.acc[i, r_, j_, 1] = fs.acc[r_, v_, 1]
        outs.status[i] = status
        outs.fail_t[i] = fail_t
        outs.fail_end[i] = fail_end
        outs.fail_block[i] = fail_block
        outs.iters[i] = iters


def batch_whole_plain(topo, drv, opts, signs, designs, outs, whole):
    """Every design (row) of ``designs`` through the sweep, serially, writing ``outs`` in place (and,
    with forces, the forces effect of each design into ``frows``): the one per-design loop of every
    sweep kernel, rendered calling the sweep (the array form), or calling the resumable sweep and a
    topology's generated loop of whole steps by turns (``_sweep.batch_whole_dialect``).

    topo, drv, opts, designs, outs: the ``_inputs`` named tuples (``designs`` set up by
    ``_batch.setup``); signs (n_blocks,): the nominal's branch of each block; fmodel, frows: the
    forces effect's shared inputs and per-row inputs and outputs (``_forces.ForceModel`` and
    ``ForceRows``; without forces the kernel takes neither). The per-row arguments come last
    (``designs``, ``outs``, ``frows``), for ``_rows.parallel_rows``. A design with a length outside the valid range is
    "invalid", its rows NaN. With forces (section ``forces``) the sweep stores every vertex's
    position, tangent and second derivative in per-design scratch, the forces effect reads them
    there when the design is ok, and the requested rows (``fmodel.out_idx``) are copied out: a forces
    study holds no position array it does not store.
    """
    maxit = opts.maxit
    T = drv.table
    d, P0, V0, Vp, A0, P1, V1, A1, P_first, V_first, A_first, si, sf = sweep_scratch(designs.start.shape[1])
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            invalid_design(outs, i)
            continue
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        shortest = designs.shortest[i]
        tol = designs.tol[i]
        out_pos = outs.pos[i]
        out_vel = outs.vel[i]
        out_acc = outs.acc[i]
        tab = designs.table[i]
        si[0] = 0
        while True:
            more, status, fail_t, fail_end, fail_block, iters = run_resumable(
                tab, topo, drv, opts, designs.start[i], designs.restart_at[i], designs.restart_pos[i], signs, cx, cy,
                scale, shortest, tol, out_pos, out_vel, out_acc, P0, V0, Vp, A0, P1, V1, A1, P_first, V_first, A_first,
                d, si, sf)
            if more == 0:
                break
            whole(T, designs.start[i], tab, signs, cx, cy, scale, tol, maxit, out_pos, out_vel, out_acc, P0, V0, Vp,
                  A0, si, sf)
        outs.status[i] = status
        outs.fail_t[i] = fail_t
        outs.fail_end[i] = fail_end
        outs.fail_block[i] = fail_block
        outs.iters[i] = iters


def batch_whole_forces(topo, drv, opts, signs, fmodel, designs, outs, frows, whole):
    """Every design (row) of ``designs`` through the sweep, serially, writing ``outs`` in place (and,
    with forces, the forces effect of each design into ``frows``): the one per-design loop of every
    sweep kernel, rendered calling the sweep (the array form), or calling the resumable sweep and a
    topology's generated loop of whole steps by turns (``_sweep.batch_whole_dialect``).

    topo, drv, opts, designs, outs: the ``_inputs`` named tuples (``designs`` set up by
    ``_batch.setup``); signs (n_blocks,): the nominal's branch of each block; fmodel, frows: the
    forces effect's shared inputs and per-row inputs and outputs (``_forces.ForceModel`` and
    ``ForceRows``; without forces the kernel takes neither). The per-row arguments come last
    (``designs``, ``outs``, ``frows``), for ``_rows.parallel_rows``. A design with a length outside the valid range is
    "invalid", its rows NaN. With forces (section ``forces``) the sweep stores every vertex's
    position, tangent and second derivative in per-design scratch, the forces effect reads them
    there when the design is ok, and the requested rows (``fmodel.out_idx``) are copied out: a forces
    study holds no position array it does not store.
    """
    maxit = opts.maxit
    T = drv.table
    d, P0, V0, Vp, A0, P1, V1, A1, P_first, V_first, A_first, si, sf = sweep_scratch(designs.start.shape[1])
    fs = force_scratch(drv.table.shape[0], designs.start.shape[1], fmodel, topo)
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            invalid_design(outs, i)
            continue
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        shortest = designs.shortest[i]
        tol = designs.tol[i]
        out_pos = fs.pos
        out_vel = fs.vel
        out_acc = fs.acc
        tab = designs.table[i]
        si[0] = 0
        while True:
            more, status, fail_t, fail_end, fail_block, iters = run_resumable(
                tab, topo, drv, opts, designs.start[i], designs.restart_at[i], designs.restart_pos[i], signs, cx, cy,
                scale, shortest, tol, out_pos, out_vel, out_acc, P0, V0, Vp, A0, P1, V1, A1, P_first, V_first, A_first,
                d, si, sf)
            if more == 0:
                break
            whole(T, designs.start[i], tab, signs, cx, cy, scale, tol, maxit, out_pos, out_vel, out_acc, P0, V0, Vp,
                  A0, si, sf)
        if status == STATUS_OK:
            design_forces(i, designs.table[i], topo, designs.uv[i], designs.slide[i], cx, cy, fmodel, frows, fs)
        # the requested rows of the scratch, as the plain sweep stores them
        oi = fmodel.out_idx
        for r_ in range(outs.pos.shape[1]):
            for j_ in range(oi.shape[0]):
                v_ = oi[j_]
                outs.pos[i, r_, j_, 0] = fs.pos[r_, v_, 0]
                outs.pos[i, r_, j_, 1] = fs.pos[r_, v_, 1]
        for r_ in range(outs.vel.shape[1]):
            for j_ in range(oi.shape[0]):
                v_ = oi[j_]
                outs.vel[i, r_, j_, 0] = fs.vel[r_, v_, 0]
                outs.vel[i, r_, j_, 1] = fs.vel[r_, v_, 1]
        for r_ in range(outs.acc.shape[1]):
            for j_ in range(oi.shape[0]):
                v_ = oi[j_]
                outs.acc[i, r_, j_, 0] = fs.acc[r_, v_, 0]
                outs.acc[i, r_, j_, 1] = fs.acc[r_, v_, 1]
        outs.status[i] = status
        outs.fail_t[i] = fail_t
        outs.fail_end[i] = fail_end
        outs.fail_block[i] = fail_block
        outs.iters[i] = iters
