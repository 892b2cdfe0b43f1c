"""Gait analysis: metrics of every variant's foot path (Numba, in batch), the buildability screen, and
ranking in pandas.

``compute_metrics(paths, velocities, status, names, band, mechanism=..., walker=...)`` returns one (N,)
array per metric; :data:`TABLE` is the one table of metrics (name, unit, direction, definition);
``rank(df, by=..., where=..., weights=..., pareto=...)`` ranks a results frame with one row per
variant; ``pareto_front(df, cols, directions)`` is the non-dominated mask. The exact definitions are
in :mod:`explorer.gait._walker` (the walker scene) and :mod:`explorer.gait._metrics` (single leg).
"""

from ._filter import FilterError, evaluate_filter, filter_columns, filter_margins, parse_filter
from ._metrics import DEFAULT_BAND, available_metrics, check_band, compute_metrics, foot_headroom, min_transmission_angle, stance_indices
from ._path import MATCHES, IGNORES, PHASES, TARGET_KEYS, Target, load_target, path_at, path_error, path_match, path_residuals
from ._rank import default_weights, ok_mask, pareto_front, rank, rank_order, screened_mask, select
from ._screen import CHECKS, SCREEN_INPUTS, SCREEN_KEYS, Check, Screen, screen_columns, screen_counts, screen_from_dict, screen_margins
from ._table import (DEFAULT_WEIGHTS, BAND_METRICS, FORCE_METRICS, PHYSICS_METRICS, ROBUSTNESS_METRICS, PIN_FORCE, metric, BY_NAME, DESCRIPTIONS, DIRECTIONS, FOOT_METRICS, LEG_METRICS, MECHANISM_METRICS,
                     METRICS, PATH_METRICS, SCREEN_METRICS, TABLE, TARGET_METRICS, UNITS, VELOCITY_METRICS, WALKER_METRICS, Metric)
from ._units import (CONVERSIONS, SI, SPEED, UNIT_SYSTEMS, change_pct, operating_line, results_si, si_label, si_operating,
                     to_si, verdict)
from ._walker import leg_samples
from ._warm import start_kernel_warmup, stop_kernel_warmup

__all__ = ["default_weights", "FORCE_METRICS", "PHYSICS_METRICS", "ROBUSTNESS_METRICS", "PIN_FORCE", "metric", "MATCHES", "IGNORES", "PHASES", "TARGET_KEYS", "TARGET_METRICS", "Target", "load_target", "path_at", "path_error", "path_match", "path_residuals", "FilterError", "evaluate_filter", "filter_columns", "filter_margins", "parse_filter", "DEFAULT_WEIGHTS", "CHECKS", "Check", "SCREEN_INPUTS", "SCREEN_KEYS", "Screen", "screen_columns", "screen_counts", "screen_from_dict", "screen_margins", "BAND_METRICS", "BY_NAME", "DEFAULT_BAND", "DESCRIPTIONS", "DIRECTIONS", "FOOT_METRICS", "LEG_METRICS",
           "MECHANISM_METRICS", "METRICS", "Metric", "PATH_METRICS", "SCREEN_METRICS", "TABLE", "UNITS",
           "VELOCITY_METRICS", "WALKER_METRICS", "available_metrics", "check_band", "compute_metrics", "foot_headroom", "leg_samples",
           "min_transmission_angle", "ok_mask", "screened_mask", "pareto_front", "rank", "rank_order", "select", "stance_indices",
           "start_kernel_warmup", "stop_kernel_warmup"]
__all__ += ["CONVERSIONS", "SI", "SPEED", "UNIT_SYSTEMS", "change_pct", "operating_line", "results_si", "si_label",
            "si_operating", "to_si", "verdict"]
