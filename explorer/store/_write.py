"""Writing results files: preallocated, chunked, compressed HDF5, committed one chunk at a time.

Crash safety. The file is built with every dataset at its full size under a hidden temporary
name, closed, and renamed into place, so the results path never holds a half-created file. A
chunk of variants is then committed as: write all of its rows; at the next sync (at once, or for
``explorer run`` about once a second: :data:`SYNC_SECONDS`, ``ResultsWriter.sync``), flush, set the
digests and ``/chunks/done`` of every chunk written since the last sync and the metadata checksum,
flush. A process killed between flushes (kill -9 included) leaves the metadata of the last flush
on disk plus, at worst, unreferenced bytes at the end of the file, so the file opens and
``/chunks/done`` names exactly the chunks that are complete (what was written since the last sync is
solved again by a resume: the resume unit).

Series rows are filtered off the GIL and written whole HDF5 chunk by chunk with ``write_direct_chunk``
(:mod:`explorer.store._chunks`): the same bytes HDF5's own pipeline stores, checked by HDF5 the same
way when read. Resuming rewrites every chunk that is
not done; variants are a pure function of the study, so the result is the same, bit for bit, as an
uninterrupted run. ``/chunks/done`` is contiguous and uncompressed, so setting a flag is an
in-place write of one byte. HDF5 has no journal: the one window left is a kill in the middle of a
flush's few metadata writes (well under a millisecond per commit).

Compression (measured on this shared 2-core box, load 1.2-1.3, on 4,096 real ±2 % Jansen foot paths +
velocities, float64, 360 steps, 47 MB raw, HDF5 chunks of 128 rows, Fletcher-32 on every filter, read
back bit for bit; ``python benchmarks/bench_study.py --compression`` re-measures):

    [output] compression  filters                      size/raw  write cost         read
    blosc (default)       Blosc LZ4 5 + byte shuffle   0.83      ~640-770 MB/CPU-s  ~890-1,170 MB/s
    zstd                  shuffle + Zstandard 3        0.80      ~320 MB/CPU-s      ~710 MB/s
    lzf                   lzf + shuffle                0.85      ~92 MB/CPU-s       ~310 MB/s
    gzip                  gzip 1 + shuffle             0.81      ~47 MB/CPU-s       ~260 MB/s
    none                  (Fletcher-32 only)           1.00      ~1,070 MB/CPU-s    ~1,240 MB/s
    (not offered)         Blosc LZ4 1 + shuffle        0.85      ~800 MB/CPU-s      ~1,020 MB/s
                          Blosc LZ4 5 + bitshuffle     0.83      ~610 MB/CPU-s      ~840 MB/s
                          Blosc Zstd 1 / 3 + shuffle   0.86/0.82 ~310 / ~190 MB/CPU-s
                          shuffle + Zstandard 1        0.81      ~410 MB/CPU-s      ~740 MB/s
                          Blosc LZ4HC 3 + shuffle      0.80      ~49 MB/CPU-s

Smooth float64 series keep little redundancy beyond the sign/exponent and high mantissa bytes,
which a byte shuffle groups together; the low mantissa bytes are noise to every codec, so no codec
gets below ~0.8 (float32 or a lossy codec would, but the stored values are the kernels' bit for bit).
What differs is the cost: on 2 cores the kernels use both, so every CPU-second of compression is
wall time added to the run. Blosc's LZ4 behind its own shuffle is both smaller than lzf + shuffle
(0.83 vs 0.85) and eight times cheaper: 100,000 × 360 foot paths and velocities (1.15 GB raw) cost
~1.6 CPU-s with it against ~12 with lzf, so it is the default. "zstd" saves 3 % more space at twice
the CPU. Both are HDF5 plugin filters (32001, 32015) from the ``hdf5plugin`` package, a core
dependency: explorer registers them on import; plain h5py reads these files after ``import
hdf5plugin`` (the root attribute ``series_filter`` says so). HDF5 chunks of (128, steps, 2) (≈ 0.7
MiB at 360 steps; 8 to 512 rows compress alike) keep reading one variant's path cheap (~2-9 ms).

Study chunks of 2,048 variants: the kernels' throughput is flat above ~512 variants per call
(8,192 variants in calls of 128 → 8,192: 1.17 → 0.92 CPU-s, best at 2,048-4,096), a commit costs a
few ms, and two chunks in flight (one solving, one being written) hold ~50 MB for a foot path with
velocities, whatever N is.
"""

from __future__ import annotations

import errno
import json
import math
import os
import sys
import time
from glob import escape as glob_escape
from pathlib import Path

import h5py
import numpy as np

from ..errors import UserError
from ._chunks import ChunkFilter, write_rows
from ._datasets import (FILE_STATUS_NAMES, SCALAR_FILTERS, SERIES, SERIES_FILTER_WORDS, SERIES_FILTERS, STATUS_NOT_RUN,
                        VARIANT_DATA, Commit, create_dataset, create_group, metric_attrs, now, strings)
from ._integrity import (DIGEST, RESTORE, digests, has_integrity, metadata_checksum, per_variant,
                         salvage, stamp, verify, warn_legacy)

__all__ = ["SCALAR_FILTERS", "SERIES_FILTERS", "FILE_STATUS_NAMES", "STATUS_NOT_RUN"]  # noqa: F822 (the rest is public by name)

FORMAT = "explorer-results"
FORMAT_VERSION = 1
#: Filters of the (N, steps, 2) datasets by the study's ``[output] compression`` (the default, blosc, chosen
#: by measurement: see the module docstring), and of the small per-variant datasets: defined beside the
#: dataset table, :mod:`explorer.store._datasets`.
#: (re-exported here for older imports)
#: Target size of one HDF5 chunk of a path-like dataset, bytes.
HDF5_CHUNK_BYTES = 1 << 20
#: HDF5's chunk cache per dataset of a file being written, bytes (one HDF5 chunk of a series). Commits
#: write whole chunks, so the cache only holds what was just written; HDF5 2.0's default, 8 MiB per
#: dataset, kept ~8 MiB of every metric dataset resident: 300 MB -> 485 MB of peak memory from 100,000 to
#: 1,000,000 lean variants, where with 1 MiB memory is flat in N (benchmarks/bench_lean.py).
WRITE_CACHE_BYTES = HDF5_CHUNK_BYTES
#: HDF5 file-format bounds of every results file written (``h5py.File(..., libver=LIBVER)``): object
#: headers of version 2 (HDF5 1.8 and later read them), whose attributes move to dense storage (a fractal
#: heap) when they outgrow the 64 kB header message: the link names and nominal lengths of a 9,999-vertex
#: chain (~80 kB each), or its mechanism text (~700 kB), where version-1 headers fail with "object header
#: message is too large".
LIBVER = ("v108", "latest")
#: Default variants per study chunk (a multiple of the HDF5 chunk rows; see ``chunk_rows``).
DEFAULT_CHUNK_VARIANTS = 2048
#: Seconds of commits marked done together by ``explorer run`` (``ResultsWriter.sync_every``): the unit a
#: kill -9 can lose (what was written since the last sync; a resume solves it again). One sync costs two
#: flushes and the metadata checksum, which walks every attribute of the file (tens of ms on a lean file
#: of 40 metric datasets): once a commit, it was the commit thread's largest cost.
SYNC_SECONDS = 1.0
#: Upper bound on the solver output one study chunk holds in memory, bytes.
CHUNK_MEMORY = 96 << 20


def hdf5_rows(steps: int) -> int:
    """Rows (variants) per HDF5 chunk of an (N, steps, 2) float64 dataset: a power of two, ≈ 1 MiB."""
    per = steps * 2 * 8
    return max(1, 1 << int(math.floor(math.log2(max(HDF5_CHUNK_BYTES / per, 1.0)))))


def series_rows(rows: int, steps: int) -> int:
    """Rows per HDF5 chunk of the series of a file committed ``rows`` variants at a time: :func:`hdf5_rows`,
    or a divisor of ``rows`` not under half of it, so that every commit covers whole HDF5 chunks (they
    are then written with ``write_direct_chunk``: :mod:`explorer.store._chunks`); ``rows`` itself when
    smaller. Files written before keep their layout (the writer sends a commit's partial chunks through
    h5py)."""
    h = hdf5_rows(steps)
    if rows <= h:
        return rows
    return next((d for d in range(h, h // 2 - 1, -1) if rows % d == 0), h)


def chunk_rows(n_variants: int, steps: int, n_series: int, target: int | None = None) -> int:
    """Variants per study chunk: ``target`` (default :data:`DEFAULT_CHUNK_VARIANTS`) rounded to a
    multiple of the HDF5 chunk rows, lowered so that ``n_series`` (N, steps, 2) outputs fit in
    :data:`CHUNK_MEMORY`, and never more than N (memory stays flat in N)."""
    h = hdf5_rows(steps)
    target = DEFAULT_CHUNK_VARIANTS if target is None else int(target)
    cap = CHUNK_MEMORY // max(1, n_series * steps * 2 * 8)
    rows = max(1, min(target, cap))
    rows = max(h, (rows // h) * h) if rows >= h else rows
    return max(1, min(rows, n_variants))


def _version() -> str:
    from .. import __version__
    return __version__


class ResultsWriter:
    """An open results file being filled chunk by chunk (see :meth:`create` and :meth:`resume`).

    Attributes: ``path``; ``n_variants`` N; ``chunk_rows`` variants per chunk; ``n_chunks``;
    ``done`` (n_chunks,) bool, the committed chunks.
    """

    def __init__(self, f: h5py.File, path: Path):
        self.f, self.path = f, path
        self.n_variants = int(f.attrs["n_variants"])
        self.chunk_rows = int(f["chunks"].attrs["rows"])
        self.n_chunks = int(f["chunks/done"].shape[0])
        self.done = np.asarray(f["chunks/done"][...], dtype=bool)
        self.vertices = tuple(f["paths"].keys()) if "paths" in f else ()  # none in a lean file
        self.velocities = "velocities" in f
        self.accelerations = "accelerations" in f
        # dataset handles, looked up once (h5py lookups cost ~0.1 ms each, per chunk)
        # every per-variant dataset of the registry the file has (explorer.store._datasets.VARIANT_DATA)
        self._scalars = [(f[spec.path], spec) for spec in VARIANT_DATA if spec.path in f]
        self._geometry = f["variants/geometry"] if "variants/geometry" in f else None
        # every stored series (explorer.store._datasets.SERIES): (dataset, its spec, its member name or None)
        self._series = [(f[s.group][m] if s.member else f[s.group], s, m if s.member else None)
                        for s in SERIES if s.group in f for m in (f[s.group] if s.member else [None])]
        # each series' filter pipeline, applied off the GIL (explorer.store._chunks; None: written through h5py)
        self._filters = [ChunkFilter.of(d) for d, _, _ in self._series]
        self._done = f["chunks/done"]
        self._metrics: dict = {}  # name -> its /metrics dataset, as written
        # files of this version carry checksums (explorer.store._integrity), kept up to date at every
        # commit; a file started by an earlier version is finished as it was begun, without them
        self.integrity = has_integrity(f) and DIGEST in f
        self._digest = f[DIGEST] if self.integrity else None
        self._covered = None  # the datasets the chunk digests cover (looked up once, again after a new metric)
        self._row_size = None  # uncompressed bytes of one row of every per-variant dataset (likewise)
        self._reserved = 0  # end of the space reserved for commits (given back at close)
        self._last, self._ratio = None, None  # (file end, raw bytes) at the last reservation; bytes/raw seen
        #: Seconds between syncs (:meth:`sync`): chunks written meanwhile are marked done together, with one
        #: metadata checksum; 0 (the default): every chunk at its commit. ``explorer run`` uses SYNC_SECONDS.
        self.sync_every = 0.0
        self._unsynced: list[int] = []  # chunks written whole since the last sync
        self._synced_at = -math.inf

    # -- opening ---------------------------------------------------------------------------------------
    @classmethod
    def create(cls, path, study, rows: int | None = None, columns: dict | None = None,
               exact_rows: bool = False) -> "ResultsWriter":
        """Create ``path`` for ``study``, every dataset preallocated (replacing any file there).

        The file is built under a hidden temporary name next to ``path`` and renamed into place
        once it holds every dataset, so ``path`` never holds a half-created file.

        rows : variants per study chunk (default from :func:`chunk_rows`; taken as given with
        ``exact_rows``, as an optimiser's population).
        columns : {name: ((N,) integer array, description)} known before any variant is solved (an
        optimisation's ``generation``), stored as ``/variants/<name>`` and read as frame columns.
        """
        path = Path(path)
        mech = study.mech
        N, S = study.n_variants, study.steps
        rows = int(rows) if exact_rows else chunk_rows(N, S, study.n_series, rows)
        n_chunks = -(-N // rows)
        h = series_rows(rows, S)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.partial")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            f = h5py.File(tmp, "w", rdcc_nbytes=WRITE_CACHE_BYTES, libver=LIBVER)
        except (OSError, ValueError) as exc:
            raise UserError(f"{path}: cannot create the results file: {write_error_reason(exc)} "
                            f"(set [output] path in {study.source} or pass -o)") from None
        except BaseException:  # a signal while h5py opens it (HDF5 has created the file by then): no leftover
            tmp.unlink(missing_ok=True)
            raise
        try:
            f.attrs["format"] = FORMAT
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["explorer_version"] = _version()
            f.attrs["created"] = now()
            f.attrs["complete"] = False
            f.attrs["study"] = study.text
            f.attrs["study_source"] = study.source
            f.attrs["study_resolved"] = json.dumps(study.as_dict())
            f.attrs["study_fingerprint"] = study.fingerprint()
            f.attrs["mechanism"] = study.mechanism_text()
            f.attrs["mechanism_source"] = mech.source
            lean = getattr(study, "lean", False)
            if lean:  # a lean study: no series; how to re-solve them bit for bit (explorer.store.Results)
                f.attrs["store"] = "metrics"
                f.attrs["series_solve"] = json.dumps(study.series_solve())
            if getattr(study, "forces", False):  # the walker's force model, which `explorer show` names
                f.attrs["body"] = study.operating.body
            f.attrs["n_variants"] = N
            f.attrs["steps"] = S
            f.attrs["series_filter"] = f"{study.compression}: {SERIES_FILTER_WORDS[study.compression]}"
            dims = {"N": N, "S": S, "links": len(mech.links), "k": len(study.geometry_names), "chunks": n_chunks}

            def make(name, **kw):  # every dataset from its row of the dataset table
                return create_dataset(f, name, dims, rows=rows, series_rows=h, compression=study.compression, **kw)

            if mech.crank is not None:
                make("theta", data=2.0 * np.pi * np.arange(S) / S)
            else:  # a path driver's samples are times, t_k = T·k/(steps − 1)
                make("theta", data=mech.path.duration * np.arange(S) / (S - 1), attrs={
                    "units": "s", "description": "time along the driver's path, t_k = T·k/(steps − 1)"})

            g = create_group(f, "variants", track_order=False)
            g.attrs["perturbed"] = strings(study.parameter_names)
            for name, (values, description) in (columns or {}).items():
                values = np.asarray(values)
                if values.shape != (N,) or values.dtype.kind not in "iu":
                    raise ValueError(f"column {name!r}: expected ({N},) integers, got {values.dtype} {values.shape}")
                make(f"variants/{name}", data=values, attrs={"description": description, "column": True})
            for spec in VARIANT_DATA:  # the per-variant datasets (explorer.store._datasets.VARIANT_DATA)
                if spec.stored is None or spec.stored(study):
                    make(spec.path, attrs=spec.attrs(study) if spec.attrs else None)

            for spec in SERIES:  # the series the scene asks for (none in a lean file: re-solved when read)
                if lean or not spec.stored(study):
                    continue
                if not spec.member:
                    make(spec.group, attrs=spec.attrs(study) if spec.attrs else None)
                    continue
                create_group(f, spec.group)  # members in scene order
                for name in spec.members(study):
                    make(f"{spec.group}/{name}", attrs={spec.member: name})
            # metrics in the order computed; the band they are computed with, as `explorer metrics` records it
            metrics_group(f, band=study.band)

            g = create_group(f, "chunks", track_order=False, attrs={
                "rows": rows,
                "description": "chunk i holds variants [i*rows, min((i+1)*rows, N)); done[i] once committed"})
            make("chunks/done")  # contiguous
            g["done"][...] = False
            make("chunks/digest")  # contiguous: each chunk's SHA-256, set with done[i]
            g["digest"][...] = 0
            stamp(f)  # the metadata checksum, kept up to date by every later change
            f.close()
            # the results path appears only now, complete with every dataset: a run killed earlier
            # leaves no half-made file there (at most a hidden .partial next to it)
            os.replace(tmp, path)
            f = h5py.File(path, "r+", rdcc_nbytes=WRITE_CACHE_BYTES)
        except BaseException:
            f.close()
            tmp.unlink(missing_ok=True)
            raise
        return cls(f, path)

    @classmethod
    def resume(cls, path, study) -> "ResultsWriter":
        """Open an existing results file of ``study`` to finish it (UserError if it is not one, or if it
        does not verify: :func:`~explorer.store._integrity.verify`, so that a resume never builds on
        damaged metadata or committed rows). The file is checked (and, after a kill in a commit,
        salvaged) in a child process first (:mod:`explorer.store._guard`): damaged bytes that make
        HDF5 loop are refused in one line."""
        from ._guard import Unreadable, call
        path = Path(path)
        try:
            legacy = call(_check_resumable, path, study.fingerprint())
        except Unreadable as exc:
            raise UserError(f"{path}: not a readable explorer results file (damaged: {exc}); use --force to start "
                            f"it over") from None
        try:
            f = h5py.File(path, "r+", rdcc_nbytes=WRITE_CACHE_BYTES)
        except (OSError, ValueError) as exc:
            raise UserError(f"{path}: cannot open the results file to resume it: {write_error_reason(exc)}") from None
        if legacy:
            warn_legacy(path)
        return cls(f, path)

    # -- filling ----------------------------------------------------------------------------------------
    def chunk_range(self, i: int) -> tuple[int, int]:
        """Variants [start, stop) of chunk ``i``."""
        return i * self.chunk_rows, min((i + 1) * self.chunk_rows, self.n_variants)

    def pending(self) -> list[int]:
        """Indices of the chunks not yet committed."""
        return [i for i in range(self.n_chunks) if not self.done[i]]

    @property
    def complete(self) -> bool:
        return bool(self.f.attrs["complete"])

    def write_chunk(self, i: int, lengths, crank, batch, metrics: dict | None = None, geometry=None,
                    partial: bool = False) -> None:
        """Commit chunk ``i`` atomically: its rows of every dataset, flush, then ``done[i]``, flush.

        lengths (n, n_links), crank (n,), batch : the :class:`~explorer.kernels.Batch` of these n
        variants; metrics : optional {name: (n,) array}, stored under ``/metrics/<name>``;
        geometry : (n, g) perturbed coordinates, required when the file has ``/variants/geometry``
        (columns in its ``names`` order). partial : the n variants are the chunk's first n (an
        optimiser's generation with fewer designs than its population); the rest keep status
        "not-run". Pass n = 0 with ``batch=None`` to commit the chunk with no variant run.
        """
        a, b = self.chunk_range(i)
        if partial:
            if len(crank) > b - a:
                raise ValueError(f"chunk {i}: at most {b - a} variants, got {len(crank)}")
            b = a + len(crank)
            if b == a:
                self._commit(i)
                return
        if len(crank) != b - a:
            raise ValueError(f"chunk {i}: expected {b - a} variants, got {len(crank)}")
        # room for the whole commit is reserved before a byte of it is written: a disk that fills
        # (this run, or another writer) stops the run here, with the file as it was at the last commit
        self._reserve(i, b - a, len(metrics or ()))
        if self._geometry is not None:
            shape = (b - a, self._geometry.shape[1])
            if geometry is None or np.shape(geometry) != shape:
                raise ValueError(f"chunk {i}: expected geometry of shape {shape}, got "
                                 f"{None if geometry is None else np.shape(geometry)}")
        f = self.f
        commit = Commit(lengths, crank, batch, geometry, metrics)
        for d, spec in self._scalars:
            d[a:b] = spec.rows(commit)
        for (d, spec, name), chunk_filter in zip(self._series, self._filters):
            write_rows(d, a, b, spec.rows(batch, name), chunk_filter)
        g = f["metrics"]
        known = self._metrics  # the metric datasets, looked up once (h5py lookups cost ~0.1 ms each)
        new = [name for name in (metrics or {}) if name not in known and name not in g]
        for name in new:  # self-describing from the first write, as `explorer metrics` writes it
            create_metric(g, name, self.n_variants, self.chunk_rows, self._band())
        if new:
            self._covered = self._row_size = None
            if self.integrity:  # the new datasets and their checksum reach the disk in one flush
                stamp(f)
                f.flush()
        for name, values in (metrics or {}).items():
            if name not in known:
                known[name] = g[name]
            known[name][a:b] = values
        self._commit(i)

    def _row_bytes(self) -> int:
        """Uncompressed bytes of one variant's row of every per-variant dataset now in the file."""
        if self._row_size is None:
            total = []
            self.f.visititems(lambda name, o: total.append(int(np.prod(o.shape[1:])) * o.dtype.itemsize)
                              if isinstance(o, h5py.Dataset) and o.ndim >= 1 and o.shape[0] == self.n_variants
                              and not name.startswith("chunks") else None)
            self._row_size = sum(total)
        return self._row_size

    def _reserve(self, i: int, rows: int, new_metrics: int) -> None:
        """Reserve the disk space commit ``i`` can take before writing it: its ``rows`` of every
        per-variant dataset (+ 8 bytes per row of each of ``new_metrics`` metric datasets not created
        yet), uncompressed, times the compression the file has had so far (the largest ratio of bytes
        written to bytes stored of any commit of this process, +10 %; before the first, 0.9 with a
        filter, as measured on foot paths, 1.1 without), plus 64 kB and 2 kB per dataset for HDF5's
        metadata. The space is
        allocated to the file beyond its end (``fallocate`` with KEEP_SIZE, Linux), so no other writer
        can take it; where that is not supported, the free space is checked instead. A disk too full is
        a one-line UserError raised before anything of the commit is written: the file stays exactly
        as the last commit left it, and --resume finishes it once there is room."""
        raw = (self._row_bytes() + 8 * new_metrics) * rows
        fd = self.f.id.get_vfd_handle()
        end = os.fstat(fd).st_size
        if self._last is not None and raw > 0:  # what the previous commit of this process took
            prev_end, prev_raw = self._last
            if prev_raw > 0:
                self._ratio = max(self._ratio or 0.0, (end - prev_end) / prev_raw)
        self._last = (end, raw)
        compressed = self._series and self._series[0][0].compression is not None
        ratio = 1.1 * self._ratio if self._ratio else (0.9 if compressed else 1.1)
        need = int(raw * ratio) + (64 << 10) + 2048 * (len(self._series) + 40)
        err = _fallocate(fd, end, need)
        if err is None:
            self._reserved = max(self._reserved, end + need)
            return
        if err in (errno.ENOSPC, errno.EDQUOT):
            free = None
        else:  # not supported here (another OS or filesystem): the free space, checked
            import shutil
            try:
                free = shutil.disk_usage(self.path.parent).free
            except OSError:
                return
            if free >= need:
                return
        try:  # the chunks written whole before this one are kept
            self.sync()
        except Exception:  # noqa: BLE001 - the disk is full: they stay not done (a resume solves them again)
            pass
        done = int(self.done.sum())
        have = "" if free is None else f", {_size(free)} free"
        kept = (f"the {done} of {self.n_chunks} chunks committed before are kept" if done else
                "no chunk was committed yet")
        raise DiskFull(f"{self.path}: the disk is full: committing chunk {i + 1} of {self.n_chunks} needs up to "
                       f"{_size(need)}{have}; nothing of it was written and {kept}: free some space and run "
                       f"again with --resume")

    def _release(self) -> None:
        """Give back what :meth:`_reserve` allocated beyond the end of the closed file."""
        reserved = self._reserved
        if not reserved:
            return
        self._reserved = 0
        try:
            fd = os.open(self.path, os.O_WRONLY)
        except OSError:
            return
        try:
            end = os.fstat(fd).st_size
            if reserved > end:
                _fallocate(fd, end, reserved - end, punch=True)
        finally:
            os.close(fd)

    def _band(self) -> float:
        """The stance band the run's metrics are computed with: ``/metrics`` attr band, else the study's."""
        g = self.f["metrics"]
        if "band" in g.attrs:
            return float(g.attrs["band"])
        from ..gait import DEFAULT_BAND
        try:
            return float(json.loads(self.f.attrs["study_resolved"])["scene"]["band"])
        except (KeyError, TypeError, ValueError):
            return DEFAULT_BAND

    def _commit(self, i: int) -> None:
        """Chunk ``i``'s rows are written: it joins the group :meth:`sync` marks done, now (``sync_every``
        0) or once ``sync_every`` seconds have passed since the last sync."""
        self._unsynced.append(int(i))
        if self.sync_every <= 0 or time.monotonic() - self._synced_at >= self.sync_every:
            self.sync()

    def sync(self) -> None:
        """Mark done every chunk written since the last sync: their rows reach the disk (flush), then, in
        one more flush, their digests, their ``done`` flags and the metadata checksum that covers them
        (one checksum per group of commits: it walks every attribute of the file)."""
        indices = sorted(set(self._unsynced) - set(np.flatnonzero(self.done).tolist()))
        if not indices:
            self._unsynced = []
            return
        self.f.flush()
        if self.integrity:
            if self._covered is None:
                self._covered = per_variant(self.f, self.n_variants)
            for i, got in zip(indices, digests(self._covered, [self.chunk_range(i) for i in indices])):
                self._digest[i] = np.frombuffer(got, dtype=np.uint8)
        self._done[indices] = True
        if self.integrity:
            stamp(self.f)
        self.f.flush()
        self.done[indices] = True
        self._unsynced = []
        self._synced_at = time.monotonic()

    def skip_chunks(self, indices) -> None:
        """Commit the chunks ``indices`` with no variant run (their rows stay "not-run") in one go: their
        digests and done flags, then one metadata checksum and flush (an optimisation's restart rounds
        that never began: committed one by one, each commit's checksum of the whole file made it
        quadratic)."""
        self._unsynced += [int(i) for i in indices]
        self.sync()

    def stamp(self) -> None:
        """Update the metadata checksum after attributes were set directly (a Dask shard's done marker);
        the caller flushes or closes."""
        if self.integrity:
            stamp(self.f)

    def finish(self) -> None:
        """Mark the file complete (every chunk must be done) and flush."""
        self.sync()
        if not self.done.all():
            raise RuntimeError(f"{self.path}: {int((~self.done).sum())} chunks are not done")
        self.f.attrs["complete"] = True
        self.f.attrs["completed"] = now()
        self.stamp()
        self.f.flush()

    def close(self) -> None:
        """Mark done the chunks written since the last sync (:meth:`sync`; if that fails they stay not
        done, and a resume solves them again), close the file."""
        if self.f.id.valid:
            try:
                self.sync()
            except Exception:  # noqa: BLE001 - already failing (a full disk ...): the file as the last sync left it
                pass
            self.f.close()
            self._release()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def _check_resumable(path: Path, fingerprint: str) -> bool:
    """What :meth:`ResultsWriter.resume` checks before it opens ``path`` (run in a child process): a
    results file of the study with this fingerprint that verifies, or is salvaged (UserError otherwise).
    True for a file written without checksums (the caller warns)."""
    try:  # read only: a file HDF5 opens for writing is marked so in its superblock until it is closed, and
        # this process may be stopped (the file looping HDF5): only the salvage below writes
        f = h5py.File(path, "r", rdcc_nbytes=WRITE_CACHE_BYTES)
    except (OSError, ValueError) as exc:
        raise UserError(f"{path}: cannot open the results file to resume it: {write_error_reason(exc)}") from None
    try:
        if f.attrs.get("format") != FORMAT or "chunks/done" not in f:
            raise UserError(f"{path}: not an explorer results file; use --force to overwrite it")
        if f.attrs.get("study_fingerprint") != fingerprint:
            try:
                old = json.loads(f.attrs["study_fingerprint"])
            except (KeyError, TypeError, ValueError):
                old = {}
            raise UserError(f"{path}: written by a different run: {fingerprint_diff(old, json.loads(fingerprint))}"
                            f"; --resume would mix two designs' results; use --force to start it over")
        try:
            legacy = not verify(f, path, warn=False)
        except UserError as exc:
            # a kill during the last commit's flush may leave its marks half written: the chunks that
            # do not match their digests are solved again; anything else is damage
            f.close()
            f = h5py.File(path, "r+", rdcc_nbytes=WRITE_CACHE_BYTES)
            if not salvage(f):
                raise UserError(f"{exc}".replace(RESTORE, "use --force to start it over")) from None
            legacy = False
        if legacy:  # no checksum read every attribute: read them here, before the caller does
            metadata_checksum(f)
        return legacy
    finally:
        f.close()


class DiskFull(UserError):
    """The disk has no room for the next commit (raised before any of it is written)."""


def _size(n: int) -> str:
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:,.1f} {unit}"
    return f"{n} bytes"


_LIBC = []


def _fallocate(fd: int, offset: int, length: int, punch: bool = False) -> int | None:
    """Linux fallocate(2) with FALLOC_FL_KEEP_SIZE (the file's size is unchanged; blocks past its end
    are allocated to it), or with FALLOC_FL_PUNCH_HOLE to give them back. None on success, else the
    errno (ENOTSUP / ENOSYS where it is not available)."""
    if not sys.platform.startswith("linux"):
        return errno.ENOTSUP
    if not _LIBC:
        import ctypes
        import ctypes.util
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
            fn = libc.fallocate
            fn.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.c_int64, ctypes.c_int64]
            fn.restype = ctypes.c_int
        except (OSError, AttributeError):
            fn = None
        _LIBC.append(fn)
    fn = _LIBC[0]
    if fn is None:
        return errno.ENOTSUP
    import ctypes
    mode = 0x01 | (0x02 if punch else 0)  # KEEP_SIZE (| PUNCH_HOLE)
    if fn(int(fd), mode, int(offset), int(length)) == 0:
        return None
    return ctypes.get_errno() or errno.EIO


def copy_for_update(path, extra: int) -> Path:
    """A copy of the results file ``path`` beside it (a hidden ``.NAME.<pid>.partial``), for a writer that
    changes a finished file (``explorer metrics``) and renames the copy over it once complete
    (:func:`replace_with`), so that a failure leaves ``path`` as it was. Room for the copy and for
    ``extra`` more bytes (+10 %, + 1 MB for HDF5's metadata) is reserved first (``fallocate``, or the
    free space checked where it is not supported): a disk without it is a one-line :class:`DiskFull`
    before anything is written. The space reserved beyond the end is given back by :func:`replace_with`."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.partial")
    for old in path.parent.glob(f".{glob_escape(path.name)}.*.partial"):  # a killed update's (the caller holds
        old.unlink(missing_ok=True)                                       # the output lock: nobody's now)
    size = path.stat().st_size
    need = size + int(1.1 * max(0, int(extra))) + (1 << 20)
    try:
        src = os.open(path, os.O_RDONLY)
    except OSError as exc:
        raise UserError(f"{path}: cannot read the results file: {exc.strerror or exc}") from None
    try:
        try:
            dst = os.open(tmp, os.O_RDWR | os.O_CREAT | os.O_TRUNC, os.stat(path).st_mode & 0o777)
        except OSError as exc:
            raise UserError(f"{path}: cannot write beside it ({tmp.name}): {exc.strerror or exc}; it is unchanged") \
                from None
        try:
            err = _fallocate(dst, 0, need)
            free = None
            if err is not None and err not in (errno.ENOSPC, errno.EDQUOT):  # not supported: the free space
                import shutil
                try:
                    free = shutil.disk_usage(path.parent).free
                except OSError:
                    free = need
                err = None if free >= need else errno.ENOSPC
            if err is not None:
                have = "" if free is None else f", {_size(free)} free"
                raise DiskFull(f"{path}: the disk is full: updating the file needs up to {_size(need)} beside it "
                               f"(a copy, renamed over it once complete){have}; nothing was written and the file is "
                               f"unchanged: free some space and run it again")
            _copy_bytes(src, dst, size)
        except BaseException:
            os.close(dst)
            tmp.unlink(missing_ok=True)
            raise
        os.close(dst)
    finally:
        os.close(src)
    return tmp


def _copy_bytes(src: int, dst: int, size: int) -> None:
    """Copy ``size`` bytes from ``src`` to ``dst`` (in the kernel where it can: copy_file_range, which
    also shares the blocks on filesystems that can), without truncating ``dst`` (its reserved blocks)."""
    done = 0
    fast = hasattr(os, "copy_file_range")
    while done < size:
        n = 0
        if fast:
            try:
                n = os.copy_file_range(src, dst, min(size - done, 1 << 30), done, done)
            except OSError as exc:
                if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO):
                    raise
                fast = False
                continue
        else:
            data = os.pread(src, min(size - done, 1 << 22), done)
            if data:
                n = os.pwrite(dst, data, done)
        if n <= 0:
            raise OSError(errno.EIO, "the results file ended while it was copied")
        done += n


class Exclusive:
    """``with Exclusive(path):`` — no process has the results file at ``path`` open (HDF5 takes a shared
    ``flock`` on every file it opens, so this exclusive one fails while any reader holds it, and keeps new
    readers out while held), without opening it for writing (HDF5 marks a file it opens for writing in
    its superblock, a write to the file). UserError naming the file otherwise. Open the file yourself with
    ``open_h5(path, "r", locking=False)`` meanwhile. Where ``fcntl`` does not exist, nothing is checked."""

    def __init__(self, path):
        self.path, self.fd = Path(path), None

    def __enter__(self):
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows
            return self
        self.fd = os.open(self.path, os.O_RDONLY)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(self.fd)
            self.fd = None
            raise UserError(f"{self.path}: cannot open the results file for writing: the file is open in another "
                            f"process (close it, or wait for `explorer run` to finish)") from None
        return self

    def __exit__(self, *exc):
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


def replace_with(tmp, path) -> None:
    """Make the finished copy ``tmp`` (:func:`copy_for_update`) the file at ``path``: synced, renamed over
    it in one step, the folder synced, and the space reserved beyond its end given back."""
    tmp, path = Path(tmp), Path(path)
    fd = os.open(tmp, os.O_RDWR)
    try:
        os.fsync(fd)
        end = os.fstat(fd).st_size
        _fallocate(fd, end, 1 << 40, punch=True)  # what the reservation left beyond the end
        os.ftruncate(fd, end)  # (filesystems that punch no hole past the end free it on a truncate)
    finally:
        os.close(fd)
    os.replace(tmp, path)
    try:
        dfd = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(dfd)
    except OSError:
        pass
    finally:
        os.close(dfd)


def fingerprint_diff(old: dict, new: dict) -> str:
    """What differs between two study fingerprints, in words."""
    words = {"mechanism_sha256": "the mechanism file's content changed",
             "explorer_version": f"explorer is now version {new.get('explorer_version')} "
                                 f"(the file was started by {old.get('explorer_version', 'an older version')})"}
    out = []
    for key, value in new.items():
        if isinstance(value, dict):
            was = old.get(key, {}) if isinstance(old.get(key), dict) else {}
            out += [f"{key}.{k}" for k in dict.fromkeys([*value, *was]) if was.get(k) != value.get(k)]
        elif old.get(key) != value:
            out.append(words.get(key, key))
    return "differs in " + ", ".join(out) if out else "its layout differs"


def open_h5(p: Path, mode: str, **kw) -> h5py.File:
    """``h5py.File(p, mode, **kw)`` of a results file already verified (:func:`~explorer.store.inspect`);
    a one-line UserError saying why it cannot be opened (another process holding it, permissions ...)."""
    try:
        return h5py.File(p, mode, **kw)
    except (OSError, ValueError) as exc:
        reason = write_error_reason(exc)
        if "unable to lock" in reason or "in use" in reason:
            reason = "the file is open in another process (close it, or wait for `explorer run` to finish)"
        raise UserError(f"{p}: cannot open the results file{' for writing' if mode != 'r' else ''}: {reason}") \
            from None


def metrics_group(f: h5py.Group, name: str = "metrics", band: float | None = None, computed: str | None = None):
    """A new group of metric datasets (``/metrics`` or a replacement being built), with the
    attributes every file's ``/metrics`` carries: description, ``band`` and ``computed``."""
    attrs = {}
    if band is not None:
        attrs["band"] = float(band)
    if computed is not None:
        attrs["computed"] = computed
    g = create_group(f, name, attrs=attrs)
    if name != "metrics":  # the replacement gets what /metrics carries
        from ._datasets import GROUPS
        for k, v in GROUPS["metrics"].items():
            g.attrs.setdefault(k, v)
    return g


def create_metric(g: h5py.Group, name: str, n_variants: int, rows: int, band: float,
                  computed: str | None = None) -> h5py.Dataset:
    """Dataset ``name`` (N,) in the metrics group ``g``, NaN-filled, with the attributes every
    metric carries (:func:`~explorer.store._datasets.metric_attrs`)."""
    return create_dataset(g, name, {"N": n_variants}, rows=rows, attrs=metric_attrs(name, band, computed),
                          like="metrics/<name>")


def write_error_reason(exc: BaseException) -> str:
    """A short reason, in words, why writing a results file failed (permission, a lock held, a full disk …)."""
    text = str(exc).strip().splitlines()
    text = text[0] if text else type(exc).__name__
    if isinstance(exc, PermissionError) or "ermission" in text:
        return "permission denied"
    if "unable to lock" in text.lower():
        return "the file is in use by another process (unable to lock it)"
    if "truncated" in text.lower() or "signature" in text.lower() or "sblock" in text.lower():
        return f"not a readable HDF5 file (truncated or corrupt: {text})"
    return text
