"""Run a serial, GIL-free row kernel over blocks of rows from a pool of Python threads.

The batch kernels are plain ``@njit(nogil=True)`` loops over the rows they are handed; this is what
makes them parallel. A ``parallel=True`` prange loop did the same job at the same speed, but its
parfor lowering compiled for about 10 s on a cold cache (a third of ``explorer run``'s first start).
Blocks are handed out dynamically, so variants that fail and sweep back take no thread hostage.
"""

from concurrent.futures import ThreadPoolExecutor

import numba

from ..errors import signals_held

#: Blocks per thread: enough to balance slow (failing) variants, few enough that the dispatch of a
#: block (tens of µs) stays far below its work (milliseconds).
BLOCKS_PER_THREAD = 8


def parallel_rows(kernel, shared: tuple, rows: tuple, threads: int | None = None) -> None:
    """Call ``kernel(*shared, *(a[lo:hi] for a in rows))`` for row blocks [lo, hi) covering every row.

    rows : arrays, or named tuples of arrays (``_inputs.Designs``, ``Outputs``), that share their first
        axis (N, ...) — the kernel's per-row inputs and outputs, written in place through the slices
        (slices along axis 0 keep C-contiguity, so no recompile).
    threads : worker threads (default: ``numba.get_num_threads()``, which honours
        ``NUMBA_NUM_THREADS`` and ``numba.set_num_threads``).
    """
    def part(a, lo, hi):
        return type(a)(*(x[lo:hi] for x in a)) if isinstance(a, tuple) else a[lo:hi]

    n = (rows[0][0] if isinstance(rows[0], tuple) else rows[0]).shape[0]
    threads = numba.get_num_threads() if threads is None else int(threads)
    if threads <= 1 or n <= 1:
        kernel(*shared, *rows)
        return
    size = max(1, -(-n // (threads * BLOCKS_PER_THREAD)))

    def block(lo: int) -> None:
        kernel(*shared, *(part(a, lo, lo + size) for a in rows))

    pool = ThreadPoolExecutor(max_workers=min(threads, -(-n // size)))
    finished = False
    try:
        # a Ctrl-C landing while a submit starts a worker thread broke threading's own lock
        # ("release unlocked lock", exit 1 instead of 130): the submits run with signals held, and
        # one that arrived is raised right after them
        with signals_held():
            futures = [pool.submit(block, lo) for lo in range(0, n, size)]
        for f in futures:
            f.result()
        finished = True
    finally:
        # on Ctrl-C or an error, blocks not yet started are dropped, and the running ones (which cannot be
        # stopped: a first call compiles the kernel, 10 s and more on a cold cache) are not waited for: the
        # interrupt goes on at once (the command then exits without waiting for them either); a second
        # Ctrl-C while the pool shuts down would break the same lock: held
        with signals_held():
            pool.shutdown(wait=finished, cancel_futures=True)
