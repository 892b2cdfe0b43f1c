"""Which dimensions matter: global sensitivity indices and a tolerance summary of a sampled study.

Everything here reads the samples a study already holds: the design parameters it perturbed (the
frame's link-length columns, ``crank`` and coordinate columns such as ``"2.x"``:
:attr:`~explorer.store.Results.perturbed`) against what came out. No new solve.

Outputs (the ``output`` column of :func:`sensitivity`)
-------------------------------------------------------
* each chosen **metric** (default: the walker score's, :data:`explorer.gait.DEFAULT_WEIGHTS`; or
  ``"all"`` stored, or a list). Failed variants have no metrics (NaN) and are left out: ``n`` says how
  many variants were used.
* ``fails``: 1 when a variant cannot be solved over a full crank turn (any failure status), else 0,
  over every sampled variant. ``fails:STATUS@VERTEX`` (such as ``fails:assembly@5``): the same for one
  failure kind, the status and the vertex where it failed (``fail_vertex``).
* ``screened``: among the variants that turn, 1 when the buildability screen removes them;
  ``screened:CHECK`` (``screened:toggle``, ``screened:foot-whip``, …) for one check. Only when the file
  stores the metrics the screen reads.

Indices (``method``), all computed by SALib from the stored samples, never by estimators written here
------------------------------------------------------------------------------------------------------
* ``rbd-fast`` (default for uniform, normal, lhs and sobol studies): ``SALib.analyze.rbd_fast``, the
  first-order index **S1** (the share of the output's variance explained by one parameter alone) from
  any sample (Plischke's EASI ordering, Tissot and Prieur's bias correction). Its interval is SALib's
  bootstrap over half-size resamples (so it is on the wide side).
* ``delta``: ``SALib.analyze.delta``: Borgonovo's moment-independent **delta** (how far the whole
  distribution of the output moves when one parameter is fixed; 0 = none, ≤ 1), bias-reduced by
  bootstrap (Plischke, Borgonovo and Smith 2013; the "raw" resampling), and its binned first-order
  **S1**. The KDE behind delta does not apply to a 0/1 outcome, so ``fails`` and ``screened`` get S1
  only. Slow: every resample re-estimates dozens of kernel densities.
* ``pawn``: ``SALib.analyze.pawn``: the median over 10 conditioning slices of the Kolmogorov–Smirnov
  distance between the output's distribution with the parameter in one slice and without
  (Pianosi and Wagener 2015). SALib gives no interval; here it is a bootstrap over the variants
  (each resample a full ``pawn.analyze``).
* ``sobol`` (default, and only, for ``saltelli`` studies): ``SALib.analyze.sobol`` with
  ``calc_second_order=False``: **S1** and the total index **ST** (the share of variance in which the
  parameter takes part, interactions included; ST − S1 is what it does only together with others).
  Rows 1 … N·(k + 2) of the file are Saltelli's design in SALib's order (variant 0, the nominal, is
  left out); a base point any of whose k + 2 variants has no value (a failed variant's metric) is
  dropped whole, which conditions the indices on success as dropping failed variants does elsewhere.

Intervals are SALib's: ``conf`` is the half-width of the ``conf_level`` (95 %) interval, z × the
bootstrap standard deviation, and ``low``/``high`` are value ∓ conf. Resamples default to
:data:`DEFAULT_RESAMPLES` per method. Every SALib call runs with the global NumPy random state seeded
from ``seed`` and restored afterwards, so the indices are reproducible and nothing else is disturbed.

A study whose variants are not a sample of the design space (``oat``, ``grid``, an optimisation's
population, a file that names no sampling method) has no global indices: that, an unknown metric, and ``sobol`` on a study that is not ``saltelli`` are one-line
:class:`~explorer.errors.UserError`\\ s.
"""

from __future__ import annotations

import math
import os
import warnings
from contextlib import contextmanager

import numpy as np

from ..errors import UserError
from ..study import SAMPLED_METHODS

#: The index methods, by the name ``--method`` takes.
INDEX_METHODS = ("rbd-fast", "delta", "pawn", "sobol")
#: Bootstrap resamples of each method's interval unless asked otherwise (SALib's default is 100; the
#: given-data methods re-run their estimator per resample, so fewer: 50 leave the interval's width
#: uncertain by about 10 %).
DEFAULT_RESAMPLES = {"rbd-fast": 50, "delta": 20, "pawn": 10, "sobol": 100}
#: The index that ranks parameters, per method and kind of output (a 0/1 outcome or a metric).
MAIN_INDEX = {"rbd-fast": "S1", "delta": "delta", "pawn": "pawn", "sobol": "ST"}
#: Words for an index, for tables and plot labels.
INDEX_NAMES = {"S1": "first-order index S1", "ST": "total index ST", "delta": "delta (moment-independent)",
               "pawn": "PAWN (median KS distance)"}
#: How a failure status reads in a sentence.
FAILURE_WORDS = {"assembly": "cannot assemble", "branch": "leaves its branch", "no-convergence": "does not converge",
                 "invalid": "is invalid (a non-positive length)"}
#: rbd-fast's harmonics (SALib's default M); a sample needs more than 2·M rows.
RBD_M = 10
#: PAWN's conditioning slices (SALib's default S).
PAWN_SLICES = 10

_COLUMNS = ["output", "kind", "what", "parameter", "index", "value", "conf", "low", "high", "n", "method", "note"]


# -- the study's samples -------------------------------------------------------------------------------------
def _read(results):
    """(frame, parameters, design, source name, stored metrics) of a results path, RunSummary or Results."""
    from ..store import Results
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    if isinstance(results, Results):
        return _from_results(results)
    try:
        os.fspath(results)
    except TypeError:
        raise UserError(f"sensitivity: expected a results file (a path, a run_study summary or an open Results), "
                        f"got {type(results).__name__} (for a results frame: explorer.analysis.sensitivity_frame)") from None
    with open_results(results) as r:
        return _from_results(r)


def _from_results(r):
    df = r.frame()
    params = [p for p in r.perturbed if p in df.columns]
    return df, params, _design(r.study), str(r.filename), tuple(r.metric_names)


def _design(study) -> str:
    """How a results file's variants were chosen: its ``[perturb] method``, ``"optimize"`` for an
    optimisation's population, ``"none"`` when the file does not say (never taken for a sample)."""
    if not isinstance(study, dict):
        return "none"
    if study.get("optimize") is not None:
        return "optimize"
    perturb = study.get("perturb")
    method = perturb.get("method") if isinstance(perturb, dict) else None
    return str(method) if method else "none"


def _check_design(design: str, method: str | None, source: str) -> str:
    """The index method to use for a study of perturb method ``design`` (UserError if none applies)."""
    if design == "optimize":
        raise UserError(f"{source}: an optimisation's results: its variants are the search's population, gathered "
                        f"where the optimiser went, not a sample of the design space, so they have no global "
                        f"indices (run a study with perturb.method = uniform, normal, lhs, sobol or saltelli)")
    if design not in SAMPLED_METHODS:
        what = {"oat": "a one-at-a-time design", "grid": "a full-factorial design"}.get(
            design, "a design set that says no sampling method" if design == "none" else f"design {design!r}")
        raise UserError(f"{source}: perturb.method = {design!r}: {what} is no sample of the design space, so it has "
                        f"no global indices (run a study with perturb.method = uniform, normal, lhs, sobol or "
                        f"saltelli; `explorer plot --sensitivity` draws an oat study's slopes)")
    if method is None:
        return "sobol" if design == "saltelli" else "rbd-fast"
    if method not in INDEX_METHODS:
        raise UserError(f"--method: expected one of {', '.join(INDEX_METHODS)}, got {method!r}")
    if method == "sobol" and design != "saltelli":
        raise UserError(f"{source}: --method sobol needs a study sampled with perturb.method = \"saltelli\" (Saltelli's "
                        f"design); this one is {design!r}: use --method rbd-fast, delta or pawn, or run a saltelli study")
    return method


def _metric_list(metrics, stored, source: str) -> list[str]:
    from ..gait import DEFAULT_WEIGHTS
    if metrics is None:
        return [m for m in DEFAULT_WEIGHTS if m in stored]
    if isinstance(metrics, str):
        if metrics.strip() == "all":
            return list(stored)
        if metrics.strip() == "none":
            return []
        metrics = [m.strip() for m in metrics.split(",") if m.strip()]
    out = []
    for m in metrics:
        if m not in stored:
            known = ", ".join(stored) if stored else "none: the study stored no metrics"
            raise UserError(f"{source}: --metrics: unknown or not stored metric {m!r} (stored: {known})")
        if m not in out:
            out.append(m)
    return out


def _outputs(df, metrics, failures: bool) -> list[tuple[str, str, np.ndarray, str]]:
    """(name, kind, y over the frame's rows (NaN = not used), description) of every analysed output."""
    status = df["status"].astype(str).to_numpy()
    run = status != "not-run"
    ok = status == "ok"
    out = []
    if failures:
        fails = np.where(run, (~ok).astype(np.float64), np.nan)
        out.append(("fails", "failure", fails, "cannot be solved over a full turn"))
        vertex = df["fail_vertex"].to_numpy(dtype=object)
        kinds = {}
        for st, v in zip(status[run & ~ok], vertex[run & ~ok]):
            kinds.setdefault((st, v), 0)
        for st, v in sorted(kinds, key=lambda sv: (sv[0], str(sv[1]))):
            name = f"fails:{st}" + (f"@{v}" if v is not None else "")
            y = np.where(run, ((status == st) & (vertex == v)).astype(np.float64), np.nan)
            words = FAILURE_WORDS.get(st, st)
            out.append((name, "failure", y, f"vertex {v} {words}" if v is not None else f"{words}"))
        if "buildable" in df.columns and ok.any():
            build = df["buildable"].to_numpy(dtype=bool)
            out.append(("screened", "screen", np.where(ok, (~build).astype(np.float64), np.nan),
                        "turns, but screened out"))
            reasons = df["screen"].astype(str).to_numpy()
            from ..gait import CHECKS
            for check in (c[0] for c in CHECKS):
                hit = np.array([any(part.startswith(check + ":") for part in r.split("; ")) for r in reasons])
                if (hit & ok).any():
                    out.append((f"screened:{check.replace(' ', '-')}", "screen",
                                np.where(ok, hit.astype(np.float64), np.nan), f"screened out: {check}"))
    for m in metrics:
        from ..gait import DESCRIPTIONS
        out.append((m, "metric", df[m].to_numpy(dtype=np.float64, na_value=np.nan), DESCRIPTIONS.get(m, m)))
    return out


# -- SALib, quietly and reproducibly ---------------------------------------------------------------------------
@contextmanager
def _salib(seed: int):
    """Seed NumPy's global random state (SALib's delta, pawn and sobol draw from it) and silence SALib's
    warnings (notes about binning); restore both afterwards (SALib's delta also replaces
    ``warnings.formatwarning``)."""
    state = np.random.get_state()
    fmt = warnings.formatwarning
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            np.random.seed(int(seed) % 2 ** 32)
            with np.errstate(all="ignore"):
                yield
    finally:
        warnings.formatwarning = fmt
        np.random.set_state(state)


def _problem(X: np.ndarray, names) -> dict:
    """SALib's problem dict; bounds are the sampled range of each parameter (only sobol's sampler would
    read them; the analyses here use the names and the count)."""
    return {"num_vars": len(names), "names": list(names),
            "bounds": [[float(X[:, j].min()), float(X[:, j].max())] for j in range(len(names))]}


def _given_data(method: str, X, y, names, binary: bool, resamples: int, conf_level: float, seed: int):
    """{index: (values (k,), conf (k,))} of one output from given samples X (n, k), y (n,)."""
    problem = _problem(X, names)
    k = len(names)
    if method == "rbd-fast":
        from SALib.analyze import rbd_fast
        with _salib(seed):
            s = rbd_fast.analyze(problem, X, y, M=RBD_M, num_resamples=resamples, conf_level=conf_level, seed=seed)
        return {"S1": (np.asarray(s["S1"], dtype=float), np.asarray(s["S1_conf"], dtype=float))}
    if method == "delta":
        from SALib.analyze import delta
        with _salib(seed):
            s = delta.analyze(problem, X, y, num_resamples=resamples, conf_level=conf_level,
                              method="sobol" if binary else "all")
        out = {}
        if not binary:
            key = "delta" if "delta" in s else "delta_raw"  # SALib 1.5 / 1.6 names
            out["delta"] = (np.asarray(s[key], dtype=float), np.asarray(s[key + "_conf"], dtype=float))
        out["S1"] = (np.asarray(s["S1"], dtype=float), np.asarray(s["S1_conf"], dtype=float))
        return out
    if method == "pawn":
        from SALib.analyze import pawn
        from scipy.stats import norm
        with _salib(seed):
            value = np.asarray(pawn.analyze(problem, X, y, S=PAWN_SLICES)["median"], dtype=float)
            rng = np.random.default_rng(seed)
            boot = np.empty((resamples, k))
            for b in range(resamples):
                idx = rng.integers(0, len(y), len(y))
                boot[b] = np.asarray(pawn.analyze(problem, X[idx], y[idx], S=PAWN_SLICES)["median"], dtype=float)
        conf = norm.ppf(0.5 + conf_level / 2) * boot.std(axis=0, ddof=1) if resamples > 1 else np.full(k, np.nan)
        return {"pawn": (value, conf)}
    raise AssertionError(method)


def _saltelli(y_design: np.ndarray, names, resamples: int, conf_level: float, seed: int):
    """({index: (values, conf)}, base points used) of Saltelli-design outputs (N·(k + 2),), blocks with a
    NaN dropped."""
    from SALib.analyze import sobol
    k = len(names)
    blocks = y_design.reshape(-1, k + 2)
    keep = np.isfinite(blocks).all(axis=1)
    y = blocks[keep].reshape(-1)
    problem = {"num_vars": k, "names": list(names), "bounds": [[0.0, 1.0]] * k}
    if keep.sum() < 2 or np.ptp(y) == 0.0:
        return None, int(keep.sum())
    with _salib(seed):
        s = sobol.analyze(problem, y, calc_second_order=False, num_resamples=resamples, conf_level=conf_level,
                          seed=seed or None)
    return {"S1": (np.asarray(s["S1"], dtype=float), np.asarray(s["S1_conf"], dtype=float)),
            "ST": (np.asarray(s["ST"], dtype=float), np.asarray(s["ST_conf"], dtype=float))}, int(keep.sum())


# -- the public functions ------------------------------------------------------------------------------------
def sensitivity(results, metrics=None, method: str | None = None, *, resamples: int | None = None, seed: int = 1,
                conf_level: float = 0.95, failures: bool = True):
    """Global sensitivity indices of a sampled study, from the samples in its results file (no new solve).

    results : a results path, a :func:`~explorer.run_study` summary or an open
        :class:`~explorer.store.Results`.
    metrics : None (the walker score's metrics that are stored), ``"all"`` (every stored metric),
        ``"none"``, or a list / comma-separated names.
    method : ``"rbd-fast"``, ``"delta"``, ``"pawn"`` or ``"sobol"`` (see the module docstring); None:
        ``sobol`` for a saltelli study, else ``rbd-fast``.
    resamples : bootstrap resamples of the intervals (default :data:`DEFAULT_RESAMPLES`). seed : of
        the bootstraps. conf_level : of the intervals. failures : also analyse the 0/1 outcomes
        ``fails``, ``fails:KIND@VERTEX``, ``screened``, ``screened:CHECK``.

    Returns a pandas DataFrame, one row per (output, parameter, index), parameters in the study's
    order: ``output``, ``kind`` (failure | screen | metric), ``what`` (the output in words, such as
    "vertex 5 cannot assemble"), ``parameter``, ``index`` (S1, ST, delta,
    pawn), ``value``, ``conf`` (half-width of the interval), ``low``, ``high``, ``n`` (variants used:
    the nominal and variants without a value are left out), ``method``, ``note`` (why a value is NaN).
    ``attrs`` hold the source, design, method, parameters, samples, resamples, seed and conf_level.
    """
    from .._extras import require
    require("SALib", "sensitivity analysis")  # before the results file is read
    df, params, design, source, stored = _read(results)
    return sensitivity_frame(df, params, design=design, metrics=metrics, method=method, resamples=resamples,
                             seed=seed, conf_level=conf_level, failures=failures, source=source, stored=stored)


def sensitivity_frame(df, parameters, *, design: str = "uniform", metrics=None, method: str | None = None,
                      resamples: int | None = None, seed: int = 1, conf_level: float = 0.95, failures: bool = True,
                      source: str = "<frame>", stored=None):
    """:func:`sensitivity` of a results frame already read (``Results.frame()``): ``parameters`` are its
    sampled columns (``Results.perturbed``), ``design`` the study's ``perturb.method``; ``stored`` the
    metric columns that may be analysed (default: every metric of :data:`explorer.gait.METRICS` in
    the frame). Row 0 must be the nominal (variant 0); it is never analysed."""
    import pandas as pd

    from .._extras import require
    from ..gait import METRICS
    require("SALib", "sensitivity analysis")
    method = _check_design(design, method, source)
    if not 0.0 < float(conf_level) < 1.0:
        raise UserError(f"conf_level: expected a number in (0, 1), got {conf_level!r}")
    resamples = DEFAULT_RESAMPLES[method] if resamples is None else resamples
    if isinstance(resamples, bool) or not isinstance(resamples, (int, np.integer)) or not 2 <= resamples <= 100_000:
        raise UserError(f"--resamples: expected a whole number from 2 to 100,000, got {resamples!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise UserError(f"--seed: expected a whole number >= 0, got {seed!r}")
    params = list(parameters)
    if not params:
        raise UserError(f"{source}: the study perturbed no parameter, so no index can be computed")
    missing = [p for p in params if p not in df.columns]
    if missing:
        raise UserError(f"{source}: parameter column {missing[0]!r} is not in the frame")
    stored = tuple(m for m in METRICS if m in df.columns) if stored is None else tuple(stored)
    chosen = _metric_list(metrics, stored, source)
    if len(df) < 2:
        raise UserError(f"{source}: only the nominal variant: nothing was sampled")
    X_all = df[params].to_numpy(dtype=np.float64)[1:]
    flat = [p for j, p in enumerate(params) if not np.ptp(X_all[:, j]) > 0]
    if flat:
        raise UserError(f"{source}: parameter {flat[0]!r} takes one value in every variant (perturb.spread = 0?): "
                        f"nothing to apportion")
    k = len(params)
    if method == "sobol" and (len(df) - 1) % (k + 2):
        raise UserError(f"{source}: {len(df) - 1:,} sampled variants are not N·(k + 2) = N·{k + 2} rows of a Saltelli "
                        f"design over {k} parameters")

    rows = []
    for name, kind, y_all, what in _outputs(df, chosen, failures):
        y_all = y_all[1:]  # variant 0 is the nominal, no sample
        binary = kind != "metric"
        if method == "sobol":
            res, used = _saltelli(y_all, params, resamples, conf_level, seed)
            n, note = used * (k + 2), ""
            if res is None:
                note = "constant output: no variance to apportion" if used >= 2 else "too few complete base points"
        else:
            use = np.isfinite(y_all) & np.isfinite(X_all).all(axis=1)
            X, y = X_all[use], y_all[use]
            n, res, note = int(use.sum()), None, ""
            if n <= 2 * RBD_M + 1:
                note = f"too few variants with a value ({n})"
            elif np.ptp(y) == 0.0:
                note = "constant output: no variance to apportion"
            else:
                res = _given_data(method, X, y, params, binary, resamples, conf_level, seed)
        indices = list(res) if res is not None else (["S1", "ST"] if method == "sobol" else
                                                      ["S1"] if binary and method == "delta" else
                                                      ["delta", "S1"] if method == "delta" else [MAIN_INDEX[method]])
        for index in indices:
            vals, confs = res[index] if res is not None else (np.full(k, np.nan), np.full(k, np.nan))
            for j, p in enumerate(params):
                v, c = float(vals[j]), float(confs[j])
                rows.append((name, kind, what, p, index, v, c, v - c, v + c, n, method, note))
    out = pd.DataFrame(rows, columns=_COLUMNS)
    out.attrs.update({"source": source, "design": design, "method": method, "parameters": params,
                      "samples": len(df) - 1, "resamples": int(resamples), "seed": int(seed),
                      "conf_level": float(conf_level)})
    return out


def main_index(method: str, kind: str) -> str:
    """The index that ranks parameters for an output of ``kind`` under ``method`` (delta's 0/1
    outcomes have S1 only)."""
    if method == "delta" and kind != "metric":
        return "S1"
    return MAIN_INDEX[method]


def drivers(indices, output: str, top: int = 3, share: float = 0.8) -> list[tuple[str, float, float]]:
    """The parameters most responsible for ``output``: (name, value, conf) by the method's main index,
    largest first, each one's interval above 0, until they hold ``share`` of the positive total, at
    most ``top``."""
    sel = indices[indices["output"] == output]
    if sel.empty:
        return []
    idx = main_index(str(sel["method"].iloc[0]), str(sel["kind"].iloc[0]))
    sel = sel[(sel["index"] == idx) & np.isfinite(sel["value"])].sort_values("value", ascending=False)
    total = float(sel["value"].clip(lower=0).sum())
    out, held = [], 0.0
    for p, v, c in zip(sel["parameter"], sel["value"], sel["conf"]):
        if len(out) >= top or v <= 0 or not (v - (c if math.isfinite(c) else 0.0)) > 0 or held >= share * total:
            break
        out.append((str(p), float(v), float(c)))
        held += v
    return out


def _quantiles(y: np.ndarray):
    y = y[np.isfinite(y)]
    if not y.size:
        return math.nan, math.nan, math.nan
    p5, med, p95 = np.quantile(y, [0.05, 0.5, 0.95])
    return float(med), float(p5), float(p95)


def tolerance_summary(results, indices=None, metrics=None, method: str | None = None, **kw):
    """The tolerance summary of a sampled study: which share of the sampled designs (variant 0, the
    nominal, left out; variants not run yet too) assemble over a full turn and pass the buildability
    screen, how often each failure kind and screen check occurs and which parameters drive it, and
    each metric's median and 5–95 % range against the nominal.

    results : as for :func:`sensitivity`; indices : its result, to reuse (else computed with
    ``metrics``, ``method`` and ``**kw``).

    Returns a DataFrame, one row per item: ``item`` (assembles, buildable, fails:KIND@VERTEX,
    screened:CHECK, or a metric), ``kind`` (share | failure | screen | metric), ``what`` (in words),
    ``count`` and ``n`` (the share's numerator and denominator; n is the variants with a value for a
    metric), ``share``, ``se`` (its binomial standard error √(share·(1 − share)/n)), ``nominal``
    (variant 0's value: 1/0 for a share), ``median``, ``p5``, ``p95``, ``index`` (the index that ranks
    the drivers) and ``drivers`` ("1-6 0.30±0.03, 2-6 0.13±0.02": see :func:`drivers`). ``attrs``
    hold the indices' attrs.
    """
    df, params, design, source, stored = _read(results)
    if indices is None:
        indices = sensitivity_frame(df, params, design=design, metrics=metrics, method=method, source=source,
                                    stored=stored, **kw)
    return summary_frame(df, indices)


def summary_frame(df, indices):
    """:func:`tolerance_summary` of a frame already read and its indices. The 0/1 outcomes are those
    the indices analyse (the same function builds them), counted over the sampled variants."""
    import pandas as pd
    method = indices.attrs.get("method", str(indices["method"].iloc[0]) if len(indices) else "rbd-fast")
    status = df["status"].astype(str).to_numpy()
    run = (status != "not-run")[1:]
    n_run = int(run.sum())
    outcomes = {name: (kind, y, what) for name, kind, y, what in _outputs(df, [], True)}
    analysed = set(indices["output"])
    rows = []

    def share_row(item, kind, what, y, nominal, output=None, invert=False):
        """y: the outcome over the frame's rows (NaN = not counted); the share counts its ones (zeros
        with ``invert``) among the sampled variants."""
        sample = y[1:]
        n = int(np.isfinite(sample).sum())
        count = int(np.nansum(1.0 - sample if invert else sample))
        p = count / n if n else math.nan
        se = math.sqrt(p * (1 - p) / n) if n else math.nan
        output = output if output in analysed else None
        ds = drivers(indices, output) if output is not None else []
        idx = main_index(method, kind) if output is not None else ""
        rows.append((item, kind, what, count, n, p, se, float(nominal), math.nan, math.nan, math.nan, idx,
                     _driver_text(ds)))

    fails = outcomes["fails"][1]
    share_row("assembles", "share", "assembles over a full turn", fails, status[0] == "ok", "fails", invert=True)
    for name, (kind, y, what) in outcomes.items():
        if name.startswith("fails:"):
            share_row(name, "failure", what, y, y[0] == 1.0, name)
    if "buildable" in df.columns:
        build = df["buildable"].to_numpy(dtype=bool)
        share_row("buildable", "share", "turns and passes the buildability screen",
                  np.where(np.isfinite(fails), build.astype(np.float64), np.nan), build[0], "screened")
        for name, (kind, y, what) in outcomes.items():
            if name.startswith("screened:"):
                check = name[len("screened:"):].replace("-", " ")
                share_row(name, "screen", f"turns, but fails the screen's {check} check", y, y[0] == 1.0, name)
    for name in dict.fromkeys(indices.loc[indices["kind"] == "metric", "output"]):
        y = df[name].to_numpy(dtype=np.float64, na_value=np.nan)
        med, p5, p95 = _quantiles(y[1:][run])
        ds = drivers(indices, name)
        rows.append((name, "metric", name, int(np.isfinite(y[1:][run]).sum()), n_run, math.nan, math.nan, float(y[0]),
                     med, p5, p95, main_index(method, "metric"), _driver_text(ds)))
    out = pd.DataFrame(rows, columns=["item", "kind", "what", "count", "n", "share", "se", "nominal", "median", "p5",
                                      "p95", "index", "drivers"])
    out.attrs.update(indices.attrs)
    return out


def _driver_text(ds) -> str:
    return ", ".join(f"{p} {v:.2f}±{c:.2f}" if math.isfinite(c) else f"{p} {v:.2f}" for p, v, c in ds)
