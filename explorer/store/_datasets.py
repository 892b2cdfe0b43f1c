"""Every dataset of a results file, one row each, and the one function that creates them.

The table :data:`DATASETS` says, for each dataset a results file may hold, its dtype, its shape
rule (symbols: ``N`` variants, ``S`` steps, ``links``, ``k`` moved coordinates, ``chunks`` study
chunks, or a number), how it is stored (``scalar``: per-variant, chunked along N, lzf;
``series``: per-variant (N, S, ...), chunked along N with the study's compression; ``plain``:
contiguous), its fill value, units and description. A ``<...>`` in a name stands for a vertex, a
joint, a metric or a column name. :func:`create_dataset` is the only place a dataset of a results
file is created (by :class:`~explorer.store.ResultsWriter` for a run, an optimisation and a
Dask shard, and by :func:`~explorer.store.metrics_group` for ``explorer metrics``), so every
file describes itself the same way whoever wrote it.

A new per-variant dataset is one :func:`register_variant_data` entry (:data:`VARIANT_DATA`: its row, how a
commit's values and its frame columns are made), a new series one :func:`register_series` entry
(:data:`SERIES`); the writer, the readers, the integrity checks and the lean re-solve iterate over both.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Callable, NamedTuple

import h5py
import hdf5plugin  # noqa: F401 - registers the Blosc and Zstandard filters with HDF5 (15 ms after h5py)
import numpy as np

#: Filters of the (N, steps, ...) datasets by the study's ``[output] compression``; the default, blosc
#: (Blosc's LZ4 at level 5 behind its byte shuffle: smaller than lzf + shuffle at an eighth of its CPU
#: cost), chosen by measurement (see :mod:`explorer.store._write`). "blosc" and "zstd" are HDF5 plugin
#: filters (Blosc: filter 32001, Zstandard: 32015) that the ``hdf5plugin`` package registers with
#: HDF5: explorer imports it with this module, and any other reader does ``import hdf5plugin`` before
#: opening such a file with plain h5py (every file records it in its ``series_filter`` attribute).
#: Every chunked dataset also carries a Fletcher-32 checksum per chunk (in every h5py build): a
#: corrupted chunk is a read error, never a number.
SERIES_FILTERS = {"blosc": {"compression": 32001, "compression_opts": (0, 0, 0, 0, 5, 1, 1), "fletcher32": True},
                  "zstd": {"compression": 32015, "compression_opts": (3,), "shuffle": True, "fletcher32": True},
                  "lzf": {"compression": "lzf", "shuffle": True, "fletcher32": True},
                  "gzip": {"compression": "gzip", "compression_opts": 1, "shuffle": True, "fletcher32": True},
                  "none": {"fletcher32": True}}
#: What each ``[output] compression`` means, in words (the root attribute ``series_filter``).
SERIES_FILTER_WORDS = {
    "blosc": "Blosc (HDF5 filter 32001) LZ4 level 5 with byte shuffle, Fletcher-32; plain h5py reads it after "
             "`import hdf5plugin` (pip install hdf5plugin)",
    "zstd": "byte shuffle + Zstandard level 3 (HDF5 filter 32015), Fletcher-32; plain h5py reads it after "
            "`import hdf5plugin` (pip install hdf5plugin)",
    "lzf": "lzf with byte shuffle, Fletcher-32 (built into h5py)",
    "gzip": "gzip level 1 with byte shuffle, Fletcher-32 (built into HDF5)",
    "none": "uncompressed, Fletcher-32",
}
#: Filters of the small per-variant datasets.
SCALAR_FILTERS = {"compression": "lzf", "fletcher32": True}


@dataclass(frozen=True)
class DatasetSpec:
    """One dataset of a results file: ``name`` (``<...>`` = any one name), ``dtype``, ``shape`` (a
    tuple of dimension symbols or numbers), ``storage`` (scalar | series | plain), ``fill``,
    ``units`` ("" for none) and ``description``."""

    name: str
    dtype: str
    shape: tuple
    storage: str
    fill: object
    units: str
    description: str

    def matches(self, path: str) -> bool:
        pa, pb = self.name.split("/"), path.strip("/").split("/")
        return len(pa) == len(pb) and all(a == b or (a.startswith("<") and a.endswith(">")) for a, b in zip(pa, pb))


_NAN = math.nan

#: Every dataset a results file may hold (see :mod:`explorer.store` for the layout).
DATASETS: tuple[DatasetSpec, ...] = (
    DatasetSpec("theta", "f8", ("S",), "plain", None, "rad", "crank angle θ_k = 2πk/steps"),
    DatasetSpec("variants/lengths", "f8", ("N", "links"), "scalar", _NAN, "model units",
                "link lengths, one column per attr 'links'"),
    DatasetSpec("variants/crank", "f8", ("N",), "scalar", _NAN, "model units", "crank radius"),
    DatasetSpec("variants/geometry", "f8", ("N", "k"), "scalar", _NAN, "model units",
                "perturbed coordinates (crank centre, ground pivots, body joints in their body's frame), one column "
                "per attr 'names'"),
    DatasetSpec("variants/<column>", "i8", ("N",), "scalar", None, "",
                "a per-variant integer column known before any variant is solved (a frame column)"),
    DatasetSpec("status", "i1", ("N",), "scalar", -1, "",
                "variant status code; attrs codes / names / mapping; -1 = not run"),
    DatasetSpec("fail_theta", "f8", ("N",), "scalar", _NAN, "rad", "crank angle of the first failure; NaN when ok"),
    DatasetSpec("fail_theta_end", "f8", ("N",), "scalar", _NAN, "rad",
                "first failing crank angle going backward from 2π: the design cannot turn through "
                "[fail_theta, fail_theta_end]; NaN when ok"),
    DatasetSpec("fail_block", "i2", ("N",), "scalar", -1, "",
                "plan block that failed, -1 when ok; attr 'vertex' maps block -> vertex name"),
    DatasetSpec("iterations", "i8", ("N",), "scalar", -1, "", "total Newton iterations of the variant's solve"),
    DatasetSpec("paths/<vertex>", "f8", ("N", "S", 2), "series", _NAN, "model units", "positions of the vertex"),
    DatasetSpec("velocities/<vertex>", "f8", ("N", "S", 2), "series", _NAN, "model units per rad (dV/dθ)",
                "velocity of the vertex per radian of crank"),
    DatasetSpec("accelerations/<vertex>", "f8", ("N", "S", 2), "series", _NAN, "model units per rad² (d²V/dθ²)",
                "acceleration of the vertex per radian² of crank"),
    DatasetSpec("torque", "f8", ("N", "S"), "series", _NAN, "N·m",
                "motor torque of the walker's crankshaft at each crank angle, positive when the motor does positive "
                "work (inertia, weight and the load included)"),
    DatasetSpec("forces/<joint>", "f8", ("N", "S", 2), "series", _NAN, "N",
                "leg 0's reaction at the joint: the force its most heavily loaded member puts on the pin"),
    DatasetSpec("metrics/<name>", "f8", ("N",), "scalar", _NAN, "", "gait metric (units and description per metric)"),
    DatasetSpec("chunks/done", "bool", ("chunks",), "plain", False, "", "chunk i committed"),
    DatasetSpec("chunks/digest", "u1", ("chunks", 32), "plain", 0, "",
                "SHA-256 of chunk i's rows of every per-variant dataset that is not a series, written with "
                "done[i] (explorer.store._integrity); zero until committed"),
)

# -- the series: what the writer creates and fills, the readers and the lean re-solve give back ------------------
@dataclass(frozen=True)
class SeriesSpec:
    """One per-variant series over the crank angles a results file may store (rows of :data:`DATASETS`
    under ``group``). member : "vertex" or "joint" (a group of datasets ``group/<member>``), or "" (one
    dataset ``group``); stored(study) : whether a full (not lean) study stores it; members(study) : the names
    it stores ([] for a single dataset); attrs(study) : the dataset's own attributes; solved(solve) : the
    names a lean file's ``series_solve`` re-solves (None: not re-solved); rows(batch, name) : its
    (n, steps, ...) rows of a solved :class:`~explorer.kernels.Batch`; attrs : the dataset's attributes;
    dataset : its :class:`DatasetSpec` row where :data:`DATASETS` has none (a series added later).

    The writer (:class:`~explorer.store.ResultsWriter`), the readers (``Results.series`` and friends),
    the integrity checks (:mod:`explorer.store._integrity`) and the lean re-solve iterate over
    :data:`SERIES`: a new stored series is one :func:`register_series` call (its ``dataset`` row with it)."""

    group: str
    member: str
    stored: object
    members: object
    solved: object
    rows: object
    attrs: object = None
    dataset: DatasetSpec | None = None


def _vertex_series(group: str, flag: str | None) -> SeriesSpec:
    """paths (always), velocities and accelerations (when the scene asks): one dataset per scene vertex."""
    return SeriesSpec(group, "vertex",
                      stored=lambda study: True if flag is None else bool(getattr(study, flag)),
                      members=lambda study: list(study.vertex_names),
                      solved=lambda solve: list(solve["stored"]) if group in solve["groups"] else None,
                      rows=lambda batch, name: getattr(batch, group)[name])


def _forced(study) -> bool:
    return bool(getattr(study, "forces", False))


#: The series of a results file, in the order the writer creates them.
SERIES: list[SeriesSpec] = [
    _vertex_series("paths", None),
    _vertex_series("velocities", "velocities"),
    _vertex_series("accelerations", "accelerations"),
    SeriesSpec("torque", "", stored=_forced, members=lambda study: [],
               solved=lambda solve: [None] if solve["forces"] else None, rows=lambda batch, name: batch.torque,
               attrs=lambda study: {"operating": json.dumps(study.operating.as_dict())}),
    SeriesSpec("forces", "joint", stored=_forced, members=lambda study: list(study.force_joints),
               solved=lambda solve: list(solve["force_joints"]) if solve["forces"] else None,
               rows=lambda batch, name: batch.forces[name]),
]


def register_series(spec: SeriesSpec) -> SeriesSpec:
    """Add a stored series: the writer creates and fills it where ``spec.stored(study)``, the readers
    (``Results.series``) and the lean re-solve give it back, the integrity checks cover it."""
    if series_spec(spec.group) is not None:
        raise ValueError(f"series {spec.group!r} is already registered")
    SERIES.append(spec)
    return spec


def series_spec(group: str) -> SeriesSpec | None:
    """The :data:`SERIES` entry of ``group`` (None for a dataset that is not a series)."""
    return next((spec for spec in SERIES if spec.group == group), None)


def vertex_series() -> tuple[str, ...]:
    """The series stored per vertex (``paths``, ``velocities``, ``accelerations``, ...)."""
    return tuple(spec.group for spec in SERIES if spec.member == "vertex")


# -- the per-variant datasets that are not series: status, failure, design, ... -----------------------------------
#: Status code of a variant whose chunk has not been committed yet (incomplete files only).
STATUS_NOT_RUN = -1
#: Every status code that can appear in ``/status`` (the file format's table, stored in its attributes): the
#: kernels' codes (:data:`explorer.kernels.STATUS_NAMES`, which tests/test_import_graph.py holds equal to
#: these: store does not import the kernels) plus ``-1: not-run``.
FILE_STATUS_NAMES = {0: "ok", 1: "assembly", 2: "branch", 3: "no-convergence", 4: "invalid", 5: "singular",
                     STATUS_NOT_RUN: "not-run"}


class Commit(NamedTuple):
    """What one commit of ``ResultsWriter.write_chunk`` holds for its n variants: lengths (n, n_links), crank (n,)
    radii, batch (the :class:`~explorer.kernels.Batch` that solved them), geometry ((n, k) moved coordinates, or
    None) and metrics ({name: (n,)})."""

    lengths: object
    crank: object
    batch: object
    geometry: object = None
    metrics: dict | None = None


@dataclass(frozen=True)
class VariantData:
    """One per-variant dataset of a results file that is not a series (shape (N,) or (N, k), stored
    ``scalar``), a row of :data:`VARIANT_DATA`.

    path : where it is stored (``"status"``, ``"variants/lengths"``); rows(commit) : its (n, ...) values of a
    :class:`Commit`; columns(results, values, a) : the :meth:`~explorer.store.Results.frame` columns of rows
    ``a ...`` read back from it ({column: (n,)}, in frame order); stored(study) : whether a file of ``study``
    has it (None: every file); attrs(study) : the dataset's own attributes when it is created (None: only its
    row's units and description); optional : readers skip it where a file lacks it (one written before it
    existed); dataset : its :class:`DatasetSpec` where :data:`DATASETS` has none (a dataset added later).

    The writer (:class:`~explorer.store.ResultsWriter`: created in ``create``, filled in ``write_chunk``), the
    readers (``Results.frame`` and every reader built on it), the integrity checks (the chunk digests cover
    every per-variant dataset, :func:`explorer.store._integrity.per_variant`) and a Dask stitch iterate over
    :data:`VARIANT_DATA`: a new one is one :func:`register_variant_data` call and its code."""

    path: str
    rows: Callable
    columns: Callable
    stored: Callable | None = None
    attrs: Callable | None = None
    optional: bool = False
    dataset: DatasetSpec | None = None


def strings(values) -> np.ndarray:
    """Text values as an HDF5 variable-length string array (what attributes listing names hold)."""
    return np.array([str(v) for v in values], dtype=h5py.string_dtype())


def _text(s) -> str:
    return s.decode() if isinstance(s, bytes) else str(s)


def _column(name: str) -> Callable:
    return lambda results, values, a: {name: values}


def _split(names: Callable) -> Callable:
    """Frame columns of an (n, k) dataset: one per name of ``names(results)``, in order."""
    return lambda results, values, a: {name: values[:, j] for j, name in enumerate(names(results))}


def _status_attrs(study) -> dict:
    codes = sorted(FILE_STATUS_NAMES)
    return {"codes": np.array(codes, dtype=np.int8), "names": strings(FILE_STATUS_NAMES[c] for c in codes),
            "mapping": json.dumps({str(c): FILE_STATUS_NAMES[c] for c in codes})}


def _status_columns(results, codes, a) -> dict:
    """``status`` (categorical, every known status a category, not-run last) and ``status_code``."""
    import pandas as pd
    order = sorted(FILE_STATUS_NAMES, key=lambda c: (c < 0, c))
    lut = np.full(256, -1, dtype=np.int64)
    for i, c in enumerate(order):
        lut[c & 0xFF] = i
    return {"status": pd.Categorical.from_codes(lut[codes.astype(np.int64) & 0xFF],
                                                categories=[FILE_STATUS_NAMES[c] for c in order]),
            "status_code": codes}


def _block_attrs(study) -> dict:
    """``vertex``: the first vertex each plan block places (the "failing vertex" of a failed variant)."""
    from ..plan import make_plan
    mech = study.mech
    return {"vertex": strings(mech.vertices[b.vertices[0]] for b in make_plan(mech).blocks)}


def _block_columns(results, block, a) -> dict:
    names = np.array([None] + [_text(s) for s in results.file["fail_block"].attrs["vertex"]], dtype=object)
    return {"fail_vertex": names[np.where(block >= 0, block + 1, 0)]}


def _lengths_attrs(study) -> dict:
    mech = study.mech
    return {"links": strings(mech.link_names), "link_ends": strings(f"{l.a}-{l.b}" for l in mech.links),
            "nominal": mech.lengths}


def _crank_attrs(study) -> dict:
    mech = study.mech
    if mech.crank is None:
        return {"nominal": np.nan, "description": "no crank: the mechanism is driven along a path (NaN)"}
    return {"nominal": float(mech.crank.radius)}


def _geometry_attrs(study) -> dict:
    moved, nominal = study.geometry_names, study.mech.parameters()
    return {"names": strings(moved), "nominal": np.array([nominal[n] for n in moved], dtype=np.float64)}


#: The per-variant datasets of a results file that are not series, in the order the writer creates them and
#: the frame shows their columns (after any ``variants/<column>`` an optimiser's writer adds, before
#: ``grashof`` and the metrics). ``/metrics/<name>`` (the metric table's, :mod:`explorer.gait`) and
#: ``/variants/<column>`` (given whole when the file is created) are not rows: they come and go by name.
VARIANT_DATA: list[VariantData] = [
    VariantData("variants/lengths", rows=lambda c: c.lengths, columns=_split(lambda r: r.link_names),
                attrs=_lengths_attrs),
    VariantData("variants/crank", rows=lambda c: c.crank, columns=_column("crank"), attrs=_crank_attrs),
    VariantData("variants/geometry", rows=lambda c: c.geometry, columns=_split(lambda r: r.geometry_names),
                stored=lambda study: bool(study.geometry_names), attrs=_geometry_attrs, optional=True),
    VariantData("status", rows=lambda c: c.batch.status, columns=_status_columns, attrs=_status_attrs),
    VariantData("fail_theta", rows=lambda c: c.batch.fail_theta, columns=_column("fail_theta")),
    VariantData("fail_theta_end", rows=lambda c: c.batch.fail_theta_end, columns=_column("fail_theta_end"),
                optional=True),
    VariantData("fail_block", rows=lambda c: c.batch.fail_block, columns=_block_columns, attrs=_block_attrs),
    VariantData("iterations", rows=lambda c: c.batch.iterations, columns=_column("iterations"), optional=True),
]


def register_variant_data(spec: VariantData) -> VariantData:
    """Add a per-variant dataset: the writer creates it (where ``spec.stored(study)``) and fills it at every
    commit, the chunk digests cover it, :meth:`~explorer.store.Results.frame` reads its columns back."""
    if any(v.path == spec.path for v in VARIANT_DATA):
        raise ValueError(f"per-variant dataset {spec.path!r} is already registered")
    VARIANT_DATA.append(spec)
    return spec


#: Attributes of the groups (those not listed carry none).
GROUPS: dict[str, dict] = {
    "paths": {"units": "model units"},
    "velocities": {"units": "model units per rad (dV/dθ)"},
    "accelerations": {"units": "model units per rad² (d²V/dθ²)"},
    "forces": {"units": "N", "description": "leg 0's reaction at each joint: the force its most heavily loaded member "
                                            "(a link, a body, the crank, the frame or the ground) puts on the pin"},
    "metrics": {"description": "gait metrics of the foot path (explorer.gait): the walker scene, the single-leg band "
                               "metrics and the buildability screen's inputs; band = stance band, a fraction of the "
                               "step height"},
}


def dataset_spec(path: str) -> DatasetSpec:
    """The row of :data:`DATASETS` for ``path`` (such as ``"paths/foot"``); KeyError if none."""
    for spec in (*DATASETS, *(s.dataset for s in (*SERIES, *VARIANT_DATA) if s.dataset is not None)):
        if spec.matches(path):
            return spec
    raise KeyError(f"no dataset spec for {path!r}")


def now() -> str:
    """The timestamp results files carry (ISO 8601 UTC, seconds)."""
    return datetime.now(timezone.utc).isoformat(timespec="seconds")


def metric_attrs(name: str, band: float, computed: str | None = None) -> dict:
    """What every ``/metrics/<name>`` dataset carries, whoever computed it: ``band`` (the stance band
    it was computed with), ``units``, ``direction`` and ``description`` (from the metric table, for
    a known metric) and ``computed`` (when)."""
    from ..gait import metric
    out: dict = {"band": float(band)}
    row = metric(name)
    if row is not None:
        out.update(units=row.unit, direction=row.direction, description=row.description)
    out["computed"] = computed or now()
    return out


def create_dataset(f: h5py.Group, path: str, dims: dict, *, rows: int | None = None, series_rows: int | None = None,
                   compression: str = "blosc", data=None, attrs: dict | None = None,
                   like: str | None = None) -> h5py.Dataset:
    """Create dataset ``path`` of a results file (group ``f``, paths relative to it) from its row of
    :data:`DATASETS`: dtype, shape (its symbols from ``dims``: N, S, links, k, chunks), filters,
    chunks (``rows`` variants per chunk for scalar ones, ``series_rows`` for series), fill value,
    ``units`` and ``description``; ``attrs`` add to (or override) those. ``data``: initial values
    (for ``theta`` and the optimiser's columns) instead of the fill value. ``like``: the table row
    to use when ``path`` is not where the dataset will end up (a metric of a replacement group)."""
    spec = dataset_spec(like or f"{f.name.rstrip('/')}/{path}".lstrip("/"))
    shape = tuple(int(dims[s]) if isinstance(s, str) else int(s) for s in spec.shape)
    kw: dict = {}
    if spec.storage == "scalar":
        kw.update(chunks=(int(rows),) + shape[1:], **SCALAR_FILTERS)
    elif spec.storage == "series":
        kw.update(chunks=(int(series_rows),) + shape[1:], **SERIES_FILTERS[compression])
    if data is not None:
        d = f.create_dataset(path, data=np.asarray(data, dtype=spec.dtype), **kw)
    else:
        fill = {"fillvalue": spec.fill} if spec.fill is not None else {}
        d = f.create_dataset(path, shape=shape, dtype=spec.dtype, **fill, **kw)
    merged = {}
    if spec.units:
        merged["units"] = spec.units
    merged["description"] = spec.description
    merged.update(attrs or {})
    for k, v in merged.items():
        if v is None:
            continue
        d.attrs[k] = json.dumps(v) if isinstance(v, dict) else v
    return d


def create_group(f: h5py.Group, name: str, attrs: dict | None = None, track_order: bool = True) -> h5py.Group:
    """Create group ``name`` with its :data:`GROUPS` attributes (plus ``attrs``)."""
    g = f.create_group(name, track_order=track_order or None)
    for k, v in {**GROUPS.get(name, {}), **(attrs or {})}.items():
        g.attrs[k] = v
    return g
