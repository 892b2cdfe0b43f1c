"""Structural analysis: the block-lower-triangular solve order of a linkage (computed once per topology)."""

from ._blt import DYAD, GENERAL, Block, Plan, make_plan

__all__ = ["DYAD", "GENERAL", "Block", "Plan", "make_plan"]
