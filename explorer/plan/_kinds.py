"""The block kinds of a plan: what each one is, and where each one lives.

A plan (``_blt``) cuts a linkage's equations into blocks solved one after another. Every block has
one kind; the kind decides how the kernels place its vertices:

========  ==============================================================  ===========================
kind      a block that ...                                                kernels (``explorer.kernels``)
========  ==============================================================  ===========================
DYAD      places one vertex by two distance equations to known vertices   ``_fast``: circle–circle
          (two links, or a link and a body's pair): Newton on a 2x2        Newton, branch = the sign of
          system, or the closed form                                       the 2x2 determinant
ATTACH    places one joint of a rigid body whose base pair of joints is   ``_fast``: a rigid
          known: exactly, by the body's rigid transform (no Newton, no    transform, exact (no branch,
          branch: a body never mirrors)                                    no failure)
GENERAL   couples several vertices (an Assur triad, a body that is part   ``_blocks``: Newton on the
          of a loop, a slot inside a loop): Newton on the block's rows     block, branch = sign of det
          together
SLIDE     places one vertex by a distance to a known vertex and a slide   ``_fast``: line–circle
          equation whose other vertices are known (a pin–slider dyad:      intersection, exact;
          a connecting rod to a piston, or a slotted link about its        branch = the sign of the
          pivot through a known slider): the slide equation is affine in   2x2 Jacobian determinant
          the vertex, so the vertex lies on a known line
========  ==============================================================  ===========================

The dyad's arithmetic has one home, ``_fast.place_dyad``; the two closed-form kinds share
``_fast.fast_step``'s one loop (a function per kind taking the state arrays measured 2x slower, see
there), the exact closed form and every design's start place them by ``_batch.place_closed``, and
the kernels generated per topology (``_codegen``, for plans of these two kinds) write each block out
with the same arithmetic.

Equations come in two forms. A *distance* equation |p_b − p_a| = d (a link, or a body's base pair)
is one scalar row; an *attach* equation p_j = p_p + u (p_q − p_p) + v R(p_q − p_p) (R: a quarter
turn counter-clockwise) places body joint j from the body's base pair (p, q) and is two rows, x and
y. A *slide* equation (a slider, ``Mechanism.sliders``) is one scalar row: the slider vertex p's
signed distance from its line equals the slot's offset, n × (p − c) − o = 0 for a ground line
through c along the unit n (o = 0), cross(b − a, p − a)/|b − a| − o = 0 for a slot along a member
that holds a and b at the fixed distance |b − a| (bilinear: affine in each of p, a, b alone). The
(u, v) of each attach equation, the lengths of the distance equations and each slide equation's
line numbers (``Designs.slide``) are per-variant numbers derived from the design parameters
(``kernels._design``).

How to add a block kind
-----------------------
1. Give it a number here (``BlockKind``, the module constant and its phrase in ``KIND_TEXT``, which
   ``explorer describe`` prints), and recognise it in ``_blt.make_plan`` where blocks are classified
   (``_classify``). If it needs a new *equation type* (as the slide equation did), also: the
   equation's vertices as a ``Plan`` array, its rows in ``_blt._plan_with_bases`` (``eqs`` and
   ``eq_vars``, and a field of ``Block`` listing a block's equations of that type), the mechanism's
   part in ``kernels._simulate._topology`` (the plan cache key), and its per-variant numbers as a field
   of ``kernels._inputs.Designs`` (filled in ``kernels._design.designs``).
2. Give it what it reads: fields of the per-variant block table (``kernels._inputs.BLOCK_DTYPE``,
   filled in ``kernels._step.block_table``) and, for topology it needs beyond a row, a field of
   ``kernels._inputs.Topology`` (built in ``kernels._inputs.topology``).
3. Write its kernel: a branch of ``kernels._fast.fast_step``'s loop if it is a closed form (and of
   ``kernels._batch.place_closed``, with its ``start`` rule), else a module like ``kernels._blocks``
   called from ``kernels._step._blocks_step``; its branch check in ``kernels._step._check_dense`` and
   ``block_signs``; the nominal's first assembly and branch signs in ``kernels._simulate.assemble`` and
   ``_signs``. A new equation type is also a GENERAL row type (``ROW_*`` below: ``kernels._blocks``'
   ``_general_jacobian``, ``_general_rates`` and ``solve_general``'s residual) and rows of the dense
   method (``kernels._dense``). Plans with the new kind run on these general kernels
   (``kernels._codegen.supported`` says no) until ``_codegen`` writes it out too (a template beside
   ``_DYAD`` and ``_ATTACH``, checked bit for bit against the general kernel in
   ``tests/test_codegen.py``).
4. The forces effect (``kernels._forces``) has its own per-kind velocities, accelerations and
   reactions: add the kind there, or refuse it in one line in ``kernels._simulate.force_setup``.
5. Test it against an independent reference in ``tests/`` (see ``tests/test_bodies.py``,
   ``tests/test_sliders.py``).
"""

from enum import IntEnum


class BlockKind(IntEnum):
    """The kind of a plan block (stored as an int64 in the kernels' tables)."""

    DYAD = 0
    ATTACH = 1
    GENERAL = 2
    SLIDE = 3


#: What a block of each kind does, in a phrase (``explorer describe`` prints it).
KIND_TEXT = {
    "DYAD": "one joint from two distances to known joints (closed form)",
    "ATTACH": "a body joint placed rigidly from its body's two known joints (exact)",
    "GENERAL": "joints coupled in a loop, solved together (Newton)",
    "SLIDE": "one joint from a distance to a known joint and a slider's line (closed form)",
}

DYAD = int(BlockKind.DYAD)
ATTACH = int(BlockKind.ATTACH)
GENERAL = int(BlockKind.GENERAL)
SLIDE = int(BlockKind.SLIDE)

#: Row types of a GENERAL block (``Topology.gen_rows[:, 0]``): a distance equation, the x / y
#: row of an attach equation, or a slide equation.
ROW_DIST = 0
ROW_ATTACH_X = 1
ROW_ATTACH_Y = 2
ROW_SLIDE = 3
