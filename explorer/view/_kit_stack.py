"""Stack order of a kit's parts: which layer each part sits on along the pins, so that no two parts of one
layer ever touch over the crank turn (issue 27).

Each part is a convex plate: the convex hull of its holes grown by half the part width (a link: a
stadium around its centre line). Over the turn (``explorer.simulate``, ``steps`` samples) a part's
centre shape is the convex hull of its joints' positions (the frame: the crank centre and the ground
pivots, fixed; the crank: centre → tip). Two parts *conflict* if they share a joint (they sit on one pin,
so at different heights) or if their centre shapes come closer than the part width at any sample (their
outlines would overlap). Layers are a greedy colouring of that conflict graph (most conflicts first,
lowest free layer), the frame alone on layer 0 (every moving part passes over the frame plate).
"""

from __future__ import annotations

import numpy as np


def _seg_dist(a, b, c, d) -> np.ndarray:
    """Distance between segments a–b and c–d, each point an (S, 2) array; (S,)."""
    def point_seg(p, q0, q1):
        v = q1 - q0
        vv = np.einsum("ij,ij->i", v, v)
        t = np.where(vv > 0, np.einsum("ij,ij->i", p - q0, v) / np.where(vv > 0, vv, 1.0), 0.0)
        t = np.clip(t, 0.0, 1.0)
        return np.hypot(*(q0 + t[:, None] * v - p).T)

    def cross(o, p, q):
        return (p[:, 0] - o[:, 0]) * (q[:, 1] - o[:, 1]) - (p[:, 1] - o[:, 1]) * (q[:, 0] - o[:, 0])

    d1, d2 = cross(c, d, a), cross(c, d, b)
    d3, d4 = cross(a, b, c), cross(a, b, d)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    dist = np.minimum.reduce([point_seg(a, c, d), point_seg(b, c, d), point_seg(c, a, b), point_seg(d, a, b)])
    return np.where(crossing, 0.0, dist)


def _inside(p, poly) -> np.ndarray:
    """Whether the points p (S, 2) lie inside the counter-clockwise convex polygons poly [(S, 2), ...] (≥ 3
    corners); (S,) bools."""
    ok = np.ones(p.shape[0], dtype=bool)
    m = len(poly)
    for i in range(m):
        o, q = poly[i], poly[(i + 1) % m]
        ok &= ((q[:, 0] - o[:, 0]) * (p[:, 1] - o[:, 1]) - (q[:, 1] - o[:, 1]) * (p[:, 0] - o[:, 0])) >= 0
    return ok


def shape_distance(A, B) -> np.ndarray:
    """Distance between two convex shapes over the samples: A, B lists of (S, 2) corners, counter-
    clockwise (one corner: a point; two: a segment); 0 where they overlap; (S,)."""
    def edges(P):
        if len(P) == 1:
            return [(P[0], P[0])]
        if len(P) == 2:
            return [(P[0], P[1])]
        return [(P[i], P[(i + 1) % len(P)]) for i in range(len(P))]

    d = np.full(A[0].shape[0], np.inf)
    for a, b in edges(A):
        for c, e in edges(B):
            d = np.minimum(d, _seg_dist(a, b, c, e))
    if len(A) >= 3:
        d = np.where(_inside(B[0], A), 0.0, d)
    if len(B) >= 3:
        d = np.where(_inside(A[0], B), 0.0, d)
    return d


def part_shapes(mech, parts, steps: int = 360) -> dict[str, list[np.ndarray]]:
    """{part name: its centre shape over the turn}: the corners (each (steps, 2), model units,
    counter-clockwise) of the convex hull of its joints' positions at crank angles 2πk/steps.
    ``parts``: (name, kind, hole joint names, hull indices) — a frame's hole names may join several
    ground joints with "+" (a pivot on the crank centre)."""
    from .. import simulate
    from ._export import CRANK_CENTRE

    cyc = simulate(mech, steps=steps)
    if not cyc.ok:
        from ..errors import UserError
        raise UserError(f"{mech.name}: the design does not turn through a full cycle ({cyc.failure}); a kit needs "
                        f"one that does")
    P = np.asarray(cyc.positions, dtype=np.float64)
    S = P.shape[0]

    def where(j):
        first = j.split("+")[0]
        if first == CRANK_CENTRE:
            return np.tile(np.asarray(mech.crank.center, dtype=np.float64), (S, 1))
        return P[:, mech.vertex_index(first)]

    return {name: [where(joints[i]) for i in hull] for name, _, joints, hull in parts}


def stack_layers(mech, parts, clearance: float, steps: int = 360) -> dict[str, int]:
    """{part name: layer}: see the module docstring. parts : (name, kind, hole joint names, hull indices);
    clearance : the part width in model units (two centre shapes closer than it overlap)."""
    shapes = part_shapes(mech, parts, steps)
    names = [p[0] for p in parts]
    kinds = {p[0]: p[1] for p in parts}
    joints = {p[0]: {x for j in p[2] for x in j.split("+")} for p in parts}
    conflict = {n: set() for n in names}
    for i, a in enumerate(names):
        for b in names[:i]:
            if joints[a] & joints[b] or np.min(shape_distance(shapes[a], shapes[b])) < clearance:
                conflict[a].add(b)
                conflict[b].add(a)
    layers: dict[str, int] = {}
    for n in names:
        if kinds[n] == "frame":
            layers[n] = 0
    order = sorted((n for n in names if n not in layers), key=lambda n: (-len(conflict[n]), names.index(n)))
    first = 1 if layers else 0
    for n in order:
        used = {layers[m] for m in conflict[n] if m in layers}
        k = first
        while k in used:
            k += 1
        layers[n] = k
    return layers
