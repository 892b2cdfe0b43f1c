"""The chunk runner and a run's output, for the rooms above study that run designs of their own
(:mod:`explorer.optimize`, :mod:`explorer.synthesis`): one public door, so that no room reaches into
study's private modules (issue 40's rooms). A user running studies needs :mod:`explorer.study`'s face
only.

Solving designs
    :func:`design_solver` ``(study) → solve(lengths, crank, geometry) → (batch, metrics)``: what a
    sampled study's chunk and an optimiser's generation both run; :func:`geometry_columns` (the moved
    coordinates the kernels take) and :func:`metric_plan` (which metrics and series the scene asks for).
An optimiser's designs
    :func:`designs_from_x` (X (n, k) → lengths, crank, geometry), :func:`stored_x` (the searched
    parameters of a results frame), :func:`nominal_x` (the study's nominal design).
Dask
    :class:`Recipe` (a study as it travels to a worker), :func:`check_client`, :func:`one_thread`,
    :func:`warm_everywhere`, :func:`worker_threads`.
The output file
    :func:`results_path` and :func:`validate_study` (the checks every runner makes first),
    :func:`optimize_writer` (a new results file laid out by generation), :func:`writer_counts`
    (``{status: variants}`` of an open writer), :func:`results_state` (``"complete"``,
    ``"incomplete"``, ... of a file on disk, for the message that refuses to overwrite it).
"""

from ._chunk import design_solver, geometry_columns, metric_plan
from ._cluster import Recipe, check_client, one_thread, warm_everywhere, worker_threads
from ._designs import designs_from_x, nominal_x, stored_x
from ._output import _counts as writer_counts, _state as results_state, optimize_writer, results_path, validate_study

__all__ = ["design_solver", "geometry_columns", "metric_plan", "Recipe", "check_client", "one_thread",
           "warm_everywhere", "worker_threads", "designs_from_x", "nominal_x", "stored_x", "optimize_writer",
           "results_path", "results_state", "validate_study", "writer_counts"]
