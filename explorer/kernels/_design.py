"""Design parameters → the numbers the kernels read for each variant (``_inputs.Designs``).

A design is its mechanism's named parameters (``Mechanism.parameters``): link lengths, the crank
radius and centre, the ground pivots, the bodies' joint coordinates. The kernels read what the plan
makes of them: each distance equation's length (links, then each body's base-pair distance), each
attach equation's (u, v) — the joint's coordinates in the frame of its body's base pair, scaled by
that pair's length — the fixed vertices' positions, the crank centre and radius, and Newton's
stopping distance. Computed here once per chunk, vectorised over the variants.
"""

from __future__ import annotations

import numpy as np

from ..errors import UserError
from ..kinds import EQUATIONS
from ..mechanism import Mechanism
from ..plan import Plan
from ._inputs import BLOCK_DTYPE, Designs


def designs(mech: Mechanism, plan: Plan, lengths: np.ndarray, scale: np.ndarray, geometry: dict | None,
            tolerance: float) -> Designs:
    """The :class:`~._inputs.Designs` of N variants.

    lengths (N, n_links) in ``mech.links`` order; scale (N,) crank radii (ones for a path driver);
    geometry: {coordinate parameter name: (N,) values} (crank centre, ground pivots, body joints;
    those left out keep their nominal). tolerance: relative to each design's size (its longest
    link or body span). A variant with a non-finite parameter, or a body whose base pair coincides, gets
    NaN lengths, which the kernels report as "invalid" (as they do lengths out of range, see
    ``_batch.valid_lengths``).
    """
    N = lengths.shape[0]
    col = _columns(mech, geometry, N)
    n_links = len(mech.links)
    dist = np.empty((N, len(plan.link_a)))
    dist[:, :n_links] = lengths
    size = np.max(lengths, axis=1) if n_links else np.zeros(N)
    points = body_points(mech, geometry, N)
    for bi, body in enumerate(mech.bodies):
        pts = points[bi]
        p, q = plan.body_base[bi]
        dist[:, n_links + bi] = np.hypot(*(pts[:, q] - pts[:, p]).T)
        diff = pts[:, :, None, :] - pts[:, None, :, :]
        size = np.maximum(size, np.max(np.hypot(diff[..., 0], diff[..., 1]), axis=(1, 2)))
    uv = np.empty((N, len(plan.attach), 2))
    for t, (bi, ji) in enumerate(zip(plan.attach_body, plan.attach_joint)):
        pts = points[bi]
        p, q = plan.body_base[bi]
        uv[:, t, 0], uv[:, t, 1] = pair_coordinates(pts[:, p], pts[:, q], pts[:, ji])
    names = [mech.vertices[v] for v in plan.fixed]
    fixed = np.stack([np.stack([col(f"{v}.x"), col(f"{v}.y")], axis=-1) for v in names], axis=1) if names \
        else np.zeros((N, 0, 2))
    if mech.crank is not None:
        center = np.stack([col("crank.x"), col("crank.y")], axis=-1)
    elif mech.path.slider is not None:  # a linear actuator: its path moves with its slider's point
        sl = next(s for s in mech.sliders if s.name == mech.path.slider)
        center = np.stack([col(f"{sl.name}.x") - sl.point[0], col(f"{sl.name}.y") - sl.point[1]], axis=-1)
    else:
        center = np.zeros((N, 2))
    slide = slide_numbers(mech, plan, lengths, points, col, N)
    extra = [eq.numbers(mech, plan, col, N) for eq in EQUATIONS if getattr(eq, "NUMBERS", 0)]
    extra = np.concatenate(extra, axis=1) if extra else np.zeros((N, 0))
    # an attached joint's error is at most (|1 − u| + |u| + 2|v|) times its base pair's: tighten
    # Newton's stopping distance by that much so that every joint keeps the promise
    amp = np.ones(N)
    if uv.shape[1]:
        with np.errstate(invalid="ignore"):
            amp = np.maximum(1.0, np.max(np.abs(1.0 - uv[..., 0]) + np.abs(uv[..., 0]) + 2.0 * np.abs(uv[..., 1]),
                                         axis=1))
    tol = tolerance * size / amp
    ok = (np.all(np.isfinite(uv), axis=(1, 2)) & np.all(np.isfinite(fixed), axis=(1, 2))
          & np.all(np.isfinite(center), axis=1) & np.isfinite(tol) & (tol > 0)
          & np.all(np.isfinite(slide), axis=(1, 2)) & np.all(slide[..., 5] > 0, axis=1)
          & np.all(np.isfinite(extra), axis=1))
    dist[~ok] = np.nan
    # the block tables, starts and closing scales are the kernels' setup's (``_batch.setup``)
    return Designs(np.ascontiguousarray(dist), np.ascontiguousarray(uv), np.ascontiguousarray(fixed),
                   np.ascontiguousarray(center), np.ascontiguousarray(scale, dtype=np.float64), tol,
                   np.ascontiguousarray(slide), np.ascontiguousarray(extra), np.zeros((N, 0), dtype=BLOCK_DTYPE),
                   np.zeros((N, 0, 2)),
                   np.full(N, np.inf), np.zeros((N, 2), dtype=np.int64), np.zeros((N, 0, 0, 2)))


def slide_numbers(mech: Mechanism, plan: Plan, lengths: np.ndarray, points: list, col, N: int) -> np.ndarray:
    """(N, n_slide, 6) each slide equation's line (``_inputs.Designs.slide``): a ground line's point and
    unit direction, 0, 1; a slot's 0, 0, 0, 0, offset and length |b − a| (its link's length, or the
    distance of its two joints in their body). NaN where a direction has no length."""
    out = np.zeros((N, len(plan.slide), 6))
    out[..., 5] = 1.0
    for k, si in enumerate(plan.slide_slider):
        s = mech.sliders[si]
        if s.ground:
            dx, dy = col(f"{s.name}.dx"), col(f"{s.name}.dy")
            n = np.hypot(dx, dy)
            with np.errstate(divide="ignore", invalid="ignore"):
                out[:, k, 2], out[:, k, 3] = np.where(n > 0, dx / n, np.nan), np.where(n > 0, dy / n, np.nan)
            out[:, k, 0], out[:, k, 1] = col(f"{s.name}.x"), col(f"{s.name}.y")
            continue
        out[:, k, 4] = col(f"{s.name}.offset")
        pair = frozenset(s.line)
        for i, link in enumerate(mech.links):
            if frozenset((link.a, link.b)) == pair:
                out[:, k, 5] = lengths[:, i]
                break
        else:
            bi = next(i for i, b in enumerate(mech.bodies) if pair <= set(b.joints))
            body = mech.bodies[bi]
            pa, pb = points[bi][:, body.joints.index(s.line[0])], points[bi][:, body.joints.index(s.line[1])]
            out[:, k, 5] = np.hypot(*(pb - pa).T)
    return out


def _columns(mech: Mechanism, geometry: dict | None, N: int):
    """``col(name)``: the (N,) values of design parameter ``name`` other than a link's length or the crank
    radius (a coordinate, or a geared crank's radius) from ``geometry``, else the nominal."""
    nominal = mech.parameters()
    geometry = dict(geometry or {})
    for name in geometry:
        mech.parameter_kind(name)  # an unknown name is an error
        if name == "crank" or name in mech.link_names:
            raise UserError(f"geometry: {name!r} is a link length or the crank radius; pass it with the lengths "
                            f"(or the crank radii)")

    def col(name):
        if name in geometry:
            c = np.asarray(geometry[name], dtype=np.float64).reshape(-1)
            if c.shape[0] != N:
                raise UserError(f"geometry: column {name!r} has {c.shape[0]} values for {N} variants")
            return c
        return np.full(N, nominal[name])

    return col


def body_points(mech: Mechanism, geometry: dict | None, N: int) -> list[np.ndarray]:
    """Each body's joints in its own frame for N variants: a list (one per body) of (N, n_joints, 2)."""
    col = _columns(mech, geometry, N)
    return [np.stack([np.stack([col(f"{b.name}.{j}.x"), col(f"{b.name}.{j}.y")], axis=-1) for j in b.joints], axis=1)
            for b in mech.bodies]


def pair_coordinates(p: np.ndarray, q: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, w), each (N,): point x in the frame of the base pair (p, q), all (N, 2) in a body's frame,
    x = p + u (q − p) + w R (q − p) with R the quarter turn (NaN where p and q coincide)."""
    e = q - p
    w = x - p
    e2 = np.sum(e * e, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.sum(w * e, axis=1) / e2, (e[:, 0] * w[:, 1] - e[:, 1] * w[:, 0]) / e2
