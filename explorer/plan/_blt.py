"""Structural analysis: block-lower-triangular (BLT) order of a linkage's equations.

Equations are the links, the rigid bodies' equations and the sliders' slide equations (see
``_kinds``); unknowns are the x and y of every vertex that is neither fixed nor the driven vertex.
A maximum matching pairs each equation with an unknown it contains; Tarjan's strongly connected
components of the resulting dependency graph, emitted dependencies first, are the blocks. Each block
is solved after the blocks it reads from. A vertex placed by two links to already-known vertices is
a *dyad* (a 2x2 block with a closed-form twin); a body joint placed by its body's known base pair is
an *attach* block (exact); a vertex placed by a link to a known vertex and a slide equation whose
other vertices are known is a *slide* block (a pin–slider dyad, exact); anything else, such as an
Assur class III triad or a slot inside a loop, is one coupled *general* block.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from itertools import combinations, product

from ..errors import UserError, where
from ..kinds import EQUATIONS, GENERAL, classify
from ..mechanism import Mechanism

#: Most unknown coordinates matched by the plain augmenting-path search (beyond: with a look-ahead,
#: see ``_matching``). Up to here the plain search costs at most ~0.2 s (a chain of 256 dyads), and
#: plans come out exactly as in earlier releases, so the block indices stored in results files keep
#: naming the same blocks; the look-ahead finds another matching of equal size, which orders some
#: independent blocks differently (same blocks, same results).
PLAIN_MATCHING_MAX = 512

#: Most combinations of body base pairs tried when choosing them (beyond: the first pair of each body,
#: or the pair through its ground pivot).
MAX_BASE_COMBINATIONS = 256


@dataclass(frozen=True)
class Block:
    """One block of the plan.

    vertices : indices (into ``mech.vertices``) of the vertices this block places.
    links : indices of its distance equations (``Plan.link_a``/``link_b``: the mechanism's links,
        then each body's base pair).
    attaches : its attach rows, as (attach equation, axis 0 = x / 1 = y) pairs.
    kind : its kind's number (``explorer.kinds``: DYAD, ATTACH, GENERAL, SLIDE, ...).
    depends : indices of earlier blocks it reads positions from.
    slides : its slide equations (indices into ``Plan.slide``).
    rows : every row, as (equation type, equation, row of the equation), in the plan's row order
        (equation types by their ORDER, then equation and row): the distance rows are ``links``, the
        attach rows ``attaches``, the slide rows ``slides``; other equation types appear here only.

    ``len(rows) == 2 * len(vertices)``.
    """

    vertices: tuple[int, ...]
    links: tuple[int, ...]
    kind: int
    depends: tuple[int, ...]
    attaches: tuple[tuple[int, int], ...] = ()
    slides: tuple[int, ...] = ()
    rows: tuple[tuple[str, int, int], ...] = ()


@dataclass(frozen=True)
class Plan:
    """The solve order of one mechanism topology, reused for every variant and crank angle.

    n_links : the mechanism's links; distance equations ``n_links ...`` are the bodies' base pairs.
    link_a, link_b : (n_distances,) int64, vertex index of each distance equation's ends.
    body_base : (n_bodies, 2) int64, the base pair of each body (indices into its ``joints``).
    attach : (n_attach, 3) int64, (joint, base p, base q) vertex indices of each attach equation;
        attach_body, attach_joint : (n_attach,) the body and the joint's index in it.
    tip : int, index of the crank tip (driven vertex); fixed : (n_fixed,) int64, the fixed vertices.
    slide : (n_slide, 3) int64, (slider vertex p, line vertex a, line vertex b) of each slide
        equation, a = b = −1 for a ground line; slide_slider : (n_slide,) its index in
        ``mech.sliders`` (a slider that a linear actuator drives has no slide equation).
    """

    n_vertices: int
    blocks: tuple[Block, ...]
    n_links: int
    link_a: np.ndarray
    link_b: np.ndarray
    body_base: np.ndarray
    attach: np.ndarray
    attach_body: np.ndarray
    attach_joint: np.ndarray
    tip: int
    fixed: np.ndarray
    slide: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))
    slide_slider: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    tables: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)

    @property
    def n_blocks(self) -> int:
        return len(self.blocks)

    @property
    def kind(self) -> np.ndarray:
        """(n_blocks,) int64, each block's kind."""
        return np.array([b.kind for b in self.blocks], dtype=np.int64)

    def block_of_vertex(self) -> dict[int, int]:
        """Map vertex index -> index of the block that places it (solved vertices only)."""
        return {v: i for i, b in enumerate(self.blocks) for v in b.vertices}

    def needed_blocks(self, vertex_indices) -> np.ndarray:
        """Indices of the blocks needed to place ``vertex_indices`` (their ancestors), in solve order."""
        owner = self.block_of_vertex()
        todo = [owner[v] for v in vertex_indices if v in owner]
        need: set[int] = set()
        while todo:
            b = todo.pop()
            if b not in need:
                need.add(b)
                todo.extend(self.blocks[b].depends)
        return np.array(sorted(need), dtype=np.int64)


def make_plan(mech: Mechanism) -> Plan:
    """Sort ``mech``'s equations into block-lower-triangular order.

    Each rigid body of n joints gives one distance equation between two of its joints (its *base
    pair*) and an attach equation (two rows) for each other joint. Base pairs are chosen so that the
    blocks come out smallest: with the right pair, a body placed by two joints places the rest by
    ATTACH blocks (exact), and the pair's own distance serves a DYAD.

    Raises UserError if the equations have no perfect matching (some part is over-constrained while
    another is free to move) even though the equation count is right.
    """
    index = {v: i for i, v in enumerate(mech.vertices)}
    tip = index[mech.driven]
    grounded = {tip, *(index[v] for v in mech.fixed)}
    choices = []
    for body in mech.bodies:
        pairs = list(combinations(range(len(body.joints)), 2))
        ground = [i for i, j in enumerate(body.joints) if index[j] in grounded]
        choices.append(pairs if not ground else sorted(pairs, key=lambda pq: ground[0] not in pq))
    n_comb = 1
    for c in choices:
        n_comb *= len(c)
    combos = product(*choices) if n_comb <= MAX_BASE_COMBINATIONS else [tuple(c[0] for c in choices)]
    best, error = None, None
    for bases in combos:
        try:
            plan = _plan_with_bases(mech, index, tip, grounded, bases)
        except UserError as exc:
            error = error or exc
            continue
        score = (sum(len(b.vertices) ** 2 for b in plan.blocks if b.kind == GENERAL), plan.n_blocks)
        if best is None or score < best[0]:
            best = (score, plan)
    if best is None:
        raise error
    return best[1]


def _plan_with_bases(mech, index, tip, grounded, bases) -> Plan:
    free = [i for i in range(len(mech.vertices)) if i not in grounded]
    tables, fields = {}, {}
    for eq in EQUATIONS:  # each equation type's equations and the plan fields they fill
        verts, f = eq.gather(mech, index, bases)
        tables[eq.NAME] = [tuple(int(v) for v in vs) for vs in verts]
        fields.update(f)

    # Unknown coordinates are (vertex, axis). Scalar equations: each equation type's rows in turn (the
    # distance equations, then two rows per attach equation, ...); each contains every free coordinate
    # of the vertices it names.
    coords = [(v, ax) for v in free for ax in (0, 1)]
    cidx = {c: i for i, c in enumerate(coords)}
    eqs = [(eq.NAME, e, ax) for eq in EQUATIONS for e in range(len(tables[eq.NAME])) for ax in range(eq.ROWS)]
    eq_vars = [[cidx[(v, ax)] for v in tables[typ][e] if v >= 0 and v not in grounded for ax in (0, 1)]
               for typ, e, _ in eqs]

    match_of_coord = _matching(eq_vars, len(coords), lookahead=len(coords) > PLAIN_MATCHING_MAX)
    unmatched = [coords[c] for c in range(len(coords)) if match_of_coord[c] < 0]
    if unmatched:
        names = sorted({mech.vertices[v] for v, _ in unmatched})
        raise UserError(
            f"{where(mech.source, 'links')}: the links, bodies and sliders do not place vertices {', '.join(names)} "
            f"(some part of the graph is over-constrained while another can move freely)"
        )

    # Dependency graph on coordinates: c depends on every other coordinate of its matched equation.
    deps = [[d for d in eq_vars[match_of_coord[c]] if d != c] for c in range(len(coords))]
    comps = _tarjan(deps)

    comp_of = {}
    for k, comp in enumerate(comps):
        for c in comp:
            comp_of[c] = k
    blocks = []
    order = {v: i for i, v in enumerate(free)}
    type_order = {eq.NAME: i for i, eq in enumerate(EQUATIONS)}
    for k, comp in enumerate(comps):
        verts = tuple(sorted({coords[c][0] for c in comp}, key=order.__getitem__))
        rows = tuple(sorted((eqs[match_of_coord[c]] for c in comp), key=lambda r: (type_order[r[0]], r[1], r[2])))
        links = tuple(e for typ, e, _ in rows if typ == "distance")
        attaches = tuple((e, ax) for typ, e, ax in rows if typ == "attach")
        slides = tuple(e for typ, e, _ in rows if typ == "slide")
        depends = tuple(sorted({comp_of[d] for c in comp for d in deps[c]} - {k}))
        blocks.append(Block(verts, links, classify(verts, rows, tables), depends, attaches, slides, rows))
    fixed = np.array(sorted(grounded - {tip}), dtype=np.int64)
    core = {f.name for f in dataclasses.fields(Plan)}
    extra = {k: v for k, v in fields.items() if k not in core}
    return Plan(len(mech.vertices), tuple(blocks), tip=tip, fixed=fixed,
                tables={k: np.array(v, dtype=np.int64).reshape(len(v), len(v[0]) if v else 0) for k, v in tables.items()}, extra=extra,
                **{k: v for k, v in fields.items() if k in core})


def _matching(eq_vars: list[list[int]], n_vars: int, lookahead: bool = True) -> list[int]:
    """Maximum bipartite matching (Kuhn's augmenting paths, searched depth first with an explicit
    stack, so a mechanism of any size plans without recursion); returns the equation of each variable.

    With ``lookahead``, each equation the search reaches first looks for a variable no equation holds
    yet before it walks the alternating paths through held ones: a chain of dyads, whose every
    equation finds a free variable, then matches in linear time, where the plain search walks back
    along the whole chain for each equation (quadratic: 1.8 s for 1,000 vertices, 18 s for 3,000).
    Both give a maximum matching; they may differ in which one (see ``PLAIN_MATCHING_MAX``)."""
    match_of_var = [-1] * n_vars
    for root in range(len(eq_vars)):
        seen: set[int] = set()
        # each frame: (equation, position in its variable list, the variable it tried last)
        stack = [_frame(root, eq_vars, match_of_var, seen, lookahead)]
        found = stack[0][2] >= 0
        while stack:
            frame = stack[-1]
            e, i = frame[0], frame[1]
            if found:
                # unwind: every equation on the path takes the variable it went through
                match_of_var[frame[2]] = e
                stack.pop()
                continue
            if i >= len(eq_vars[e]):
                stack.pop()
                continue
            v = eq_vars[e][i]
            frame[1] += 1
            if v in seen:
                continue
            seen.add(v)
            frame[2] = v
            if match_of_var[v] < 0:
                found = True
            else:
                child = _frame(match_of_var[v], eq_vars, match_of_var, seen, lookahead)
                stack.append(child)
                found = child[2] >= 0
    return match_of_var


def _frame(e: int, eq_vars: list[list[int]], match_of_var: list[int], seen: set[int], lookahead: bool) -> list[int]:
    """The search's frame for equation ``e``: with ``lookahead``, holding a free variable of it
    already (the search then unwinds) if it has one; else ready to walk its variables in order."""
    for v in eq_vars[e] if lookahead else ():
        if match_of_var[v] < 0 and v not in seen:
            seen.add(v)
            return [e, len(eq_vars[e]), v]
    return [e, 0, -1]


def _tarjan(deps: list[list[int]]) -> list[list[int]]:
    """Strongly connected components, each emitted after every component it depends on (Tarjan's
    algorithm with an explicit stack: no recursion, whatever the mechanism's size)."""
    index, low, on_stack, stack, out = {}, {}, set(), [], []
    counter = 0
    for root in range(len(deps)):
        if root in index:
            continue
        work = [(root, 0)]
        while work:
            v, i = work.pop()
            if i == 0:
                index[v] = low[v] = counter
                counter += 1
                stack.append(v)
                on_stack.add(v)
            recurse = False
            while i < len(deps[v]):
                w = deps[v][i]
                i += 1
                if w not in index:
                    work.append((v, i))
                    work.append((w, 0))
                    recurse = True
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            if recurse:
                continue
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                out.append(sorted(comp))
            if work:  # back in the caller: take the child's low link
                u = work[-1][0]
                low[u] = min(low[u], low[v])
    return out
