"""Reading results files: :func:`open_results` → :class:`Results` (a thin layer over plain h5py)."""

from __future__ import annotations

import contextlib

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING

import h5py
import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism, mechanism_from_dict
from ..plan import fourbar_loops, grashof_batch
from ._datasets import FILE_STATUS_NAMES, SERIES, VARIANT_DATA, series_spec, vertex_series
from ._resolver import Resolver, registered_resolver
from ._integrity import READ_CACHE_BYTES, RESTORE, is_legacy, warn_legacy
from ._write import FORMAT, open_h5

if TYPE_CHECKING:
    import pandas as pd


def open_results(path, resolver: Resolver | None = None) -> "Results":
    """Open a results file written by ``explorer run`` / :func:`explorer.run_study` (read only).

    ``resolver``: how a lean file's series are re-solved and a variant's mechanism assembled
    (:class:`~explorer.store.Resolver`); default: the one :mod:`explorer.study` registers
    (:func:`explorer.open_results` passes it).

    ``path`` is a path or anything with ``__fspath__`` (such as the summary ``run_study`` returns).
    Incomplete files (an interrupted run) open too: rows not yet run have status "not-run".

    Verified before anything is read (:func:`explorer.store._integrity.verify`): the checksum of the
    metadata and every attribute and contiguous dataset, the digest of every committed chunk's
    per-variant rows, and the chunk index of every series. A file that does not verify is a one-line
    UserError naming it and what is damaged; a file written by an earlier version (no checksums) opens
    with a one-line warning on stderr. The verification runs first in a child process
    (:mod:`explorer.store._guard`): damaged bytes that make HDF5 loop or crash are refused in one line
    in bounded time, and Ctrl-C stops the wait at once.
    """
    p = Path(os.fspath(path))
    for _ in range(3):
        before = _identity(p)
        report = inspect(p, warn=False)
        try:
            f = h5py.File(p, "r", rdcc_nbytes=READ_CACHE_BYTES)  # the verification holds every dataset open
        except OSError as exc:
            raise UserError(f"{p}: cannot open as an HDF5 results file: {_open_error(exc)}") from None
        if _identity(p, f) == before:
            break
        f.close()  # replaced or changed while the child read it: read it again
    else:
        raise UserError(f"{p}: the file keeps changing while it is read (is a run writing it?)")
    try:
        r = Results(f, p, resolver)
        if report["legacy"]:  # an earlier version's file: one line, once the file has opened
            warn_legacy(p)
        return r
    except UserError:
        f.close()
        raise
    except (KeyError, ValueError, TypeError, OSError, RuntimeError) as exc:  # foreign or damaged metadata
        f.close()
        raise UserError(f"{p}: not a readable explorer results file ({_reason(exc)})") from None


def _reason(exc: BaseException) -> str:
    """What h5py or the reading code raised for foreign or damaged metadata, in words."""
    what = f"missing {exc.args[0]}" if isinstance(exc, KeyError) and exc.args else \
        (str(exc).splitlines()[0] if str(exc) else type(exc).__name__)
    return what[:200]


def _open_error(exc: BaseException) -> str:
    """Why h5py could not open a file, in words."""
    msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
    if "unable to lock" in msg.lower():
        return "the file is being written by another process (unable to lock it)"
    if "truncated" in msg.lower() or "signature" in msg.lower():
        return f"truncated or corrupt ({msg})"
    return msg


def _identity(p: Path, f: h5py.File | None = None) -> tuple | None:
    """What tells one version of the file at ``p`` from another (device, inode, size, times): of the
    path, or of the file ``f`` holds open."""
    try:
        st = os.fstat(f.id.get_vfd_handle()) if f is not None else os.stat(p)
    except (OSError, ValueError, TypeError, AttributeError):
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)


def inspect(path, verify: bool = True, warn: bool = True) -> dict:
    """Read and verify the results file at ``path`` in a child process (:func:`explorer.store._guard.call`)
    before the caller opens it: a UserError naming the file for one that is missing, cannot be opened,
    is not an explorer results file or does not verify (or makes HDF5 loop or crash); else
    {"legacy": bool (written without checksums), "complete", "fingerprint", "sharded"}. ``verify=False``
    reads every attribute and the structure only (no digests of rows). ``warn``: the one-line warning
    for a file written without checksums (:func:`~explorer.store._integrity.warn_legacy`)."""
    from ._guard import Unreadable, call
    p = Path(os.fspath(path))
    if not p.is_file():
        raise UserError(f"{p}: no such results file")
    try:
        report = call(_inspect, p, verify)
    except Unreadable as exc:
        raise UserError(f"{p}: not a readable explorer results file (damaged: {exc}); {RESTORE}") from None
    if warn and report["legacy"]:
        warn_legacy(p)
    return report


def _inspect(p: Path, verify: bool) -> dict:
    """:func:`inspect`'s work, in the child."""
    from ._integrity import metadata_checksum
    from ._integrity import verify as verify_file
    try:
        f = h5py.File(p, "r", rdcc_nbytes=READ_CACHE_BYTES)
    except OSError as exc:
        raise UserError(f"{p}: cannot open as an HDF5 results file: {_open_error(exc)}") from None
    try:
        if f.attrs.get("format") != FORMAT:
            raise UserError(f"{p}: not an explorer results file (no format = {FORMAT!r} attribute)")
        if "shards" in f.attrs:  # a study stitched from shard files (explorer.run_study_dask): are they there?
            from ._shards import check_sources
            check_sources(f, p)
        # before any number is read: metadata, attributes and committed rows match their checksums
        try:
            legacy = not verify_file(f, p, warn=False) if verify else is_legacy(f)
        except UserError as exc:
            if "shards" not in f.attrs:
                raise
            folder = _text(f.attrs["shards"])  # its rows are read from its shard files: say where to look
            raise UserError(str(exc).replace(f"; {RESTORE}", f" (its rows are those of the shard files in {folder}/: "
                                                              f"one is damaged); {RESTORE}")) from None
        if legacy or not verify:  # no checksum read them: every attribute and structure is read here once
            metadata_checksum(f)
        a = f.attrs
        return {"legacy": legacy, "complete": bool(a.get("complete", False)), "sharded": "shards" in a,
                "fingerprint": a.get("study_fingerprint")}
    except UserError:
        raise
    except (KeyError, ValueError, TypeError, OSError, RuntimeError) as exc:  # foreign or damaged metadata
        raise UserError(f"{p}: not a readable explorer results file ({_reason(exc)})") from None
    finally:
        f.close()


def probe(path) -> dict:
    """What the file at ``path`` is, read from its root attributes only (for the runners' checks
    before they write): ``format`` (the attribute, None if absent), ``complete``, ``fingerprint``
    (the study fingerprint or None), ``sharded`` (stitched from shard files), ``error`` (None, or
    "in use" when another process holds it, "damaged" when reading it makes HDF5 loop or crash,
    "unreadable" otherwise). Read in a child process (:mod:`explorer.store._guard`); for a damaged
    file, ``format`` says whether its bytes hold explorer's format marker (so that ``--force`` may
    replace it)."""
    from ._guard import Unreadable, call
    p = Path(os.fspath(path))
    try:
        return call(_probe, p)
    except Unreadable:
        return {"format": FORMAT if _marked(p) else None, "complete": False, "fingerprint": None,
                "sharded": False, "error": "damaged"}


def _probe(p: Path) -> dict:
    out = {"format": None, "complete": False, "fingerprint": None, "sharded": False, "error": None}
    try:
        with h5py.File(p, "r") as f:
            a = f.attrs
            out.update(format=a.get("format"), complete=bool(a.get("complete", False)),
                       fingerprint=a.get("study_fingerprint"), sharded="shards" in a)
    except OSError as exc:
        out["error"] = "in use" if "unable to lock" in str(exc).lower() else "unreadable"
    return out


#: Bytes of a file searched for explorer's format marker when HDF5 cannot read it (its root attributes
#: are written first: they sit in the first kilobytes).
MARK_BYTES = 16 << 20


def _marked(p: Path) -> bool:
    """Whether the file at ``p`` is an HDF5 file whose first :data:`MARK_BYTES` hold the format marker."""
    try:
        with open(p, "rb") as fh:
            head = fh.read(MARK_BYTES)
    except OSError:
        return False
    return head.startswith(b"\x89HDF\r\n\x1a\n") and FORMAT.encode() in head


class Results:
    """An open results file.

    theta : (steps,) crank angles, rad. study : the study as a nested dict, every default filled
    in; study_text : the study file's text. mechanism : the nominal :class:`Mechanism`.
    link_names, geometry_names (the perturbed coordinates stored in ``/variants/geometry``, () if
    none), vertices (stored), n_variants N, steps, complete (False for an interrupted run),
    attrs : the root attributes as a dict. ``file`` is the underlying ``h5py.File``.
    resolver : how designs are solved again (:class:`~explorer.store.Resolver`; None: the registered one).
    Use as a context manager or call :meth:`close`.
    """

    def __init__(self, f: h5py.File, filename: Path, resolver: Resolver | None = None):
        self.file, self.filename = f, filename
        self._resolver = resolver
        self.attrs = dict(f.attrs)
        self.theta = f["theta"][...]
        self.study = json.loads(self.attrs["study_resolved"])
        self.study_text = str(self.attrs["study"])
        self.n_variants = int(self.attrs["n_variants"])
        self.steps = int(self.attrs["steps"])
        self.link_names = tuple(_text(s) for s in f["variants/lengths"].attrs["links"])
        g = f["variants"].get("geometry")
        self.geometry_names = tuple(_text(s) for s in g.attrs["names"]) if g is not None else ()
        #: a lean file (``[scene] store = "metrics"``): no series stored; :meth:`path` and the other
        #: series readers re-solve the designs they are asked for, bit for bit (:func:`explorer.study.resolve_series`)
        self.lean = lean_file(f)
        self._solve = json.loads(self.attrs["series_solve"]) if self.lean else None
        self._cache: dict = {}  # a lean file's re-solved series: {variant: {(group, vertex): (steps, 2)}}
        self._keep_solved = True  # False inside read_once()
        if self.lean:
            self.vertices = tuple(self._solve["stored"])
        else:
            self.vertices = tuple(f["paths"].keys()) if "paths" in f else ()
        self._mech = None
        self._screen_counts = None  # the screen's counts of the last blocked rank() (explorer.store._blocks)
        self._failed_at_vertex = None  # whether any variant failed at a vertex (explorer.store._blocks.as_whole)
        _check_shapes(f, filename, self.n_variants)

    @property
    def resolver(self) -> Resolver:
        """How this file's designs are solved again: the one given to :func:`open_results`, else the
        registered one (:func:`~explorer.store.registered_resolver`)."""
        return self._resolver if self._resolver is not None else registered_resolver()

    # -- metadata --------------------------------------------------------------------------------------
    @property
    def complete(self) -> bool:
        return bool(self.file.attrs["complete"])

    @property
    def mechanism(self) -> Mechanism:
        """The nominal mechanism, rebuilt from the copy of its TOML stored in the file."""
        if self._mech is None:
            from ..mechanism import parse_toml
            source = f"{self.filename} (its stored mechanism)"
            data = parse_toml(str(self.attrs.get("mechanism", "")), source)
            mech = mechanism_from_dict(data, source)
            if (self.study or {}).get("build"):  # the study's [build] over the mechanism's: its link masses
                from ..mechanism._build import apply_build, build_from_dict
                mech = apply_build(mech, build_from_dict(self.study["build"], source, base=mech.build), source)
            self._mech = mech
        return self._mech

    @property
    def metric_names(self) -> tuple[str, ...]:
        """Names of the datasets under ``/metrics`` (each (N,), one frame column)."""
        g = self.file.get("metrics")
        return tuple(k for k in g.keys() if g[k].shape == (self.n_variants,)) if g is not None else ()

    @property
    def band(self) -> float:
        """Stance band of the stored metrics: the ``band`` attribute of ``/metrics`` (set by the run
        and by ``explorer metrics``), else the study's ``[scene] band`` (files written before the run
        set it), else the default 0.01."""
        g = self.file.get("metrics")
        if g is not None and "band" in g.attrs:
            return float(g.attrs["band"])
        try:
            return float(self.study["scene"]["band"])
        except (KeyError, TypeError, ValueError):
            from ..gait import DEFAULT_BAND
            return DEFAULT_BAND

    @property
    def nominal(self) -> dict[str, float]:
        """The nominal design as stored in the file: {link name: length, ..., "crank": radius, then each
        perturbed coordinate ("2.x": value, ...)}. Every design parameter, stored or not:
        ``mechanism.parameters()``."""
        nom = self.file["variants/lengths"].attrs["nominal"]
        out = {name: float(v) for name, v in zip(self.link_names, nom)}
        out["crank"] = float(self.file["variants/crank"].attrs["nominal"])
        if self.geometry_names:
            gnom = self.file["variants/geometry"].attrs["nominal"]
            out.update({name: float(v) for name, v in zip(self.geometry_names, gnom)})
        return out

    @property
    def perturbed(self) -> tuple[str, ...]:
        """Names of the parameters the study perturbed (link names, possibly "crank", and the
        coordinates it moved, such as "2.x")."""
        return tuple(_text(s) for s in self.file["variants"].attrs.get("perturbed", ()))

    def status_counts(self) -> dict[str, int]:
        """{status name: number of variants}, every known status listed; the counts add up to N."""
        codes = self.file["status"][...]
        counts = {FILE_STATUS_NAMES[c]: 0 for c in sorted(FILE_STATUS_NAMES) if c >= 0}
        for c, n in zip(*np.unique(codes, return_counts=True)):
            counts[FILE_STATUS_NAMES.get(int(c), f"code {int(c)}")] = int(n)
        return counts

    # -- tables ----------------------------------------------------------------------------------------
    def frame(self, rows: tuple[int, int] | None = None) -> "pd.DataFrame":
        """One row per variant: ``variant``, one column per link length (by link name), ``crank``, one
        column per perturbed coordinate (named by its parameter, such as ``"2.x"`` or ``"crank.y"``),
        ``status`` (name; categorical), ``status_code``, ``fail_theta`` and ``fail_theta_end`` (rad,
        the unreachable crank range of a failed variant; NaN when ok), ``fail_vertex`` (None when ok),
        ``iterations`` (these from the per-variant datasets of :data:`~explorer.store.VARIANT_DATA`, then the
        columns of any registered since), ``grashof`` and ``grashof_margin`` (class and margin of the limiting
        crank-driven four-bar loop, for mechanisms that have one), then one column per
        ``/metrics/<name>``, then ``buildable`` (bool: ok and passing the buildability screen,
        :mod:`explorer.gait._screen`) and ``screen`` ("pass" or why not) when the file stores a
        metric the screen reads. An optimisation's file adds ``generation`` after ``variant``.

        rows : (a, b) for variants a … b − 1 only (default: every variant)."""
        import pandas as pd  # imported on use: it costs ~0.5 s at start-up
        f = self.file
        a, b = (0, self.n_variants) if rows is None else (int(rows[0]), int(rows[1]))
        s = slice(a, b)
        cols: dict = {"variant": np.arange(a, b, dtype=np.int64)}
        for name, d in f["variants"].items():
            if d.attrs.get("column", False):
                cols[name] = d[s]
        read = {}  # every per-variant dataset of the registry (explorer.store._datasets.VARIANT_DATA), in order
        for spec in VARIANT_DATA:
            if spec.optional and spec.path not in f:
                continue
            read[spec.path] = values = f[spec.path][s]
            cols.update(spec.columns(self, values, a))
        L = read["variants/lengths"]
        geometry = {name: cols[name] for name in self.geometry_names} if "variants/geometry" in read else {}
        if fourbar_loops(self.mechanism):
            cols["grashof"], cols["grashof_margin"] = grashof_batch(self.mechanism, L, cols["crank"],
                                                                    geometry=geometry or None)
        for m in self.metric_names:
            cols[m] = f["metrics"][m][s]
        df = pd.DataFrame(cols, index=pd.RangeIndex(a, b) if rows is not None else None)
        from ..gait import screen_columns
        screened = screen_columns(df, self.screen)
        if screened is not None:
            df["buildable"], df["screen"] = screened[0], screened[1]
        return df

    def frame_rows(self, variants, columns=None) -> "pd.DataFrame":
        """The rows of :meth:`frame` of ``variants`` (a variant, or any sequence of them: any order, repeats
        allowed), in that order, indexed by variant: the same columns, dtypes and values as those rows of the
        whole frame, read without it (only the blocks of rows that hold them:
        :func:`explorer.store._blocks.frame_rows`). UserError for a variant outside 0 … N−1. ``columns``: only
        these frame columns, in this order (default: every column)."""
        from ._blocks import frame_rows
        empty = np.size(variants) == 0  # [] reads as float: no rows
        return frame_rows(self, np.empty(0, dtype=np.int64) if empty else self._indices(variants), columns)

    def frame_blocks(self):
        """:meth:`frame` in consecutive blocks of rows (:data:`explorer.store._blocks.READ_BLOCK`, ~16k rows
        each), in variant order, each indexed by its variant numbers and typed as the whole frame: for a pass
        over every variant of a large file without holding its whole frame."""
        from ._blocks import blocks
        return blocks(self)

    def select(self, where: str | None = None, include_failed: bool = False, include_screened: bool = False,
               columns=None) -> "pd.DataFrame":
        """The rows of :meth:`frame` that :meth:`rank` ranks (ok unless ``include_failed``, passing the
        buildability screen unless ``include_screened``, then the filter ``where``), in variant order, indexed by
        variant, with only ``columns`` (``variant`` first; default every column): read in blocks of rows, so
        that a million-design file's frame is never held whole (:func:`explorer.store._blocks.select`)."""
        from ._blocks import select
        return select(self, where, include_failed, include_screened, columns)

    # -- one variant -----------------------------------------------------------------------------------
    def check_variant(self, variant) -> int:
        """``variant`` as an int in 0 … N−1 (UserError otherwise)."""
        from ._variants import check_variant
        return check_variant(self, variant)

    def row(self, variant, frame: "pd.DataFrame | None" = None) -> "pd.Series":
        """Variant ``variant``'s row of :meth:`frame` as a pandas Series indexed by column name (the
        same values and units: lengths, crank and coordinates in model units, ``fail_theta`` in rad,
        each metric in its unit, see ``/metrics/<name>`` attr units). UserError for a variant
        outside 0 … N−1. ``frame``: a :meth:`frame` already read, to reuse."""
        from ._variants import check_variant, variant_row
        return variant_row(self, check_variant(self, variant), frame)

    def design(self, variant, frame: "pd.DataFrame | None" = None) -> dict[str, float]:
        """The design parameters of variant ``variant`` as {parameter name: value}: every parameter
        of ``mechanism.parameters()``, in its order (link lengths by link name, ``crank`` the crank
        radius, ``crank.x``/``crank.y`` its centre, ``V.x``/``V.y`` each ground pivot and body joint),
        all in model units; the variant's stored value where the study perturbed the parameter, the
        nominal elsewhere. ``mechanism.with_parameters(r.design(v))`` is the variant's mechanism
        (:meth:`variant_mechanism` also sets its assembly guess). UserError for a variant outside 0 … N−1.
        ``frame``: a :meth:`frame` already read, to reuse."""
        from ._variants import variant_design
        return variant_design(self, variant, frame)

    def metric_ranks(self, variant, frame: "pd.DataFrame | None" = None, include_screened: bool = False) -> dict:
        """{metric: (rank, pool) or None} of variant ``variant`` for every stored metric: its rank among
        the variants ``explorer rank`` ranks (ok, passing the buildability screen unless
        ``include_screened``) with a finite value (1 = best in the metric's natural direction, ties
        share a rank), None when it is not in that pool (failed, not run, screened out, NaN). What
        ``explorer show`` prints. ``frame``: a :meth:`frame` already read, to reuse."""
        if frame is None:  # counted block by block (a million-design file's frame is never held)
            from ._blocks import metric_ranks as blocked
            return blocked(self, self.check_variant(variant), include_screened)
        from ._variants import metric_ranks
        return metric_ranks(self, variant, frame, include_screened)

    def variant_mechanism(self, variant) -> Mechanism:
        """The :class:`~explorer.mechanism.Mechanism` of variant ``variant`` (its design on the
        nominal, assembling on the nominal's branch); UserError for a design that has no valid
        lengths or coordinates."""
        from ._variants import variant_mechanism
        return variant_mechanism(self, variant)

    def screen_summary(self, df=None) -> dict:
        """What the buildability screen removes from the ok variants: {"removed": n, "checks": {check:
        n}, "applied": [check names]} (:func:`explorer.gait.screen_counts`); ``df`` : a frame() to reuse (without
        it the counts are summed block by block, or taken from the :meth:`rank` that just read every block)."""
        from ..gait import screen_counts
        if df is not None:
            out = screen_counts(df, self.screen)
        else:
            from ._blocks import screen_counts as blocked
            out = self._screen_counts if self._screen_counts is not None else blocked(self)
            out = {**out, "checks": dict(out["checks"]), "applied": list(out["applied"])}
        out["path_driven"] = self.mechanism.crank is None
        if not out["path_driven"]:  # a foot on a ground slider: the screen's inputs do not apply (the reason)
            from ..gait import available_metrics
            out["not_applicable"] = available_metrics(self.mechanism)["foot_headroom"]
        return out

    @property
    def operating(self):
        """The study's operating point (:class:`explorer.mechanism.Operating`: its ``[operating]`` over the
        mechanism's, as the run resolved it), or None when neither gave one."""
        table = self.study.get("operating")
        return stored_operating(table, f"{self.filename} (its study)") if table else None

    @property
    def body(self) -> str | None:
        """The walker's force model its forces were computed with: "moving" (the body moves with the
        contact foot) or "held" (the frame held still; every forces file made before the moving model),
        from the root attribute ``body``; None for a file without forces."""
        if not self.study.get("scene", {}).get("forces"):
            return None
        return _text(self.attrs.get("body", "held"))

    @property
    def screen(self):
        """The buildability screen's thresholds (:class:`explorer.gait.Screen`): the study's
        ``[screen]`` table, else the defaults."""
        from ..gait import Screen
        try:
            return Screen(**self.study.get("screen", {}))
        except TypeError:
            return Screen()

    def rank(self, by=None, top: int | None = 10, where: str | None = None, ascending=None, weights=None,
             pareto=None, include_failed: bool = False, include_screened: bool = False,
             frame: "pd.DataFrame | None" = None, columns=None) -> "pd.DataFrame":
        """Ranked rows of :meth:`frame`, best first, with a ``rank`` column: :func:`explorer.gait.rank`
        (by default the weighted score of :data:`explorer.gait.DEFAULT_WEIGHTS` over those of them stored,
        :meth:`default_weights`; one metric ``by``, a weighted ``score`` over normalised metrics with ``weights``, or the
        Pareto front of ``pareto``; ``where`` is a filter such as "bob < 0.5 and slip < 0.05" (explorer.gait._filter);
        failed variants are left out unless ``include_failed``, variants the buildability screen
        removes unless ``include_screened``; the frame's ``screen`` column says why). ``frame``: a
        :meth:`frame` already read, to reuse; without it the file is read in blocks of rows and only the
        ranked columns of the rows that pass the filters are kept (:func:`explorer.store._blocks.rank`: the
        same answer, in the memory of those columns). ``columns``: without ``frame``, the frame columns to
        return after ``rank`` (``variant`` and the ranked ones always; default: every column).

        A metric that is not stored raises UserError saying how to compute it
        (``explorer metrics RESULTS`` or ``[scene] metrics = true``).
        """
        from ..gait import rank
        if by is None and weights is None and pareto is None:
            self.default_weights()  # ranks over the default metrics stored; UserError if none is
        else:
            self._check_metrics(_ranked_columns(by, weights, pareto))
        if frame is None:
            from ._blocks import rank as blocked
            return blocked(self, by=by, top=top, where=where, ascending=ascending, weights=weights, pareto=pareto,
                           include_failed=include_failed, include_screened=include_screened, columns=columns)
        return rank(frame, by=by, top=top, where=where, ascending=ascending,
                    weights=weights, pareto=pareto, include_failed=include_failed, include_screened=include_screened)

    def default_weights(self, check: bool = True) -> tuple[dict[str, float], list[str]]:
        """The default score's weights over the metrics this file stores, and the default metrics it
        lacks (ranked without): :func:`explorer.gait.default_weights`. An optimisation stores
        only its objectives, constraints and the screen's inputs. With ``check``, a file that stores
        none of them is a UserError saying how to compute them."""
        from ..gait import DEFAULT_WEIGHTS, default_weights
        stored = self.metric_names
        if not any(m in stored for m in DEFAULT_WEIGHTS):
            if check:
                self._check_metrics(list(DEFAULT_WEIGHTS))
            return {}, list(DEFAULT_WEIGHTS)
        return default_weights(stored)

    def _check_metrics(self, names) -> None:
        """UserError if any of ``names`` is a gait metric that this file does not store."""
        from ..gait import METRICS
        stored = self.metric_names
        missing = [n for n in names if n in METRICS and n not in stored]
        if not missing:
            return
        if not stored and self.mechanism.crank is None:
            raise UserError(f"{self.filename}: mechanism {self.mechanism.name!r} is driven along a path: gait metrics "
                            f"do not apply to it; rank by a column such as iterations (--by iterations: the fewest "
                            f"Newton iterations first)")
        from ..gait import available_metrics, metric
        why = available_metrics(self.mechanism)  # a metric the mechanism cannot have (a foot on a ground slider)
        never = [n for n in missing if why[n] is not None and metric(n).group in ("walker", "leg", "screen", "slider")]
        if never:
            usable = [m for m in stored if why.get(m) is None] or [m for m in METRICS if why[m] is None]
            s = "s" if len(never) > 1 else ""
            hint = f"; rank by a metric it has: --by {usable[0]}" if usable else ""
            raise UserError(f"{self.filename}: metric{s} {', '.join(never)} do{'' if s else 'es'} not apply: "
                            f"{why[never[0]]}{hint}")
        if not stored:
            raise UserError(f"{self.filename}: no gait metrics stored; compute them with "
                            f"`explorer metrics {self.filename}` (no re-solving) or set [scene] metrics = true "
                            f"in the study and run it again")
        s = "s" if len(missing) > 1 else ""
        raise UserError(f"{self.filename}: metric{s} {', '.join(missing)} not stored (stored: {', '.join(stored)}); "
                        f"compute {'them' if s else 'it'} with `explorer metrics {self.filename} "
                        f"--metrics {','.join(missing)}`")

    # -- series ----------------------------------------------------------------------------------------
    def _series(self, group: str, variant, vertex) -> np.ndarray:
        """Rows of a stored (or re-solved) series; a chunk that fails HDF5's Fletcher-32 or its filter (a
        damaged data chunk) is a one-line UserError naming the file, never a traceback."""
        try:
            return self._series_rows(group, variant, vertex)
        except OSError as exc:
            what = " ".join(str(exc).split())[:160] or type(exc).__name__
            raise UserError(f"{self.filename}: not a readable explorer results file (damaged: /{group}: {what}); "
                            f"{RESTORE}") from None

    def _series_rows(self, group: str, variant, vertex) -> np.ndarray:
        vertex = self._vertex(vertex)
        if self.lean:
            return self._lean_series(group, variant, vertex)
        if group not in self.file:
            raise UserError(f"{self.filename}: no {group} stored (the study's [scene] did not ask for them)")
        g = self.file[group]
        if vertex not in g:
            raise UserError(f"{self.filename}: vertex {vertex!r} is not stored "
                            f"(stored: {', '.join(g.keys())}; set [scene] vertices)")
        if isinstance(variant, (int, np.integer)):
            if not -self.n_variants <= variant < self.n_variants:
                raise UserError(f"{self.filename}: variant {variant} out of range (0 to {self.n_variants - 1})")
            return g[vertex][variant]
        if isinstance(variant, slice):
            return g[vertex][variant]
        idx = self._indices(variant)
        uniq, back = np.unique(idx, return_inverse=True)
        if uniq.size == 0:
            return np.empty((0,) + g[vertex].shape[1:])
        return g[vertex][uniq][back]

    def _indices(self, variant) -> np.ndarray:
        """Any sequence of variants as (n,) int64 in 0 … N−1, in the order given (UserError otherwise)."""
        # any sequence of variants, in any order, repeats allowed (h5py wants sorted unique indices)
        try:
            idx = np.asarray(variant).astype(np.int64, casting="safe").reshape(-1)
        except (TypeError, ValueError):
            raise UserError(f"{self.filename}: variant: expected a whole number, a slice or a list of them, "
                            f"got {variant!r}") from None
        bad = idx[(idx < -self.n_variants) | (idx >= self.n_variants)]
        if bad.size:
            raise UserError(f"{self.filename}: variant {int(bad[0])} out of range (0 to {self.n_variants - 1})")
        return np.where(idx < 0, idx + self.n_variants, idx)

    def _lean_series(self, group: str, variant, vertex: str) -> np.ndarray:
        """A lean file's series, re-solved (the same checks and shapes as a stored one)."""
        solve = self._solve
        spec = series_spec(group)
        if spec is None or spec.solved(solve) is None:
            raise UserError(f"{self.filename}: no {group} stored (the study's [scene] did not ask for them)")
        if spec.member == "vertex" and vertex not in self.vertices:
            raise UserError(f"{self.filename}: vertex {vertex!r} is not stored "
                            f"(stored: {', '.join(self.vertices)}; set [scene] vertices)")
        if isinstance(variant, (int, np.integer)):
            if not -self.n_variants <= variant < self.n_variants:
                raise UserError(f"{self.filename}: variant {variant} out of range (0 to {self.n_variants - 1})")
            return self._resolved(np.array([int(variant) % self.n_variants]), group, vertex)[0]
        if isinstance(variant, slice):
            idx = np.arange(self.n_variants)[variant]
        else:
            idx = self._indices(variant)
        return self._resolved(idx, group, vertex)

    def prefetch(self, variants) -> None:
        """Re-solve ``variants`` (any sequence) of a lean file at once, saying so in one line on stderr,
        so that the series readers that follow find them solved (nothing for a file that stores its series)."""
        if self.lean:
            self._resolved(self._indices(variants), None, None)

    #: Most re-solved series bytes a lean file's :class:`Results` keeps (older variants are dropped first).
    CACHE_BYTES = 64 << 20

    @contextlib.contextmanager
    def read_once(self):
        """``with results.read_once(): ...``: a lean file's series re-solved inside are handed back and not
        kept for later reads (those already kept still serve): for a large read made once, such as the
        report's 2,000 foot paths, whose kept series (every re-solved series of those designs) would
        otherwise stay in memory to the end."""
        keep, self._keep_solved = getattr(self, "_keep_solved", True), False
        try:
            yield self
        finally:
            self._keep_solved = keep

    def _resolved(self, idx: np.ndarray, group, vertex) -> np.ndarray | None:
        """Series ``group``/``vertex`` of variants ``idx`` (in that order, repeats allowed) of a lean file:
        those not solved yet are re-solved, in chunks of :data:`RESOLVE_ROWS` designs, saying so in one line
        on stderr; kept for later reads while they fit in :data:`CACHE_BYTES`. ``group`` None: solve only."""
        uniq, back = np.unique(idx, return_inverse=True)
        todo = np.array([v for v in uniq.tolist() if v not in self._cache], dtype=np.int64)
        per = self.steps * 16 * (len(self._solve["vertices"]) * (1 + self._solve["velocities"]
                                                                  + self._solve["accelerations"])
                                 + len(self._solve["force_joints"])) + self.steps * 8
        keep = getattr(self, "_keep_solved", True) and len(uniq) * per <= self.CACHE_BYTES  # a big read: not kept
        got = {}
        if todo.size:
            import sys
            import time
            t0 = time.perf_counter()
            for a in range(0, todo.size, RESOLVE_ROWS):
                part = todo[a:a + RESOLVE_ROWS]
                batch = self.resolver.series(self.file, part, mechanism=self.mechanism, solve=self._solve,
                                       study=self.study, operating=self.operating if self._solve["forces"] else None)
                for k, v in enumerate(part.tolist()):
                    rows = _rows_of(batch, self._solve, k)
                    if keep:
                        self._cache[v] = rows
                    elif group is not None:
                        got[v] = rows[(group, vertex)]
            print(f"{self.filename} stores metrics only: re-solved {_variant_list(todo)} "
                  f"({time.perf_counter() - t0:.1f} s){_version_note(self.attrs)}", file=sys.stderr)
        out = None
        if group is not None:
            if not uniq.size:
                return np.empty((0, self.steps) if group == "torque" else (0, self.steps, 2))
            key = (group, vertex)
            out = np.stack([got[v] if v in got else self._cache[v][key] for v in uniq.tolist()])[back]
        if keep:  # the oldest re-solved variants go first (never those just read)
            excess = len(self._cache) - max(len(uniq), self.CACHE_BYTES // max(per, 1))
            wanted = set(uniq.tolist())
            for v in list(self._cache):
                if excess <= 0:
                    break
                if v not in wanted:
                    del self._cache[v]
                    excess -= 1
        return out

    @property
    def series_groups(self) -> tuple[str, ...]:
        """The series groups of the file stored per vertex (``paths``, ``velocities``, ``accelerations``: the
        :data:`~explorer.store._datasets.SERIES` entries of member "vertex"): those stored,
        or, in a lean file, those a full study would have stored (re-solved when read)."""
        if self.lean:
            return tuple(self._solve["groups"])
        return tuple(g for g in vertex_series() if g in self.file)

    def _vertex(self, vertex) -> str:
        if vertex is not None:
            return str(vertex)
        foot = self.mechanism.foot
        return foot if foot in self.vertices or not self.vertices else self.vertices[0]

    def path(self, variant: int, vertex: str | None = None) -> np.ndarray:
        """Positions of ``vertex`` (default: the foot) for one variant, shape (steps, 2), model units.

        ``variant`` may also be a slice or any list of variants (any order, repeats allowed, such as
        ``r.rank(...).variant.values``), giving (n, steps, 2) in that order.
        """
        return self._series("paths", variant, vertex)

    def velocity(self, variant: int, vertex: str | None = None) -> np.ndarray:
        """dV/dθ of ``vertex`` for one variant, shape (steps, 2), model units per radian of crank."""
        return self._series("velocities", variant, vertex)

    def acceleration(self, variant: int, vertex: str | None = None) -> np.ndarray:
        """d²V/dθ² of ``vertex`` for one variant, shape (steps, 2), model units per rad²."""
        return self._series("accelerations", variant, vertex)

    def torque(self, variant: int) -> np.ndarray:
        """Motor torque of one variant at every crank angle, shape (steps,), N·m (a study with
        ``[scene] forces = true``; positive when the motor does positive work)."""
        if "torque" not in self.file and not (self.lean and self._solve["forces"]):
            raise UserError(f"{self.filename}: no motor torque stored: run the study with [scene] forces = true "
                            f"and an [operating] table")
        v = self.check_variant(variant)
        if self.lean:
            return self._resolved(np.array([v]), "torque", None)[0]
        return self.file["torque"][v]

    def series(self, group: str, variant, name: str | None = None) -> np.ndarray:
        """Any series the file stores (:data:`explorer.store._datasets.SERIES`: paths, velocities,
        accelerations, torque, forces, and any registered since) of one ``variant``: ``name`` the vertex or
        joint (a vertex series: default the foot). Re-solved in a lean file, as the series it would store."""
        spec = series_spec(group)
        if spec is None:
            raise UserError(f"{self.filename}: {group!r} is not a series (series: "
                            f"{', '.join(s.group for s in SERIES)})")
        if spec.member == "vertex":
            return self._series(group, variant, name)
        v = self.check_variant(variant)
        if self.lean:
            solved = spec.solved(self._solve)
            if solved is None or (spec.member and name not in solved):
                raise UserError(f"{self.filename}: no {group}{'/' + str(name) if spec.member else ''} stored")
            return self._resolved(np.array([v]), group, name if spec.member else None)[0]
        if group not in self.file or (spec.member and name not in self.file[group]):
            raise UserError(f"{self.filename}: no {group}{'/' + str(name) if spec.member else ''} stored")
        return (self.file[group][name] if spec.member else self.file[group])[v]

    @property
    def force_joints(self) -> tuple[str, ...]:
        """Joints whose reactions are stored (``[scene] force_joints``)."""
        if self.lean:
            return tuple(self._solve["force_joints"]) if self._solve["forces"] else ()
        return tuple(self.file["forces"].keys()) if "forces" in self.file else ()

    def force(self, variant: int, joint: str) -> np.ndarray:
        """Leg 0's reaction at ``joint`` for one variant, shape (steps, 2), N: the force the joint's most heavily
        loaded member puts on its pin."""
        if joint not in self.force_joints:
            raise UserError(f"{self.filename}: no reaction stored for joint {joint!r} (stored: "
                            f"{', '.join(self.force_joints) or 'none; list joints in [scene] force_joints'})")
        v = self.check_variant(variant)
        if self.lean:
            return self._resolved(np.array([v]), "forces", joint)[0]
        return self.file["forces"][joint][v]

    # -- lifetime --------------------------------------------------------------------------------------
    def close(self) -> None:
        if self.file.id.valid:
            self.file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __repr__(self) -> str:
        state = "complete" if self.complete else "incomplete"
        return f"<Results {self.filename} ({self.n_variants} variants × {self.steps} steps, {state})>"


#: Designs a lean file's readers re-solve per kernel call (a chunk of a study's size: memory stays flat).
RESOLVE_ROWS = 2048


def lean_file(f: h5py.File) -> bool:
    """Whether an open results file is lean (``[scene] store = "metrics"``: no series stored; root
    attributes ``store = "metrics"`` and ``series_solve``, how its designs were solved)."""
    return f.attrs.get("store") == "metrics" and "series_solve" in f.attrs


def stored_operating(table: dict, source: str):
    """The :class:`~explorer.mechanism.Operating` of a results file's stored ``[operating]`` table
    (``study_resolved``). A table without ``body`` was stored before the moving-body force model, when
    the forces held the frame still: it reads as body = "held", so its series re-solve as they were."""
    from ..mechanism import operating_from_dict
    return operating_from_dict({"body": "held", **table}, source, "operating")


def stored_designs(f: h5py.File, variants) -> tuple[np.ndarray, np.ndarray, dict]:
    """The designs of ``variants`` (an (n,) increasing index array or a slice) as an open results file
    stores them: lengths (n, n_links), crank radii (n,) and {coordinate name: (n,)} of the coordinates the
    study moved (empty when it moved none), model units: what a re-solve solves
    (:func:`explorer.study.resolve_series`)."""
    rows = variants if isinstance(variants, slice) else np.asarray(variants, dtype=np.int64)
    lengths = f["variants/lengths"][rows]
    crank = f["variants/crank"][rows]
    moved = {}
    if "variants/geometry" in f:
        g = f["variants/geometry"]
        G = g[rows]
        moved = {_text(n): G[:, j] for j, n in enumerate(g.attrs["names"])}
    return lengths, crank, moved


def stored_mechanism(f: h5py.File) -> Mechanism:
    """The nominal mechanism of an open results file, from the copy of its TOML stored in the file (without
    the study's ``[build]``: :attr:`Results.mechanism` applies it)."""
    from ..mechanism import parse_toml
    return mechanism_from_dict(parse_toml(str(f.attrs["mechanism"]), "its stored mechanism"), "its stored mechanism")


def _rows_of(batch, solve: dict, k: int) -> dict:
    """{(group, vertex): (steps, 2), ("torque", None): (steps,)} of row ``k`` of a re-solved batch: what a
    full study stores of it (copies, so that the batch can go)."""
    out = {}
    for spec in SERIES:  # every series a full study would have stored (explorer.store._datasets.SERIES)
        for name in spec.solved(solve) or ():
            out[(spec.group, name)] = spec.rows(batch, name)[k].copy()
    return out


def _variant_list(variants: np.ndarray, shown: int = 8) -> str:
    """"variants 3, 17" / "variant 5" / "1,024 variants (0, 1, … 1023)": what a re-solve says it solved."""
    vs = [int(v) for v in variants]
    if len(vs) == 1:
        return f"variant {vs[0]}"
    if len(vs) <= shown:
        return "variants " + ", ".join(map(str, vs))
    return f"{len(vs):,} variants ({', '.join(map(str, vs[:3]))}, … {vs[-1]})"


def _version_note(attrs: dict) -> str:
    """A note when the file was written by another explorer version (its kernels may round differently)."""
    from .. import __version__
    written = str(attrs.get("explorer_version", ""))
    return f"; written by explorer {written}, re-solved by {__version__}" if written and written != __version__ else ""


def _check_shapes(f: h5py.File, filename, n: int) -> None:
    """UserError unless every per-variant dataset has N rows and /status holds only known codes: what a
    file without checksums (an earlier version's) can still be checked for (issue 31 item 7: a damaged
    n_variants or status value used to be a traceback)."""
    if n < 0:
        raise UserError(f"{filename}: not a readable explorer results file (damaged: n_variants = {n})")
    bad = []

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and not name.startswith(("chunks", "metrics_partial")) and name != "theta" \
                and obj.ndim >= 1 and obj.shape[0] != n:
            bad.append(f"/{name} has {obj.shape[0]} rows")

    f.visititems(visit)
    if bad or "status" not in f:
        what = bad[0] if bad else "/status is missing"
        raise UserError(f"{filename}: not a readable explorer results file (damaged: n_variants = {n} but {what})")
    codes = np.unique(f["status"][...])
    unknown = [int(c) for c in codes if int(c) not in FILE_STATUS_NAMES]
    if unknown:
        raise UserError(f"{filename}: not a readable explorer results file (damaged: /status holds code "
                        f"{unknown[0]}, which no run writes)")


def _ranked_columns(by, weights, pareto) -> list[str]:
    """The columns a rank() call ranks on (for the not-stored-metric check; rank validates the rest)."""
    if pareto is not None:
        if isinstance(pareto, str):
            return [c.strip() for c in pareto.split(",") if c.strip()]
        try:
            return [str(c) for c in pareto]
        except TypeError:
            return []
    if weights is not None:
        try:
            return [str(c) for c in weights]
        except TypeError:
            return []
    if by is None:
        from ..gait import DEFAULT_WEIGHTS
        return list(DEFAULT_WEIGHTS)
    return [str(by)]


def _text(s) -> str:
    return s.decode() if isinstance(s, bytes) else str(s)


def open_for_update(path) -> h5py.File:
    """An existing, complete-or-not explorer results file opened for writing (``r+``), for a deliberate
    edit (``explorer metrics`` writes a copy instead: :func:`copy_for_update`). UserError for a missing,
    foreign, busy, unreadable or damaged file (it is verified first, in a child process:
    :func:`~explorer.store.inspect`)."""
    p = Path(os.fspath(path))
    if not p.is_file():
        raise UserError(f"{p}: no such results file")
    inspect(p, warn=False)  # in a child process first: bytes that make HDF5 loop are refused in one line
    f = open_h5(p, "r+")
    if f.attrs.get("format") != FORMAT:
        f.close()
        raise UserError(f"{p}: not an explorer results file (no format = {FORMAT!r} attribute)")
    if is_legacy(f):
        warn_legacy(p)
    return f
