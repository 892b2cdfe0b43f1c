"""Results files (HDF5): written chunk by chunk by ``run_study``, read with ``open_results``.

Layout (N variants, S = steps, readable with plain h5py)::

    /                      attrs: format = "explorer-results", format_version = 1, explorer_version,
                           created (ISO 8601 UTC), complete (bool), completed, study (the study file's
                           text), study_source, study_resolved (JSON, every default filled in),
                           study_fingerprint, mechanism (the mechanism's TOML text), mechanism_source,
                           n_variants, steps
    /theta                 (S,) float64, rad: θ_k = 2πk/S (a path driver: s, t_k = T·k/(S−1))
    /variants/lengths      (N, n_links) float64; attrs links (names, columns in order), link_ends,
                           nominal (n_links,), units
    /variants/crank        (N,) float64 crank radius; attr nominal
    /variants/geometry     (N, k) float64, only when the study moves coordinates (k > 0): the crank
                           centre, ground pivot and body joint coordinates it perturbs; attrs names
                           (k,) (parameter names such as "crank.x", "2.y", "coupler.P.x", columns in
                           order), nominal (k,), units. Coordinates not listed keep their nominal.
    /variants              attr perturbed: names of the perturbed parameters (mech.parameters() order)
    /status                (N,) int8; attrs codes / names (and mapping, JSON): 0 ok, 1 assembly,
                           2 branch, 3 no-convergence, 4 invalid, -1 not-run (incomplete files)
    /fail_theta            (N,) float64 rad, first failing crank angle; NaN when ok
    /fail_block            (N,) int16 plan block that failed, -1 when ok; attr vertex: block → the
                           first vertex it places (the "failing vertex")
    /iterations            (N,) int64 total Newton iterations
    /paths/<vertex>        (N, S, 2) float64 for every [scene] vertex
    /velocities/<vertex>   (N, S, 2) dV/dθ, only if [scene] velocities = true
    /accelerations/<vertex> (N, S, 2) d²V/dθ², only if [scene] accelerations = true
    /torque                (N, S) float64 N·m motor torque, only for a forces study ([scene] forces = true)
    /forces/<joint>        (N, S, 2) float64 N, leg 0's reaction at each [scene] force_joints joint
    /metrics/<name>        (N,) float64 gait metrics, only those the study asked for; attrs band, units,
                           direction, description, computed (the same whether the run or `explorer
                           metrics` wrote it); /metrics attrs band, description
    A lean file (``[scene] store = "metrics"``) has root attributes store = "metrics" and series_solve
    (JSON: how its designs were solved) and no /paths, /velocities, /accelerations, /torque, /forces:
    Results re-solves the series it is asked for, bit for bit, through its resolver (explorer.store.Resolver:
    explorer.study.resolve_series; store itself reads and writes files only, and imports no kernel).
    /chunks/done           (n_chunks,) bool; /chunks attr rows: chunk i is variants [i·rows, (i+1)·rows)
    /chunks/digest         (n_chunks, 32) uint8: SHA-256 of chunk i's per-variant rows (not the series),
                           set with done[i]; root attr integrity = "sha256-v1 <hex>": SHA-256 of the
                           metadata, every attribute and the contiguous datasets. Both are verified by
                           open_results before anything is read (explorer.store._integrity); a file
                           edited on purpose with plain h5py is re-checksummed with seal(path)

Every dataset is one row of the table :data:`explorer.store._datasets.DATASETS` (dtype, shape rule,
storage, fill, units, description) and is created by its one function, ``create_dataset``. The per-variant
datasets that are not series are the rows of :data:`VARIANT_DATA` (how a commit's values and the frame's
columns are made of each; a new one is one :func:`register_variant_data` entry), the series those of
:data:`SERIES` (:func:`register_series`): the writer, the readers and the integrity checks iterate over them.
Every (N, ...) dataset is chunked along N and compressed (for the (N, S, 2) series, by default Blosc's
LZ4 with byte shuffle, chosen by measurement: see :mod:`explorer.store._write`; root attribute
series_filter). Blosc and Zstandard are HDF5 plugin filters: explorer registers them (``hdf5plugin``);
plain h5py reads such a file after ``import hdf5plugin``.
"""

from ._datasets import (DATASETS, SERIES, VARIANT_DATA, Commit, DatasetSpec, SeriesSpec, VariantData, create_dataset,
                        dataset_spec, metric_attrs, now, register_series, register_variant_data)
from ._guard import Unreadable
from ._guard import call as guarded
from ._integrity import seal
from ._lock import OutputLock
from ._shards import ShardPlan, clean_folder, completed_shards, plan_shards, shards_folder, stitch, write_shard
from ._read import (RESOLVE_ROWS, Results, inspect, lean_file, open_for_update, open_results, probe, stored_designs,
                    stored_mechanism, stored_operating)
from ._resolver import RESOLVER_HOME, Resolver, register_resolver, registered_resolver
from ._update import check_updatable, update_metrics
from ._variants import (check_variant, is_results, results_band, variant_design, variant_mechanism, variant_peak_forces,
                        variant_row, variant_torque)
from ._write import (DEFAULT_CHUNK_VARIANTS, FILE_STATUS_NAMES, FORMAT, FORMAT_VERSION, STATUS_NOT_RUN, SYNC_SECONDS,
                     Exclusive,
                     ResultsWriter, chunk_rows, copy_for_update, create_metric, fingerprint_diff, hdf5_rows,
                     metrics_group, open_h5, replace_with, write_error_reason)

__all__ = ["SERIES", "SeriesSpec", "register_series", "VARIANT_DATA", "VariantData", "Commit", "register_variant_data", "DATASETS", "DEFAULT_CHUNK_VARIANTS", "DatasetSpec", "FILE_STATUS_NAMES", "FORMAT", "FORMAT_VERSION",
           "STATUS_NOT_RUN", "Results", "ResultsWriter", "check_variant", "chunk_rows", "create_dataset", "create_metric",
           "dataset_spec", "hdf5_rows", "is_results", "metric_attrs", "metrics_group", "open_for_update", "open_results", "probe", "results_band", "variant_design",
           "variant_mechanism", "variant_peak_forces", "variant_row", "variant_torque", "now", "OutputLock", "ShardPlan", "clean_folder", "completed_shards",
           "plan_shards", "shards_folder", "stitch", "write_shard", "fingerprint_diff", "write_error_reason", "seal",
           "RESOLVE_ROWS", "lean_file", "stored_designs", "stored_mechanism", "stored_operating",
           "RESOLVER_HOME", "Resolver", "register_resolver", "registered_resolver", "guarded", "Unreadable", "inspect",
           "copy_for_update", "replace_with", "open_h5", "Exclusive", "check_updatable", "update_metrics",
           "SYNC_SECONDS"]

from .._moved import moved  # noqa: E402

#: names that moved up to explorer.study (issue 40: store reads and writes files only), importable from here for
#: one release
__getattr__ = moved(__name__, {"resolve_series": "explorer.study"})
