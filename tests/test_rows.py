"""parallel_rows: every row exactly once, in place, whatever the thread and block counts.

The batch kernels get their parallelism from it, so a row it skipped or ran twice would be a silent
hole in a study. References: a plain numpy expression, and the same study on one thread.
"""

from __future__ import annotations

import math

import numba
import numpy as np
import pytest
from numba import njit

from explorer import simulate_batch
from explorer.kernels import parallel_rows


@njit(cache=True, nogil=True)
def _affine(a, b, x, out, count):
    """out[i] = a * x[i] + b, and count[i] += 1 (to catch a row run twice)."""
    for i in range(x.shape[0]):
        for j in range(x.shape[1]):
            out[i, j] = a * x[i, j] + b
        count[i] += 1


@pytest.mark.parametrize("n", [0, 1, 2, 7, 16, 17, 1000, 1001])
@pytest.mark.parametrize("threads", [1, 2, 3, 8])
def test_every_row_once(n, threads):
    x = np.random.default_rng(n).normal(size=(n, 3))
    out = np.full((n, 3), np.nan)
    count = np.zeros(n, dtype=np.int64)
    parallel_rows(_affine, (2.0, -1.0), (x, out, count), threads=threads)
    np.testing.assert_array_equal(out, 2.0 * x - 1.0)
    np.testing.assert_array_equal(count, np.ones(n, dtype=np.int64))


def test_study_is_the_same_on_one_thread(jansen):
    """Rows are independent: the threaded batch equals a one-thread batch bit for bit (failures included)."""
    rng = np.random.default_rng(7)
    L = np.asarray(jansen.lengths) * rng.uniform(0.95, 1.05, (300, len(jansen.links)))
    crank = jansen.crank.radius * rng.uniform(0.95, 1.05, 300)
    many = simulate_batch(jansen, L, crank, 72, velocities=True)
    before = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        one = simulate_batch(jansen, L, crank, 72, velocities=True)
    finally:
        numba.set_num_threads(before)
    assert (many.status != 0).any() and (many.status == 0).any()  # both kinds of row are exercised
    np.testing.assert_array_equal(many.status, one.status)
    np.testing.assert_array_equal(many.paths["7"], one.paths["7"])
    np.testing.assert_array_equal(many.velocities["7"], one.velocities["7"])
    np.testing.assert_array_equal(many.fail_theta, one.fail_theta)
    np.testing.assert_array_equal(many.iterations, one.iterations)


@njit(cache=True, nogil=True)
def _fail_first(work, x, count):
    """Raise on the study's first row; every other row does ``work`` flops and is counted."""
    for i in range(x.shape[0]):
        if x[i] == 0.0:
            raise ValueError("row 0")
        acc = 0.0
        for k in range(work):
            acc += math.sin(k * x[i])
        count[i] = 1 if acc == acc else 2


def test_error_stops_the_blocks_not_yet_started():
    """An error (or Ctrl-C) in one block surfaces at once; blocks not started are dropped, not run."""
    n = 256
    x = np.arange(n, dtype=np.float64)  # row 0 raises, in the first block
    count = np.zeros(n, dtype=np.int64)
    with pytest.raises(ValueError, match="row 0"):
        parallel_rows(_fail_first, (200_000,), (x, count), threads=2)
    assert count.sum() < n - 1  # far from every other row: most blocks were never started
