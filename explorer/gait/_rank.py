"""Ranking a results frame (one row per variant) by one metric, a weighted score, or a Pareto front.

The frame has a ``variant`` column (optional), one column per metric, and a ``status`` column
("ok" or a failure name; integer 0 also counts as ok; no column = every row ok). Each metric has a
natural direction (:data:`DIRECTIONS`): "max" = larger is better, "min" = smaller is better.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from ..errors import UserError
from ._filter import evaluate_filter
from ._table import DEFAULT_WEIGHTS, DIRECTIONS, METRICS, metric

if TYPE_CHECKING:  # pandas is imported where it is used: it costs ~0.4 s, and `explorer run` never needs it
    import pandas as pd

_RESERVED = ("variant", "status", "rank", "score", "buildable", "screen")
#: Frame columns that are no metric but have a natural direction: the Newton iterations a variant's
#: solve took (fewer: a design the solver passes through easily; what a path-driven arm ranks by).
COLUMN_DIRECTIONS = {"iterations": "min"}


# -- helpers ------------------------------------------------------------------------------------------
def _rankable(df: pd.DataFrame) -> list[str]:
    """Numeric columns that can be ranked on (metrics first, in METRICS order)."""
    import pandas as pd

    numeric = [c for c in df.columns if c not in _RESERVED and pd.api.types.is_numeric_dtype(df[c])
               and not pd.api.types.is_bool_dtype(df[c])]
    return [m for m in METRICS if m in numeric] + [c for c in numeric if c not in METRICS]


def _check_columns(df: pd.DataFrame, cols) -> list[str]:
    known = _rankable(df)
    out = []
    for c in cols:
        c = str(c)
        if c not in known:
            if c in METRICS:
                raise UserError(f"metric {c!r} was not computed for these results "
                                f"(known: {', '.join(known) or 'none'})")
            raise UserError(f"unknown metric {c!r} (known: {', '.join(known) or 'none'})")
        out.append(c)
    return out


def _direction(col: str, override) -> str:
    """'max' or 'min' for ``col``: the override (bool ascending / "max" / "min") or the natural one."""
    if override is not None:
        if isinstance(override, str):
            if override not in ("max", "min"):
                raise UserError(f"direction of {col!r}: expected 'max' or 'min', got {override!r}")
            return override
        return "min" if bool(override) else "max"
    if col in DIRECTIONS:
        return DIRECTIONS[col]
    if metric(col) is not None:  # pin_force.<joint>
        return metric(col).direction
    if col in COLUMN_DIRECTIONS:
        return COLUMN_DIRECTIONS[col]
    raise UserError(f"{col!r} has no natural direction: say which is better, --ascending (smaller first) or "
                    f"--descending (larger first); in Python rank(..., ascending=True or False)")


def _directions(cols: list[str], ascending) -> dict[str, str]:
    if ascending is None or isinstance(ascending, Mapping):
        over = dict(ascending or {})
        bad = [k for k in over if k not in cols]
        if bad:
            raise UserError(f"ascending: {bad[0]!r} is not one of the ranked metrics ({', '.join(cols)})")
        return {c: _direction(c, over.get(c)) for c in cols}
    raise UserError("ascending: with weights= or pareto= pass a dict metric -> True/False "
                    "(True: smaller is better)")


def ok_mask(df: pd.DataFrame) -> np.ndarray:
    """Boolean mask of the rows whose ``status`` is ok (name "ok" or code 0); all rows if there is no status."""
    import pandas as pd

    if "status" not in df.columns:
        return np.ones(len(df), dtype=bool)
    st = df["status"]
    if pd.api.types.is_numeric_dtype(st):
        return (st == 0).to_numpy()
    return (st.astype(str) == "ok").to_numpy()


def screened_mask(df: pd.DataFrame) -> np.ndarray:
    """Boolean mask of the ok rows the buildability screen removes (the frame's ``buildable`` column;
    none if the frame has no such column)."""
    if "buildable" not in df.columns:
        return np.zeros(len(df), dtype=bool)
    return ok_mask(df) & ~df["buildable"].to_numpy(dtype=bool)


def select(df: pd.DataFrame, where=None, include_failed: bool = False, include_screened: bool = False) -> pd.DataFrame:
    """The rows that are ok (unless ``include_failed``), pass the buildability screen (unless
    ``include_screened``; only frames with a ``buildable`` column are screened) and satisfy the
    filter ``where`` (e.g. "bob < 0.5 and slip < 0.05", in the restricted grammar of
    :mod:`explorer.gait._filter`: never executed as Python); a bad filter is a UserError naming it."""
    keep = np.ones(len(df), dtype=bool) if include_failed else ok_mask(df).copy()
    if not include_screened:
        keep &= ~screened_mask(df)
    # every row kept: a shallow copy (no data copied: a million-row frame is not duplicated; pandas' copy on
    # write keeps the caller's frame as it is)
    df = df[keep] if not keep.all() else df.copy(deep=False)
    if where is not None and str(where).strip():
        df = df[evaluate_filter(df, str(where))]
    return df


def default_weights(columns) -> tuple[dict[str, float], list[str]]:
    """The default score (:data:`DEFAULT_WEIGHTS`) over the metrics ``columns`` holds: (its weights
    restricted to them, the default metrics missing, which it ranks without). An optimisation stores
    only its objectives, constraints and the screen's inputs, so a results file may hold some of them.
    UserError if it holds none."""
    have = set(map(str, columns))
    weights = {m: w for m, w in DEFAULT_WEIGHTS.items() if m in have}
    missing = [m for m in DEFAULT_WEIGHTS if m not in have]
    if not weights:
        raise UserError(f"the default ranking needs the walker metrics {', '.join(missing)}, which these results "
                        f"do not have; rank by=METRIC (for example by='stride') or compute them")
    return weights, missing


def _check_top(top):
    """None or 0 (every row, as ``--top 0`` on the command line), else a row count >= 1."""
    if top is None:
        return None
    if isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 0:
        raise UserError(f"top: expected a whole number >= 0 (0 or None: every row), got {top!r}")
    return int(top) or None


def _tiebreak(df: pd.DataFrame) -> np.ndarray:
    """Secondary sort key: the variant number if there is one, else the row position."""
    import pandas as pd

    if "variant" in df.columns and pd.api.types.is_numeric_dtype(df["variant"]):
        return df["variant"].to_numpy()
    return np.arange(len(df))


def _costs(df: pd.DataFrame, cols: list[str], directions: dict[str, str]) -> np.ndarray:
    """(n, k) float array where smaller is better in every column."""
    cost = np.empty((len(df), len(cols)), dtype=np.float64)
    for j, c in enumerate(cols):
        v = df[c].to_numpy(dtype=np.float64, na_value=np.nan)
        cost[:, j] = -v if directions[c] == "max" else v
    return cost


def _finish(df: pd.DataFrame, order: np.ndarray, score: np.ndarray | None = None, top=None) -> pd.DataFrame:
    """The rows ``order`` (positions in ``df``) of ``df``, the first ``top`` only, with ``rank`` first (and
    ``score``, one value per row of ``df``, last)."""
    if top is not None:
        order = order[:top]  # only the rows returned are copied
    out = df.take(order)  # a new frame, copied once (not df.iloc[order].copy(): twice at its peak)
    out.insert(0, "rank", np.arange(1, len(out) + 1, dtype=np.int64))
    if score is not None:
        out["score"] = score[order]
    return out


#: Rows scored at a time by :func:`_score` (its temporaries stay small on a million-row frame).
SCORE_ROWS = 1 << 16


def _score(df: pd.DataFrame, cols: list[str], directions: dict[str, str], w: np.ndarray) -> np.ndarray:
    """The weighted score (n,) of ``df``'s rows over ``cols`` with weights (k,): each column's cost (smaller
    is better, :func:`_costs`) min-max normalised over the rows (1 = best; a constant column gives 1), Σ w s /
    Σ w; NaN where a cost is. Row by row arithmetic on the costs of :data:`SCORE_ROWS` rows at a time (the
    same bits as all rows at once; no (n, k) array of every cost: its memory on a million-row frame)."""
    n = len(df)
    score = np.empty(n, dtype=np.float64)
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN column
        if n:  # each column's least and greatest cost, NaN for an all-NaN column (as nanmin over every row)
            lo = hi = np.full(len(cols), np.nan)
            for a in range(0, n, SCORE_ROWS):
                c = _costs(df.iloc[a:a + SCORE_ROWS], cols, directions)
                lo, hi = np.fmin(lo, np.nanmin(c, axis=0)), np.fmax(hi, np.nanmax(c, axis=0))
        else:
            lo = hi = np.zeros(len(cols))
        span = hi - lo
        for a in range(0, n, SCORE_ROWS):
            c = _costs(df.iloc[a:a + SCORE_ROWS], cols, directions)
            s = np.where(span > 0, (hi - c) / np.where(span > 0, span, 1.0), 1.0)
            s[np.isnan(c)] = np.nan
            part = (s * w).sum(axis=1) / w.sum()
            part[np.isnan(s).any(axis=1)] = np.nan
            score[a:a + SCORE_ROWS] = part
    return score


# -- public --------------------------------------------------------------------------------------------
def pareto_front(df: pd.DataFrame, cols, directions=None) -> np.ndarray:
    """Boolean mask (len(df),) of the rows no other row dominates on ``cols``.

    cols : metric names (a list, or one comma-separated string).
    directions : None (natural, :data:`DIRECTIONS`), a dict col -> "max"/"min" (columns it leaves
    out keep their natural direction; extra keys are ignored, so DIRECTIONS itself can be passed),
    or a sequence of "max"/"min" aligned with ``cols``. Row a dominates row b when a is at least as good in every
    column and strictly better in one; equal rows do not dominate each other (both stay). Rows with
    NaN in any of ``cols`` are never on the front and dominate nothing.
    """
    names = [c.strip() for c in cols.split(",") if c.strip()] if isinstance(cols, str) else list(cols)
    cols = _check_columns(df, names)
    if not cols:
        raise UserError("pareto: name at least one metric")
    if directions is None:
        dirs = {c: _direction(c, None) for c in cols}
    elif isinstance(directions, Mapping):
        dirs = {c: _direction(c, directions.get(c)) for c in cols}
    else:
        directions = list(directions)
        if len(directions) != len(cols):
            raise UserError(f"pareto: {len(directions)} directions for {len(cols)} metrics")
        dirs = {c: _direction(c, d) for c, d in zip(cols, directions)}
    cost = _costs(df, cols, dirs)
    mask = np.zeros(len(df), dtype=bool)
    valid = np.flatnonzero(~np.isnan(cost).any(axis=1))
    if valid.size == 0:
        return mask
    c = cost[valid]
    # lexicographic order: a row can only be dominated by one before it, and the first is on the front
    order = np.lexsort(c.T[::-1])
    c = c[order]
    idx = valid[order]
    # the first remaining row in lexicographic order is never dominated by a remaining row: take it,
    # drop every row it dominates (<= everywhere and < somewhere), repeat on what is left
    front = []
    while len(c):
        p, c, idx_rest = c[0], c[1:], idx[1:]
        front.append(idx[0])
        dominated = (p <= c).all(axis=1) & (p < c).any(axis=1)
        c, idx = c[~dominated], idx_rest[~dominated]
    mask[np.array(front, dtype=np.int64)] = True
    return mask


def rank(df: pd.DataFrame, by=None, top: int | None = 10, where: str | None = None, ascending=None,
         weights: Mapping[str, float] | None = None, pareto=None, include_failed: bool = False,
         include_screened: bool = False) -> pd.DataFrame:
    """Rank the variants of a results frame; returns the chosen rows, best first, with a ``rank`` column.

    Rows are first filtered: failed variants (status not "ok") are dropped unless
    ``include_failed``, ok variants the buildability screen removes (``buildable`` false) unless
    ``include_screened``; then ``where``, a filter in the restricted grammar of :mod:`._filter` such as
    "duty > 0.3 and flatness < 0.002", keeps the rows where it is true (a bad expression raises
    UserError naming it). Then one of three modes, in this precedence:

    * ``pareto=["stride", "flatness"]`` (or "stride,flatness"): only the Pareto front
      (non-dominated rows) over those metrics, sorted by the first of them, best first (then the
      others, then variant).
      ``ascending`` may be a dict metric -> True/False (True: smaller is better) to override
      natural directions.
    * ``weights={"stride": 2, "flatness": 1}``: a ``score`` column in [0, 1], higher is better,
      Σ w_m s_m / Σ w_m where s_m is metric m min-max normalised over the filtered rows and
      flipped for "min" metrics so that 1 is the best row (a metric constant over those rows gives
      s_m = 1 to all). Weights must be ≥ 0 with a positive sum. ``ascending`` as for pareto.
    * ``by`` (a metric name): sorted in its natural direction, or smallest first if
      ``ascending=True``, largest first if ``ascending=False``.
    * none of them: the default ranking, the weighted score of :data:`DEFAULT_WEIGHTS` (travel,
      bob, body_speed_ripple, peak_torque and clearance, equal weights) over those of them the frame
      holds (:func:`default_weights`: an optimisation's results hold only some).

    NaN values of the sort key (a failed variant kept with include_failed, an undefined metric)
    come last. Ties keep variant order. ``top`` rows are returned (0 or None: all, as ``--top 0``). ``rank`` is the
    1-based position, the first column; the frame's index is kept. Unknown metric names raise
    UserError listing the ones the frame has.
    """
    import pandas as pd

    if not isinstance(df, pd.DataFrame):
        raise UserError(f"rank: expected a pandas DataFrame, got {type(df).__name__}")
    top = _check_top(top)
    return _finish(*_ranking(df, by, where, ascending, weights, pareto, include_failed, include_screened), top=top)


def rank_order(df: pd.DataFrame, by=None, where: str | None = None, ascending=None,
               weights: Mapping[str, float] | None = None, pareto=None, include_failed: bool = False,
               include_screened: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """The ranking :func:`rank` gives (every row, ``top=None``; the same arguments) without its rows:
    (the index labels of the ranked rows, best first; their ``score`` where the ranking is a weighted score,
    else None). No ranked row is copied: on a million-row frame only these arrays are made."""
    import pandas as pd

    if not isinstance(df, pd.DataFrame):
        raise UserError(f"rank: expected a pandas DataFrame, got {type(df).__name__}")
    sub, order, score = _ranking(df, by, where, ascending, weights, pareto, include_failed, include_screened)
    return sub.index.to_numpy()[order], (None if score is None else score[order])


def _ranking(df, by, where, ascending, weights, pareto, include_failed, include_screened):
    """(the rows ranked: ``df`` filtered, or its Pareto front; their order, positions in them, best first;
    their scores in row order, or None): :func:`rank` before its rows are taken."""
    if by is None and weights is None and pareto is None:
        weights, _ = default_weights(df.columns)
    if pareto is not None and weights is not None:
        raise UserError("rank: pass either pareto= or weights=, not both")
    if pareto is not None:
        names = [c.strip() for c in pareto.split(",") if c.strip()] if isinstance(pareto, str) else list(pareto)
        cols = _check_columns(df, names)
        if not cols:
            raise UserError("pareto: name at least one metric")
        dirs = _directions(cols, ascending)
        sub = select(df, where, include_failed, include_screened)
        front = sub[pareto_front(sub, cols, dirs)]
        cost = _costs(front, cols, dirs)
        keys = [_tiebreak(front)] + [cost[:, j] for j in range(len(cols) - 1, -1, -1)]
        return front, np.lexsort(keys), None
    if weights is not None:
        if not isinstance(weights, Mapping) or not weights:
            raise UserError("weights: expected a non-empty dict metric -> weight")
        cols = _check_columns(df, list(weights))
        w = np.empty(len(cols))
        for j, c in enumerate(cols):
            try:
                w[j] = float(weights[c])
            except (TypeError, ValueError):
                raise UserError(f"weights: {c!r}: expected a number, got {weights[c]!r}") from None
        if not np.isfinite(w).all() or (w < 0).any() or w.sum() <= 0:
            raise UserError(f"weights: expected finite weights >= 0 with a positive sum, got {dict(weights)!r}")
        dirs = _directions(cols, ascending)
        used = w > 0  # a zero weight neither counts nor turns a row's score NaN
        cols, w = [c for c, u in zip(cols, used) if u], w[used]
        sub = select(df, where, include_failed, include_screened)
        score = _score(sub, cols, dirs, w)
        key = np.where(np.isnan(score), np.inf, -score)
        return sub, np.lexsort([_tiebreak(sub), key]), score
    # one metric
    if isinstance(ascending, Mapping):
        raise UserError("ascending: with by= pass True/False (or None for the natural direction)")
    (col,) = _check_columns(df, [by])
    d = _direction(col, ascending)
    sub = select(df, where, include_failed, include_screened)
    cost = _costs(sub, [col], {col: d})[:, 0]
    key = np.where(np.isnan(cost), np.inf, cost)
    return sub, np.lexsort([_tiebreak(sub), np.isnan(cost), key]), None
