"""Crank-driven four-bar loops of a mechanism and their Grashof class.

A loop is a vertex v linked both to the crank tip (the coupler) and to a ground pivot f (the
rocker); with the crank and the ground line from the crank centre to f it closes a four-bar. The
Jansen leg has two (vertices 3 and 6), the built-in four-bar one.

With s and l the shortest and longest of the four lengths and p, q the others, the Grashof margin
is (p + q) − (s + l). A positive margin lets the shortest link turn fully: the class then depends on
which link is shortest (the input link is the crank). A negative margin is a triple-rocker, whose
crank cannot make a full turn; zero is a change-point mechanism.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UserError, where
from ..mechanism import Mechanism

#: Class names, by which link is shortest when the margin is positive.
GRASHOF_KINDS = ("crank-rocker", "double-crank", "rocker-crank", "double-rocker", "triple-rocker", "change-point")
_BY_SHORTEST = ("crank-rocker", "double-rocker", "rocker-crank", "double-crank")  # crank, coupler, rocker, ground


@dataclass(frozen=True)
class Grashof:
    """The Grashof class of one crank-driven four-bar loop.

    kind : one of GRASHOF_KINDS; margin : (p + q) − (s + l), model units (negative: the crank
    cannot turn fully); vertex : the loop's coupler–rocker joint; lengths : (crank, coupler,
    rocker, ground).
    """

    kind: str
    margin: float
    vertex: str
    lengths: tuple[float, float, float, float]


def fourbar_loops(mech: Mechanism) -> list[tuple]:
    """The crank-driven four-bar loops of ``mech``: (vertex v, ground pivot f, side tip–v, side f–v).

    A side is a link (its index in ``mech.links``) or two joints of one rigid body, (body index,
    joint, joint); :func:`loop_side` gives its length.
    """
    if mech.crank is None:
        return []
    tip = mech.crank.tip
    # the members joining each pair of joints, indexed once (a scan of every link per pair was
    # quadratic: 66 s for a 9,999-vertex chain): links first, then bodies, each in file order
    pairs: dict = {}
    for i, l in enumerate(mech.links):
        pairs.setdefault(frozenset((l.a, l.b)), []).append(i)
    for bi, b in enumerate(mech.bodies):
        for j, u in enumerate(b.joints):
            for w in b.joints[j + 1:]:
                pairs.setdefault(frozenset((u, w)), []).append((bi, u, w))

    def side(u, w):
        """The first member joining u and w ((body, u, w) with the joints in the caller's order), or None."""
        found = pairs.get(frozenset((u, w)))
        if not found:
            return None
        first = found[0]
        return first if isinstance(first, int) else (first[0], u, w)

    loops = []
    for v in mech.vertices:
        if v == tip or v in mech.fixed:
            continue
        to_tip = side(tip, v)
        if to_tip is None:
            continue
        for f in mech.fixed:
            to_f = side(f, v)
            if to_f is not None:
                loops.append((v, f, to_tip, to_f))
    return loops


def loop_side(mech: Mechanism, side, lengths=None, geometry=None, n: int | None = None):
    """The length of a loop side (see :func:`fourbar_loops`): the nominal's (a float) without
    ``lengths``; else (N,) per variant, from ``lengths`` (N, n_links) for a link, or from the body's
    joint coordinates in ``geometry`` ({parameter name: (N,) values}; those not given keep the
    nominal's) for a body pair."""
    if isinstance(side, (int, np.integer)):
        return float(mech.links[side].length) if lengths is None else np.asarray(lengths, dtype=np.float64)[:, side]
    bi, a, b = side
    body = mech.bodies[bi]
    pts = dict(zip(body.joints, body.points))
    geometry = geometry or {}
    rows = n if lengths is None else np.asarray(lengths).shape[0]

    def coord(j, ax):
        name = f"{body.name}.{j}.{'xy'[ax]}"
        if lengths is None and not geometry:
            return pts[j][ax]
        return np.broadcast_to(np.asarray(geometry.get(name, pts[j][ax]), dtype=np.float64), (rows,))

    d = np.hypot(coord(b, 0) - coord(a, 0), coord(b, 1) - coord(a, 1))
    return float(d) if np.ndim(d) == 0 else d


def classify(crank, coupler, rocker, ground, rtol: float = 1e-9):
    """Vectorised Grashof class: arrays of the four lengths (N,) → (kinds (N,) object, margins (N,))."""
    L = np.stack(np.broadcast_arrays(*(np.asarray(x, dtype=np.float64) for x in (crank, coupler, rocker, ground))),
                 axis=-1)
    srt = np.sort(L, axis=-1)
    margin = (srt[..., 1] + srt[..., 2]) - (srt[..., 0] + srt[..., 3])
    shortest = np.argmin(L, axis=-1)
    kinds = np.array(_BY_SHORTEST, dtype=object)[shortest]
    kinds = np.where(margin < 0, "triple-rocker", kinds)
    kinds = np.where(np.abs(margin) <= rtol * srt[..., 3], "change-point", kinds)
    return kinds, margin


def grashof(mech: Mechanism, vertex: str | None = None) -> Grashof:
    """Classify ``mech``'s crank-driven four-bar loop (the one closing at ``vertex``, or by default the
    loop with the smallest margin, which is the one that limits the crank).

    Raises UserError if the mechanism has no crank-driven four-bar loop.
    """
    loops = fourbar_loops(mech)
    if vertex is not None:
        loops = [lp for lp in loops if lp[0] == str(vertex)]
    if not loops:
        raise UserError(f"{where(mech.source, 'links')}: no crank-driven four-bar loop"
                        + (f" closes at vertex {vertex!r}" if vertex is not None else ""))
    best = None
    for v, f, coupler, rocker in loops:
        cx, cy = mech.crank.center
        fx, fy = mech.fixed[f]
        lengths = (mech.crank.radius, loop_side(mech, coupler), loop_side(mech, rocker), math.hypot(fx - cx, fy - cy))
        kind, margin = classify(*lengths)
        g = Grashof(str(kind), float(margin), v, lengths)
        if best is None or g.margin < best.margin:
            best = g
    return best


def loop_ground(mech: Mechanism, pivot: str, geometry=None, n: int | None = None):
    """The ground link of a crank-driven four-bar loop: the distance from the crank centre to ground
    pivot ``pivot``. Without ``geometry``, the nominal's (a float); with ``geometry`` ({coordinate
    parameter name: (N,) values}, such as "crank.x" or "2.y"; those not given keep the nominal's),
    (N,) per variant (``n`` rows when ``geometry`` gives none of the four coordinates)."""
    cx, cy = mech.crank.center
    fx, fy = mech.fixed[pivot]
    if not geometry:
        return math.hypot(fx - cx, fy - cy)
    cols = [np.asarray(geometry.get(k, d), dtype=np.float64)
            for k, d in (("crank.x", cx), ("crank.y", cy), (f"{pivot}.x", fx), (f"{pivot}.y", fy))]
    shape = np.broadcast_shapes(*(c.shape for c in cols), (n,) if n is not None else ())
    cx, cy, fx, fy = (np.broadcast_to(c, shape) for c in cols)
    return np.hypot(fx - cx, fy - cy)


def grashof_batch(mech: Mechanism, lengths, crank, geometry=None) -> tuple[np.ndarray, np.ndarray]:
    """Grashof class and margin of the limiting loop of every variant: lengths (N, n_links), crank (N,),
    geometry : None (the nominal's pivots) or {coordinate parameter name: (N,) values} (the crank
    centre and ground pivots of each variant: they set each loop's ground link)."""
    loops = fourbar_loops(mech)
    L = np.asarray(lengths, dtype=np.float64)
    r = np.asarray(crank, dtype=np.float64)
    kinds = np.full(L.shape[0], "", dtype=object)
    margins = np.full(L.shape[0], np.inf)
    for v, f, coupler, rocker in loops:
        g = loop_ground(mech, f, geometry, L.shape[0])
        k, m = classify(r, loop_side(mech, coupler, L, geometry), loop_side(mech, rocker, L, geometry), g)
        take = m < margins
        kinds[take], margins[take] = k[take], m[take]
    if not loops:
        margins[:] = np.nan
    return kinds, margins
