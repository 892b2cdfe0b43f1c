"""The one timing rule every benchmark here follows: a warm-up call (compile or load the cached
kernels), then the best of ``repeat`` timed calls. (Imported by the scripts beside it, which run as
``python benchmarks/<script>.py``.)"""

import time


def best(fn, repeat: int, warm_up: bool = True) -> float:
    """Smallest wall time of ``repeat`` calls of ``fn()``, s, after one untimed warm-up call."""
    if warm_up:
        fn()
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)
