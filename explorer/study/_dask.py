"""Running a study on a Dask cluster: one task per shard, one HDF5 file per shard, stitched at the end.

``run_study(study, client=client)`` (or ``run_study_dask(client, study, output=...)``, the same call)
runs a study on a ``dask.distributed.Client`` (a ``LocalCluster`` on a laptop, a scheduler started by hand or by
dask-jobqueue on HPC): the study is cut into shards (contiguous variant ranges, see
:func:`explorer.store._shards.plan_shards`), each task solves its shard with the same Numba kernels
in chunks and writes its own shard file (temporary name, then rename), and the client stitches the
shards into one study file of h5py virtual datasets (see :mod:`explorer.store._shards`). The
result reads exactly like a single-process run, bit for bit.

Requirements: the results folder must be on a filesystem every worker can write and the client can
read (a laptop's disk for a LocalCluster; a shared filesystem on a cluster), and explorer (same
version) must be installed on the workers. Dask is an optional extra: ``pip install "explorer[dask]"``.

Numba: the kernels cache compiled code on disk, and processes that write the cache at the same time
can crash (numba issue 4807). Before the first task the client compiles (or loads) every kernel the
study needs, then each host's first worker does so one host at a time, then the other workers in
parallel (they only read the cache by then). Each task runs its kernels on one Numba thread: run
one single-threaded worker per core (``dask worker ADDRESS --nworkers N --nthreads 1``).
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

from ..errors import UserError, signals_held
from ..store import (FORMAT, OutputLock, ShardPlan, clean_folder, completed_shards, fingerprint_diff, plan_shards,
                     shards_folder, stitch, write_shard)
from ._chunk import chunk_solver
from ._cluster import (INSTALL_HINT, Recipe, check_client, dask_client, one_thread, require_dask, token, warm, warm_everywhere,
                       worker_threads)
from ._output import RunSummary, _state, results_path, status_counts, validate_study
from ._spec import Study, load_study

# the names this module had before the Dask plumbing moved to ._cluster (benchmarks, older callers)
_require_dask, _Recipe, _one_thread, _warm, _warm_everywhere, _worker_threads, _token = (
    require_dask, Recipe, one_thread, warm, warm_everywhere, worker_threads, token)
__all__ = ["INSTALL_HINT", "dask_client", "run_study_dask"]


# -- the work of one task ---------------------------------------------------------------------------
def _solver(study: Study):
    """solve(a, b) → (lengths, crank, geometry, batch, metrics) for variants [a, b): the one chunk runner."""
    return chunk_solver(study)


def _shard_task(recipe: Recipe, folder: str, plan: ShardPlan, i: int) -> dict:
    """Solve and write shard ``i`` (a Dask task). Returns what the client reports."""
    t0 = time.perf_counter()
    one_thread()
    study = recipe.study()
    wrote = write_shard(folder, plan, i, study, _solver(study))
    a, b = plan.range(i)
    return {"shard": i, "ran": (b - a) if wrote else 0, "wall_s": time.perf_counter() - t0}


# -- the client side --------------------------------------------------------------------------------
def run_study_dask(client, study=None, output=None, resume: bool = False, force: bool = False,
                   shard_size: int | None = None, progress: bool = True, chunk_size: int | None = None,
                   retries: int = 2) -> RunSummary:
    """Run a study on a Dask cluster into one results file (stitched from one HDF5 file per shard).

    client : a ``dask.distributed.Client`` (``Client("tcp://host:8786")``, ``Client(LocalCluster(...))``).
    study, output, resume, force, progress : as :func:`~explorer.study.run_study`. The shard files
        go to a folder beside the results file (``results/name.h5`` → ``results/name.shards/``),
        which must be writable by every worker (a shared filesystem on a real cluster).
    resume : finish an interrupted run: shards already complete are skipped (a shard file under its
        final name is complete), the rest are run, then the study file is stitched.
    shard_size : variants per shard (one task and one file each; default: about 4 shards per
        worker, at least 2^19 ≈ 524,000 crank configurations each, at most 1,000 shards). A resumed run
        keeps the layout it started with. chunk_size : variants per solve call inside a shard
        (default as ``run_study``).
    retries : times Dask retries a shard task that raised (a task on a worker that died is
        rescheduled by the scheduler anyway, up to its ``allowed-failures``).

    Returns a :class:`RunSummary` (``os.fspath`` gives the results path); the results file opens
    with :func:`~explorer.store.open_results` like any other. Raises
    :class:`~explorer.errors.UserError` for a bad study, an existing file, or a failed shard.
    """
    t0 = time.perf_counter()
    distributed = check_client(client, "run_study_dask")
    study = load_study(study)
    out = results_path(study, output, resume, force, shard_size=shard_size, chunk_size=chunk_size)
    validate_study(study)
    with OutputLock(out):  # one run per output, from creation to the end
        return _run_dask_locked(client, distributed, study, out, resume, force, shard_size, progress, chunk_size,
                                retries, t0)


def _run_dask_locked(client, distributed, study, out, resume, force, shard_size, progress, chunk_size, retries, t0):
    folder = shards_folder(out)

    # -- what is there already
    resumed = False
    if out.exists():
        kind = _existing(out, study)
        if resume:
            if kind == "complete":  # sharded or not: the results are there
                from ..store import open_results
                with open_results(out) as r:
                    counts = status_counts(r.file["status"][...])
                return RunSummary(out, study.name, study.n_variants, study.steps, 0, counts,
                                  time.perf_counter() - t0, resumed=True, already_complete=True)
            raise UserError(f"{out}: {kind}; pass --force to overwrite it")
        if not force:
            raise UserError(f"{out}: results file exists ({_state(out)}); pass --force to overwrite it"
                            + (" or --resume to finish it" if _state(out) != "complete" else ""))
    old = ShardPlan.read(folder) if folder.is_dir() else None
    if force:
        if out.exists() and _is_sharded(out):
            out.unlink()  # its shards are about to go: leave no study file pointing at nothing
        clean_folder(folder, everything=True)
        old = None
    elif old is not None and not resume:
        raise UserError(f"{folder}: holds the shards of an unfinished run; pass --resume to finish it or "
                        f"--force to start over")
    elif old is not None and old.fingerprint != study.fingerprint():
        why = fingerprint_diff(json.loads(old.fingerprint), json.loads(study.fingerprint()))
        raise UserError(f"{folder}: holds shards of a different run ({why}); pass --force to start over")

    workers = worker_threads(client)
    if old is not None:
        plan, resumed = old, True  # a resumed run keeps its layout
        clean_folder(folder)  # leftovers of killed tasks
    else:
        plan = plan_shards(study, workers, shard_size, chunk_size)
        try:
            plan.write(folder)
        except OSError as exc:
            raise UserError(f"{folder}: cannot create the shards folder: {exc}") from None
    done = completed_shards(folder, plan)
    pending = [i for i, ok in enumerate(done) if not ok]

    # -- fan out
    ran = 0
    if pending:
        recipe = Recipe(study)
        warm_everywhere(client, recipe)
        bar = _progress_bar(progress, sum(_size(plan, i) for i in pending) * study.steps, study.name)
        folder_abs = str(folder.resolve())
        futures = [client.submit(_shard_task, recipe, folder_abs, plan, i, key=f"explorer-shard-{i}-{token()}",
                                 pure=False, retries=retries) for i in pending]
        try:
            for fut in distributed.as_completed(futures):
                try:
                    res = fut.result()
                except Exception as exc:  # a shard failed for good: keep what is done, report
                    _stop(client, futures, distributed)
                    n_done = sum(completed_shards(folder, plan))
                    msg = " ".join(str(exc).split()) or type(exc).__name__
                    raise UserError(f"{out}: a shard failed ({type(exc).__name__}: {msg[:300]}); {n_done} of "
                                    f"{plan.n_shards} shards are complete in {folder}; run again with --resume "
                                    f"to finish the others") from None
                ran += res["ran"]
                if bar is not None:
                    bar.update(_size(plan, res["shard"]) * study.steps)
        except KeyboardInterrupt:
            with signals_held():  # a second Ctrl-C must not cut the wait short
                _stop(client, futures, distributed)
            n_done = sum(completed_shards(folder, plan))
            raise KeyboardInterrupt(f"{out}: interrupted with {n_done} of {plan.n_shards} shards complete; "
                                    f"run again with --resume to finish it") from None
        finally:
            if bar is not None:
                bar.close()

    # -- stitch
    missing = [i for i, ok in enumerate(completed_shards(folder, plan)) if not ok]
    if missing:
        raise UserError(f"{folder}: the workers reported shard {missing[0]} done but this machine cannot see "
                        f"its file; the results folder must be on a filesystem shared by the client and "
                        f"every worker")
    try:
        stitch(out, folder, plan)
    except OSError as exc:
        raise UserError(f"{out}: cannot write the results file: {exc}") from None
    clean_folder(folder)  # temporary files of attempts that died (their shards were redone)
    from ..store import open_results
    with open_results(out) as r:
        counts = status_counts(r.file["status"][...])
    return RunSummary(out, study.name, study.n_variants, study.steps, ran, counts, time.perf_counter() - t0,
                      resumed=resumed)


def _size(plan: ShardPlan, i: int) -> int:
    a, b = plan.range(i)
    return b - a


def _existing(out: Path, study: Study) -> str:
    """State of an existing results file, for a resume: ``complete`` or why it cannot be resumed."""
    from ..store import probe
    info = probe(out)
    if info["error"] is not None:
        return "unreadable or in use"
    if info["format"] != FORMAT:
        return "not an explorer results file"
    if info["fingerprint"] != study.fingerprint():
        return "written by a different study"
    if info["complete"]:
        return "complete"
    if not info["sharded"]:
        return "an unfinished single-process run (finish it with explorer run --resume, without --dask)"
    return "incomplete"


def _is_sharded(out: Path) -> bool:
    from ..store import probe
    return probe(out)["sharded"]


#: Longest wait, seconds, for the shards being worked on when a run stops (about one shard's time).
STOP_WAIT = 300.0


def _stop(client, futures, distributed) -> None:
    """Stop a run's shard tasks: cancel those not started and wait for those being worked on.

    Cancelling a task that is already running does not stop it on its worker: it would go on and
    write its shard after this run returned (and released the output's lock), under a run that
    --resume may have started by then, and the count of completed shards reported would be short.
    """
    try:
        busy = {k for keys in client.processing().values() for k in keys}
    except Exception:  # the scheduler is gone: nothing more will run
        return
    running = [f for f in futures if f.key in busy and not f.done()]
    client.cancel([f for f in futures if f.key not in busy])
    try:
        distributed.wait(running, timeout=STOP_WAIT)
    except Exception:  # a timeout or a lost scheduler: report what is complete now
        pass


def _progress_bar(progress: bool, total: int, name: str):
    if not progress or not total or not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
        return None
    from tqdm import tqdm
    return tqdm(total=total, unit="cfg", unit_scale=True, desc=name, file=sys.stderr, smoothing=0.1,
                dynamic_ncols=True, leave=False)
