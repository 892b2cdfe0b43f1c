"""Samplers: the variants of a study as offsets δ of its design parameters from the nominal.

Variant 0 is always the nominal design, exactly. Variant i ≥ 1 is a row of k samples δ, one per
perturbed parameter in ``mech.parameters()`` order (:attr:`~explorer.study.Study.parameter_names`:
the chosen links in ``mech.links`` order, the crank radius, then the coordinates), each in
[−spread, spread] (or with sigma = spread for ``normal``). A sample maps to a value by the
parameter's kind (:meth:`~explorer.mechanism.Mechanism.parameter_kind`):

* a length (a link, the crank radius) varies relatively: ``nominal × (1 + δ)`` (the *multiplier*
  1 + δ);
* a coordinate (the crank centre, a ground pivot, a body joint) varies by a distance:
  ``nominal + δ × mech.size``. Coordinates vary by ±spread × the mechanism's size, its longest
  link or body span, since a coordinate's own value (often 0) is no scale.

The lines below give the multipliers 1 + δ; a coordinate's δ is the same draw without the 1.

- ``uniform``: 1 + spread·U(−1, 1), independently per parameter.
- ``normal``: 1 + spread·Z, Z ~ N(0, 1) (spread is sigma). Draws are *not* clipped: a variant with a
  non-positive length is kept and gets status "invalid" from the kernels, so every variant is
  accounted for and the distribution is not distorted (at sigma = 0.02 this takes a 50-sigma draw).
- ``lhs``: scipy.stats.qmc.LatinHypercube over the N − 1 non-nominal variants, mapped to ±spread.
- ``sobol``: scrambled scipy.stats.qmc.Sobol points 0 … N − 2, mapped to ±spread. Its balance
  properties hold when N − 1 is a power of two (e.g. ``variants = 4097``).
- ``saltelli``: Saltelli's scheme for Sobol indices, ``SALib.sample.sobol.sample`` with
  ``calc_second_order=False`` (a scrambled Sobol sequence of dimension 2k seeded with ``seed``, as
  SALib draws it), over [−1, 1] per parameter, mapped to ±spread. ``variants`` = N base points; the
  study has N·(k + 2) + 1 variants: the nominal, then for base point j the k + 2 rows A_j,
  AB_j^(1) … AB_j^(k) (A_j with column i taken from B_j), B_j, in SALib's order, so that the rows
  1 … N·(k + 2) of a results file are exactly what ``SALib.analyze.sobol.analyze`` expects. Like
  ``lhs`` it draws every point at once (N·(k + 2)·k floats; SALib fills them in a Python loop,
  about a second per million numbers).
- ``oat`` (one at a time): ``variants`` = L levels per parameter, evenly spaced in
  [1 − spread, 1 + spread] (``numpy.linspace``); N = 1 + k·L. Variant 1 + j·L + l has parameter j at
  level l and every other parameter nominal.
- ``grid``: full factorial over the same L levels per parameter; N = 1 + L**k. Variant 1 + i takes
  the levels ``numpy.unravel_index(i, (L,)*k)`` (C order, the last parameter varies fastest).

Everything is reproducible from (seed, method, spread) and the perturbed parameters. The random
methods draw in fixed blocks of :data:`BLOCK` variants, each from its own
``SeedSequence(seed, spawn_key=(block,))``, so any range of variants can be generated on its own,
in bounded memory, and the result does not depend on how a run is chunked. Only ``lhs`` draws all
N − 1 points at once (a Latin hypercube is stratified over all of them): N·k floats; and
``saltelli`` (SALib builds its whole design at once).
"""

from __future__ import annotations

import inspect
import warnings

import numpy as np

from ..errors import UserError
from ..mechanism import Mechanism
from ._spec import PERTURB_METHODS, variant_count

#: Rows per independently seeded block of the random samplers.
BLOCK = 4096


def _qmc_engine(name: str, d: int, seed: int):
    """A scipy.stats.qmc engine (``Sobol`` or ``LatinHypercube``) seeded reproducibly (scipy ≥ 1.15
    calls the argument ``rng``, older ones ``seed``). scipy.stats is imported here, on first use: it
    takes seconds to import and only these two methods need it."""
    from scipy.stats import qmc
    cls = getattr(qmc, name)
    params = inspect.signature(cls).parameters
    key = "rng" if "rng" in params else "seed"
    return cls(d=d, scramble=True, **{key: np.random.default_rng(seed)})


class Sampler:
    """Samples of one study design: ``rows(start, stop)`` → (stop − start, k) float64 multipliers
    1 + δ; ``rows(start, stop, offsets=mask)`` gives δ itself in the columns where ``mask`` is True
    (the coordinates), from the same draws.

    method : one of uniform, normal, lhs, sobol, saltelli, oat, grid; variants : the study's ``variants``
    (N for random methods, base points for saltelli, levels per parameter for oat and grid); k : number of perturbed
    parameters; spread : relative (see the module docstring); seed : integer ≥ 0.
    """

    def __init__(self, method: str, variants: int, k: int, spread: float, seed: int = 0):
        if method not in PERTURB_METHODS:
            raise UserError(f"perturb.method: expected one of {', '.join(PERTURB_METHODS)}, got {method!r}")
        if k < 1:
            raise UserError(f"perturb: expected at least one perturbed parameter, got k = {k}")
        self.method, self.variants, self.k, self.spread, self.seed = method, int(variants), int(k), float(spread), int(seed)
        self.n_total = variant_count(method, self.variants, self.k)
        if method == "saltelli":
            _require_salib()  # say so before a results file is created
        self._lhs = None  # the whole design of lhs and saltelli, drawn on first use
        if method in ("oat", "grid"):
            self.levels = np.linspace(1.0 - self.spread, 1.0 + self.spread, self.variants)
            self.offset_levels = np.linspace(-self.spread, self.spread, self.variants)

    def rows(self, start: int = 0, stop: int | None = None, offsets=None) -> np.ndarray:
        """Samples of variants ``start … stop − 1``, shape (stop − start, k): multipliers 1 + δ, or δ in
        the columns where the boolean mask ``offsets`` (k,) is True. Variant 0 is exactly 1 (0 for an
        offset column)."""
        stop = self.n_total if stop is None else min(int(stop), self.n_total)
        start = max(0, int(start))
        off = np.zeros(self.k, dtype=bool) if offsets is None else np.asarray(offsets, dtype=bool).reshape(-1)
        if off.shape != (self.k,):
            raise UserError(f"offsets: expected {self.k} flags, got {off.shape[0]}")
        base = np.where(off, 0.0, 1.0)
        out = np.tile(base, (max(stop - start, 0), 1))
        a = max(start, 1)  # variant 0 stays nominal; variant i ≥ 1 is design point i − 1
        if stop > a:
            out[a - start:] = self._points(a - 1, stop - 1, off, base)
        return out

    def _points(self, a: int, b: int, off: np.ndarray, base: np.ndarray) -> np.ndarray:
        """Design points a … b − 1 (point p is variant p + 1): ``base + spread·draw`` per column (base
        1 for a multiplier, 0 for an offset), the same arithmetic for both."""
        m, s = self.method, self.spread
        if m in ("uniform", "normal"):
            pieces = []
            for blk in range(a // BLOCK, (b - 1) // BLOCK + 1):
                rng = np.random.Generator(np.random.PCG64(np.random.SeedSequence(self.seed, spawn_key=(blk,))))
                lo, hi = max(a - blk * BLOCK, 0), min(b - blk * BLOCK, BLOCK)
                # the block's rows lo … hi − 1 only, the same numbers as drawing it whole (row-major): a
                # uniform draw takes one 64-bit step per number, so rows before lo are skipped by advancing
                # the generator; normal draws take a varying number of steps, so rows 0 … hi − 1 are drawn
                # (a block of 4,096 rows × k parameters cost seconds for a 10-variant study of a big mechanism)
                if m == "uniform":
                    rng.bit_generator.advance(lo * self.k)
                    draw = rng.uniform(-1.0, 1.0, (hi - lo, self.k))
                else:
                    draw = rng.standard_normal((hi, self.k))[lo:]
                pieces.append(draw)
            return base + s * np.concatenate(pieces)
        if m == "sobol":
            eng = _qmc_engine("Sobol", self.k, self.seed)
            if a:
                eng.fast_forward(a)
            with warnings.catch_warnings():  # balance needs powers of two; documented, not nagged per chunk
                warnings.simplefilter("ignore", UserWarning)
                u = eng.random(b - a)
            return base + s * (2.0 * u - 1.0)
        if m == "lhs":
            if self._lhs is None:
                n = self.n_total - 1
                self._lhs = _qmc_engine("LatinHypercube", self.k, self.seed).random(n) if n else np.empty((0, self.k))
            return base + s * (2.0 * self._lhs[a:b] - 1.0)
        if m == "saltelli":
            if self._lhs is None:
                self._lhs = saltelli_design(self.variants, self.k, self.seed)
            return base + s * self._lhs[a:b]
        # oat and grid: the levels of each column's kind (linspace of the multipliers or of the offsets)
        levels = [self.offset_levels if o else self.levels for o in off]
        p = np.arange(a, b)
        out = np.tile(base, (b - a, 1))
        L = self.variants
        if m == "oat":
            j, lev = p // L, p % L
            for col in np.unique(j):
                rows = np.flatnonzero(j == col)
                out[rows, col] = levels[col][lev[rows]]
            return out
        idx = np.unravel_index(p, (L,) * self.k)  # grid
        return np.stack([levels[c][i] for c, i in enumerate(idx)], axis=1) if b > a else out


def _require_salib():
    from .._extras import require
    require("SALib", 'perturb.method = "saltelli"')


def saltelli_design(n: int, k: int, seed: int) -> np.ndarray:
    """Saltelli's design for first-order and total Sobol indices of k parameters: (n·(k + 2), k) points
    in [−1, 1], from ``SALib.sample.sobol.sample`` (``calc_second_order=False``, scrambled, ``seed``).
    SALib is imported here, on first use (the ``sensitivity`` extra)."""
    _require_salib()
    from SALib.sample import sobol as salib_sobol
    problem = {"num_vars": int(k), "names": [f"x{i}" for i in range(k)], "bounds": [[-1.0, 1.0]] * int(k)}
    with warnings.catch_warnings():  # balance needs n a power of two: documented, not nagged
        warnings.simplefilter("ignore", UserWarning)
        return np.asarray(salib_sobol.sample(problem, int(n), calc_second_order=False, scramble=True, seed=int(seed)),
                          dtype=np.float64)


def apply_multipliers(mech: Mechanism, mult: np.ndarray, links=None, crank: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Lengths (n, n_links) in ``mech.links`` order and crank radii (n,) from multipliers (n, k).

    ``links``: names of the perturbed links ("all" or None for every link); their columns come
    first in ``mech.links`` order, then the crank's if ``crank``.
    """
    names = mech.link_names if links in (None, "all") else tuple(links)
    cols = [i for i, n in enumerate(mech.link_names) if n in set(names)]
    n = mult.shape[0]
    if mult.shape[1] != len(cols) + int(crank):
        raise UserError(f"multipliers: expected {len(cols) + int(crank)} columns, got {mult.shape[1]}")
    lengths = np.broadcast_to(mech.lengths, (n, len(mech.links))).copy()
    lengths[:, cols] *= mult[:, :len(cols)]
    radius = np.full(n, float(mech.crank.radius) if mech.crank is not None else np.nan)
    if crank:
        radius *= mult[:, -1]
    return lengths, radius


def sample_variants(mech: Mechanism, variants: int, method: str = "uniform", spread: float = 0.02, seed: int = 0,
                    links="all", crank: bool = True, start: int = 0, stop: int | None = None):
    """Variants ``start … stop − 1`` of a design study on ``mech``.

    Returns (lengths (n, n_links) in ``mech.links`` order, crank radii (n,)), in model units; row 0
    of the full range is the nominal design. ``variants`` is N for the random methods and levels per
    parameter for ``oat`` and ``grid`` (see the module docstring for the total N).
    """
    names = mech.link_names if links == "all" else tuple(links)
    for n in names:
        mech.link_index(n)
    k = len(names) + int(crank)
    mult = Sampler(method, variants, k, spread, seed).rows(start, stop)
    return apply_multipliers(mech, mult, names, crank)


def apply_samples(mech: Mechanism, samples: np.ndarray, names) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The design of n variants from samples (n, k), one column per parameter in ``names`` (in any
    order): a length's column is a multiplier 1 + δ (value = nominal × multiplier), a coordinate's
    column an offset δ (value = nominal + δ × ``mech.size``).

    Returns (lengths (n, n_links) in ``mech.links`` order, crank radii (n,) (NaN for a path driver),
    geometry (n, g)): the coordinate parameters among ``names``, in the order they come there.
    """
    names = tuple(names)
    samples = np.asarray(samples, dtype=np.float64)
    n = samples.shape[0]
    if samples.ndim != 2 or samples.shape[1] != len(names):
        raise UserError(f"samples: expected {len(names)} columns, got shape {samples.shape}")
    nominal = mech.parameters()
    lengths = np.broadcast_to(mech.lengths, (n, len(mech.links))).copy()
    radius = np.full(n, float(mech.crank.radius) if mech.crank is not None else np.nan)
    coords = [j for j, p in enumerate(names) if mech.parameter_kind(p) == "coordinate"]
    geometry = np.empty((n, len(coords)))
    size = mech.size
    index = {p: i for i, p in enumerate(mech.link_names)}
    for j, p in enumerate(names):
        if p == "crank":
            radius = radius * samples[:, j]
        elif p in index:
            lengths[:, index[p]] *= samples[:, j]
    for c, j in enumerate(coords):
        geometry[:, c] = nominal[names[j]] + samples[:, j] * size
    return lengths, radius, geometry


def study_sampler(study) -> Sampler:
    """The :class:`Sampler` of a validated :class:`~explorer.study.Study`."""
    return Sampler(study.perturb_method, study.variants, study.n_parameters, study.spread, study.seed)


def study_variants(study, start: int = 0, stop: int | None = None, sampler: Sampler | None = None):
    """(lengths, crank, geometry) of variants ``start … stop − 1`` of ``study``: lengths (n, n_links)
    in ``mech.links`` order, crank radii (n,), geometry (n, g) of the perturbed coordinates in
    :attr:`~explorer.study.Study.geometry_names` order ((n, 0) when the study moves none). Variant 0
    is the nominal design, exactly."""
    sampler = sampler or study_sampler(study)
    mech = study.mech
    names = study.parameter_names
    offsets = np.array([mech.parameter_kind(p) == "coordinate" for p in names], dtype=bool)
    return apply_samples(mech, sampler.rows(start, stop, offsets), names)
