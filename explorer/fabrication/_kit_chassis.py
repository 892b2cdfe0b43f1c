"""The chassis of a build kit (issue 37): standoffs that join the plates, the motor plate, and where every
plate and layer sits along the crankshaft.

Along the shaft (z, mm, from the motor's side): the motor plate; a gap for the shaft coupler; then each leg
in turn (its frame plate, then its layers); a gap between legs for the pins' heads and nuts; and, unless the
crank arm is outboard, an end plate that carries the shaft's far bushing. Threaded-rod standoffs run
through every plate, a nut on each side of each plate. They pass every layer of every leg, so they stand
where nothing turns: :func:`standoff_points` searches a grid around the legs for points at least a nut's
radius plus the running clearance from every moving part over the turn (the plain and, for a walker
with mirrored legs, the mirrored leg; a mirrored standoff set, so one plate fits both).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import UserError
from ._kit_stack import point_distance

#: Length of the gap between the motor plate and the first frame plate, mm: a shaft coupler (25 mm) and room.
COUPLER = 25.0
MOTOR_GAP = COUPLER + 5.0


def _hull_distance(P: np.ndarray, hull: np.ndarray) -> np.ndarray:
    """Distance of the points P (N, 2) from the convex polygon ``hull`` (counter-clockwise (m, 2); 0 inside)."""
    if len(hull) == 1:
        return np.hypot(*(P - hull[0]).T)
    d = np.full(P.shape[0], np.inf)
    m = len(hull)
    inside = np.ones(P.shape[0], dtype=bool)
    for i in range(m if m > 2 else 1):
        a, b = hull[i], hull[(i + 1) % m]
        v = b - a
        t = np.clip(((P - a) @ v) / max(float(v @ v), 1e-300), 0.0, 1.0)
        d = np.minimum(d, np.hypot(*(a + t[:, None] * v - P).T))
        inside &= (v[0] * (P[:, 1] - a[1]) - v[1] * (P[:, 0] - a[0])) >= 0
    return np.where(inside & (m > 2), 0.0, d)


def standoff_points(moving: list[tuple[list, float]], frame_pts, radius: float, clearance: float, bound: float,
                    mirrored: bool, spacing: float | None = None) -> list[tuple[float, float]]:
    """Where the standoffs stand, mm from the crank centre: 2 (or 3, a mirrored set that leaves the axis).

    moving : (corners, half width) of every moving thing of one leg over the turn (corners: (S, 2) arrays,
    mm from the crank centre; a pin is one corner with its radius as half width); frame_pts : the frame's
    holes (the shaft and the pivots, mm); radius : what a standoff needs (its nut's radius), mm; mirrored :
    the walker has mirrored legs (the set is mirrored about x = 0 and clear of the mirrored leg too).
    The first standoff is the free point nearest the frame's pivots, the second the free point that
    makes the widest triangle with it and the shaft, among those no farther from the pivots than the
    first plus the legs' size / 4. UserError if no point is free."""
    allc = np.vstack([np.vstack(c) for c, _ in moving] + [np.asarray(frame_pts, dtype=np.float64)])
    if mirrored:
        allc = np.vstack([allc, allc * np.array([-1.0, 1.0])])
    reach = max(h for _, h in moving) + radius + clearance + bound
    lo, hi = allc.min(axis=0) - reach - 2 * radius, allc.max(axis=0) + reach + 2 * radius
    size = float(np.max(hi - lo))
    h = spacing or max(1.0, min(size / 120.0, radius))
    xs = h * np.arange(math.floor(lo[0] / h), math.ceil(hi[0] / h) + 1)  # x = 0 is a column
    ys = h * np.arange(math.floor(lo[1] / h), math.ceil(hi[1] / h) + 1)
    G = np.array([(x, y) for y in ys for x in xs])
    if mirrored:  # one standoff set for both: clear of the leg and of its mirror image, on the axis or in pairs
        G = G[(np.abs(G[:, 0]) < 1e-9) | (G[:, 0] > 2.0 * radius)]
    S = moving[0][0][0].shape[0]
    step = max(1, S // 360)  # a coarse turn first (its own bound), then every sample for the point kept
    coarse = np.arange(0, S, step)
    shapes = []
    for corners, half in moving:
        for sign in ((1.0, -1.0) if mirrored else (1.0,)):
            C = [c * np.array([sign, 1.0]) for c in corners]
            shapes.append((C, [c[coarse] for c in C], half))

    def clear_point(p) -> bool:
        """Whether the point p stays clear of every shape at every sample."""
        P = np.broadcast_to(np.asarray(p, dtype=np.float64), (S, 2))
        return all(float(np.min(point_distance(P, C))) >= half + radius + clearance + bound for C, _, half in shapes)

    def first_clear(cands):
        """The first of the candidates (in order) clear of everything: 64 at a time on the coarse turn, then
        the full turn for those that pass; None if none is."""
        n = len(coarse)
        for start in range(0, len(cands), 64):
            blk = cands[start:start + 64]
            ok = np.ones(len(blk), dtype=bool)
            rows = np.repeat(blk, n, axis=0)
            for _, Cc, half in shapes:
                CC = [np.tile(c, (len(blk), 1)) for c in Cc]
                d = point_distance(rows, CC).reshape(len(blk), n).min(axis=1)
                ok &= d >= half + radius + clearance + bound * step
            for i in np.flatnonzero(ok):
                if clear_point(blk[i]):
                    return blk[i]
        return None

    fp = np.asarray(frame_pts, dtype=np.float64)
    from ._export import _hull
    hull = np.asarray(_hull([tuple(p) for p in fp]), dtype=np.float64)
    dist = _hull_distance(G, hull)
    order = np.argsort(dist + 1e-6 * np.hypot(*G.T), kind="stable")
    s1 = first_clear(G[order])
    if s1 is None:
        raise UserError("no room for the chassis standoffs: every point near the legs is swept by a part")
    chosen = [s1]
    # the second: the widest triangle with the shaft and the first, as near the frame as will do
    fsize = max(float(np.max(np.ptp(fp, axis=0))) if len(fp) > 1 else 0.0, 8 * radius)
    d1 = float(_hull_distance(s1[None, :], hull)[0])
    for limit in (d1 + 0.5 * fsize, d1 + fsize, d1 + 2 * fsize, d1 + 0.25 * size, np.inf):
        cand = G[dist <= limit]
        area = np.abs(s1[0] * cand[:, 1] - s1[1] * cand[:, 0])  # twice the triangle (shaft, s1, candidate)
        far = np.hypot(*(cand - s1).T)
        keep = (far >= 4 * radius) & (area >= 4 * radius * max(float(np.hypot(*s1)), 4 * radius))
        if mirrored:
            keep &= np.hypot(cand[:, 0] + s1[0], cand[:, 1] - s1[1]) >= 4 * radius  # not s1's mirror image
        cand, area, far = cand[keep], area[keep], far[keep]
        s2 = first_clear(cand[np.argsort(-(area + 1e-3 * far), kind="stable")]) if len(cand) else None
        if s2 is not None:
            chosen.append(s2)
            break
    pts = []
    for p in chosen:
        pts.append((float(p[0]), float(p[1])))
        if mirrored and p[0] > 1e-9:
            pts.append((float(-p[0]), float(p[1])))
    if len(pts) < 2:
        raise UserError("no room for a second chassis standoff clear of the legs")
    return pts


def motor_pattern(text, shaft: float | None = None) -> tuple[int, float, float]:
    """``--motor-holes N×D@PCD`` (e.g. "6xM3@31": six M3 holes on a 31 mm circle; "4x3.2@25") → (N, hole
    diameter mm, pitch circle diameter mm); UserError otherwise, or if the holes come within a 1.5 mm wall
    of the motor's boss hole (twice ``shaft``, mm)."""
    s = str(text).strip().replace("×", "x").replace(" ", "")
    try:
        count, rest = s.lower().split("x", 1)
        size, pcd = rest.split("@", 1)
        n = int(count)
        d = float(size[1:]) if size.startswith("m") else float(size)
        p = float(pcd)
    except ValueError:
        raise UserError(f"--motor-holes: expected COUNTxSIZE@CIRCLE such as 6xM3@31 (six M3 holes on a 31 mm "
                        f"circle), got {text!r}") from None
    if not (2 <= n <= 12 and math.isfinite(d) and 0 < d <= 20 and math.isfinite(p) and 0 < p <= 500):
        raise UserError(f"--motor-holes: expected 2 to 12 holes of 0 to 20 mm on a circle of 0 to 500 mm, got {text!r}")
    if p * math.sin(math.pi / n) < d + 1.5:
        raise UserError(f"--motor-holes: {n} holes of {d:g} mm do not fit on a {p:g} mm circle, got {text!r}")
    if shaft is not None and 0.5 * p - 0.5 * d - 1.5 < shaft:
        raise UserError(f"--motor-holes: holes of {d:g} mm on a {p:g} mm circle leave no wall around the "
                        f"{2 * shaft:g} mm boss hole of a {shaft:g} mm motor shaft, got {text!r}")
    return n, d, p
