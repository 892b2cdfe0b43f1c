"""Numba kernels and the public solvers over them: ``simulate`` (one design) and ``simulate_batch`` (N variants)."""

from ._cache import guard_cache, is_cached

guard_cache()  # before any kernel is loaded from the on-disk cache

from ..kinds._common import lu_solve  # noqa: E402
from ._legs import contact_stroke, ground_contact, leg_feet, leg_samples  # noqa: E402
from ._rows import parallel_rows  # noqa: E402
from ._simulate import check_dense  # noqa: E402
from ._simulate import (DEFAULT_TOLERANCE, METHODS, TOLERANCE_RANGE, STATUS_NAMES, Batch, Cycle, Failure, assemble,  # noqa: E402
                        GENERATED_MIN_CONFIGS, branch_signs, compiling_generated, plan_for, simulate, simulate_batch,
                        vector_applies, warm_dyad)
from ._drive import LINEAR, QUINTIC, timing  # noqa: E402 - a prescribed driver's timing laws (explorer.wrist's too)
from .._moved import moved  # noqa: E402

#: the 3-D wrist moved to explorer.wrist (issue 40's rooms); importable from here for one release
__getattr__ = moved(__name__, dict.fromkeys(
    ("INTERPOLATIONS", "SEQUENCES", "GimbalLock", "WristPath", "check_sequence", "euler_sets", "interpolate",
     "lock_distance", "orthonormality_defect", "project", "relative_angle", "track", "wrist_for", "wrist_path"),
    "explorer.wrist"))

__all__ = ["check_dense", "lu_solve", "is_cached", "GENERATED_MIN_CONFIGS", "compiling_generated", "DEFAULT_TOLERANCE", "METHODS", "TOLERANCE_RANGE", "STATUS_NAMES", "Batch", "Cycle", "Failure", "assemble", "branch_signs", "contact_stroke", "ground_contact", "leg_feet", "leg_samples",
           "parallel_rows",
           "plan_for", "simulate", "simulate_batch", "vector_applies", "warm_dyad",
           "LINEAR", "QUINTIC", "timing"]
