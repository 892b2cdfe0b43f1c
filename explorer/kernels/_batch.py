"""The batch kernels: N variants through the sweep driver, and each variant's setup.

:func:`setup` runs once per chunk of variants, before any sweep: for each variant, its block table
(each block's numbers, filled by its kind) and its start (the design assembled at the first sample on
the nominal's branch by the closed form). It is one compiled function for every topology (the
lowered plan and the block table are arrays), so the kernels generated per topology do not compile
it again, and a cache built once serves every plan.

For every row they are handed, the batch kernels check the variant's lengths and run
:func:`~._sweep.sweep` (and, with forces, the forces effect), serially and without the GIL:
:func:`~._rows.parallel_rows` runs them in parallel over blocks of rows. Their per-design loop is
written once, ``_sweep_template.batch``, rendered in the array form (``_batch_array.py``): around
the table-driven sweep, and around the resumable sweep and a topology's generated loop of whole steps
(``whole_batch_jit``, ``whole_forces_jit``: ``_codegen``).
"""

import types

import numpy as np
from numba import njit

from . import _batch_array
from ._drive import CRANK
from ._forces import design_forces_any, design_forces_fast
from ._kinds_array import block_table, place_closed
from ._rows import parallel_rows
from ._step import generic_context
from ._sweep import fast_sweep, fast_sweep_resumable, generic_sweep
from ._sweep_template import MAX_LENGTH, MIN_LENGTH, valid_lengths  # noqa: F401 (the kernels' length range)


@njit(cache=True, nogil=True)
def setup_jit(topo, d0, P_init, signs, crank, designs):
    """Each valid design's (row's) block table and start into ``designs.table`` and ``designs.start``.

    The start is the design assembled at the first sample (driver values d0, (6,)) on the nominal's
    branch of every block (``signs``), by the closed form (``_kinds_array.place_closed``): Newton's
    first solve then starts at the root it must keep, wherever the design's dimensions put it. (Started
    from the nominal's configuration, a design far from it could converge to the mirror root and be
    reported as a branch failure although it assembles on the nominal's branch.) Vertices the closed
    form cannot place (beyond a coupled block, or where the design cannot assemble) keep the nominal's
    positions P_init, and Newton starts there; fixed vertices are the design's own."""
    fixed = topo.fixed
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            continue
        P = designs.start[i]
        for v in range(P.shape[0]):
            P[v, 0] = P_init[v, 0]
            P[v, 1] = P_init[v, 1]
        for f in range(fixed.shape[0]):
            P[fixed[f], 0] = designs.fixed[i, f, 0]
            P[fixed[f], 1] = designs.fixed[i, f, 1]
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        tab = designs.table[i]
        block_table(tab, topo.kind, topo.blk, topo.tip, L, designs.uv[i], designs.slide[i], designs.extra[i],
                    topo.att_vpq, topo.slide, P, cx, cy, scale, crank)
        place_closed(tab, topo.tip, cx, cy, scale, d0, signs, P, True)


def setup(plan, blocks, topo, drv, P_init, signs, des):
    """``des`` (``_inputs.Designs``) with its block tables, starts and closing-check scales filled
    (see :func:`setup_jit`). The closing check's scale (``Designs.shortest``) is the shortest distance
    equation among the rows of the blocks solved (their links and body base pairs), or, for blocks
    without one, the design's shortest distance equation."""
    rows = sorted({e for b in blocks for e in plan.blocks[b].links})
    L = des.dist
    with np.errstate(invalid="ignore"):
        shortest = (L[:, rows] if rows else L).min(axis=1, initial=np.inf) if L.shape[1] else np.full(L.shape[0], np.inf)
    des = des._replace(shortest=np.ascontiguousarray(shortest))
    parallel_rows(setup_jit, (topo, drv.table[0], P_init, signs, drv.kind == CRANK), (des,))
    return des


@njit(cache=True, inline="always")
def table_context(opts, topo, designs, i, known):
    """The fast step's context: design i's block table."""
    return designs.table[i]


@njit(cache=True)
def generic_context_of(opts, topo, designs, i, known):
    """The generic step's context of design i (``_step.generic_context``)."""
    return generic_context(opts.method, designs.table[i], topo.gen_vptr, topo.gen_verts, topo.gen_rptr, topo.gen_rows,
                           topo.dist_a, topo.dist_b, topo.att_vpq, designs.dist[i], designs.uv[i], known,
                           designs.fixed[i], topo.slide, designs.slide[i], topo.explicit)


def _specialise(fn, name: str, **bind):
    """Jit a copy of the batch loop ``fn`` (``_batch_array``) with its globals bound: each copy compiles
    (and caches) only what it calls."""
    env = dict(fn.__globals__, **bind)
    copy = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
    copy.__qualname__ = f"{fn.__name__}_{name}"
    copy.__doc__ = fn.__doc__
    return njit(cache=True, nogil=True)(copy)


#: Every design (row) of ``designs`` through the sweep with the fast step (plans without coupled
#: blocks) or the generic one (any plan; the block or dense method), serially, writing ``outs`` in place
#: (``_sweep_template.batch``: arguments (topo, drv, opts, signs, designs, outs), the per-row ones last,
#: for ``_rows.parallel_rows``); the ``*_forces`` ones also compute the forces effect (arguments
#: (..., fmodel, frows)).
fast_batch_jit = _specialise(_batch_array.batch_plain, "fast", run_sweep=fast_sweep, make_context=table_context)
generic_batch_jit = _specialise(_batch_array.batch_plain, "generic", run_sweep=generic_sweep,
                                make_context=generic_context_of)
fast_forces_jit = _specialise(_batch_array.batch_forces, "fast", run_sweep=fast_sweep, make_context=table_context,
                              design_forces=design_forces_fast)
generic_forces_jit = _specialise(_batch_array.batch_forces, "generic", run_sweep=generic_sweep,
                                 make_context=generic_context_of, design_forces=design_forces_any)
#: The batch loop around a topology's generated loop of whole steps (``_codegen``; arguments as
#: ``fast_batch_jit``'s and ``fast_forces_jit``'s, then ``whole``, that loop as a first-class function):
#: compiled once for every topology.
whole_batch_jit = _specialise(_batch_array.batch_whole_plain, "whole", run_resumable=fast_sweep_resumable)
whole_forces_jit = _specialise(_batch_array.batch_whole_forces, "whole", run_resumable=fast_sweep_resumable,
                               design_forces=design_forces_fast)


_WHOLE_FORCES: dict = {}  # generated module name -> its forces batch loop


def whole_forces_with(name: str, design_forces):
    """The forces batch loop around a topology's generated loop of whole steps (``whole_forces_jit``'s
    arguments) with ``design_forces``, the forces effect with a base leg generated for the topology and
    its members (``_forces.design_forces_with``), in place of ``_forces.design_forces_fast``: jitted
    (and cached) under the generated module's ``name``, once per process."""
    fn = _WHOLE_FORCES.get(name)
    if fn is None:
        fn = _WHOLE_FORCES[name] = _specialise(_batch_array.batch_whole_forces, f"whole_{name}",
                                               run_resumable=fast_sweep_resumable, design_forces=design_forces)
    return fn
