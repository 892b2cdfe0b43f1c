"""Running a study: chunks of variants → ``simulate_batch`` → HDF5, with progress, resume and a summary."""

from __future__ import annotations

import os
import queue
import stat
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import Terminated, UserError, signals_held, where
from ..gait import start_kernel_warmup, stop_kernel_warmup
from ..kernels import STATUS_NAMES, assemble
from ..store._lock import OutputLock
from ..store._write import FILE_STATUS_NAMES, ResultsWriter
from ._chunk import chunk_solver, compute_study_metrics, metric_plan
from ._spec import Study, load_study


@dataclass
class RunSummary:
    """What :func:`run_study` did. ``os.fspath(summary)`` is the results path, so the summary can be
    passed wherever a path is expected (``explorer.open_results(run_study(...))``).

    path : the results file. name : the study's name. n_variants : N. steps : crank samples.
    ran : variants solved by this call (fewer than N after ``resume``; 0 if the file was complete).
    counts : {status name: variants} over the whole file (they add up to N).
    wall_s : seconds this call took. resumed : True if it finished an existing file.
    already_complete : True if ``resume`` found the file complete and did nothing.
    """

    path: Path
    name: str
    n_variants: int
    steps: int
    ran: int
    counts: dict = field(default_factory=dict)
    wall_s: float = 0.0
    resumed: bool = False
    already_complete: bool = False

    def __fspath__(self) -> str:
        return str(self.path)

    @property
    def configurations_per_s(self) -> float:
        """Crank configurations solved per second by this call (ran × steps / wall_s)."""
        return self.ran * self.steps / self.wall_s if self.wall_s > 0 else float("nan")

    @property
    def failed(self) -> int:
        return sum(n for k, n in self.counts.items() if k != "ok")

    def text(self) -> str:
        """The multi-line summary ``explorer run`` prints."""
        if self.already_complete:
            return f"{self.path}: already complete ({self.n_variants:,} variants); nothing to do"
        ok = self.counts.get("ok", 0)
        reasons = ", ".join(f"{k} {n:,}" for k, n in self.counts.items() if k != "ok" and n)
        verb = "resumed" if self.resumed else "ran"
        lines = [
            f"{self.name}: {verb} {self.ran:,} of {self.n_variants:,} variants × {self.steps} steps → {self.path}",
            f"  ok {ok:,}, failed {self.failed:,}" + (f" ({reasons})" if reasons else ""),
            f"  wall {self.wall_s:.2f} s, {_rate(self.configurations_per_s)} configurations/s",
        ]
        return "\n".join(lines)

    __str__ = text


def _rate(x: float) -> str:
    if not x == x:
        return "n/a"
    return f"{x / 1e6:.2f} M" if x >= 1e5 else f"{x:,.0f}"


def run_study(study=None, output=None, resume: bool = False, force: bool = False, progress: bool = True,
              chunk_size: int | None = None) -> RunSummary:
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

    Returns a :class:`RunSummary` (``os.fspath`` gives the results path). Raises
    :class:`~explorer.errors.UserError` for a bad study, an existing file, or an unwritable path.
    """
    t0 = time.perf_counter()
    study = load_study(study)
    out = results_path(study, output, resume, force, chunk_size=chunk_size)
    # on an empty Numba cache, a second process compiles the metric kernels while this one compiles
    # the solver (Numba compiles under one lock per process): 20.4 s -> see the README's cold start
    warm = start_kernel_warmup() if metric_plan(study)[2] else None
    try:
        validate_study(study)
        with OutputLock(out):  # one run per output, from creation to the end
            return _run_locked(study, out, resume, force, progress, chunk_size, t0)
    finally:
        stop_kernel_warmup(warm)


def _run_locked(study, out: Path, resume: bool, force: bool, progress: bool, chunk_size, t0: float) -> RunSummary:
    resumed = False
    if out.exists():
        if resume:
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
    try:
        pending = writer.pending()
        solve = chunk_solver(study)
        bar = _progress_bar(progress, writer, pending, study)
        committer = _Committer(writer, bar, study.steps, threaded=_THREADED)
        try:
            for i in pending:
                a, b = writer.chunk_range(i)
                lengths, crank, geometry, batch, metrics = solve(a, b)
                committer.put(i, lengths, crank, geometry, batch, metrics)
                ran += b - a
            committer.close()
        except KeyboardInterrupt as exc:
            with signals_held():  # a second Ctrl-C must not cut the commit in flight (h5py would crash)
                committer.abort()
                done = int(writer.done.sum())
            what = "terminated" if isinstance(exc, Terminated) else "interrupted"
            raise type(exc)(f"{out}: {what} with {done} of {writer.n_chunks} chunks committed; run again with "
                            f"--resume to finish it") from None
        finally:
            with signals_held():
                committer.abort()
                if bar is not None:
                    bar.close()
        writer.finish()
        counts = _counts(writer)
    finally:
        with signals_held():
            writer.close()
    return RunSummary(out, study.name, study.n_variants, study.steps, ran, counts, time.perf_counter() - t0,
                      resumed=resumed)


def validate_study(study: Study, optimizing: bool = False) -> None:
    """The checks every runner makes before touching a file: the study is of the runner's kind
    (sampled, or an ``[optimize]`` search when ``optimizing``), the nominal design assembles at the
    first sample, and the metrics and band the scene asks for are valid (UserError otherwise)."""
    if study.optimize is not None and not optimizing:
        raise UserError(f"{study.source}: has an [optimize] table; run it with `explorer optimize {study.source}` "
                        f"(explorer run samples a [perturb] study)")
    mech = study.mech
    _, fail = assemble(mech)
    if fail is not None:
        raise UserError(f"{where(study.source, 'study.mechanism')}: the nominal design cannot be assembled at "
                        f"θ = 0: {fail.message}")
    if metric_plan(study)[2]:
        z = np.zeros((1, study.steps, 2))
        crank = np.array([mech.crank.radius if mech.crank is not None else 1.0])
        try:
            compute_study_metrics(study, z, z, np.ones(1, dtype=np.int8), mech.lengths[None, :], crank)
        except UserError as exc:
            raise UserError(f"{where(study.source, 'scene.metrics')}: {exc}") from None


def results_path(study, output, resume: bool, force: bool, **sizes) -> Path:
    """The results file of a run (``output``, else the study's ``[output] path``) after the checks every
    runner shares: --resume and --force exclude each other, the path is not a folder, and each of
    ``sizes`` (e.g. chunk_size=…) is None or a whole number of variants ≥ 1."""
    out = Path(output if output is not None else study.output)
    if resume and force:
        raise UserError("--resume and --force exclude each other: resume finishes a file, force starts it over")
    if out.is_dir():
        raise UserError(f"{out}: is a folder; the results path must be a file such as {out / (study.name + '.h5')}")
    inputs = [("study", study.source), ("mechanism", study.mechanism_path)]
    for what, src in inputs:
        if src and Path(src).is_file() and _same_file(out, Path(src)):
            raise UserError(f"{out}: is the run's own {what} file; choose another results path with -o")
    if force and (out.exists() or out.is_symlink()):
        _check_overwritable(out)
    _check_disk_space(study, out)
    for name, v in sizes.items():
        if v is not None and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
            raise UserError(f"{name.replace('_', ' ')}: expected an integer ≥ 1 (variants), got {v!r}")
    return out


def estimated_bytes(study) -> int:
    """An upper estimate of a study's results file: every stored series uncompressed (compression
    saves 15-20 %), plus the per-variant columns."""
    per_variant = study.n_series * study.steps * 2 * 8 + (len(study.mech.links) + len(study.geometry_names) + 32) * 8
    return study.n_variants * per_variant


def _check_disk_space(study, out: Path) -> None:
    """Refuse, before anything is written, a study whose results would not fit on the disk."""
    import shutil
    folder = out.parent if str(out.parent) else Path(".")
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    need = int(estimated_bytes(study) * 1.05)  # uncompressed, plus HDF5's own overhead: an upper bound
    if need > free:
        raise UserError(f"{out}: the study would write up to {_size(need)} and {folder} has {_size(free)} free; "
                        f"store fewer vertices, steps or variants (or use another disk)")


def _size(n: int) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:,.1f} {unit}"
    return f"{n} bytes"


def _same_file(a: Path, b: Path) -> bool:
    try:
        if a.exists():
            return os.path.samefile(a, b)
        return a.resolve() == b.resolve()
    except OSError:
        return False


def _check_overwritable(out: Path) -> None:
    """--force replaces explorer results files only: not a study, a mechanism, a device, anything else."""
    from ..store import FORMAT, probe
    if out.is_symlink() or not stat.S_ISREG(out.stat().st_mode):
        raise UserError(f"{out}: is not a regular file; --force overwrites explorer results files only")
    info = probe(out)
    if info["error"] == "in use":
        raise UserError(f"{out}: is open in another process; wait for it to finish")
    if info["format"] != FORMAT:
        raise UserError(f"{out}: is not an explorer results file; --force overwrites explorer results files only "
                        f"(move it away or choose another output with -o)")


#: Commit chunks on a background thread while the next chunk is solved (h5py releases the GIL while
#: it compresses and writes, so HDF5 work overlaps the kernels). Off: commit inline (for measurement).
_THREADED = True


class _Committer:
    """Commits solved chunks in order, on a background thread (at most one chunk queued, so memory
    stays at two chunks whatever N is) or inline. Errors of the thread are raised in the caller."""

    def __init__(self, writer: ResultsWriter, bar, steps: int, threaded: bool = True):
        self.writer, self.bar, self.steps = writer, bar, steps
        self.error: BaseException | None = None
        self.thread = None
        if threaded:
            self.queue = queue.Queue(maxsize=1)
            self.thread = threading.Thread(target=self._loop, name="explorer-commit", daemon=True)
            self.thread.start()

    def _commit(self, item) -> None:
        i, lengths, crank, geometry, batch, metrics = item
        self.writer.write_chunk(i, lengths, crank, batch, metrics, geometry=geometry)
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
        while True:
            try:
                self.queue.put(item, timeout=0.1)
                return
            except queue.Full:
                self._check()
                if not self.thread.is_alive():
                    raise RuntimeError("the commit thread stopped")

    def close(self) -> None:
        """Wait until every queued chunk is committed; raise the thread's error if any."""
        if self.thread is not None:
            self._stop()
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


def _counts(writer: ResultsWriter) -> dict:
    codes = writer.f["status"][...]
    counts = {name: 0 for code, name in sorted(STATUS_NAMES.items())}
    for c, n in zip(*np.unique(codes, return_counts=True)):
        counts[FILE_STATUS_NAMES.get(int(c), f"code {int(c)}")] = int(n)
    return counts


def _state(path: Path) -> str:
    from ..store import probe
    info = probe(path)
    if info["error"] is not None:
        return "unreadable or in use"
    if info["format"] is None:
        return "not an explorer results file"
    return "complete" if info["complete"] else "incomplete"


def _progress_bar(progress: bool, writer: ResultsWriter, pending, study):
    if not progress or not pending:
        return None
    if not (hasattr(sys.stderr, "isatty") and sys.stderr.isatty()):
        return None
    from tqdm import tqdm
    total = sum(b - a for a, b in map(writer.chunk_range, pending)) * study.steps
    return tqdm(total=total, unit="cfg", unit_scale=True, desc=study.name, file=sys.stderr, smoothing=0.1,
                dynamic_ncols=True, leave=False)
