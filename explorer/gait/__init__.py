"""Gait analysis: metrics of every variant's foot path (Numba, in batch) and ranking in pandas.

``compute_metrics(paths, velocities, status, names, band)`` returns one (N,) array per metric;
``rank(df, by=..., where=..., weights=..., pareto=...)`` ranks a results frame with one row per
variant; ``pareto_front(df, cols, directions)`` is the non-dominated mask. The exact metric
definitions are in :mod:`explorer.gait._metrics`.
"""

from ._metrics import (DEFAULT_BAND, DESCRIPTIONS, DIRECTIONS, FOOT_METRICS, MECHANISM_METRICS, METRICS,
                       PATH_METRICS, UNITS, VELOCITY_METRICS, compute_metrics, min_transmission_angle,
                       stance_indices)
from ._rank import ok_mask, pareto_front, rank, select

__all__ = ["DEFAULT_BAND", "DESCRIPTIONS", "DIRECTIONS", "FOOT_METRICS", "MECHANISM_METRICS", "METRICS",
           "PATH_METRICS", "UNITS", "VELOCITY_METRICS", "compute_metrics",
           "min_transmission_angle", "ok_mask", "pareto_front", "rank", "select", "stance_indices"]
