"""Run a serial, GIL-free row kernel over blocks of rows from a pool of Python threads.

The batch kernels are plain ``@njit(nogil=True)`` loops over the rows they are handed; this is what
makes them parallel. A ``parallel=True`` prange loop did the same job at the same speed, but its
parfor lowering compiled for about 10 s on a cold cache (a third of ``explorer run``'s first start).
Blocks are handed out dynamically, so variants that fail and sweep back take no thread hostage.
"""

import os
import threading
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

    if threading.current_thread().name.startswith(_PREFIX):  # called from a kernel block: no nested wait on the pool
        kernel(*shared, *rows)
        return
    pool = _pool(threads)
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
        # interrupt goes on at once (the command then exits without waiting for them either), and the pool
        # is given up (the next call starts another); a second Ctrl-C while the pool shuts down would break
        # the same lock: held
        if not finished:
            with signals_held():
                _drop(pool)


#: Name prefix of the pool's threads.
_PREFIX = "explorer-rows"
_POOLS: dict = {}  # threads -> (pid, pool): one persistent pool per process and thread count
_POOLS_LOCK = threading.Lock()


def _pool(threads: int) -> ThreadPoolExecutor:
    """The process's persistent pool of ``threads`` workers (started once, reused by every call: a run
    of a thousand chunks starts two threads, not two thousand); a new one after a fork (the parent's
    threads are not in the child)."""
    with _POOLS_LOCK:
        pid, pool = _POOLS.get(threads, (None, None))
        if pool is None or pid != os.getpid():
            pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix=_PREFIX)
            _POOLS[threads] = (os.getpid(), pool)
        return pool


def _drop(pool: ThreadPoolExecutor) -> None:
    """Give up ``pool`` after an interrupted call: its queued blocks dropped, its running ones not waited for."""
    with _POOLS_LOCK:
        for key, (_, p) in list(_POOLS.items()):
            if p is pool:
                del _POOLS[key]
    pool.shutdown(wait=False, cancel_futures=True)


def _forget_pools() -> None:  # in a forked child: the parent's pools have no threads here, its lock may be held
    global _POOLS_LOCK
    _POOLS.clear()
    _POOLS_LOCK = threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pools)
