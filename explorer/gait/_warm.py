"""Compile the gait kernels ahead of time, in another process: ``python -m explorer.gait._warm``.

On an empty Numba cache, ``explorer run`` spends about 10 s compiling the solver and about 6 s
compiling the metric kernels (foot metrics, walker, crossings), one after the other: Numba compiles
under one global lock, so a thread cannot overlap them, but a second process can. The study runner
(``explorer.study._run``) starts this module in the background when the walker kernel is not in the
cache yet; it compiles the metric kernels into the shared cache while the runner compiles the
solver, and the runner's first chunk then loads them. The kernels' argument types do not depend on
the study (``compute_metrics`` hands them contiguous float64 arrays and int64 codes), so any walking
path compiles the same signatures; tests/test_cache.py checks that a study's call then hits the cache.

It starts with one piece of the solver, the dyad's arithmetic (``explorer.kernels.warm_dyad``, ~2
CPU-s): its argument types are scalars, the same for every plan, and the runner's own compile of
the solver reaches it only after its imports, the drive table and the design setup, by which time
this process has put it in the cache, so the runner loads it. (The rest of the solver cannot be
taken over this way: the runner needs it sooner, or it is the generated kernel itself.)
"""

from __future__ import annotations

import math

import numpy as np


def warm() -> None:
    """Compile the dyad's arithmetic (the part of the solver whose types are the same for every
    study, see the module's docstring), then compute every metric of two synthetic foot paths of the
    built-in Jansen leg (compiling every metric kernel into the on-disk cache)."""
    from ..kernels import warm_dyad
    from ..mechanism import load_mechanism
    from ._metrics import compute_metrics

    warm_dyad()  # first: the runner's compile of the solver needs it a few seconds from now

    mech = load_mechanism("jansen")
    S = 72
    th = 2.0 * math.pi * np.arange(S) / S
    # a D-shaped loop below the crank: a flat bottom (stance) and an arched return
    x = 40.0 * np.cos(th)
    y = -90.0 + 12.0 * np.clip(np.sin(th), 0.0, None)
    paths = np.repeat(np.stack([x, y], axis=-1)[None], 2, axis=0)
    vel = np.gradient(paths, th, axis=1)
    compute_metrics(paths, vel, np.zeros(2, dtype=np.int8), None, mechanism=mech,
                    lengths=np.repeat(mech.lengths[None], 2, axis=0), crank=np.full(2, mech.crank.radius))


if __name__ == "__main__":
    warm()


def start_kernel_warmup():
    """Start ``python -m explorer.gait._warm`` in the background if the metric kernels are not in the
    on-disk cache yet; returns the process (stop it with :func:`stop_kernel_warmup`) or None."""
    import os
    import subprocess
    import sys

    from ..kernels import is_cached
    from ._walker import _walker_kernel

    if is_cached(_walker_kernel) or os.environ.get("NUMBA_DISABLE_JIT") == "1":
        return None
    try:
        return subprocess.Popen([sys.executable, "-m", "explorer.gait._warm"], stdin=subprocess.DEVNULL,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except OSError:  # no process to spare: the runner compiles them itself
        return None


def stop_kernel_warmup(proc) -> None:
    """End a warm-up process that is still running (its work, if unfinished, is not needed any more)."""
    if proc is not None and proc.poll() is None:
        proc.kill()
        proc.wait()
