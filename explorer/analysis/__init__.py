"""Analysis: what a study's results, or a design, say once they are solved.

``sensitivity(path)`` and ``tolerance_summary(path)`` say which dimensions matter (SALib's global
indices from the samples in a results file; ``sensitivity_frame(df, parameters)`` from any frame);
``tolerance(mechanism, target=0.99)`` finds the spread at which a share of the legs still walks, by
bisection over studies; ``results_yield(results, variants)`` / ``results_robustness(results)`` the
``yield`` of designs in a results file (a design's own yield, ``design_yield``, and the
``[robustness]`` table are :mod:`explorer.study`'s, since a running study computes it chunk by chunk);
``recompute_metrics(path, band=...)`` redoes the gait metrics of a results file without re-solving.

Module graph: every module here imports :mod:`explorer.study`, :mod:`explorer.store`,
:mod:`explorer.gait` and lower floors through their faces, and no module of this package imports another.
"""

from ._metrics import recompute_metrics
from ._sensitivity import (INDEX_METHODS, INDEX_NAMES, drivers, main_index, sensitivity, sensitivity_frame,
                           summary_frame, tolerance_summary)
from ._tolerance import PARAMETER_SETS, PARAMETER_WORDS, ToleranceResult, tolerance
from ._yield import parse_tolerance, results_robustness, results_yield

__all__ = ["INDEX_METHODS", "INDEX_NAMES", "PARAMETER_SETS", "PARAMETER_WORDS", "ToleranceResult", "drivers",
           "main_index", "parse_tolerance", "recompute_metrics", "results_robustness", "results_yield",
           "sensitivity", "sensitivity_frame", "summary_frame", "tolerance", "tolerance_summary"]
