"""A results file's frame read in blocks of rows: ranking, filtering, the screen's counts, metric ranks and
single rows of a million-design file without holding its whole frame (issue 39, "lean reads that stay lean").

:meth:`Results.frame` stays the pandas surface for users (every row at once); the readers here take
:data:`READ_BLOCK` rows of it at a time (``frame(rows=(a, b))``), keep of each block only the rows and columns
they need, and give the answer the whole frame gives: the same rows, columns, order and values (the tests
check them against :func:`explorer.gait.rank` on the whole frame, with the block size patched small).

Memory: a block is ~``READ_BLOCK`` × (columns) × 8 bytes (~6 MB for a Jansen study with every metric); a
ranking keeps the ranked columns of the rows that pass the filters (``variant`` + the ranked metrics, 8 bytes
each per row); the rows shown are read again, whole, by themselves (:func:`frame_rows`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Iterator

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

#: Rows of the frame read at a time by the blocked readers (a block of a Jansen study with every metric:
#: ~16,384 × 45 columns × 8 bytes ≈ 6 MB, ~20 MB at its peak while it is built).
READ_BLOCK = 1 << 14


def blocks(results, size: int | None = None) -> Iterator[pd.DataFrame]:
    """``results.frame(rows=(a, b))`` for consecutive blocks of ``size`` rows (default :data:`READ_BLOCK`)
    covering every variant, in variant order; each block's index is its variant numbers, its columns typed
    as the whole frame's (:func:`as_whole`)."""
    n = int(results.n_variants)
    size = max(1, int(READ_BLOCK if size is None else size))
    for a in range(0, n, size):
        yield as_whole(results, results.frame(rows=(a, min(a + size, n))))


def as_whole(results, df: pd.DataFrame) -> pd.DataFrame:
    """``df`` (some rows of ``results.frame()``) with its text columns typed as the whole frame types them.

    pandas infers a column's type from its values: a text column (``fail_vertex``, ``grashof``, ``screen``)
    of the whole frame is pandas' text dtype (``str`` in pandas 3, NaN where empty), but one whose rows read
    hold no text (``fail_vertex`` of ok rows only, or no rows at all) stays ``object`` (None where empty). The
    whole frame's ``fail_vertex`` holds text when any variant of the file failed at a vertex (``/fail_block``
    >= 0, one small integer per variant, read once); its other text columns hold text in every row."""
    import pandas as pd
    text = pd.Series(np.array(["x"], dtype=object)).dtype  # what a column of text reads as
    if text == np.dtype(object) or int(results.n_variants) == 0:
        return df
    cols = [c for c in df.columns if df[c].dtype == object]
    if "fail_vertex" in cols:
        if getattr(results, "_failed_at_vertex", None) is None:
            results._failed_at_vertex = bool((results.file["fail_block"][...] >= 0).any())
        if not results._failed_at_vertex:
            cols.remove("fail_vertex")
    if not cols:
        return df
    return df.astype({c: text for c in cols})


def frame_rows(results, variants, columns=None) -> pd.DataFrame:
    """The rows of ``results.frame()`` of ``variants`` (any sequence of variant numbers, any order, repeats
    allowed), in that order, indexed by variant: the same columns, dtypes and values as those rows of the
    whole frame, read block by block (only the blocks that hold one of them, each from its first to its
    last wanted row). ``columns``: only these frame columns, in this order (default: every column); each
    block keeps only them, so many rows cost the memory of those columns (numbers and flags only: written
    in place, block after block, with no blocks joined at the end)."""
    import pandas as pd
    idx = np.asarray(variants, dtype=np.int64).reshape(-1)
    uniq = np.unique(idx)
    size = READ_BLOCK
    parts = []
    held = None  # {column: (len(uniq),) array} where every column asked for is a number or a flag
    i = 0
    while i < len(uniq):
        a = int(uniq[i])
        j = int(np.searchsorted(uniq, a + size, side="left"))  # the wanted rows in [a, a + size)
        b = int(uniq[j - 1]) + 1
        part = results.frame(rows=(a, b))
        if columns is not None:
            part = part[list(columns)]
            if held is None and i == 0 and all(part[c].dtype.kind in "biuf" for c in part.columns):
                held = {c: np.empty(len(uniq), dtype=part[c].dtype) for c in part.columns}
        if held is not None:
            for c in part.columns:
                held[c][i:j] = part[c].to_numpy()[uniq[i:j] - a]
        else:
            parts.append(part if b - a == j - i else part.loc[uniq[i:j]])
        i = j
        del part
    if held is not None:
        df = pd.DataFrame(held, index=pd.Index(uniq, dtype=np.int64), copy=False)
        del held
        return df if len(uniq) == len(idx) and np.array_equal(uniq, idx) else df.loc[idx]
    if not parts:
        empty = results.frame(rows=(0, 0))
        return as_whole(results, empty if columns is None else empty[list(columns)])
    df = as_whole(results, parts[0] if len(parts) == 1 else pd.concat(parts))
    del parts
    return df if len(uniq) == len(idx) and np.array_equal(uniq, idx) else df.loc[idx]


def _add_counts(total: dict | None, part: dict) -> dict:
    """Two :func:`explorer.gait.screen_counts` answers of disjoint rows, added."""
    if total is None:
        return {"removed": part["removed"], "checks": dict(part["checks"]), "applied": list(part["applied"])}
    total["removed"] += part["removed"]
    for k, v in part["checks"].items():
        total["checks"][k] = total["checks"].get(k, 0) + v
    return total


def screen_counts(results) -> dict:
    """:func:`explorer.gait.screen_counts` of the whole frame, summed block by block."""
    from ..gait import screen_counts as counts
    total = None
    screen = results.screen
    for df in blocks(results):
        total = _add_counts(total, counts(df, screen))
    return total if total is not None else counts(results.frame(rows=(0, 0)), screen)


def _ranked_names(head: pd.DataFrame, by, weights, pareto) -> list[str]:
    """The frame columns a ranking reads (validated by :func:`explorer.gait.rank` on ``head`` first)."""
    from ..gait import default_weights
    if pareto is not None:
        names = [c.strip() for c in pareto.split(",") if c.strip()] if isinstance(pareto, str) else list(pareto)
    elif weights is not None:
        names = list(weights)
    elif by is not None:
        names = [by]
    else:
        names = list(default_weights(head.columns)[0])
    return list(dict.fromkeys(str(c) for c in names))


def _head(results) -> pd.DataFrame:
    """The frame's first row (none for an empty file), typed as the whole frame: its columns, to check
    arguments against before any block is read."""
    return as_whole(results, results.frame(rows=(0, min(1, int(results.n_variants)))))


def _scan(results, head: pd.DataFrame, keep: list, where, include_failed: bool, include_screened: bool):
    """(the rows of the whole frame that :func:`explorer.gait.select` keeps, only the columns ``keep``,
    indexed by variant; the screen's counts of every ok variant), in one pass over the blocks."""
    import pandas as pd

    from ..gait import screen_counts as counts
    from ..gait import select
    parts, index, total, screen = {c: [] for c in keep}, [], None, results.screen
    for df in blocks(results):
        total = _add_counts(total, counts(df, screen))
        sub = select(df, where, include_failed, include_screened)
        index.append(sub.index.to_numpy().copy())
        for c in keep:  # each column by itself: no block of every column is kept
            parts[c].append(sub[c].to_numpy().copy() if sub[c].dtype.kind in "biuf" else sub[c].copy())
    results._screen_counts = total  # the summary of this pass, for Results.screen_summary
    df = sub = None  # the last block goes before the columns are joined
    if not index:
        return head[keep].iloc[:0], counts(head.iloc[:0], screen)
    out = {}
    for c in keep:  # joined one column at a time, its blocks let go as it is
        got = parts.pop(c)
        out[c] = np.concatenate(got) if isinstance(got[0], np.ndarray) else pd.concat(got, ignore_index=True)
        del got
    cols = {c: (v if isinstance(v, np.ndarray) else v.array) for c, v in out.items()}  # .array: keeps the dtype
    return pd.DataFrame(cols, index=pd.Index(np.concatenate(index), dtype=np.int64), copy=False), total


def _columns(head: pd.DataFrame, columns, first=("variant",)) -> list:
    """``first`` then ``columns`` (names of frame columns; None: every column), each once; UserError naming
    an unknown one."""
    names = list(head.columns) if columns is None else [str(c) for c in columns]
    wanted = list(dict.fromkeys([*first, *names]))
    unknown = [c for c in wanted if c not in head.columns]
    if unknown:
        from ..errors import UserError
        raise UserError(f"unknown column {unknown[0]!r} (columns: {', '.join(map(str, head.columns))})")
    return wanted


def select(results, where: str | None = None, include_failed: bool = False, include_screened: bool = False,
           columns=None) -> pd.DataFrame:
    """:func:`explorer.gait.select` of ``results.frame()`` (ok unless ``include_failed``, buildable unless
    ``include_screened``, then ``where``), read in blocks: the same rows, indexed by variant, with only
    ``columns`` (``variant`` first; default every column)."""
    from ..gait import select as select_frame
    head = _head(results)
    select_frame(head, where, include_failed, include_screened)  # the errors the whole frame gives, first
    keep = _columns(head, columns)
    return _scan(results, head, keep, where, include_failed, include_screened)[0]


def rank(results, by=None, top: int | None = 10, where: str | None = None, ascending=None, weights=None,
         pareto=None, include_failed: bool = False, include_screened: bool = False,
         columns=None) -> pd.DataFrame:
    """:func:`explorer.gait.rank` of ``results.frame()``, read in blocks: the same rows, in the same order,
    with the same ``rank`` (and ``score``) and the same columns, without the whole frame in memory.

    Each block is filtered as the whole frame would be (ok unless ``include_failed``, buildable unless
    ``include_screened``, then ``where``; each is a test of one row), and only ``variant`` and the ranked
    columns of the rows kept stay; :func:`explorer.gait.rank` ranks those (a score's min-max normalisation
    and the Pareto front see every kept row, as on the whole frame); then the ranked rows are read whole
    (:func:`frame_rows`). ``columns``: the frame columns to return after ``rank`` (``variant`` and the
    ranked ones are always there; default: every column, as :func:`explorer.gait.rank` returns them).

    Along the way the screen's counts of every ok variant are summed (what :meth:`Results.screen_summary`
    gives), and kept on ``results`` so that the summary costs no second pass."""
    from ..gait import rank as rank_frame
    head = _head(results)
    # every argument checked on the frame's columns: the errors the whole frame gives, before any block is read
    rank_frame(head, by=by, top=top, where=where, ascending=ascending, weights=weights, pareto=pareto,
               include_failed=include_failed, include_screened=include_screened)
    keep = _columns(head, _ranked_names(head, by, weights, pareto))
    slim = _scan(results, head, keep, where, include_failed, include_screened)[0]
    # the rows kept are already filtered: rank them all, as rank() ranks the rows its filters keep
    ranked = rank_frame(slim, by=by, top=top, ascending=ascending, weights=weights, pareto=pareto,
                        include_failed=True, include_screened=True)
    del slim
    variants = ranked["variant"].to_numpy()
    if columns is None:
        out = frame_rows(results, variants).copy()
    else:
        wanted = _columns(head, [c for c in columns if c not in ("rank", "score")], keep)
        out = ranked[wanted].copy() if set(wanted) <= set(ranked.columns) else frame_rows(results, variants)[wanted]
        out.index = ranked.index
    out.insert(0, "rank", ranked["rank"].to_numpy())
    if "score" in ranked.columns:
        out["score"] = ranked["score"].to_numpy()
    return out


def metric_ranks(results, variant: int, include_screened: bool = False) -> dict:
    """:func:`explorer.store._variants.metric_ranks` of the whole frame, counted block by block: {metric:
    (rank, pool) or None} of ``variant`` (checked already)."""
    from ..gait import metric, ok_mask, screened_mask
    row = frame_rows(results, [variant])
    names = list(getattr(results, "metric_names", ()))
    in_pool = bool(ok_mask(row)[0]) and (include_screened or not bool(screened_mask(row)[0]))
    value = {m: float(row[m].to_numpy(dtype=np.float64)[0]) for m in names}
    counted = [m for m in names if metric(m) is not None and in_pool and np.isfinite(value[m])]
    better = dict.fromkeys(counted, 0)
    pool = dict.fromkeys(counted, 0)
    if counted:
        for df in blocks(results):
            ok = ok_mask(df)
            if not include_screened:
                ok = ok & ~screened_mask(df)
            for m in counted:
                x = df[m].to_numpy(dtype=np.float64)
                inside = ok & np.isfinite(x)
                pool[m] += int(inside.sum())
                x = x[inside]
                better[m] += int(((x > value[m]) if metric(m).direction == "max" else (x < value[m])).sum())
    return {m: ((better[m] + 1, pool[m]) if m in better else None) for m in names}
