"""The forces effect's base leg generated per topology (explorer/kernels/_forces_scalar.py) against the
table-driven one, and against the independent Newton–Euler model of the whole walker.

The generated code writes the table-driven base leg's arithmetic out in scalars, operation for
operation, so every stored forces output (torque, leg 0's joint reactions, every member's force on
every pin, the pin peaks and the other metrics, statuses, the failing sample and block) must be the
same bit for bit, held and moving, with and without drag, on legs with rigid bodies and on designs at
a toggle (where the singular check must stop at the same sample and block). The table-driven base leg
is itself checked against plain references in tests/test_forces.py and tests/test_forces_moving.py;
the generated one is checked against the Newton–Euler model here too.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest

import explorer
from explorer.testing import kernels_codegen as _codegen, kernels_simulate as _simulate

REPO = Path(__file__).resolve().parents[1]
PLYWOOD = REPO / "studies" / "mechanisms" / "jansen-plywood.toml"
OP = {"unit": 0.01, "rpm": 30.0, "gravity": 9.81, "load": 8.0}


def _both(mech, lengths, crank, steps, **kw):
    """simulate_batch with forces by the generated kernel (its base leg generated) and by the general one."""
    _codegen._BY_TOPOLOGY.clear()
    gen = explorer.simulate_batch(mech, lengths, crank, steps, forces=True, kernel="generated", **kw)
    src = [_codegen.source(*key) for key in _generated_sources()]
    assert any("def base_leg(" in s for s in src), "the generated base leg was not used"
    ref = explorer.simulate_batch(mech, lengths, crank, steps, forces=True, kernel="general", **kw)
    return gen, ref


_SEEN: list = []


def _generated_sources():
    return list(_SEEN)


@pytest.fixture(autouse=True)
def _spy(monkeypatch):
    """Record the arguments of every generated kernel simulate_batch asks for."""
    _SEEN.clear()
    real = _simulate.kernel_for

    def spy(topo, *args):
        _SEEN.append((topo, *args))
        return real(topo, *args)

    monkeypatch.setattr(_simulate, "kernel_for", spy)


def _assert_same(gen, ref):
    np.testing.assert_array_equal(gen.status, ref.status)
    np.testing.assert_array_equal(gen.torque, ref.torque)
    assert set(gen.forces) == set(ref.forces) and gen.forces
    for j in ref.forces:
        np.testing.assert_array_equal(gen.forces[j], ref.forces[j], err_msg=j)
    assert set(gen.force_metrics) == set(ref.force_metrics)
    for k in ref.force_metrics:
        np.testing.assert_array_equal(gen.force_metrics[k], ref.force_metrics[k], err_msg=k)
    for v in ref.paths:
        np.testing.assert_array_equal(gen.paths[v], ref.paths[v])
        np.testing.assert_array_equal(gen.velocities[v], ref.velocities[v])


def _designs(mech, n, spread, seed):
    rng = np.random.default_rng(seed)
    lengths = mech.lengths * (1 + rng.uniform(-spread, spread, (n, len(mech.links))))
    crank = mech.crank.radius * (1 + rng.uniform(-spread, spread, n))
    return lengths, crank


@pytest.mark.slow
@pytest.mark.parametrize("body,drag", [("moving", 0.0), ("moving", 0.1), ("held", 0.0), ("held", 0.1)])
def test_generated_base_leg_equals_the_table_driven_one_on_the_plywood_walker(body, drag):
    mech = explorer.load_mechanism(PLYWOOD)
    walker = dataclasses.replace(mech.walker, drag=drag)
    lengths, crank = _designs(mech, 80, 0.03, seed=11)
    gen, ref = _both(mech, lengths, crank, 360, operating={"body": body}, walker=walker,
                     force_joints=list(mech.vertices))
    ok = ref.status == 0
    assert 30 <= ok.sum() < len(ok)  # solved designs and failed ones, both compared
    assert np.isfinite(ref.torque[ok]).all() and np.isfinite(ref.force_metrics["pin_force_max"][ok]).all()
    _assert_same(gen, ref)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["klann"])
def test_generated_base_leg_equals_the_table_driven_one_on_the_built_in_legs(name):
    """Klann's leg has rigid bodies (attach blocks, the bodies' inertia loads); odd phases read between
    samples on three legs. (One leg: each compiles its own generated forces kernel.)"""
    mech = explorer.load_mechanism(name)
    lengths, crank = _designs(mech, 64, 0.02, seed=5)
    walker = explorer.mechanism.Walker(legs=3, phases=(0.0, 2.0, 4.0), mirrored=(False, True, False))
    for body in ("moving", "held"):
        gen, ref = _both(mech, lengths, crank, 120, operating=dict(OP, body=body), walker=walker,
                         force_joints=list(mech.vertices))
        assert (ref.status == 0).sum() >= 32
        _assert_same(gen, ref)


@pytest.mark.slow
def test_the_generated_base_leg_stops_at_the_same_singular_sample_and_block():
    """A dyad made singular at one sample (its joint moved onto its parents' line, and at another sample
    to within 1e-15 of it): the generated base leg reports the same block and sample as the table-driven
    one, and both fill the same incidence forces, torques and frame forces up to there."""
    from explorer.testing import kernels_forces as _forces

    mech = explorer.load_mechanism(PLYWOOD)
    cap = {}
    real = _simulate.parallel_rows

    def spy(fn, shared, rows, threads=None):
        cap["args"] = (fn, shared, rows)
        return real(fn, shared, rows, threads)

    _simulate.parallel_rows = spy
    try:
        explorer.simulate_batch(mech, mech.lengths[None], None, 72, forces=True, kernel="generated")
    finally:
        _simulate.parallel_rows = real
    fn, (topo, _, _, _, fm), (des, _, fr) = cap["args"]
    leg = sys.modules[fn.whole.py_func.__module__].base_leg  # the generated module (its loop of whole steps)
    allv = explorer.simulate_batch(mech, mech.lengths[None], None, 72, vertices="all", accelerations=True,
                                   kernel="general")
    names = list(mech.vertices)
    P = np.stack([allv.paths[v][0] for v in names], axis=1)
    A = np.stack([allv.accelerations[v][0] for v in names], axis=1)
    dyads = [k for k in range(topo.kind.shape[0]) if topo.kind[k] == 0]
    for k, u, off in ((dyads[2], 40, 0.0), (dyads[-1], 7, 1e-15), (dyads[0], 0, 0.0)):
        v, a, b = (int(x) for x in topo.blk[k, :3])
        out = []
        for base_leg in (leg, _forces.base_leg_fast):
            fs = _forces.force_scratch(72, len(names), fm, topo)
            fs.pos[:] = P
            fs.acc[:] = A
            fs.pos[u, v] = P[u, a] + 0.37 * (P[u, b] - P[u, a]) + off
            nrhs, Fx, Fy, walk, weightless, grid = _forces._forces_setup(0, fm, fr, fs, topo)
            got = base_leg(0, des.table[0], topo, des.uv[0], des.slide[0], des.center[0, 0], des.center[0, 1], fm,
                           fr, fs, nrhs, Fx, weightless)
            out.append((got, fs.Fi[:u].copy(), fs.tau[:u].copy(), fs.frame[:u].copy()))
        assert out[0][0] == out[1][0] == (k, u)
        for x, y in zip(out[0][1:], out[1][1:]):
            np.testing.assert_array_equal(x, y)


@pytest.mark.slow
def test_generated_forces_against_the_newton_euler_model():
    """The plywood walker's nominal through the generated forces kernel: every member force of leg 0, the
    torque, the body's acceleration, the ground force and every pin's peak against the whole-machine
    Newton–Euler system of tests/naive_forces.py (the moving model's reference test, run generated)."""
    import test_forces_moving as ref_test

    with _simulate.compiling_generated():
        ref_test.test_jansen_walker_against_a_newton_euler_model_of_the_whole_machine()
    assert any("def base_leg(" in _codegen.source(*key) for key in _SEEN), "the generated base leg was not used"
