"""A design is assembled at its first sample on the nominal's branch, however far its dimensions are
from the nominal's.

The truth is a plain-numpy four-bar: A on the crank circle, B the intersection of the circles about A
(coupler) and B0 (rocker) on the nominal's side of the line A → B0, P the intersection of the circles
about A and B on the nominal's side of A → B, at every sample. Designs with the pivots moved and the
links changed by up to ±35 % that this truth turns through a whole cycle with margin must come out
"ok" from one batch that starts every design at the nominal (as an optimiser's population does), with
the truth's coupler path. (When the first Newton solve started from the nominal's configuration, a
design whose root lay far from it could converge to the mirror root at θ = 0 and be reported as a
branch failure: 25 of the designs below that turn were.)
"""

from __future__ import annotations

import numpy as np
import pytest

import explorer

S = 360
N = 400


def _side(a, b, p):
    return np.sign((b[..., 0] - a[..., 0]) * (p[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (p[..., 0] - a[..., 0]))


def _circles(a, b, ra, rb, side):
    """Intersection of the circles about a (radius ra) and b (rb) on ``side`` of a → b; NaN where none.
    a, b (..., 2); returns (..., 2) and the slack min(ra + rb − d, d − |ra − rb|) (..., )."""
    g = b - a
    d2 = np.sum(g * g, axis=-1)
    d = np.sqrt(d2)
    slack = np.minimum(ra + rb - d, d - np.abs(ra - rb))
    with np.errstate(invalid="ignore"):
        x = 0.5 * (ra * ra - rb * rb + d2) / d2
        y = side * np.sqrt(ra * ra / d2 - x * x)
    p = np.stack([a[..., 0] + x * g[..., 0] - y * g[..., 1], a[..., 1] + x * g[..., 1] + y * g[..., 0]], axis=-1)
    return p, slack


@pytest.mark.slow
def test_far_designs_start_on_the_nominal_branch():
    mech = explorer.load_mechanism("fourbar")
    names = list(mech.link_names)
    nominal = explorer.simulate(mech, S, velocities=False)
    B0n = np.array([30.0, 0.0])
    An, Bn, Pn = (nominal.path(v)[0] for v in ("A", "B", "P"))
    sB, sP = _side(An, B0n, Bn), _side(An, Bn, Pn)  # the nominal's branch of each dyad

    rng = np.random.default_rng(5)
    L = mech.lengths * (1 + rng.uniform(-0.35, 0.35, (N, len(names))))
    r = 10.0 * (1 + rng.uniform(-0.35, 0.35, N))
    geometry = {"crank.x": rng.uniform(-5, 5, N), "crank.y": rng.uniform(-5, 5, N),
                "B0.x": 30.0 + rng.uniform(-8, 8, N), "B0.y": rng.uniform(-8, 8, N)}
    batch = explorer.simulate_batch(mech, L, r, S, geometry=geometry, vertices=["P"], velocities=False)

    th = 2 * np.pi * np.arange(S) / S
    c = np.stack([geometry["crank.x"], geometry["crank.y"]], axis=-1)[:, None, :]
    A = c + r[:, None, None] * np.stack([np.cos(th), np.sin(th)], axis=-1)[None]
    B0 = np.stack([geometry["B0.x"], geometry["B0.y"]], axis=-1)[:, None, :] + 0 * A
    col = {n: L[:, names.index(n)][:, None] for n in names}
    B, slackB = _circles(A, B0, col["coupler"], col["rocker"], sB)
    P, slackP = _circles(A, B, col["A-P"], col["B-P"], sP)
    size = L.max(axis=1)[:, None]
    turns = (np.minimum(slackB, slackP) > 0.02 * size).all(axis=1)  # assembles everywhere, with margin
    assert 100 < turns.sum() < N  # the sample holds designs far from the nominal that turn, and ones that do not
    ok = batch.status == 0
    assert ok[turns].all(), f"{(~ok[turns]).sum()} designs that turn on the nominal's branch were not ok"
    err = np.abs(batch.paths["P"][turns] - P[turns]).max()
    assert err < 1e-8 * L.max()
    # and none is refused for the branch at the first sample: designs that cannot assemble there say so
    at_start = (batch.status != 0) & (batch.fail_theta == 0.0)
    assert (batch.status[at_start] == 1).all()
