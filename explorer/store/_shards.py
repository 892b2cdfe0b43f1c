"""Sharded results: one HDF5 file per shard (written by one worker each), stitched into one study file.

HDF5 has no safe concurrent writer without MPI, so a study run on a cluster
(:func:`explorer.study.run_study_dask`) is cut into *shards*, contiguous ranges of variants. Each
worker writes its own shard file into a folder beside the results file::

    results/jansen-2pct.h5                 the study file (virtual datasets: ~30 kB + ~2.5 kB per shard)
    results/jansen-2pct.shards/            one folder per study file
        manifest.json                      study fingerprint and the shard layout (rows per shard)
        shard-00000.h5 … shard-NNNNN.h5    variants [i·rows, min((i+1)·rows, N)) each

A shard file is an ordinary results file of the *whole* study (made by
:class:`~explorer.store.ResultsWriter`, so its datasets, filters, chunking and attributes are
exactly those of a single-process run) in which only the shard's chunks are written: HDF5 allocates
no space for chunks never written, so it holds just its rows. It is built under a hidden temporary
name and renamed into place only once every row is written, closed and synced, with the root
attributes ``shard_done = True``, ``shard_start``, ``shard_stop`` and ``study_fingerprint``: a shard
file under its final name is complete (the "done marker"), and a run that dies leaves at most a
hidden ``.shard-*.partial`` file, which the next resume (or the end of the run, when Dask redid
that shard) deletes.

When every shard is done, :func:`stitch` writes the study file: the same layout as a
single-process file (see :mod:`explorer.store`), every per-variant dataset an h5py *virtual
dataset* mapping rows [a, b) to rows [a, b) of shard i through a path relative to the study
file's folder (``jansen-2pct.shards/shard-00003.h5``). HDF5 resolves relative source paths against
the folder of the file that holds the virtual dataset, so the study file and its shards folder can
be moved together anywhere. ``/chunks`` describes the shards (``rows`` = shard rows, all done), the
root attribute ``shards`` names the folder, and :func:`check_sources` (called by
:func:`~explorer.store.open_results`) turns a missing shard into an error, where HDF5 alone would
silently read fill values (NaN, status "not-run").
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import socket
import uuid
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numpy as np

from ..errors import UserError
from ._datasets import create_dataset
from ._guard import call as guarded
from ._integrity import DIGEST, READ_CACHE_BYTES, digests_many, has_integrity, per_variant, stamp
from ._write import FORMAT, LIBVER, ResultsWriter, chunk_rows, hdf5_rows

#: Name of the shard-layout file in a shards folder.
MANIFEST = "manifest.json"
#: Shards per worker aimed for when the study is small enough (load balance: the last wave of
#: tasks leaves workers idle for at most ~1/4 of a shard each).
SHARDS_PER_WORKER = 4
#: Fewest crank configurations (variants × steps) per shard. Measured on the shared 2-core box
#: (benchmarks/bench_dask.py --overhead, one core): a shard costs 20-45 ms fixed (HDF5 file create
#: ~12 ms, first-chunk metadata, close, fsync, rename; Dask's round trip adds ~4-6 ms per task) plus
#: 0.57-1.0 µs per configuration (solve ~45 %, lzf+shuffle write ~55 %). 2^19 configurations
#: (1,457 variants at 360 steps, 0.3-0.55 s of one core) keep the fixed part to ~6-13 %; larger
#: studies get larger shards (SHARDS_PER_WORKER per worker), where it falls below 5 %.
MIN_SHARD_CONFIGURATIONS = 1 << 19
#: Most shard files per study: above this, shards grow instead (file count on shared filesystems,
#: and the study file's virtual-dataset mappings: one per shard per dataset).
MAX_SHARDS = 1000


def shards_folder(output) -> Path:
    """The shards folder of results file ``output``: ``results/name.h5`` → ``results/name.shards``."""
    out = Path(output)
    return out.with_name((out.stem if out.suffix else out.name) + ".shards")


def shard_name(i: int) -> str:
    """File name of shard ``i`` (``shard-00003.h5``)."""
    return f"shard-{i:05d}.h5"


# -- layout -------------------------------------------------------------------------------------------
class ShardPlan:
    """The layout of a sharded study: N variants; ``chunk_rows`` per solve call and HDF5 commit
    (``chunk_target`` is what :class:`~explorer.store.ResultsWriter` is asked for, giving
    ``chunk_rows``); ``shard_rows`` (a multiple of ``chunk_rows``) per shard; ``n_shards`` shards."""

    def __init__(self, n_variants: int, chunk_target: int, chunk_rows: int, shard_rows: int, fingerprint: str,
                 created: str = ""):
        if shard_rows % chunk_rows:
            raise ValueError(f"shard rows {shard_rows} are not a multiple of the chunk rows {chunk_rows}")
        self.n_variants, self.chunk_target = int(n_variants), int(chunk_target)
        self.chunk_rows, self.shard_rows = int(chunk_rows), int(shard_rows)
        self.fingerprint = fingerprint
        self.created = created or datetime.now(timezone.utc).isoformat(timespec="seconds")
        self.n_shards = -(-self.n_variants // self.shard_rows)

    def range(self, i: int) -> tuple[int, int]:
        """Variants [start, stop) of shard ``i``."""
        return i * self.shard_rows, min((i + 1) * self.shard_rows, self.n_variants)

    def same_layout(self, other: "ShardPlan") -> bool:
        return (self.n_variants, self.chunk_rows, self.shard_rows, self.fingerprint) == \
            (other.n_variants, other.chunk_rows, other.shard_rows, other.fingerprint)

    def to_json(self) -> str:
        return json.dumps({"format": FORMAT + "-shards", "n_variants": self.n_variants,
                           "chunk_target": self.chunk_target, "chunk_rows": self.chunk_rows,
                           "shard_rows": self.shard_rows, "n_shards": self.n_shards, "created": self.created,
                           "study_fingerprint": self.fingerprint}, indent=1)

    @classmethod
    def read(cls, folder) -> "ShardPlan | None":
        """The plan stored in ``folder`` (None if there is none or it cannot be read)."""
        try:
            d = json.loads((Path(folder) / MANIFEST).read_text(encoding="utf-8"))
            return cls(d["n_variants"], d["chunk_target"], d["chunk_rows"], d["shard_rows"], d["study_fingerprint"],
                       d.get("created", ""))
        except (OSError, ValueError, KeyError, TypeError):
            return None

    def write(self, folder) -> None:
        """Store the plan in ``folder`` (created if needed) atomically."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        tmp = folder / f".{MANIFEST}.{os.getpid()}.partial"
        tmp.write_text(self.to_json(), encoding="utf-8")
        os.replace(tmp, folder / MANIFEST)


def plan_shards(study, workers: int = 1, shard_size: int | None = None, chunk_size: int | None = None) -> ShardPlan:
    """Choose the shard layout of ``study`` for a cluster running ``workers`` tasks at a time.

    Default shard size: :data:`SHARDS_PER_WORKER` shards per worker (load balance), but at least
    :data:`MIN_SHARD_CONFIGURATIONS` crank configurations per shard (task overhead) and at most
    :data:`MAX_SHARDS` shards (file count); when there are more shards than workers their number is
    rounded up to a multiple of the workers. ``shard_size`` (variants) overrides it. A shard is
    solved and committed in k equal chunks of at most the memory-bounded chunk size
    (:func:`~explorer.store.chunk_rows`, 2,048 variants by default or ``chunk_size``); the chunk is
    rounded up to whole HDF5 chunks, so the shard size may grow slightly (by < k × 128 variants at
    360 steps).
    """
    N, S = study.n_variants, study.steps
    n_series = study.n_series
    if shard_size is None:
        want = math.ceil(N / (SHARDS_PER_WORKER * max(1, int(workers))))
        want = max(want, math.ceil(MIN_SHARD_CONFIGURATIONS / S), math.ceil(N / MAX_SHARDS))
        n, w = -(-N // want), max(1, int(workers))
        if n > w and n % w:  # a whole number of waves: every worker gets as many shards
            want = math.ceil(N / (-(-n // w) * w))
    else:
        want = int(shard_size)
    want = max(1, min(want, N))
    base = chunk_rows(N, S, n_series, chunk_size)  # the memory-bounded chunk (≤ N)
    h = hdf5_rows(S)
    k = -(-want // base)  # chunks per shard
    target = -(-want // k)
    if target >= h:
        target = -(-target // h) * h  # whole HDF5 chunks (≤ base, a multiple of h when ≥ h)
    rows = chunk_rows(N, S, n_series, target)
    shard = k * target
    if shard >= N:  # one shard
        shard = -(-N // rows) * rows
    elif rows != target:  # cannot happen (target is a fixed point of chunk_rows below N); keep it safe
        shard = -(-shard // rows) * rows
    return ShardPlan(N, target, rows, shard, study.fingerprint())


# -- shard files --------------------------------------------------------------------------------------
def shard_complete(path, plan: ShardPlan, i: int, metrics: list | None = None) -> bool:
    """True if ``path`` is a complete shard ``i`` of ``plan`` (its done marker set, same study and
    range). ``metrics``, if a list, receives the names under the shard's ``/metrics``."""
    a, b = plan.range(i)
    try:
        with h5py.File(path, "r") as f:
            at = f.attrs
            ok = (bool(at.get("shard_done", False)) and at.get("study_fingerprint") == plan.fingerprint
                  and int(at.get("shard_start", -1)) == a and int(at.get("shard_stop", -1)) == b
                  and int(f["chunks"].attrs["rows"]) == plan.chunk_rows)
            if ok and metrics is not None and "metrics" in f:
                metrics.extend(f["metrics"].keys())
            return ok
    except (OSError, KeyError, ValueError):
        return False


def write_shard(folder, plan: ShardPlan, i: int, study, solve) -> bool:
    """Solve and write shard ``i`` of ``plan`` into ``folder`` atomically; False if it was already there.

    solve(a, b) → (lengths, crank, geometry, batch, metrics) for variants [a, b) (one chunk). The file is
    made under a hidden temporary name, every chunk of the shard written, closed, fsynced and only
    then renamed to ``shard-0000i.h5``: a worker killed at any point leaves no file under that name.
    """
    folder = Path(folder)
    final = folder / shard_name(i)
    if final.exists() and guarded(shard_complete, final, plan, i):
        return False  # a retried task whose first attempt finished (e.g. the worker died after the rename)
    a, b = plan.range(i)
    tag = f"{socket.gethostname()}-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    tmp = folder / f".{final.name}.{tag}.partial"
    try:
        writer = ResultsWriter.create(tmp, study, plan.chunk_target)
        try:
            if writer.chunk_rows != plan.chunk_rows:  # the shard layout must be the study's
                raise RuntimeError(f"shard {i}: chunk rows {writer.chunk_rows} != {plan.chunk_rows}")
            first, last = a // plan.chunk_rows, -(-b // plan.chunk_rows)
            for c in range(first, last):
                ca, cb = writer.chunk_range(c)
                lengths, crank, geometry, batch, metrics = solve(ca, cb)
                writer.write_chunk(c, lengths, crank, batch, metrics, geometry=geometry)
            at = writer.f.attrs
            at["shard_index"] = i
            at["shard_start"] = a
            at["shard_stop"] = b
            at["shard_host"] = tag
            at["shard_done"] = True  # the done marker (the rename below publishes it)
            writer.stamp()  # the metadata checksum covers the marker too
        finally:
            writer.close()
        _fsync(tmp)
        os.replace(tmp, final)
    except BaseException:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass
        raise
    return True


def _fsync(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def clean_folder(folder, everything: bool = False) -> None:
    """Delete leftover temporary files in ``folder`` (and, with ``everything``, its shards and
    manifest too, for a forced restart). Only explorer's own file names are touched."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    for p in folder.iterdir():
        name = p.name
        # .shard-00003.h5.<host-pid-id>.partial, and ResultsWriter's own ..shard-….partial.<pid>.partial
        ours_tmp = name.lstrip(".").startswith(("shard-", f"{MANIFEST}.")) and name.endswith(".partial")
        ours = name == MANIFEST or (name.startswith("shard-") and name.endswith(".h5"))
        if p.is_file() and (ours_tmp or (everything and ours)):
            p.unlink(missing_ok=True)


def completed_shards(folder, plan: ShardPlan) -> list[bool]:
    """For each shard of ``plan``: is a complete shard file in ``folder``? (Read in a child process,
    :mod:`explorer.store._guard`: a shard whose bytes make HDF5 loop cannot hang the run; then none is
    taken for complete, and the stitch or the next open says which is damaged.)"""
    from ._guard import Unreadable
    try:
        return guarded(_completed_shards, Path(folder), plan)
    except Unreadable:
        return [False] * plan.n_shards


def _completed_shards(folder: Path, plan: ShardPlan) -> list[bool]:
    return [(folder / shard_name(i)).exists() and shard_complete(folder / shard_name(i), plan, i)
            for i in range(plan.n_shards)]


# -- stitching ----------------------------------------------------------------------------------------
def stitch(output, folder, plan: ShardPlan) -> None:
    """Write the study file ``output``: every per-variant dataset of the shards as one virtual dataset.

    Every shard must be complete. The file is built under a hidden temporary name and renamed into
    place. Source paths are relative (``<folder name>/shard-00000.h5``), so ``output`` must be in
    the parent folder of ``folder`` and the pair can be moved together. The shards are read (and the
    file written) in a child process (:mod:`explorer.store._guard`): a damaged shard that makes HDF5
    loop or crash is a one-line error.
    """
    from ._guard import Unreadable
    out = Path(output)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.partial")
    try:
        guarded(_stitch, out, Path(folder), plan, tmp)
    except Unreadable as exc:
        raise UserError(f"{output}: cannot stitch its shards in {folder}: {exc}; delete the damaged shard files "
                        f"and run the study again with --resume") from None
    finally:
        tmp.unlink(missing_ok=True)  # the child's, when it was stopped (Ctrl-C) or died


def _stitch(out: Path, folder: Path, plan: ShardPlan, tmp: Path) -> None:
    """:func:`stitch`'s work (in the child), building the file at ``tmp``."""
    if folder.resolve().parent != out.resolve().parent:
        raise ValueError(f"{folder}: the shards folder must be beside {out}")
    names = [shard_name(i) for i in range(plan.n_shards)]
    rel = [f"{folder.name}/{n}" for n in names]
    metric_names = None
    for i, n in enumerate(names):  # one pass: every shard complete, and all with the same metrics
        found: list = []
        if not shard_complete(folder / n, plan, i, found):
            raise RuntimeError(f"{folder / n}: shard {i} is missing or not complete")
        these = set(found)
        if metric_names is None:
            metric_names = these
        elif these != metric_names:
            raise RuntimeError(f"{folder / n}: metrics {sorted(these)} differ from shard 0's {sorted(metric_names)}")
    with h5py.File(folder / names[0], "r", rdcc_nbytes=READ_CACHE_BYTES) as src0:
        try:
            with h5py.File(tmp, "w", libver=LIBVER) as f:
                for k, v in src0.attrs.items():
                    if not k.startswith("shard_"):
                        f.attrs[k] = v
                f.attrs["created"] = plan.created
                f.attrs["complete"] = True
                f.attrs["completed"] = datetime.now(timezone.utc).isoformat(timespec="seconds")
                f.attrs["shards"] = folder.name
                f.attrs["n_shards"] = plan.n_shards
                f.attrs["shard_rows"] = plan.shard_rows
                _mirror(src0, f, plan, rel)
                g = f.create_group("chunks")
                g.attrs["rows"] = plan.shard_rows
                g.attrs["description"] = (f"shard i holds variants [i*rows, min((i+1)*rows, N)) in "
                                          f"{folder.name}/shard-<i:05d>.h5; all done")
                g.attrs["chunk_rows"] = plan.chunk_rows
                g.create_dataset("done", data=np.ones(plan.n_shards, dtype=bool))
                if has_integrity(src0):  # the digest of each shard's per-variant rows, read from the shard
                    digest = create_dataset(f, "chunks/digest", {"chunks": plan.n_shards})
                    for i, n in enumerate(names):
                        with (h5py.File(folder / n, "r", rdcc_nbytes=READ_CACHE_BYTES) if i else _borrowed(src0)) as src:
                            digest[i] = _shard_digest(src, folder / n, plan, i)
                    stamp(f)
            _fsync(tmp)
            os.replace(tmp, out)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise


def _shard_digest(src: h5py.File, path: Path, plan: ShardPlan, i: int) -> np.ndarray:
    """The study file's digest of shard ``i`` (its per-variant rows [a, b) whole), computed in the same
    pass over the rows (read in blocks: memory flat in the shard size) as the shard's own per-chunk
    digests, which must match what the worker stored: a shard damaged since it was written is refused
    here, not baked into the study file's checksums."""
    a, b = plan.range(i)
    rows = plan.chunk_rows
    done = np.asarray(src["chunks/done"][...], dtype=bool)
    stored = src[DIGEST][...]
    first, last = a // rows, -(-b // rows)
    if not done[first:last].all():
        raise RuntimeError(f"{path}: shard {i} has chunks not committed")
    chunks = [(c * rows, min((c + 1) * rows, plan.n_variants)) for c in range(first, last)]
    own, whole = digests_many(per_variant(src, plan.n_variants), [chunks, [(a, b)]])
    for c, got in zip(range(first, last), own):
        if got != stored[c].tobytes():
            raise UserError(f"{path}: damaged shard file: the data of variants {c * rows}..{min((c + 1) * rows, b) - 1} "
                            f"do not match their checksum; delete it and run the study again with --resume")
    return np.frombuffer(whole[0], dtype=np.uint8)


@contextlib.contextmanager
def _borrowed(f):
    yield f  # an open file, used in a with block without being closed by it


def _mirror(src: h5py.Group, dst: h5py.Group, plan: ShardPlan, rel: list[str]) -> None:
    """Recreate ``src``'s tree in ``dst`` in its own order (creation order where ``src`` tracks it):
    groups with their attributes, every (N, ...) dataset as a virtual dataset over the shards, any
    other dataset (``/theta``) copied; ``/chunks`` is left out (the caller writes the shard table)."""
    N = plan.n_variants
    for name in src.keys():
        obj = src[name]
        if src.name == "/" and name == "chunks":
            continue
        if isinstance(obj, h5py.Group):
            order = bool(obj.id.get_create_plist().get_link_creation_order())
            g = dst.create_group(name, track_order=order or None)
            for k, v in obj.attrs.items():
                g.attrs[k] = v
            _mirror(obj, g, plan, rel)
        elif isinstance(obj, h5py.Dataset) and obj.ndim >= 1 and obj.shape[0] == N and not obj.is_virtual:
            v = _virtual_dataset(dst, name, obj, plan, rel)
            for k, val in obj.attrs.items():
                v.attrs[k] = val
        else:
            src.copy(obj, dst, name=name)


def _virtual_dataset(dst: h5py.Group, name: str, obj: h5py.Dataset, plan: ShardPlan, rel: list[str]) -> h5py.Dataset:
    """A virtual dataset shaped like ``obj`` whose rows [a, b) are rows [a, b) of ``obj``'s name in
    shard file ``rel[i]``. What ``h5py.VirtualLayout`` does, with the low-level calls: its
    ``VirtualSource[a:b]`` deep-copies the source per mapping (~5 ms per shard for ~20 datasets)."""
    shape = obj.shape
    dcpl = h5py.h5p.create(h5py.h5p.DATASET_CREATE)
    dcpl.set_layout(h5py.h5d.VIRTUAL)
    dcpl.set_fill_value(np.array([obj.fillvalue], dtype=obj.dtype))
    dset = obj.name.encode()
    for i in range(plan.n_shards):
        a, b = plan.range(i)
        start, count = (a,) + (0,) * (len(shape) - 1), (b - a,) + tuple(shape[1:])
        vspace = h5py.h5s.create_simple(shape)
        vspace.select_hyperslab(start, count)
        sspace = h5py.h5s.create_simple(shape)
        sspace.select_hyperslab(start, count)
        dcpl.set_virtual(vspace, rel[i].encode(), dset, sspace)
    dsid = h5py.h5d.create(dst.id, name.encode(), obj.id.get_type(), h5py.h5s.create_simple(shape), dcpl=dcpl)
    return h5py.Dataset(dsid)


def check_sources(f: h5py.File, path) -> None:
    """Raise a UserError if a stitched study file ``f`` (at ``path``) cannot reach one of its shards.

    HDF5 reads a missing virtual-dataset source as fill values (NaN, "not-run") without a word;
    this names the first missing shard instead. Each shard of a file with checksums is verified too:
    its own metadata checksum and its series' chunk index; its rows are not hashed again here (that
    would read every row twice): the study file's digest of each shard, checked next by
    :func:`~explorer.store._integrity.verify` through the virtual datasets, covers the bytes a reader
    gets. Called by :func:`~explorer.store.open_results`.
    """
    folder = f.attrs.get("shards")
    if folder is None:
        return
    folder = folder.decode() if isinstance(folder, bytes) else str(folder)
    base = Path(path).resolve().parent
    prefix = os.environ.get("HDF5_VDS_PREFIX")
    roots = [Path(prefix)] if prefix else []
    roots.append(base)
    n = int(f.attrs.get("n_shards", 0))
    for i in range(n):
        rel = f"{folder}/{shard_name(i)}"
        found = [r / rel for r in roots if (r / rel).is_file()]
        if not found:
            raise UserError(f"{path}: shard file {base / rel} is missing; a sharded results file needs its "
                            f"{folder}/ folder beside it (move or copy the two together)")
        if has_integrity(f):  # the shard's own metadata checksum, and its series' chunk index (read only
            _verify_shard(found[0], path)  # through it); its rows: the study file's digests, read through it


def _verify_shard(shard: Path, path) -> None:
    from ._integrity import Damaged, check
    try:
        with h5py.File(shard, "r", rdcc_nbytes=READ_CACHE_BYTES) as s:
            check(s, digest_rows=False)
    except Damaged as exc:
        raise UserError(f"{path}: damaged shard file {shard}: {exc}; run the study again or restore the "
                        f"file from a copy") from None
    except Exception as exc:  # noqa: BLE001 - whatever the damaged bytes made h5py raise
        what = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise UserError(f"{path}: damaged shard file {shard}: cannot verify it ({what})") from None
