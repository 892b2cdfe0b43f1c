"""The kernels generated per topology (``explorer.kernels._codegen``) and the dyad arithmetic they share.

* A generated kernel is the general sweep with one plan's blocks written out: on every built-in leg
  (dyads, rigid bodies, a crank or a path driver), with perturbations small enough to turn and large
  enough to fail in every way, its positions, velocities, statuses, failure angles and ends, failing
  blocks and Newton iteration counts equal the general kernel's bit for bit.
* Newton's second correction of a dyad taken without new residuals (``_fast.place_dyad``) keeps the
  tolerance promise: from starts up to a tenth of a link away, the position is within tol of the
  circle–circle intersection computed here with numpy, and two corrections do where the start is
  close, as a predictor's is.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import explorer
from explorer.testing import kernels_codegen as _codegen, kernels_simulate as _simulate
from explorer.kinds import KINDS
from explorer.kinds.dyad import place_dyad
from explorer.testing import STATUS_NOCONV

#: each leg with a spread at which some of its designs turn and some fail
LEGS = {"jansen": 0.25, "klann": 0.12, "arm": 0.25, "geared5bar": 0.6}
#: The generated kernels compared with the general kernel bit for bit: (leg, outputs stored). Each costs
#: a compile of its own (5-15 CPU-s on a 2-core machine, most of this file's time), so not every leg with
#: every set of outputs: a set of legs that, between them, hold every block kind with a generated form
#: and every driver of the built-ins the generator takes, each kind's second derivatives included, and
#: every set of outputs the generator writes differently (positions only, with velocities, with
#: accelerations). The code generated for a leg is its kinds' snippets in plan order around the one
#: template, so a kind checked on one leg is checked on all; test_the_checked_legs_cover_every_kind_driver_and_output
#: derives what must be covered from the kinds and the built-ins and fails when a new one is not.
#: The forces' generated kernel (moving and held bodies) is compared in
#: tests/test_forces.py::test_forces_read_the_sweeps_own_rates.
CHECKED = [("jansen", "positions"), ("jansen", "velocities"), ("jansen", "accelerations"),
           ("klann", "accelerations"), ("arm", "accelerations"), ("geared5bar", "accelerations")]
OUTPUTS = {"positions": dict(velocities=False), "velocities": dict(velocities=True),
           "accelerations": dict(velocities=True, accelerations=True)}
#: at least this many of the 400 designs compared in each regime (about half of what the data hold), so
#: that the bit-for-bit test cannot pass having checked nothing. "swept back": crank cycles that failed
#: and were swept backward from θ = 0 (the arm has no crank).
MINIMUM = {
    "jansen": {"ok": 40, "failed": 150, "swept back": 70},
    "klann": {"ok": 150, "failed": 40, "swept back": 10},
    "arm": {"ok": 100, "failed": 100},
    "geared5bar": {"ok": 150, "failed": 25, "swept back": 20},
}
for _least in MINIMUM.values():
    _least.update({"ok, more iterations than the least": 20, "solved samples": 100 * 180})


def _batch(mech, spread, n, seed, steps=180):
    rng = np.random.default_rng(seed)
    L = mech.lengths * (1 + rng.uniform(-spread, spread, (n, len(mech.links))))
    crank = None if mech.crank is None else mech.crank.radius * (1 + rng.uniform(-spread, spread, n))
    if mech.crank is not None:
        L[0], crank[0] = mech.lengths, mech.crank.radius
    return L, crank


def _features(mech) -> set:
    """What of ``mech`` shapes the code generated for it: its plan's block kinds and its driver."""
    kinds = {f"kind {KINDS[b.kind].NAME}" for b in _simulate.plan_for(mech).blocks}
    return kinds | {"driver crank" if mech.crank is not None else f"driver path {mech.path.kind}"}


def test_the_checked_legs_cover_every_kind_driver_and_output():
    """CHECKED, between its legs, holds every block kind that has a generated form (each also with its
    second derivatives), every driver and kind of every built-in the generator takes, and every set of
    outputs; the built-ins with sliders (SLIDE blocks) the generator refuses. A new kind, driver, built-in
    feature or output the checked legs miss fails here: add a leg (with its LEGS spread and MINIMUM) or
    its outputs to CHECKED."""
    builtin = Path(explorer.__file__).parent / "mechanism" / "builtin"
    mechs = {p.stem: explorer.load_mechanism(p.stem) for p in builtin.glob("*.toml")}
    scalar = {f"kind {k.NAME}" for k in KINDS if k.SCALAR is not None}
    taken = {n for n, m in mechs.items() if {f for f in _features(m) if f.startswith("kind ")} <= scalar}
    refused = set(mechs) - taken
    assert refused == {n for n, m in mechs.items() if m.sliders} == {"slidercrank", "whitworth"}
    for n in refused:
        with pytest.raises(explorer.UserError, match="kernel 'generated'"):
            explorer.simulate_batch(mechs[n], mechs[n].lengths[None], steps=12, kernel="generated")
    need = scalar.union(*(_features(mechs[n]) for n in taken)) | {f"outputs {o}" for o in OUTPUTS}
    have = set().union(*(_features(mechs[n]) | {f"outputs {o}"} for n, o in CHECKED))
    assert need <= have, f"not compared bit for bit with the general kernel: {sorted(need - have)}"
    with_acc = set().union(*(_features(mechs[n]) for n, o in CHECKED if o == "accelerations"))
    assert scalar <= with_acc, f"second derivatives not compared: {sorted(scalar - with_acc)}"
    assert {n for n, _ in CHECKED} == set(LEGS) == set(MINIMUM) and set(LEGS) <= taken


@pytest.mark.slow
@pytest.mark.parametrize("name, outputs", CHECKED)
def test_generated_kernel_equals_the_general_sweep_bit_for_bit(name, outputs):
    """Positions, velocities and accelerations (as ``outputs`` stores them), statuses, failure angles
    and blocks, and Newton iteration counts, of 400 designs of the leg in every regime."""
    _generated_equals_general(name, **OUTPUTS[outputs])


def _generated_equals_general(name, velocities, accelerations=False):
    mech = explorer.load_mechanism(name)
    n = 400
    L, crank = _batch(mech, LEGS[name], n, seed=7)
    kw = dict(vertices="all", velocities=velocities, accelerations=accelerations)
    if name == "jansen":  # the fixed pivot moves too (a constant of the generated code, per design)
        rng = np.random.default_rng(8)
        kw["geometry"] = {"2.x": -38.0 + rng.uniform(-1, 1, n), "2.y": -7.8 + rng.uniform(-1, 1, n)}
    _codegen._BY_TOPOLOGY.clear()
    gen = explorer.simulate_batch(mech, L, crank, 180, kernel="generated", **kw)
    assert len(_codegen._BY_TOPOLOGY) == 1, "the generated kernel was not used"
    ref = explorer.simulate_batch(mech, L, crank, 180, kernel="general", **kw)
    # What was compared: every design, and enough of them in each regime that the test cannot pass
    # having checked nothing: clean cycles, failures, crank cycles swept backward after a failure, and
    # clean cycles whose Newton counts differ (refined steps or extra iterations).
    counts = _regimes(mech, ref)
    assert counts["designs"] == n and len(ref.paths) == len(mech.vertices)
    for regime, least in MINIMUM[name].items():
        assert counts[regime] >= least, (regime, counts)
    np.testing.assert_array_equal(gen.status, ref.status)
    np.testing.assert_array_equal(gen.iterations, ref.iterations)
    np.testing.assert_array_equal(gen.fail_block, ref.fail_block)
    np.testing.assert_array_equal(gen.fail_theta, ref.fail_theta)
    np.testing.assert_array_equal(gen.fail_theta_end, ref.fail_theta_end)
    for v in ref.paths:
        np.testing.assert_array_equal(gen.paths[v], ref.paths[v])
        if velocities:
            np.testing.assert_array_equal(gen.velocities[v], ref.velocities[v])
        if accelerations:
            np.testing.assert_array_equal(gen.accelerations[v], ref.accelerations[v])
    assert bool(gen.velocities) == bool(ref.velocities) == velocities


@pytest.mark.parametrize("velocities", [True, False])
def test_generated_kernel_reports_invalid_lengths_as_the_general_sweep(velocities):
    """The generated kernel writes an invalid design's outputs itself (no _batch._invalid): status
    invalid, NaN rows, no iterations, exactly as the general kernel, around valid designs."""
    mech = explorer.load_mechanism("jansen")
    L = np.repeat(mech.lengths[None], 6, axis=0).astype(float)
    L[1, 2] = -1.0
    L[2, 0] = np.nan
    L[3, 4] = np.inf
    L[4, 1] = 0.0
    _codegen._BY_TOPOLOGY.clear()
    gen = explorer.simulate_batch(mech, L, None, 36, kernel="generated", vertices="all", velocities=velocities)
    assert len(_codegen._BY_TOPOLOGY) == 1, "the generated kernel was not used"
    ref = explorer.simulate_batch(mech, L, None, 36, kernel="general", vertices="all", velocities=velocities)
    invalid = np.array([False, True, True, True, True, False])
    assert ((gen.status != 0) == invalid).all() and (gen.iterations[invalid] == 0).all()
    for field in ("status", "iterations", "fail_block", "fail_theta", "fail_theta_end"):
        np.testing.assert_array_equal(getattr(gen, field), getattr(ref, field), err_msg=field)
    for v in ref.paths:
        assert np.isnan(gen.paths[v][invalid]).all() and not np.isnan(gen.paths[v][~invalid]).any()
        np.testing.assert_array_equal(gen.paths[v], ref.paths[v], err_msg=v)
        if velocities:
            assert np.isnan(gen.velocities[v][invalid]).all()
            np.testing.assert_array_equal(gen.velocities[v], ref.velocities[v], err_msg=v)


def _assert_same(gen, ref):
    for field in ("status", "iterations", "fail_block", "fail_theta", "fail_theta_end"):
        np.testing.assert_array_equal(getattr(gen, field), getattr(ref, field), err_msg=field)
    for group in ("paths", "velocities", "accelerations"):
        assert getattr(gen, group).keys() == getattr(ref, group).keys(), group
        for v, want in getattr(ref, group).items():
            np.testing.assert_array_equal(getattr(gen, group)[v], want, err_msg=f"{group} {v}")


#: each checked leg with the outputs of its last CHECKED kernel (compiled for the test above: no compile more)
REFINED = dict(CHECKED)


@pytest.mark.parametrize("name", REFINED)
def test_generated_kernel_equals_the_general_sweep_where_steps_are_refined_and_newton_gives_up(name):
    """Five samples per cycle (every step refined, many down to the smallest size) and Newton allowed
    two iterations (no-convergence failures): the paths the clean data above do not take."""
    mech = explorer.load_mechanism(name)
    L, crank = _batch(mech, 0.1 if name == "jansen" else LEGS[name], 200, seed=3)
    kw = dict(vertices="all", **OUTPUTS[REFINED[name]])
    noconv = 0
    for steps, maxit in ((5, 50), (36, 2)):
        gen = explorer.simulate_batch(mech, L, crank, steps, kernel="generated", max_iterations=maxit, **kw)
        ref = explorer.simulate_batch(mech, L, crank, steps, kernel="general", max_iterations=maxit, **kw)
        _assert_same(gen, ref)
        assert (ref.status == 0).sum() >= 50
        noconv += int((ref.status == STATUS_NOCONV).sum())
    assert noconv >= 5


def _regimes(mech, b) -> dict:
    clean = b.status == 0
    return {"designs": b.status.shape[0], "ok": int(clean.sum()), "failed": int((~clean).sum()),
            "swept back": int(np.isfinite(b.fail_theta_end).sum()),
            "ok, more iterations than the least": int((b.iterations[clean] > b.iterations[clean].min()).sum()),
            "solved samples": int(np.isfinite(b.paths[mech.foot]).all(axis=2).sum())}


def test_kernel_choice():
    """kernel="auto" takes the generated kernel where it applies and pays (a large job, or within
    compiling_generated()), "general" never does, "generated" where it does not apply is an error; an
    unknown choice is an error."""
    mech = explorer.load_mechanism("jansen")
    one = mech.lengths[None]
    kw = dict(vertices="all", velocities=False)  # CHECKED's kernel (jansen, "positions"): no compile of its own
    _codegen._BY_TOPOLOGY.clear()
    explorer.simulate_batch(mech, one, None, 36, kernel="general", **kw)
    assert not _codegen._BY_TOPOLOGY
    explorer.simulate_batch(mech, one, None, 36, job_configs=explorer.kernels.GENERATED_MIN_CONFIGS, **kw)
    assert len(_codegen._BY_TOPOLOGY) == 1
    with pytest.raises(explorer.UserError, match="kernel"):
        explorer.simulate_batch(mech, one, None, 36, kernel="fast")
    for bad in ("lots", -1, 2.5, True):
        with pytest.raises(explorer.UserError, match="job_configs"):
            explorer.simulate_batch(mech, one, None, 36, job_configs=bad)
    with pytest.raises(explorer.UserError, match="generated"):
        explorer.simulate_batch(mech, one, None, 36, method="dense", kernel="generated")


def _topology_cached(mech, **kw) -> bool:
    """Whether _codegen.is_ready says the generated kernel of simulate_batch(mech, ..., **kw) is ready,
    by catching the topology the call hands it."""
    seen = []
    real = _simulate.is_ready

    def spy(topo, *args):
        seen.append(real(topo, *args))
        return seen[-1]

    _simulate.is_ready = spy
    try:
        explorer.simulate_batch(mech, mech.lengths[None], None, 36, **kw)
    finally:
        _simulate.is_ready = real
    return seen


def test_auto_compiles_a_topology_only_when_the_job_pays_for_it(tmp_path, monkeypatch):
    """A small job on a topology whose generated kernel is not compiled runs the general kernel (nothing
    generated, nothing compiled for the topology); a job of GENERATED_MIN_CONFIGS configurations, or
    any job within compiling_generated() (what ``explorer warm`` runs), generates and compiles it; from
    then on, and in a fresh process through the on-disk cache, small jobs take it too. Same answers."""
    from numba.core import config

    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path))  # a cache of this test's own: nothing cached yet
    mech = explorer.load_mechanism("hoeken")
    L, crank = _batch(mech, 0.05, 5, seed=4)
    _codegen._BY_TOPOLOGY.clear()
    _codegen._LOADED.clear()
    _codegen._NAMES.clear()
    small = explorer.simulate_batch(mech, L, crank, 36, velocities=False)
    assert not _codegen._BY_TOPOLOGY  # the general kernel
    assert _topology_cached(mech, velocities=False) == [False]
    with explorer.kernels.compiling_generated():
        warm = explorer.simulate_batch(mech, L, crank, 36, velocities=False)
    assert len(_codegen._BY_TOPOLOGY) == 1
    np.testing.assert_array_equal(warm.paths[mech.foot], small.paths[mech.foot])
    assert _topology_cached(mech, velocities=False) == [True]  # compiled in this process
    # as a fresh process sees it: only the files in the cache folder
    _codegen._BY_TOPOLOGY.clear()
    _codegen._LOADED.clear()
    assert _topology_cached(mech, velocities=False) == [True]
    assert len(_codegen._BY_TOPOLOGY) == 1  # ... and the call took it
    # another set of outputs is another kernel: not ready, and a large job compiles it
    assert _topology_cached(mech, velocities=True) == [False]
    big = explorer.kernels.GENERATED_MIN_CONFIGS
    assert _topology_cached(mech, velocities=True, job_configs=big) == []  # a large job: no need to ask
    assert len(_codegen._BY_TOPOLOGY) == 2


def test_generated_kernel_is_used_for_dyad_and_body_plans_only(triad):
    mech = explorer.load_mechanism("jansen")
    L, crank = _batch(mech, 0.01, 4, seed=1)
    kw = dict(vertices="all")  # the three kernels of CHECKED's jansen: no compile of their own
    _codegen._BY_TOPOLOGY.clear()
    with explorer.kernels.compiling_generated():
        explorer.simulate_batch(mech, L, crank, 36, velocities=False, **kw)
        assert len(_codegen._BY_TOPOLOGY) == 1
        explorer.simulate_batch(mech, L, crank, 36, velocities=False, **kw)  # memoised: not generated again
        assert len(_codegen._BY_TOPOLOGY) == 1
        explorer.simulate_batch(mech, L, crank, 36, velocities=True, **kw)   # storing velocities: its own kernel
        assert len(_codegen._BY_TOPOLOGY) == 2
        explorer.simulate_batch(mech, L, crank, 36, accelerations=True, **kw)  # accelerations: their own kernel
        assert len(_codegen._BY_TOPOLOGY) == 3
        explorer.simulate_batch(mech, L, crank, 36, method="dense")
        explorer.simulate(triad, 36)  # a coupled (GENERAL) block: the general kernel
        assert len(_codegen._BY_TOPOLOGY) == 3
    folder = _codegen._folder()
    assert len(list(folder.glob("explorer_gen_*.py"))) >= 2


@pytest.mark.slow
def test_threads_share_one_generated_kernel():
    """Threads of one process (a Dask worker's) that ask for the same topology at once get one kernel,
    imported once, and the same answers."""
    from concurrent.futures import ThreadPoolExecutor

    mech = explorer.load_mechanism("jansen")  # CHECKED's (jansen, "positions") kernel: no compile of its own
    L, crank = _batch(mech, 0.05, 8, seed=3)
    _codegen._BY_TOPOLOGY.clear()
    _codegen._LOADED.clear()
    kw = dict(vertices="all", velocities=False, kernel="generated")
    with ThreadPoolExecutor(4) as pool:
        out = list(pool.map(lambda _: explorer.simulate_batch(mech, L, crank, 36, **kw), range(8)))
    assert len(_codegen._BY_TOPOLOGY) == 1 and len(_codegen._LOADED) == 1
    for b in out[1:]:
        np.testing.assert_array_equal(b.paths[mech.foot], out[0].paths[mech.foot])


class _Caught(Exception):
    """Raised by a spy once it holds what it came for: the kernel is neither imported nor compiled."""


def test_generated_source_names_every_block():
    mech = explorer.load_mechanism("klann")
    plan = _simulate.plan_for(mech)
    captured = {}

    def spy(topo, *args):
        captured["src"] = _codegen.source(topo, *args)
        raise _Caught  # the source is what is checked: compiling it is the bit-for-bit tests' job

    from explorer.testing import kernels_simulate as sim
    old = sim.kernel_for
    sim.kernel_for = spy
    try:
        with pytest.raises(_Caught):
            explorer.simulate_batch(mech, mech.lengths[None], None, 36, vertices="all", velocities=False,
                                    kernel="generated")
    finally:
        sim.kernel_for = old
    src = captured["src"]
    compile(src, "generated", "exec")
    for k, blk in enumerate(plan.blocks):
        assert f"# block {k}:" in src
    # one call per dyad, in the loop of whole steps: the batch loop and the rest of the sweep are shared
    assert src.count("place_dyad(") == sum(b.kind == 0 for b in plan.blocks)
    assert "while True" not in src and "valid_lengths" not in src
    assert "vel[sample" not in src


# -- the dyad's Newton and its shortcut against numpy --------------------------------------------------
def _exact(ax, ay, bx, by, da, db, side):
    """The point at da from a and db from b on ``side`` of a → b (numpy, plain formula)."""
    g = np.array([bx - ax, by - ay])
    d2 = g @ g
    x = 0.5 * (da * da - db * db + d2) / d2
    y = side * math.sqrt(da * da / d2 - x * x)
    return np.array([ax + x * g[0] - y * g[1], ay + x * g[1] + y * g[0]])


def _place(a, b, da, db, start, side, tol):
    big = 1e300
    return place_dyad(False, False, 0.0, 0.0, a[0], a[1], b[0], b[1], 0.0, 0.0, 0.0, 0.0,
                      a[0], a[1], b[0], b[1], 0.0, 0.0, 0.0, 0.0, start[0], start[1], 0.0, 0.0, 0.0, 0.0,
                      da * da, db * db, (da + db) ** 2, (da - db) ** 2, big, side, tol * tol, 50)


@pytest.mark.parametrize("seed", range(6))
def test_dyad_newton_keeps_the_tolerance_from_any_nearby_start(seed):
    rng = np.random.default_rng(seed)
    worst = 0.0
    for _ in range(300):
        a = rng.uniform(-50, 50, 2)
        b = a + rng.uniform(10, 60) * np.array([math.cos(t := rng.uniform(0, 2 * math.pi)), math.sin(t)])
        D = np.linalg.norm(b - a)
        da = rng.uniform(0.3, 1.5) * D
        db = rng.uniform(abs(D - da) * 1.02 + 1e-3, (D + da) * 0.98)
        side = rng.choice([-1.0, 1.0])
        p = _exact(*a, *b, da, db, side)
        tol = 10.0 ** rng.uniform(-12, -6) * max(da, db)
        off = 10.0 ** rng.uniform(-7, -1) * min(da, db)
        start = p + off * np.array([math.cos(t := rng.uniform(0, 2 * math.pi)), math.sin(t)])
        code, it, x, y, *_ = _place(a, b, da, db, start, side, tol)
        if code != 0:  # a start beyond the fold's reach may end on the other branch: honest, not wrong
            assert code == 2
            continue
        err = float(np.hypot(x - p[0], y - p[1]))
        worst = max(worst, err / tol)
        assert err <= tol, (err, tol, off, it)
    assert worst < 1.0


def test_dyad_takes_two_corrections_from_a_predictors_distance():
    """From about 1e-6 of the link lengths away (a second-order predictor's error at 1° steps on the
    Jansen leg, where the previous scheme's second correction was within tol 99 % of the time) the
    first Newton step and the correction from its known residual reach the tolerance: two
    iterations, no more."""
    a, b = np.array([0.0, 0.0]), np.array([40.0, 5.0])
    da, db = 30.0, 25.0
    p = _exact(*a, *b, da, db, 1.0)
    tol = 1e-11 * 40
    its = []
    for t in np.linspace(0, 2 * math.pi, 12, endpoint=False):
        start = p + 4e-5 * np.array([math.cos(t), math.sin(t)])
        code, it, x, y, *_ = _place(a, b, da, db, start, 1.0, tol)
        assert code == 0
        assert math.hypot(x - p[0], y - p[1]) <= tol
        its.append(it)
    assert max(its) == 2
