"""Small Numba helpers the gait kernels share (the single-leg stance and the walker's swing)."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def longest_cyclic_run(inside):
    """Longest run of consecutive True in ``inside`` (S,), taken cyclically (a run may wrap from S−1 to
    0): (start, length). Ties go to the run with the smallest start; (0, S) if every sample is True,
    (0, 0) if none is."""
    S = inside.shape[0]
    k0 = -1
    for k in range(S):
        if not inside[k]:
            k0 = k
            break
    if k0 < 0:
        return 0, S
    best_start = 0
    best_len = 0
    run_start = 0
    run_len = 0
    # scan S samples starting right after a sample that is outside, so no run is cut
    for j in range(1, S + 1):
        k = (k0 + j) % S
        if inside[k]:
            if run_len == 0:
                run_start = k
            run_len += 1
        else:
            if run_len > best_len or (run_len == best_len and run_len > 0 and run_start < best_start):
                best_start = run_start
                best_len = run_len
            run_len = 0
    # the scan ends on sample k0, which is outside, so every run has been closed
    return best_start, best_len


@njit(cache=True)
def all_finite(a):
    """True if every value of the 2-D array ``a`` is finite."""
    for k in range(a.shape[0]):
        for c in range(a.shape[1]):
            if not math.isfinite(a[k, c]):
                return False
    return True
