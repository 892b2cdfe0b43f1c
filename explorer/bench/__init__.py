"""Benchmarks a user can run: what accuracy costs in time (``explorer bench accuracy``).

``accuracy_sweep`` measures, over assembling variants of a mechanism, the wall time, mean Newton
iterations, foot-position error against the exact closed form at the same angles, and gait-metric
error against a fine closed-form reference, for every (method, steps, tolerance) cell, plus the seeds'
formulations and linear solvers as extra rows (:mod:`explorer.bench._seeds`). ``format_table``,
``write_csv`` and ``plot`` render its result.

``rotations_bench`` (``explorer bench rotations``) reproduces seed 004's orientation problem and what
each interpolation of a rotation costs (:mod:`explorer.bench._rotations`).
"""

from ._accuracy import (DEFAULT_STEPS, DEFAULT_TOLERANCES, AccuracyReport, accuracy_sweep, closed_form_reference,
                        format_table, plot, read_csv, write_csv)

from ._rotations import RotationsReport, rotations_bench, seed_facts, seed_rotation

__all__ = ["RotationsReport", "rotations_bench", "seed_facts", "seed_rotation", "DEFAULT_STEPS", "DEFAULT_TOLERANCES", "AccuracyReport", "accuracy_sweep", "closed_form_reference",
           "format_table", "plot", "read_csv", "write_csv"]
