"""Structural analysis: block-lower-triangular (BLT) order of a linkage's equations.

Equations are the links; unknowns are the x and y of every vertex that is neither fixed nor the
crank tip. A maximum matching pairs each equation with an unknown it contains; Tarjan's strongly
connected components of the resulting dependency graph, emitted dependencies first, are the blocks.
Each block is solved after the blocks it reads from. A vertex placed by two links to already-known
vertices is a *dyad* (a 2x2 block with a closed-form twin); anything else, such as an Assur class III
triad, is one coupled *general* block.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UserError, where
from ..mechanism import Mechanism

DYAD = 0
GENERAL = 1


@dataclass(frozen=True)
class Block:
    """One block of the plan.

    vertices : indices (into ``mech.vertices``) of the vertices this block places.
    links : indices (into ``mech.links``) of its equations, ``2 * len(vertices)`` of them.
    kind : DYAD or GENERAL.
    depends : indices of earlier blocks it reads positions from.
    """

    vertices: tuple[int, ...]
    links: tuple[int, ...]
    kind: int
    depends: tuple[int, ...]


@dataclass(frozen=True)
class Plan:
    """The solve order of one mechanism topology, reused for every variant and crank angle.

    Array fields are what the Numba kernels read:

    link_a, link_b : (n_links,) int64, vertex index of each link's ends.
    tip : int, index of the crank tip; fixed : (n_fixed,) int64, indices of the fixed vertices.
    kind : (n_blocks,) int64, DYAD or GENERAL.
    vert_ptr, verts : CSR lists of each block's vertices; link_ptr, blinks : of each block's links.
    """

    n_vertices: int
    blocks: tuple[Block, ...]
    link_a: np.ndarray
    link_b: np.ndarray
    tip: int
    fixed: np.ndarray
    kind: np.ndarray
    vert_ptr: np.ndarray
    verts: np.ndarray
    link_ptr: np.ndarray
    blinks: np.ndarray

    @property
    def n_blocks(self) -> int:
        return len(self.blocks)

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

    def arrays(self, blocks=None) -> tuple:
        """The tuple of arrays the kernels take, restricted to ``blocks`` (default: all), in order."""
        if blocks is None:
            return (self.kind, self.vert_ptr, self.verts, self.link_ptr, self.blinks)
        sel = [self.blocks[i] for i in blocks]
        return _csr(sel)


def _csr(blocks) -> tuple:
    kind = np.array([b.kind for b in blocks], dtype=np.int64)
    vert_ptr = np.zeros(len(blocks) + 1, dtype=np.int64)
    link_ptr = np.zeros(len(blocks) + 1, dtype=np.int64)
    for i, b in enumerate(blocks):
        vert_ptr[i + 1] = vert_ptr[i] + len(b.vertices)
        link_ptr[i + 1] = link_ptr[i] + len(b.links)
    verts = np.array([v for b in blocks for v in b.vertices], dtype=np.int64)
    blinks = np.array([l for b in blocks for l in b.links], dtype=np.int64)
    return kind, vert_ptr, verts, link_ptr, blinks


def make_plan(mech: Mechanism) -> Plan:
    """Sort ``mech``'s equations into block-lower-triangular order.

    Raises UserError if the link graph has no perfect matching (some part is over-constrained
    while another is free to move) even though the equation count is right.
    """
    index = {v: i for i, v in enumerate(mech.vertices)}
    tip = index[mech.driven]
    grounded = {tip, *(index[v] for v in mech.fixed)}
    free = [i for i in range(len(mech.vertices)) if i not in grounded]
    link_a = np.array([index[l.a] for l in mech.links], dtype=np.int64)
    link_b = np.array([index[l.b] for l in mech.links], dtype=np.int64)

    # Unknown coordinates are (vertex, axis); equation e contains both coordinates of its free ends.
    coords = [(v, ax) for v in free for ax in (0, 1)]
    cidx = {c: i for i, c in enumerate(coords)}
    eq_vars = []
    for a, b in zip(link_a, link_b):
        eq_vars.append([cidx[(int(v), ax)] for v in (a, b) if int(v) not in grounded for ax in (0, 1)])

    match_of_coord = _matching(eq_vars, len(coords))
    unmatched = [coords[c] for c in range(len(coords)) if match_of_coord[c] < 0]
    if unmatched:
        names = sorted({mech.vertices[v] for v, _ in unmatched})
        raise UserError(
            f"{where(mech.source, 'links')}: the links do not place vertices {', '.join(names)} "
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
    for k, comp in enumerate(comps):
        verts = tuple(sorted({coords[c][0] for c in comp}, key=free.index))
        links = tuple(sorted({match_of_coord[c] for c in comp}))
        depends = tuple(sorted({comp_of[d] for c in comp for d in deps[c]} - {k}))
        is_dyad = len(verts) == 1 and len(links) == 2
        blocks.append(Block(verts, links, DYAD if is_dyad else GENERAL, depends))
    kind, vert_ptr, verts, link_ptr, blinks = _csr(blocks)
    fixed = np.array(sorted(grounded - {tip}), dtype=np.int64)
    return Plan(len(mech.vertices), tuple(blocks), link_a, link_b, tip, fixed, kind, vert_ptr, verts, link_ptr, blinks)


def _matching(eq_vars: list[list[int]], n_vars: int) -> list[int]:
    """Maximum bipartite matching (Kuhn's augmenting paths, searched depth first with an explicit
    stack, so a mechanism of any size plans without recursion); returns the equation of each variable."""
    match_of_var = [-1] * n_vars
    for root in range(len(eq_vars)):
        seen: set[int] = set()
        # each frame: (equation, position in its variable list, the variable it tried last)
        stack = [[root, 0, -1]]
        found = False
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
                stack.append([match_of_var[v], 0, -1])
    return match_of_var


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
