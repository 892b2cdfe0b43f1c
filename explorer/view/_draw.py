"""Drawing a linkage on a matplotlib axes with artists that are created once and then updated.

:class:`LegArtists` owns the moving parts of one leg (links, crank, joints, foot, velocity arrow);
``update(P, v)`` moves them with ``set_data`` / ``set_offsets`` only, so an animation never clears or
re-creates anything (seed 003 found that redrawing everything per frame is what makes it slow).
:func:`draw_ground` and :func:`draw_path` add the static parts once. Sliders: a ground slider's guide
is a dashed line over its vertex's travel (:func:`guide_segments`, static), a slot a thin groove along
its member (:func:`slot_segments`, moving), each sliding vertex a square block.

Positions are (n_vertices, 2) arrays in the mechanism's vertex order, model units. A leg can be drawn
mirrored about the vertical line through its crank centre (the hind legs of seed 001's four-legged
render): see :func:`mirror_positions` / :func:`mirror_velocity`.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.axes import Axes

from ..mechanism import Mechanism

#: Colours of the parts (matplotlib colour specs); tests look for FOOT_PATH_COLOR in rendered pixels.
LINK_COLOR = "#2b3a55"
CRANK_COLOR = "#d62728"
JOINT_FACE = "#ffffff"
FOOT_COLOR = "#9467bd"
ARROW_COLOR = "#2ca02c"
FOOT_PATH_COLOR = "#ff7f0e"
GROUND_COLOR = "#000000"
STANCE_COLOR = "#8c564b"
#: A ground slider's guide (dashed, over its travel) and a slot (a thin groove along its member).
GUIDE_COLOR = "#7f7f7f"
SLOT_COLOR = "#d9d9d9"


def mirror_positions(P: np.ndarray, cx: float) -> np.ndarray:
    """Positions reflected about the vertical line x = cx (any shape (..., 2))."""
    Q = np.array(P, dtype=np.float64, copy=True)
    Q[..., 0] = 2.0 * cx - Q[..., 0]
    return Q


def mirror_velocity(V: np.ndarray) -> np.ndarray:
    """World dP/dβ of a mirrored leg from its own dP/dα, where the leg is solved at α = π − β.

    Reflection maps (vx, vy) → (−vx, vy) and dα/dβ = −1, so the result is (vx, −vy).
    """
    W = np.array(V, dtype=np.float64, copy=True)
    W[..., 1] = -W[..., 1]
    return W


def hull_order(points) -> list[int]:
    """Indices of ``points`` (n, 2) around their convex hull, counter-clockwise, the first repeated at
    the end (Andrew's monotone chain); for collinear points, the two outermost there and back."""
    pts = np.asarray(points, dtype=np.float64)
    order = sorted(range(len(pts)), key=lambda i: (pts[i, 0], pts[i, 1]))

    def cross(o, a, b):
        return (pts[a, 0] - pts[o, 0]) * (pts[b, 1] - pts[o, 1]) - (pts[a, 1] - pts[o, 1]) * (pts[b, 0] - pts[o, 0])

    lower, upper = [], []
    for i in order:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], i) <= 0:
            lower.pop()
        lower.append(i)
    for i in reversed(order):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], i) <= 0:
            upper.pop()
        upper.append(i)
    hull = lower[:-1] + upper[:-1]
    return hull + hull[:1]


def slot_segments(mech: Mechanism, P: np.ndarray) -> np.ndarray:
    """(n_slots, 2, 2) the slots of ``mech`` at positions ``P`` (n_vertices, 2), in ``mech.sliders``
    order (slots only): each the line through its slider's vertex parallel to the slot's a → b (the
    vertex is on it in a solved configuration, whatever the offset, so a mirrored leg needs no sign
    flip), from the first to the last of a, b and the vertex projected onto it. Model units."""
    P = np.asarray(P, dtype=np.float64)
    out = np.full((sum(not sl.ground for sl in mech.sliders), 2, 2), np.nan)
    k = 0
    for sl in mech.sliders:
        if sl.ground:
            continue
        a, b = P[mech.vertex_index(sl.line[0])], P[mech.vertex_index(sl.line[1])]
        v = P[mech.vertex_index(sl.vertex)]
        d = b - a
        n = math.hypot(d[0], d[1])
        if n > 0:
            u = d / n
            t = ((a - v) @ u, (b - v) @ u, 0.0)
            out[k] = v + np.outer([min(t), max(t)], u)
        k += 1
    return out


def guide_segments(mech: Mechanism, positions: np.ndarray, pad: float = 0.1) -> np.ndarray:
    """(n_ground_sliders, 2, 2) the ground sliders' guides of ``mech`` (``mech.sliders`` order, ground
    lines only): each a segment of its line (``point``, ``direction``) over the travel of its vertex in
    ``positions`` (S, n_vertices, 2; non-finite rows skipped), from the lowest to the highest
    projection along the direction, lengthened by ``pad`` × the stroke at both ends (a stroke of zero,
    or no finite position: ``pad`` × the mechanism's size, about the line's point). Model units."""
    pos = np.asarray(positions, dtype=np.float64)
    ground = [sl for sl in mech.sliders if sl.ground]
    out = np.empty((len(ground), 2, 2))
    for k, sl in enumerate(ground):
        p = np.asarray(sl.point, dtype=np.float64)
        u = np.asarray(sl.unit())
        v = pos[:, mech.vertex_index(sl.vertex)]
        t = (v[np.isfinite(v).all(axis=1)] - p) @ u
        lo, hi = (float(t.min()), float(t.max())) if t.size else (0.0, 0.0)
        e = pad * (hi - lo) if hi > lo else pad * mech.size
        out[k] = p + np.outer([lo - e, hi + e], u)
    return out


class LegArtists:
    """The moving artists of one leg on ``ax``: create once, then :meth:`update` per frame.

    Parameters
    ----------
    ax : matplotlib Axes
    mech : Mechanism (its links, crank tip, crank centre and foot are drawn)
    arrow_scale : float
        Data units of arrow length per (model unit / radian) of foot speed; 0 hides the arrow.
    alpha : float
        Opacity of the whole leg (legs behind others are drawn fainter).
    zorder : float
        Base z-order; the parts stack above it.
    max_arrow : float or None
        Longest arrow drawn (data units); longer ones are shortened to it, direction kept.
    """

    def __init__(self, ax: Axes, mech: Mechanism, *, arrow_scale: float = 1.0, alpha: float = 1.0,
                 zorder: float = 3.0, link_color: str = LINK_COLOR, linewidth: float = 2.4, label: str | None = None,
                 max_arrow: float | None = None):
        self.ax = ax
        self.max_arrow = max_arrow
        self.mech = mech
        self.arrow_scale = float(arrow_scale)
        self._a = np.array([mech.vertex_index(l.a) for l in mech.links], dtype=np.int64)
        self._b = np.array([mech.vertex_index(l.b) for l in mech.links], dtype=np.int64)
        self._tip = mech.vertex_index(mech.driven)
        self._foot = mech.vertex_index(mech.foot)
        # a path driver has no crank arm: its "crank" artist stays empty
        self._center = np.array(mech.crank.center, dtype=np.float64) if mech.crank is not None else None
        nl = len(mech.links)
        # each rigid body is drawn as the outline of its joints (its convex hull; a collinear body as
        # the bar between its two outermost joints), closed, after the links
        self._loops = [np.array([mech.vertex_index(b.joints[i]) for i in hull_order(b.points)], dtype=np.int64)
                       for b in mech.bodies]
        # one polyline with NaN breaks draws every link and body in a single artist
        self._seg = np.full((3 * nl + sum(len(lp) + 1 for lp in self._loops), 2), np.nan)
        # sliders: each slot a thin groove along its member, each sliding vertex a square block
        self._n_slots = sum(not sl.ground for sl in mech.sliders)
        self._slot = np.full((3 * self._n_slots, 2), np.nan)
        self._blocks = np.array([mech.vertex_index(sl.vertex) for sl in mech.sliders], dtype=np.int64)
        self._crank = np.empty((2, 2))
        (self.links,) = ax.plot([], [], "-", color=link_color, lw=linewidth, alpha=alpha, solid_capstyle="round",
                                zorder=zorder, label=label)
        (self.crank,) = ax.plot([], [], "-", color=CRANK_COLOR, lw=linewidth * 1.8, alpha=alpha,
                                solid_capstyle="round", zorder=zorder + 0.1)
        (self.slots,) = ax.plot([], [], "-", color=SLOT_COLOR, lw=max(linewidth * 0.45, 0.8), alpha=alpha,
                                solid_capstyle="round", zorder=zorder + 0.15)
        (self.blocks,) = ax.plot([], [], "s", ms=8.5, mfc=SLOT_COLOR, mec=link_color, mew=1.4, alpha=alpha,
                                 zorder=zorder + 0.18)
        (self.joints,) = ax.plot([], [], "o", ms=5.5, mfc=JOINT_FACE, mec=link_color, mew=1.4, alpha=alpha,
                                 zorder=zorder + 0.2)
        (self.foot,) = ax.plot([], [], "o", ms=8, color=FOOT_COLOR, alpha=alpha, zorder=zorder + 0.3)
        self.arrow = ax.quiver([0.0], [0.0], [0.0], [0.0], angles="xy", scale_units="xy", scale=1.0,
                               color=ARROW_COLOR, alpha=alpha, width=0.007, headwidth=3.5, headlength=4.5,
                               headaxislength=4.0, zorder=zorder + 0.4)
        self.arrow.set_visible(self.arrow_scale > 0)
        self._visible = True

    @property
    def artists(self) -> list:
        return [self.links, self.crank, self.slots, self.blocks, self.joints, self.foot, self.arrow]

    def set_visible(self, visible: bool) -> None:
        if visible != self._visible:
            for a in self.artists:
                a.set_visible(visible)
            self.arrow.set_visible(visible and self.arrow_scale > 0)
            self._visible = visible

    def update(self, P: np.ndarray, v: np.ndarray | None = None) -> None:
        """Move the leg to positions ``P`` (n_vertices, 2); ``v`` is the foot's dF/dθ (2,) or None.

        A configuration with a non-finite position (past a failure) hides the leg.
        """
        if not np.isfinite(P).all():
            self.set_visible(False)
            return
        self.set_visible(True)
        seg = self._seg
        nl3 = 3 * len(self._a)
        seg[0:nl3:3] = P[self._a]
        seg[1:nl3:3] = P[self._b]
        o = nl3
        for lp in self._loops:
            seg[o:o + len(lp)] = P[lp]
            o += len(lp) + 1
        self.links.set_data(seg[:, 0], seg[:, 1])
        if self._center is not None:
            self._crank[0] = self._center
            self._crank[1] = P[self._tip]
            self.crank.set_data(self._crank[:, 0], self._crank[:, 1])
        if self._n_slots:
            seg = slot_segments(self.mech, P)
            self._slot[0::3] = seg[:, 0]
            self._slot[1::3] = seg[:, 1]
            self.slots.set_data(self._slot[:, 0], self._slot[:, 1])
        if len(self._blocks):
            self.blocks.set_data(P[self._blocks, 0], P[self._blocks, 1])
        self.joints.set_data(P[:, 0], P[:, 1])
        f = P[self._foot]
        self.foot.set_data([f[0]], [f[1]])
        if self.arrow_scale > 0:
            if v is None or not np.isfinite(v).all():
                self.arrow.set_visible(False)
            else:
                self.arrow.set_visible(True)
                u = v * self.arrow_scale
                n = math.hypot(u[0], u[1])
                if self.max_arrow is not None and n > self.max_arrow:
                    u = u * (self.max_arrow / n)
                self.arrow.set_offsets(f[None, :])
                self.arrow.set_UVC(u[0], u[1])


def draw_ground(ax: Axes, mech: Mechanism, *, mirrored: bool = False, crank_circle: bool = True,
                zorder: float = 2.0, label: str | None = "ground pivots", positions: np.ndarray | None = None) -> list:
    """Static parts: the ground pivots (triangles), the crank centre and the crank circle (a path driver
    has neither: its path is drawn as the driven vertex's trajectory instead), and with ``positions``
    (S, n_vertices, 2: the configurations drawn) each ground slider's guide, dashed over its travel
    (:func:`guide_segments`)."""
    fixed = np.array(list(mech.fixed.values()), dtype=np.float64).reshape(-1, 2)
    if mech.crank is None:
        crank_circle = False
        cx = cy = None
        pts = fixed
    else:
        cx, cy = mech.crank.center
        pts = np.vstack([fixed, [[cx, cy]]])
    if mirrored and cx is not None:
        pts = mirror_positions(pts, cx)
    out = []
    (p,) = ax.plot(pts[:, 0], pts[:, 1], "^", ms=10, color=GROUND_COLOR, zorder=zorder, label=label)
    out.append(p)
    if positions is not None and any(sl.ground for sl in mech.sliders):
        seg = guide_segments(mech, positions)
        if mirrored and cx is not None:
            seg = mirror_positions(seg, cx)
        xy = np.concatenate([np.vstack([s, [[np.nan, np.nan]]]) for s in seg])
        (g,) = ax.plot(xy[:, 0], xy[:, 1], "--", color=GUIDE_COLOR, lw=1.6, zorder=zorder)
        out.append(g)
    if crank_circle:
        t = np.linspace(0.0, 2.0 * np.pi, 97)
        r = mech.crank.radius
        (c,) = ax.plot(cx + r * np.cos(t), cy + r * np.sin(t), ":", color=CRANK_COLOR, lw=1.0, alpha=0.6,
                       zorder=zorder)
        out.append(c)
    return out


def draw_path(ax: Axes, path: np.ndarray, *, closed: bool = True, color: str = FOOT_PATH_COLOR, lw: float = 2.0,
              zorder: float = 1.5, label: str | None = None, **kw):
    """The foot path (S, 2) as one line, closed back to its start when ``closed`` (a full ok cycle)."""
    path = np.asarray(path, dtype=np.float64)
    if closed and len(path):
        path = np.vstack([path, path[:1]])
    (line,) = ax.plot(path[:, 0], path[:, 1], "-", color=color, lw=lw, zorder=zorder, label=label, **kw)
    return line
