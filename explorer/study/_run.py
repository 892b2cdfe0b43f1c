"""Running a study: chunks of variants → ``simulate_batch`` → HDF5, with progress, resume and a summary."""

from __future__ import annotations

import queue
import sys
import threading
import time
from pathlib import Path

from ..errors import Terminated, UserError, signals_held
from ..gait import start_kernel_warmup, stop_kernel_warmup
from ..store import SYNC_SECONDS, OutputLock, ResultsWriter
from ._chunk import chunk_solver, metric_plan
from ._output import (RunSummary, _check_disk_space, _check_overwritable, _counts, _state,  # noqa: F401
                      estimated_bytes, results_path, validate_study)
from ._spec import load_study


def run_study(study=None, output=None, resume: bool = False, force: bool = False, progress: bool = True,
              chunk_size: int | None = None, client=None, shard_size: int | None = None) -> RunSummary:
    """Run a study and stream every variant to one HDF5 results file.

    study : path to a study ``.toml``, a built-in study name, a dict in the TOML shape, a
        :class:`Study`, or None for the built-in default (``studies/default.toml``).
    output : results path overriding ``[output] path`` (relative paths: against the working dir).
    resume : finish an interrupted run of the same study (runs only the chunks not yet committed;
        the result is identical to an uninterrupted run). If the file does not exist, start it.
    force : overwrite an existing file. Without ``force`` or ``resume`` an existing file is an error.
    progress : show a tqdm bar (configurations/s and ETA) on stderr when it is a terminal.
    chunk_size : variants per chunk (default: chosen from the scene, see
        :func:`explorer.store.chunk_rows`); a resumed run keeps the file's chunking.
    client : a ``dask.distributed.Client`` to run the study on, one HDF5 shard file per task,
        stitched into one results file that reads exactly like a single-process run
        (:func:`~explorer.study.run_study_dask`; needs ``pip install "explorer[dask]"``). Default:
        this process. shard_size : with ``client``, variants per shard (default: about 4 shards per
        worker).

    Returns a :class:`RunSummary` (``os.fspath`` gives the results path). Raises
    :class:`~explorer.errors.UserError` for a bad study, an existing file, or an unwritable path.
    """
    if client is not None:
        from ._dask import run_study_dask
        return run_study_dask(client, study, output=output, resume=resume, force=force, shard_size=shard_size,
                              progress=progress, chunk_size=chunk_size)
    if shard_size is not None:
        raise UserError("shard size: applies to a run on a Dask cluster only (client=, or --dask)")
    t0 = time.perf_counter()
    study = load_study(study)
    out = results_path(study, output, resume, force, chunk_size=chunk_size)
    # on an empty Numba cache, a second process compiles the metric kernels while this one compiles
    # the solver (Numba compiles under one lock per process): 20.4 s -> see docs/speed.md, cold start
    warm = start_kernel_warmup() if metric_plan(study)[2] else None
    try:
        validate_study(study)
        with OutputLock(out):  # one run per output, from creation to the end
            return _run_locked(study, out, resume, force, progress, chunk_size, t0)
    finally:
        stop_kernel_warmup(warm)


def _run_locked(study, out: Path, resume: bool, force: bool, progress: bool, chunk_size, t0: float) -> RunSummary:
    resumed = False
    timer = dict.fromkeys(STAGES, 0.0)
    # before any file is made: what cannot be solved is refused first; with the commit thread, each chunk's
    # metrics are computed there, while the main thread solves the next chunk
    solve = chunk_solver(study, timer, _THREADED)  # (deferred, positionally: tests wrap it as solver(study, *args))
    if out.exists():
        if resume and _nothing_committed(out, study) is not None:
            # a run stopped before its first commit (a disk that filled, a kill) holds no result: it is
            # started over, whatever state its first commit left it in (a failed write can leave the
            # chunk index pointing past the end of the file, unreadable and unwritable)
            writer = ResultsWriter.create(out, study, _nothing_committed(out, study), exact_rows=True)
            resumed = True
        elif resume:
            writer = ResultsWriter.resume(out, study)
            resumed = True
            if writer.complete:
                counts = _counts(writer)
                writer.close()
                return RunSummary(out, study.name, study.n_variants, study.steps, 0, counts,
                                  time.perf_counter() - t0, resumed=True, already_complete=True)
        elif force:  # the new file replaces the old one only once it is created
            writer = ResultsWriter.create(out, study, chunk_size)
        else:
            state = _state(out)
            raise UserError(f"{out}: results file exists ({state}); pass --force to overwrite it"
                            + (" or --resume to finish it" if state != "complete" else ""))
    else:
        writer = ResultsWriter.create(out, study, chunk_size)

    ran = 0
    writer.sync_every = SYNC_SECONDS  # chunks marked done in groups: what a kill -9 can lose (docs/results.md)
    switch = sys.getswitchinterval()
    try:
        bar = committer = None
        try:  # a signal from here on leaves a resumable file, and says so
            pending = writer.pending()
            bar = _progress_bar(progress, writer, pending, study)
            committer = _Committer(writer, bar, study.steps, threaded=_THREADED, timer=timer)
            if committer.thread is not None:
                sys.setswitchinterval(SWITCH_INTERVAL)
            for i in pending:
                a, b = writer.chunk_range(i)
                lengths, crank, geometry, batch, metrics = solve(a, b)
                committer.put(i, lengths, crank, geometry, batch, metrics)
                ran += b - a
            committer.close()
        except KeyboardInterrupt as exc:
            with signals_held():  # a second Ctrl-C must not cut the commit in flight (h5py would crash)
                if committer is not None:
                    committer.abort()
                try:
                    writer.sync()  # the chunks written whole are kept
                except Exception:  # noqa: BLE001 - they stay not done: the resume solves them again
                    pass
                done = int(writer.done.sum())
            what = "terminated" if isinstance(exc, Terminated) else "interrupted"
            raise type(exc)(f"{out}: {what} with {done} of {writer.n_chunks} chunks committed; run again with "
                            f"--resume to finish it") from None
        finally:
            with signals_held():
                if committer is not None:
                    committer.abort()
                sys.setswitchinterval(switch)
                if bar is not None:
                    bar.close()
        writer.finish()
        counts = _counts(writer)
    finally:
        with signals_held():
            writer.close()
    return RunSummary(out, study.name, study.n_variants, study.steps, ran, counts, time.perf_counter() - t0,
                      resumed=resumed, timings=timer)


def _nothing_committed(out: Path, study) -> int | None:
    """The chunk rows of ``out`` if it is a results file of ``study`` (its format and fingerprint) with
    no chunk committed, else None. Only the root attributes, ``/chunks`` and ``/chunks/done`` are read."""
    from ..store import guarded
    try:  # in a child process: damaged bytes cannot hang the run here
        return guarded(_uncommitted_rows, out, study.fingerprint(), study.n_variants)
    except Exception:  # noqa: BLE001 - unreadable: ResultsWriter.resume says why
        return None


def _uncommitted_rows(out: Path, fingerprint: str, n_variants: int) -> int | None:
    import h5py
    import numpy as np

    from ..store import FORMAT
    with h5py.File(out, "r") as f:
        if f.attrs.get("format") != FORMAT or f.attrs.get("study_fingerprint") != fingerprint:
            return None
        if np.asarray(f["chunks/done"][...], dtype=bool).any():
            return None
        rows = int(f["chunks"].attrs["rows"])
        return rows if 1 <= rows <= n_variants else None


#: The stages a run's wall time is broken into (``RunSummary.timings``, seconds): sampling the designs and
#: the kernels (the main thread, in turn), the metrics and writing (the commit thread, chunk k's while
#: the main thread solves chunk k+1) and ``wait``, the main thread blocked on the commit thread (the
#: metrics and writes the solve did not hide); ``write_cpu``: the CPU seconds of the commit thread's
#: writing (filters, checksums, HDF5), whatever core ran it.
STAGES = ("sample", "solve", "metrics", "write", "wait", "write_cpu")

#: Commit chunks on a background thread while the next chunk is solved. Off: commit inline (for
#: measurement). h5py holds the GIL while HDF5 compresses and writes, so the writer commits one HDF5
#: chunk per call (ResultsWriter.write_chunk) and, while the thread runs, the interpreter's switch
#: interval is cut from 5 ms to :data:`SWITCH_INTERVAL`: a kernel thread finishing its block of rows
#: then waits for the GIL at most about one HDF5 chunk's write instead of 5 ms (on the shared 2-core
#: machine, 50,000 variants x 360 steps with velocities, Blosc, load ~2.8: 1.71x the kernels' time with a
#: 5 ms interval, 1.19x with 0.2 ms; benchmarks/bench_pipeline.py).
_THREADED = True
#: The switch interval while the commit thread runs, s (restored after the run).
SWITCH_INTERVAL = 2e-4


class _Committer:
    """Commits solved chunks in order, on a background thread (at most one chunk queued, so memory
    stays at two chunks whatever N is) or inline. Errors of the thread are raised in the caller."""

    def __init__(self, writer: ResultsWriter, bar, steps: int, threaded: bool = True, timer: dict | None = None):
        self.writer, self.bar, self.steps = writer, bar, steps
        self.timer = {} if timer is None else timer
        self.error: BaseException | None = None
        self.thread = None
        if threaded:
            self.queue = queue.Queue(maxsize=1)
            self.thread = threading.Thread(target=self._loop, name="explorer-commit", daemon=True)
            self.thread.start()

    def _commit(self, item) -> None:
        i, lengths, crank, geometry, batch, metrics = item
        if callable(metrics):  # deferred by the chunk solver: computed here, beside the next chunk's solve
            metrics = metrics()
        t0, c0 = time.perf_counter(), time.thread_time()
        self.writer.write_chunk(i, lengths, crank, batch, metrics, geometry=geometry)
        self.timer["write"] = self.timer.get("write", 0.0) + (time.perf_counter() - t0)
        self.timer["write_cpu"] = self.timer.get("write_cpu", 0.0) + (time.thread_time() - c0)
        if self.bar is not None:
            self.bar.update(len(crank) * self.steps)

    def _loop(self) -> None:
        while True:
            item = self.queue.get()
            if item is None or self.error is not None:
                return
            try:
                self._commit(item)
            except BaseException as exc:  # handed to the main thread
                self.error = exc
                return

    def _check(self) -> None:
        if self.error is not None:
            raise self.error

    def put(self, *item) -> None:
        """Commit a chunk (queued when threaded); raises an earlier commit's error."""
        self._check()
        if self.thread is None:
            self._commit(item)
            return
        t0 = time.perf_counter()
        try:
            while True:
                try:
                    self.queue.put(item, timeout=0.1)
                    return
                except queue.Full:
                    self._check()
                    if not self.thread.is_alive():
                        raise RuntimeError("the commit thread stopped")
        finally:
            self.timer["wait"] = self.timer.get("wait", 0.0) + (time.perf_counter() - t0)

    def close(self) -> None:
        """Wait until every queued chunk is committed; raise the thread's error if any."""
        if self.thread is not None:
            t0 = time.perf_counter()
            self._stop()
            self.timer["wait"] = self.timer.get("wait", 0.0) + (time.perf_counter() - t0)
        self._check()

    def _stop(self) -> None:
        """Queue the end marker (unless the thread already died, leaving the queue full) and join."""
        while self.thread.is_alive():
            try:
                self.queue.put(None, timeout=0.1)
                break
            except queue.Full:
                continue
        self.thread.join()
        self.thread = None

    def abort(self) -> None:
        """Let a commit in progress finish, drop what is queued, stop the thread (idempotent)."""
        if self.thread is None:
            return
        self.error = self.error or _Aborted()
        try:
            while True:
                self.queue.get_nowait()
        except queue.Empty:
            pass
        self._stop()


class _Aborted(Exception):
    pass


def _progress_bar(progress: bool, writer: ResultsWriter, pending, study):
    if not progress or not pending:
        return None
    if not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
        return None
    from tqdm import tqdm
    total = sum(b - a for a, b in map(writer.chunk_range, pending)) * study.steps
    return tqdm(total=total, unit="cfg", unit_scale=True, desc=study.name, file=sys.stderr, smoothing=0.1,
                dynamic_ncols=True, leave=False)
