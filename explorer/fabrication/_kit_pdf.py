"""The assembly sheet of a build kit (issue 27): ``assembly.pdf``, A4 landscape, every length in mm.

:func:`write_assembly_pdf` writes ``1 + len(kit.parts)`` pages (matplotlib's PDF backend, text as real
TrueType text, so it can be searched and extracted):

* **Page 1, the assembly.** The leg at θ = 0 (:func:`explorer.kernels.assemble`), in mm relative to the
  crank centre (model units × ``kit.scale``), each part drawn in place as its outline (a link: a slot
  between its two joints; a body or the frame: the hull of its joints grown by half the part width),
  filled in the colour of its stack layer (lower layers drawn first), every joint labelled with its
  name, the ground pivots hatched, the crank centre marked and the crank circle dashed. Beside it: the
  stack order on each pin (bottom, the frame side, to top, each part with its layer; pin diameter ×
  length and count), the crank phase of each leg on the shaft (a list and a polar diagram of the crank
  arms at θ = 0), and a dimensioned drawing of the frame's pivots: x and y of every fixed pivot from the
  crank centre and the distance between every two of them. A footer states the scale (mm per model
  unit), the material, where the design came from and the tolerance it needs (if known).
* **One page per part** (``kit.parts`` order): its outline with each hole labelled with its joint name
  and diameter, the centre-to-centre distance of every pair of holes as dimension lines and as a table,
  the part width, copies and mirrored copies (a mirrored copy of an asymmetric part is drawn beside
  the plain one, as cut). The drawing is true size (1:1) when it fits the page, else at the first
  standard reduction that does (1:2, 1:2.5, 1:4, 1:5, 1:10, ...), stated on the page with a scale bar.
  Links and bodies are turned so their two farthest holes lie along x; the frame keeps the design's
  orientation (y up).

Numbers are printed by :func:`mm` (one decimal, mm) and :func:`degrees` (one decimal, ``°``), so a test
can compute the strings it expects to find.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from ..errors import UserError
from ._export import CRANK_CENTRE, _hull, _outline

#: A4 landscape, mm.
PAGE = (297.0, 210.0)
#: Standard drawing reductions tried in order (1:k); 1:1 is true size.
SCALES = (1.0, 2.0, 2.5, 4.0, 5.0, 10.0, 20.0, 25.0, 50.0, 100.0, 200.0, 500.0, 1000.0)
#: Fill colours of the stack layers (layer n: LAYER_COLORS[n % 10]).
LAYER_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                "#bcbd22", "#17becf")
INK = "#222222"
DIM_COLOR = "#0b4f9c"
_PT = 25.4 / 72.0  # mm per point


# -- formatting ------------------------------------------------------------------------------------------
def mm(x: float) -> str:
    """A length in mm as the PDF prints it: one decimal, no sign on zero ("-76.0", "0.0")."""
    s = f"{float(x):.1f}"
    return "0.0" if s == "-0.0" else s


def degrees(deg: float) -> str:
    """An angle in degrees as the PDF prints it, in [0, 360): one decimal and a degree sign ("90.0°")."""
    d = round(float(deg) % 360.0, 1) % 360.0
    return f"{d:.1f}°"


def scale_text(k: float) -> str:
    """A drawing scale 1:k as printed ("1:1", "1:2.5")."""
    return f"1:{k:g}"


# -- geometry --------------------------------------------------------------------------------------------
def assembly_positions(mech) -> dict[str, np.ndarray]:
    """Every vertex and the crank centre at θ = 0, mm relative to the crank centre would be × scale; here
    model units: name → (2,) array. UserError if the design does not assemble at θ = 0."""
    from ..kernels import assemble
    P, fail = assemble(mech)
    P = np.asarray(P, dtype=np.float64)
    if fail is not None or not np.all(np.isfinite(P)):
        raise UserError(f"{mech.name}: cannot draw the assembly: the design does not assemble at θ = 0 ({fail})")
    pos = {v: P[i] for i, v in enumerate(mech.vertices)}
    if mech.crank is not None:
        pos[CRANK_CENTRE] = np.asarray(mech.crank.center, dtype=np.float64)
    return pos


def _origin(mech) -> np.ndarray:
    """The reference point of the drawings, model units: the crank centre (the first pivot without one)."""
    if mech.crank is not None:
        return np.asarray(mech.crank.center, dtype=np.float64)
    if mech.fixed:
        return np.asarray(next(iter(mech.fixed.values())), dtype=np.float64)
    return np.zeros(2)


def _joint_position(pos: dict, joint: str):
    """Position of a part's hole named ``joint`` (a merged hole "2+crank centre": its first known name)."""
    for name in joint.split("+"):
        if name in pos:
            return pos[name]
    return None


def frame_pivots(kit) -> list[tuple[str, float, float]]:
    """The frame's pivots in mm relative to the crank centre: [(name, x, y)], the crank centre first
    (0, 0), then every fixed pivot in the mechanism's vertex order (model coordinates − crank centre,
    × kit.scale)."""
    mech = kit.mechanism
    o = _origin(mech)
    out = []
    if mech.crank is not None:
        out.append((CRANK_CENTRE, 0.0, 0.0))
    for v in mech.vertices:
        if v in mech.fixed:
            x, y = (np.asarray(mech.fixed[v], dtype=np.float64) - o) * kit.scale
            out.append((v, float(x), float(y)))
    return out


def _outline_xy(holes, r: float) -> np.ndarray:
    """The outline of a part with holes ``holes`` (H, 2) grown by r, as a closed polygon (N, 2), mm."""
    hull = _hull(holes)
    if len(hull) < 2:
        c = hull[0] if hull else (0.0, 0.0)
        t = np.linspace(0.0, 2.0 * math.pi, 49)
        return np.column_stack([c[0] + r * np.cos(t), c[1] + r * np.sin(t)])
    pts = []
    for seg in _outline(hull, r):
        if seg[0] == "arc":
            _, c, rr, a0, a1 = seg
            t = np.linspace(a0, a1, max(2, int(math.ceil((a1 - a0) / (math.pi / 24))) + 1))
            pts.extend(zip(c[0] + rr * np.cos(t), c[1] + rr * np.sin(t)))
        else:
            pts.append(seg[1])
            pts.append(seg[2])
    return np.asarray(pts, dtype=np.float64)


def hole_groups(part) -> list[str]:
    """The holes of a part as its page lists them: "2 Ø3.0", runs of numbered holes of one size joined
    ("motor hole 1–6 Ø3.0", "standoff 1–3 Ø4.0")."""
    import re
    out: list[list] = []  # [prefix, first, last, d] or [name, None, None, d]
    for j, d in zip(part.joints, part.diameters):
        m = re.fullmatch(r"(.*\D) (\d+)", j)
        if m and out and out[-1][1] is not None and out[-1][0] == m.group(1) and out[-1][3] == d \
                and int(m.group(2)) == out[-1][2] + 1:
            out[-1][2] = int(m.group(2))
        elif m:
            out.append([m.group(1), int(m.group(2)), int(m.group(2)), d])
        else:
            out.append([j, None, None, d])
    return [f"{p} Ø{mm(d)}" if a is None else (f"{p} {a} Ø{mm(d)}" if a == b else f"{p} {a}–{b} Ø{mm(d)}")
            for p, a, b, d in out]


def shown_pairs(part) -> list[tuple[str, str, float]]:
    """The hole-to-hole distances a part's page prints and dimensions: every pair (:func:`pair_distances`) up
    to six holes, else those from the first hole (a plate's centre)."""
    pairs = pair_distances(part)
    return pairs if len(part.holes) <= 6 else [t for t in pairs if t[0] == part.joints[0]]


def pair_distances(part) -> list[tuple[str, str, float]]:
    """Centre-to-centre distance of every pair of the part's holes, mm: [(joint i, joint j, d)], i < j in
    hole order."""
    H = np.asarray(part.holes, dtype=np.float64)
    return [(part.joints[i], part.joints[j], float(math.dist(H[i], H[j])))
            for i in range(len(H)) for j in range(i + 1, len(H))]


def _turned(holes: np.ndarray, mirrored: bool, along_x: bool) -> np.ndarray:
    """Holes (H, 2) mirrored (x → −x) if asked, then turned so the two farthest lie along +x (if along_x),
    and shifted so the first hole of that pair is at the origin."""
    P = np.array(holes, dtype=np.float64)
    if mirrored:
        P[:, 0] = -P[:, 0]
    if not along_x or len(P) < 2:
        return P
    i, j, best = 0, 1, -1.0
    for a in range(len(P)):
        for b in range(a + 1, len(P)):
            d = math.dist(P[a], P[b])
            if d > best + 1e-12:
                i, j, best = a, b, d
    if P[j][0] < P[i][0]:
        i, j = j, i
    ang = math.atan2(P[j][1] - P[i][1], P[j][0] - P[i][0])
    c, s = math.cos(-ang), math.sin(-ang)
    Q = P - P[i]
    return np.column_stack([c * Q[:, 0] - s * Q[:, 1], s * Q[:, 0] + c * Q[:, 1]])


# -- drawing helpers -------------------------------------------------------------------------------------
def _axes(fig, x: float, y: float, w: float, h: float, **kw):
    """An axes at (x, y) mm from the page's lower left, w × h mm, no frame."""
    ax = fig.add_axes([x / PAGE[0], y / PAGE[1], w / PAGE[0], h / PAGE[1]], **kw)
    ax.set_axis_off()
    return ax


def _text(fig, x: float, y: float, s: str, **kw):
    """Text at (x, y) mm on the page."""
    kw.setdefault("color", INK)
    return fig.text(x / PAGE[0], y / PAGE[1], s, **kw)


def _fit_scale(w: float, h: float, box_w: float, box_h: float, margin: float = 0.0) -> float:
    """The first standard reduction k (:data:`SCALES`) at which a drawing w × h mm (plus ``margin`` mm of
    paper on every side) fits a box of box_w × box_h mm of paper."""
    for k in SCALES:
        if w / k + 2 * margin <= box_w and h / k + 2 * margin <= box_h:
            return k
    return SCALES[-1]


def _set_view(ax, centre, k: float, box_w: float, box_h: float) -> None:
    """Show data mm at 1:k in an axes of box_w × box_h mm of paper, centred on ``centre``."""
    cx, cy = centre
    ax.set_xlim(cx - 0.5 * box_w * k, cx + 0.5 * box_w * k)
    ax.set_ylim(cy - 0.5 * box_h * k, cy + 0.5 * box_h * k)


def _dimension(ax, p, q, off: float, text: str, k: float, fs: float = 6.5, color: str = DIM_COLOR,
               labels: _Labels | None = None) -> None:
    """An aligned dimension between points p and q (data mm): a line with arrows ``off`` data mm along the
    left normal of p → q (negative: the right), extension lines from the points, ``text`` on the line's
    outer side, upright; its lines and text become obstacles of ``labels``."""
    p, q = np.asarray(p, dtype=np.float64), np.asarray(q, dtype=np.float64)
    d = q - p
    L = float(np.hypot(*d))
    if L <= 0:
        return
    u = d / L
    n = np.array([-u[1], u[0]])
    if off < 0:
        n, off = -n, -off
    a, b = p + n * off, q + n * off
    gap, over = 1.0 * k, 1.5 * k
    for s in (p, q):
        e0, e1 = s + n * min(gap, off), s + n * (off + over)
        ax.plot([e0[0], e1[0]], [e0[1], e1[1]], color=color, lw=0.4, zorder=20)
        if labels is not None:
            labels.segment(e0, e1)
    ax.annotate("", xy=b, xytext=a, zorder=20,
                arrowprops=dict(arrowstyle="<|-|>", color=color, lw=0.5, shrinkA=0, shrinkB=0, mutation_scale=5))
    ang = math.degrees(math.atan2(u[1], u[0]))
    if ang > 90.0 + 1e-9:
        ang -= 180.0
    elif ang <= -90.0 + 1e-9:
        ang += 180.0
    up = np.array([-math.sin(math.radians(ang)), math.cos(math.radians(ang))])
    m = 0.5 * (a + b) + n * 0.6 * k
    if labels is not None:
        labels.segment(a, b)
        tw = 0.5 * (len(text) * 0.62 * fs * _PT + 1.0) * k
        for lift in (0.5, 1.5):
            c = m + n * lift * fs * _PT * k
            labels.segment(c - u * tw, c + u * tw)
    ax.text(m[0], m[1], text, rotation=ang, rotation_mode="anchor", ha="center",
            va="bottom" if float(up @ n) >= 0 else "top", fontsize=fs, color=color, zorder=21,
            bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none", alpha=0.8))


def _scale_bar(ax, x0: float, y0: float, k: float, box_w: float) -> None:
    """A scale bar at data (x0, y0): a round length of part mm drawn at 1:k, labelled."""
    target = 0.25 * box_w * k
    length = 10.0
    for v in (1, 2, 5, 10, 20, 25, 50, 100, 200, 250, 500, 1000, 2000, 5000):
        if v <= target:
            length = float(v)
    ax.plot([x0, x0 + length], [y0, y0], color=INK, lw=1.2, solid_capstyle="butt", zorder=25)
    for x in (x0, x0 + length):
        ax.plot([x, x], [y0 - 0.8 * k, y0 + 0.8 * k], color=INK, lw=0.6, zorder=25)
    ax.text(x0 + 0.5 * length, y0 + 1.2 * k, f"{length:g} mm (drawn {scale_text(k)})", ha="center", va="bottom",
            fontsize=6, color=INK, zorder=25)


class _Labels:
    """Places labels next to points without covering the obstacles (segments) or each other: for each
    label the candidate directions are tried and the one whose box crosses the fewest obstacles wins
    (ties: the preferred direction). Coordinates are data mm; k is the drawing's reduction (1:k)."""

    def __init__(self, k: float):
        self.k = k
        self.segments: list[tuple[np.ndarray, np.ndarray]] = []
        self.boxes: list[tuple[float, float, float, float]] = []

    def segment(self, p, q) -> None:
        self.segments.append((np.asarray(p, dtype=np.float64), np.asarray(q, dtype=np.float64)))

    def polygon(self, P) -> None:
        P = np.asarray(P, dtype=np.float64)
        for i in range(len(P)):
            self.segment(P[i], P[(i + 1) % len(P)])

    def box(self, x0, y0, x1, y1) -> None:
        self.boxes.append((x0, y0, x1, y1))

    @staticmethod
    def _hits(seg, box) -> bool:
        """Whether segment seg crosses the box (x0, y0, x1, y1) (Liang–Barsky)."""
        (px, py), (qx, qy) = seg
        x0, y0, x1, y1 = box
        dx, dy = qx - px, qy - py
        t0, t1 = 0.0, 1.0
        for p, q in ((-dx, px - x0), (dx, x1 - px), (-dy, py - y0), (dy, y1 - py)):
            if p == 0:
                if q < 0:
                    return False
            else:
                t = q / p
                if p < 0:
                    t0 = max(t0, t)
                else:
                    t1 = min(t1, t)
                if t0 > t1:
                    return False
        return True

    def place(self, ax, p, text: str, fontsize: float, gap: float, prefer=None, **kw):
        """Put ``text`` (lines) beside point p, ``gap`` data mm from it; prefer : a unit vector, the
        direction to take when several are free."""
        lines = text.split("\n")
        w = (max(len(s) for s in lines) * 0.64 * fontsize * _PT + 1.2) * self.k
        h = (len(lines) * 1.22 * fontsize * _PT + 1.0) * self.k
        prefer = np.array([0.6, 0.8]) if prefer is None else np.asarray(prefer, dtype=np.float64)
        best = None
        for a in np.radians(np.arange(0.0, 360.0, 22.5)):
            u = np.array([math.cos(a), math.sin(a)])
            # the box's centre: gap from p along u, plus the box's half extent along u
            reach = gap + 0.5 * min(w / max(abs(u[0]), 1e-9), h / max(abs(u[1]), 1e-9))
            c = np.asarray(p, dtype=np.float64) + u * reach
            box = (c[0] - 0.5 * w, c[1] - 0.5 * h, c[0] + 0.5 * w, c[1] + 0.5 * h)
            cost = sum(self._hits(s, box) for s in self.segments)
            cost += sum(3 for b in self.boxes if box[0] < b[2] and b[0] < box[2] and box[1] < b[3] and b[1] < box[3])
            score = (cost, -float(u @ prefer))
            if best is None or score < best[0]:
                best = (score, c, box)
        _, c, box = best
        self.boxes.append(box)
        ax.text(c[0], c[1], text, ha="center", va="center", fontsize=fontsize, linespacing=1.1, **kw)


def _layer_color(layer: int) -> str:
    return LAYER_COLORS[int(layer) % len(LAYER_COLORS)]


def _free_direction(angles) -> np.ndarray:
    """A unit vector in the middle of the widest gap between the directions ``angles`` (radians); up-right
    if there are none."""
    if not angles:
        return np.array([0.6, 0.8])
    a = sorted(x % (2.0 * math.pi) for x in angles)
    gaps = [((a[(i + 1) % len(a)] - a[i]) % (2.0 * math.pi) or 2.0 * math.pi, a[i]) for i in range(len(a))]
    g, start = max(gaps)
    t = start + 0.5 * g
    return np.array([math.cos(t), math.sin(t)])


def _away(p, others) -> np.ndarray:
    """A unit vector pointing from the mean of ``others`` to p (up-right if they coincide)."""
    if len(others) == 0:
        return np.array([0.6, 0.8])
    v = np.asarray(p, dtype=np.float64) - np.mean(np.asarray(others, dtype=np.float64), axis=0)
    n = float(np.hypot(*v))
    return v / n if n > 1e-9 else np.array([0.6, 0.8])


# -- page 1 ----------------------------------------------------------------------------------------------
def _page_assembly(fig, kit) -> None:
    mech, s = kit.mechanism, kit.scale
    pos = assembly_positions(mech)
    o = _origin(mech)
    world = {name: (p - o) * s for name, p in pos.items()}
    if kit.chassis is not None:
        for name, x, y in kit.chassis.standoffs:
            world[name] = np.array([x, y])

    _text(fig, 10, 200, f"{mech.name}: assembly at θ = 0°", fontsize=14, weight="bold", va="baseline")
    _text(fig, 10, 194.5, f"all lengths in mm · scale {kit.scale:g} mm per model unit · part width "
          f"{mm(kit.width)} mm · {len(kit.parts)} parts, {len(kit.legs)} legs · drawn as seen from the front "
          "(layer 0, the frame, at the back)", fontsize=7.5, va="baseline")

    # the assembly drawing: placed outlines, coloured by layer
    placed = []
    for part in kit.parts:
        if part.layer is None or part.kind == "crank" and part.name != "crank":
            continue  # chassis plates are drawn on the chassis page; one crank web is enough here
        pts = [_joint_position(world, j) for j in part.joints]
        if any(p is None for p in pts):
            continue
        placed.append((kit.layers.get(part.name, 0), part, np.asarray(pts)))
    placed.sort(key=lambda t: t[0])
    allpts = np.vstack([p for _, _, p in placed] + [np.zeros((1, 2))])
    wmax = max(part.width for _, part, _ in placed)
    lo, hi = allpts.min(axis=0) - wmax, allpts.max(axis=0) + wmax
    box = (10.0, 32.0, 165.0, 156.0)  # x, y, w, h of the drawing on the page, mm
    k = _fit_scale(hi[0] - lo[0], hi[1] - lo[1], box[2], box[3], margin=5.0)
    ax = _axes(fig, *box)
    _set_view(ax, 0.5 * (lo + hi), k, box[2], box[3])
    ax.set_aspect("equal", adjustable="box")
    _set_view(ax, 0.5 * (lo + hi), k, box[2], box[3])

    if mech.crank is not None:
        r = mech.crank.radius * s
        t = np.linspace(0, 2 * math.pi, 181)
        ax.plot(r * np.cos(t), r * np.sin(t), ls=(0, (4, 3)), lw=0.5, color="#888888", zorder=1)
    for layer, part, P in placed:
        col = _layer_color(layer)
        poly = _outline_xy(P, 0.5 * part.width)
        ax.fill(poly[:, 0], poly[:, 1], fc=col, alpha=0.35, ec="none", zorder=2 + 2 * layer)
        ax.plot(np.r_[poly[:, 0], poly[0, 0]], np.r_[poly[:, 1], poly[0, 1]], color=col, lw=0.8, zorder=3 + 2 * layer)
        for (x, y), d in zip(P, part.diameters):
            ax.add_patch(_circle((x, y), 0.5 * d, fc="white", ec=INK, lw=0.4, zorder=3 + 2 * layer))

    top = 10 + 2 * (max((lay for lay, _, _ in placed), default=0) + 1)
    # ground pivots (hatched triangles) and the crank centre (a circled cross)
    tri = 2.6 * k
    for name, x, y in frame_pivots(kit):
        if name == CRANK_CENTRE:
            ax.add_patch(_circle((x, y), 1.6 * k, fc="white", ec=INK, lw=0.8, zorder=top))
            ax.plot([x - 2.4 * k, x + 2.4 * k], [y, y], color=INK, lw=0.6, zorder=top + 1)
            ax.plot([x, x], [y - 2.4 * k, y + 2.4 * k], color=INK, lw=0.6, zorder=top + 1)
        else:
            from matplotlib.patches import Polygon
            ax.add_patch(Polygon([(x, y - 0.5 * kit.width), (x - tri, y - 0.5 * kit.width - 1.6 * tri),
                                  (x + tri, y - 0.5 * kit.width - 1.6 * tri)], closed=True, fc="white", ec=INK,
                                 hatch="/////", lw=0.6, zorder=top))

    # every joint labelled in the widest free angle between the parts (and the pivot's triangle) at it
    spokes: dict[str, list[float]] = {}
    for _, part, P in placed:
        for j, p in zip(part.joints, P):
            for p2 in P:
                if float(np.hypot(*(p2 - p))) > 1e-9:
                    for single in j.split("+"):
                        spokes.setdefault(single, []).append(math.atan2(p2[1] - p[1], p2[0] - p[0]))
    for name in mech.fixed:
        spokes.setdefault(name, []).append(-0.5 * math.pi)
    labels = _Labels(k)
    for _, part, P in placed:
        labels.polygon(_outline_xy(P, 0.5 * part.width))
    for name, x, y in frame_pivots(kit):
        if name == CRANK_CENTRE:
            labels.box(x - 2.4 * k, y - 2.4 * k, x + 2.4 * k, y + 2.4 * k)
        else:
            labels.box(x - tri, y - 0.5 * kit.width - 1.6 * tri, x + tri, y - 0.5 * kit.width)
    names = [v for v in mech.vertices] + ([CRANK_CENTRE] if mech.crank is not None else [])
    names += [n for n, *_ in (kit.chassis.standoffs if kit.chassis is not None else ())]
    for name in sorted(names, key=len, reverse=True):
        labels.place(ax, world[name], name, 7.5, 0.5 * kit.width + 1.2 * k, prefer=_free_direction(spokes.get(name, [])),
                     weight="bold", color=INK, zorder=top + 5,
                     bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="#999999", lw=0.3, alpha=0.85))
    x0, y0 = ax.get_xlim()[0] + 4 * k, ax.get_ylim()[0] + 3 * k
    _scale_bar(ax, x0, y0, k, box[2])

    # layer legend under the drawing
    layers = sorted({lay for lay, _, _ in placed})
    x = 10.0
    _text(fig, x, 26.5, "stack layers:", fontsize=7, va="center")
    x += 18.0
    for lay in layers:
        fig.patches.append(_rect_page(fig, x, 25.0, 5.0, 3.0, _layer_color(lay)))
        label = f"{lay} (frame side)" if lay == layers[0] else str(lay)
        _text(fig, x + 6.0, 26.5, label, fontsize=7, va="center")
        x += 9.0 + 1.3 * len(label)

    y = _pins_block(fig, kit, 182.0, 188.0)
    y = _phases_block(fig, kit, 182.0, y - 4.0)
    _frame_block(fig, kit, 182.0, y - 4.0, 108.0, 24.0)
    _footer(fig, kit)


# -- page 2: the crankshaft and the chassis ----------------------------------------------------------------
def leg_order_lines(kit) -> list[str]:
    """The crank arrangement table of the chassis page, one line per leg in its order along the shaft from the
    motor: "leg 2 at z = 62.5 mm: crank 90.0°, mirrored; webs on layers 1 and 4; D-flat normal 270.0°"."""
    sh = kit.shaft
    out = []
    webs = [kit.layers["crank"]] + ([kit.layers["crank-outer"]] if sh.mode == "throws" else [])
    for leg in sorted(kit.legs, key=lambda lg: lg.z):
        w = (f"webs on layers {webs[0]} and {webs[1]}" if len(webs) == 2 else f"arm on layer {webs[0]}")
        out.append(f"leg {leg.index + 1} at z = {mm(leg.z)} mm: crank {degrees(leg.phase_deg)}"
                   + (", mirrored" if leg.mirrored else "") + f"; {w}; D-flat normal {degrees(-leg.phase_deg)}")
    return out


def shaft_lines(kit) -> list[str]:
    """What the chassis page says of the shaft and its sizing."""
    sh, m, ch = kit.shaft, kit.material, kit.chassis
    mode = {"through": "one straight rod through every leg",
            "outboard": "it ends at the outboard crank arm",
            "throws": f"a crank with throws: {len(sh.segments)} pieces between the webs"}[sh.mode]
    out = [f"crankshaft: Ø{mm(sh.diameter)} mm {m.shaft_material}, {mm(sh.length)} mm of rod; {mode}",
           f"D-flat {mm(sh.flat)} mm deep along it; bushings Ø{mm(sh.diameter)}/{mm(sh.bushing_od)} mm in every frame "
           f"plate" + ("" if sh.mode == "outboard" else " and the end plate")]
    if sh.torque is not None:
        out.append(f"sized for T = {sh.torque:.3g} N·m (peak motor torque) and M = {sh.bending:.3g} N·m (crank pin "
                   f"{sh.arm_force:.4g} N at {mm(sh.arm)} mm from a bushing): needs Ø{mm(sh.required)} mm")
    else:
        out.append("not sized from a load (no forces): the standard size nearest a fifth of the crank radius")
    out.append(f"standoffs: {len(ch.standoffs)} × M{ch.standoff_d:g} threaded rod, {mm(ch.standoff_length)} mm, "
               f"a nut each side of each plate")
    out.append(f"motor: Ø{mm(ch.motor_shaft)} mm shaft, {ch.motor_holes[0]} × Ø{mm(ch.motor_holes[1])} on "
               f"Ø{mm(ch.motor_holes[2])} mm; coupler to the crankshaft")
    return out


def _page_chassis(fig, kit) -> None:
    """The crankshaft and the chassis: a section along the shaft (z across, y up, at θ = 0: each leg's crank
    pin where its phase puts it), the legs' order, the crank arrangement, the shaft's sizing, the motor
    plate, and the clearance found."""
    from matplotlib.patches import Rectangle
    from ._kit_stack import WASHER
    from ._kit_chassis import COUPLER, MOTOR_GAP
    mech, sh, ch = kit.mechanism, kit.shaft, kit.chassis
    t = kit.material.thickness
    _text(fig, 10, 200, f"{mech.name}: crankshaft and chassis", fontsize=14, weight="bold", va="baseline")
    _text(fig, 10, 194.5, "section along the shaft at θ = 0 (z from the motor plate across, y up; the legs' parts "
          "are the coloured layers, each leg's crank pin at its phase), all lengths in mm", fontsize=7.5,
          va="baseline")
    r = mech.crank.radius * kit.scale
    ys = [0.0, r, -r] + [y for _, _, y in ch.standoffs]
    ylo, yhi = min(ys) - 8.0, max(ys) + 8.0
    zlo, zhi = -45.0, ch.length + 15.0
    box = (10.0, 80.0, 277.0, 106.0)
    k = _fit_scale(zhi - zlo, yhi - ylo, box[2], box[3] - 8.0)
    ax = _axes(fig, *box)
    _set_view(ax, (0.5 * (zlo + zhi), 0.5 * (ylo + yhi)), k, box[2], box[3])
    ax.set_aspect("equal", adjustable="box")
    _set_view(ax, (0.5 * (zlo + zhi), 0.5 * (ylo + yhi)), k, box[2], box[3])
    p = t + WASHER
    top = max(v for v in kit.layers.values())
    depth = (top + 1) * t + top * WASHER
    # the legs' layers
    for leg in kit.legs:
        for layer in range(1, top + 1):
            z = leg.z + layer * p
            ax.add_patch(Rectangle((z, ylo + 4 * k), t, yhi - ylo - 8 * k, fc=_layer_color(layer), alpha=0.18,
                                   ec="none", zorder=1))
        ax.text(leg.z + 0.5 * (t + depth), yhi + 0.5 * k, f"leg {leg.index + 1}\n{degrees(leg.phase_deg)}"
                + (" M" if leg.mirrored else ""), ha="center", va="bottom", fontsize=6, color=INK, zorder=30)
    # the plates
    for name, z in ch.plates:
        ax.add_patch(Rectangle((z, ylo + 2 * k), t, yhi - ylo - 4 * k, fc="#c8a26b", ec=INK, lw=0.5, zorder=3))
        if not name.startswith("frame"):
            ax.text(z + 0.5 * t, ylo + 1.0 * k, name, ha="center", va="top", fontsize=6, color=INK, zorder=30)
    # the standoffs
    by_y: dict[float, list] = {}
    for name, x, y in ch.standoffs:
        by_y.setdefault(round(y, 6), []).append((name, x))
    for y, items in by_y.items():
        ax.plot([-2.0 * ch.standoff_d, ch.length + 2.0 * ch.standoff_d], [y, y], color="#555555", lw=1.0, zorder=4)
        label = ", ".join(f"{n} (x = {mm(x)})" for n, x in items)
        ax.text(ch.length + 3.0 * ch.standoff_d, y, label, fontsize=5.5, va="center", zorder=30)
    # the motor and the coupler
    ax.add_patch(Rectangle((-40.0, -18.0), 40.0, 36.0, fc="#dddddd", ec=INK, lw=0.6, zorder=2))
    ax.text(-20.0, 0.0, "motor", ha="center", va="center", fontsize=6, zorder=30)
    zc = t + 0.5 * MOTOR_GAP
    ax.add_patch(Rectangle((zc - 0.5 * COUPLER, -0.5 * max(10.0, 2 * sh.diameter)), COUPLER,
                           max(10.0, 2 * sh.diameter), fc="#999999", ec=INK, lw=0.5, zorder=5))
    # the shaft, the webs and the crank pins at θ = 0
    for a, b in sh.segments:
        ax.add_patch(Rectangle((a, -0.5 * sh.diameter), b - a, sh.diameter, fc="#444444", ec="none", zorder=6))
    webs = [kit.layers["crank"]] + ([kit.layers["crank-outer"]] if sh.mode == "throws" else [])
    pin_r = 0.5 * kit.pin(mech.crank.tip).diameter
    for leg in kit.legs:
        yp = r * math.sin(math.radians(leg.phase_deg))
        for w in webs:
            z = leg.z + w * p
            ax.add_patch(Rectangle((z, min(0.0, yp) - 0.5 * kit.part("crank").width), t,
                                   abs(yp) + kit.part("crank").width, fc="#1f77b4", ec=INK, lw=0.4, zorder=7))
        z0 = leg.z + webs[0] * p
        z1 = leg.z + (webs[-1] * p + t if len(webs) == 2 else (max(kit.pin(mech.crank.tip).layers) + 1) * p)
        ax.add_patch(Rectangle((z0, yp - pin_r), z1 - z0, 2 * pin_r, fc="#d62728", ec="none", zorder=8))
    ax.plot([zlo, zhi], [0, 0], color=INK, lw=0.3, ls=(0, (6, 2, 1, 2)), zorder=9)
    _scale_bar(ax, zlo, yhi - 1.0 * k, k, 0.5 * (zhi - zlo) / k)
    _text(fig, box[0] + box[2], box[1] + box[3] + 1.0, f"drawn {scale_text(k)}", fontsize=6, ha="right",
          color="#555555")
    # tables
    y = 72.0
    _text(fig, 10, y, "The legs along the shaft, from the motor", fontsize=8.5, weight="bold")
    lines = leg_order_lines(kit)
    fs = 6.5 if len(lines) <= 8 else max(4.5, 6.5 * 8 / len(lines))
    for i, line in enumerate(lines):
        _text(fig, 10, y - 3.5 - i * fs * _PT * 1.3, line, fontsize=fs, va="top")
    y2 = y - 5.0 - len(lines) * fs * _PT * 1.3 - 2.0
    _text(fig, 10, y2, "Crankshaft, bushings, standoffs, motor", fontsize=8.5, weight="bold")
    for i, line in enumerate(shaft_lines(kit)):
        _text(fig, 10, y2 - 3.5 - i * 3.0, line, fontsize=6.5, va="top")
    y3 = y2 - 5.0 - len(shaft_lines(kit)) * 3.0 - 2.0
    from ._kit_stack import clearance_line
    for i, line in enumerate(textwrap.wrap("Clearance: " + clearance_line(kit), 105)):
        _text(fig, 10, y3 - i * 3.0, line, fontsize=6.5, va="top", weight="bold" if i == 0 else "normal")
    # the motor plate, front view
    motor = kit.part("motor plate")
    bx, by, bw, bh = 200.0, 12.0, 87.0, 58.0
    _text(fig, bx, by + bh + 1.0, "motor plate (front)", fontsize=8.5, weight="bold")
    H = np.asarray(motor.holes, dtype=np.float64)
    poly = _outline_xy(H, 0.5 * motor.width)
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    km = _fit_scale(hi[0] - lo[0], hi[1] - lo[1], bw, bh, margin=4.0)
    axm = _axes(fig, bx, by, bw, bh)
    _set_view(axm, 0.5 * (lo + hi), km, bw, bh)
    axm.fill(poly[:, 0], poly[:, 1], fc="#c8a26b", alpha=0.3, ec=INK, lw=0.6)
    for (x, yy), d, j in zip(H, motor.diameters, motor.joints):
        axm.add_patch(_circle((x, yy), 0.5 * d, fc="white", ec=INK, lw=0.5, zorder=3))
        if j.startswith("standoff") or j == "motor":
            axm.text(x, yy + 0.5 * d + 1.0 * km, j, ha="center", va="bottom", fontsize=5.5, zorder=4)
    axm.text(0.02, 0.02, f"drawn {scale_text(km)}", transform=axm.transAxes, fontsize=5.5, color="#555555")


def _circle(c, r, **kw):
    from matplotlib.patches import Circle
    return Circle(c, r, **kw)


def _rect_page(fig, x, y, w, h, color):
    from matplotlib.patches import Rectangle
    return Rectangle((x / PAGE[0], y / PAGE[1]), w / PAGE[0], h / PAGE[1], transform=fig.transFigure,
                     fc=color, alpha=0.5, ec=color, lw=0.6)


def pin_lines(kit) -> list[tuple[str, str]]:
    """The stack table of page 1: one (head, stack) pair per pin: "2: Ø3.0 × 15.0 mm, 4 pins" and
    "frame [0] · 2-3 [1] · 2-4 [2]" (bottom → top, each part with its layer)."""
    out = []
    for pin in kit.pins:
        if pin.kind == "standoff":
            continue
        head = f"{pin.joint}: Ø{mm(pin.diameter)} × {mm(pin.length)} mm, {pin.count} pin{'s' if pin.count != 1 else ''}"
        if pin.kind == "shaft":
            head = (f"{pin.joint} (the crankshaft, {kit.shaft.mode}): Ø{mm(pin.diameter)}, layers "
                    f"{', '.join(map(str, pin.layers))} of every leg")
        stack = " · ".join(f"{p} [{kit.layers.get(p, '?')}]" for p in pin.stack)
        out.append((head, stack))
    return out


def _pins_block(fig, kit, x: float, ytop: float) -> float:
    """The pin stack table from ytop (mm of paper) down; returns the y of its bottom."""
    _text(fig, x, ytop, "Pins: stack order, bottom (frame side) → top [layer]", fontsize=8.5, weight="bold")
    lines = pin_lines(kit)
    n = sum(1 + len(textwrap.wrap(stack, 62, break_on_hyphens=False)) for _, stack in lines)
    fs = 6.5 if n <= 20 else max(4.5, 6.5 * 20 / n)
    lh = fs * _PT * 1.3
    y = ytop - 3.0
    for head, stack in lines:
        _text(fig, x, y, head, fontsize=fs, weight="bold", va="top")
        y -= lh
        for part in textwrap.wrap(stack, 62, break_on_hyphens=False):
            _text(fig, x + 4.0, y, part, fontsize=fs, va="top")
            y -= lh
        y -= 0.3 * lh
    return y


def leg_lines(kit) -> list[str]:
    """The crank phase list of page 1: "leg 1: 90.0°, mirrored" (legs numbered from 1)."""
    return [f"leg {leg.index + 1}: {degrees(leg.phase_deg)}" + (", mirrored" if leg.mirrored else "")
            for leg in kit.legs]


def _phases_block(fig, kit, x: float, ytop: float) -> float:
    """The crank phase list and the polar diagram of the crank arms from ytop down; returns its bottom."""
    _text(fig, x, ytop, "Crank phase of each leg on the shaft (at θ = 0)", fontsize=8.5, weight="bold")
    lines = leg_lines(kit)
    fs = 6.5 if len(lines) <= 8 else max(4.5, 6.5 * 8 / len(lines))
    lh = fs * _PT * 1.3
    y = ytop - 3.0
    for line in lines:
        _text(fig, x, y, line, fontsize=fs, va="top")
        y -= lh
    _text(fig, x, y - 1.0, "the crank arm's angle, counter-clockwise\nfrom +x as drawn; a mirrored leg is\n"
          "built from the mirrored parts", fontsize=5.5, va="top", color="#555555", linespacing=1.2)
    y -= 1.0 + 3 * 5.5 * _PT * 1.25
    # the polar diagram of the crank arms
    size = 27.0
    ax = fig.add_axes([(x + 66.0) / PAGE[0], (ytop - 5.0 - size) / PAGE[1], size / PAGE[0], size / PAGE[1]],
                      projection="polar")
    ax.set_ylim(0, 1.3)
    ax.set_rlim(0, 1.3)
    ax.set_yticks([])
    ax.set_xticks(np.radians(np.arange(0, 360, 90)))
    ax.set_xticklabels(["0°", "90°", "180°", "270°"], fontsize=5.5)
    ax.tick_params(pad=-1)
    ax.grid(lw=0.3)
    groups: dict[float, list] = {}
    for leg in kit.legs:
        groups.setdefault(round(float(leg.phase_deg) % 360.0, 6), []).append(leg)
    for ph, legs in groups.items():
        t = math.radians(ph)
        mirrored = all(leg.mirrored for leg in legs)
        ax.plot([t, t], [0, 0.6], color=INK, lw=1.0, ls="--" if mirrored else "-")
        ax.plot([t], [0.6], "o", ms=2.5, color=INK)
        ax.text(t, 0.98, ",".join(str(leg.index + 1) + ("m" if leg.mirrored else "") for leg in legs),
                fontsize=5.5, ha="center", va="center", color=DIM_COLOR)
    return min(y, ytop - 9.0 - size)


def pivot_lines(kit) -> list[str]:
    """The frame pivot table: "2: x = -76.0 mm, y = -15.6 mm" for every fixed pivot (from the crank
    centre), then "crank centre – 2: 77.6 mm" for every pair."""
    piv = frame_pivots(kit)
    out = [f"{n}: x = {mm(x)} mm, y = {mm(y)} mm" for n, x, y in piv if n != CRANK_CENTRE]
    for i in range(len(piv)):
        for j in range(i + 1, len(piv)):
            d = math.hypot(piv[j][1] - piv[i][1], piv[j][2] - piv[i][2])
            out.append(f"{piv[i][0]} – {piv[j][0]}: {mm(d)} mm")
    return out


def _frame_block(fig, kit, x: float, ytop: float, w: float, ybottom: float) -> None:
    """The frame's pivots from ytop down to ybottom (mm of paper), w wide: a table (x, y from the crank
    centre, the distance of every two pivots) at the left, the dimensioned drawing at its right."""
    _text(fig, x, ytop, "Frame pivots, mm from the crank centre", fontsize=8.5, weight="bold")
    piv = frame_pivots(kit)
    lines = pivot_lines(kit)
    fs = 6.0 if len(lines) <= 12 else max(4.5, 6.0 * 12 / len(lines))
    lh = fs * _PT * 1.35
    for i, line in enumerate(lines):
        _text(fig, x, ytop - 3.0 - i * lh, line, fontsize=fs, va="top")
    tw = 4.0 + max(len(s) for s in lines) * fs * _PT * 0.55 if lines else 0.0
    dx, dw = x + tw, w - tw
    dh = ytop - 3.0 - ybottom
    P = np.array([[px, py] for _, px, py in piv])
    lo, hi = P.min(axis=0), P.max(axis=0)
    n = len(P)
    margin = 6.0 + 4.0 * max(0, n - 1)  # room for the stacked baseline dimensions, mm of paper
    k = _fit_scale(hi[0] - lo[0], hi[1] - lo[1], dw - margin - 14.0, dh - margin - 6.0)
    ax = _axes(fig, dx, ybottom, dw, dh)
    # the drawing's lower left corner at the box's, less the room the dimensions need
    c = np.array([lo[0] - margin * k + 0.5 * dw * k, hi[1] + 5.0 * k - 0.5 * dh * k])  # top left
    _set_view(ax, c, k, dw, dh)
    _text(fig, dx + dw, ytop - 3.0, f"drawn {scale_text(k)}", fontsize=5.5, ha="right", va="top", color="#555555")
    for i in range(n):
        for j in range(i + 1, n):
            ax.plot(P[[i, j], 0], P[[i, j], 1], color="#999999", lw=0.5, ls=":", zorder=1)
            if i == 0 and min(abs(P[j][0]), abs(P[j][1])) <= 1e-9:
                continue  # from the crank centre along an axis: the baseline dimension says it
            d = math.dist(P[i], P[j])
            m = 0.5 * (P[i] + P[j])
            ax.text(m[0], m[1], mm(d), fontsize=5.5, color="#555555", ha="center", va="center", zorder=5,
                    bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none"))
    for name, px, py in piv:
        mark = "+" if name == CRANK_CENTRE else "o"
        ax.plot([px], [py], marker=mark, ms=5, mfc="white", mec=INK, mew=0.8, color=INK, zorder=6)
        ax.annotate(name, xy=(px, py), xytext=(3, 3), textcoords="offset points", fontsize=6, weight="bold",
                    zorder=7)
    # baseline dimensions: x under the drawing, y at its left, stacked
    others = [(name, px, py) for name, px, py in piv if name != CRANK_CENTRE]
    for i, (name, px, py) in enumerate(sorted(others, key=lambda t: abs(t[1]))):
        if abs(px) > 1e-9:
            yb = lo[1] - (4.0 + 4.0 * i) * k
            _hdim(ax, 0.0, px, yb, (0.0, 0.0), (px, py), mm(px), k)
    for i, (name, px, py) in enumerate(sorted(others, key=lambda t: abs(t[2]))):
        if abs(py) > 1e-9:
            xb = lo[0] - (4.0 + 4.0 * i) * k
            _vdim(ax, 0.0, py, xb, (0.0, 0.0), (px, py), mm(py), k)


def _hdim(ax, x0, x1, yb, p0, p1, text, k):
    for (px, py) in (p0, p1):
        ax.plot([px, px], [py, yb - 1.0 * k], color=DIM_COLOR, lw=0.3, zorder=2)
    ax.annotate("", xy=(x1, yb), xytext=(x0, yb), zorder=3,
                arrowprops=dict(arrowstyle="<|-|>", color=DIM_COLOR, lw=0.5, shrinkA=0, shrinkB=0, mutation_scale=4))
    ax.text(0.5 * (x0 + x1), yb + 0.4 * k, text, fontsize=5.5, color=DIM_COLOR, ha="center", va="bottom", zorder=4,
            bbox=dict(boxstyle="square,pad=0.05", fc="white", ec="none", alpha=0.8))


def _vdim(ax, y0, y1, xb, p0, p1, text, k):
    for (px, py) in (p0, p1):
        ax.plot([px, xb - 1.0 * k], [py, py], color=DIM_COLOR, lw=0.3, zorder=2)
    ax.annotate("", xy=(xb, y1), xytext=(xb, y0), zorder=3,
                arrowprops=dict(arrowstyle="<|-|>", color=DIM_COLOR, lw=0.5, shrinkA=0, shrinkB=0, mutation_scale=4))
    ax.text(xb - 0.4 * k, 0.5 * (y0 + y1), text, fontsize=5.5, color=DIM_COLOR, ha="center", va="bottom",
            rotation=90, rotation_mode="anchor", zorder=4,
            bbox=dict(boxstyle="square,pad=0.05", fc="white", ec="none", alpha=0.8))


def _footer(fig, kit) -> None:
    m = kit.material
    lines = [f"Scale: {kit.scale:g} mm per model unit.  Material: {m.name}, {mm(m.thickness)} mm thick (one stack "
             f"layer); pins {m.pin_material}."]
    if kit.source:
        lines += textwrap.wrap(f"Design: {kit.source}", 150)
    if kit.tolerance_note:
        lines += textwrap.wrap(f"Tolerance: {kit.tolerance_note}", 150)
    for i, line in enumerate(lines[:5]):
        _text(fig, 10.0, 19.0 - i * 3.2, line, fontsize=6.5, va="top")


# -- part pages ------------------------------------------------------------------------------------------
def _draw_part(ax, part, H: np.ndarray, width: float, k: float, color: str, flats=None, depth: float = 0.0) -> None:
    """One part drawn with its holes at H (H, 2), data mm: outline, hole circles (a D-hole where ``flats``, per
    hole the flat's normal in degrees or None, says) with centre marks, joint labels with diameters, and a
    dimension for every pair of holes."""
    poly = _outline_xy(H, 0.5 * width)
    ax.fill(poly[:, 0], poly[:, 1], fc=color, alpha=0.18, ec="none", zorder=1)
    ax.plot(np.r_[poly[:, 0], poly[0, 0]], np.r_[poly[:, 1], poly[0, 1]], color=INK, lw=0.8, zorder=2)
    c = H.mean(axis=0)
    labels = _Labels(k)
    labels.polygon(poly)
    for j, (p, d) in enumerate(zip(H, part.diameters)):
        fl = flats[j] if flats is not None and j < len(flats) else None
        if fl is None:
            ax.add_patch(_circle(p, 0.5 * d, fc="white", ec=INK, lw=0.6, zorder=3))
        else:
            from matplotlib.patches import Polygon
            from ._kit_sheet import hole_segments
            ax.add_patch(Polygon(_segments_xy(hole_segments(tuple(p), d, fl, depth)), closed=True, fc="white",
                                 ec=INK, lw=0.6, zorder=3))
        cm = max(0.5 * d + 1.0, 1.5 * k)
        ax.plot([p[0] - cm, p[0] + cm], [p[1], p[1]], color=INK, lw=0.3, zorder=4)
        ax.plot([p[0], p[0]], [p[1] - cm, p[1] + cm], color=INK, lw=0.3, zorder=4)
    hull = _hull([tuple(p) for p in H])
    idx = {tuple(p): i for i, p in enumerate(map(tuple, H))}
    edges = set()
    if len(hull) >= 2:
        for a in range(len(hull) if len(hull) > 2 else 1):
            i, j = idx[hull[a]], idx[hull[(a + 1) % len(hull)]]
            edges.add((min(i, j), max(i, j)))
    collinear = len(hull) == 2
    inner_levels: list[tuple[float, float, int]] = []
    for i in range(len(H) if len(H) <= 6 else 1):
        for j in range(i + 1, len(H)):
            d = math.dist(H[i], H[j])
            if d <= 1e-9:
                continue
            text = mm(d)
            p, q = H[i], H[j]
            u = (q - p) / d
            n = np.array([-u[1], u[0]])
            side = 1.0 if float(n @ (0.5 * (p + q) - c)) >= 0 else -1.0
            if (i, j) in edges:
                if collinear:
                    side = 1.0 if n[1] >= 0 else -1.0
                _dimension(ax, p, q, side * (0.5 * width + 6.0 * k), text, k, labels=labels)
            elif collinear:
                # chain dimensions on the other side, stacked where they overlap
                a0, b0 = sorted((float(p @ u), float(q @ u)))
                level = 0
                while any(lv == level and not (b0 <= s0 + 1e-9 or a0 >= e0 - 1e-9) for s0, e0, lv in inner_levels):
                    level += 1
                inner_levels.append((a0, b0, level))
                down = -1.0 if n[1] >= 0 else 1.0
                _dimension(ax, p, q, down * (0.5 * width + (6.0 + 6.0 * level) * k), text, k, labels=labels)
            else:
                ax.plot([p[0], q[0]], [p[1], q[1]], color=DIM_COLOR, lw=0.4, ls=(0, (3, 2)), zorder=5)
                labels.segment(p, q)
                m = 0.5 * (p + q)
                ang = math.degrees(math.atan2(u[1], u[0]))
                ang = ang - 180 if ang > 90 else (ang + 180 if ang <= -90 else ang)
                ax.text(m[0], m[1], text, rotation=ang, rotation_mode="anchor", ha="center", va="center", fontsize=6.5,
                        color=DIM_COLOR, zorder=12, bbox=dict(boxstyle="square,pad=0.1", fc="white", ec="none"))
    for j, (p, d) in enumerate(zip(H, part.diameters)):
        others = [q for q in H if float(np.hypot(*(q - p))) > 1e-9]
        labels.place(ax, p, f"{part.joints[j]}\nØ{mm(d)}", 7, 0.5 * width + 1.5 * k, prefer=_away(p, others or [c]),
                     color=INK, weight="bold", zorder=10,
                     bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="#aaaaaa", lw=0.3, alpha=0.9))


def _segments_xy(segs) -> np.ndarray:
    """A closed chain of ("arc", c, r, a0, a1) and ("line", p, q) as a polygon (N, 2)."""
    pts = []
    for seg in segs:
        if seg[0] == "arc":
            _, c, rr, a0, a1 = seg
            t = np.linspace(a0, a1, max(2, int(math.ceil(abs(a1 - a0) / (math.pi / 48))) + 1))
            pts.extend(zip(c[0] + rr * np.cos(t), c[1] + rr * np.sin(t)))
        else:
            pts.append(seg[1])
            pts.append(seg[2])
    return np.asarray(pts, dtype=np.float64)


def _page_part(fig, kit, part) -> None:
    m = kit.material
    _text(fig, 10, 200, f"{part.name}", fontsize=15, weight="bold", va="baseline")
    plain = part.copies - part.mirrored
    if part.mirrored:
        cut = f"cut {part.copies}: {plain} as drawn, {part.mirrored} mirrored"
    else:
        cut = f"cut {part.copies}" + (" (symmetric: its mirror image is the same part)" if part.symmetric else "")
    layer = "chassis plate" if part.layer is None else f"stack layer {part.layer}"
    _text(fig, 10, 194, f"{part.kind} · {cut} · part width {mm(part.width)} mm · {m.name} {mm(m.thickness)} mm · "
          f"{layer} · all lengths in mm", fontsize=8, va="baseline")
    # the hole-to-hole table (a plate with many holes: from its centre hole)
    pairs = shown_pairs(part)
    _text(fig, 10, 188, "hole to hole, centre to centre:", fontsize=7.5, weight="bold", va="baseline")
    holes = "  ·  ".join(hole_groups(part))
    _text(fig, 150, 188, f"holes: {holes}", fontsize=7.5, va="baseline")
    right = part.kind == "frame" or bool(part.flats)  # a block of its own at x = 150 mm
    cols, col_w = (2, 68.0) if right else (4, 68.0)
    per_col = max(3, math.ceil(len(pairs) / cols))
    for i, (a, b, d) in enumerate(pairs):
        col, row = divmod(i, per_col)
        _text(fig, 10 + col_w * col, 184 - 3.6 * row, f"{a} – {b}: {mm(d)} mm", fontsize=7.5, va="baseline")
    ytop = 184 - 3.6 * min(per_col, max(1, len(pairs))) - 2.0
    if part.flats:  # a crank arm: copy k is leg k's, its D-hole turned by the leg's phase
        sh = kit.shaft
        _text(fig, 150, 184, f"D-hole for the {mm(sh.diameter)} mm crankshaft's {mm(sh.flat)} mm flat; copy k is "
              f"leg k's:", fontsize=7.5, weight="bold", va="baseline")
        rows = [f"copy {c + 1}: leg {c + 1} at {degrees(kit.legs[c].phase_deg)}, flat normal at "
                f"{degrees(f[0])} from the arm" for c, f in enumerate(part.flats)]
        for i, line in enumerate(rows):
            _text(fig, 150 + 70 * (i // 4), 180.4 - 3.6 * (i % 4), line, fontsize=6.5, va="baseline")
        ytop = min(ytop, 180.4 - 3.6 * min(4, len(rows)) - 2.0)
    if part.kind == "frame":
        piv = [s for s in pivot_lines(kit) if ": x = " in s]
        _text(fig, 150, 184, "pivots from the crank centre:", fontsize=7.5, weight="bold", va="baseline")
        for i, s in enumerate(piv):
            _text(fig, 150 + 70 * (i // 3), 180.4 - 3.6 * (i % 3), s, fontsize=7.5, va="baseline")
        ytop = min(ytop, 180.4 - 3.6 * min(3, len(piv)) - 2.0)

    frame = part.kind == "frame"
    views = [(False, f"as drawn ×{plain}" if part.mirrored else "")]
    if part.mirrored and not part.symmetric:
        views.append((True, f"mirrored ×{part.mirrored}"))
    shapes = [(_turned(part.holes, mir, not frame), cap) for mir, cap in views]
    pad = 0.5 * part.width
    ext = [(H.min(axis=0) - pad, H.max(axis=0) + pad) for H, _ in shapes]
    sizes = [hi - lo for lo, hi in ext]
    box_x, box_y, box_w, box_h = 10.0, 14.0, 277.0, ytop - 14.0
    margin = 16.0  # mm of paper around each drawing: labels and dimensions
    side = len(shapes) == 1 or (sizes[0][0] + sizes[1][0]) / 1.0 + 4 * margin <= box_w \
        or sizes[0][1] > sizes[0][0]
    if len(shapes) == 1:
        k = _fit_scale(sizes[0][0], sizes[0][1], box_w, box_h, margin)
        cells = [(box_x, box_y, box_w, box_h)]
    else:
        k_side = _fit_scale(max(s[0] for s in sizes), max(s[1] for s in sizes), 0.5 * box_w, box_h, margin)
        k_stack = _fit_scale(max(s[0] for s in sizes), max(s[1] for s in sizes), box_w, 0.5 * box_h, margin)
        side = k_side <= k_stack
        k = min(k_side, k_stack)
        if side:
            cells = [(box_x, box_y, 0.5 * box_w, box_h), (box_x + 0.5 * box_w, box_y, 0.5 * box_w, box_h)]
        else:
            cells = [(box_x, box_y + 0.5 * box_h, box_w, 0.5 * box_h), (box_x, box_y, box_w, 0.5 * box_h)]
    color = _layer_color(kit.layers.get(part.name, 0))
    for (H, cap), (lo, hi), cell in zip(shapes, ext, cells):
        ax = _axes(fig, *cell)
        _set_view(ax, 0.5 * (lo + hi), k, cell[2], cell[3])
        flats = None
        if part.flats:  # a crank arm: copy 1's D-hole, turned as the part is
            turn = _turn_angle(part.holes, H)
            flats = [None if f is None else f + turn for f in part.flats[0]]
        _draw_part(ax, part, H, part.width, k, color, flats, kit.shaft.flat if kit.shaft else 0.0)
        if cap:
            ax.text(0.02, 0.97, cap, transform=ax.transAxes, fontsize=8, weight="bold", va="top", color=INK)
    scale = "true size (1:1)" if k == 1.0 else f"drawn at {scale_text(k)} (the part is {k:g}× larger)"
    _text(fig, 10, 7, f"Drawing scale: {scale} when printed at 100 % on A4; the bar is 50 mm of paper.",
          fontsize=7, va="baseline")
    fig.lines.append(_page_line(fig, 180, 8, 230, 8))
    for xx in (180, 230):
        fig.lines.append(_page_line(fig, xx, 6.8, xx, 9.2))
    _text(fig, 205, 9.5, f"50 mm on paper = {50 * k:g} mm of part", fontsize=6, ha="center", va="bottom")


def _turn_angle(holes, H) -> float:
    """The angle, degrees, the drawing turned the part's frame by (from its first two holes)."""
    a = math.atan2(holes[1][1] - holes[0][1], holes[1][0] - holes[0][0])
    b = math.atan2(H[1][1] - H[0][1], H[1][0] - H[0][0])
    return math.degrees(b - a)


def _page_line(fig, x0, y0, x1, y1):
    from matplotlib.lines import Line2D
    return Line2D([x0 / PAGE[0], x1 / PAGE[0]], [y0 / PAGE[1], y1 / PAGE[1]], transform=fig.transFigure,
                  color=INK, lw=0.8)


# -- the document ----------------------------------------------------------------------------------------
def write_assembly_pdf(kit, path) -> Path:
    """Write the kit's assembly sheet to ``path`` (see the module docstring): A4 landscape pages, page 1
    the assembly, then one page per part of ``kit.parts``; returns the path. UserError if the design does
    not assemble at θ = 0."""
    import matplotlib
    from matplotlib.backends.backend_pdf import PdfPages
    from matplotlib.figure import Figure

    path = Path(path)
    mech = kit.mechanism
    size = (PAGE[0] / 25.4, PAGE[1] / 25.4)
    rc = {"pdf.fonttype": 42, "font.family": "DejaVu Sans", "hatch.linewidth": 0.4, "axes.unicode_minus": False}
    with matplotlib.rc_context(rc):
        figs = []
        fig = Figure(figsize=size)
        _page_assembly(fig, kit)
        figs.append(fig)
        if kit.shaft is not None and kit.chassis is not None:
            fig = Figure(figsize=size)
            _page_chassis(fig, kit)
            figs.append(fig)
        for part in kit.parts:
            fig = Figure(figsize=size)
            _page_part(fig, kit, part)
            figs.append(fig)
        meta = {"Title": f"{mech.name}: assembly", "Subject": "build kit (explorer export --as kit)",
                "Creator": "explorer"}
        with PdfPages(path, metadata=meta) as pdf:
            for i, fig in enumerate(figs):
                _text(fig, PAGE[0] - 10, 4, f"{mech.name} · assembly.pdf · page {i + 1} of {len(figs)}",
                      fontsize=6, ha="right", color="#777777")
                pdf.savefig(fig)
    return path
