"""The one table formatter of the CLI: aligned plain-text columns (two spaces between them, trailing
spaces dropped), over rows of strings (:func:`table`), a DataFrame's columns (:func:`frame_table`) or
a table of string cells with some columns left-aligned (:func:`aligned`); and the JSON records of a
frame that ``--format json`` prints."""

from __future__ import annotations

import json
import math


def table(rows, right) -> list[str]:
    """Lines of ``rows`` (sequences of strings, the header first), each column as wide as its widest
    cell, right-aligned where ``right[j]``."""
    rows = [list(r) for r in rows]
    if not rows:
        return []
    widths = [max(len(r[j]) for r in rows) for j in range(len(rows[0]))]
    return ["  ".join(c.rjust(w) if rj else c.ljust(w) for c, w, rj in zip(r, widths, right)).rstrip()
            for r in rows]


def format_floats(values, sig: int = 5) -> list[str]:
    """Strings for one column of floats: a common number of decimals giving ``sig`` significant digits
    to the largest magnitude (scientific notation for very small or large columns); NaN → "-"."""
    finite = [abs(v) for v in values if v is not None and math.isfinite(v)]
    big = max(finite) if finite else 0.0
    if big and (big < 1e-4 or big >= 1e9):
        return ["-" if v is None or not math.isfinite(v) else f"{v:.{sig - 1}e}" for v in values]
    dec = 0 if big == 0 else min(8, max(0, sig - 1 - math.floor(math.log10(big))))
    return ["-" if v is None or not math.isfinite(v) else f"{v:.{dec}f}" for v in values]


def format_column(series) -> tuple[list[str], bool]:
    """(cells, right-aligned) for one frame column."""
    import pandas as pd
    if pd.api.types.is_bool_dtype(series):
        return [str(bool(v)).lower() for v in series], False
    if pd.api.types.is_integer_dtype(series):
        return [f"{int(v)}" for v in series], True
    if pd.api.types.is_float_dtype(series):
        return format_floats([float(v) for v in series]), True
    return ["-" if v is None or (isinstance(v, float) and math.isnan(v)) else str(v).replace(" ", "_")
            for v in series.astype(object)], False


def frame_table(df, columns: list[str], right=()) -> str:
    """An aligned plain-text table of ``columns`` of ``df`` (no spaces in cells; numbers right-aligned, and
    the columns named in ``right`` whatever they hold)."""
    cols = [format_column(df[c]) for c in columns]
    rows = [list(columns)] + [[cells[i] for cells, _ in cols] for i in range(len(df))]
    return "\n".join(table(rows, [r or c in right for (_, r), c in zip(cols, columns)]))


def aligned(frame, columns, left=()) -> str:
    """A plain-text table of string (or number) cells: the ``left`` columns left-aligned, the others
    (numbers) right-aligned under right-aligned headers."""
    cells = {c: [str(v) for v in frame[c]] for c in columns}
    rows = [list(columns)] + [[cells[c][i] for c in columns] for i in range(len(frame))]
    return "\n".join(table(rows, [c not in left for c in columns]))


def json_records(df) -> str:
    """The rows of ``df`` as a JSON list of objects; NaN → null, exact float repr."""
    import numpy as np
    import pandas as pd
    cols = list(df.columns)
    data = []
    arrays = []
    for c in cols:
        s = df[c]
        if isinstance(s.dtype, pd.CategoricalDtype):
            s = s.astype(object)
        arrays.append(s.to_numpy(dtype=object))
    for i in range(len(df)):
        row = {}
        for c, a in zip(cols, arrays):
            v = a[i]
            if isinstance(v, (np.integer,)):
                v = int(v)
            elif isinstance(v, (float, np.floating)):
                v = None if not math.isfinite(float(v)) else float(v)
            elif isinstance(v, np.bool_):
                v = bool(v)
            elif v is not None and not isinstance(v, (str, int, bool)):
                v = str(v)
            row[str(c)] = v
        data.append(row)
    return json.dumps(data, indent=1, allow_nan=False)


def better(direction: str) -> str:
    """The words for a ranking direction ("max" or "min")."""
    return "higher is better" if direction == "max" else "lower is better"


# -- physical units (--units si): the figures of show, rank and report ------------------------------------
def add_units_argument(p) -> None:
    """The ``--units model|si`` option (:func:`explorer.cli._args.add_units`, the vocabulary's home)."""
    from ._args import add_units
    add_units(p)


def results_si(res, frame, units: str):
    """:func:`explorer.gait.results_si`: ``frame`` in SI units for ``--units si``, else None."""
    from ..gait import results_si as convert
    return convert(res, frame, units)
