"""Optimisation: search a study's design parameters for the best designs.

``run_optimize(study, output=...)`` is what ``explorer optimize`` calls: a pymoo search over a study's
``[optimize]`` parameters (the table itself is part of the study: :class:`explorer.study.Optimize`),
one batch solve per generation through the study's chunk runner (:mod:`explorer.study.runner`), into
an ordinary results file with a ``generation`` column; ``client=`` (a ``dask.distributed.Client``)
splits each generation over the workers. ``objective_matrix`` / ``feasible_mask`` score evaluated
designs as the search does; ``final_front``, ``front_history`` and ``optimization_of`` read a finished
run back; ``hypervolume_per_generation`` / ``hypervolume_history`` measure its fronts; ``best_design``
is the one rule that picks an optimisation's best design. A path-synthesis search (one objective,
``path_error``) starts from the curve atlas's designs and is polished by least squares on the path
residuals (both :mod:`explorer.synthesis`'s), a several-objective front by SLSQP (the front polish here),
each committed as one more generation.

Module graph: ``_optimize`` → ``_front_polish``, ``_hypervolume`` → ``_objectives``; every module
imports :mod:`explorer.study` (and its runner door) and :mod:`explorer.synthesis` by their faces, never
their private modules.
"""

from ._best import best_design
from ._hypervolume import REFERENCE as HYPERVOLUME_REFERENCE, Hypervolume, hypervolume_history, hypervolume_per_generation
from ._objectives import INFEASIBLE_VALUE, feasible_mask, objective_matrix
from ._optimize import OptimizeSummary, final_front, front_history, optimization_of, run_optimize

__all__ = ["HYPERVOLUME_REFERENCE", "INFEASIBLE_VALUE", "Hypervolume", "OptimizeSummary", "best_design",
           "feasible_mask", "final_front", "front_history", "hypervolume_history", "hypervolume_per_generation",
           "objective_matrix", "optimization_of", "run_optimize"]
