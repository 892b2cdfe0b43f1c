"""Dask plumbing shared by every runner that takes ``client=``: :func:`~explorer.study.run_study`
(through :mod:`._dask`, one shard file per task) and :func:`~explorer.optimize.run_optimize` (each
generation's designs split over the workers).

A study travels to the workers as a :class:`Recipe` (its fields and the mechanism's TOML text: a
Mechanism does not pickle), rebuilt once per worker process. Before the first task the client
compiles (or loads) the study's kernels, then each host's first worker does, one host at a time, then
the others together (processes writing the Numba cache at once can crash: numba issue 4807). Each task
runs its kernels on one Numba thread (:func:`one_thread`). ``dask_client(spec)`` is the CLI's
``--dask SPEC``.
"""

from __future__ import annotations

import contextlib
import json
import os
import time
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import UserError
from ._chunk import chunk_solver, design_solver
from ._designs import designs_from_x, nominal_x
from ._spec import Study

INSTALL_HINT = 'pip install "explorer[dask]"'


def require_dask():
    try:
        import distributed  # noqa: F401
    except ImportError:
        raise UserError(f"--dask needs Dask, which is not installed: {INSTALL_HINT}") from None
    return distributed


def check_client(client, who: str):
    """The ``client=`` of ``who`` (a runner's name): Dask must be installed (a one-line UserError naming
    the extra otherwise) and ``client`` a ``dask.distributed.Client``. Returns :mod:`distributed`."""
    distributed = require_dask()
    if not isinstance(client, distributed.Client):
        raise UserError(f"{who}: expected a dask.distributed.Client as client, got {type(client).__name__}")
    return distributed


class Recipe:
    """A picklable description of a validated study (a Study holds a Mechanism, which does not
    pickle): its fields and the mechanism's TOML text, rebuilt once per worker process."""

    def __init__(self, study: Study):
        from dataclasses import fields
        self.fields = tuple((f.name, getattr(study, f.name)) for f in fields(study) if f.name != "_mech")
        self.mechanism_text = study.mechanism_text()
        self.mechanism_source = study.mech.source
        # everything the fields decide, as text (a field may hold arrays, which == does not compare)
        self.key = (study.fingerprint(), json.dumps(study.as_dict(), sort_keys=True), self.mechanism_text)

    def __hash__(self):
        return hash(self.key)

    def __eq__(self, other):
        return isinstance(other, Recipe) and self.key == other.key

    def study(self) -> Study:
        return rebuild(self)


@lru_cache(maxsize=4)
def rebuild(recipe: Recipe) -> Study:
    from ..mechanism import mechanism_from_dict, parse_toml
    mech = mechanism_from_dict(parse_toml(recipe.mechanism_text, recipe.mechanism_source), recipe.mechanism_source)
    return Study(**dict(recipe.fields), _mech=mech)


def one_thread() -> int | None:
    """A task runs on one Numba thread: Dask already runs one task per worker thread (per core).
    Returns the calling thread's Numba thread count before (None without Numba)."""
    try:
        import numba
        before = numba.get_num_threads()
        numba.set_num_threads(1)
        return before
    except (ImportError, ValueError):
        return None


def warm(recipe: Recipe, restore: bool = False) -> float:
    """Compile or load every kernel the study uses (two variants); returns the seconds it took.

    restore : give the calling thread back its Numba thread count afterwards (the client: a later
    ``run_study`` or ``simulate_batch`` in the same process must use every core again).
    """
    t0 = time.perf_counter()
    before = one_thread()
    try:
        study = recipe.study()
        if study.optimize is not None:  # an optimiser's designs are not sampled: warm up on the nominal
            design_solver(study)(*designs_from_x(study, np.vstack([nominal_x(study)] * 2)))
        else:
            chunk_solver(study)(0, min(2, study.n_variants))
    finally:
        if restore and before is not None:
            import numba
            numba.set_num_threads(before)
    return time.perf_counter() - t0


def token() -> str:
    import uuid
    return uuid.uuid4().hex[:12]


def worker_threads(client) -> int:
    try:
        info = client.scheduler_info()
        return max(1, sum(int(w.get("nthreads", 1)) for w in info.get("workers", {}).values()))
    except Exception:
        return 1


def warm_everywhere(client, recipe: Recipe) -> None:
    """Compile or load the study's kernels here, then on each host's first worker (one host at a
    time), then on the other workers together: no two processes ever write the Numba cache at once."""
    warm(recipe, restore=True)
    workers = client.scheduler_info().get("workers", {})
    by_host: dict[str, list[str]] = {}
    for addr, w in workers.items():
        by_host.setdefault(str(w.get("host", addr)), []).append(addr)
    firsts = [ws[0] for ws in by_host.values()]
    rest = [a for ws in by_host.values() for a in ws[1:]]
    def on(addrs):  # a task pinned to each worker (a task thread, not the worker's event loop)
        return [client.submit(warm, recipe, workers=[a], allow_other_workers=False, pure=False,
                              key=f"explorer-warm-{token()}") for a in addrs]

    try:
        for addr in firsts:
            client.gather(on([addr]))
        if rest:
            client.gather(on(rest))
    except Exception as exc:
        # a worker that cannot even load the kernels: say so now rather than through every task
        msg = " ".join(str(exc).split())[:300]
        raise UserError(f"a Dask worker could not load explorer's kernels ({type(exc).__name__}: {msg}); "
                        f"is explorer installed on the workers?") from None


# -- clusters for the CLI -----------------------------------------------------------------------------
@contextlib.contextmanager
def dask_client(spec: str):
    """A Client for ``--dask SPEC``: ``local:N`` (a LocalCluster of N single-threaded worker
    processes; ``local`` alone: one per core), a scheduler file (``*.json``, as written by
    ``dask scheduler --scheduler-file`` or dask-jobqueue), or a scheduler address
    (``tcp://host:8786``). The cluster it starts is closed on exit; a remote one is left running."""
    require_dask()
    import logging

    from distributed import Client, LocalCluster
    spec = str(spec).strip()
    if spec == "local" or spec.startswith("local:"):
        n_text = spec[6:] if spec.startswith("local:") else str(os.cpu_count() or 1)
        try:
            n = int(n_text)
            if n < 1:
                raise ValueError
        except ValueError:
            raise UserError(f"--dask {spec}: expected local:N with N ≥ 1 worker processes") from None
        with LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                          silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
            yield client
        return
    try:
        if spec.endswith(".json"):
            if not Path(spec).is_file():
                raise UserError(f"--dask {spec}: no such scheduler file")
            client = Client(scheduler_file=spec, timeout="20s")
        else:
            client = Client(spec, timeout="20s")
    except UserError:
        raise
    except (OSError, TimeoutError, ValueError) as exc:
        msg = " ".join(str(exc).split())[:200]
        raise UserError(f"--dask {spec}: cannot connect to a Dask scheduler ({msg}); give its address "
                        f"(tcp://host:8786), a scheduler file (.json), or local:N") from None
    try:
        yield client
    finally:
        client.close()
