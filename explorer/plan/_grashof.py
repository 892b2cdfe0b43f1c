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


def fourbar_loops(mech: Mechanism) -> list[tuple[str, str, int, int]]:
    """The crank-driven four-bar loops of ``mech``: (vertex v, ground pivot f, link tip–v, link f–v)."""
    if mech.crank is None:
        return []
    tip = mech.crank.tip
    loops = []
    for v in mech.vertices:
        if v == tip or v in mech.fixed:
            continue
        to_tip = [i for i, l in enumerate(mech.links) if {l.a, l.b} == {tip, v}]
        if not to_tip:
            continue
        for f in mech.fixed:
            to_f = [i for i, l in enumerate(mech.links) if {l.a, l.b} == {f, v}]
            if to_f:
                loops.append((v, f, to_tip[0], to_f[0]))
    return loops


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
        lengths = (mech.crank.radius, mech.links[coupler].length, mech.links[rocker].length, math.hypot(fx - cx, fy - cy))
        kind, margin = classify(*lengths)
        g = Grashof(str(kind), float(margin), v, lengths)
        if best is None or g.margin < best.margin:
            best = g
    return best


def grashof_batch(mech: Mechanism, lengths, crank) -> tuple[np.ndarray, np.ndarray]:
    """Grashof class and margin of the limiting loop of every variant: lengths (N, n_links), crank (N,)."""
    loops = fourbar_loops(mech)
    L = np.asarray(lengths, dtype=np.float64)
    r = np.asarray(crank, dtype=np.float64)
    kinds = np.full(L.shape[0], "", dtype=object)
    margins = np.full(L.shape[0], np.inf)
    for v, f, coupler, rocker in loops:
        g = math.hypot(mech.fixed[f][0] - mech.crank.center[0], mech.fixed[f][1] - mech.crank.center[1])
        k, m = classify(r, L[:, coupler], L[:, rocker], g)
        take = m < margins
        kinds[take], margins[take] = k[take], m[take]
    if not loops:
        margins[:] = np.nan
    return kinds, margins
