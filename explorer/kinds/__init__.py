"""The block kinds and equation types: one module each, every per-kind piece in it.

A plan (``explorer.plan``) cuts a linkage's equations into blocks solved one after another; each block
has one *kind*, which decides how the kernels place its vertices. A kind is one module here
(``dyad``, ``attach``, ``slide``, ``general``, and any other module of this package not starting with
``_`` or ``eq_``), holding, each written once:

* what it is: ``NAME``, ``NUMBER`` (stored as an int64 in the kernels' tables and in results files'
  failing blocks' kinds), ``TEXT`` (``explorer describe`` prints it);
* how the plan recognises it, ``classify(vertices, rows, tables)``, and lowers it, ``lower(plan,
  block, crank)`` → its ``COLUMNS`` of the lowered plan's block table (``explorer.kernels._inputs.
  Topology.blk``), the vertices of which its generated code reads (``READS``);
* the numbers it reads per design, ``FIELDS`` of the per-design block table (``_inputs.BLOCK_DTYPE``
  is their union over the kinds);
* the nominal's first assembly and branch sign (``assemble``, ``branch``; Python, once per topology);
* its numerics (Numba): closed form, branch sign, gap check, step, rates, reactions;
* the code the generator writes for it: ``ARRAY`` snippets, rendered into the table-driven kernels
  (``explorer/kernels/_kinds_array.py``, committed, re-rendered by ``explorer.kernels._render``; among
  them ``vector``, the kind over every sample at once with its checks, for the vectorised first pass of
  method "auto", ``explorer.kernels._vector``: a kind without it sends its plans to Newton; and ``good``, where
  those checks pass sample by sample, for Newton to resume a design the pass flagged: a kind without it
  leaves such a design's whole sweep to Newton), and
  ``SCALAR`` snippets, rendered into the code generated per topology (``explorer.kernels._codegen``;
  None: plans with it run the table-driven kernels);
* ``START``: how a design's start places it ("sign": by its closed form on the nominal's branch,
  "always": exactly, "stop": not at all, Newton starts from the nominal's configuration);
* optional: ``EXPLICIT`` (its vertex, its first column, follows from the driver alone: the dense
  method takes it as known), ``CONTEXT`` (its snippets read the generic context: coupled blocks),
  ``FORCES = False`` with ``FORCES_REFUSED`` (a phrase) where the forces effect does not take it yet,
  ``FAILS_AS`` ("no-convergence" where a failed first assembly is Newton's, not a proof).

An *equation type* is a module ``eq_*.py`` (distance, attach, slide), or an ``EQUATION`` namespace a
kind module defines for itself: ``NAME``, ``ORDER`` (the order of the plan's rows), ``ROWS`` per
equation, ``gather(mech, index, bases)`` (its equations' vertices and the plan fields they fill),
``key(mech)`` (what of the mechanism its structure depends on: the plan's cache key), ``describe``
(an equation in words), its residual, gradient and curvature in one sign and scale convention, and,
where its equations carry per-design numbers beyond the core three's, ``NUMBERS`` per equation and
``numbers(mech, plan, col, N)`` → (N, n·NUMBERS) columns of ``Designs.extra``.

How to add a block kind
-----------------------
1. Write its module here (copy the closest: ``attach`` or ``gears`` for an exact placement, ``dyad``
   for a Newton step); if it needs a new equation type, define it in the module as ``EQUATION``
   (per-design numbers of its own: ``NUMBERS`` and ``numbers``, read from ``Designs.extra``). It is
   found by its file name: nothing else in the kernels, the plan or the generator lists it.
2. Re-render the table-driven kernels (``python -m explorer.kernels._render``; tests/test_kinds.py
   fails while they differ).
3. If it comes from a new part of the mechanism file, that part's entry in ``explorer.mechanism``:
   its dataclass and design parameters (``_model``), its table (``_load``), its writing back
   (``_toml``); ``explorer describe`` words it (``cli/_describe``).
4. Its tests against an independent reference (``tests/test_gears.py`` is the pattern).

The geared pair (``gears``, issue 38) was added this way: its module, the mechanism's ``Gear`` (model,
loader, TOML writer), its words in ``describe``, the built-in ``geared5bar`` and its tests.
"""

from __future__ import annotations

import importlib
import pkgutil
from enum import IntEnum

from . import eq_attach, eq_distance, eq_slide


def _discover():
    kinds, equations = [], [eq_distance, eq_attach, eq_slide]
    for info in pkgutil.iter_modules(__path__):
        if info.name.startswith(("_", "eq_")):
            continue
        mod = importlib.import_module(f"{__name__}.{info.name}")
        kinds.append(mod)
        if getattr(mod, "EQUATION", None) is not None:
            equations.append(mod.EQUATION)
    kinds.sort(key=lambda m: m.NUMBER)
    if [m.NUMBER for m in kinds] != list(range(len(kinds))):
        raise ImportError(f"explorer.kinds: kind numbers must be 0 … n−1, got {[m.NUMBER for m in kinds]}")
    equations.sort(key=lambda m: m.ORDER)
    return tuple(kinds), tuple(equations)


#: every block kind, indexed by its number; every equation type, in the plan's row order
KINDS, EQUATIONS = _discover()
#: equation type by name
EQUATION_BY_NAME = {eq.NAME: eq for eq in EQUATIONS}

BlockKind = IntEnum("BlockKind", {k.NAME: k.NUMBER for k in KINDS})
BlockKind.__doc__ = "The kind of a plan block (stored as an int64 in the kernels' tables)."
#: What a block of each kind does, in a phrase (``explorer describe`` prints it).
KIND_TEXT = {k.NAME: k.TEXT for k in KINDS}

DYAD = int(BlockKind.DYAD)
ATTACH = int(BlockKind.ATTACH)
GENERAL = int(BlockKind.GENERAL)
SLIDE = int(BlockKind.SLIDE)

#: Row types of a GENERAL block (``Topology.gen_rows[:, 0]``): a distance equation, the x / y row of
#: an attach equation, or a slide equation.
ROW_DIST = eq_distance.ROW
ROW_ATTACH_X = eq_attach.ROW_X
ROW_ATTACH_Y = eq_attach.ROW_Y
ROW_SLIDE = eq_slide.ROW


def extra_columns(plan) -> dict:
    """{equation type name: (its first column, columns per equation)} of ``Designs.extra``, the per-design
    numbers of the equation types that keep numbers of their own (``NUMBERS`` per equation and a
    ``numbers`` function), in the equation types' order."""
    out, col = {}, 0
    for eq in EQUATIONS:
        width = getattr(eq, "NUMBERS", 0)
        if width:
            out[eq.NAME] = (col, width)
            col += width * len(plan.tables.get(eq.NAME, ()))
    return out


def classify(vertices, rows, tables) -> int:
    """The kind of a block of ``vertices`` and ``rows`` ((equation type, equation, row) each): the
    first kind other than GENERAL whose ``classify`` takes it, else GENERAL."""
    for k in KINDS:
        if k.NUMBER != GENERAL and k.classify(vertices, rows, tables):
            return k.NUMBER
    return GENERAL


__all__ = ["ATTACH", "DYAD", "EQUATIONS", "EQUATION_BY_NAME", "GENERAL", "KINDS", "KIND_TEXT", "ROW_ATTACH_X",
           "extra_columns",
           "ROW_ATTACH_Y", "ROW_DIST", "ROW_SLIDE", "SLIDE", "BlockKind", "classify"]
