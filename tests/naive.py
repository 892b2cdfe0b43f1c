"""Slow, plain-numpy reference implementations the tests check explorer against.

Nothing here imports explorer's solvers: positions come from sequential circle-circle intersections
(closed form) or from a textbook dense Newton iteration on seed 000's system, velocities from
central finite differences. Everything is written for clarity, not speed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

TESTS = Path(__file__).resolve().parent
REPO = TESTS.parent
TRIAD = REPO / "data" / "triad.toml"
# shipped in the repository (a copy of the project's shared/reference/, see tests/reference/README.md),
# so the test runs on every checkout instead of skipping where the shared folder is absent
REFERENCE_FOOT = TESTS / "reference" / "jansen_nominal_foot_360.csv"

#: Jansen's leg, seed 000: vertex names, link list (file order of builtin jansen.toml) and numbers.
JANSEN_VERTICES = ("1", "2", "3", "4", "5", "6", "7")
JANSEN_LINKS = (("1", "3"), ("3", "4"), ("2", "3"), ("2", "4"), ("4", "5"),
                ("2", "6"), ("1", "6"), ("5", "6"), ("5", "7"), ("6", "7"))
JANSEN_LENGTHS = (50.0, 55.8, 41.5, 40.1, 39.4, 39.3, 61.9, 36.7, 65.7, 49.0)
JANSEN_CRANK = 15.0
JANSEN_CENTER = (0.0, 0.0)
JANSEN_FIXED2 = (-38.0, -7.8)
#: seed 000's initial guess at θ = 0 (it picks the branch of every dyad)
JANSEN_GUESS = {"3": (-50.0, 50.0), "4": (-100.0, 0.0), "5": (-100.0, -50.0), "6": (-50.0, -50.0),
                "7": (-50.0, -100.0)}
#: order of the sequential construction: vertex, parent a, parent b (each placed before)
JANSEN_ORDER = (("3", "1", "2"), ("4", "3", "2"), ("6", "1", "2"), ("5", "4", "6"), ("7", "5", "6"))


def cross(u, w):
    """z-component of u × w for arrays (..., 2)."""
    return u[..., 0] * w[..., 1] - u[..., 1] * w[..., 0]


def circle_circle(pa, pb, ra, rb, side):
    """Point at distance ra from pa and rb from pb with sign(cross(pb − pa, p − pa)) == side.

    pa, pb: (..., 2); ra, rb: broadcastable to (...); side: ±1. Returns (p, slack) where slack is
    min(ra + rb − d, d − |ra − rb|) (negative: the circles do not meet, p is NaN there).
    """
    g = pb - pa
    d = np.hypot(g[..., 0], g[..., 1])
    ra = np.broadcast_to(ra, d.shape)
    rb = np.broadcast_to(rb, d.shape)
    slack = np.minimum(ra + rb - d, d - np.abs(ra - rb))
    with np.errstate(invalid="ignore", divide="ignore"):
        x = (ra ** 2 - rb ** 2 + d ** 2) / (2.0 * d)
        y = np.sqrt(ra ** 2 - x ** 2)
        u = g / d[..., None]
    perp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    p = pa + x[..., None] * u + (side * y)[..., None] * perp
    p = np.where((slack >= 0.0)[..., None], p, np.nan)
    return p, slack


def jansen_signs(lengths=JANSEN_LENGTHS, crank=JANSEN_CRANK):
    """The branch (orientation sign) of every dyad that seed 000's guess implies at θ = 0.

    Each vertex is put on the side of the line parent a → parent b on which its guess lies, the
    parents being the already-constructed positions at θ = 0.
    """
    L = dict(zip(JANSEN_LINKS, np.asarray(lengths, dtype=float)))
    P = {"1": np.array([JANSEN_CENTER[0] + crank, JANSEN_CENTER[1]]), "2": np.array(JANSEN_FIXED2)}
    signs = {}
    for v, a, b in JANSEN_ORDER:
        s = np.sign(cross(P[b] - P[a], np.array(JANSEN_GUESS[v]) - P[a]))
        signs[v] = float(s)
        P[v], slack = circle_circle(P[a], P[b], _length(L, a, v), _length(L, b, v), s)
        assert slack > 0, "the reference guess must assemble"
    return signs


def _length(L, u, w):
    return L[(u, w)] if (u, w) in L else L[(w, u)]


def jansen_closed_form(lengths, crank, thetas, signs=None, center=JANSEN_CENTER, fixed2=JANSEN_FIXED2):
    """Jansen leg positions by sequential circle-circle intersections (plain numpy).

    lengths : (10,) or (N, 10) link lengths in JANSEN_LINKS order; crank : scalar or (N,) radius;
    thetas : (S,) crank angles, or (N, S) per variant; signs : dict vertex -> ±1 (default: the nominal design's, from the
    seed's guess); center : the crank centre, (2,) or (N, 2) per variant; fixed2 : ground pivot 2, (2,)
    or (N, 2). Returns (positions, ok, slack):
    positions (…, S, 7, 2) in JANSEN_VERTICES order (NaN where not assemblable),
    ok (…, S) bool, True where every vertex assembles,
    slack dict vertex -> (…, S) circle-circle slack of that dyad (NaN when a parent is missing).
    """
    lengths = np.asarray(lengths, dtype=float)
    batch = lengths.ndim == 2
    lengths = np.atleast_2d(lengths)
    crank = np.broadcast_to(np.asarray(crank, dtype=float), lengths.shape[:1])
    thetas = np.asarray(thetas, dtype=float)
    if signs is None:
        signs = jansen_signs()
    N = lengths.shape[0]
    th = np.broadcast_to(thetas if thetas.ndim == 2 else thetas[None, :], (N, thetas.shape[-1]))
    S = th.shape[1]
    c = np.broadcast_to(np.asarray(center, dtype=float), (N, 2))
    f2 = np.broadcast_to(np.asarray(fixed2, dtype=float), (N, 2))
    P = {}
    P["1"] = np.stack([c[:, 0, None] + crank[:, None] * np.cos(th),
                       c[:, 1, None] + crank[:, None] * np.sin(th)], axis=-1)
    P["2"] = np.broadcast_to(f2[:, None, :], (N, S, 2))
    col = {pair: lengths[:, i][:, None] for i, pair in enumerate(JANSEN_LINKS)}
    slack = {}
    for v, a, b in JANSEN_ORDER:
        P[v], slack[v] = circle_circle(P[a], P[b], _length(col, a, v), _length(col, b, v), signs[v])
    pos = np.stack([P[v] for v in JANSEN_VERTICES], axis=2)
    ok = np.all(np.isfinite(pos), axis=(2, 3))
    if not batch:
        pos, ok, slack = pos[0], ok[0], {k: s[0] for k, s in slack.items()}
    return pos, ok, slack


def jansen_assembly_margin(lengths, crank, grid=1440, signs=None):
    """How far each Jansen variant is from failing to assemble somewhere in the crank cycle.

    Returns (N,) margins in model units: the smallest circle-circle slack min(ra + rb − d, d − |ra − rb|)
    over every dyad and every crank angle. Negative: the variant cannot assemble at some angle.

    Not a plain sampled minimum, which could step over a sub-degree gap:
    * vertices 3 and 6 hang from the crank tip 1 and the ground pivot 2, whose distance sweeps exactly
      [D − r, D + r] (D = |pivot 2 − crank centre|), so their slack is exact;
    * vertices 4 and 7 hang from parents a fixed link apart (2-3 and 5-6): constant slack;
    * vertex 5 hangs from 4 and 6, whose distance has no closed-form extremes: it is sampled on
      ``grid`` angles and each extreme is refined three times on a 201-point local grid around the
      best sample (to ~1e-9 rad). Only computed where 3 and 6 assemble at every angle (NaN term
      otherwise, the margin being negative already).
    """
    lengths = np.atleast_2d(np.asarray(lengths, dtype=float))
    N = lengths.shape[0]
    crank = np.broadcast_to(np.asarray(crank, dtype=float), (N,))
    ln = {pair: lengths[:, i] for i, pair in enumerate(JANSEN_LINKS)}
    D = np.hypot(JANSEN_FIXED2[0] - JANSEN_CENTER[0], JANSEN_FIXED2[1] - JANSEN_CENTER[1])
    dmin, dmax = D - crank, D + crank

    def slack(ra, rb, lo, hi):
        return np.minimum(ra + rb - hi, lo - np.abs(ra - rb))

    terms = [slack(ln[("1", "3")], ln[("2", "3")], dmin, dmax),
             slack(ln[("1", "6")], ln[("2", "6")], dmin, dmax),
             slack(ln[("3", "4")], ln[("2", "4")], ln[("2", "3")], ln[("2", "3")]),
             slack(ln[("5", "7")], ln[("6", "7")], ln[("5", "6")], ln[("5", "6")])]
    margin = np.min(np.stack(terms), axis=0)
    live = margin > 0.0
    signs = jansen_signs() if signs is None else signs
    m5 = np.full(N, np.nan)
    if live.any():
        Ls, cs = lengths[live], crank[live]

        def d46(th):
            pos, _, _ = jansen_closed_form(Ls, cs, th, signs)
            g = pos[:, :, 5] - pos[:, :, 3]
            return np.hypot(g[..., 0], g[..., 1])

        step = 2.0 * np.pi / grid
        th = np.arange(grid) * step
        d = d46(th)
        ext = []
        for sense in (1.0, -1.0):  # minimum, then maximum
            k = np.argmin(sense * d, axis=1)
            centre, half = th[k], step
            for _ in range(3):
                local = centre[:, None] + np.linspace(-half, half, 201)[None, :]
                dl = d46(local)
                j = np.argmin(sense * dl, axis=1)
                centre = local[np.arange(local.shape[0]), j]
                best = dl[np.arange(local.shape[0]), j]
                half = 2.0 * half / 200
            ext.append(best)
        m5[live] = slack(ln[("4", "5")][live], ln[("5", "6")][live], ext[0], ext[1])
        margin = np.where(live, np.minimum(margin, m5), margin)
    return margin


def central_difference(f, thetas, h=1e-5):
    """(f(θ + h) − f(θ − h)) / 2h for a function of an angle array."""
    thetas = np.asarray(thetas, dtype=float)
    return (f(thetas + h) - f(thetas - h)) / (2.0 * h)


def link_length_errors(positions, link_ends, lengths):
    """| |p_b − p_a| − d | for every sample and link: positions (S, nv, 2), link_ends [(ia, ib)]."""
    out = []
    for (ia, ib), d in zip(link_ends, lengths):
        g = positions[:, ib] - positions[:, ia]
        out.append(np.abs(np.hypot(g[:, 0], g[:, 1]) - d))
    return np.stack(out, axis=1)


# -- a textbook dense Newton solve of seed 000's system (any topology) ---------------------------------
def system(mech):
    """Plain description of a mechanism: (names, link ends (ia, ib), lengths, crank, center, fixed {i: xy})."""
    names = list(mech.vertices)
    idx = {v: i for i, v in enumerate(names)}
    ends = [(idx[l.a], idx[l.b]) for l in mech.links]
    lengths = np.array([l.length for l in mech.links], dtype=float)
    fixed = {idx[v]: np.array(xy, dtype=float) for v, xy in mech.fixed.items()}
    return names, ends, lengths, float(mech.crank.radius), np.array(mech.crank.center, dtype=float), \
        idx[mech.crank.tip], fixed


def residual_and_jacobian(X, ends, lengths, known):
    """Seed 000 eqs. 5 and 9: link residuals |p_b − p_a|² − d² and coordinate equations, with the Jacobian.

    X: (2 nv,) interleaved x1, y1, x2, y2, ...; known: {vertex index: target (2,)}.
    """
    n = X.shape[0]
    F, J = [], []
    for (a, b), d in zip(ends, lengths):
        g = X[2 * b:2 * b + 2] - X[2 * a:2 * a + 2]
        F.append(g @ g - d * d)
        row = np.zeros(n)
        row[2 * a:2 * a + 2] = -2.0 * g
        row[2 * b:2 * b + 2] = 2.0 * g
        J.append(row)
    for v, xy in known.items():
        for ax in range(2):
            F.append(X[2 * v + ax] - xy[ax])
            row = np.zeros(n)
            row[2 * v + ax] = 1.0
            J.append(row)
    return np.array(F), np.array(J)


def newton_solve(mech, theta, start, tol=1e-13, maxit=60):
    """Dense Newton on the whole square system at crank angle θ from ``start`` (nv, 2). Returns (nv, 2)."""
    names, ends, lengths, r, c, tip, fixed = system(mech)
    known = dict(fixed)
    known[tip] = c + r * np.array([np.cos(theta), np.sin(theta)])
    X = np.asarray(start, dtype=float).reshape(-1).copy()
    for _ in range(maxit):
        F, J = residual_and_jacobian(X, ends, lengths, known)
        if np.max(np.abs(F[:len(ends)]) / lengths ** 2) < tol and np.max(np.abs(F[len(ends):])) < 1e-12:
            return X.reshape(-1, 2)
        X = X - np.linalg.solve(J, F)
    raise RuntimeError(f"naive Newton did not converge at theta={theta}")


def newton_velocity(mech, P, theta):
    """Seed 000 eqs. 29-30: dV/dθ = M⁻¹ B at a solved configuration P (nv, 2) (plain numpy)."""
    names, ends, lengths, r, c, tip, fixed = system(mech)
    known = dict(fixed)
    known[tip] = c + r * np.array([np.cos(theta), np.sin(theta)])
    _, J = residual_and_jacobian(P.reshape(-1), ends, lengths, known)
    B = np.zeros(J.shape[0])
    k = len(ends) + 2 * list(known).index(tip)
    B[k:k + 2] = r * np.array([-np.sin(theta), np.cos(theta)])
    return np.linalg.solve(J, B).reshape(-1, 2)


def newton_path(mech, thetas, start, substeps=8):
    """Naive continuation: solve at every θ in order, each from the previous solution (with substeps)."""
    out = []
    P = np.asarray(start, dtype=float)
    prev = None
    for th in thetas:
        if prev is not None:
            for t in np.linspace(prev, th, substeps + 1)[1:-1]:
                P = newton_solve(mech, t, P)
        P = newton_solve(mech, th, P)
        out.append(P)
        prev = th
    return np.array(out)


# -- generic sequential dyads and structure (any mechanism) ---------------------------------------------
def dyad_peel(mech):
    """Brute-force structure: repeatedly place any vertex with two links to already-placed vertices.

    Returns (order, rest): order lists (vertex, parent a, parent b, link a, link b) by name in the order
    found; rest is the set of vertices that no dyad can place (empty for a dyad-decomposable linkage).
    """
    placed = {mech.crank.tip, *mech.fixed}
    rest = set(mech.guess)
    order = []
    progress = True
    while rest and progress:
        progress = False
        for v in sorted(rest):
            links = [l for l in mech.links if v in (l.a, l.b) and ({l.a, l.b} - {v}) <= placed]
            if len(links) >= 2:
                la, lb = links[:2]
                a = la.b if la.a == v else la.a
                b = lb.b if lb.a == v else lb.a
                order.append((v, a, b, la.name, lb.name))
                placed.add(v)
                rest.discard(v)
                progress = True
                break
    return order, rest


def sequential_dyads(mech, thetas):
    """Positions (S, nv, 2) of a dyad-decomposable mechanism by circle-circle intersections.

    Each dyad keeps the side of its parents' line on which the mechanism's guess lies at θ = 0.
    Returns (positions in mech.vertices order, ok (S,) bool).
    """
    order, rest = dyad_peel(mech)
    assert not rest, "not dyad-decomposable"
    thetas = np.asarray(thetas, dtype=float)
    S = thetas.shape[0]
    L = {l.name: l.length for l in mech.links}
    c = np.array(mech.crank.center, dtype=float)
    r = mech.crank.radius
    P = {mech.crank.tip: c + r * np.stack([np.cos(thetas), np.sin(thetas)], axis=-1)}
    P0 = {mech.crank.tip: c + np.array([r, 0.0])}
    for v, xy in mech.fixed.items():
        P[v] = np.broadcast_to(np.array(xy, dtype=float), (S, 2))
        P0[v] = np.array(xy, dtype=float)
    for v, a, b, la, lb in order:
        side = np.sign(cross(P0[b] - P0[a], np.array(mech.guess[v]) - P0[a]))
        P0[v], _ = circle_circle(P0[a], P0[b], L[la], L[lb], side)
        P[v], _ = circle_circle(P[a], P[b], L[la], L[lb], side)
    pos = np.stack([P[v] for v in mech.vertices], axis=1)
    return pos, np.all(np.isfinite(pos), axis=(1, 2))


def fletcher32_naive(data: bytes) -> int:
    """HDF5's ``H5_checksum_fletcher32`` (H5checksum.c) line by line: 16-bit big-endian words, the two sums
    folded with (s & 0xffff) + (s >> 16) after every 360 words, an odd last byte as a word shifted by 8."""
    n, k, s1, s2 = len(data), 0, 0, 0
    words = n // 2
    while words:
        t = min(words, 360)
        words -= t
        for _ in range(t):
            s1 = (s1 + ((data[k] << 8) | data[k + 1])) & 0xFFFFFFFF
            k += 2
            s2 = (s2 + s1) & 0xFFFFFFFF
        s1 = (s1 & 0xFFFF) + (s1 >> 16)
        s2 = (s2 & 0xFFFF) + (s2 >> 16)
    if n % 2:
        s1 = (s1 + (data[k] << 8)) & 0xFFFFFFFF
        s2 = (s2 + s1) & 0xFFFFFFFF
        s1 = (s1 & 0xFFFF) + (s1 >> 16)
        s2 = (s2 & 0xFFFF) + (s2 >> 16)
    s1 = (s1 & 0xFFFF) + (s1 >> 16)
    s2 = (s2 & 0xFFFF) + (s2 >> 16)
    return (s2 << 16) | s1
