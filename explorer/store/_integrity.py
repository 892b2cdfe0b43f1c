"""Integrity of results files: what is verified before any number is read.

HDF5's Fletcher-32 covers the bytes of each compressed chunk only. A results file written by this
version also carries, and :func:`verify` checks before a verb reads anything:

* the root attribute ``integrity`` = ``"sha256-v1 <hex>"``: SHA-256 over the file's metadata, walked
  in name order: every group and dataset by path, every attribute (its HDF5 type, dataspace and
  value) of the root, of every group and of every dataset, every dataset's HDF5 type, dataspace,
  layout, filter pipeline and fill value, the mapping of every virtual dataset (a stitched Dask
  file), and the values of every contiguous dataset (``/theta``, ``/chunks/done``,
  ``/chunks/digest``). Not covered: the scratch group ``/metrics_partial`` that ``explorer metrics``
  leaves behind when it is killed (never read) and the chunked data (below).
* ``/chunks/digest`` (n_chunks, 32) uint8: for each committed chunk i, SHA-256 over its rows
  [i·rows, min((i+1)·rows, N)) of every per-variant dataset that is not a series (``/variants/*``,
  ``/status``, ``/fail_*``, ``/iterations``, ``/metrics/*``), read back from the file after the
  rows were flushed. A damaged chunk-index key (which makes HDF5 read the fill value, NaN, for a
  chunk it can no longer find), a skipped filter or a changed value all change it. Computed and
  verified in one streaming pass (:func:`digests`): each dataset read in blocks of about
  :data:`READ_ROWS` rows on its HDF5 chunk boundaries, every chunk's hash fed with ``update`` (the same
  bytes in the same order as hashing the rows whole, so the digests are those of files written before),
  so memory does not grow with N nor with the chunk (a stitched file's chunk is a whole shard).
  A stitched file's shards are checked at open for their own metadata checksum and series chunk index;
  their rows are verified once, through the study file's digests (one pass, not two), and the stitch
  checks each shard's own chunk digests in the pass that computes the study file's.
* the series (``/paths``, ``/velocities``, ``/accelerations``, ``/torque``, ``/forces``): every
  HDF5 chunk of a committed row that was run (status not -1) is in the chunk index, at an aligned
  offset, with no filter skipped (Fletcher-32 then checks its bytes when it is read).

The writer (:class:`~explorer.store.ResultsWriter`, the Dask stitch, ``explorer metrics``) updates
both in the same flush as the data they cover: the digest and the ``integrity`` attribute at each
commit with ``/chunks/done[i]``, the attribute alone whenever it adds a dataset or an attribute. A
process killed between flushes therefore leaves a file that verifies. Rows of chunks not yet
committed (an interrupted run) are not covered: they read as whatever the interrupted commit left,
and a resume rewrites them.

Files written before these checks existed (no ``integrity`` attribute) are read as before, with a
one-line warning on stderr (once per file and process).
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

import h5py
import numpy as np

from ..errors import UserError
from ._datasets import SERIES as _SERIES
from ._guard import PROGRESS

#: Root attribute holding the metadata checksum.
ATTR = "integrity"
#: Prefix of its value (the scheme; a later scheme gets a new prefix).
SCHEME = b"sha256-v1 "
#: Per-chunk digests of the per-variant data.
DIGEST = "chunks/digest"
#: Groups never read by a verb, left out of the checksum (``explorer metrics``' scratch group).
SCRATCH = frozenset({"metrics_partial"})
#: Groups and datasets whose (N, S, ...) datasets are "series": checked through their chunk index (read
#: from :data:`explorer.store._datasets.SERIES` at each check, so a series added there is checked too).
def series_groups() -> tuple[str, ...]:
    return tuple(spec.group for spec in _SERIES)


SERIES = series_groups()  # as at import (the checks below call series_groups())

#: What a damaged file's message advises.
RESTORE = "run the study again or restore the file from a copy"

_warned: set = set()

#: Progress callback of a verification run in a guarded child process (:data:`explorer.store._guard.PROGRESS`,
#: which the child sets): called after every object, attribute, block of rows and chunk-index entry, so that
#: a child making no progress (HDF5 looping on damaged bytes) is told from one that is slow.


def _tick() -> None:
    cb = PROGRESS[0]
    if cb is not None:
        cb()


class Damaged(Exception):
    """What is damaged, in words (turned into a UserError naming the file by :func:`verify`)."""


# -- the metadata checksum ----------------------------------------------------------------------------------
def _value(v) -> bytes:
    if isinstance(v, str):
        return b"s" + v.encode("utf-8", "surrogatepass")
    if isinstance(v, bytes):
        return b"b" + v
    a = np.asarray(v)
    if a.dtype.kind == "O":
        return b"o" + repr(a.shape).encode() + b"\0".join(_value(x) for x in a.ravel())
    return a.dtype.str.encode() + repr(a.shape).encode() + np.ascontiguousarray(a).tobytes()


def _attrs(obj, h, skip=()) -> None:
    a = obj.attrs
    for k in sorted(a.keys()):
        if k in skip:
            continue
        _tick()
        aid = a.get_id(k)
        h.update(b"\0A" + k.encode("utf-8", "surrogatepass") + b"\0")
        h.update(aid.get_type().encode())
        h.update(aid.get_space().encode())
        h.update(_value(a[k]))


def _dataset(d: h5py.Dataset, h) -> None:
    h.update(d.id.get_type().encode())
    h.update(d.id.get_space().encode())
    dcpl = d.id.get_create_plist()
    layout = dcpl.get_layout()
    h.update(f"layout {layout} chunks {d.chunks}".encode())
    for i in range(dcpl.get_nfilters()):
        h.update(repr(dcpl.get_filter(i)).encode())
    if dcpl.fill_value_defined() != h5py.h5d.FILL_VALUE_UNDEFINED and d.dtype.kind != "O":
        fill = np.zeros((1,), dtype=d.dtype)
        dcpl.get_fill_value(fill)
        h.update(b"fill" + fill.tobytes())
    if layout == h5py.h5d.VIRTUAL:
        for vs in d.virtual_sources():
            h.update(repr((vs.vspace.get_select_bounds(), vs.file_name, vs.dset_name,
                           vs.src_space.get_select_bounds())).encode())
    elif layout in (h5py.h5d.CONTIGUOUS, h5py.h5d.COMPACT):
        h.update(b"data" + np.ascontiguousarray(d[()]).tobytes())
    _attrs(d, h)


def _group(g: h5py.Group, h) -> None:
    _attrs(g, h, skip=(ATTR,) if g.name == "/" else ())
    for name in sorted(g.keys()):
        if g.name == "/" and name in SCRATCH:
            continue
        _tick()
        link = g.get(name, getlink=True)
        if not isinstance(link, h5py.HardLink):
            h.update(f"\0L{name}={link!r}".encode())
            continue
        obj = g[name]
        if isinstance(obj, h5py.Group):
            h.update(b"\0G" + name.encode("utf-8", "surrogatepass"))
            _group(obj, h)
            h.update(b"\0g")
        else:
            h.update(b"\0D" + name.encode("utf-8", "surrogatepass"))
            _dataset(obj, h)


def metadata_checksum(f: h5py.File) -> bytes:
    """The value of the ``integrity`` attribute for ``f`` as it is now (see the module docstring)."""
    h = hashlib.sha256()
    _group(f["/"], h)
    return SCHEME + h.hexdigest().encode()


def stamp(f: h5py.File) -> None:
    """Set ``integrity`` to the checksum of ``f``'s metadata now (in place: same size every time). The
    caller flushes, in the same flush as the change it covers."""
    value = np.bytes_(metadata_checksum(f))
    if ATTR in f.attrs and f.attrs.get_id(ATTR).dtype == value.dtype:
        f.attrs.modify(ATTR, value)
    else:
        f.attrs[ATTR] = value


def has_integrity(f: h5py.File) -> bool:
    return ATTR in f.attrs


# -- the per-chunk digests ----------------------------------------------------------------------------------
def _is_series(path: str) -> bool:
    return path.split("/")[0] in series_groups()


def per_variant(f: h5py.File, n: int) -> list[tuple[str, h5py.Dataset]]:
    """The per-variant datasets the chunk digests cover: every dataset of shape (N, ...) that is not a
    series, by path, sorted (``/chunks`` and the scratch group left out)."""
    out = []

    def visit(name, obj):
        _tick()
        top = name.split("/")[0]
        if (isinstance(obj, h5py.Dataset) and top not in SCRATCH and top != "chunks" and not _is_series(name)
                and obj.ndim >= 1 and obj.shape[0] == n):
            out.append((name, obj))

    f.visititems(visit)
    return sorted(out)


#: Rows of one dataset read at a time by the digests (rounded to whole HDF5 chunks of the dataset): the
#: memory of a verification or a stitch is this many rows of the widest per-variant dataset (~4 MB for
#: ``/variants/lengths`` of 8 links), whatever N or the chunk size...
READ_ROWS = 1 << 16
#: ... and at most about this many bytes (whole HDF5 chunks, at least one): the lengths of a 9,999-link
#: mechanism are 80 kB a row, 5 GB for READ_ROWS rows.
READ_BYTES = 8 << 20


def _step(d: h5py.Dataset, block: int) -> int:
    """Rows per read of ``d``: ``block`` rows, fewer if they would pass :data:`READ_BYTES`, rounded down
    to whole HDF5 chunks (at least one chunk). The digests do not depend on it."""
    row = max(1, int(np.prod(d.shape[1:], dtype=np.int64)) * d.dtype.itemsize) if d.dtype.kind != "O" else 64
    block = max(1, min(int(block), READ_BYTES // row))
    c = d.chunks[0] if d.chunks else 0
    return max(c, block // c * c) if c else max(1, block)


#: Chunk cache per dataset for a file opened to be verified or stitched (``h5py.File(..., rdcc_nbytes=)``):
#: the digests read each HDF5 chunk once, whole, and hold every per-variant dataset open, so HDF5 2.0's
#: default, 8 MiB per open dataset, kept ~250 MB resident for the ~30 datasets of a lean file.
READ_CACHE_BYTES = 1 << 20


def _bytes(values: np.ndarray):
    v = np.ascontiguousarray(values)
    return v.tobytes() if v.dtype.kind == "O" else v.reshape(-1).view(np.uint8)  # no copy


def digests(datasets, ranges, block: int | None = None) -> list[bytes]:
    """SHA-256 of rows [a, b) of ``datasets`` (from :func:`per_variant`), as stored, for each (a, b) of
    ``ranges`` (sorted, not overlapping): the digests :func:`chunk_digest` gives one by one, computed in
    one pass that reads each dataset in blocks of about ``block`` rows (default :data:`READ_ROWS`) on its
    HDF5 chunk boundaries and feeds every range's hash (``hashlib``'s ``update`` over the same bytes in
    the same order: the name of each dataset, then its rows; files written before the streaming verify).
    Memory: one block of one dataset, whatever N and the range sizes."""
    return digests_many(datasets, [ranges], block)[0]


def digests_many(datasets, lists, block: int | None = None) -> list[list[bytes]]:
    """:func:`digests` of several lists of ranges (each sorted, not overlapping; one list may overlap
    another: a shard's chunks and the shard whole) in one pass over the rows: each block read feeds
    every list's hashes."""
    block = int(block or READ_ROWS)
    lists = [[(int(a), int(b)) for a, b in rs] for rs in lists]
    hs = [[hashlib.sha256() for _ in rs] for rs in lists]
    spans: list[list[int]] = []  # the union of every range, merged: what is read
    for a, b in sorted(r for rs in lists for r in rs):
        if spans and a <= spans[-1][1]:
            spans[-1][1] = max(spans[-1][1], b)
        elif b > a:
            spans.append([a, b])
    for name, d in datasets:
        head = b"\0" + name.encode("utf-8", "surrogatepass") + b"\0"
        for h in (h for row in hs for h in row):
            h.update(head)
        step = _step(d, block)
        ptr = [0] * len(lists)
        for lo, hi in spans:
            p = lo
            while p < hi:
                q = min(hi, (p // step + 1) * step)  # to the next HDF5 chunk boundary of ``step`` rows
                values = d[p:q]
                _tick()
                for m, rs in enumerate(lists):
                    k = ptr[m]
                    while k < len(rs) and rs[k][0] < q:
                        a, b = rs[k]
                        if min(b, q) > max(a, p):
                            hs[m][k].update(_bytes(values[max(a, p) - p:min(b, q) - p]))
                        if b > q:
                            break
                        k += 1
                    ptr[m] = k
                p = q
    return [[h.digest() for h in row] for row in hs]


def chunk_digest(datasets, a: int, b: int) -> np.ndarray:
    """SHA-256 (32 uint8) of rows [a, b) of ``datasets`` (from :func:`per_variant`), as stored: for each
    dataset in order, its name between NUL bytes, then the bytes of its rows (read in blocks:
    :func:`digests`)."""
    return np.frombuffer(digests(datasets, [(a, b)])[0], dtype=np.uint8)


def _done_ranges(done: np.ndarray, rows: int, n: int) -> tuple[np.ndarray, list[tuple[int, int]]]:
    idx = np.flatnonzero(done)
    return idx, [(int(i) * rows, min((int(i) + 1) * rows, n)) for i in idx]


def write_digests(f: h5py.File, chunks=None) -> None:
    """Recompute ``/chunks/digest`` of the committed chunks (all, or those in ``chunks``), reading the
    rows back from ``f`` (``explorer metrics``' swap and the Dask stitch; the writer does one chunk per
    commit)."""
    n = int(f.attrs["n_variants"])
    rows = int(f["chunks"].attrs["rows"])
    done = np.asarray(f["chunks/done"][...], dtype=bool)
    if chunks is not None:
        keep = np.zeros_like(done)
        keep[list(chunks)] = True
        done &= keep
    idx, ranges = _done_ranges(done, rows, n)
    if len(idx):
        table = np.array(f[DIGEST][...], dtype=np.uint8)
        for i, got in zip(idx, digests(per_variant(f, n), ranges)):
            table[i] = np.frombuffer(got, dtype=np.uint8)
        f[DIGEST][...] = table


def _status(f: h5py.File, n: int) -> np.ndarray:
    d = f["status"]
    out = np.empty(n, dtype=np.int8)
    step = _step(d, 1 << 20)
    for a in range(0, n, step):
        out[a:a + step] = d[a:min(a + step, n)]
        _tick()
    return out


# -- verification -------------------------------------------------------------------------------------------
def _check_series(f: h5py.File, n: int, rows: int, done: np.ndarray, status: np.ndarray) -> None:
    ran = status != -1
    for top in series_groups():
        if top not in f:
            continue
        obj = f[top]
        items = [(top, obj)] if isinstance(obj, h5py.Dataset) else [(f"{top}/{k}", obj[k]) for k in obj]
        for name, d in items:
            if not isinstance(d, h5py.Dataset) or d.is_virtual or d.chunks is None or d.shape[:1] != (n,):
                continue
            h = d.chunks[0]
            found = {}

            def seen(info, found=found):
                found[info.chunk_offset] = info.filter_mask
                if len(found) % 256 == 0:
                    _tick()

            d.id.chunk_iter(seen)
            zeros = (0,) * (d.ndim - 1)
            for off, mask in found.items():
                if off[0] % h or off[0] >= n or tuple(off[1:]) != zeros:
                    raise Damaged(f"/{name}: its chunk index names a chunk at {off} that cannot exist")
                if mask:
                    raise Damaged(f"/{name}: its chunk index skips a filter of the chunk at row {off[0]}")
            for start in range(0, n, h):
                stop = min(start + h, n)
                committed = done[np.arange(start, stop) // rows]
                if (committed & ran[start:stop]).any() and (start,) + zeros not in found:
                    raise Damaged(f"/{name}: the chunk of rows {start}..{stop - 1} is missing from its chunk index")


def check(f: h5py.File, digest_rows: bool = True) -> None:
    """Raise :class:`Damaged` if ``f`` (which has an ``integrity`` attribute) does not verify: the
    metadata checksum, the chunk table, the digest of every committed chunk's per-variant rows (read
    in blocks: memory flat in N) and the series' chunk index. ``digest_rows=False`` leaves out the
    rows' digests: only for a shard of a stitched file, whose rows the study file's own digests cover
    when they are read through it (:func:`~explorer.store._shards.check_sources`)."""
    stored = f.attrs[ATTR]
    stored = stored if isinstance(stored, bytes) else str(stored).encode()
    if not stored.startswith(SCHEME):
        raise Damaged("its integrity attribute is not one this version knows")
    if metadata_checksum(f) != stored:
        raise Damaged("its metadata or attributes do not match their checksum")
    n = int(f.attrs["n_variants"])
    rows = int(f["chunks"].attrs["rows"])
    done = np.asarray(f["chunks/done"][...], dtype=bool)
    digest = f[DIGEST][...]
    if rows < 1 or len(done) != -(-n // rows) or digest.shape != (len(done), 32):
        raise Damaged("its chunk table does not fit its number of variants")
    ds = per_variant(f, n)
    if "status" not in dict(ds):
        raise Damaged("it has no /status of one entry per variant")
    idx, ranges = _done_ranges(done, rows, n) if digest_rows else (np.zeros(0, dtype=np.intp), [])
    for i, got in zip(idx, digests(ds, ranges)):  # streamed: memory flat in N and in the chunk size
        if got != digest[i].tobytes():
            raise Damaged(f"the data of variants {i * rows}..{min((i + 1) * rows, n) - 1} "
                          f"do not match their checksum")
    if any(top in f for top in series_groups()):
        _check_series(f, n, rows, done, _status(f, n))


def salvage(f: h5py.File) -> bool:
    """An interrupted file whose last commit was cut by a kill (kill -9 during HDF5's flush, which is not
    atomic, can leave a chunk marked done before its digest or the metadata checksum reached the disk):
    every chunk marked done whose rows do not match their digest is marked not done again (a resume
    solves it again), the checksum is restamped, and the file must then verify whole. Only for a file
    that is not complete, opened for writing; True if it now verifies, False otherwise (left for the
    caller to refuse)."""
    try:
        if bool(f.attrs.get("complete", False)) or ATTR not in f.attrs:
            return False
        n = int(f.attrs["n_variants"])
        rows = int(f["chunks"].attrs["rows"])
        done = np.asarray(f["chunks/done"][...], dtype=bool)
        digest = f[DIGEST][...]
        if rows < 1 or len(done) != -(-n // rows) or digest.shape != (len(done), 32):
            return False
        idx, ranges = _done_ranges(done, rows, n)
        for i, got in zip(idx, digests(per_variant(f, n), ranges)):
            if got != digest[i].tobytes():
                done[i] = False
        f["chunks/done"][...] = done
        stamp(f)
        f.flush()
        check(f)
        return True
    except (Damaged, KeyError, ValueError, TypeError, OSError):
        return False


def is_legacy(f: h5py.File) -> bool:
    """True for a file written before checksums existed: neither the ``integrity`` attribute nor
    ``/chunks/digest`` (one damaged byte can remove one of the two, never both: such a file is damaged)."""
    return ATTR not in f.attrs and not ("chunks" in f and "digest" in f["chunks"])


def warn_legacy(path) -> None:
    """The one-line warning for a file without checksums (once per file and process)."""
    key = str(Path(path).resolve())
    if key not in _warned:
        _warned.add(key)
        print(f"explorer: warning: {path}: written by an earlier version, without checksums: its numbers "
              f"cannot be verified (run the study again to get a verified file)", file=sys.stderr)


def verify(f: h5py.File, path, warn: bool = True) -> bool:
    """Verify the open results file ``f`` (at ``path``) before anything is read from it: a one-line
    :class:`~explorer.errors.UserError` naming the file and what is damaged when it does not verify.
    A file written by an earlier version (:func:`is_legacy`) is read as it is, with a one-line warning
    on stderr (with ``warn``; once per file and process). True if the file was verified."""
    if is_legacy(f):
        if warn:
            warn_legacy(path)
        return False
    try:
        if ATTR not in f.attrs:
            raise Damaged("its integrity attribute is missing")
        check(f)
    except Damaged as exc:
        raise UserError(f"{path}: not a readable explorer results file (damaged: {exc}); {RESTORE}") from None
    except Exception as exc:  # noqa: BLE001 - whatever the damaged bytes made h5py or numpy raise
        what = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise UserError(f"{path}: not a readable explorer results file (damaged: cannot verify it: {what}); "
                        f"{RESTORE}") from None
    return True


def seal(path) -> None:
    """Recompute the checksums of the results file at ``path`` after it was changed on purpose with
    plain h5py (a dataset added, an attribute edited): the digest of every committed chunk, then the
    metadata checksum. Only for deliberate edits: sealing a damaged file makes its damage read as
    data. A file written by an earlier version gets checksums from now on."""
    from ._guard import call
    call(_seal, Path(path))  # in a child process: bytes that make HDF5 loop cannot hang the caller


def _seal(path: Path) -> None:
    from ._datasets import create_dataset
    with h5py.File(path, "r+") as f:
        if DIGEST not in f:
            create_dataset(f, DIGEST, {"chunks": f["chunks/done"].shape[0]})
        write_digests(f)
        stamp(f)
