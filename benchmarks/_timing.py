"""The one timing rule every benchmark here follows: a warm-up call (compile or load the cached
kernels), then the best of ``repeat`` timed calls; and the one set of designs the kernel benchmarks
time. (Imported by the scripts beside it, which run as ``python benchmarks/<script>.py``.)"""

import time


def best(fn, repeat: int, warm_up: bool = True, clock=time.perf_counter) -> float:
    """Smallest time of ``repeat`` calls of ``fn()``, s, after one untimed warm-up call: wall time, or
    with ``clock=time.process_time`` this process's CPU time (every thread's), the fairer figure on a
    machine shared with other work."""
    if warm_up:
        fn()
    times = []
    for _ in range(repeat):
        t = clock()
        fn()
        times.append(clock() - t)
    return min(times)


#: ``--clock`` choices of the benchmarks that take one
CLOCKS = {"wall": time.perf_counter, "cpu": time.process_time}


def best_cpu(fn, repeat: int, warm_up: bool = True) -> tuple[float, float]:
    """(wall, CPU) seconds of the call of ``fn()`` with the smallest wall time of ``repeat``, after one
    untimed warm-up call; CPU is the process's, every thread's (``time.process_time``): on a shared
    machine it counts the work, where wall time counts the waiting too."""
    if warm_up:
        fn()
    out = (float("inf"), float("inf"))
    for _ in range(repeat):
        c = time.process_time()
        t = time.perf_counter()
        fn()
        t, c = time.perf_counter() - t, time.process_time() - c
        out = min(out, (t, c))
    return out


def load() -> str:
    """The load averages and core count, to print beside any timing."""
    import os
    a = os.getloadavg()
    return f"load average {a[0]:.2f} {a[1]:.2f} {a[2]:.2f} on {os.cpu_count()} cores"


def variants(mech, n: int, spread: float = 0.02, seed: int = 1):
    """(lengths (n, n_links), crank (n,)): ``mech``'s links and crank radius each within ±spread,
    uniformly (seeded), variant 0 the nominal: the designs the kernel benchmarks share."""
    import numpy as np

    rng = np.random.default_rng(seed)
    lengths = mech.lengths * (1 + rng.uniform(-spread, spread, (n, len(mech.links))))
    crank = mech.crank.radius * (1 + rng.uniform(-spread, spread, n))
    lengths[0], crank[0] = mech.lengths, mech.crank.radius
    return lengths, crank
