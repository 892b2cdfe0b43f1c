"""Structural analysis: the block-lower-triangular solve order of a linkage (computed once per topology),
and the Grashof class of its crank-driven four-bar loops."""

from ._blt import Block, Plan, make_plan
from ._kinds import ATTACH, DYAD, GENERAL, ROW_ATTACH_X, ROW_ATTACH_Y, ROW_DIST, ROW_SLIDE, SLIDE, KIND_TEXT, BlockKind
from ._grashof import GRASHOF_KINDS, Grashof, classify, fourbar_loops, grashof, grashof_batch, loop_ground, loop_side

__all__ = ["loop_ground", "loop_side", "ATTACH", "DYAD", "GENERAL", "ROW_ATTACH_X", "ROW_ATTACH_Y", "ROW_DIST", "ROW_SLIDE", "SLIDE", "KIND_TEXT", "BlockKind", "GRASHOF_KINDS", "Block", "Grashof", "Plan", "classify", "fourbar_loops", "grashof",
           "grashof_batch", "make_plan"]
