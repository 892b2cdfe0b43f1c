"""Samplers: reproducibility, bounds, variant 0 nominal, chunk independence, and scipy.stats.qmc use."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc

from explorer import load_mechanism, sample_variants
from explorer.study import BLOCK, Sampler, load_study, study_variants

RANDOM = ("uniform", "normal", "lhs", "sobol")
ALL = RANDOM + ("oat", "grid")


def sampler(method, spread=0.05, seed=11, k=4):
    return Sampler(method, 4 if method in ("oat", "grid") else 300, k, spread, seed)


@pytest.mark.parametrize("method", ALL)
def test_variant_0_is_nominal_and_shapes(method):
    s = sampler(method)
    m = s.rows()
    assert m.shape == (s.n_total, 4)
    assert np.array_equal(m[0], np.ones(4))


@pytest.mark.parametrize("method", ALL)
def test_reproducible_from_seed_method_spread(method):
    a = sampler(method).rows()
    b = sampler(method).rows()
    assert np.array_equal(a, b)
    if method in RANDOM:
        assert not np.array_equal(a, sampler(method, seed=12).rows())
    assert not np.array_equal(a, sampler(method, spread=0.06).rows())


@pytest.mark.parametrize("method", ALL)
def test_any_range_is_the_same_rows(method):
    """Chunked generation equals one-shot generation whatever the cut points (resume relies on it)."""
    s = sampler(method)
    full = s.rows()
    cuts = [0, 1, 2, 37, 128, 129, s.n_total]
    pieces = [sampler(method).rows(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if a < s.n_total]
    assert np.array_equal(np.concatenate(pieces), full[:cuts[-1]])


def test_random_blocks_do_not_depend_on_the_chunking():
    s = Sampler("uniform", 3 * BLOCK + 5, 3, 0.02, 5)
    full = s.rows()
    assert np.array_equal(s.rows(BLOCK - 3, BLOCK + 9), full[BLOCK - 3:BLOCK + 9])


@pytest.mark.parametrize("method", ("uniform", "lhs", "sobol", "oat", "grid"))
def test_bounds(method):
    m = sampler(method, spread=0.05).rows()
    assert m.min() >= 0.95 - 1e-15 and m.max() <= 1.05 + 1e-15
    assert m[1:].std() > 0.01  # actually spread out


def test_uniform_fills_the_interval():
    m = Sampler("uniform", 20000, 2, 0.1, 0).rows()[1:]
    assert m.min() < 0.901 and m.max() > 1.099
    assert abs(m.mean() - 1.0) < 0.002


def test_normal_sigma_and_not_clipped():
    m = Sampler("normal", 20001, 2, 0.1, 0).rows()[1:]
    assert abs(m.std() - 0.1) < 0.003 and abs(m.mean() - 1.0) < 0.003
    # a huge sigma gives non-positive multipliers: kept (the kernels mark such variants "invalid")
    wide = Sampler("normal", 2001, 3, 0.9, 0).rows()
    assert (wide <= 0).any()


def test_sobol_is_scipy_qmc():
    k, seed, spread = 5, 9, 0.04
    m = Sampler("sobol", 257, k, spread, seed).rows()
    try:
        eng = qmc.Sobol(d=k, scramble=True, rng=np.random.default_rng(seed))
    except TypeError:  # scipy < 1.15
        eng = qmc.Sobol(d=k, scramble=True, seed=np.random.default_rng(seed))
    u = eng.random_base2(8)
    assert np.array_equal(m[1:], 1.0 + spread * (2.0 * u - 1.0))


def test_lhs_is_scipy_qmc_and_stratified():
    k, seed, n = 3, 4, 100
    m = Sampler("lhs", n + 1, k, 0.1, seed).rows()
    try:
        eng = qmc.LatinHypercube(d=k, rng=np.random.default_rng(seed))
    except TypeError:
        eng = qmc.LatinHypercube(d=k, seed=np.random.default_rng(seed))
    assert np.array_equal(m[1:], 1.0 + 0.1 * (2.0 * eng.random(n) - 1.0))
    u = (m[1:] - 0.9) / 0.2  # back to [0, 1): one point per stratum in every column
    for j in range(k):
        assert sorted(np.floor(u[:, j] * n).astype(int)) == list(range(n))


def test_oat_structure():
    L, k, s = 5, 3, 0.1
    m = Sampler("oat", L, k, s, 0).rows()
    assert m.shape == (1 + k * L, k)
    levels = np.linspace(1 - s, 1 + s, L)
    for j in range(k):
        block = m[1 + j * L:1 + (j + 1) * L]
        assert np.array_equal(block[:, j], levels)
        assert np.all(np.delete(block, j, axis=1) == 1.0)


def test_grid_is_full_factorial():
    L, k = 3, 4
    m = Sampler("grid", L, k, 0.1, 0).rows()
    assert m.shape == (1 + L ** k, k)
    assert len({tuple(r) for r in m[1:]}) == L ** k
    assert set(np.unique(m[1:])) == set(np.linspace(0.9, 1.1, L))


def test_sample_variants_maps_to_lengths():
    mech = load_mechanism("jansen")
    L, c = sample_variants(mech, 50, "uniform", 0.02, seed=1, links=["2-6", "1-3"], crank=False)
    assert L.shape == (50, len(mech.links)) and c.shape == (50,)
    assert np.array_equal(L[0], mech.lengths) and c[0] == mech.crank.radius
    moved = [mech.link_index("1-3"), mech.link_index("2-6")]
    still = [i for i in range(len(mech.links)) if i not in moved]
    assert np.all(L[:, still] == mech.lengths[still]) and np.all(c == mech.crank.radius)
    rel = L[1:, moved] / mech.lengths[moved]
    assert np.all(np.abs(rel - 1) <= 0.02) and np.all(rel != 1)
    # the order of the names does not matter (columns follow mech.links)
    L2, _ = sample_variants(mech, 50, "uniform", 0.02, seed=1, links=["1-3", "2-6"], crank=False)
    assert np.array_equal(L, L2)


def test_study_variants_match_default_study_head():
    study = load_study()
    L, c, G = study_variants(study, 0, 8)
    assert G.shape == (8, 0)  # the default study moves no coordinate
    assert np.array_equal(L[0], study.mech.lengths) and c[0] == study.mech.crank.radius
    assert np.all(np.abs(L[1:] / study.mech.lengths - 1) <= 0.02)
    assert np.all(np.abs(c[1:] / study.mech.crank.radius - 1) <= 0.02)
