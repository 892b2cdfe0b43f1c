"""One variant of a results file: its number checked, its frame row, its design parameters, its mechanism.

Functions over any results object (an open :class:`~explorer.store.Results`, or anything with
``frame()`` and ``path()``); :class:`~explorer.store.Results` has them as methods (``check_variant``,
``row``, ``design``, ``variant_mechanism``). Plots, exports and the CLI read a variant through these.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..errors import UserError

if TYPE_CHECKING:
    import pandas as pd

    from ..mechanism import Mechanism


def is_results(obj) -> bool:
    """True for a results object (``explorer.open_results``): it has ``frame()`` and ``path()``."""
    return callable(getattr(obj, "frame", None)) and callable(getattr(obj, "path", None))


def results_band(results) -> float:
    """The stance band of the results' study (``[scene] band``), else the results' ``band``, else the
    default 0.01."""
    for get in (lambda r: r.study["scene"]["band"], lambda r: r.band):
        try:
            b = float(get(results))
        except (AttributeError, KeyError, TypeError, ValueError):
            continue
        if 0.0 <= b <= 1.0:
            return b
    from ..gait import DEFAULT_BAND
    return DEFAULT_BAND


def n_variants(results, df: "pd.DataFrame | None" = None) -> int:
    """N of a results object (its ``n_variants``, else the length of ``df`` or of its frame)."""
    n = getattr(results, "n_variants", None)
    if n is None:
        n = len(df if df is not None else results.frame())
    return int(n)


def check_variant(results, variant) -> int:
    """``variant`` as an int in 0 … N−1 (UserError otherwise)."""
    n = n_variants(results)
    try:
        v = int(variant)
        if isinstance(variant, bool) or v != variant:
            raise ValueError
    except (TypeError, ValueError):
        raise UserError(f"variant: expected a whole number, got {variant!r}") from None
    if not 0 <= v < n:
        raise UserError(f"variant {v} out of range (this results file has variants 0 to {n - 1})")
    return v


def variant_row(results, variant: int, frame: "pd.DataFrame | None" = None) -> "pd.Series":
    """Row ``variant`` of the results' frame (``frame()``, or ``frame`` already read), as a Series
    indexed by column name."""
    if frame is None and callable(getattr(results, "frame_rows", None)):  # the row alone, not the whole frame
        return results.frame_rows([variant]).iloc[0]
    # the whole frame, as Results.frame() gives it (a one-row read types some cells differently: None
    # for NaN in an object column)
    df = results.frame() if frame is None else frame
    if "variant" in df.columns:
        rows = df[df["variant"] == variant]
        if len(rows):
            return rows.iloc[0]
    return df.iloc[variant]


def variant_design(results, variant, frame: "pd.DataFrame | None" = None) -> dict[str, float]:
    """{parameter name: value} of every design parameter of the results' mechanism
    (``mechanism.parameters()`` order: link lengths, the crank radius, ``crank.x``/``crank.y``, the
    ground pivots' and body joints' coordinates; model units): the variant's stored value where the
    file stores the parameter, else the nominal (the file's stored nominal, else the mechanism's).
    ``frame``: the results' frame already read."""
    v = check_variant(results, variant)
    row = variant_row(results, v, frame)
    nominal = getattr(results, "nominal", {}) or {}
    out = {}
    for name, mech_nominal in results.mechanism.parameters().items():
        out[name] = float(row[name]) if name in row.index else float(nominal.get(name, mech_nominal))
    return out


def metric_ranks(results, variant, frame: "pd.DataFrame | None" = None, include_screened: bool = False) -> dict:
    """{metric: (rank, pool) or None} for every stored metric (``metric_names``) of variant
    ``variant``: pool = the variants ``explorer rank`` ranks (ok, and passing the buildability screen
    unless ``include_screened``) with a finite value, rank = 1 + those strictly better in the
    metric's natural direction (ties share a rank); None when the variant is not in the pool (failed,
    not run, screened out, NaN) or the metric has no direction. ``frame``: the results' frame already
    read."""
    import numpy as np

    from ..gait import metric, ok_mask, screened_mask
    v = check_variant(results, variant)
    df = results.frame() if frame is None else frame
    ok = ok_mask(df)
    if not include_screened:
        ok = ok & ~screened_mask(df)
    out = {}
    for m in getattr(results, "metric_names", ()):
        info = metric(m)
        values = df[m].to_numpy(dtype=np.float64)
        pool = ok & np.isfinite(values)
        if info is None or not pool[v]:
            out[m] = None
            continue
        x = values[pool]
        better = (x > values[v]) if info.direction == "max" else (x < values[v])
        out[m] = (int(better.sum()) + 1, int(pool.sum()))
    return out


def variant_mechanism(results, variant) -> "Mechanism":
    """The mechanism of one variant of a results file: the nominal with every design parameter the
    variant's row holds (lengths, crank radius, and the coordinates the study moved: crank centre,
    ground pivots, body joints), through ``Mechanism.with_parameters``.

    Its guess is the nominal's configuration at θ = 0 (assembled by the file's resolver,
    :attr:`Results.resolver <explorer.store.Results.resolver>`), so it assembles on the nominal's branch, as
    the study's batch solve did.
    """
    from dataclasses import replace

    v = check_variant(results, variant)
    nominal = results.mechanism
    row = variant_row(results, v)
    values = {name: float(row[name]) for name in nominal.parameters() if name in row.index}
    lengths = [x for name, x in values.items() if nominal.parameter_kind(name) == "length"]
    coords = [x for name, x in values.items() if nominal.parameter_kind(name) == "coordinate"]
    if not all(math.isfinite(x) and x > 0 for x in lengths):
        raise UserError(f"variant {v}: its lengths are not all finite and > 0 (status {row.get('status', '?')})")
    if not all(math.isfinite(x) for x in coords):
        raise UserError(f"variant {v}: its coordinates are not all finite (status {row.get('status', '?')})")
    mech = nominal.with_parameters(values)
    P0, fail = _resolver_of(results).assemble(nominal)
    if fail is None:
        skip = set(nominal.fixed) | {nominal.driven}
        guess = {name: tuple(P0[i]) for i, name in enumerate(nominal.vertices) if name not in skip}
        mech = replace(mech, guess=guess)
    return mech


def _resolver_of(results):
    """The resolver of an open :class:`~explorer.store.Results` (the registered one for any other reader)."""
    from ._resolver import registered_resolver
    return getattr(results, "resolver", None) or registered_resolver()


# -- the forces a variant's study stored (the build kit sizes its pins and shaft from them) --------------------
def variant_peak_forces(res, v: int) -> dict[str, float]:
    """{joint: peak reaction, N} of variant ``v`` of an open results file: its ``pin_force.<joint>`` metrics,
    else the peak magnitude of the stored ``/forces/<joint>`` series; {} when the study stored neither."""
    import numpy as np

    row = variant_row(res, v)
    out = {}
    for col, val in row.items():
        if str(col).startswith("pin_force."):
            try:
                f = float(val)
            except (TypeError, ValueError):
                continue
            if math.isfinite(f):
                out[str(col)[len("pin_force."):]] = f
    if not out:
        for j in res.force_joints:
            a = np.asarray(res.force(v, j), dtype=np.float64)
            m = np.hypot(a[:, 0], a[:, 1])
            if np.any(np.isfinite(m)):
                out[j] = float(np.nanmax(m))
    return out


def variant_torque(res, v: int) -> float | None:
    """The stored ``motor_torque_peak`` (N·m) of variant ``v`` of an open results file, or None."""
    row = variant_row(res, v)
    try:
        f = float(row.get("motor_torque_peak")) if "motor_torque_peak" in row.index else math.nan
    except (TypeError, ValueError):
        f = math.nan
    return f if math.isfinite(f) else None
