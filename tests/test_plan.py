"""make_plan: block-lower-triangular order, checked against the link graph itself (brute force)."""

from __future__ import annotations

import numpy as np
import pytest

import naive
from explorer import UserError, load_mechanism, make_plan, simulate, simulate_batch
from explorer.mechanism import mechanism_from_dict
from explorer.plan import DYAD, GENERAL


def check_plan(mech, plan):
    """Every structural property a plan must have, recomputed from mech.links."""
    names = mech.vertices
    grounded = {mech.vertex_index(mech.crank.tip), *(mech.vertex_index(v) for v in mech.fixed)}
    free = {mech.vertex_index(v) for v in mech.guess}
    # blocks partition the unknown vertices and the links
    placed_by = {}
    for k, b in enumerate(plan.blocks):
        for v in b.vertices:
            assert v not in placed_by and v in free
            placed_by[v] = k
    assert set(placed_by) == free
    all_links = [e for b in plan.blocks for e in b.links]
    assert sorted(all_links) == list(range(len(mech.links)))
    for k, b in enumerate(plan.blocks):
        assert len(b.links) == 2 * len(b.vertices)
        parents = set()
        for e in b.links:
            ends = {mech.vertex_index(mech.links[e].a), mech.vertex_index(mech.links[e].b)}
            assert ends & set(b.vertices), f"block {k} holds link {e} that places none of its vertices"
            for u in ends - set(b.vertices):
                assert u in grounded or placed_by[u] < k, (
                    f"block {k} reads vertex {names[u]} which is placed later (block {placed_by.get(u)})")
                if u not in grounded:
                    parents.add(placed_by[u])
        assert set(b.depends) == parents
        assert all(d < k for d in b.depends)
        assert b.kind == (DYAD if len(b.vertices) == 1 else GENERAL)
    # the kernel arrays say the same as the blocks
    assert list(plan.kind) == [b.kind for b in plan.blocks]
    assert plan.tip == mech.vertex_index(mech.crank.tip)
    assert set(plan.fixed) == {mech.vertex_index(v) for v in mech.fixed}
    for e, l in enumerate(mech.links):
        assert {plan.link_a[e], plan.link_b[e]} == {mech.vertex_index(l.a), mech.vertex_index(l.b)}


def test_jansen_five_dyads_in_dependency_order(jansen):
    plan = make_plan(jansen)
    check_plan(jansen, plan)
    assert plan.n_blocks == 5
    assert all(b.kind == DYAD and len(b.vertices) == 1 and len(b.links) == 2 for b in plan.blocks)
    # each dyad is placed by exactly the two links the seed's construction uses
    order, rest = naive.dyad_peel(jansen)
    assert not rest
    by_vertex = {jansen.vertices[b.vertices[0]]: {jansen.links[e].name for e in b.links} for b in plan.blocks}
    assert by_vertex == {v: {la, lb} for v, a, b, la, lb in order}


def test_jansen_needed_blocks(jansen):
    plan = make_plan(jansen)
    owner = {jansen.vertices[b.vertices[0]]: k for k, b in enumerate(plan.blocks)}
    need = lambda *vs: {jansen.vertices[plan.blocks[k].vertices[0]] for k in plan.needed_blocks(  # noqa: E731
        [jansen.vertex_index(v) for v in vs])}
    assert need("7") == {"3", "4", "5", "6", "7"}
    assert need("6") == {"6"}
    assert need("4") == {"3", "4"}
    assert need("1", "2") == set()
    assert list(plan.needed_blocks([jansen.vertex_index("5")])) == sorted(owner[v] for v in "3456")


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_plan_does_not_depend_on_file_order(jansen, seed):
    """Shuffle the links and the guesses: still five dyads, in a valid order, and the same motion."""
    rng = np.random.default_rng(seed)
    links = [dict(a=l.a, b=l.b, length=l.length) if rng.random() < 0.5 else dict(a=l.b, b=l.a, length=l.length)
             for l in jansen.links]
    links = [links[i] for i in rng.permutation(len(links))]
    guess = {v: list(jansen.guess[v]) for v in rng.permutation(list(jansen.guess))}
    mech = mechanism_from_dict(dict(name="shuffled", foot="7", crank=dict(center=[0.0, 0.0], radius=15.0, tip="1"),
                                    fixed={"2": [-38.0, -7.8]}, guess=guess, links=links), f"<shuffled {seed}>")
    plan = make_plan(mech)
    check_plan(mech, plan)
    assert plan.n_blocks == 5 and all(b.kind == DYAD for b in plan.blocks)
    th = 2 * np.pi * np.arange(36) / 36
    # the array form of the sweep: each shuffled order is a new topology, and the per-topology generated
    # code (compared with it bit for bit in tests/test_codegen.py) would compile ~10 s for each
    b = simulate_batch(mech, mech.lengths[None, :], steps=36, tolerance=1e-12, kernel="general")
    ref, ok, _ = naive.jansen_closed_form(naive.JANSEN_LENGTHS, 15.0, th)
    assert b.status[0] == 0 and ok.all()
    np.testing.assert_allclose(b.paths["7"][0], ref[:, 6], rtol=0, atol=1e-9)


def test_fourbar_two_dyads(fourbar):
    plan = make_plan(fourbar)
    check_plan(fourbar, plan)
    assert [fourbar.vertices[b.vertices[0]] for b in plan.blocks] == ["B", "P"]
    assert all(b.kind == DYAD for b in plan.blocks)


def test_triad_is_one_general_block(triad):
    order, rest = naive.dyad_peel(triad)
    assert order == [] and rest == {"T1", "T2", "T3"}  # brute force: no vertex is a dyad
    plan = make_plan(triad)
    check_plan(triad, plan)
    assert plan.n_blocks == 1
    (b,) = plan.blocks
    assert b.kind == GENERAL
    assert {triad.vertices[v] for v in b.vertices} == {"T1", "T2", "T3"}
    assert len(b.links) == 6 and b.depends == ()


def test_mixed_dyad_triad_dyad():
    """A dyad feeding a triad feeding a dyad: three blocks, DYAD → GENERAL → DYAD."""
    mech = mechanism_from_dict(dict(
        name="mixed", foot="Q", crank=dict(center=[0.0, 0.0], radius=2.0, tip="A"),
        fixed={"G1": [30.0, 40.0], "G2": [-10.0, 40.0], "G3": [10.0, -10.0]},
        guess={"Q": [30.0, 20.0], "T1": [0.0, 25.0], "T2": [18.0, 25.0], "D": [8.0, 10.0], "T3": [9.0, 40.0]},
        links=[dict(a="T3", b="Q", length=20.0), dict(a="G1", b="Q", length=20.0),
               dict(a="D", b="T1", length=17.0), dict(a="G1", b="T2", length=20.0),
               dict(a="G2", b="T3", length=19.0), dict(a="T1", b="T2", length=18.0),
               dict(a="T2", b="T3", length=17.0), dict(a="T3", b="T1", length=17.0),
               dict(a="A", b="D", length=12.0), dict(a="G3", b="D", length=20.0)]), "<mixed>")
    plan = make_plan(mech)
    check_plan(mech, plan)
    got = [({mech.vertices[v] for v in b.vertices}, b.kind) for b in plan.blocks]
    assert got == [({"D"}, DYAD), ({"T1", "T2", "T3"}, GENERAL), ({"Q"}, DYAD)]
    assert plan.blocks[1].depends == (0,) and plan.blocks[2].depends == (1,)


def test_no_perfect_matching_is_a_user_error(tmp_path):
    """Right equation count, wrong structure: B is held by three links while C hangs on one."""
    path = tmp_path / "bad.toml"
    path.write_text("""
name = "bad"
foot = "C"
[crank]
center = [0.0, 0.0]
radius = 5.0
tip = "A"
[fixed]
G1 = [30.0, 0.0]
G2 = [0.0, 30.0]
[guess]
B = [20.0, 20.0]
C = [40.0, 30.0]
[[links]]
a = "A"
b = "B"
length = 28.0
[[links]]
a = "G1"
b = "B"
length = 22.0
[[links]]
a = "G2"
b = "B"
length = 21.0
[[links]]
a = "B"
b = "C"
length = 22.0
""")
    mech = load_mechanism(path)  # the count is right, so the loader accepts it
    for call in (lambda: make_plan(mech), lambda: simulate(mech, 36)):
        with pytest.raises(UserError) as exc:
            call()
        msg = str(exc.value)
        assert msg.startswith(f"{path}: links: ") and "\n" not in msg
        assert "C" in msg


def test_a_thousand_vertex_chain_plans_without_recursion():
    """A chain of 1,000 dyads (vertex k on links to vertices k−1 and k−2) is planned iteratively: one
    2x2 block per vertex, in chain order (the recursive matching used to hit Python's recursion limit)."""
    import time

    n = 1000
    names = ["T", "G"] + [f"v{k}" for k in range(n)]
    links = [{"a": names[k + 1], "b": names[k + 2], "length": 1.0} for k in range(n)]
    links += [{"a": names[k], "b": names[k + 2], "length": 1.0} for k in range(n)]
    d = {"name": "chain", "foot": names[-1], "crank": {"center": [0.0, 0.0], "radius": 0.5, "tip": "T"},
         "fixed": {"G": [1.0, 0.0]}, "guess": {f"v{k}": [float(k), 1.0] for k in range(n)}, "links": links}
    mech = mechanism_from_dict(d, "chain.toml")
    t = time.perf_counter()
    plan = make_plan(mech)
    took = time.perf_counter() - t
    assert plan.n_blocks == n
    assert [mech.vertices[b.vertices[0]] for b in plan.blocks] == [f"v{k}" for k in range(n)]
    assert all(len(b.vertices) == 1 for b in plan.blocks)
    print(f"planned {n} vertices in {took * 1e3:.0f} ms")
