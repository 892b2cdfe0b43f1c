"""Studies: a study file (TOML) → sampled variants → chunked batch solves streamed to HDF5.

``load_study(path_or_dict)`` validates a study; ``sample_variants`` / ``Sampler`` generate its
variants; ``run_study(study, output=..., resume=..., force=...)`` is what ``explorer run`` calls;
``run_study_dask(client, study, ...)`` runs it on a Dask cluster, one HDF5 shard per task;
``recompute_metrics(path, band=...)`` redoes the gait metrics of a results file without re-solving.
"""

from ._dask import run_study_dask
from ._metrics import recompute_metrics
from ._run import RunSummary, Terminated, run_study
from ._sample import BLOCK, Sampler, apply_multipliers, apply_samples, sample_variants, study_sampler, study_variants
from ._spec import (MAX_VARIANTS, PERTURB_METHODS, SOLVE_METHODS, Study, builtin_studies, default_study_text,
                    dumps_toml, load_study, study_from_dict, variant_count)

__all__ = ["Terminated", "BLOCK", "MAX_VARIANTS", "PERTURB_METHODS", "SOLVE_METHODS", "RunSummary", "Sampler", "Study",
           "apply_multipliers", "apply_samples", "builtin_studies", "default_study_text", "dumps_toml", "load_study",
           "recompute_metrics", "run_study", "run_study_dask", "sample_variants", "study_from_dict", "study_sampler",
           "study_variants", "variant_count"]
