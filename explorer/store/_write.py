"""Writing results files: preallocated, chunked, compressed HDF5, committed one chunk at a time.

Crash safety. The file is built with every dataset at its full size under a hidden temporary
name, closed, and renamed into place, so the results path never holds a half-created file. A
chunk of variants is then committed as: write all of its rows, flush, set ``/chunks/done[i]``,
flush. A process killed between flushes (kill -9 included) leaves the metadata of the last flush
on disk plus, at worst, unreferenced bytes at the end of the file, so the file opens and
``/chunks/done`` names exactly the chunks that are complete. Resuming rewrites every chunk that is
not done; variants are a pure function of the study, so the result is the same, bit for bit, as an
uninterrupted run. ``/chunks/done`` is contiguous and uncompressed, so setting a flag is an
in-place write of one byte. HDF5 has no journal: the one window left is a kill in the middle of a
flush's few metadata writes (well under a millisecond per commit).

Compression (measured on this shared 2-core box on 4,096 real ±2 % Jansen foot paths + velocities,
float64, 360 steps, HDF5 chunks of 128 rows; benchmarks/bench_study.py --compression re-measures):

    filter         size/raw    write cost               read
    none           1.00        ~1,000 MB per CPU-s       ~1,700-2,400 MB/s
    lzf            0.96-1.00   ~50-67 MB/s               ~190-345 MB/s
    lzf+shuffle    0.80-0.85   ~60-104 MB per CPU-s      ~220-290 MB/s
    gzip1+shuffle  0.77-0.81   ~37-44 MB per CPU-s       ~120-250 MB/s
    gzip4+shuffle  0.76-0.80   ~25-38 MB/s               ~160-257 MB/s
    gzip4          0.90        ~23-26 MB/s

(ranges: repeated runs on a busy machine, and two kernel versions whose low-order bits differ).

Smooth float64 series keep little redundancy beyond the sign/exponent and high mantissa bytes,
which shuffle groups together; without shuffle neither codec finds much. gzip+shuffle saves only
3-4 % more space than lzf+shuffle at 2.5x its CPU cost (the default study's 115 MB of paths and
velocities: ~1.2 CPU-s with lzf+shuffle, ~3 CPU-s with gzip 1+shuffle), so the (N, steps, 2)
datasets use **lzf + shuffle**. HDF5 chunks of (128, steps, 2) (≈ 0.7 MiB at 360 steps; 8 to 512
rows compress alike) keep reading one variant's path cheap (~2-9 ms).

Study chunks of 2,048 variants: the kernels' throughput is flat above ~512 variants per call
(8,192 variants in calls of 128 → 8,192: 1.17 → 0.92 CPU-s, best at 2,048-4,096), a commit costs a
few ms, and two chunks in flight (one solving, one being written) hold ~50 MB for a foot path with
velocities, whatever N is.
"""

from __future__ import annotations

import json
import math
import os
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numpy as np

from ..errors import UserError
from ..kernels import STATUS_NAMES, plan_for

FORMAT = "explorer-results"
FORMAT_VERSION = 1
#: Status code of a variant whose chunk has not been committed yet (incomplete files only).
STATUS_NOT_RUN = -1
#: Every status code that can appear in ``/status``: the kernels' codes plus ``-1: not-run``.
FILE_STATUS_NAMES = {**{int(k): v for k, v in STATUS_NAMES.items()}, STATUS_NOT_RUN: "not-run"}
#: Filters of the (N, steps, 2) datasets by the study's ``[output] compression``; the default, lzf,
#: chosen by measurement (see the module docstring). On the default study (10,000 x 360 foot paths and
#: velocities, 2 cores) "none" writes 118 MB in 0.9 s end to end and "lzf" 99 MB in 3.0 s.
#: Every chunked dataset also carries a Fletcher-32 checksum per chunk (in every h5py build): a
#: corrupted chunk is a read error, never a number.
SERIES_FILTERS = {"lzf": {"compression": "lzf", "shuffle": True, "fletcher32": True},
                  "gzip": {"compression": "gzip", "compression_opts": 1, "shuffle": True, "fletcher32": True},
                  "none": {"fletcher32": True}}
#: Filters of the small per-variant datasets.
SCALAR_FILTERS = {"compression": "lzf", "fletcher32": True}
#: Target size of one HDF5 chunk of a path-like dataset, bytes.
HDF5_CHUNK_BYTES = 1 << 20
#: Default variants per study chunk (a multiple of the HDF5 chunk rows; see ``chunk_rows``).
DEFAULT_CHUNK_VARIANTS = 2048
#: Upper bound on the solver output one study chunk holds in memory, bytes.
CHUNK_MEMORY = 96 << 20


def hdf5_rows(steps: int) -> int:
    """Rows (variants) per HDF5 chunk of an (N, steps, 2) float64 dataset: a power of two, ≈ 1 MiB."""
    per = steps * 2 * 8
    return max(1, 1 << int(math.floor(math.log2(max(HDF5_CHUNK_BYTES / per, 1.0)))))


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


def _strings(values) -> np.ndarray:
    return np.array([str(v) for v in values], dtype=h5py.string_dtype())


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
        self.vertices = tuple(f["paths"].keys())
        self.velocities = "velocities" in f
        self.accelerations = "accelerations" in f
        # dataset handles, looked up once (h5py lookups cost ~0.1 ms each, per chunk)
        self._scalars = [(f["variants/lengths"], "lengths"), (f["variants/crank"], "crank"), (f["status"], "status"),
                         (f["fail_theta"], "fail_theta"), (f["fail_block"], "fail_block"),
                         (f["iterations"], "iterations")]
        if "fail_theta_end" in f:
            self._scalars.append((f["fail_theta_end"], "fail_theta_end"))
        self._geometry = f["variants/geometry"] if "variants/geometry" in f else None
        self._series = [(f[g][v], g, v) for g in ("paths", "velocities", "accelerations") if g in f for v in f[g]]
        self._torque = f["torque"] if "torque" in f else None
        self._forces = [(f["forces"][j], j) for j in f["forces"]] if "forces" in f else []
        self._done = f["chunks/done"]

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
        vertices = study.vertex_names
        rows = int(rows) if exact_rows else chunk_rows(N, S, study.n_series, rows)
        n_chunks = -(-N // rows)
        h = min(hdf5_rows(S), rows)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.partial")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            f = h5py.File(tmp, "w")
        except (OSError, ValueError) as exc:
            raise UserError(f"{path}: cannot create the results file: {_reason(exc)} "
                            f"(set [output] path in {study.source} or pass -o)") from None
        try:
            plan = plan_for(mech)
            f.attrs["format"] = FORMAT
            f.attrs["format_version"] = FORMAT_VERSION
            f.attrs["explorer_version"] = _version()
            f.attrs["created"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
            f.attrs["complete"] = False
            f.attrs["study"] = study.text
            f.attrs["study_source"] = study.source
            f.attrs["study_resolved"] = json.dumps(study.as_dict())
            f.attrs["study_fingerprint"] = study.fingerprint()
            f.attrs["mechanism"] = study.mechanism_text()
            f.attrs["mechanism_source"] = mech.source
            f.attrs["n_variants"] = N
            f.attrs["steps"] = S

            if mech.crank is not None:
                d = f.create_dataset("theta", data=2.0 * np.pi * np.arange(S) / S)
                d.attrs["units"] = "rad"
                d.attrs["description"] = "crank angle θ_k = 2πk/steps"
            else:  # a path driver's samples are times, t_k = T·k/(steps − 1)
                d = f.create_dataset("theta", data=mech.path.duration * np.arange(S) / (S - 1))
                d.attrs["units"] = "s"
                d.attrs["description"] = "time along the driver's path, t_k = T·k/(steps − 1)"

            g = f.create_group("variants")
            d = g.create_dataset("lengths", shape=(N, len(mech.links)), dtype="f8", chunks=(rows, len(mech.links)),
                                 fillvalue=np.nan, **SCALAR_FILTERS)
            d.attrs["links"] = _strings(mech.link_names)
            d.attrs["link_ends"] = _strings(f"{l.a}-{l.b}" for l in mech.links)
            d.attrs["nominal"] = mech.lengths
            d.attrs["units"] = "model units"
            d = g.create_dataset("crank", shape=(N,), dtype="f8", chunks=(rows,), fillvalue=np.nan, **SCALAR_FILTERS)
            d.attrs["nominal"] = float(mech.crank.radius) if mech.crank is not None else np.nan
            d.attrs["units"] = "model units"
            if mech.crank is None:
                d.attrs["description"] = "no crank: the mechanism is driven along a path (NaN)"
            moved = study.geometry_names
            if moved:  # only a study that moves coordinates has the dataset (older files never do)
                k = len(moved)
                d = g.create_dataset("geometry", shape=(N, k), dtype="f8", chunks=(rows, k), fillvalue=np.nan,
                                     **SCALAR_FILTERS)
                nominal = mech.parameters()
                d.attrs["names"] = _strings(moved)
                d.attrs["nominal"] = np.array([nominal[n] for n in moved], dtype=np.float64)
                d.attrs["units"] = "model units"
                d.attrs["description"] = ("perturbed coordinates (crank centre, ground pivots, body joints in their "
                                          "body's frame), one column per attr 'names'")
            g.attrs["perturbed"] = _strings(study.parameter_names)
            for name, (values, description) in (columns or {}).items():
                values = np.asarray(values)
                if values.shape != (N,) or values.dtype.kind not in "iu":
                    raise ValueError(f"column {name!r}: expected ({N},) integers, got {values.dtype} {values.shape}")
                d = g.create_dataset(name, data=values.astype(np.int64), chunks=(rows,), **SCALAR_FILTERS)
                d.attrs["description"] = description
                d.attrs["column"] = True

            codes = sorted(FILE_STATUS_NAMES)
            d = f.create_dataset("status", shape=(N,), dtype="i1", chunks=(rows,), fillvalue=STATUS_NOT_RUN,
                                 **SCALAR_FILTERS)
            d.attrs["codes"] = np.array(codes, dtype=np.int8)
            d.attrs["names"] = _strings(FILE_STATUS_NAMES[c] for c in codes)
            d.attrs["mapping"] = json.dumps({str(c): FILE_STATUS_NAMES[c] for c in codes})
            d = f.create_dataset("fail_theta", shape=(N,), dtype="f8", chunks=(rows,), fillvalue=np.nan,
                                 **SCALAR_FILTERS)
            d.attrs["units"] = "rad"
            d.attrs["description"] = "crank angle of the first failure; NaN when ok"
            d = f.create_dataset("fail_theta_end", shape=(N,), dtype="f8", chunks=(rows,), fillvalue=np.nan,
                                 **SCALAR_FILTERS)
            d.attrs["units"] = "rad"
            d.attrs["description"] = ("first failing crank angle going backward from 2π: the design cannot turn "
                                      "through [fail_theta, fail_theta_end]; NaN when ok")
            d = f.create_dataset("fail_block", shape=(N,), dtype="i2", chunks=(rows,), fillvalue=-1, **SCALAR_FILTERS)
            d.attrs["description"] = "plan block that failed, -1 when ok; attr 'vertex' maps block -> vertex name"
            d.attrs["vertex"] = _strings(mech.vertices[b.vertices[0]] for b in plan.blocks)
            f.create_dataset("iterations", shape=(N,), dtype="i8", chunks=(rows,), fillvalue=-1, **SCALAR_FILTERS)

            groups = [("paths", True, "model units"), ("velocities", study.velocities, "model units per rad (dV/dθ)"),
                      ("accelerations", study.accelerations, "model units per rad² (d²V/dθ²)")]
            for name, wanted, units in groups:
                if not wanted:
                    continue
                g = f.create_group(name, track_order=True)  # vertices in scene order
                g.attrs["units"] = units
                for v in vertices:
                    d = g.create_dataset(v, shape=(N, S, 2), dtype="f8", chunks=(h, S, 2), fillvalue=np.nan,
                                         **SERIES_FILTERS[study.compression])
                    d.attrs["vertex"] = v
            if getattr(study, "forces", False):
                d = f.create_dataset("torque", shape=(N, S), dtype="f8", chunks=(h, S), fillvalue=np.nan,
                                     **SERIES_FILTERS[study.compression])
                d.attrs["units"] = "N·m"
                d.attrs["description"] = ("motor torque of the walker's crankshaft at each crank angle, positive when "
                                          "the motor does positive work (inertia, weight and the load included)")
                d.attrs["operating"] = json.dumps(study.operating.as_dict())
                g = f.create_group("forces", track_order=True)
                g.attrs["units"] = "N"
                g.attrs["description"] = ("leg 0's reaction at each joint: the force its most heavily loaded member "
                                          "(a link, a body, the crank, the frame or the ground) puts on the pin")
                for j in study.force_joints:
                    d = g.create_dataset(j, shape=(N, S, 2), dtype="f8", chunks=(h, S, 2), fillvalue=np.nan,
                                         **SERIES_FILTERS[study.compression])
                    d.attrs["joint"] = j
            f.create_group("metrics", track_order=True)  # metrics in the order computed

            g = f.create_group("chunks")
            g.attrs["rows"] = rows
            g.attrs["description"] = "chunk i holds variants [i*rows, min((i+1)*rows, N)); done[i] once committed"
            g.create_dataset("done", shape=(n_chunks,), dtype=bool, fillvalue=False)  # contiguous
            g["done"][...] = False
            f.close()
            # the results path appears only now, complete with every dataset: a run killed earlier
            # leaves no half-made file there (at most a hidden .partial next to it)
            os.replace(tmp, path)
            f = h5py.File(path, "r+")
        except BaseException:
            f.close()
            tmp.unlink(missing_ok=True)
            raise
        return cls(f, path)

    @classmethod
    def resume(cls, path, study) -> "ResultsWriter":
        """Open an existing results file of ``study`` to finish it (UserError if it is not one)."""
        path = Path(path)
        try:
            f = h5py.File(path, "r+")
        except (OSError, ValueError) as exc:
            raise UserError(f"{path}: cannot open the results file to resume it: {_reason(exc)}") from None
        try:
            if f.attrs.get("format") != FORMAT or "chunks/done" not in f:
                raise UserError(f"{path}: not an explorer results file; use --force to overwrite it")
            if f.attrs.get("study_fingerprint") != study.fingerprint():
                try:
                    old = json.loads(f.attrs["study_fingerprint"])
                except (KeyError, TypeError, ValueError):
                    old = {}
                raise UserError(f"{path}: written by a different run: {fingerprint_diff(old, json.loads(study.fingerprint()))}"
                                f"; --resume would mix two designs' results; use --force to start it over")
        except BaseException:
            f.close()
            raise
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
        if self._geometry is not None:
            shape = (b - a, self._geometry.shape[1])
            if geometry is None or np.shape(geometry) != shape:
                raise ValueError(f"chunk {i}: expected geometry of shape {shape}, got "
                                 f"{None if geometry is None else np.shape(geometry)}")
        f = self.f
        values = {"lengths": lengths, "crank": crank, "status": batch.status, "fail_theta": batch.fail_theta,
                  "fail_theta_end": batch.fail_theta_end, "fail_block": batch.fail_block,
                  "iterations": batch.iterations}
        for d, key in self._scalars:
            d[a:b] = values[key]
        if self._geometry is not None:
            self._geometry[a:b] = geometry
        for d, group, v in self._series:
            d[a:b] = getattr(batch, group)[v]
        if self._torque is not None:
            self._torque[a:b] = batch.torque
        for d, j in self._forces:
            d[a:b] = batch.forces[j]
        for name, values in (metrics or {}).items():
            g = f["metrics"]
            if name not in g:
                d = g.create_dataset(name, shape=(self.n_variants,), dtype="f8", chunks=(self.chunk_rows,),
                                     fillvalue=np.nan, **SCALAR_FILTERS)
                from ..gait import metric
                row = metric(name)
                if row is not None:  # self-describing from the first write, not only after a recompute
                    d.attrs["units"] = row.unit
                    d.attrs["description"] = row.description
            g[name][a:b] = values
        self._commit(i)

    def _commit(self, i: int) -> None:
        self.f.flush()
        self._done[i] = True
        self.f.flush()
        self.done[i] = True

    def finish(self) -> None:
        """Mark the file complete (every chunk must be done) and flush."""
        if not self.done.all():
            raise RuntimeError(f"{self.path}: {int((~self.done).sum())} chunks are not done")
        self.f.attrs["complete"] = True
        self.f.attrs["completed"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
        self.f.flush()

    def close(self) -> None:
        if self.f.id.valid:
            self.f.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def fingerprint_diff(old: dict, new: dict) -> str:
    """What differs between two study fingerprints, in words."""
    words = {"mechanism_sha256": "the mechanism file's content changed",
             "explorer_version": f"explorer is now version {new.get('explorer_version')} "
                                 f"(the file was started by {old.get('explorer_version', 'an older version')})"}
    out = []
    for key, value in new.items():
        if isinstance(value, dict):
            was = old.get(key, {}) if isinstance(old.get(key), dict) else {}
            out += [f"{key}.{k}" for k in value if was.get(k) != value[k]]
        elif old.get(key) != value:
            out.append(words.get(key, key))
    return "differs in " + ", ".join(out) if out else "its layout differs"


def _reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    text = text[0] if text else type(exc).__name__
    if isinstance(exc, PermissionError) or "ermission" in text:
        return "permission denied"
    if "unable to lock" in text.lower():
        return "the file is in use by another process (unable to lock it)"
    if "truncated" in text.lower() or "signature" in text.lower() or "sblock" in text.lower():
        return f"not a readable HDF5 file (truncated or corrupt: {text})"
    return text
