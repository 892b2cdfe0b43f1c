"""Studies: a study file (TOML) → sampled variants → chunked batch solves streamed to HDF5.

``load_study(path_or_dict)`` validates a study; ``sample_variants`` / ``Sampler`` generate its
variants; ``run_study(study, output=..., resume=..., force=...)`` is what ``explorer run`` calls;
``client=`` (a ``dask.distributed.Client``) runs a study on a Dask cluster, one HDF5 shard per task
(``run_study_dask(client, study)`` is the same call). A study's ``[optimize]`` table (:class:`Optimize`)
is part of the study; the search itself, ``run_optimize``, is :mod:`explorer.optimize`'s (its names are
still importable from here for one release). Module graph: ``_run`` → ``_dask`` →
``_cluster``/``_output``; no runner imports another's private names;
``design_yield`` gives the ``yield`` of designs: the share of copies cut with a ``[robustness]`` error
that still walk (a running study computes it as a metric). What a results file says once written
(sensitivity, tolerance, the yield of stored designs, recomputed metrics) is :mod:`explorer.analysis`'s;
its names are still importable from here for one release (:mod:`explorer._moved`), as are the curve
atlas, the path polish and ``synthesize``, now :mod:`explorer.synthesis`'s.
:mod:`explorer.study.runner` is the chunk runner's door for the rooms above study that solve designs of
their own (the optimiser, synthesis): the solver, an optimiser's designs, the Dask plumbing, the output
checks. ``open_results`` opens a results file with explorer's re-solver (``resolve_series``, :data:`RESOLVER`,
registered with :mod:`explorer.store` on import): store reads and writes files only, the solving is study's.
"""

from ._cluster import dask_client, require_dask
from ._dask import run_study_dask
from ._objectives import ALGORITHMS, Optimize, optimize_from_dict
from ._resolve import RESOLVER, open_results, resolve_series
from ._run import RunSummary, Terminated, run_study
from ._sample import (BLOCK, Sampler, apply_multipliers, apply_samples, saltelli_design, sample_variants,
                      study_sampler, study_variants)
from ._spec import (MAX_VARIANTS, STUDY_KEYS, PERTURB_METHODS, SAMPLED_METHODS, SOLVE_METHODS, Output, Perturb, Scene,
                    Solver, Study, builtin_studies,
                    default_study_text, dumps_toml, load_study, study_from_dict, variant_count)
from ._yield import DEFAULT_COPIES, Robustness, YieldResult, design_yield, robustness_from_dict, split_parameters
from .._moved import moved

#: names that moved to explorer.analysis, explorer.synthesis and explorer.optimize (issue 40's rooms),
#: importable from here for one release
__getattr__ = moved(__name__, dict.fromkeys(
    ("INDEX_METHODS", "INDEX_NAMES", "PARAMETER_SETS", "PARAMETER_WORDS", "ToleranceResult", "main_index",
     "recompute_metrics", "results_robustness", "results_yield", "sensitivity", "sensitivity_frame",
     "summary_frame", "tolerance", "tolerance_summary"), "explorer.analysis")
    | dict.fromkeys(("HYPERVOLUME_REFERENCE", "Hypervolume", "OptimizeSummary", "best_design", "feasible_mask",
                     "final_front", "front_history", "hypervolume_history", "hypervolume_per_generation",
                     "objective_matrix", "optimization_of", "run_optimize"), "explorer.optimize")
    | dict.fromkeys(("ATLAS_FAMILIES", "Atlas", "AtlasSpec", "BatchedLMResult", "ConstrainedResiduals", "PathResiduals",
                     "PolishResult", "SynthSummary", "atlas_dir", "atlas_spec", "batched_lm", "build_atlas",
                     "distinct_best", "multistart", "open_atlas", "polish", "polish_constrained", "scout_and_polish",
                     "synthesize"), "explorer.synthesis"))

__all__ = ["STUDY_KEYS", "dask_client", "require_dask", "ALGORITHMS", "Optimize", "optimize_from_dict", "Terminated", "BLOCK", "MAX_VARIANTS", "PERTURB_METHODS", "SAMPLED_METHODS", "SOLVE_METHODS",
           "RunSummary", "Sampler", "Study", "apply_multipliers", "apply_samples", "builtin_studies",
           "default_study_text", "dumps_toml", "load_study", "run_study", "run_study_dask",
           "saltelli_design", "sample_variants", "study_from_dict", "study_sampler",
           "study_variants", "variant_count",
           "Robustness", "YieldResult", "design_yield", "robustness_from_dict"]
__all__ += ["DEFAULT_COPIES", "split_parameters", "Output", "Perturb", "Scene", "Solver", "RESOLVER", "open_results",
            "resolve_series"]
