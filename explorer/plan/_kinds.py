"""The block kinds of a plan: what each one is lives in its own module, ``explorer.kinds.<kind>``.

A plan (``_blt``) cuts a linkage's equations into blocks solved one after another. Every block has one
kind, which decides how the kernels place its vertices; each kind is one module of
:mod:`explorer.kinds` (``dyad``, ``attach``, ``slide``, ``general``, ``gears``, ...) holding every piece
of it: how the plan recognises it, its closed form, branch sign, gap check, step, rates, reactions and
the code the kernels' generator writes for it. Equation types (distance, attach, slide) are modules
of the same package. How to add a kind: :mod:`explorer.kinds`' docstring (and the README's recipe).

This module re-exports the registry's names for the plan's users.
"""

from ..kinds import (ATTACH, DYAD, GENERAL, KIND_TEXT, ROW_ATTACH_X, ROW_ATTACH_Y, ROW_DIST, ROW_SLIDE, SLIDE,
                     BlockKind)

__all__ = ["ATTACH", "DYAD", "GENERAL", "KIND_TEXT", "ROW_ATTACH_X", "ROW_ATTACH_Y", "ROW_DIST", "ROW_SLIDE", "SLIDE",
           "BlockKind"]
