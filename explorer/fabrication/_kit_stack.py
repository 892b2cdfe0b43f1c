"""Stack order of a kit's parts and the clearance of everything that turns (issues 27, 37).

Along the pins every leg is a stack of layers: layer 0 is the frame plate, each moving part sits on one
layer above it. A pin spans the layers from its lowest part to its highest; on a layer of its span that
it carries no part on it wears a spacer, and its head and nut stick out into the layer below and the
layer above its span. The crankshaft is a pin at the crank centre: through every layer of the leg (a
*through* shaft), up to the crank arm (an *outboard* crank arm, one leg only), or up to an inner crank web
and again from an outer web up (a crank with *throws*: the parts on the crank pin turn between the webs,
where there is no shaft).

Over the turn (S samples of the crank angle) each part is its centre shape (the convex hull of its
joints) grown by half its width; a pin is a disc about its joint of its bare radius (its spacer, head or
nut: one pin diameter; the crankshaft's spacer: one shaft diameter). Two things *conflict* when they come
closer than their radii (half widths) plus the running clearance, at any sample less a bound on how much
closer they can come between samples (:func:`sample_bound`). Conflicts that must not share a layer:

* two parts that share a joint (they sit on one pin) or whose outlines conflict;
* a part and a pin it is not on, on a layer the pin spans (or holds its head or nut on);
* two pins on a layer where neither carries a part (spacers, heads, nuts).

The layers are the solution of a small mixed-integer program (:func:`assign_layers`, scipy's HiGHS):
fewest layers first, then the shortest pins; the pins' spans are variables of the program. Every
assignment is then checked again, pair by pair, by :func:`clearance_checks`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import UserError

#: Shaft modes, in the order tried.
MODES = ("through", "outboard", "throws")


# -- distances -------------------------------------------------------------------------------------------
def _point_seg(p, q0, q1) -> np.ndarray:
    v = q1 - q0
    vv = np.einsum("ij,ij->i", v, v)
    t = np.where(vv > 0, np.einsum("ij,ij->i", p - q0, v) / np.where(vv > 0, vv, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    return np.hypot(*(q0 + t[:, None] * v - p).T)


def _seg_dist(a, b, c, d) -> np.ndarray:
    """Distance between segments a–b and c–d, each point an (S, 2) array; (S,)."""
    def cross(o, p, q):
        return (p[:, 0] - o[:, 0]) * (q[:, 1] - o[:, 1]) - (p[:, 1] - o[:, 1]) * (q[:, 0] - o[:, 0])

    d1, d2 = cross(c, d, a), cross(c, d, b)
    d3, d4 = cross(a, b, c), cross(a, b, d)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    dist = np.minimum.reduce([_point_seg(a, c, d), _point_seg(b, c, d), _point_seg(c, a, b), _point_seg(d, a, b)])
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


def _edges(P):
    if len(P) == 1:
        return [(P[0], P[0])]
    if len(P) == 2:
        return [(P[0], P[1])]
    return [(P[i], P[(i + 1) % len(P)]) for i in range(len(P))]


def shape_distance(A, B) -> np.ndarray:
    """Distance between two convex shapes over the samples: A, B lists of (S, 2) corners, counter-
    clockwise (one corner: a point; two: a segment); 0 where they overlap; (S,)."""
    d = np.full(A[0].shape[0], np.inf)
    for a, b in _edges(A):
        for c, e in _edges(B):
            d = np.minimum(d, _seg_dist(a, b, c, e))
    if len(A) >= 3:
        d = np.where(_inside(B[0], A), 0.0, d)
    if len(B) >= 3:
        d = np.where(_inside(A[0], B), 0.0, d)
    return d


def point_distance(p, A) -> np.ndarray:
    """Distance from the points p (S, 2) to the convex shape A (corners, as :func:`shape_distance`); (S,)."""
    return shape_distance([p], A)


def sample_bound(velocities, steps: int) -> float:
    """How much closer two things can come between two samples of the turn than at the nearer sample, in the
    units of ``velocities`` × radians: every point moves at most v_max · Δθ / 2 from its nearer sample
    (Δθ = 2π / steps), and two moving things close by at most twice that; v_max is the largest sampled
    speed (per radian) with 10 % on top for its peaks between samples. velocities : (S, n, 2)."""
    v = np.asarray(velocities, dtype=np.float64)
    vmax = float(np.nanmax(np.hypot(v[..., 0], v[..., 1]))) if v.size else 0.0
    return 1.1 * vmax * (2.0 * math.pi / steps)


# -- the problem -----------------------------------------------------------------------------------------
@dataclass
class StackPart:
    """A part in the stack problem. joints : the single joint names it carries; corners : its centre shape
    over the turn, (S, 2) arrays, mm, counter-clockwise; half : half its width, mm; role : "frame",
    "crank" (the crank arm, or the inner web of a throw), "crank-outer" (the outer web) or "part"."""

    name: str
    joints: tuple[str, ...]
    corners: list
    half: float
    role: str = "part"


@dataclass
class StackPin:
    """A pin (or the shaft) in the stack problem: its joint, its centre over the turn (S, 2) mm, its bare
    radius (spacer, head or nut), mm; shaft : the crankshaft."""

    joint: str
    path: np.ndarray
    radius: float
    shaft: bool = False


@dataclass
class Conflict:
    """Why two things cannot share a layer: their least distance over the turn less what they need
    (``margin``, mm, negative: a conflict), at crank angle ``theta_deg``."""

    a: str
    b: str
    margin: float
    theta_deg: float
    distance: float = 0.0  # the least distance between their centres (centre lines), mm


@dataclass
class Layout:
    """A solved stack: layers (part name → layer), mode (:data:`MODES`), spans (pin joint → (lo, hi) layers
    it spans, the shaft's as its set of layers in ``shaft_layers``), top : the leg's top layer."""

    layers: dict
    mode: str
    spans: dict
    shaft_layers: tuple
    top: int
    conflicts: dict = field(default_factory=dict)


def _theta(k: int, S: int) -> float:
    return 360.0 * k / S


class Problem:
    """Every conflict of one leg's parts and pins (see the module docstring), computed once. bound : mm a
    distance may shrink between samples; clearance : the running clearance, mm."""

    def __init__(self, parts: list[StackPart], pins: list[StackPin], clearance: float, bound: float):
        self.parts, self.pins = parts, pins
        self.clearance, self.bound = clearance, bound
        self.S = parts[0].corners[0].shape[0]
        self.on = {p.joint: [q.name for q in parts if p.joint in q.joints] for p in pins}
        need = clearance + bound
        self.part_part: dict = {}
        for i, a in enumerate(parts):
            for b in parts[:i]:
                if set(a.joints) & set(b.joints):
                    self.part_part[(a.name, b.name)] = Conflict(a.name, b.name, -math.inf, 0.0)
                    continue
                if a.role == "frame" or b.role == "frame":
                    continue
                d = shape_distance(a.corners, b.corners) - (a.half + b.half + need)
                k = int(np.argmin(d))
                if d[k] < 0:
                    self.part_part[(a.name, b.name)] = Conflict(a.name, b.name, float(d[k] + self.bound),
                                                                _theta(k, self.S))
        self.pin_part: dict = {}
        for p in pins:
            for q in parts:
                if q.name in self.on[p.joint] or q.role == "frame":
                    continue
                raw = point_distance(p.path, q.corners)
                d = raw - (q.half + p.radius + need)
                k = int(np.argmin(d))
                if d[k] < 0:
                    self.pin_part[(p.joint, q.name)] = Conflict(p.joint, q.name, float(d[k] + self.bound),
                                                                _theta(k, self.S), float(raw[k]))
        self.pin_pin: dict = {}
        for i, a in enumerate(pins):
            for b in pins[:i]:
                d = np.hypot(*(a.path - b.path).T) - (a.radius + b.radius + need)
                k = int(np.argmin(d))
                if d[k] < 0:
                    self.pin_pin[(a.joint, b.joint)] = Conflict(a.joint, b.joint, float(d[k] + self.bound),
                                                                _theta(k, self.S))


class _Model:
    """A mixed-integer program built row by row (scipy.optimize.milp)."""

    def __init__(self):
        self.lb, self.ub, self.integer, self.cost = [], [], [], []
        self.rows: list[tuple[dict, float, float]] = []

    def var(self, lo=0.0, hi=1.0, integer=False, cost=0.0) -> int:
        self.lb.append(lo)
        self.ub.append(hi)
        self.integer.append(1 if integer else 0)
        self.cost.append(cost)
        return len(self.lb) - 1

    def add(self, coefs: dict, lo=-np.inf, hi=np.inf) -> None:
        self.rows.append((coefs, lo, hi))

    def solve(self, time_limit: float = 60.0):
        from scipy.optimize import Bounds, LinearConstraint, milp
        from scipy.sparse import lil_matrix
        A = lil_matrix((len(self.rows), len(self.lb)))
        lo, hi = np.empty(len(self.rows)), np.empty(len(self.rows))
        for r, (coefs, a, b) in enumerate(self.rows):
            for j, v in coefs.items():
                A[r, j] += v
            lo[r], hi[r] = a, b
        res = milp(np.asarray(self.cost), integrality=np.asarray(self.integer),
                   bounds=Bounds(np.asarray(self.lb), np.asarray(self.ub)),
                   constraints=LinearConstraint(A.tocsr(), lo, hi), options={"time_limit": time_limit})
        return res.x if res.x is not None and res.status in (0, 1) else None


def _cumulative(m: _Model, xs: list[dict], K: int, up: bool) -> list[int]:
    """Variables u_k ≥ Σ xs[k] that are monotone: from below (u_k ≥ u_{k-1}, 1 at and above the lowest
    layer set) if up, else from above."""
    u = [m.var() for _ in range(K)]
    for k in range(K):
        m.add({**{i: -1.0 for i in xs[k]}, u[k]: 1.0}, lo=0.0)
        nb = k - 1 if up else k + 1
        if 0 <= nb < K:
            m.add({u[k]: 1.0, u[nb]: -1.0}, lo=0.0)
    return u


def assign_layers(prob: Problem, mode: str, time_limit: float = 60.0) -> Layout | None:
    """The layers of ``prob``'s parts with the shaft as ``mode`` (:data:`MODES`), or None if there are none.
    Parts with role "crank" / "crank-outer" are the crank arm / the webs ("crank-outer" only in "throws")."""
    parts = [p for p in prob.parts if mode == "throws" or p.role != "crank-outer"]
    pins = prob.pins
    names = [p.name for p in parts]
    active = set(names)
    on = {j: [n for n in ns if n in active] for j, ns in prob.on.items()}
    role = {p.name: p.role for p in parts}
    crank = next(p.name for p in parts if p.role == "crank")
    outer = next((p.name for p in parts if p.role == "crank-outer"), None)
    if mode == "throws" and outer is None:
        raise ValueError("a crank with throws needs its outer web")
    shaft = next(p for p in pins if p.shaft)
    carried = set(on[shaft.joint])
    if mode == "through":  # the shaft is everywhere: nothing it does not carry may come near it
        if any(q for (j, q) in prob.pin_part if j == shaft.joint and q in active and q not in carried):
            return None
    K = len(parts) + 1
    m = _Model()
    x = {n: [m.var(integer=True) for _ in range(K)] for n in names}
    top = m.var(0.0, K - 1.0, cost=1000.0)
    for n in names:
        m.add({v: 1.0 for v in x[n]}, 1.0, 1.0)
        m.add({top: 1.0, **{v: -float(k) for k, v in enumerate(x[n])}}, lo=0.0)
        if role[n] == "frame":
            m.add({x[n][0]: 1.0}, 1.0, 1.0)
        else:
            m.add({x[n][0]: 1.0}, hi=0.0)
    for (a, b) in prob.part_part:
        if a not in active or b not in active:
            continue
        for k in range(K):
            m.add({x[a][k]: 1.0, x[b][k]: 1.0}, hi=1.0)
    # the pins: s (spans), e (spans with the head's and the nut's layers), c (carried layers, an expression)
    s, e, carry = {}, {}, {}
    for p in pins:
        carry[p.joint] = [[x[n][k] for n in on[p.joint]] for k in range(K)]
        if p.shaft and mode == "through":
            one = m.var(1.0, 1.0)
            s[p.joint] = e[p.joint] = [one] * K
            continue
        if p.shaft:
            if mode == "outboard":  # from the frame up to the crank arm
                below = _cumulative(m, [[x[crank][k]] for k in range(K)], K, up=False)
                s[p.joint] = below
            else:  # up to the inner web, and again from the outer web up
                below = _cumulative(m, [[x[crank][k]] for k in range(K)], K, up=False)
                above = _cumulative(m, [[x[outer][k]] for k in range(K)], K, up=True)
                sv = [m.var() for _ in range(K)]
                for k in range(K):
                    m.add({sv[k]: 1.0, below[k]: -1.0}, lo=0.0)
                    m.add({sv[k]: 1.0, above[k]: -1.0}, lo=0.0)
                s[p.joint] = sv
            e[p.joint] = s[p.joint]
            continue
        a = _cumulative(m, carry[p.joint], K, up=True)
        b = _cumulative(m, carry[p.joint], K, up=False)
        sv = [m.var(cost=1.0) for _ in range(K)]
        ev = [m.var(cost=0.01) for _ in range(K)]
        for k in range(K):
            m.add({sv[k]: 1.0, a[k]: -1.0, b[k]: -1.0}, lo=-1.0)
            for nb in (k - 1, k, k + 1):
                if 0 <= nb < K:
                    m.add({ev[k]: 1.0, sv[nb]: -1.0}, lo=0.0)
        s[p.joint], e[p.joint] = sv, ev
    for (j, q) in prob.pin_part:
        if q not in active or (j == shaft.joint and q in carried):
            continue
        for k in range(K):
            m.add({x[q][k]: 1.0, e[j][k]: 1.0}, hi=1.0)
    for (i, j) in prob.pin_pin:
        for k in range(K):
            coefs: dict = {}
            for v, c in ((e[i][k], 1.0), (e[j][k], 1.0)):
                coefs[v] = coefs.get(v, 0.0) + c
            for v in carry[i][k] + carry[j][k]:
                coefs[v] = coefs.get(v, 0.0) - 1.0
            m.add(coefs, hi=1.0)
    if mode == "throws":  # the crank pin's parts between the webs
        def level(n):
            return {v: float(k) for k, v in enumerate(x[n])}
        for n in on[next(p.joint for p in pins if crank in on[p.joint] and not p.shaft)]:
            if n in (crank, outer):
                continue
            m.add({**level(n), **{v: -c for v, c in level(crank).items()}}, lo=1.0)
            m.add({**level(outer), **{v: -c for v, c in level(n).items()}}, lo=1.0)
    sol = m.solve(time_limit)
    if sol is None:
        return None
    layers = {n: int(np.argmax([sol[v] for v in x[n]])) for n in names}
    T = max(layers.values())
    spans = {}
    for p in pins:
        if p.shaft:
            continue
        ls = [layers[n] for n in on[p.joint]]
        spans[p.joint] = (min(ls), max(ls))
    if mode == "through":
        shaft_layers = tuple(range(T + 1))
    elif mode == "outboard":
        shaft_layers = tuple(range(layers[crank] + 1))
    else:
        shaft_layers = tuple(range(layers[crank] + 1)) + tuple(range(layers[outer], T + 1))
    return Layout(layers, mode, spans, shaft_layers, T)


# -- the check -------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Check:
    """One clearance checked over the turn: ``what`` ("pin", "spacer", "head or nut", "shaft", "shaft spacer",
    "part" (two parts of one layer), "pins" (two bare pins)), the two things, the layer, the least
    sampled distance less what they need (radius or half widths plus the running clearance): ``margin``,
    mm, at crank angle ``theta_deg``. The distance between two samples is at most ``bound`` mm lower."""

    what: str
    a: str
    b: str
    layer: int
    margin: float
    theta_deg: float


def clearance_checks(prob: Problem, lay: Layout, spacer_of=None) -> list[Check]:
    """Every clearance of the solved stack ``lay`` (see :class:`Check`), worst first: every part against every
    pin, spacer, head, nut or shaft on its layer that does not carry it; every two parts of one layer;
    every two pins bare on one layer."""
    layer = lay.layers
    parts = [q for q in prob.parts if q.name in layer]
    pins = prob.pins
    on = {j: [n for n in ns if n in layer] for j, ns in prob.on.items()}
    by_layer: dict[int, list[StackPart]] = {}
    for q in parts:
        by_layer.setdefault(layer[q.name], []).append(q)
    out = []

    def occupied(p: StackPin) -> dict[int, str]:
        """layer → what the pin is there: "carries", "spacer", "head or nut"."""
        if p.shaft:  # its layers, and on to the next leg past the top one (the nuts' gap) unless it ends there
            got = {k: "shaft" for k in lay.shaft_layers}
            if lay.mode != "outboard":
                got[lay.top + 1] = "shaft"
        else:
            lo, hi = lay.spans[p.joint]
            got = {k: "spacer" for k in range(lo, hi + 1)}
            for k in (lo - 1, hi + 1):
                if 0 <= k:
                    got[k] = "head or nut"
        for n in on[p.joint]:
            got[layer[n]] = "carries"
        return got

    occ = {p.joint: occupied(p) for p in pins}
    for p in pins:
        for k, what in occ[p.joint].items():
            if what == "carries":
                continue
            for q in by_layer.get(k, []):
                if q.role == "frame":
                    continue
                d = point_distance(p.path, q.corners) - (q.half + p.radius + prob.clearance)
                i = int(np.argmin(d))
                kind = ("shaft spacer" if p.shaft else what)
                out.append(Check(kind, p.joint, q.name, k, float(d[i]), _theta(i, prob.S)))
    for k, qs in by_layer.items():
        for i, a in enumerate(qs):
            for b in qs[:i]:
                if "frame" in (a.role, b.role):
                    continue
                d = shape_distance(a.corners, b.corners) - (a.half + b.half + prob.clearance)
                j = int(np.argmin(d))
                out.append(Check("part", a.name, b.name, k, float(d[j]), _theta(j, prob.S)))
    for i, a in enumerate(pins):
        for b in pins[:i]:
            both = [k for k, w in occ[a.joint].items() if w != "carries" and occ[b.joint].get(k, "carries") != "carries"]
            if not both:
                continue
            d = np.hypot(*(a.path - b.path).T) - (a.radius + b.radius + prob.clearance)
            j = int(np.argmin(d))
            out.append(Check("pins", a.joint, b.joint, min(both), float(d[j]), _theta(j, prob.S)))
    out.sort(key=lambda c: c.margin)
    return out


def refusal(prob: Problem) -> str:
    """Why no stack exists, in words: the part that comes nearest the shaft (or, without one, the worst
    conflict of a pin and a part), its distance and the angle."""
    shaft = next(p for p in prob.pins if p.shaft)
    worst = [c for (j, q), c in prob.pin_part.items() if j == shaft.joint and q not in prob.on[shaft.joint]]
    if not worst:
        worst = list(prob.pin_part.values())
    if not worst:
        return "no order of the layers keeps the parts apart"
    c = min(worst, key=lambda c: c.margin)
    pin = "the crankshaft" if c.a == shaft.joint else f"pin {c.a}"
    return (f"part {c.b!r} passes {c.distance:.3g} mm from the axis of {pin} at θ = {c.theta_deg:.1f}° "
            f"({c.distance - c.margin:.3g} mm needed)")


def solve_stack(prob: Problem, legs: int, modes=MODES) -> Layout:
    """The first mode of ``modes`` (through, then outboard for one leg, then throws) with a stack; UserError
    (one line, naming the part, the pin and the angle) if none has one."""
    for mode in modes:
        if mode == "outboard" and legs != 1:
            continue
        if mode == "throws" and not any(p.role == "crank-outer" for p in prob.parts):
            continue
        lay = assign_layers(prob, mode)
        if lay is not None:
            return lay
    raise UserError(f"no stack keeps every part clear of the pins and the crankshaft (a through shaft, "
                    f"{'an outboard crank arm, ' if legs == 1 else ''}a crank with throws): {refusal(prob)}; "
                    f"try a smaller --width, --hole or --clearance")


#: A washer between two parts on a pin, mm thick (so they turn freely).
WASHER = 0.5


def clearance_line(kit) -> str:
    """One line on the worst clearance found over the turn of ``kit`` (an :class:`explorer.fabrication.Kit`)."""
    c = kit.worst
    if c is None:
        return "nothing shares a layer with a pin, the shaft or another part"
    what = {"part": f"parts {c.a} and {c.b} (layer {c.layer})", "pins": f"pins {c.a} and {c.b} (bare, layer {c.layer})",
            "shaft spacer": f"the crankshaft and part {c.b} (layer {c.layer})"}.get(
        c.what, f"the {c.what} of pin {c.a} and part {c.b} (layer {c.layer})")
    return (f"worst margin {c.margin:.2f} mm beyond the {kit.running:g} mm running clearance: {what} at θ = "
            f"{c.theta_deg:.1f}°, sampled every {360.0 / kit.samples:g}° (between samples at most {kit.bound:.2f} mm "
            f"less)")
