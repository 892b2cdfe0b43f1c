"""Big mechanisms (issue 31 item 6): a chain of hundreds of dyads plans in linear time and solves on
the general kernel with memory linear in its size; what cannot fit is refused with one line and an
estimate. (Time and memory per size: ``python benchmarks/bench_size.py``.)"""

import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import explorer
from explorer.errors import UserError
from explorer.kernels import plan_for
from explorer.testing import kernels_codegen as _codegen, kernels_simulate as _simulate
from explorer.mechanism import mechanism_from_dict
from explorer.plan import DYAD, make_plan
from explorer.testing import plan_blt as _blt

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
sys.path.insert(0, str(BENCH))
from bench_size import chain_dict, ring_dict  # noqa: E402


def _circles(a, b, ra, rb, side):
    """The point at ra from a and rb from b on ``side`` (±1) of the line a → b."""
    g = b - a
    d = math.hypot(*g)
    x = (ra * ra - rb * rb + d * d) / (2 * d)
    y = math.sqrt(ra * ra - x * x)
    u = g / d
    return a + x * u + side * y * np.array([-u[1], u[0]])


def reference_chain(table: dict, theta: np.ndarray) -> dict:
    """Every moving vertex of a ``chain_dict`` mechanism at each angle, built stage by stage by
    circle–circle intersections, each on the side of its parents (previous vertex → pivot) that its
    guess takes at θ = 0."""
    crank = table["crank"]
    c, r = np.array(crank["center"]), crank["radius"]
    lengths = {(lk["a"], lk["b"]): lk["length"] for lk in table["links"]}
    out = {}
    prev = np.stack([c[0] + r * np.cos(theta), c[1] + r * np.sin(theta)], axis=1)
    prev_name = "t"
    for k in range(1, len(table["fixed"]) + 1):
        g = np.array(table["fixed"][f"g{k}"])
        guess = np.array(table["guess"][f"m{k}"])
        d = prev[0] - g
        side = 1.0 if (g - prev[0])[0] * (guess - prev[0])[1] - (g - prev[0])[1] * (guess - prev[0])[0] > 0 else -1.0
        assert abs(d[0]) + abs(d[1]) > 0
        ra, rb = lengths[(prev_name, f"m{k}")], lengths[(f"g{k}", f"m{k}")]
        pts = np.array([_circles(p, g, ra, rb, side) for p in prev])
        out[f"m{k}"] = pts
        prev, prev_name = pts, f"m{k}"
    return out


def test_a_chain_of_hundreds_of_dyads_plans_into_dyads_in_linear_time():
    mech = mechanism_from_dict(chain_dict(2001))
    plan = make_plan(mech)
    assert plan.n_blocks == 1000 and all(b.kind == DYAD for b in plan.blocks)
    # each stage after the previous one: the plan is the construction order
    assert [mech.vertices[b.vertices[0]] for b in plan.blocks] == [f"m{k}" for k in range(1, 1001)]
    assert all(b.depends == ((k - 1,) if k else ()) for k, b in enumerate(plan.blocks))


def test_matching_with_the_lookahead_finds_the_same_blocks(monkeypatch):
    """The look-ahead (above PLAIN_MATCHING_MAX unknowns) finds another matching of the same size:
    the same blocks, in an order that respects their dependencies."""
    for table in (chain_dict(41), ring_dict(41)):
        mech = mechanism_from_dict(table)
        plain = make_plan(mech)
        monkeypatch.setattr(_blt, "PLAIN_MATCHING_MAX", 0)
        ahead = make_plan(mech)
        monkeypatch.undo()
        key = [(b.vertices, b.links, b.kind, b.attaches) for b in plain.blocks]
        assert sorted(key) == sorted((b.vertices, b.links, b.kind, b.attaches) for b in ahead.blocks)
        assert all(d < k for k, b in enumerate(ahead.blocks) for d in b.depends)


def test_a_chain_of_301_vertices_solves_as_the_sequential_construction():
    table = chain_dict(301)
    mech = mechanism_from_dict(table)
    assert len(mech.vertices) == 301 and plan_for(mech).n_blocks == 150
    generated = len(_codegen._BY_TOPOLOGY)
    cyc = explorer.simulate(mech, steps=36)
    assert cyc.ok, cyc.failure
    ref = reference_chain(table, cyc.theta)
    tol = 1e-9 * mech.size
    worst = max(np.max(np.abs(cyc.path(v) - p)) for v, p in ref.items())
    assert worst <= tol, worst
    # a batch: the nominal and a copy, every vertex
    with explorer.kernels.compiling_generated():  # "auto" would generate any topology it may: not this one
        batch = explorer.simulate_batch(mech, np.vstack([mech.lengths] * 2), steps=36, vertices="all")
    assert list(batch.status) == [0, 0]
    for v, p in ref.items():
        np.testing.assert_allclose(batch.paths[v][1], p, rtol=0, atol=tol)
    # 150 blocks is beyond GENERATED_MAX_BLOCKS: kernel "auto" took the general kernel, no compile per topology
    assert plan_for(mech).n_blocks > _simulate.GENERATED_MAX_BLOCKS
    assert len(_codegen._BY_TOPOLOGY) == generated


def test_a_big_coupled_block_solves():
    """One coupled block of 100 vertices (a ring of spokes): Newton on it with scratch of its size."""
    mech = mechanism_from_dict(ring_dict(201))
    plan = plan_for(mech)
    assert plan.n_blocks == 1 and len(plan.blocks[0].vertices) == 100
    cyc = explorer.simulate(mech, steps=36)
    assert cyc.ok, cyc.failure
    # every link keeps its length at every sample
    P = cyc.positions
    for lk in mech.links:
        d = np.hypot(*(P[:, mech.vertex_index(lk.b)] - P[:, mech.vertex_index(lk.a)]).T)
        assert np.max(np.abs(d - lk.length)) <= 1e-9 * mech.size


def test_solving_a_chain_of_1001_vertices_stays_within_modest_memory(tmp_path):
    """In a fresh process capped at 3 GB of address space: load, plan, simulate and a batch of 10
    designs of a 1,001-vertex chain (the issue: killed at 24 GB)."""
    code = textwrap.dedent(f"""
        import resource, sys
        sys.path.insert(0, {str(BENCH)!r})
        import numpy as np, explorer
        from explorer.mechanism import mechanism_from_dict
        from bench_size import chain_dict
        base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        mech = mechanism_from_dict(chain_dict(1001))
        cyc = explorer.simulate(mech, steps=36)
        b = explorer.simulate_batch(mech, np.vstack([mech.lengths] * 10), steps=36)
        grew = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) / 1024
        print(cyc.ok, int((b.status == 0).sum()), round(grew))
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    ok, n_ok, grew = out.stdout.split()
    assert ok == "True" and n_ok == "10"
    assert int(grew) < 500, f"peak RSS grew {grew} MB"


def test_the_dense_method_is_refused_with_an_estimate_where_it_cannot_fit(monkeypatch):
    mech = mechanism_from_dict(chain_dict(301))
    monkeypatch.setattr(_simulate, "available_memory", lambda: 10**6)
    with pytest.raises(UserError) as exc:
        explorer.simulate(mech, steps=36, method="dense")
    msg = str(exc.value)
    assert "\n" not in msg and "method 'dense'" in msg and "301 vertices" in msg
    assert "need about" in msg and "MB" in msg and "1.0 MB is available" in msg and "'block'" in msg
    with pytest.raises(UserError, match="method 'dense'"):
        explorer.simulate_batch(mech, mech.lengths[None], steps=36, method="dense")
    # the block method needs no full-system matrix
    assert explorer.simulate(mech, steps=36).ok


def test_outputs_that_cannot_fit_are_refused_with_an_estimate(monkeypatch):
    mech = mechanism_from_dict(chain_dict(101))
    monkeypatch.setattr(_simulate, "available_memory", lambda: 10**8)
    lengths = np.vstack([mech.lengths] * 1000)
    with pytest.raises(UserError) as exc:
        explorer.simulate_batch(mech, lengths, steps=360, vertices="all")
    msg = str(exc.value)
    # 1,000 x 360 x 101 x 2 doubles, positions and velocities: 1.16 GB
    assert "\n" not in msg and "1,000 variants x 360 steps x 101 vertices" in msg
    assert "need about 1.2 GB of memory and 100.0 MB is available" in msg
    # the foot alone fits
    assert explorer.simulate_batch(mech, lengths[:20], steps=36).status.tolist() == [0] * 20


def test_forces_are_solved_in_chunks_that_fit():
    assert _simulate.force_chunk(360, 7) == _simulate.FORCE_CHUNK  # the built-in legs: unchanged
    rows = _simulate.force_chunk(360, 1001)
    assert 1 <= rows < _simulate.FORCE_CHUNK and rows * 360 * 1001 * 16 <= _simulate.FORCE_MEMORY
    assert _simulate.force_chunk(360, 10**7) == 1


def test_a_study_refused_for_memory_writes_no_file(monkeypatch, tmp_path):
    """A dense study that cannot fit is refused before its results file is made (it used to leave an empty
    file behind)."""
    study = {"study": {"name": "big", "mechanism": "jansen", "variants": 3, "steps": 12, "method": "dense"},
             "perturb": {"spread": 0.01}}
    monkeypatch.setattr(_simulate, "available_memory", lambda: 10)
    out = tmp_path / "big.h5"
    with pytest.raises(UserError, match="method 'dense'"):
        explorer.run_study(study, output=out, progress=False)
    assert not out.exists()
