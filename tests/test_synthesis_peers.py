"""benchmarks/bench_synthesis_peers.py poses the literature's four-bar problems to pylinkage's optimisers:
an independent check that both sides pose the same problem (pylinkage's own solver traces the same
coupler path as explorer for a known four-bar, and the two objectives agree), and that pylinkage's
optimisers accept the nine variables with explorer's budget counted."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pylinkage", reason='pylinkage is an optional peer: pip install -e ".[bench]"')

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import _synthesis_problems as problems  # noqa: E402
import bench_synthesis_peers as peers  # noqa: E402

from explorer import simulate  # noqa: E402
from explorer.mechanism import mechanism_from_dict  # noqa: E402

KNOWN = [problems.CONSISTENT_TIMED_FIVE[0][v] for v in problems.VARIABLES]


@pytest.mark.parametrize("sim", ["numba", "python"])
def test_pylinkage_traces_explorers_coupler_path(sim):
    """Sample k of pylinkage's solver (step_fast or step) is explorer's sample k, θ = 2πk/360."""
    linkage = peers.SynthesisFourBar(KNOWN)
    assert linkage.get_constraints() == pytest.approx(KNOWN, abs=0)
    ours = simulate(mechanism_from_dict(problems.fourbar_mechanism_dict(*KNOWN), "known"), 360, tolerance=1e-12)
    assert ours.ok
    theirs = linkage.coupler_path(sim)
    assert theirs is not None and theirs.shape == (360, 2)
    assert np.max(np.abs(theirs - ours.path("P"))) < 1e-6


def test_set_constraints_moves_the_ground_pivots():
    """One linkage re-posed as another design traces that design's path (the pivots x0, y0, r1, θ0 too)."""
    other = [4.0, 1.5, 4.5, 3.0, 1.0, -0.5, 0.7, 1.0, -2.0]
    linkage = peers.SynthesisFourBar(KNOWN)
    linkage.coupler_path()
    linkage.set_constraints(other)
    theta2 = np.arange(360) * 2 * math.pi / 360 - other[6]
    ref = np.array(problems.fourbar_points(*other, theta2, branch=1))
    assert np.max(np.abs(linkage.coupler_path() - ref)) < 1e-9


def test_objectives_agree():
    """pylinkage's fitness and explorer's evaluate: the timed problem's known four-bar at 2.71e-7 on both
    (the prescribed angles are exact samples); the untimed one within polyline-vs-Hermite accuracy."""
    t = problems.TIMED_FIVE
    f = peers.pylinkage_fitness(t)
    theirs = f(peers.pylinkage_linkage(t, KNOWN), KNOWN)
    ours, _ = peers.rescore(t, KNOWN, 360)
    assert theirs == pytest.approx(problems.CONSISTENT_TIMED_FIVE_SUMSQ, rel=1e-2)
    assert abs(theirs - ours) < 1e-12
    v = problems.VERTICAL_LINE
    theirs = peers.pylinkage_fitness(v)(peers.pylinkage_linkage(v, KNOWN), KNOWN)
    ours, _ = peers.rescore(v, KNOWN, 360)
    assert theirs == pytest.approx(ours, rel=1e-3)
    assert f.calls == 1


def test_unassemblable_design_is_infeasible_on_both_sides():
    """A crank longer than the others can reach cannot turn: +inf for pylinkage, inf for explorer."""
    bad = [1.0, 4.0, 1.0, 1.0, 0.5, 0.5, 0.0, 0.0, 0.0]
    t = problems.TIMED_FIVE
    assert peers.pylinkage_fitness(t)(peers.pylinkage_linkage(t, bad), bad) == math.inf
    assert peers.rescore(t, bad, 360)[0] == math.inf


@pytest.mark.parametrize("method", ["de", "pso"])
def test_optimisers_take_nine_variables_and_the_budget(method):
    """pylinkage's DE and PSO run on the nine variables within the bounds, population x generations
    evaluations exactly, and return a design their fitness scored."""
    t = problems.TIMED_FIVE
    score, calls, wall, x = peers.run_pylinkage(t, method, 10, 3, seed=2, steps=360)
    assert calls == 30
    lo, hi = peers.ours.bounds(t)
    assert x.shape == (9,) and np.all(x >= lo) and np.all(x <= hi)
    assert score == peers.pylinkage_fitness(t)(peers.pylinkage_linkage(t, x), list(x))
