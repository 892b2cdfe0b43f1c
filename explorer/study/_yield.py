"""Will it survive the workshop? The ``yield`` of a design: the share of copies of it, cut with a
manufacturing error on every design parameter, that still assemble over the whole crank turn and pass
the buildability screen.

A study asks for it with a ``[robustness]`` table and ``yield`` among its ``[scene] metrics`` (or an
``[optimize]`` objective or constraint naming it)::

    [robustness]
    tolerance = 0.5          # ± this much on every design parameter, in `unit`
    unit = "%"               # "%": lengths relatively, coordinates in % of the mechanism's size (as
                             #      [perturb] spreads them); "model": model units; "mm": millimetres
                             #      (needs [operating] unit, metres per model unit)
    distribution = "uniform" # "uniform" on ±tolerance, or "normal" with standard deviation
                             #      tolerance / 3 (±tolerance is the ±3σ band: 99.73 % of cuts inside it)
    copies = 256             # copies per design
    seed = 0                 # of the errors
    parameters = "all"       # or a list of design parameter names (default every one: links, crank
                             #      radius and centre, ground pivots, body points)

**Common random numbers.** Copy j of every design is cut with the same draws u_j (one row of a
(copies, P) matrix from ``numpy.random.default_rng(seed)``: ``uniform(-1, 1, (copies, P))``, or
``standard_normal((copies, P)) / 3``, P = every parameter of ``Mechanism.parameters()`` in its order,
drawn for all of them whichever are cut): designs are compared on the same errors, so the difference
between two designs' yields is far more precise than either yield.

Copy j of a design x (P,) in ``Mechanism.parameters()`` order: a cut parameter i is
``x_i · (1 + t·u_ji)`` for a length (link or crank radius) and ``x_i + t·u_ji·size`` for a
coordinate with ``unit = "%"`` (t = tolerance / 100, size = the nominal mechanism's
``Mechanism.size``); ``x_i + t·u_ji`` for every parameter with ``unit = "model"`` (t = tolerance) or
``"mm"`` (t = tolerance / 1000 / [operating] unit).

A copy counts when it solves over the whole turn (status ok) and passes the study's buildability
screen (:mod:`explorer.gait._screen`, every check whose metric the mechanism has). The yield p is the
share of the ``copies`` that count; its binomial standard error is √(p(1 − p)/copies) (at 256 copies
and p = 0.95: ±0.014).

Cost: one kernel call solves a block of designs × copies (at most :data:`MAX_ROWS` copies per call:
100 designs × 256 copies is one), with the foot's velocities (the screen's foot speed needs them);
about ``copies`` times a plain solve of the designs (``benchmarks/bench_yield.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UserError, where
from ..mechanism import Mechanism, Operating

#: Keys of the ``[robustness]`` table.
ROBUSTNESS_KEYS = ("tolerance", "unit", "distribution", "copies", "seed", "parameters")
#: ``[robustness] unit`` choices.
UNITS = ("%", "model", "mm")
#: ``[robustness] distribution`` choices.
DISTRIBUTIONS = ("uniform", "normal")
DEFAULT_COPIES = 256
#: Most copies a design may be given.
MAX_COPIES = 1_000_000
#: Most copies (designs × copies) solved in one kernel call: 100 designs × 256 copies is one call.
MAX_ROWS = 32_768
#: The metric's name.
YIELD = "yield"


@dataclass(frozen=True)
class Robustness:
    """A validated ``[robustness]`` table (see the module docstring).

    tolerance : ± this much, in ``unit``; unit : "%", "model" or "mm"; distribution : "uniform" or
    "normal" (σ = tolerance / 3); copies : per design; seed : of the draws; parameters : "all" or a
    tuple of design parameter names; scale_mm : model units per millimetre for ``unit = "mm"``
    (1 / (1000 · [operating] unit)), else None.
    """

    tolerance: float
    unit: str = "%"
    distribution: str = "uniform"
    copies: int = DEFAULT_COPIES
    seed: int = 0
    parameters: object = "all"
    scale_mm: float | None = None

    def as_dict(self) -> dict:
        return {"tolerance": self.tolerance, "unit": self.unit, "distribution": self.distribution,
                "copies": self.copies, "seed": self.seed,
                "parameters": self.parameters if self.parameters == "all" else list(self.parameters)}

    def describe(self) -> str:
        """One line: "±0.5 % uniform on every design parameter, 256 copies (seed 0)"."""
        unit = {"%": " %", "model": " model units", "mm": " mm"}[self.unit]
        what = "every design parameter" if self.parameters == "all" else ", ".join(self.parameters)
        law = "uniform" if self.distribution == "uniform" else "normal, ±3σ"
        return f"±{self.tolerance:g}{unit} ({law}) on {what}, {self.copies:,} copies (seed {self.seed})"


#: Largest tolerance in model units or mm, as a share of the mechanism's size (``Mechanism.size``).
MAX_TOLERANCE_OF_SIZE = 0.5


def robustness_from_dict(table, source: str, mech: Mechanism, operating: Operating | None = None,
                         key: str = "robustness") -> Robustness:
    """Validate a ``[robustness]`` table for ``mech`` (``operating``: the study's operating point, whose
    ``unit`` a tolerance in mm needs). UserError naming ``source`` and the key on bad input."""
    def k(name):
        return where(source, f"{key}.{name}" if key else name)

    if not isinstance(table, dict):
        raise UserError(f"{where(source, key)}: expected a table ([{key}] with tolerance = ...), got {table!r}")
    for name in table:
        if name not in ROBUSTNESS_KEYS:
            raise UserError(f"{k(name)}: unknown key (allowed in [{key}]: {', '.join(ROBUSTNESS_KEYS)})")
    if "tolerance" not in table:
        raise UserError(f"{k('tolerance')}: missing: the manufacturing error every design parameter is cut with, "
                        f"e.g. tolerance = 0.5 with unit = \"%\"")
    unit = table.get("unit", "%")
    if unit not in UNITS:
        raise UserError(f"{k('unit')}: expected one of {', '.join(repr(u) for u in UNITS)}, got {unit!r}")
    tol = table["tolerance"]
    hi = 50.0 if unit == "%" else math.inf
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (math.isfinite(tol) and 0.0 < tol <= hi):
        what = "a percentage in (0, 50]" if unit == "%" else f"a positive number of {'model units' if unit == 'model' else 'mm'}"
        raise UserError(f"{k('tolerance')}: expected {what}, got {tol!r}")
    distribution = table.get("distribution", "uniform")
    if distribution not in DISTRIBUTIONS:
        raise UserError(f"{k('distribution')}: expected one of {', '.join(DISTRIBUTIONS)}, got {distribution!r}")
    copies = table.get("copies", DEFAULT_COPIES)
    if isinstance(copies, bool) or not isinstance(copies, int) or not 2 <= copies <= MAX_COPIES:
        raise UserError(f"{k('copies')}: expected a whole number from 2 to {MAX_COPIES:,}, got {copies!r}")
    seed = table.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed < 2 ** 63:
        raise UserError(f"{k('seed')}: expected a whole number >= 0, got {seed!r}")
    parameters = table.get("parameters", "all")
    known = tuple(mech.parameters())
    if parameters != "all":
        if isinstance(parameters, str):
            parameters = [parameters]
        if not isinstance(parameters, list) or not parameters or not all(isinstance(p, str) for p in parameters):
            raise UserError(f"{k('parameters')}: expected \"all\" or a list of design parameter names, got "
                            f"{table['parameters']!r}")
        for p in parameters:
            if p not in known:
                raise UserError(f"{k('parameters')}: unknown design parameter {p!r} (known: {', '.join(known)})")
        parameters = tuple(p for p in known if p in set(parameters))
    scale_mm = None
    if unit == "mm":
        if operating is None or operating.unit is None:
            raise UserError(f"{k('unit')}: a tolerance in mm needs [operating] unit (metres per model unit, e.g. "
                            f"0.01 for a mechanism drawn in centimetres); or give unit = \"%\" or \"model\"")
        scale_mm = 1.0 / (1000.0 * float(operating.unit))
    if unit != "%":  # an error as big as the mechanism is no tolerance: at most half its size (its longest member)
        most = MAX_TOLERANCE_OF_SIZE * mech.size
        model = float(tol) * (scale_mm if unit == "mm" else 1.0)
        if model > most:
            limit = most / scale_mm if unit == "mm" else most
            raise UserError(f"{k('tolerance')}: expected at most {limit:.6g} {'mm' if unit == 'mm' else 'model units'} "
                            f"(half the mechanism's size, its longest member), got {tol!r}")
    return Robustness(tolerance=float(tol), unit=unit, distribution=distribution, copies=int(copies), seed=int(seed),
                      parameters=parameters, scale_mm=scale_mm)


def draws(robustness: Robustness, n_parameters: int) -> np.ndarray:
    """The common random numbers (copies, P): uniform on [−1, 1], or standard normal / 3."""
    rng = np.random.default_rng(robustness.seed)
    shape = (robustness.copies, int(n_parameters))
    if robustness.distribution == "uniform":
        return rng.uniform(-1.0, 1.0, shape)
    return rng.standard_normal(shape) / 3.0


def full_parameters(mech: Mechanism, lengths, crank, geometry: dict | None = None) -> np.ndarray:
    """Designs as (n, P) values of every parameter of ``mech.parameters()``, in its order: lengths (n,
    n_links) in ``mech.links`` order, crank (n,) radii (NaN or ignored for a path driver), geometry
    {coordinate name: (n,)} for the coordinates that differ from the nominal's (None: none)."""
    lengths = np.atleast_2d(np.asarray(lengths, dtype=np.float64))
    n = lengths.shape[0]
    nominal = mech.parameters()
    names = list(nominal)
    X = np.empty((n, len(names)))
    links = {name: i for i, name in enumerate(mech.link_names)}
    geometry = geometry or {}
    for j, p in enumerate(names):
        if p in links:
            X[:, j] = lengths[:, links[p]]
        elif p == "crank":
            X[:, j] = np.asarray(crank, dtype=np.float64).reshape(n)
        elif p in geometry:
            X[:, j] = np.asarray(geometry[p], dtype=np.float64).reshape(n)
        else:
            X[:, j] = nominal[p]
    return X


def _copies(mech: Mechanism, X: np.ndarray, U: np.ndarray, robustness: Robustness) -> np.ndarray:
    """Every copy of the designs X (m, P): (m·K, P), design-major (the K copies of design 0 first)."""
    names = list(mech.parameters())
    cut = np.array([robustness.parameters == "all" or p in robustness.parameters for p in names])
    relative = np.array([mech.parameter_kind(p) == "length" for p in names])
    m, P = X.shape
    K = U.shape[0]
    if robustness.unit == "%":
        t = robustness.tolerance / 100.0
        step = np.where(relative, 0.0, t * mech.size)  # coordinates move by t·size
        factor = np.where(relative, t, 0.0)            # lengths scale by 1 + t·u
    else:
        t = robustness.tolerance if robustness.unit == "model" else robustness.tolerance * robustness.scale_mm
        step = np.full(P, t)
        factor = np.zeros(P)
    step = np.where(cut, step, 0.0)
    factor = np.where(cut, factor, 0.0)
    Xc = X[:, None, :] * (1.0 + factor * U[None, :, :]) + step * U[None, :, :]
    return Xc.reshape(m * K, P)


def split_parameters(mech: Mechanism, Xc: np.ndarray):
    """(lengths (n, n_links), crank (n,) or None, geometry {coordinate: (n,)}) of full designs Xc (n, P)."""
    names = list(mech.parameters())
    col = {p: j for j, p in enumerate(names)}
    lengths = np.ascontiguousarray(Xc[:, [col[p] for p in mech.link_names]])
    crank = np.ascontiguousarray(Xc[:, col["crank"]]) if mech.crank is not None else None
    geometry = {p: np.ascontiguousarray(Xc[:, col[p]]) for p in names if mech.parameter_kind(p) == "coordinate"}
    return lengths, crank, geometry


@dataclass
class YieldResult:
    """What :func:`design_yield` found, per design: share (n,) the yield p in [0, 1]; count (n,) the
    copies that count; copies : K; se (n,) the binomial standard error √(p(1 − p)/K); robustness : the
    settings."""

    share: np.ndarray
    count: np.ndarray
    copies: int
    robustness: Robustness

    @property
    def se(self) -> np.ndarray:
        p = self.share
        return np.sqrt(p * (1.0 - p) / self.copies)


def design_yield(mech: Mechanism, lengths, crank=None, geometry: dict | None = None, *,
                 robustness: Robustness, steps: int = 360, tolerance: float | None = None, method: str = "block",
                 screen=None) -> YieldResult:
    """The yield of n designs of ``mech`` (see the module docstring).

    lengths : (n, n_links) in ``mech.links`` order, model units; crank : (n,) radii (None: the
    nominal's); geometry : {coordinate parameter name: (n,)} where the designs move coordinates (None:
    the nominal's). robustness : :class:`Robustness`. steps, tolerance, method : of the solve, as the
    study's. screen : the buildability screen's thresholds (:class:`explorer.gait.Screen`; None: the
    defaults). Returns a :class:`YieldResult`.
    """
    import pandas as pd

    from ..gait import SCREEN_INPUTS, available_metrics, compute_metrics, screen_columns
    from ..kernels import DEFAULT_TOLERANCE, simulate_batch

    lengths = np.atleast_2d(np.asarray(lengths, dtype=np.float64))
    n = lengths.shape[0]
    if crank is None:
        crank = np.full(n, float(mech.crank.radius) if mech.crank is not None else np.nan)
    X = full_parameters(mech, lengths, crank, geometry)
    U = draws(robustness, X.shape[1])
    K = robustness.copies
    available = available_metrics(mech)
    names = [m for m in SCREEN_INPUTS if available.get(m) is None]
    need_vel = bool(names)
    count = np.zeros(n, dtype=np.int64)
    per_call = max(1, MAX_ROWS // K)
    foot = mech.foot
    for a in range(0, n, per_call):
        b = min(n, a + per_call)
        Xc = _copies(mech, X[a:b], U, robustness)
        L, r, geo = split_parameters(mech, Xc)
        batch = simulate_batch(mech, L, r, steps, geometry=geo or None, vertices=[foot], velocities=need_vel,
                               tolerance=tolerance if tolerance is not None else DEFAULT_TOLERANCE, method=method)
        status = np.asarray(batch.status)
        good = status == 0
        if names:
            metrics = compute_metrics(batch.paths[foot], batch.velocities.get(foot), status, names, mechanism=mech,
                                      lengths=L, crank=r, geometry=geo or None)
            df = pd.DataFrame(metrics)
            df["status"] = status
            df["crank"] = r if r is not None else np.nan
            screened = screen_columns(df, screen)
            if screened is not None:
                good = screened[0]
        count[a:b] = good.reshape(b - a, K).sum(axis=1)
    return YieldResult(share=count / K, count=count, copies=K, robustness=robustness)
