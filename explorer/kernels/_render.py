"""The table-driven kernels' per-block dispatch, rendered from the block kinds (``explorer.kinds``).

Every kind module holds the code the kernels write for it (its ``ARRAY`` snippets: filling its row of
the per-design block table, its closed form, its step, its dense-method check, its branch sign).
:func:`kinds_module_source` renders them into ``_kinds_array.py``: one loop over a plan's blocks per
function, each block's kind choosing its snippet. The rendering is committed (lint, coverage and
tracebacks see it); tests/test_kinds.py re-renders it and compares the text. After adding or editing a
kind: ``python -m explorer.kernels._render``.

No kernel dispatches on a block's kind by hand: the dispatch below is the only place, and it is
written from the registry.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

from ..kinds import KINDS

MODULE = Path(__file__).with_name("_kinds_array.py")

_HEADER = '''"""The table-driven kernels' per-block dispatch: rendered from the block kinds by ``explorer.kernels._render``;
do not edit (edit the kind's module in ``explorer/kinds``, then ``python -m explorer.kernels._render``).
"""

import math

import numpy as np
from numba import njit

from explorer.kinds._common import MAX_MOVE, OK, SIGN, SUSPECT, frame_point, gap_suspect
{imports}

#: the dense method's check: a dyad on the mirror root at a fold (not a branch change)
FOLD = -1
'''

#: Each rendered function: (signature and head, indentation of the dispatch, snippet key, which kinds,
#: what follows the dispatch). ``kinds``: "all", or "closed" (kinds that need no generic context).
_FUNCTIONS = [
    ('''

@njit(cache=True)
def block_table(tab, kind, blk, tip, dist, uv, sd, extra, att_vpq, slide, P, cx, cy, scale, crank):
    """Fill the block table of one design, tab (nb,) records of ``BLOCK_DTYPE`` (zeros) in plan order,
    each block by its kind from its row of the lowered plan (``blk``) and the design's numbers: dist
    (n_dist,), uv (n_attach, 2), sd (n_slide, 6), extra (n_extra,) (``Designs``); P (n_vertices, 2) its
    start (fixed vertices in place); (cx, cy), scale: its crank centre and radius; crank: whether the
    driver is a crank."""
    nb = kind.shape[0]
    for k in range(nb):
        rec = tab[k]
        rec.kind = kind[k]
        row = blk[k]
''', 8, "fill", "all", ""),
    ('''

@njit(cache=True)
def place_closed(tab, tip, cx, cy, scale, d, signs, P, start):
    """Place the driven vertex at (cx, cy) + scale * d[:2], then every block of the block table
    ``tab`` in order by its kind's closed form on the side ``signs[j]``. Writes P (n_vertices, 2) in
    place; returns the first block it could not place, or −1.

    start: placing a design's start for Newton (the kernels' first sample): then it also stops,
    leaving that vertex and the later ones where they were, at a block with no closed form (GENERAL)
    or with no branch to keep (sign 0), which Newton places from there."""
    P[tip, 0] = cx + scale * d[0]
    P[tip, 1] = cy + scale * d[1]
    for j in range(tab.shape[0]):
        rec = tab[j]
''', 8, "place", "all", "    return -1\n"),
    ('''

@njit(cache=True, inline="always")
def fast_step(table, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """Place every block of the block table ``table`` (kinds with no generic context) in order at the
    new driver position (already in P1). Returns (code, failing block or −1, iterations)."""
    iters = 0
    c2 = 0.5 * h * h / hp if hp != 0.0 else 0.0
    tol2 = tol * tol
    for k in range(table.shape[0]):
        rec = table[k]
''', 8, "step", "closed", "    return OK, -1, iters\n"),
    ('''

@njit(cache=True)
def block_step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks):
    """Place every block of ``ctx.table`` (any kind; ``ctx`` a ``_step.GenericContext``) in order at
    the new driver position. Returns (code, failing block or −1, iterations)."""
    iters = 0
    c2 = 0.5 * h * h / hp if hp != 0.0 else 0.0
    tol2 = tol * tol
    table = ctx.table
    for k in range(table.shape[0]):
        rec = table[k]
''', 8, "step", "all", "    return OK, -1, iters\n"),
    ('''

@njit(cache=True)
def check_dense(ctx, signs, P0, V0, P1, V1, h, checks):
    """The per-block branch, gap and move checks on a full-system solution. Returns (code, block);
    code FOLD marks a dyad on the mirror root at a fold (not a branch change: both roots meet there)."""
    table = ctx.table
    for k in range(table.shape[0]):
        rec = table[k]
''', 8, "check", "all", "    return OK, -1\n"),
    ('''

@njit(cache=True)
def block_signs(P, table, gen_vptr, gen_verts, gen_rptr, gen_rows, dist_a, dist_b, att_vpq, uv, slide, sd):
    """Branch sign (+1.0 / −1.0, 0.0 if singular or without a branch) of every block at positions P."""
    nb = table.shape[0]
    out = np.zeros(nb)
    n = 2 * P.shape[0]
    loc = np.full(P.shape[0], -1, dtype=np.int64)
    M = np.empty((n, n))
    rhs = np.empty(n)
    for k in range(nb):
        rec = table[k]
''', 8, "sign", "all", "    return out\n"),
    ('''

@njit(cache=True)
def place_explicit(table, explicit, P1, V1, A1, want_acc):
    """Place the blocks ``explicit`` (kinds that place their vertex from the driver alone, ``EXPLICIT``)
    at the driver's new position (already in P1, V1, A1): the dense method then takes them as known."""
    for q in range(explicit.shape[0]):
        k = explicit[q]
        rec = table[k]
''', 8, "step", "explicit", ""),
    ('''

@njit(cache=True, nogil=True)
def vector_blocks(tab, signs, X, Y, VX, VY, Q, M, P, V, h, closed, first):
    """The vectorised first pass over one design's blocks (``explorer.kernels._vector``): each block of
    the block table ``tab`` from block ``first`` on, in order, over every sample at once by its kind's closed form on the side
    ``signs[k]``, with its tangents, from the rows of X, Y (positions) and VX, VY (tangents),
    (n_vertices, S) each, into its own rows, then its checks between samples a step h apart
    (``closed``: the last and the first too). Q, M (S,), P, V (n_vertices, 2): scratch. Returns the
    first block that flags the design (leave it to Newton), or −1. Only for plans whose every kind has
    a vector form (``_vector.applies``)."""
    for k in range(first, tab.shape[0]):
        rec = tab[k]
''', 8, "vector", "closed", "    return -1\n"),
    ('''

@njit(cache=True, nogil=True)
def vector_good(tab, X, Y, VX, VY, h, closed, good_at, good_to):
    """Where a design the first pass flagged passes its blocks' checks, sample by sample (``_vector.
    restart_points``): each block of ``tab`` by its kind's ``good`` snippet clears good_at[k] (S,) where
    sample k fails a check and good_to[k] where the step from sample k to k + 1 does (X, Y, VX, VY
    (n_vertices, S): its rows, as ``vector_blocks`` left them). Returns False where a block's kind does
    not tell its checks sample by sample (no ``good`` snippet: Newton then solves the whole sweep)."""
    for k in range(tab.shape[0]):
        rec = tab[k]
''', 8, "good", "closed", "        else:\n            return False\n    return True\n"),
    ('''

@njit(cache=True, nogil=True)
def singular_{which}(table, topo, uv, sd, P, loc, M, x, tol):
    """The forces effect's check at positions P: the first block whose Jacobian is singular (for a
    dyad or a slider, |det| ≤ tol × the sum of its terms' sizes), or −1."""
    blk = topo.blk
    for k in range(table.shape[0]):
        rec = table[k]
''', 8, "singular", "both", "    return -1\n"),
    ('''

@njit(cache=True, nogil=True)
def reactions_{which}(table, topo, uv, sd, P, R, act, lam_d, lam_a, lam_s, loc, M, x):
    """The forces effect's multipliers: Φ_qᵀ λ = R solved block by block in reverse plan order for
    every right-hand side r with act[r] (R (nr, n_vertices, 2) the loads, left holding what the plan's
    constraints do not carry: the crank's force on the tip, the frame's on the fixed vertices). Each
    block's multipliers by its kind into lam_d (nr, n_dist), lam_a (nr, n_attach, 2), lam_s (nr, n_slide),
    in the equation types' convention. Returns the first singular block or −1."""
    blk = topo.blk
    for k in range(table.shape[0] - 1, -1, -1):
        rec = table[k]
''', 8, "reactions", "both", "    return -1\n"),
]


def _kinds(which: str):
    if which == "explicit":
        return [k for k in KINDS if getattr(k, "EXPLICIT", False)]
    return [k for k in KINDS if which in ("all", "any") or not getattr(k, "CONTEXT", False)]


def _dispatch(key: str, kinds, indent: int) -> str:
    """The chain ``if rec.kind == N: <snippet> elif ...`` over ``kinds`` (those with code for ``key``)."""
    pad = " " * indent
    out, first = [], True
    for k in kinds:
        snippet = k.ARRAY.get(key, "")
        if not snippet.strip():
            continue
        out.append(f"{pad}{'if' if first else 'elif'} rec.kind == {k.NUMBER}:  # {k.NAME}")
        out.append(textwrap.indent(snippet.rstrip("\n"), pad + "    "))
        first = False
    return "\n".join(out) + "\n" if out else ""


def kinds_module_source() -> str:
    """The text of ``_kinds_array.py``."""
    imports = "\n".join(sorted({ln for k in KINDS for ln in k.ARRAY.get("imports", "").splitlines() if ln.strip()}))
    out = _HEADER.format(imports=imports)
    for head, indent, key, which, tail in _FUNCTIONS:
        # "both": one copy for plans without coupled blocks ("closed"), one for any plan ("any")
        for w in (("closed", "any") if which == "both" else (which,)):
            body = _dispatch(key, _kinds(w), indent)
            text = head.replace("{which}", w)
            if not body:  # no kind has code here: the loop does nothing
                lines = text.splitlines()
                loop = max(n for n, ln in enumerate(lines) if ln.startswith("    for "))
                text = "\n".join(lines[:loop + 1]) + "\n        pass  # no kind of this sort\n"
            out += text + body + tail
    return out


def write_kinds_module() -> Path:
    """Rewrite ``_kinds_array.py`` from the kinds."""
    MODULE.write_text(kinds_module_source(), encoding="utf-8")
    return MODULE


if __name__ == "__main__":
    print(write_kinds_module())
