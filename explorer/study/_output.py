"""What every runner shares (``run_study``, its Dask form, ``run_optimize``): the checks made before a
results file is touched (:func:`validate_study`, :func:`results_path`), the state of an existing file,
the status counts, and :class:`RunSummary`. A module of its own so that the runners depend on it and
not on each other."""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._files import format_size
from ..errors import UserError, where
from ..kernels import STATUS_NAMES, assemble
from ..store import FILE_STATUS_NAMES, ResultsWriter
from ._chunk import compute_study_metrics, metric_plan
from ._spec import Study


@dataclass
class RunSummary:
    """What :func:`run_study` did. ``os.fspath(summary)`` is the results path, so the summary can be
    passed wherever a path is expected (``explorer.open_results(run_study(...))``).

    path : the results file. name : the study's name. n_variants : N. steps : crank samples.
    ran : variants solved by this call (fewer than N after ``resume``; 0 if the file was complete).
    counts : {status name: variants} over the whole file (they add up to N).
    wall_s : seconds this call took. resumed : True if it finished an existing file.
    already_complete : True if ``resume`` found the file complete and did nothing.
    timings : {stage: wall seconds} of this call (``explorer.study._run.STAGES``: sample, solve,
        metrics on the main thread; write on the commit thread, overlapping them; wait, the main
        thread blocked on the commit thread); empty when nothing ran.
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
    timings: dict = field(default_factory=dict)

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
    _check_disk_space(study, out, resume)
    for name, v in sizes.items():
        if v is not None and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
            raise UserError(f"{name.replace('_', ' ')}: expected an integer ≥ 1 (variants), got {v!r}")
    return out


def estimated_bytes(study, rows: int | None = None) -> int:
    """An upper estimate of a study's results file (or of the ``rows`` variants of it still to be
    written): every stored series uncompressed (compression saves 15-20 %) plus the per-variant
    columns, 5 % for HDF5's chunk indexes and checksums, and the metadata every file carries whatever
    its size: ~3 kB of headers and index per dataset and ~64 kB more (study, mechanism, attributes).
    Measured (jansen, 1-2,000 variants, 24-360 steps, lzf, gzip and none): files are 0.52-0.95 of this
    estimate; the data term alone plus 5 % (the estimate before) undercounted them by 1.08x (300 x 36,
    gzip), 1.31x (100 x 72) and up to 69x (1 variant: 108 kB of metadata for 1.5 kB of data)."""
    from ..gait import METRICS
    n_metrics = len(METRICS) if study.metrics is True else len(study.metrics or ())
    n_forces = (1 + len(study.force_joints)) if getattr(study, "forces", False) else 0
    per_variant = (study.n_series * study.steps * 2 * 8 + n_forces * study.steps * 2 * 8
                   + (len(study.mech.links) + len(study.geometry_names) + 12 + n_metrics) * 8)
    n = study.n_variants if rows is None else int(rows)
    datasets = study.n_series + n_forces + 12 + n_metrics
    fixed = (64 << 10) + 3 * 1024 * datasets + len(study.text) + 4 * len(study.mechanism_text())
    return int(n * per_variant * 1.05) + (fixed if rows is None else 0)


def _check_disk_space(study, out: Path, resume: bool = False) -> None:
    """Refuse, before anything is written, a study whose results would not fit on the disk; with
    ``resume`` and an existing file of the study, only the variants not yet committed count (what is
    written is already on the disk)."""
    import shutil
    folder = out.parent if str(out.parent) else Path(".")
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    pending = _pending_rows(out) if resume else None
    need = estimated_bytes(study) if pending is None else estimated_bytes(study, pending)
    if need > free:
        left = "" if pending is None else f" (the {pending:,} variants not yet committed)"
        raise UserError(f"{out}: the study would write up to {format_size(need)}{left} and {folder} has {format_size(free)} "
                        f"free; store fewer vertices, steps or variants (or use another disk)")


def _pending_rows(out: Path) -> int | None:
    """Variants of the results file ``out`` whose chunks are not committed, or None if it cannot be
    read (then the whole study counts; a file that commits nothing is started over by ``--resume``)."""
    if not out.is_file():
        return None
    from ..store import guarded
    try:
        return guarded(_pending, out)  # in a child process: damaged bytes cannot hang the run here
    except Exception:  # noqa: BLE001 - unreadable or damaged (or looping: Unreadable): its own opening says so
        return None


def _pending(out: Path) -> int | None:
    import h5py
    with h5py.File(out, "r") as f:
        n, rows = int(f.attrs["n_variants"]), int(f["chunks"].attrs["rows"])
        done = np.asarray(f["chunks/done"][...], dtype=bool)
        if not done.any():
            return None
        return int(sum(min((i + 1) * rows, n) - i * rows for i in np.flatnonzero(~done)))


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


def status_counts(codes: np.ndarray) -> dict:
    """{status name: variants} of a ``/status`` column, every kernel status listed."""
    counts = {name: 0 for code, name in sorted(STATUS_NAMES.items())}
    for c, n in zip(*np.unique(codes, return_counts=True)):
        counts[FILE_STATUS_NAMES.get(int(c), f"code {int(c)}")] = int(n)
    return counts


def _counts(writer) -> dict:
    """:func:`status_counts` of an open :class:`~explorer.store.ResultsWriter`."""
    return status_counts(writer.f["status"][...])


def _state(path: Path) -> str:
    from ..store import probe
    info = probe(path)
    if info["error"] is not None:
        return "unreadable or in use"
    if info["format"] is None:
        return "not an explorer results file"
    return "complete" if info["complete"] else "incomplete"


def optimize_writer(out: Path, study: Study):
    """A new results file for an ``[optimize]`` study: P = ``[optimize] population`` rows a chunk (one
    generation), and a ``generation`` column (rows g·P … g·P + P − 1 hold generation g). What
    ``explorer optimize`` and ``explorer synth`` (its designs as one generation) write into."""
    P = study.optimize.population
    generation = np.arange(study.n_variants, dtype=np.int64) // P
    return ResultsWriter.create(out, study, P, exact_rows=True, columns={
        "generation": (generation, f"optimiser generation (rows g*{P} … g*{P}+{P - 1}); the nominal design, "
                                   f"when inside the bounds, is variant 0")})
