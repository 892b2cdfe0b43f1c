"""The one door through which the tests (and anyone testing explorer) reach its internals.

The packages' public faces (``explorer``, ``explorer.mechanism``, ``explorer.kernels``, ``explorer.gait``,
``explorer.store``, ``explorer.study``, ``explorer.view``, ...) are what a user imports. The tests also
check pieces that are no one's public API: a kernel's cache key, the writer's internals, the kit's
sheet layout, the command line's vocabulary. They import them from here, never from a private module
(``explorer.x._y``), so that moving a module inside explorer changes this file, not the tests.

Names are grouped by the package they come from; a module itself is re-exported where a test patches
it (``monkeypatch.setattr(testing.store_write, ...)``).
"""

from __future__ import annotations

import importlib

#: name -> (module relative to explorer, attribute; None: the module itself). Read lazily: importing
#: explorer.testing costs nothing until a name is used.
_HOMES = {
    # -- extras ------------------------------------------------------------------------------------------------
    "EXTRAS": ("._extras", "EXTRAS"),
    "MissingExtra": ("._extras", "MissingExtra"),
    "require": ("._extras", "require"),
    "MOVED": ("._moved", "MOVED"),
    # -- bench -------------------------------------------------------------------------------------------------
    "COLUMNS": (".bench._accuracy", "COLUMNS"),
    "draw_variants": (".bench._accuracy", "draw_variants"),
    # -- cli: the vocabulary, and what verbs print ------------------------------------------------------------
    "VOCABULARY": (".cli._args", "VOCABULARY"),
    "chosen_variant": (".cli._args", "chosen_variant"),
    "top_count": (".cli._args", "top_count"),
    "describe_text": (".cli._describe", "text"),
    "parameter_lines": (".cli._show", "parameter_lines"),
    # -- gait --------------------------------------------------------------------------------------------------
    "evaluate_filter": (".gait._filter", "evaluate_filter"),
    "METRIC_GROUPS": (".gait._metrics", "GROUPS"),
    "MetricGroup": (".gait._metrics", "MetricGroup"),
    "load_target": (".gait._path", "load_target"),
    "path_error": (".gait._path", "path_error"),
    "path_match": (".gait._path", "path_match"),
    "path_residuals": (".gait._path", "path_residuals"),
    "BY_NAME": (".gait._table", "BY_NAME"),
    "walker_metrics": (".gait._walker", "walker_metrics"),
    # -- kernels -----------------------------------------------------------------------------------------------
    "kernels_simulate": (".kernels._simulate", None),
    "KEY": (".kernels._cache", "KEY"),
    "kernel_cache_path": (".kernels._cache", "kernel_cache_path"),
    "kernel_sources": (".kernels._cache", "kernel_sources"),
    "source_key": (".kernels._cache", "source_key"),
    "topology": (".kernels._inputs", "topology"),
    "STATUS_NOCONV": (".kernels._sweep", "STATUS_NOCONV"),
    "HOLES": (".kernels._sweep_template", "HOLES"),
    "SECTIONS": (".kernels._sweep_template", "SECTIONS"),
    "render": (".kernels._sweep_template", "render"),
    # -- plan ------------------------------------------------------------------------------------------------
    "strong_components": (".plan._blt", "_tarjan"),
    # -- store -------------------------------------------------------------------------------------------------
    "store_write": (".store._write", None),
    "ChunkFilter": (".store._chunks", "ChunkFilter"),
    "SERIES_FILTERS": (".store._datasets", "SERIES_FILTERS"),
    "fletcher32": (".store._chunks", "fletcher32"),
    "write_rows": (".store._chunks", "write_rows"),
    "series_rows": (".store._write", "series_rows"),
    "parallel_rows": (".kernels._rows", "parallel_rows"),
    "check_integrity": (".store._integrity", "check"),
    "store_blocks": (".store._blocks", None),
    "view_plots": (".view._plots", None),  # SCATTER_POINTS, DENSITY_ROWS: patched small in tests
    "series_groups": (".store._integrity", "series_groups"),
    "stamp": (".store._integrity", "stamp"),
    "OutputLock": (".store._lock", "OutputLock"),
    "lock_path": (".store._lock", "lock_path"),
    "MAX_SHARDS": (".store._shards", "MAX_SHARDS"),
    "ShardPlan": (".store._shards", "ShardPlan"),
    "completed_shards": (".store._shards", "completed_shards"),
    "plan_shards": (".store._shards", "plan_shards"),
    "shard_name": (".store._shards", "shard_name"),
    "shards_folder": (".store._shards", "shards_folder"),
    "stitch": (".store._shards", "stitch"),
    "write_shard": (".store._shards", "write_shard"),
    # -- study -------------------------------------------------------------------------------------------------
    "study_dask": (".study._dask", None),
    "chunk_solver": (".study._chunk", "chunk_solver"),
    "check_disk_space": (".study._output", "_check_disk_space"),
    "estimated_bytes": (".study._output", "estimated_bytes"),
    # -- view --------------------------------------------------------------------------------------------------
    "LinkageAnimation": (".view._animate", "LinkageAnimation"),
    "describe": (".view._describe", "describe"),
    "FOOT_COLOR": (".view._draw", "FOOT_COLOR"),
    "GUIDE_COLOR": (".view._draw", "GUIDE_COLOR"),
    "SLOT_COLOR": (".view._draw", "SLOT_COLOR"),
    "LegArtists": (".view._draw", "LegArtists"),
    "guide_segments": (".view._draw", "guide_segments"),
    "hull_order": (".view._draw", "hull_order"),
    "slot_segments": (".view._draw", "slot_segments"),
    "export_dxf": (".fabrication._export", "export_dxf"),
    "export_svg": (".fabrication._export", "export_svg"),
    "Material": (".fabrication._kit", "Material"),
    "build_kit": (".fabrication._kit", "build_kit"),
    "clearance_line": (".fabrication._kit", "clearance_line"),
    "kit_data": (".fabrication._kit", "kit_data"),
    "pin_diameter": (".fabrication._kit", "pin_diameter"),
    "shaft_diameter": (".fabrication._kit", "shaft_diameter"),
    "write_kit": (".fabrication._kit", "write_kit"),
    "write_assembly_pdf": (".fabrication._kit_pdf", "write_assembly_pdf"),
    "CHAR_W": (".fabrication._kit_sheet", "CHAR_W"),
    "copy_labels": (".fabrication._kit_sheet", "copy_labels"),
    "check_variant": (".view._plots", "check_variant"),
    "is_results": (".view._plots", "is_results"),
    "results_band": (".view._plots", "results_band"),
    "variant_row": (".view._plots", "variant_row"),
    "optimize_front_polish": (".optimize._front_polish", None),
    "study_output": (".study._output", None),
    "study_run": (".study._run", None),
    "store_guard": (".store._guard", None),
    "store_lock": (".store._lock", None),
    "verb_modules": (".cli", "_verb_modules"),
    "cli_physics": (".cli._physics", None),
    "run_physics_jobs": (".physics._check", "_run_jobs"),
    # -- added for the tests' imports --------------------------------------------------------------------
    "N_CURVE": (".synthesis._curves", "N_CURVE"),
    "angles_at_arc": (".synthesis._curves", "angles_at_arc"),
    "arc_fractions": (".synthesis._curves", "arc_fractions"),
    "descriptors": (".synthesis._curves", "descriptors"),
    "normalise": (".synthesis._curves", "normalise"),
    "ordered_match": (".synthesis._curves", "ordered_match"),
    "reverse_descriptor": (".synthesis._curves", "reverse_descriptor"),
    "build_atlas": (".synthesis._atlas", "build_atlas"),
    "move_parameters": (".synthesis._atlas", "move_parameters"),
    "open_atlas": (".synthesis._atlas", "open_atlas"),
    "synthesize": (".synthesis._synth", "synthesize"),
    "bench_seeds": (".bench._seeds", None),
    "kernels_codegen": (".kernels._codegen", None),
    "plan_blt": (".plan._blt", None),
    "gait_metrics": (".gait._metrics", None),
    "gait_walker": (".gait._walker", None),
    "kernels_batch": (".kernels._batch", None),
    "dumps_toml": (".study._spec", "dumps_toml"),
    "analysis_metrics": (".analysis._metrics", None),
    "BLOCK": (".study._sample", "BLOCK"),
    "Sampler": (".study._sample", "Sampler"),
    "store_integrity": (".store._integrity", None),
    "cli_report": (".cli._report", None),
    "view_report": (".view._report", None),
    "cli_describe": (".cli._describe", "describe"),
    "kernels_sweep": (".kernels._sweep", None),
    "kernels_sweep_template": (".kernels._sweep_template", None),
    "kernels_sweep_array": (".kernels._sweep_array", None),
    "study_yield": (".study._yield", None),
    "kernels_render": (".kernels._render", None),
    "BLOCK_DTYPE": (".kernels._inputs", "BLOCK_DTYPE"),
    "kernels_batch_array": (".kernels._batch_array", None),
    "kernels_forces": (".kernels._forces", None),
}

__all__ = list(_HOMES)


def __getattr__(name: str):
    try:
        module, attr = _HOMES[name]
    except KeyError:
        raise AttributeError(f"explorer.testing has no {name!r} (add it to _HOMES)") from None
    mod = importlib.import_module(module, __package__)
    value = mod if attr is None else getattr(mod, attr)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_HOMES))
