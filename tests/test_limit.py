"""The benchmarks' speed limit (benchmarks/_limit.py) computes what explorer computes: its vectorised
branch-free closed form against explorer's block Newton results, to 1e-11 of the longest link; and the
compiled code is the vectorised one (packed divisions and square roots)."""

from __future__ import annotations

import platform
import sys
from pathlib import Path

import numpy as np
import pytest

import explorer

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _limit  # noqa: E402
from _timing import variants  # noqa: E402


def test_limit_equals_newton_to_1e_11_of_the_longest_link():
    mech = explorer.load_mechanism("jansen")
    lengths, crank = variants(mech, 400, spread=0.05)
    x, y = _limit.foot_limit(lengths, crank, 360)
    b = explorer.simulate_batch(mech, lengths, crank, 360, velocities=False)
    ok = b.status == 0
    assert 50 < ok.sum() < len(ok)  # some variants fail at ±5 %: the comparison sees both kinds
    foot = b.paths[mech.foot]
    longest = np.maximum(lengths.max(axis=1), crank)
    err = np.maximum(np.abs(x - foot[..., 0]), np.abs(y - foot[..., 1])).max(axis=1)
    assert (err[ok] <= 1e-11 * longest[ok]).all(), err[ok].max() / longest[ok].min()
    # where Newton reports that a variant cannot assemble, the limit has NaN samples (no check, no branch
    # test: the square root of a negative number)
    asm = b.status == {v: k for k, v in explorer.STATUS_NAMES.items()}["assembly"]
    assert asm.any()
    assert np.isnan(x[asm]).any(axis=1).all()


def test_scalar_form_is_the_same_arithmetic():
    mech = explorer.load_mechanism("jansen")
    lengths, crank = variants(mech, 50)
    x, y = _limit.foot_limit(lengths, crank, 72)
    out = _limit.foot_scalar(lengths, crank, 72)
    np.testing.assert_allclose(x, out[..., 0], atol=1e-11 * lengths.max(), equal_nan=True)
    np.testing.assert_allclose(y, out[..., 1], atol=1e-11 * lengths.max(), equal_nan=True)


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="reads x86 machine code")
def test_limit_is_vectorised_and_the_old_form_is_not():
    _limit.foot_limit(np.ones((1, 10)) * 40.0, np.ones(1) * 15.0, 8)
    _limit.foot_scalar(np.ones((1, 10)) * 40.0, np.ones(1) * 15.0, 8)
    (vec,) = _limit.vector_width(_limit.jansen_foot_vec).values()
    (sca,) = _limit.vector_width(_limit.jansen_foot_scalar).values()
    packed_sqrt = sum(n for k, n in vec.items() if k.startswith("vsqrtpd"))
    packed_div = sum(n for k, n in vec.items() if k.startswith("vdivpd"))
    assert packed_sqrt >= _limit.SQRTS and packed_div >= _limit.DIVS, vec
    assert not any(k.startswith(("vsqrtpd", "vdivpd")) for k in sca), sca


def test_probe_and_ceiling():
    rates = _limit.probe(threads=1, n=256, reps=200, repeat=1)
    assert rates["div"] > 1e6 and rates["sqrt"] > 1e6
    c = _limit.ceiling(rates)
    assert c == pytest.approx(1.0 / (_limit.DIVS / rates["div"] + _limit.SQRTS / rates["sqrt"]))
