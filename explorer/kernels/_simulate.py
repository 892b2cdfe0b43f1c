"""Public entry points over the kernels: validate, allocate, call the ``_jit`` kernel, wrap results."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import UserError, where
from ..mechanism import Mechanism
from ..plan import DYAD, Plan, make_plan
from ._blocks import solve_general
from ._closed import closed_batch_jit, closed_cycle
from ._dyads import dyad_batch_jit, dyad_cycle
from ._cycle import (BLOCK, DENSE, STATUS_ASSEMBLY, STATUS_BRANCH, STATUS_INVALID, STATUS_NOCONV, STATUS_OK,
                     block_signs, cycle_batch_jit, run_cycle)

#: Status code -> name; the same codes are stored in results files as ``/status``.
STATUS_NAMES = {
    STATUS_OK: "ok",
    STATUS_ASSEMBLY: "assembly",
    STATUS_BRANCH: "branch",
    STATUS_NOCONV: "no-convergence",
    STATUS_INVALID: "invalid",
}
METHODS = {"block": BLOCK, "dense": DENSE, "closed": -1}
DEFAULT_TOLERANCE = 1e-10
DEFAULT_MAX_ITERATIONS = 50

_KIND_TEXT = {
    "assembly": "cannot assemble",
    "branch": "left its branch (toggle crossed or mirrored assembly)",
    "no-convergence": "Newton did not converge",
    "invalid": "has a non-finite or non-positive length",
}


@dataclass(frozen=True)
class Failure:
    """Why a cycle is not ok.

    kind : "assembly" | "branch" | "no-convergence" | "invalid"
    theta : crank angle in radians where it failed (the first angle that could not be solved,
        located to within Δθ/65536; 2π for a cycle that does not close on itself).
    block : index of the failing block in the plan, or None.
    vertex : name of the first vertex that block places, or None.
    message : one readable line.
    """

    kind: str
    theta: float
    block: int | None
    vertex: str | None
    message: str


@dataclass(frozen=True)
class Cycle:
    """One design solved over a crank cycle.

    theta : (steps,) crank angles θ_k = 2πk/steps, radians.
    positions : (steps, n_vertices, 2), model units; NaN from a failure on.
    velocities : (steps, n_vertices, 2) dV/dθ, units per radian, or None if not asked for.
    accelerations : (steps, n_vertices, 2) d²V/dθ², or None if not asked for.
    ok : True only if the whole cycle solved on one branch and closed on itself.
    failure : None, or a :class:`Failure`.
    iterations : total Newton iterations spent.
    """

    mechanism: Mechanism
    theta: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None
    accelerations: np.ndarray | None
    ok: bool
    failure: Failure | None
    iterations: int

    def path(self, vertex: str) -> np.ndarray:
        """Positions of ``vertex`` over the cycle, shape (steps, 2)."""
        return self.positions[:, self.mechanism.vertex_index(vertex)]

    def velocity(self, vertex: str) -> np.ndarray:
        """dV/dθ of ``vertex`` over the cycle, shape (steps, 2) (per radian of crank)."""
        if self.velocities is None:
            raise UserError("velocities were not computed: call simulate(..., velocities=True)")
        return self.velocities[:, self.mechanism.vertex_index(vertex)]


@dataclass(frozen=True)
class Batch:
    """Many variants of one mechanism, solved over a crank cycle.

    theta : (steps,); paths / velocities / accelerations : dict vertex -> (N, steps, 2);
    status : (N,) int8 codes (see STATUS_NAMES); fail_theta : (N,) radians, NaN when ok;
    fail_block : (N,) plan block index, −1 when ok; iterations : (N,) total Newton iterations.
    """

    theta: np.ndarray
    paths: dict
    velocities: dict
    accelerations: dict
    status: np.ndarray
    fail_theta: np.ndarray
    fail_block: np.ndarray
    iterations: np.ndarray


# -- cached per topology and per step count --------------------------------------------------------
def _topology(mech: Mechanism) -> tuple:
    return (mech.vertices, tuple((l.a, l.b) for l in mech.links), mech.crank.tip, tuple(mech.fixed))


_PLANS: dict = {}


def plan_for(mech: Mechanism) -> Plan:
    """The BLT plan of ``mech``'s topology (computed once per topology, then reused)."""
    key = _topology(mech)
    if key not in _PLANS:
        _PLANS[key] = make_plan(mech)
    return _PLANS[key]


@lru_cache(maxsize=32)
def crank_table(steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """θ_k = 2πk/steps with cos θ_k and sin θ_k, each (steps,) and read-only (one table per step count)."""
    theta = 2.0 * np.pi * np.arange(steps) / steps
    out = (theta, np.cos(theta), np.sin(theta))
    for a in out:
        a.setflags(write=False)
    return out


# -- assembly at θ = 0 -------------------------------------------------------------------------------
def assemble(mech: Mechanism) -> tuple[np.ndarray, Failure | None]:
    """Positions (n_vertices, 2) of ``mech`` at θ = 0 on the branch its guess selects.

    A dyad takes the circle–circle intersection on the same side of its parents as the guess; a
    general block runs damped Newton from the guess. Returns (positions, None) or (partial, Failure).
    """
    plan = plan_for(mech)
    P = np.zeros((len(mech.vertices), 2))
    for v, xy in mech.guess.items():
        P[mech.vertex_index(v)] = xy
    for v, xy in mech.fixed.items():
        P[mech.vertex_index(v)] = xy
    c, r = mech.crank.center, mech.crank.radius
    P[plan.tip] = (c[0] + r, c[1])
    L = mech.lengths
    n = 2 * len(mech.vertices)
    loc, M, rhs = np.full(len(mech.vertices), -1, dtype=np.int64), np.empty((n, n)), np.empty(n)
    Z = np.zeros_like(P)
    for k, blk in enumerate(plan.blocks):
        if blk.kind == DYAD:
            v = blk.vertices[0]
            (a, la), (b, lb) = [(_other(plan, e, v), e) for e in blk.links]
            p = _circle_intersection(P[a], P[b], L[la], L[lb], P[v])
            if p is None:
                return P, _failure(mech, plan, STATUS_ASSEMBLY, 0.0, k)
            P[v] = p
        else:
            P1 = P.copy()
            code, _ = solve_general(P, Z, Z, P1, Z.copy(), Z.copy(), np.array(blk.vertices), np.array(blk.links),
                                    plan.link_a, plan.link_b, L, 0.0, 0.0, 1e-13, 200, 0.0, False, False, loc, M, rhs)
            if code != 0:
                return P, _failure(mech, plan, STATUS_NOCONV, 0.0, k)
            P = P1
    return P, None


def _other(plan: Plan, link: int, v: int) -> int:
    return int(plan.link_b[link] if plan.link_a[link] == v else plan.link_a[link])


def _circle_intersection(a, b, da, db, guess):
    """The point at distances da from a and db from b on the side of line a→b where ``guess`` lies."""
    g = b - a
    d = math.hypot(g[0], g[1])
    if d == 0.0 or d > da + db or d < abs(da - db):
        return None
    x = (da * da - db * db + d * d) / (2.0 * d)
    y = math.sqrt(max(da * da - x * x, 0.0))
    u = g / d
    perp = np.array([-u[1], u[0]])
    side = g[0] * (guess[1] - a[1]) - g[1] * (guess[0] - a[0])
    return a + x * u + (y if side >= 0.0 else -y) * perp


def _failure(mech: Mechanism, plan: Plan, status: int, theta: float, block: int) -> Failure:
    kind = STATUS_NAMES[int(status)]
    vertex = mech.vertices[plan.blocks[block].vertices[0]] if block >= 0 else None
    at = f"θ = {math.degrees(theta):.4f}°"
    who = f"vertex {vertex}" if vertex is not None else "the design"
    if theta >= 2 * math.pi - 1e-12 and kind == "branch":
        msg = f"{who}: the cycle does not close on its starting configuration after a full crank turn"
    else:
        msg = f"{who} {_KIND_TEXT[kind]} at {at}"
    return Failure(kind, float(theta), None if block < 0 else int(block), vertex, msg)


# -- the public solvers ------------------------------------------------------------------------------
def _check_common(steps, tolerance, method, max_iterations):
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 3:
        raise UserError(f"steps: expected an integer ≥ 3, got {steps!r}")
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and 0 < tolerance < 1):
        raise UserError(f"tolerance: expected a number in (0, 1), got {tolerance!r}")
    if method not in METHODS:
        raise UserError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if not (isinstance(max_iterations, (int, np.integer)) and max_iterations >= 1):
        raise UserError(f"max_iterations: expected an integer ≥ 1, got {max_iterations!r}")


def simulate(mech: Mechanism, steps: int = 360, *, tolerance: float = DEFAULT_TOLERANCE, method: str = "block",
             velocities: bool = True, accelerations: bool = False,
             max_iterations: int = DEFAULT_MAX_ITERATIONS) -> Cycle:
    """Solve ``mech`` over one crank cycle at θ_k = 2πk/steps, k = 0 … steps−1.

    method "block" runs Newton block by block in plan order; "dense" runs Newton on the full
    system (the reference); "closed" (all-dyad plans, positions only) places each dyad by
    circle–circle intersection on the nominal branch: the exact answer, with no branch tracking. ``tolerance`` bounds every scaled residual (|p_b − p_a|² − d²)/d².
    Velocities dV/dθ (per radian) and accelerations d²V/dθ² are returned when asked for.
    The cycle is ok only if every step converged on the branch chosen at θ = 0 (by the guess),
    no assembly gap hides between samples, and the cycle closes on itself.
    """
    _check_common(steps, tolerance, method, max_iterations)
    plan = plan_for(mech)
    theta, _, _ = crank_table(steps)
    nv = len(mech.vertices)
    P0, fail = assemble(mech)
    if fail is not None:
        nan = np.full((steps, nv, 2), np.nan)
        return Cycle(mech, theta, nan, nan.copy() if velocities else None, nan.copy() if accelerations else None,
                     False, fail, 0)
    signs = _signs(plan, P0)
    out = _run(mech, plan, mech.lengths[None, :], np.array([mech.crank.radius]), steps, np.arange(nv),
               velocities, accelerations, tolerance, method, max_iterations, P0, signs, np.arange(plan.n_blocks))
    pos, vel, acc, status, fth, fbl, its = out
    st = int(status[0])
    failure = None if st == STATUS_OK else _failure(mech, plan, st, float(fth[0]), int(fbl[0]))
    return Cycle(mech, theta, pos[0], vel[0] if velocities else None, acc[0] if accelerations else None,
                 st == STATUS_OK, failure, int(its[0]))


def _signs(plan: Plan, P: np.ndarray) -> np.ndarray:
    n = 2 * plan.n_vertices
    return block_signs(P, *plan.arrays(), plan.link_a, plan.link_b, np.full(plan.n_vertices, -1, dtype=np.int64),
                       np.empty((n, n)), np.empty(n))


def _run(mech, plan, lengths, crank, steps, out_idx, velocities, accelerations, tolerance, method, max_iterations,
         P0, signs, blocks):
    """Allocate the outputs and call the batch kernel on the plan restricted to ``blocks``."""
    _, cth, sth = crank_table(steps)
    N = lengths.shape[0]
    k = len(out_idx)
    pos = np.empty((N, steps, k, 2))
    vel = np.empty((N, steps if velocities else 0, k, 2))
    acc = np.empty((N, steps if accelerations else 0, k, 2))
    status = np.empty(N, dtype=np.int8)
    fth = np.empty(N)
    fbl = np.empty(N, dtype=np.int64)
    its = np.empty(N, dtype=np.int64)
    fixed_idx = plan.fixed
    known = np.concatenate([[plan.tip], fixed_idx]).astype(np.int64)
    fixed_pos = np.array([mech.fixed[mech.vertices[i]] for i in fixed_idx], dtype=np.float64).reshape(-1, 2)
    c = mech.crank.center
    lengths = np.ascontiguousarray(lengths, dtype=np.float64)
    crank = np.ascontiguousarray(crank, dtype=np.float64)
    out_idx = np.asarray(out_idx, dtype=np.int64)
    sg = np.ascontiguousarray(signs[blocks])
    all_dyads = all(plan.blocks[b].kind == DYAD for b in blocks)
    # One design runs the serial cycle kernel: a parallel region on a busy machine waits for every thread.
    if method == "closed":
        if velocities or accelerations or not all_dyads:
            raise UserError("method 'closed': the closed form gives positions only, and only for all-dyad plans")
        head = (*_dyad_tables(plan, blocks), plan.tip, fixed_idx, fixed_pos)
        if N == 1:
            status[0], fth[0] = closed_cycle(*head, lengths[0], crank[0], c[0], c[1], sg, cth, sth, out_idx, pos[0],
                                             P0.copy())
        else:
            closed_batch_jit(*head, lengths, crank, c[0], c[1], P0, sg, cth, sth, out_idx, pos, status, fth)
        fbl[:] = -1
        its[:] = 0
    else:
        if method == "block" and all_dyads:
            head, batch_kernel, cycle_kernel = (*_dyad_tables(plan, blocks), plan.tip, fixed_idx, fixed_pos), \
                dyad_batch_jit, dyad_cycle
        else:
            head, batch_kernel, cycle_kernel = (METHODS[method], *plan.arrays(blocks), plan.link_a, plan.link_b, known,
                                                fixed_pos), cycle_batch_jit, run_cycle
        tail = (float(c[0]), float(c[1]), P0, sg, cth, sth, float(tolerance), int(max_iterations), out_idx,
                bool(velocities), bool(accelerations))
        if N == 1:
            status[0], fth[0], fbl[0], its[0] = cycle_kernel(*head, lengths[0], crank[0], *tail, pos[0], vel[0], acc[0])
        else:
            batch_kernel(*head, lengths, crank, *tail, pos, vel, acc, status, fth, fbl, its)
    # report the failing block by its index in the full plan
    fbl = np.where(fbl >= 0, blocks[np.maximum(fbl, 0)], -1)
    return pos, vel, acc, status, fth, fbl, its


def _dyad_tables(plan: Plan, blocks) -> tuple:
    """(dv, dpa, dpb, dla, dlb): placed vertex, parents and links of each dyad in ``blocks``, int64 (n,)."""
    rows = []
    for b in blocks:
        v = plan.blocks[b].vertices[0]
        la, lb = plan.blocks[b].links
        rows.append((v, _other(plan, la, v), _other(plan, lb, v), la, lb))
    return tuple(np.array(col, dtype=np.int64).reshape(-1) for col in zip(*rows)) if rows else \
        tuple(np.zeros(0, dtype=np.int64) for _ in range(5))


def simulate_batch(mech: Mechanism, lengths, crank, steps: int = 360, *, vertices=None, velocities: bool = True,
                   accelerations: bool = False, tolerance: float = DEFAULT_TOLERANCE, method: str = "block",
                   max_iterations: int = DEFAULT_MAX_ITERATIONS) -> Batch:
    """Solve N variants of ``mech`` in parallel; only what is asked for is computed.

    lengths : (N, n_links) link lengths in ``mech.links`` order; crank : (N,) crank radii.
    vertices : names whose paths are returned (default: the foot). Blocks that neither place a
        requested vertex nor feed one are not solved (block method; "dense" solves everything).
    Every variant starts its θ = 0 Newton solve from the nominal design's configuration, and must
    keep the nominal's branch in every block; one that differs is flagged "branch", not mixed in.
    Returns a :class:`Batch`; rows whose lengths are not all finite and > 0 get status "invalid".
    """
    _check_common(steps, tolerance, method, max_iterations)
    lengths = np.asarray(lengths, dtype=np.float64)
    crank = np.asarray(crank, dtype=np.float64).reshape(-1)
    nl = len(mech.links)
    if lengths.ndim != 2 or lengths.shape[1] != nl:
        raise UserError(f"lengths: expected shape (N, {nl}) in mech.links order, got {lengths.shape}")
    if crank.shape[0] != lengths.shape[0]:
        raise UserError(f"crank: expected shape ({lengths.shape[0]},), got {crank.shape}")
    names = [mech.foot] if vertices is None else (list(mech.vertices) if vertices == "all" else [str(v) for v in vertices])
    out_idx = np.array([mech.vertex_index(v) for v in names], dtype=np.int64)
    plan = plan_for(mech)
    P0, fail = assemble(mech)
    if fail is not None:
        raise UserError(f"{where(mech.source, 'guess')}: the nominal design cannot be assembled at θ = 0: {fail.message}")
    signs = _signs(plan, P0)
    blocks = np.arange(plan.n_blocks) if method == "dense" else plan.needed_blocks(out_idx)
    pos, vel, acc, status, fth, fbl, its = _run(mech, plan, lengths, crank, steps, out_idx, velocities, accelerations,
                                                tolerance, method, max_iterations, P0, signs, blocks)
    theta, _, _ = crank_table(steps)
    return Batch(
        theta=theta,
        paths={v: pos[:, :, j] for j, v in enumerate(names)},
        velocities={v: vel[:, :, j] for j, v in enumerate(names)} if velocities else {},
        accelerations={v: acc[:, :, j] for j, v in enumerate(names)} if accelerations else {},
        status=status,
        fail_theta=fth,
        fail_block=fbl,
        iterations=its,
    )
