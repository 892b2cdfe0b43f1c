"""Structural analysis: the block-lower-triangular solve order of a linkage (computed once per topology),
and the Grashof class of its crank-driven four-bar loops."""

from ._blt import DYAD, GENERAL, Block, Plan, make_plan
from ._grashof import GRASHOF_KINDS, Grashof, classify, fourbar_loops, grashof, grashof_batch

__all__ = ["DYAD", "GENERAL", "GRASHOF_KINDS", "Block", "Grashof", "Plan", "classify", "fourbar_loops", "grashof",
           "grashof_batch", "make_plan"]
