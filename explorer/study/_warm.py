"""Kernels that start warm: compile (or load) every kernel a study needs into the on-disk cache, once.

``explorer warm`` calls :func:`warm_kernels`. Numba compiles a kernel per argument types, and the types
a study's kernels see do not depend on its number of variants, so running the study itself on a few
variants (into a temporary file) compiles exactly what a full run of it needs: the solver's kernels
(for a built-in topology, the module generated for it), the metric kernels and the results writer's.
The cache folder is keyed by the kernels' code (``explorer.kernels._cache``), and since the generated
modules are cached whatever path they were imported from, a cache built once, here or at install,
serves every later run of the same explorer, copied to another folder or machine or not.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

#: variants each study is warmed with (the nominal and a few perturbed: every kernel's types are seen)
WARM_VARIANTS = 8


def warm_kernels(studies=(None,), mechanisms=(), steps: int = 360) -> dict:
    """Compile or load the kernels of each study (a path, built-in name or None for the default) and, for
    each mechanism named in ``mechanisms`` (built-in names or files), of a foot path with velocities at
    ``steps`` samples (an ``explorer.simulate_batch`` call with the defaults).

    Returns {"compiled": kernels compiled now, "seconds": wall time, "cpu_seconds": this process's CPU
    time, "cache": the cache folder, "items": [what was warmed]}: a second call compiles nothing.
    """
    from numba.core import event

    from ..kernels import compiling_generated, simulate_batch
    from ..kernels._cache import cache_bases
    from ..mechanism import load_mechanism
    from ._run import run_study
    from ._spec import load_study

    compiled = []

    class _Count(event.Listener):
        def on_start(self, ev):
            compiled.append(ev.data.get("dispatcher"))

        def on_end(self, ev):
            pass

    t0, c0 = time.perf_counter(), time.process_time()
    items = []
    # the generated kernels too, whatever the small runs' size: later runs find them cached
    with event.install_listener("numba:compile", _Count()), compiling_generated():
        for st in studies:
            study = load_study(st)
            small = dataclasses.replace(study, variants=min(study.variants, WARM_VARIANTS))
            with tempfile.TemporaryDirectory(prefix="explorer-warm-") as tmp:
                run_study(small, output=Path(tmp) / "warm.h5", force=True, progress=False)
            # the general kernel too (one for every topology): a single design or a small batch takes it
            simulate_batch(study.mech, study.mech.lengths[None],
                           None if study.mech.crank is None else [study.mech.crank.radius], 12, kernel="general")
            items.append(f"study {study.name}")
        for name in mechanisms:
            mech = load_mechanism(name)
            crank = None if mech.crank is None else [mech.crank.radius]
            simulate_batch(mech, mech.lengths[None], crank, steps)
            items.append(f"mechanism {mech.name}")
    return {"compiled": len(compiled), "seconds": time.perf_counter() - t0, "cpu_seconds": time.process_time() - c0,
            "cache": str(cache_bases()[0]), "items": items}
