"""Plain-numpy closed forms of the built-in walking legs ``hoeken``, ``klann`` and ``strider``.

Nothing here imports explorer: every joint is placed by a circle–circle intersection or by the
rotation that carries a rigid body's own frame onto two joints already placed, written out below.
tests/test_legs.py compares explorer's Newton solutions (positions and velocities) against these.

Each ``<leg>_positions(theta)`` returns ``{joint: (len(theta), 2) array}`` for every vertex of the
mechanism (crank tip, ground pivots, moving joints) at the crank angles ``theta`` (radians,
counter-clockwise from +x, the tip at centre + r (cos θ, sin θ)). The assembly branch of each
circle–circle intersection is an explicit side of a directed line (``side`` below), the side the
mechanism file's [guess] picks at θ = 0; each dyad stays strictly non-degenerate over the turn (its
half-chord never vanishes; ``circle_intersection`` raises if it would), so the fixed side is the
continuous branch.

The dimensions are the published ones (see each .toml's header for the source) and are the same
numbers as the .toml files; tests/test_legs.py checks that they agree.
"""

from __future__ import annotations

import math

import numpy as np

# --------------------------------------------------------------------------------------------------
# geometry


def crank_tip(theta, center, radius) -> np.ndarray:
    """(n, 2): center + radius (cos θ, sin θ)."""
    theta = np.asarray(theta, dtype=np.float64)
    return np.stack([center[0] + radius * np.cos(theta), center[1] + radius * np.sin(theta)], axis=-1)


def circle_intersection(c1, r1, c2, r2, side) -> np.ndarray:
    """The point at distance r1 from c1 and r2 from c2, on side ``side`` of the directed line c1 → c2.

    c1, c2 : (n, 2) (or (2,), broadcast); side : +1 = left of c1 → c2 (counter-clockwise from it),
    −1 = right. With d = |c2 − c1|, u = (c2 − c1)/d and n = u turned +90°, the point is
    c1 + a u + side·h n, a = (r1² − r2² + d²) / 2d along the line and h = √(r1² − a²) across it.
    """
    c1, c2 = np.broadcast_arrays(np.asarray(c1, dtype=np.float64), np.asarray(c2, dtype=np.float64))
    g = c2 - c1
    d = np.hypot(g[..., 0], g[..., 1])
    a = (r1 * r1 - r2 * r2 + d * d) / (2.0 * d)
    h2 = r1 * r1 - a * a
    if np.any(h2 <= 0.0):
        raise ValueError(f"circles of radius {r1} and {r2} do not cross at every angle (min h² = {h2.min():.3g})")
    h = np.sqrt(h2)
    ux, uy = g[..., 0] / d, g[..., 1] / d
    nx, ny = -uy, ux
    return np.stack([c1[..., 0] + a * ux + side * h * nx, c1[..., 1] + a * uy + side * h * ny], axis=-1)


def place_body(shape: dict, a: str, b: str, pa, pb) -> dict:
    """World positions of every joint of a rigid body, given the world positions pa, pb of two of them.

    shape : {joint: (x, y)} in the body's own frame. The body turns by φ = angle(pb − pa) −
    angle(b − a in the body frame) and moves so that a lands on pa: p = pa + R(φ)(s_p − s_a). (For a
    closed form, |pb − pa| must equal the body's |b − a|, which the callers' constructions ensure.)
    """
    pa, pb = np.asarray(pa, dtype=np.float64), np.asarray(pb, dtype=np.float64)
    sa, sb = np.asarray(shape[a], dtype=np.float64), np.asarray(shape[b], dtype=np.float64)
    phi = np.arctan2(pb[..., 1] - pa[..., 1], pb[..., 0] - pa[..., 0]) - math.atan2(sb[1] - sa[1], sb[0] - sa[0])
    c, s = np.cos(phi), np.sin(phi)
    out = {}
    for j, p in shape.items():
        dx, dy = p[0] - sa[0], p[1] - sa[1]
        out[j] = np.stack([pa[..., 0] + c * dx - s * dy, pa[..., 1] + s * dx + c * dy], axis=-1)
    return out


def _fixed(p, theta) -> np.ndarray:
    return np.broadcast_to(np.asarray(p, dtype=np.float64), (len(np.atleast_1d(theta)), 2)).copy()


def _bent(length, degrees):
    """(x, y) of a point ``length`` from the origin at ``degrees`` counter-clockwise from +x."""
    r = math.radians(degrees)
    return (length * math.cos(r), length * math.sin(r))


# --------------------------------------------------------------------------------------------------
# Hoeken (the proportions): crank 1 about (0, 0), rocker pivot D at (2, 0), coupler B→C 2.5
# and rocker D→C 2.5 with C below the x axis at θ = 0, the foot P on the line from B through C, 5 from
# B (B, C, P one rigid body).

HOEKEN = {"crank": 1.0, "center": (0.0, 0.0), "pivot": (2.0, 0.0), "coupler": 2.5, "rocker": 2.5, "foot": 5.0}
HOEKEN_COUPLER = {"B": (0.0, 0.0), "C": (HOEKEN["coupler"], 0.0), "P": (HOEKEN["foot"], 0.0)}
HOEKEN_LINKS = (("D", "C", HOEKEN["rocker"]),)
HOEKEN_BODIES = {"coupler": HOEKEN_COUPLER}


def hoeken_positions(theta) -> dict:
    d = HOEKEN
    B = crank_tip(theta, d["center"], d["crank"])
    D = _fixed(d["pivot"], theta)
    # at θ = 0, B = (1, 0) and D = (2, 0): C below the axis is right of B → D
    C = circle_intersection(B, d["coupler"], D, d["rocker"], side=-1)
    out = {"B": B, "D": D}
    out.update(place_body(HOEKEN_COUPLER, "B", "C", B, C))
    return out


# --------------------------------------------------------------------------------------------------
# Klann (US 6,260,862), in DIYwalkers.com's scaling of the patent (crank = 3), joints named by the
# patent's reference numerals: 29 crank pin, 11 second (lower) rocker arm axle, 9 first (upper)
# rocker arm axle, 27 elbow, 35 knee, 37 hip, 33 foot. Connecting rod 29–27–35 (27 is 6.6 from the
# crank pin, the knee 5.84 further on, bent 12.8° clockwise); leg 37–35–33 (hip and foot 10.04 from
# the knee, the foot bent 30° off the straight line through the knee).

KLANN = {
    "crank": 3.0, "center": (0.0, 0.0),
    "lower_axle": (-6.6, -1.97),        # 11: 6.6 left of and 1.97 below the crank shaft
    "upper_axle": (-2.6, 6.9),          # 9: 2.6 left of and 6.9 above it
    "rod": 6.6, "rod_knee": 5.84, "rod_bend": 12.8,
    "lower_rocker": 3.59, "upper_rocker": 5.79,
    "thigh": 10.04, "shin": 10.04, "knee_bend": 30.0,
}
_KNEE = _bent(KLANN["rod_knee"], -KLANN["rod_bend"])  # elbow → knee in the rod's frame
KLANN_ROD = {  # crank pin at the origin, elbow along +x, the knee bent clockwise by rod_bend
    "29": (0.0, 0.0),
    "27": (KLANN["rod"], 0.0),
    "35": (KLANN["rod"] + _KNEE[0], _KNEE[1]),
}
KLANN_LEG = {  # knee at the origin, hip along +x, the foot on the far side turned by knee_bend
    "35": (0.0, 0.0),
    "37": (KLANN["thigh"], 0.0),
    "33": _bent(KLANN["shin"], 180.0 + KLANN["knee_bend"]),
}
KLANN_LINKS = (("11", "27", KLANN["lower_rocker"]), ("9", "37", KLANN["upper_rocker"]))
KLANN_BODIES = {"connecting_rod": KLANN_ROD, "leg": KLANN_LEG}


def klann_positions(theta) -> dict:
    d = KLANN
    P29 = crank_tip(theta, d["center"], d["crank"])
    P11, P9 = _fixed(d["lower_axle"], theta), _fixed(d["upper_axle"], theta)
    # elbow: the upper of the two points (DIYwalkers' "high"), right of crank pin → lower axle
    P27 = circle_intersection(P29, d["rod"], P11, d["lower_rocker"], side=-1)
    rod = place_body(KLANN_ROD, "29", "27", P29, P27)
    P35 = rod["35"]
    # hip: the upper point, right of upper axle → knee
    P37 = circle_intersection(P9, d["upper_rocker"], P35, d["thigh"], side=-1)
    leg = place_body(KLANN_LEG, "35", "37", P35, P37)
    return {"29": P29, "11": P11, "9": P9, "27": P27, "35": P35, "37": P37, "33": leg["33"]}


# --------------------------------------------------------------------------------------------------
# Strider (Wade and Ben Vagle, DIYwalkers.com), with DIYwalkers' joint numbers: crank 4 to the pin 1;
# frame pivots 2 and 6 at (∓11, +8) from the crank shaft; two triangles on the crank pin, each a bar
# 14 from the pin to its rocker joint (3, 7; rockers 5 to the frame) extended 6 past the pin and
# turned 1 sideways to a tip (10, 11); foot 4 hangs 13 from 3 and 10 from 11, foot 8 13 from 7 and 10
# from 10 (the mirror image: foot 8 at θ is foot 4 at π − θ mirrored about x = 0).

STRIDER = {
    "crank": 4.0, "center": (0.0, 0.0), "frame_x": 11.0, "frame_y": 8.0,
    "rocker": 5.0, "bar": 14.0, "tail": 6.0, "offset": 1.0, "shin": 13.0, "thigh": 10.0,
}
STRIDER_LEFT = {"1": (0.0, 0.0), "3": (STRIDER["bar"], 0.0), "10": (-STRIDER["tail"], -STRIDER["offset"])}
STRIDER_RIGHT = {"1": (0.0, 0.0), "7": (STRIDER["bar"], 0.0), "11": (-STRIDER["tail"], STRIDER["offset"])}
STRIDER_LINKS = (
    ("2", "3", STRIDER["rocker"]), ("6", "7", STRIDER["rocker"]),
    ("3", "4", STRIDER["shin"]), ("11", "4", STRIDER["thigh"]),
    ("7", "8", STRIDER["shin"]), ("10", "8", STRIDER["thigh"]),
)
STRIDER_BODIES = {"triangle_left": STRIDER_LEFT, "triangle_right": STRIDER_RIGHT}


def strider_positions(theta) -> dict:
    d = STRIDER
    P1 = crank_tip(theta, d["center"], d["crank"])
    P2 = _fixed((d["center"][0] - d["frame_x"], d["center"][1] + d["frame_y"]), theta)
    P6 = _fixed((d["center"][0] + d["frame_x"], d["center"][1] + d["frame_y"]), theta)
    # rocker joints: the lower points (DIYwalkers' "low"), right of 2 → 1 and right of 1 → 6
    P3 = circle_intersection(P2, d["rocker"], P1, d["bar"], side=-1)
    P7 = circle_intersection(P1, d["bar"], P6, d["rocker"], side=-1)
    P10 = place_body(STRIDER_LEFT, "1", "3", P1, P3)["10"]
    P11 = place_body(STRIDER_RIGHT, "1", "7", P1, P7)["11"]
    # feet: the lower points; right of 3 → 11, and (the mirror image) left of 7 → 10
    P4 = circle_intersection(P3, d["shin"], P11, d["thigh"], side=-1)
    P8 = circle_intersection(P7, d["shin"], P10, d["thigh"], side=+1)
    return {"1": P1, "2": P2, "6": P6, "3": P3, "7": P7, "10": P10, "11": P11, "4": P4, "8": P8}


#: name -> (positions function, crank centre, crank radius, crank tip, links (a, b, length), bodies)
LEGS = {
    "hoeken": (hoeken_positions, HOEKEN["center"], HOEKEN["crank"], "B", HOEKEN_LINKS, HOEKEN_BODIES),
    "klann": (klann_positions, KLANN["center"], KLANN["crank"], "29", KLANN_LINKS, KLANN_BODIES),
    "strider": (strider_positions, STRIDER["center"], STRIDER["crank"], "1", STRIDER_LINKS, STRIDER_BODIES),
}


def central_difference(f, theta, h=1e-6) -> dict:
    """{joint: (f(θ + h) − f(θ − h)) / 2h} for a positions function f."""
    theta = np.asarray(theta, dtype=np.float64)
    plus, minus = f(theta + h), f(theta - h)
    return {j: (plus[j] - minus[j]) / (2.0 * h) for j in plus}
