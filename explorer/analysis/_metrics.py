"""Recomputing the gait metrics of an existing results file (another band, more metrics) without re-solving.

``recompute_metrics(path, band=0.02)`` reads the stored foot path (and velocities; where they are not
stored, it solves them again from each variant's stored design) chunk by chunk,
runs :func:`explorer.gait.compute_metrics` on each chunk and writes ``/metrics/<name>``. Memory is
one chunk of foot paths whatever N is.

Crash safety. ``explorer metrics`` writes like every other writer: the file is verified first (in a
child process, :func:`explorer.store.inspect`: a damaged file or a damaged shard of a Dask-stitched
file is refused before anything is computed or written), the space the update needs (the file's size
plus the new metric datasets) is reserved beside it, the file is copied there (a hidden
``.NAME.<pid>.partial``), the new metrics are written into the copy (a hidden group ``/metrics_partial``
swapped in for ``/metrics`` once complete, with the chunk digests and the metadata checksum that cover
it), and the copy is synced and renamed over the original only when all of that succeeded. A full
disk (no room for the copy, or a write that fails), an error or a kill at any point leave the original
exactly as it was (at most the hidden copy, removed by the next run), and the message says so. The
output lock (:class:`explorer.store.OutputLock`) keeps a run or another ``explorer metrics`` from
writing the file meanwhile. Paths, velocities and every other dataset are copied, never changed.

Band bookkeeping. Every metric dataset carries its ``band`` attribute and ``/metrics`` carries the
band of the whole set (:attr:`explorer.store.Results.band`). Recomputing only some metrics with a
new band also recomputes the stored stance-based metrics that were computed with another band, so
one file never mixes bands.
"""

from __future__ import annotations

import errno
import json
import os
import sys
import time
from pathlib import Path

import h5py
import numpy as np

from ..errors import UserError
from ..store import (STATUS_NOT_RUN, Exclusive, OutputLock, Unreadable, copy_for_update, create_metric, guarded, hdf5_rows, inspect,
                     lean_file, metrics_group, open_h5, replace_with, write_error_reason)
from ..store import now as timestamp
from ..study import resolve_series
from ..store._integrity import has_integrity, stamp, write_digests

#: Name of the group the new metrics are written to before they replace ``/metrics``.
PARTIAL = "metrics_partial"


def _text(s) -> str:
    return s.decode() if isinstance(s, bytes) else str(s)


def _parse_names(names):
    """None (the stored metrics, or all if none), "all" / True (every metric), or a list of names."""
    if names is None or names is True:
        return names
    if isinstance(names, str):
        if names.strip().lower() == "all":
            return True
        names = [n.strip() for n in names.split(",") if n.strip()]
    try:
        names = [str(n) for n in names]
    except TypeError:
        raise UserError(f"metrics: expected metric names or 'all', got {names!r}") from None
    if not names:
        raise UserError("metrics: name at least one metric (or 'all')")
    return names


def _study_band(f: h5py.File) -> float:
    import json
    from ..gait import DEFAULT_BAND
    try:
        return float(json.loads(f.attrs["study_resolved"])["scene"]["band"])
    except (KeyError, TypeError, ValueError):
        return DEFAULT_BAND


def recompute_metrics(path, band: float | None = None, names=None, progress: bool = False) -> dict:
    """Recompute the gait metrics of a complete results file from its stored foot path, no re-solving.

    path : the results file (``explorer run`` output); it must be complete and not open for writing.
    band : stance band in [0, 1]; None keeps the file's band (:attr:`Results.band`: the last
        recomputation's, else the study's ``[scene] band``).
    names : the metrics to compute: None = the ones stored (every metric if none is), "all"/True =
        every metric (min_transmission_angle only for a mechanism with a crank-driven four-bar loop),
        or a list / comma-separated string of names. Metrics stored but not named are kept as they
        are, except stance-based ones stored with a different band, which are recomputed too.
    progress : a tqdm bar on stderr when it is a terminal.

    Returns a dict: ``path``, ``band``, ``metrics`` (names recomputed, as asked), ``also`` (stance
    metrics recomputed to keep one band), ``kept`` (stored metrics left as they were),
    ``n_variants``, ``ok`` (variants with status ok), ``wall_s``.

    Foot velocities that the file does not store (an optimisation's results, a study run with
    ``[scene] velocities = false``) are solved again from each ok variant's stored design, chunk by
    chunk, with the study's steps, tolerance and method (``resolved``: how many variants; else 0). A
    lean file (``[scene] store = "metrics"``) stores no series: every variant is solved again, a chunk
    at a time, exactly as the run solved it (``lean`` True, ``resolved`` N).

    Raises UserError for a missing, foreign, incomplete or busy file, an unknown metric, a bad band,
    or a file that lacks the foot path the metrics need (named in the message).
    """
    from ..gait import check_band

    t0 = time.perf_counter()
    p = Path(os.fspath(path))
    names = _parse_names(names)
    if band is not None:
        try:
            band = check_band(band)
        except UserError as exc:
            raise UserError(f"--{exc}") from None
    if not p.is_file():
        raise UserError(f"{p}: no such results file")
    lock = OutputLock(p)
    try:
        lock.acquire()  # no run, no other `explorer metrics` writes it meanwhile
    except UserError as exc:
        raise UserError(str(exc).split("; wait")[0] + "; wait for it to finish") from None
    try:
        inspect(p)  # verified in a child process (shards too) before anything is read or written
        with Exclusive(p):  # and no reader has it open (nor opens it) until the update is renamed over it
            return _recompute(p, band, names, progress, t0)
    finally:
        lock.release()


def _recompute(p: Path, band, names, progress: bool, t0: float) -> dict:
    """:func:`recompute_metrics` once the file is verified and locked."""
    from ..gait import (BAND_METRICS, METRICS, VELOCITY_METRICS, available_metrics, compute_metrics, load_target)
    from ..mechanism import mechanism_from_dict, parse_toml, walker_from_dict
    f = open_h5(p, "r", locking=False)  # (Exclusive holds the file's lock)
    copy = None
    try:
        N = int(f.attrs["n_variants"])
        if not bool(f.attrs.get("complete", False)):
            src = _text(f.attrs.get("study_source", "STUDY"))
            src = src[len("builtin:"):] if src.startswith("builtin:") else src
            raise UserError(f"{p}: incomplete results file (an interrupted run); finish it first with "
                            f"`explorer run {src} -o {p} --resume`")
        mech = mechanism_from_dict(parse_toml(_text(f.attrs["mechanism"]), f"{p} (its stored mechanism)"),
                                   _text(f.attrs.get("mechanism_source", p)))
        stored_group = f.get("metrics")
        stored = [k for k in stored_group.keys()] if stored_group is not None else []
        file_band = (float(stored_group.attrs["band"]) if stored_group is not None and "band" in stored_group.attrs
                     else _study_band(f))
        band = file_band if band is None else band

        # -- which metrics --------------------------------------------------------------------------
        if mech.crank is None:
            raise UserError(f"{p}: mechanism {mech.name!r} is driven along a path, not by a crank: gait metrics "
                            f"describe a leg's closed foot path over a crank turn, so there are none to compute")
        try:
            tspec = json.loads(_text(f.attrs["study_resolved"])).get("target")
        except (KeyError, TypeError, ValueError):
            tspec = None
        target = load_target(tspec, source=f"{p} (study_resolved)") if tspec else None
        why_not = available_metrics(mech, target)
        every = [m for m in METRICS if why_not[m] is None]
        if names is None:  # the force metrics stay as the run computed them (they need every vertex solved)
            chosen = [m for m in METRICS if m in stored and why_not[m] is None] or every
        elif names is True:
            chosen = every
        else:
            unknown = [n for n in names if n not in METRICS]
            if unknown:
                raise UserError(f"--metrics: unknown metric {unknown[0]!r} (known: {', '.join(METRICS)}, or all)")
            for n in names:
                if why_not[n] is not None:
                    raise UserError(f"--metrics: {n}: {why_not[n]}")
            chosen = [m for m in METRICS if m in names]
        walker = None
        if mech.crank is not None:
            try:
                spec = json.loads(_text(f.attrs["study_resolved"])).get("walker") or {}
            except (KeyError, TypeError, ValueError):
                spec = {}
            walker = walker_from_dict(spec, f"{p} (study_resolved)", "walker", base=mech.walker)

        def stored_band(m):
            return float(stored_group[m].attrs["band"]) if "band" in stored_group[m].attrs else file_band

        also = [m for m in METRICS if m in stored and m not in chosen and m in BAND_METRICS
                and stored_band(m) != band]
        compute = [m for m in METRICS if m in chosen or m in also]
        kept = [m for m in stored if m not in compute]

        # -- what they need ----------------------------------------------------------------------------
        foot = mech.foot
        need_path = [m for m in compute if m != "min_transmission_angle"]  # the others read the foot path
        need_vel = [m for m in compute if m in VELOCITY_METRICS]
        missing, blocked = [], set()
        # a lean file ([scene] store = "metrics") stores no series: each chunk is solved again as the run
        # solved it (its series_solve), so the metrics come out as the run's, bit for bit
        lean = lean_file(f)
        if need_path and not lean and not ("paths" in f and foot in f["paths"]):
            missing.append(f"/paths/{foot} (the foot path), needed for {', '.join(need_path)}")
            blocked |= set(need_path)
            fix = f"vertex {foot!r} in [scene] vertices"
        # foot velocities not stored (an optimisation, a study run without them): solved again from each
        # variant's stored design, chunk by chunk, as the run solved it (same steps, tolerance, method)
        resolve = bool(need_vel) and not lean and not ("velocities" in f and foot in f["velocities"])
        if missing:
            possible = [m for m in compute if m not in blocked]
            forced = [m for m in also if m in blocked]
            note = (f" ({', '.join(forced)} stored with band {file_band:g}: recomputed to keep one band)"
                    if forced else "")
            alt = f", or ask only for --metrics {','.join(possible)}" if possible and not forced else ""
            raise UserError(f"{p}: lacks {missing[0]}{note}; re-run the study with {fix}{alt}")
        if "min_transmission_angle" in compute:
            links = tuple(_text(s) for s in f["variants/lengths"].attrs["links"])
            if links != tuple(mech.link_names):
                raise UserError(f"{p}: the stored link columns ({', '.join(links)}) do not match the mechanism's "
                                f"links; cannot compute min_transmission_angle")

        # -- a copy of the file, with room for the new metrics, to write into --------------------------
        f.close()
        copy = copy_for_update(p, 8 * N * (len(compute) + len(kept)))

        def fill() -> tuple[int, int]:
            """Compute the metrics into the copy (in a child process: a write that fails leaves HDF5's state
            broken there, never in the caller's); (ok variants, variants solved again)."""
            f = h5py.File(copy, "r+")
            stored_group = f.get("metrics")
            # -- compute into /metrics_partial, chunk by chunk -----------------------------------------
            if PARTIAL in f:
                del f[PARTIAL]
            rows = int(f["chunks"].attrs["rows"]) if "chunks" in f and "rows" in f["chunks"].attrs else \
                max(hdf5_rows(int(f.attrs["steps"])), 1024)
            rows = max(1, min(rows, N))
            order = [m for m in METRICS if m in compute or m in kept] + [m for m in kept if m not in METRICS]
            now = timestamp()
            bar = None
            try:
                g = metrics_group(f, PARTIAL, band=band, computed=now)
                for m in order:
                    if m in kept:
                        f.copy(stored_group[m], g, name=m)
                        continue
                    create_metric(g, m, N, rows, band, now)
                if progress and hasattr(sys.stderr, "isatty") and sys.stderr.isatty() and N > rows:
                    from tqdm import tqdm
                    bar = tqdm(total=N, unit="variant", unit_scale=True, desc="metrics", file=sys.stderr, leave=False)
                dpath = f["paths"][foot] if need_path and not lean else None
                dvel = f["velocities"][foot] if need_vel and not resolve and not lean else None
                if lean:
                    how = json.loads(_text(f.attrs["series_solve"]))
                    lean_vertices = how["vertices"] + ([foot] if foot not in how["vertices"] else [])
                    study_dict = json.loads(_text(f.attrs["study_resolved"]))
                solver = _solver(f) if resolve else None
                resolved = 0
                dstatus, dlen, dcrank = f["status"], f["variants/lengths"], f["variants/crank"]
                dgeom = f["variants/geometry"] if "variants/geometry" in f else None  # each variant's own pivots
                gnames = [_text(s) for s in dgeom.attrs["names"]] if dgeom is not None else []
                targets = [g[m] for m in compute]
                ok = 0
                S = int(f.attrs["steps"])
                for a in range(0, N, rows):
                    b = min(a + rows, N)
                    status = dstatus[a:b]
                    if (status == STATUS_NOT_RUN).any():
                        raise UserError(f"{p}: variants {a}..{b - 1} were never run although the file is marked "
                                        f"complete; run the study again with --force")
                    ok += int((status == 0).sum())
                    paths = dpath[a:b] if dpath is not None else np.zeros((b - a, S, 2))
                    vel = dvel[a:b] if dvel is not None else None
                    G = dgeom[a:b] if dgeom is not None else None
                    geometry = {n: G[:, j] for j, n in enumerate(gnames)} if G is not None else None
                    if lean and (need_path or need_vel):  # solved again, a chunk at a time: memory stays one chunk
                        batch = resolve_series(f, slice(a, b), mechanism=mech, solve=how, study=study_dict,
                                               vertices=lean_vertices, velocities=bool(need_vel))
                        paths = batch.paths[foot]
                        vel = batch.velocities.get(foot) if need_vel else None
                        resolved += b - a
                    if resolve:
                        vel = _velocities(mech, foot, status, dlen[a:b], dcrank[a:b], geometry, S, solver)
                        resolved += int((status == 0).sum())
                    out = compute_metrics(paths, vel, status, compute, band, mechanism=mech,
                                          lengths=dlen[a:b], crank=dcrank[a:b], walker=walker, geometry=geometry,
                                          target=target)
                    for d, m in zip(targets, compute):
                        d[a:b] = out[m]
                    if bar is not None:
                        bar.update(b - a)
                f.flush()
                # the swap: the complete new group replaces the old one, and the checksums that cover it
                # (chunk digests, metadata) reach the disk in the same flush
                if "metrics" in f:
                    del f["metrics"]
                f.move(PARTIAL, "metrics")
                if has_integrity(f):
                    write_digests(f)
                    stamp(f)
                f.flush()
            finally:
                if bar is not None:
                    bar.close()
            f.close()
            return ok, resolved

        try:
            ok, resolved = guarded(fill, stall=None)
        except Unreadable as exc:  # HDF5 can crash when a write fails on a full disk (no reservation there)
            why = _full(p) if _no_room(p.parent) else (f"the process writing its copy stopped ({exc.signal or exc.how}); "
                                                        f"{p} is unchanged")
            raise UserError(f"{p}: cannot update the metrics: {why}") from None
        replace_with(copy, p)
        copy = None
    except (OSError, RuntimeError) as exc:  # h5py reports a failed write (a full disk) as either
        full = "No space left" in str(exc) or "errno = 28" in str(exc) or getattr(exc, "errno", None) == errno.ENOSPC
        why = _full(p) if full else f"{write_error_reason(exc)}; {p} is unchanged"
        raise UserError(f"{p}: cannot update the metrics: {why}") from None
    finally:
        _close_quietly(f)
        if copy is not None:
            copy.unlink(missing_ok=True)
    return {"path": p, "band": band, "metrics": tuple(chosen), "also": tuple(also), "kept": tuple(kept),
            "n_variants": N, "ok": ok, "resolved": resolved, "lean": lean, "wall_s": time.perf_counter() - t0}


def _full(p: Path) -> str:
    """What a failed update of ``p`` says when the disk is full."""
    return (f"the disk is full (no space left to write its updated copy); {p} is unchanged: free some space (the "
            f"update writes a copy of the file beside it) and run `explorer metrics` again")


def _no_room(folder: Path, slack: int = 1 << 20) -> bool:
    """Whether the filesystem of ``folder`` has less than ``slack`` bytes free (asked while the update's
    copy is still there: a writer that died of a full disk left it so)."""
    try:
        st = os.statvfs(folder)
    except OSError:
        return False
    return st.f_bavail * st.f_frsize < slack


def _close_quietly(f) -> None:
    """Close ``f`` if it is open; a close that fails (a full disk) is the error already being reported."""
    try:
        if f is not None and f.id.valid:
            f.close()
    except Exception:  # noqa: BLE001
        pass


def _solver(f: h5py.File) -> dict:
    """The solver settings the study ran with (its [study] tolerance and method), to solve again."""
    from ..kernels import DEFAULT_TOLERANCE
    try:
        st = json.loads(_text(f.attrs["study_resolved"]))["study"]
    except (KeyError, TypeError, ValueError):
        st = {}
    return {"tolerance": float(st.get("tolerance", DEFAULT_TOLERANCE)), "method": str(st.get("method", "block"))}


def _velocities(mech, foot: str, status, lengths, crank, geometry, steps: int, solver: dict) -> np.ndarray:
    """The foot velocities (n, steps, 2) of a chunk's ok variants, solved again from their stored designs
    (NaN for the others, whose metrics are NaN anyway)."""
    from ..kernels import simulate_batch
    vel = np.full((len(status), steps, 2), np.nan)
    ok = np.flatnonzero(status == 0)
    if ok.size:
        geo = {n: np.asarray(v)[ok] for n, v in geometry.items()} if geometry else None
        batch = simulate_batch(mech, np.asarray(lengths)[ok], np.asarray(crank)[ok], steps, geometry=geo,
                               vertices=[foot], velocities=True, **solver)
        vel[ok] = batch.velocities[foot]
    return vel
