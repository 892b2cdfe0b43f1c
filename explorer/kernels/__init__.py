"""Numba kernels and the public solvers over them: ``simulate`` (one design) and ``simulate_batch`` (N variants)."""

from ._simulate import (DEFAULT_TOLERANCE, METHODS, STATUS_NAMES, Batch, Cycle, Failure, assemble, crank_table,
                        plan_for, simulate, simulate_batch)

__all__ = ["DEFAULT_TOLERANCE", "METHODS", "STATUS_NAMES", "Batch", "Cycle", "Failure", "assemble", "crank_table",
           "plan_for", "simulate", "simulate_batch"]
