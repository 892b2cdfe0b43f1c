"""Slow, plain-numpy references for the gait metrics and the Pareto front (used by the tests only).

Written independently of explorer.gait from the definitions in the issue: brute force over every
start for the stance, np.polyfit for the line, an O(n²) double loop for dominance.
"""

from __future__ import annotations

import math

import numpy as np


def naive_stance(y: np.ndarray, band: float) -> np.ndarray:
    """Indices (cyclic, in order) of the longest run with y <= min + band * height.

    Every start s is tried and the run from s is extended while it stays in the band (at most S
    samples); the longest wins, ties to the smallest start.
    """
    S = len(y)
    inside = y <= y.min() + band * (y.max() - y.min())
    best_start, best_len = 0, 0
    for s in range(S):
        n = 0
        while n < S and inside[(s + n) % S]:
            n += 1
        if n > best_len:
            best_start, best_len = s, n
    return (best_start + np.arange(best_len)) % S


def naive_metrics(path: np.ndarray, vel: np.ndarray | None = None, band: float = 0.01) -> dict[str, float]:
    """Every foot metric of one path (S, 2) and velocity (S, 2), straight from the definitions."""
    x, y = path[:, 0], path[:, 1]
    if not np.isfinite(path).all():
        return {k: math.nan for k in ("width", "height", "stride", "duty", "flatness", "stance_rms_line",
                                      "stance_speed", "speed_ripple", "max_speed")}
    idx = naive_stance(y, band)
    xs, ys = x[idx], y[idx]
    stride = float(np.max(xs) - np.min(xs))
    out = {
        "width": float(np.ptp(x)),
        "height": float(np.ptp(y)),
        "stride": stride,
        "duty": len(idx) / len(y),
        "flatness": float(np.std(ys) / stride) if stride > 0 else math.nan,
    }
    if len(idx) >= 2 and np.ptp(xs) > 0:
        b, a = np.polyfit(xs, ys, 1)
        # perpendicular distance: component of (p - p0) along the unit normal of the line
        normal = np.array([-b, 1.0]) / math.hypot(1.0, b)
        d = (np.stack([xs, ys - a], axis=1)) @ normal
        out["stance_rms_line"] = float(np.sqrt(np.mean(d ** 2)))
    else:
        out["stance_rms_line"] = math.nan
    if vel is not None:
        speed = np.linalg.norm(vel, axis=1)
        if np.isfinite(speed).all():
            ss = speed[idx]
            out["stance_speed"] = float(ss.mean())
            out["speed_ripple"] = float(ss.std() / ss.mean()) if ss.mean() > 0 else math.nan
            out["max_speed"] = float(speed.max())
        else:
            out.update(stance_speed=math.nan, speed_ripple=math.nan, max_speed=math.nan)
    return out


def naive_transmission(positions: np.ndarray, mech) -> float:
    """Least min(μ, 180° − μ) in degrees over sampled positions (S, n_vertices, 2), every loop.

    A loop is a vertex v linked to the crank tip and to a fixed vertex f; μ is the angle at v
    between v→tip and v→f, measured from the solved positions.
    """
    tip = mech.crank.tip
    pairs = {frozenset((l.a, l.b)) for l in mech.links}
    best = math.inf
    for v in mech.vertices:
        for f in mech.fixed:
            if v in (tip, f) or v in mech.fixed:
                continue
            if frozenset((v, tip)) in pairs and frozenset((v, f)) in pairs:
                P = positions[:, mech.vertex_index(v)]
                a = positions[:, mech.vertex_index(tip)] - P
                b = positions[:, mech.vertex_index(f)] - P
                cos = (a * b).sum(axis=1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
                mu = np.degrees(np.arccos(np.clip(cos, -1, 1)))
                best = min(best, float(np.minimum(mu, 180 - mu).min()))
    return best


def naive_pareto(values: np.ndarray, directions: list[str]) -> np.ndarray:
    """O(n²) non-dominated filter: values (n, k), directions "max"/"min" per column -> mask (n,).

    Rows holding NaN are never on the front and dominate nothing.
    """
    n = len(values)
    sign = np.array([-1.0 if d == "max" else 1.0 for d in directions])
    cost = values * sign
    valid = ~np.isnan(cost).any(axis=1)
    mask = np.zeros(n, dtype=bool)
    for i in range(n):
        if not valid[i]:
            continue
        dominated = False
        for j in range(n):
            if j == i or not valid[j]:
                continue
            if all(cost[j, c] <= cost[i, c] for c in range(cost.shape[1])) and \
                    any(cost[j, c] < cost[i, c] for c in range(cost.shape[1])):
                dominated = True
                break
        mask[i] = not dominated
    return mask
