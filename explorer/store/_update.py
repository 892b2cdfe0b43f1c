"""Adding metric values to a complete results file, written through a renamed copy.

``update_metrics(path, rows, values, attrs)`` sets ``/metrics/<name>[rows]`` for a few rows (a
verb that checks a shortlist: ``explorer physics``) and leaves every other value as it was. The file
is never written in place:

1. the original is checked first (it must be a complete explorer results file that verifies:
   :func:`~explorer.store._integrity.verify`), and the disk must have room for a copy of it (else one
   line saying how much is needed, and the file as it was);
2. it is copied to a hidden temporary file beside it (``.NAME.PID.update``), the copy is changed (new
   metric datasets created NaN-filled from their row of the dataset table, the rows written, the
   attributes set), its chunk digests recomputed and its metadata checksum stamped, then flushed,
   closed and synced;
3. the copy is renamed over the original (one atomic step).

A failure or a kill at any point before the rename leaves the original untouched (at most the
temporary file, which the next update removes); after it, the new file verifies. Signals are held
over the rename. The caller holds the results path's :class:`~explorer.store.OutputLock` so that two
updates do not race (the later rename would drop the earlier's values).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import h5py
import numpy as np

from ..errors import UserError, signals_held
from ._datasets import now
from ._integrity import has_integrity, stamp, verify, write_digests
from ._write import FORMAT, create_metric, metrics_group, write_error_reason

#: Room kept free on the disk beyond the copy itself (HDF5 metadata of new datasets, the file system's own).
SPARE_BYTES = 4 << 20


def _tmp(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.update")


def _stale(path: Path) -> None:
    """Remove temporary copies an update killed before its rename left beside ``path`` (those of dead pids)."""
    for p in path.parent.glob(f".{path.name}.*.update"):
        try:
            pid = int(p.name[len(path.name) + 2:-len(".update")])
            os.kill(pid, 0)
        except ProcessLookupError:
            p.unlink(missing_ok=True)
        except (ValueError, PermissionError, OSError):
            continue


def check_updatable(path) -> Path:
    """``path`` as a Path if it is a complete explorer results file that verifies and can be replaced
    (its folder writable); UserError otherwise."""
    p = Path(os.fspath(path))
    if not p.is_file():
        raise UserError(f"{p}: no such results file")
    try:
        with h5py.File(p, "r") as f:
            if f.attrs.get("format") != FORMAT:
                raise UserError(f"{p}: not an explorer results file (no format = {FORMAT!r} attribute)")
            if not bool(f.attrs.get("complete", False)):
                raise UserError(f"{p}: incomplete results file (an interrupted run); finish it first with "
                                f"`explorer run STUDY -o {p} --resume`")
            verify(f, p)
    except OSError as exc:
        raise UserError(f"{p}: cannot read the results file: {write_error_reason(exc)}") from None
    if not os.access(p.parent if str(p.parent) else Path("."), os.W_OK):
        raise UserError(f"{p}: cannot update it: its folder is not writable (permission denied)")
    return p


def update_metrics(path, rows, values: dict, attrs: dict | None = None, clear=()) -> Path:
    """Write ``values`` {metric: (k,) floats} at the variants ``rows`` (k,) into ``/metrics/<metric>``
    of the complete results file ``path``, through a renamed copy (see the module docstring).

    attrs : {metric: {attribute: value}} set on those datasets (a dict value is stored as JSON).
    clear : metrics whose stored values are dropped first (every row NaN again, then ``values``).
    A metric not stored yet is created NaN-filled (the rows not given stay NaN). Returns the path.
    UserError (one line, the file as it was) for a file that is missing, foreign, incomplete or damaged,
    a full disk or any failed write."""
    import json

    p = check_updatable(path)
    rows = np.asarray(rows, dtype=np.int64).reshape(-1)
    order = np.argsort(rows, kind="stable")
    rows = rows[order]
    if len(np.unique(rows)) != len(rows):
        raise ValueError("update_metrics: each row at most once")
    _stale(p)
    size = p.stat().st_size
    free = shutil.disk_usage(p.parent if str(p.parent) else Path(".")).free
    if free < size + SPARE_BYTES:
        from .._files import format_size
        raise UserError(f"{p}: cannot update it: writing through a copy needs {format_size(size + SPARE_BYTES)} "
                        f"free on its disk, {format_size(free)} is; free some space and run again (the file is "
                        f"as it was)")
    tmp = _tmp(p)
    try:
        shutil.copyfile(p, tmp)
        shutil.copymode(p, tmp)
        with h5py.File(tmp, "r+") as f:
            N = int(f.attrs["n_variants"])
            if len(rows) and (rows[0] < 0 or rows[-1] >= N):
                raise ValueError(f"update_metrics: rows outside 0 … {N - 1}")
            g = f["metrics"] if "metrics" in f else metrics_group(f, band=None)
            band = float(g.attrs["band"]) if "band" in g.attrs else float("nan")
            chunk = int(f["chunks"].attrs["rows"]) if "chunks" in f and "rows" in f["chunks"].attrs else min(N, 1024)
            stamp_time = now()
            for name in clear:
                if name in g:
                    del g[name]
            for name, vals in values.items():
                vals = np.asarray(vals, dtype=np.float64).reshape(-1)[order]
                if vals.shape != rows.shape:
                    raise ValueError(f"update_metrics: {name}: {vals.shape[0]} values for {rows.shape[0]} rows")
                d = g[name] if name in g else create_metric(g, name, N, max(1, min(chunk, N)), band, stamp_time)
                if len(rows):
                    d[rows] = vals
                d.attrs["computed"] = stamp_time
                for k, v in ((attrs or {}).get(name) or {}).items():
                    d.attrs[k] = json.dumps(v) if isinstance(v, (dict, list)) else v
            f.flush()
            if has_integrity(f):  # a new dataset enters every chunk's digest: all are recomputed
                write_digests(f)
                stamp(f)
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        with signals_held():
            os.replace(tmp, p)
        try:  # the rename itself reaches the disk
            dfd = os.open(p.parent if str(p.parent) else ".", os.O_RDONLY)
            try:
                os.fsync(dfd)
            finally:
                os.close(dfd)
        except OSError:
            pass
    except OSError as exc:
        raise UserError(f"{p}: cannot update it: {write_error_reason(exc)} (the file is as it was)") from None
    finally:
        if tmp.exists():
            tmp.unlink(missing_ok=True)
    return p
