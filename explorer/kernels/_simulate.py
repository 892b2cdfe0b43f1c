"""Public entry points over the kernels: validate, allocate, call the ``_jit`` kernel, wrap results."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from contextlib import contextmanager
from functools import lru_cache

import numpy as np

from .._files import format_size
from ..errors import UserError, where
from ..mechanism import Mechanism, Operating, Walker, operating_from_dict, walker_body
from ..kinds import EQUATIONS, KINDS
from ..plan import Plan, make_plan
from ._closed import closed_batch_jit
from ._design import body_points
from ._design import designs as _designs
from ._forces import F_OK, collect, force_inputs, force_metrics, has_mass, no_forces
from ._drive import ARC, CRANK, LINE, LINEAR, QUINTIC, SPLINE, drive_table
from ._batch import fast_batch_jit, fast_forces_jit, generic_batch_jit, generic_forces_jit, setup
from ._codegen import is_ready, kernel_for, supported
from ._inputs import BLOCK_DTYPE, Designs, Drive, Options, Outputs, topology
from ._kinds_array import block_table
from ._rows import parallel_rows
from ._step import BLOCK, DENSE
from ._vector import FLAGGED, applies, vector_batch_jit
from ._sweep import STATUS_ASSEMBLY, STATUS_BRANCH, STATUS_INVALID, STATUS_NOCONV, STATUS_OK

#: Status code -> name; the same codes are stored in results files as ``/status``.
STATUS_NAMES = {
    STATUS_OK: "ok",
    STATUS_ASSEMBLY: "assembly",
    STATUS_BRANCH: "branch",
    STATUS_NOCONV: "no-convergence",
    STATUS_INVALID: "invalid",
}
#: The forces effect's own failure: a Jacobian singular at a sample (a toggle), where the joint
#: reactions and the motor torque are unbounded.
STATUS_SINGULAR = 5
STATUS_NAMES[STATUS_SINGULAR] = "singular"
METHODS = ("block", "dense", "closed", "vector", "auto")
#: Default tolerance: every solved position within 1e-11 × the design's longest link of the exact one
#: (6.6e-10 for Jansen's leg). It costs no measurable time over 1e-6 (see docs/accuracy.md).
DEFAULT_TOLERANCE = 1e-11
#: The range of tolerances accepted. Below 1e-12 rounding decides: solved positions differ from an
#: exact closed form by up to 2.5e-13 of the longest link whatever the tolerance (measured on 2,000
#: ±2 % Jansen variants), so a tighter promise could not be kept; above 1e-6 nothing is saved.
TOLERANCE_RANGE = (1e-12, 1e-6)
DEFAULT_MAX_ITERATIONS = 50

_KIND_TEXT = {
    "assembly": "cannot assemble",
    "branch": "left its branch (toggle crossed or mirrored assembly)",
    "no-convergence": "could not be solved (Newton did not converge, or a step could not be resolved)",
    "invalid": "has a non-finite or non-positive length",
    "singular": "is at or too near a toggle for its forces (a singular Jacobian: the joint reactions are unbounded)",
}
#: Variants solved at once when forces are asked for (the forces read every vertex's positions, per
#: design, from scratch; this bounds a chunk's designs and outputs as an earlier release bounded the
#: positions it kept: 1,024 × 360 steps × 7 vertices), fewer for a large mechanism (FORCE_MEMORY).
FORCE_CHUNK = 1024
FORCE_MEMORY = 64 << 20


def force_chunk(steps: int, n_vertices: int) -> int:
    """Variants per forces chunk: FORCE_CHUNK, lowered so their positions fit in FORCE_MEMORY."""
    return max(1, min(FORCE_CHUNK, FORCE_MEMORY // max(1, steps * n_vertices * 2 * 8)))


def available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux's MemAvailable), None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def dense_bytes(n_vertices: int, threads: int | None = None) -> int:
    """Memory the dense method's full-system matrix takes: (2 n_vertices)² doubles per thread."""
    import numba
    threads = numba.get_num_threads() if threads is None else int(threads)
    return threads * (2 * n_vertices) ** 2 * 8


def check_memory(need: int, what: str, advice: str) -> None:
    """Refuse, with one line and the estimate, what needs more memory than is available."""
    avail = available_memory()
    if avail is not None and need > avail:
        raise UserError(f"{what} need about {format_size(need)} of memory and {format_size(avail)} is available; {advice}")


def check_dense(n_vertices: int, method: str) -> None:
    """Refuse the dense method where its full-system matrices cannot fit in memory."""
    if method == "dense":
        import numba
        threads = numba.get_num_threads()
        check_memory(dense_bytes(n_vertices, threads), f"method 'dense': the full system of {n_vertices:,} vertices "
                     f"({2 * n_vertices:,} unknowns, one matrix per thread, {threads} threads) would",
                     "use method 'block' (the default), which solves it block by block")


@dataclass(frozen=True)
class Failure:
    """Why a cycle (or path) is not ok.

    kind : "assembly" | "branch" | "no-convergence" | "invalid"
    theta : driver parameter where it failed: the first crank angle (radians) going forward from
        θ = 0 that could not be solved, located to within Δθ/65536 (2π for a cycle that does not
        close on itself); for a path driver, the time in seconds.
    theta_end : for a crank, the first angle that could not be solved going backward (clockwise)
        from θ = 0: the design cannot move through [theta, theta_end], and the samples there are
        NaN; None when not applicable.
    block : index of the failing block in the plan, or None.
    vertex : name of the first vertex that block places, or None.
    message : one readable line.
    """

    kind: str
    theta: float
    theta_end: float | None
    block: int | None
    vertex: str | None
    message: str


@dataclass(frozen=True)
class Cycle:
    """One design solved over a crank cycle (or along its prescribed path).

    theta : (steps,) the driver parameter at each sample: crank angles θ_k = 2πk/steps in
        radians, or times t_k = T·k/(steps−1) in seconds for a path driver.
    positions : (steps, n_vertices, 2), model units; NaN where the design could not be solved.
    velocities : (steps, n_vertices, 2) dV/dθ per radian (dV/dt per second for a path), or None.
    accelerations : (steps, n_vertices, 2) d²V/dθ² (d²V/dt²), or None if not asked for.
    ok : True only if every sample solved on one branch (and a crank cycle closed on itself).
    failure : None, or a :class:`Failure`.
    iterations : total Newton iterations spent.
    torque : (steps,) motor torque, N·m (``forces=True``; see :mod:`explorer.kernels._forces`), or None.
    force_metrics : {metric: float} the forces effect's metrics in SI units (empty without forces).
    member_forces : {(member, joint): (steps, 2)} each member's force on each of its pins, N.
    body : the walker's force model the forces used, "moving" or "held" (``[operating] body``).
    body_acceleration : (steps, 2) the walker body's acceleration, m/s² (zero when held).
    ground_force : (steps, 2) the ground's force on the contact foot, N, in the walker's frame.
    contact : (steps,) the leg whose foot carries the walker at each sample (the walker scene's).
    """

    mechanism: Mechanism
    theta: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None
    accelerations: np.ndarray | None
    ok: bool
    failure: Failure | None
    iterations: int
    torque: np.ndarray | None = None
    joint_forces: dict | None = None
    force_metrics: dict | None = None
    member_forces: dict | None = None
    body: str | None = None
    body_acceleration: np.ndarray | None = None
    ground_force: np.ndarray | None = None
    contact: np.ndarray | None = None

    def force(self, joint: str) -> np.ndarray:
        """The reaction at ``joint`` at every sample, shape (steps, 2), N: the force its most heavily loaded
        member puts on the pin (``forces=True``)."""
        if self.joint_forces is None:
            raise UserError("forces were not computed: call simulate(..., forces=True, operating={...})")
        self.mechanism.vertex_index(joint)  # a one-line error naming the known joints
        return self.joint_forces[str(joint)]

    def path(self, vertex: str) -> np.ndarray:
        """Positions of ``vertex`` at every sample, shape (steps, 2)."""
        return self.positions[:, self.mechanism.vertex_index(vertex)]

    def velocity(self, vertex: str) -> np.ndarray:
        """Velocity of ``vertex`` at every sample, shape (steps, 2): per radian of crank, or per second for a path."""
        if self.velocities is None:
            raise UserError("velocities were not computed: call simulate(..., velocities=True)")
        return self.velocities[:, self.mechanism.vertex_index(vertex)]

    def link_angle(self, link: str) -> np.ndarray:
        """Direction of link ``link`` (from its ``a`` to its ``b`` vertex) at every sample, radians in (−π, π], shape (steps,)."""
        lk = self.mechanism.links[self.mechanism.link_index(link)]
        d = self.path(lk.b) - self.path(lk.a)
        return np.arctan2(d[:, 1], d[:, 0])

    def __repr__(self) -> str:
        state = "ok" if self.ok else f"failed: {self.failure.message}" if self.failure is not None else "failed"
        extra = " + velocities" if self.velocities is not None else ""
        extra += " + accelerations" if self.accelerations is not None else ""
        extra += " + forces" if self.torque is not None else ""
        return f"<Cycle {self.mechanism.name}: {len(self.theta)} steps, {self.positions.shape[1]} vertices{extra}; {state}>"


@dataclass(frozen=True)
class Batch:
    """Many variants of one mechanism, each solved at every sample of its driver.

    theta : (steps,) driver parameter (see :class:`Cycle`); paths / velocities / accelerations :
    dict vertex -> (N, steps, 2); status : (N,) int8 codes (see STATUS_NAMES); fail_theta : (N,)
    where it failed, NaN when ok; fail_theta_end : (N,) end of the unreachable crank range (see
    :class:`Failure`), NaN when not applicable; fail_block : (N,) plan block index, −1 when ok;
    iterations : (N,) total Newton iterations. With ``forces=True``: torque (N, steps) motor torque,
    N·m; forces {joint: (N, steps, 2)} reactions, N; force_metrics {metric: (N,)} in SI units.
    """

    theta: np.ndarray
    paths: dict
    velocities: dict
    accelerations: dict
    status: np.ndarray
    fail_theta: np.ndarray
    fail_theta_end: np.ndarray
    fail_block: np.ndarray
    iterations: np.ndarray
    torque: np.ndarray | None = None
    forces: dict | None = None
    force_metrics: dict | None = None

    def __repr__(self) -> str:
        n = len(self.status)
        counts = ", ".join(f"{STATUS_NAMES.get(int(c), c)} {int(k)}" for c, k in zip(*np.unique(self.status,
                                                                                                  return_counts=True)))
        extra = " + velocities" if self.velocities else ""
        extra += " + accelerations" if self.accelerations else ""
        return (f"<Batch {n} variants x {len(self.theta)} steps, vertices {', '.join(self.paths)}{extra}; "
                f"{counts or 'empty'}>")


# -- cached per topology and per driver and step count --------------------------------------------
def _topology(mech: Mechanism) -> tuple:
    """What a mechanism's plan depends on: its vertices, driven and fixed ones, and each equation type's
    structure (``key`` of ``explorer.kinds.EQUATIONS``)."""
    return (mech.vertices, mech.driven, tuple(mech.fixed), *(eq.key(mech) for eq in EQUATIONS))


_PLANS: dict = {}


def plan_for(mech: Mechanism) -> Plan:
    """The BLT plan of ``mech``'s topology (computed once per topology, then reused)."""
    key = _topology(mech)
    if key not in _PLANS:
        _PLANS[key] = make_plan(mech)
    return _PLANS[key]


@dataclass(frozen=True)
class _Drive:
    kind: int
    prm: np.ndarray  # driver parameters (see _drive)
    params: np.ndarray  # (S,) the sample parameters
    table: np.ndarray  # (S, 6) unit values at the samples
    t_end: float
    closed: bool
    center: tuple[float, float]  # the driven vertex sits at center + scale * unit value


@lru_cache(maxsize=64)
def _drive_for(driver, steps: int) -> _Drive:
    """Sample parameters and driver table for a Crank or PathDriver (computed once per driver and step count)."""
    if hasattr(driver, "tip"):  # a crank
        kind, prm, t_end, closed, center = CRANK, np.zeros(0), 2.0 * np.pi, True, driver.center
        params = 2.0 * np.pi * np.arange(steps) / steps
    else:
        law = QUINTIC if driver.timing == "quintic" else LINEAR
        head = [driver.duration, law]
        if driver.kind == "line":
            kind, prm = LINE, np.array(head + [*driver.points[0], *driver.points[1]])
        elif driver.kind == "arc":
            kind, prm = ARC, np.array(head + [*driver.center, driver.radius, driver.start_angle, driver.end_angle])
        else:
            from scipy.interpolate import CubicSpline

            pts = np.array(driver.points, dtype=np.float64)
            spline = CubicSpline(np.linspace(0.0, 1.0, len(pts)), pts, bc_type="natural")
            kind, prm = SPLINE, np.concatenate([head, [len(pts)], spline.c.ravel()])
        t_end, closed, center = driver.duration, False, (0.0, 0.0)
        params = driver.duration * np.arange(steps) / (steps - 1)
    # read-only before the first call of ``drive``: the sweep calls it with this read-only array, so one
    # compiled signature serves both (a writable one here compiled ``drive`` twice, 0.7 s on a cold cache)
    prm = np.asarray(prm, dtype=np.float64)
    prm.setflags(write=False)
    table = drive_table(kind, prm, params)
    for a in (params, table):
        a.setflags(write=False)
    return _Drive(kind, prm, params, table, t_end, closed, (float(center[0]), float(center[1])))


def _scale(mech: Mechanism) -> float:
    return mech.crank.radius if mech.crank is not None else 1.0


# -- assembly at the first sample ------------------------------------------------------------------
def assemble(mech: Mechanism) -> tuple[np.ndarray, Failure | None]:
    """Positions (n_vertices, 2) of ``mech`` at its first sample on the branch its guess selects.

    A dyad takes the circle–circle intersection on the same side of its parents as the guess; a
    pin–slider (SLIDE) block the line–circle intersection on the guess's side (``explorer.kinds.slide``);
    a body joint follows its base pair rigidly; a general block runs damped Newton from the guess.
    Returns (positions, None) or (partial, Failure).
    """
    plan = plan_for(mech)
    P = np.zeros((len(mech.vertices), 2))
    for v, xy in mech.guess.items():
        P[mech.vertex_index(v)] = xy
    for v, xy in mech.fixed.items():
        P[mech.vertex_index(v)] = xy
    drv = _drive_for(mech.crank or mech.path, 3)
    P[plan.tip] = np.array(drv.center) + _scale(mech) * drv.table[0, :2]
    ctx = _nominal_context(mech, plan, P)
    for k, blk in enumerate(plan.blocks):
        kind = KINDS[blk.kind]
        if not kind.assemble(k, P, ctx):
            status = STATUS_NOCONV if getattr(kind, "FAILS_AS", "assembly") == "no-convergence" else STATUS_ASSEMBLY
            return P, _failure(mech, plan, status, 0.0, math.nan, k)
    return P, None


def _nominal_context(mech: Mechanism, plan: Plan, P: np.ndarray):
    """What the kinds' ``assemble`` and ``branch`` read (Python, once per topology): the plan, the nominal
    design (``des``), the lowered plan of every block (``topo``), the nominal's block table at positions
    P (``table``), a coupled block's Newton tolerance and scratch of the largest coupled block."""
    from types import SimpleNamespace

    des = _nominal_design(mech, plan, DEFAULT_TOLERANCE)
    topo = topology(plan, range(plan.n_blocks), [], [], mech.crank is not None)
    table = np.zeros(plan.n_blocks, dtype=BLOCK_DTYPE)
    block_table(table, topo.kind, topo.blk, topo.tip, des.dist[0], des.uv[0], des.slide[0], des.extra[0], topo.att_vpq,
                topo.slide, P, des.center[0, 0], des.center[0, 1], des.scale[0], False)
    n = 2 * _largest_general(plan)  # scratch of the largest coupled block, not of the whole mechanism
    return SimpleNamespace(plan=plan, des=des, topo=topo, table=table, tol=1e-12 * mech.size,
                           loc=np.full(len(mech.vertices), -1, dtype=np.int64), M=np.empty((n, n)), rhs=np.empty(n))


def _largest_general(plan: Plan) -> int:
    """Vertices of the plan's largest coupled (GENERAL) block, 0 if it has none."""
    return max((len(b.vertices) for b in plan.blocks if _coupled(b.kind)), default=0)


def _coupled(kind: int) -> bool:
    """Whether blocks of this kind need the generic context (coupled blocks: ``kinds.general``)."""
    return getattr(KINDS[int(kind)], "CONTEXT", False)


def _nominal_design(mech: Mechanism, plan: Plan, tolerance: float):
    """The nominal design as the kernels read it (``_inputs.Designs`` of one row)."""
    return _designs(mech, plan, mech.lengths[None, :], np.array([_scale(mech)]), None, tolerance)


def _failure(mech: Mechanism, plan: Plan, status: int, theta: float, theta_end: float, block: int) -> Failure:
    kind = STATUS_NAMES[int(status)]
    vertex = mech.vertices[plan.blocks[block].vertices[0]] if block >= 0 else None
    who = f"vertex {vertex}" if vertex is not None else "the design"
    if mech.crank is None:
        at = f"t = {theta:.6g} s"
    else:
        at = f"θ = {math.degrees(theta):.4f}°"
        if theta_end == theta_end:  # not NaN: the reachable range ends on both sides
            at += f" (it cannot turn through θ = {math.degrees(theta):.4f}° … {math.degrees(theta_end):.4f}°)"
    if mech.crank is not None and kind == "branch" and theta >= 2 * math.pi - 1e-12:
        msg = f"{who}: the cycle does not close on its starting configuration after a full crank turn"
    else:
        msg = f"{who} {_KIND_TEXT[kind]} at {at}"
    return Failure(kind, float(theta), None if theta_end != theta_end else float(theta_end),
                   None if block < 0 else int(block), vertex, msg)


# -- the public solvers ------------------------------------------------------------------------------
def _check_common(steps, tolerance, method, max_iterations):
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 3:
        raise UserError(f"steps: expected an integer ≥ 3, got {steps!r}")
    lo, hi = TOLERANCE_RANGE
    if (isinstance(tolerance, bool) or not isinstance(tolerance, (int, float)) or not math.isfinite(tolerance)
            or not lo <= tolerance <= hi):
        raise UserError(f"tolerance: expected a number from {lo:g} to {hi:g} (the bound on every solved position's "
                        f"error, relative to the longest link; looser saves no time, tighter hits rounding), "
                        f"got {tolerance!r}")
    if method not in METHODS:
        raise UserError(f"method: expected one of {', '.join(METHODS)}, got {method!r}")
    if not (isinstance(max_iterations, (int, np.integer)) and max_iterations >= 1):
        raise UserError(f"max_iterations: expected an integer ≥ 1, got {max_iterations!r}")


def simulate(mech: Mechanism, steps: int = 360, *, tolerance: float = DEFAULT_TOLERANCE, method: str = "block",
             velocities: bool | None = None, accelerations: bool = False,
             max_iterations: int = DEFAULT_MAX_ITERATIONS, forces: bool = False, operating=None,
             walker: Walker | None = None) -> Cycle:
    """Solve ``mech`` at every sample of its driver: θ_k = 2πk/steps for a crank (k = 0 … steps−1),
    t_k = T·k/(steps−1) for a prescribed path of duration T.

    method "block" runs Newton block by block in plan order; "dense" runs Newton on the full
    system (the reference); "closed" (all-dyad plans, positions only) places each dyad by
    circle–circle intersection on the starting branch: exact, but blind to branch changes;
    "vector" is the vectorised closed-form first pass (``explorer.kernels._vector``: each block over
    every sample at once on the starting branch, with its tangents, then the assembly margin, fold,
    gap and move checks as passes over the step arrays; a design it flags goes through the block
    Newton sweep, which reports every failure) for plans of dyads, body joints, sliders and geared
    cranks, positions and velocities (an error otherwise); "auto" is "vector" where it applies
    (:func:`vector_applies`, no accelerations, no forces) and "block" elsewhere.
    ``tolerance`` bounds the error of every solved position, relative to the design's longest link:
    Newton stops once it has applied a correction shorter than tolerance × the longest link, which
    (Newton converging quadratically) leaves an error of the order of that correction squared.
    It must be in :data:`TOLERANCE_RANGE` (1e-12 … 1e-6; default 1e-11). Velocities (default: yes,
    except with method "closed", which gives positions only) and accelerations are returned when
    asked for. The result is ok only if every sample solved on the
    branch chosen at the start (by the guess), no assembly gap hides between samples, and a crank
    cycle closes on itself.

    forces : also the motor torque, every joint's reaction and the force metrics, in SI units, at the
        ``operating`` point (a dict of ``[operating]`` keys or an :class:`~explorer.mechanism.Operating`;
        keys not given come from the mechanism file's ``[operating]``; ``unit`` and ``rpm`` are
        required), for the ``walker`` scene (default: the mechanism's own ``[walker]``, else one leg);
        see :mod:`explorer.kernels._forces` for the model: ``operating["body"]`` "moving" (the default:
        the body, of mass ``load``, moves with the planted contact foot and the ground carries the whole
        machine) or "held" (the frame held still). A sample where a Jacobian is singular fails the cycle
        as "singular".
    """
    _check_common(steps, tolerance, method, max_iterations)
    velocities = _default_velocities(velocities, method)
    if forces:
        operating, walker = force_setup(mech, operating, walker)
    check_dense(len(mech.vertices), method)
    plan = plan_for(mech)
    drv = _drive_for(mech.crank or mech.path, steps)
    nv = len(mech.vertices)
    P0, fail = assemble(mech)
    if fail is not None:
        nan = np.full((steps, nv, 2), np.nan)
        return Cycle(mech, drv.params, nan, nan.copy() if velocities else None,
                     nan.copy() if accelerations else None, False, fail, 0)
    signs = _signs(mech, plan, P0)
    des = _nominal_design(mech, plan, tolerance)
    fin = None
    if forces:  # computed in the same kernel call as the sweep
        model, frows, tb = force_inputs(mech, plan, mech.lengths[None, :], np.array([_scale(mech)]),
                                        body_points(mech, None, 1), operating, walker, steps, mech.vertices,
                                        members=True, out_idx=np.arange(nv))
        fin = (model, frows)
    pos, vel, acc, status, fth, fend, fbl, its = _run(
        mech, plan, des, steps, np.arange(nv), velocities, accelerations, method, max_iterations, P0, signs,
        np.arange(plan.n_blocks), forces=fin)
    extra = {}
    if forces:
        fo = collect(mech, operating, walker, model, frows, tb, status, mech.vertices, members=True)
        _force_status(fo, status, fth, fbl, drv.params)
        met = force_metrics(fo, operating, mech.vertices)
        extra = dict(torque=fo.torque[0], joint_forces={j: f[0] for j, f in fo.joint_forces.items()},
                     force_metrics={k: float(v[0]) for k, v in met.items()},
                     member_forces={k: f[0] for k, f in fo.members.items()}, body=fo.body,
                     body_acceleration=fo.body_acceleration[0], ground_force=fo.ground_force[0], contact=fo.contact[0])
    st = int(status[0])
    failure = None if st == STATUS_OK else _failure(mech, plan, st, float(fth[0]), float(fend[0]), int(fbl[0]))
    return Cycle(mech, drv.params, pos[0], vel[0] if velocities else None, acc[0] if accelerations else None,
                 st == STATUS_OK, failure, int(its[0]), **extra)


def force_setup(mech: Mechanism, operating, walker) -> tuple[Operating, Walker]:
    """The operating point (``operating``: None, a dict of ``[operating]`` keys or an Operating, over the
    mechanism file's ``[operating]``) and walker scene (default: the mechanism's, else one leg) of the
    forces effect; UserError unless the mechanism has a crank and ``unit`` and ``rpm`` are given."""
    if mech.crank is None:
        raise UserError(f"{where(mech.source, 'driver')}: forces are computed for crank-driven mechanisms (the motor "
                        f"torque is the crank's); this one is driven by a path")
    for b in plan_for(mech).blocks:  # a kind whose forces are not written yet says so (``FORCES``)
        kind = KINDS[b.kind]
        if not getattr(kind, "FORCES", True):
            raise UserError(f"{where(mech.source, 'operating')}: forces are not computed for a mechanism with "
                            f"{kind.FORCES_REFUSED} yet (the {kind.NAME} block placing "
                            f"{', '.join(mech.vertices[v] for v in b.vertices)})")
    if isinstance(operating, Operating):
        op = operating
    else:
        op = operating_from_dict(dict(operating or {}), "operating", "operating", base=mech.operating)
    for k, what in (("unit", "metres per model unit, e.g. 0.01 for a mechanism in centimetres"),
                    ("rpm", "the crank speed in revolutions per minute")):
        if getattr(op, k) is None:
            raise UserError(f"operating.{k}: forces need it ({what}); give it in the study's or the mechanism's "
                            f"[operating] table")
    return walker_body(mech, op, "operating"), (walker or mech.walker or Walker(legs=1))


def _force_status(fo, status, fth, fbl, params) -> None:
    """Mark the rows whose forces failed (a singular Jacobian, or non-finite forces) "singular", in place."""
    bad = (fo.code != F_OK) & (status == STATUS_OK)
    status[bad] = STATUS_SINGULAR
    fth[bad] = params[np.maximum(fo.sample[bad], 0)]
    fbl[bad] = fo.block[bad]


def branch_signs(mech: Mechanism, positions) -> np.ndarray:
    """The branch of a configuration: the sign (+1.0 / −1.0) of every block of ``mech``'s plan at
    ``positions`` (n_vertices, 2), in plan order; 0.0 for a block at a singular point (a dyad whose
    vertex is on its parents' line, a coupled block at a toggle) and for an ATTACH block, which has no
    branch. Two configurations of one topology lie on the same branch where their signs agree: the
    solver keeps every block's sign through a cycle and fails a variant whose sign changes."""
    P = np.asarray(positions, dtype=np.float64)
    if P.shape != (len(mech.vertices), 2):
        raise UserError(f"positions: expected shape ({len(mech.vertices)}, 2), got {P.shape}")
    return _signs(mech, plan_for(mech), P)


def _signs(mech: Mechanism, plan: Plan, P: np.ndarray) -> np.ndarray:
    """Branch sign (+1.0 / −1.0; 0.0 if singular or for an ATTACH block, which has none) of every block
    at positions P (n_vertices, 2)."""
    # each kind's own sign (a dyad's orientation, a coupled block's determinant sign, ...)
    ctx = _nominal_context(mech, plan, P)
    return np.array([KINDS[blk.kind].branch(k, P, ctx) for k, blk in enumerate(plan.blocks)], dtype=np.float64)


KERNELS = ("auto", "general", "generated")
#: Most blocks for which kernel "auto" generates a kernel for the topology (``_codegen``). Its
#: compile time grows faster than its size, and its speed-up vanishes: on the 2-core development
#: machine, cold, a chain of dyads compiled in 13 s with 5 blocks, 22 s with 10, 35 s with 20 and
#: 206 s with 50 (two such kernels for a first ``simulate`` and ``simulate_batch``), and solved 2,000
#: variants x 360 steps 1.02x, 1.11x and 0.80x as fast as the general kernel, which is compiled once
#: for every topology. Every built-in leg has at most 6 blocks.
GENERATED_MAX_BLOCKS = 12

#: Kernel "auto" compiles a topology's generated kernel (about 2 CPU-s for its loop of whole steps on a
#: 2-core machine, ~10 more for a forces kernel's generated base leg and batch loop; once per topology
#: and set of outputs, then cached on disk) only where it costs nothing now (compiled in this
#: process, or cached by an earlier run or ``explorer warm``) or the job is at least this many
#: configurations (designs x samples). The generated code is 1.3-1.4x as fast as the general kernel
#: (Jansen, 10,000 x 360: 0.47 against 0.62 CPU-s), a saving of ~0.04 µs a configuration: a single
#: ``simulate``, an editor's drag, a yield check or a small batch is done by the general kernel
#: (compiled once for every topology) long before the compile would finish, while a study (the
#: default one is 3.6 million) compiles it once, caches it and every later run of it gains.
#: The answers are the same bit for bit (tests/test_codegen.py).
GENERATED_MIN_CONFIGS = 1_000_000
_GENERATE_ALWAYS = [0]  # depth of compiling_generated() blocks (process-wide: a study's threads see it)


@contextmanager
def compiling_generated():
    """Within this block, kernel "auto" uses the generated kernel wherever it applies, compiling it if it
    is not cached, whatever the job's size: ``explorer warm`` runs its small studies in one, so that
    later runs find every generated kernel of them in the cache."""
    _GENERATE_ALWAYS[0] += 1
    try:
        yield
    finally:
        _GENERATE_ALWAYS[0] -= 1


def _generated_pays(topo, opts, forces, job_configs: int) -> bool:
    """Kernel "auto"'s choice (see :data:`GENERATED_MIN_CONFIGS`); forces: False, or the forces' shared
    inputs (``_forces.ForceModel``: the generated kernel depends on its members)."""
    return (_GENERATE_ALWAYS[0] > 0 or job_configs >= GENERATED_MIN_CONFIGS
            or is_ready(topo, opts.want_vel, opts.want_acc, forces))


def _run(mech, plan, des, steps, out_idx, velocities, accelerations, method, max_iterations, P0, signs, blocks,
         kernel="auto", forces=None, job_configs=0):
    """Allocate the outputs and call the kernel for ``method`` on the plan restricted to ``blocks``;
    ``des``: the variants' ``_inputs.Designs``; ``kernel``: see :func:`simulate_batch`. ``forces``:
    None, or the forces effect's (``_forces.ForceModel``, ``ForceRows``), computed in the same kernel
    call (every vertex solved with its rates into per-design scratch; the rows of ``out_idx`` stored).
    ``job_configs``: the configurations of the whole job this call is part of (kernel "auto" weighs a
    generated kernel's compile against it; at least this call's)."""
    drv = _drive_for(mech.crank or mech.path, steps)
    N = des.scale.shape[0]
    job_configs = max(int(job_configs), N * steps)
    k = len(out_idx)
    outs = Outputs(np.empty((N, steps, k, 2)), np.empty((N, steps if velocities else 0, k, 2)),
                   np.empty((N, steps if accelerations else 0, k, 2)), np.empty(N, dtype=np.int8), np.empty(N),
                   np.full(N, np.nan), np.full(N, -1, dtype=np.int64), np.zeros(N, dtype=np.int64))
    nv, nb = len(mech.vertices), len(blocks)
    solved = sorted({plan.tip, *(v for b in blocks for v in plan.blocks[b].vertices)})
    moving = np.arange(nv) if method == "dense" else np.array(solved, dtype=np.int64)
    # with forces the sweep stores every vertex (the forces' scratch), and the kernel copies out_idx's rows
    topo = topology(plan, blocks, moving, np.arange(nv) if forces is not None else out_idx, mech.crank is not None)
    kdrv = Drive(drv.kind, drv.prm, drv.table, drv.params, drv.t_end, drv.closed)
    sg = np.ascontiguousarray(signs[blocks])
    general = any(_coupled(k) for k in topo.kind)
    des = setup(plan, blocks, topo, kdrv, P0, sg, des._replace(
        table=np.zeros((N, nb), dtype=BLOCK_DTYPE), start=np.empty((N, nv, 2)), shortest=np.empty(N)))
    if method in ("auto", "vector"):
        fits = forces is None and not accelerations and not general and applies(topo.kind, sg)
        if method == "vector" and not fits:
            raise UserError("method 'vector': the vectorised first pass solves plans of dyads, rigid bodies and "
                            "sliders (no coupled blocks), positions and velocities (no accelerations or forces); "
                            "use method 'auto', which runs Newton where it does not apply")
        method = "vector" if fits else "block"
    if method == "vector":  # where the first pass leaves each flagged design to Newton (``_vector.restart_points``)
        des = des._replace(restart_at=np.zeros((N, 2), dtype=np.int64), restart_pos=np.zeros((N, 2, nv, 2)))
    if method == "closed":
        if velocities or accelerations or general:
            raise UserError("method 'closed': the closed form gives positions only, and only for plans of dyads and "
                            "rigid bodies (no coupled blocks)")
        parallel_rows(closed_batch_jit, (topo, kdrv, sg), (des, outs))
    elif method == "vector":
        # the first pass for every design; the ones it flags through the Newton sweep, which reports failures
        parallel_rows(vector_batch_jit, (topo, kdrv, bool(velocities), sg), (des, outs))
        rows = np.flatnonzero(outs.status == FLAGGED)
        if rows.size:
            sub = Outputs(*(a[rows] for a in outs))
            _newton(topo, kdrv, sg, Designs(*(a[rows] for a in des)), sub, "block", max_iterations, velocities,
                    False, kernel, general, None, job_configs)
            for a, b in zip(outs, sub):
                a[rows] = b
    else:
        _newton(topo, kdrv, sg, des, outs, method, max_iterations, velocities, accelerations, kernel, general, forces,
                job_configs)
    fbl = outs.fail_block
    if len(blocks):  # report the failing block by its index in the full plan
        fbl = np.where(fbl >= 0, blocks[np.maximum(fbl, 0)], -1)
    return outs.pos, outs.vel, outs.acc, outs.status, outs.fail_t, outs.fail_end, fbl, outs.iters


def _newton(topo, kdrv, sg, des, outs, method, max_iterations, velocities, accelerations, kernel, general, forces,
            job_configs):
    """The Newton sweep ("block" or "dense") for every row of ``des`` into ``outs``; the kernel chosen
    as :func:`simulate_batch` documents (``kernel``), with the forces effect when ``forces`` is given."""
    # with forces the sweep carries every vertex's rates (the forces read them)
    opts = Options(DENSE if method == "dense" else BLOCK, int(max_iterations),
                   bool(velocities) or forces is not None, bool(accelerations) or forces is not None)
    if kernel == "generated" and (method == "dense" or general or not supported(topo, opts)):
        raise UserError("kernel 'generated': per-topology code is generated only for the block method on plans "
                        "whose kinds have a generated form (not coupled blocks or sliders); use kernel='auto' "
                        "or 'general'")
    if method == "dense" or general:
        fn = generic_batch_jit if forces is None else generic_forces_jit
    elif kernel != "general" and supported(topo, opts) and (
            kernel == "generated" or (topo.kind.shape[0] <= GENERATED_MAX_BLOCKS
                                      and _generated_pays(topo, opts, False if forces is None else forces[0],
                                                          job_configs))):
        # this plan's code, generated (the same results)
        fn = kernel_for(topo, opts.want_vel, opts.want_acc, False if forces is None else forces[0])
    else:
        fn = fast_batch_jit if forces is None else fast_forces_jit
    if forces is None:
        parallel_rows(fn, (topo, kdrv, opts, sg), (des, outs))
    else:
        parallel_rows(fn, (topo, kdrv, opts, sg, forces[0]), (des, outs, forces[1]))


def vector_applies(mech: Mechanism, vertices="all") -> bool:
    """Whether method "auto" solves ``mech`` (the blocks that place ``vertices``: names, or "all") by
    the vectorised closed-form first pass (without accelerations or forces): every block a dyad, a body
    joint or a slider, and the nominal assembles off a fold. Otherwise "auto" runs the Newton sweep."""
    P0, fail = assemble(mech)
    if fail is not None:
        return False
    plan = plan_for(mech)
    names = list(mech.vertices) if vertices == "all" else [str(v) for v in vertices]
    blocks = plan.needed_blocks(np.array([mech.vertex_index(v) for v in names], dtype=np.int64))
    return applies([plan.blocks[b].kind for b in blocks], _signs(mech, plan, P0)[blocks])


def warm_dyad() -> None:
    """Compile the dyad's arithmetic (``explorer.kinds.dyad.place_dyad``, with ``gap_suspect``) into the
    on-disk kernel cache, for a warm-up process (``explorer.gait._warm``): it is called here once, on
    numbers it settles at once, with the argument types every solver kernel (generated or general)
    calls it with, so a cold ``explorer run``, whose own compile of the solver reaches it seconds
    later, loads it from the cache instead of compiling it (1.7-2 CPU-s)."""
    from ..kinds.dyad import place_dyad

    place_dyad(True, True, *([0.0] * 31), 1)


def _by_name(mech: Mechanism, lengths, crank, geometry):
    """Parameters given by name — a pandas DataFrame or a dict {name: (N,) values} — as an (N, n_links)
    array in ``mech.links`` order, the crank radii and the geometry (column order does not matter; a
    "crank" column gives the radii when ``crank`` is None; coordinate columns such as "2.x" join
    ``geometry`` unless it names them; other columns, such as a results frame's metrics, are
    ignored). A plain array is taken in ``mech.links`` order, as documented."""
    columns = None
    if hasattr(lengths, "columns") and hasattr(lengths, "to_numpy"):  # a DataFrame
        columns = {str(c): lengths[c].to_numpy(dtype=np.float64) for c in lengths.columns}
    elif isinstance(lengths, dict):
        columns = {str(k): np.asarray(v, dtype=np.float64).reshape(-1) for k, v in lengths.items()}
    if columns is None:
        return lengths, crank, geometry
    missing = [n for n in mech.link_names if n not in columns]
    if missing:
        raise UserError(f"lengths: no column for link {missing[0]!r} (links: {', '.join(mech.link_names)}; "
                        f"columns given: {', '.join(columns)})")
    if crank is None and "crank" in columns and mech.crank is not None:
        crank = columns["crank"]
    coords = [n for n in mech.parameters() if n != "crank" and n not in mech.link_names]  # coordinates, gear radii
    geometry = dict(geometry or {})
    for n in coords:
        if n in columns and n not in geometry:
            geometry[n] = columns[n]
    return np.column_stack([columns[n] for n in mech.link_names]), crank, geometry


def _default_velocities(velocities, method: str) -> bool:
    """None → velocities unless the method is "closed" (positions only)."""
    if velocities is None:
        return method != "closed"
    return bool(velocities)


def simulate_batch(mech: Mechanism, lengths, crank=None, steps: int = 360, *, geometry=None, vertices=None,
                   velocities: bool | None = None,
                   accelerations: bool = False, tolerance: float = DEFAULT_TOLERANCE, method: str = "block",
                   max_iterations: int = DEFAULT_MAX_ITERATIONS, kernel: str = "auto", forces: bool = False,
                   operating=None, walker: Walker | None = None, force_joints=(), job_configs: int = 0) -> Batch:
    """Solve N variants of ``mech`` in parallel; only what is asked for is computed.

    lengths : (N, n_links) link lengths in ``mech.links`` order, or every design parameter by name
        (``Mechanism.parameters``): a pandas DataFrame (a results frame will do) or a dict with a
        column per link name, in any order; a "crank" column gives the radii when ``crank`` is
        None, coordinate columns ("crank.x", "2.y", "coupler.P.x") the geometry; columns that name
        no parameter are ignored.
    crank : (N,) crank radii (None: the nominal radius for every variant; must be None for a
        path-driven mechanism).
    geometry : {coordinate parameter name: (N,) values}, model units: geared cranks' radii, the crank centre, ground
        pivots and body joints of each variant (those not given keep their nominal values).
    vertices : names whose paths are returned (default: the foot; "all" for every vertex). Blocks
        that neither place a requested vertex nor feed one are not solved (block and closed
        methods; "dense" solves everything).
    Every variant keeps the nominal's branch in every block: it is assembled at the first sample on
    that branch (each dyad's vertex on the nominal's side of its parents' line, each body joint by
    its body's rigid transform, by the closed form; a coupled block by Newton from the nominal's
    configuration), however far its dimensions are from the nominal's, then followed; one whose
    branch changes on the way is flagged "branch", not mixed in.
    Returns a :class:`Batch`; rows with a length (or crank) that is not finite and within
    [1e-150, 1e150] (where squared lengths stay representable) get status "invalid". If the nominal
    design itself cannot be assembled at the start, there is no configuration or branch to start
    from: every row fails as the nominal does (as :func:`simulate` reports it), with NaN paths.
    velocities : default yes, except with method "closed" (positions only).
    method : as for :func:`simulate` ("block", "dense", "closed", "vector", "auto").
    kernel : "auto" (default: the per-topology generated code where it applies, the blocks solved
        are at most :data:`GENERATED_MAX_BLOCKS` and its compile pays (:data:`GENERATED_MIN_CONFIGS`:
        it is cached, or the job is large), else the array form),
        "general" (always the array form of the sweep) or "generated" (the generated code; an error
        where it does not apply). The results are the same bit for bit; the choice is for speed.
    job_configs : configurations (designs x samples) of the whole job this call is one part of (a
        study's chunk passes the study's), which kernel "auto" weighs a compile against; default:
        this call's.
    forces, operating, walker : as for :func:`simulate`; the Batch then holds ``torque`` (N, steps),
        ``forces`` {joint: (N, steps, 2)} for the joints named in ``force_joints`` and
        ``force_metrics`` {metric: (N,)}. Variants are solved ``force_chunk`` at a time.
    """
    _check_common(steps, tolerance, method, max_iterations)
    if forces:
        operating, walker = force_setup(mech, operating, walker)
        force_joints = [str(j) for j in ([force_joints] if isinstance(force_joints, str) else force_joints)]
        for j in force_joints:
            mech.vertex_index(j)
    if kernel not in KERNELS:
        raise UserError(f"kernel: expected one of {', '.join(KERNELS)}, got {kernel!r}")
    if isinstance(job_configs, bool) or not isinstance(job_configs, (int, np.integer)) or job_configs < 0:
        raise UserError(f"job_configs: expected a number of configurations (an integer >= 0), got {job_configs!r}")
    velocities = _default_velocities(velocities, method)
    lengths, crank, geometry = _by_name(mech, lengths, crank, geometry)
    lengths = np.asarray(lengths, dtype=np.float64)
    nl = len(mech.links)
    if lengths.ndim != 2 or lengths.shape[1] != nl:
        raise UserError(f"lengths: expected shape (N, {nl}) in mech.links order, got {lengths.shape}")
    if crank is None:
        scale = np.full(lengths.shape[0], _scale(mech))
    elif mech.crank is None:
        raise UserError(f"{where(mech.source, 'crank')}: this mechanism is driven by a path; pass crank=None")
    else:
        scale = np.asarray(crank, dtype=np.float64).reshape(-1)
    if scale.shape[0] != lengths.shape[0]:
        raise UserError(f"crank: expected shape ({lengths.shape[0]},), got {scale.shape}")
    if isinstance(vertices, str) and vertices != "all":
        vertices = [vertices]  # one vertex name, not its characters ("37" is vertex 37, not 3 and 7)
    names = [mech.foot] if vertices is None else (list(mech.vertices) if vertices == "all" else [str(v) for v in vertices])
    out_idx = np.array([mech.vertex_index(v) for v in names], dtype=np.int64)
    check_dense(len(mech.vertices), method)
    plan = plan_for(mech)
    P0, fail = assemble(mech)
    if fail is not None:  # no start: every row fails as the nominal does
        N, n_out = lengths.shape[0], len(names)
        pos = np.full((N, steps, n_out, 2), np.nan)
        vel, acc = pos.copy(), pos.copy()
        code = {v: k for k, v in STATUS_NAMES.items()}[fail.kind]
        status = np.full(N, code, dtype=np.int8)
        fth, fend = np.full(N, fail.theta), np.full(N, np.nan)
        fbl = np.full(N, -1 if fail.block is None else fail.block, dtype=np.int64)
        its = np.zeros(N, dtype=np.int64)
        fo = met = None
    elif forces:
        pos, vel, acc, status, fth, fend, fbl, its, fo, met = _batch_forces(
            mech, plan, lengths, scale, geometry, tolerance, steps, out_idx, velocities, accelerations, method,
            max_iterations, P0, kernel, operating, walker, force_joints, job_configs)
    else:
        N = lengths.shape[0]
        per = steps * len(names) * 2 * 8 * (1 + bool(velocities) + bool(accelerations))
        check_memory(N * per, f"simulate_batch: the outputs of {N:,} variants x {steps:,} steps x {len(names):,} "
                     f"vertices would", "ask for fewer vertices or variants at a time (a study solves in chunks)")
        signs = _signs(mech, plan, P0)
        blocks = np.arange(plan.n_blocks) if method == "dense" else plan.needed_blocks(out_idx)
        des = _designs(mech, plan, lengths, scale, geometry, tolerance)
        pos, vel, acc, status, fth, fend, fbl, its = _run(mech, plan, des, steps, out_idx, velocities, accelerations,
                                                          method, max_iterations, P0, signs, blocks, kernel,
                                                          job_configs=job_configs)
        fo = met = None
    if forces and fo is None:  # no start: every row failed, and every force figure is NaN
        failed = no_forces(lengths.shape[0], steps, len(mech.vertices), force_joints, has_mass(mech, operating))
        fo, met = (failed.torque, failed.joint_forces), force_metrics(failed, operating, mech.vertices)
    return Batch(
        theta=_drive_for(mech.crank or mech.path, steps).params,
        paths={v: pos[:, :, j] for j, v in enumerate(names)},
        velocities={v: vel[:, :, j] for j, v in enumerate(names)} if velocities else {},
        accelerations={v: acc[:, :, j] for j, v in enumerate(names)} if accelerations else {},
        status=status,
        fail_theta=fth,
        fail_theta_end=fend,
        fail_block=fbl,
        iterations=its,
        torque=fo[0] if forces else None,
        forces=fo[1] if forces else None,
        force_metrics=met if forces else None,
    )


def _batch_forces(mech, plan, lengths, scale, geometry, tolerance, steps, out_idx, velocities, accelerations, method,
                  max_iterations, P0, kernel, operating, walker, force_joints, job_configs=0):
    """simulate_batch with forces: FORCE_CHUNK variants at a time, every vertex solved and the forces
    effect computed in one kernel call per chunk; returns the outputs for ``out_idx`` and (torque,
    {joint: forces}) and the force metrics."""
    N = lengths.shape[0]
    signs = _signs(mech, plan, P0)
    blocks = np.arange(plan.n_blocks)
    k = len(out_idx)
    pos = np.empty((N, steps, k, 2))
    vel = np.empty((N, steps if velocities else 0, k, 2))
    acc = np.empty((N, steps if accelerations else 0, k, 2))
    status, fth, fend = np.empty(N, dtype=np.int8), np.empty(N), np.empty(N)
    fbl, its = np.empty(N, dtype=np.int64), np.empty(N, dtype=np.int64)
    torque = np.empty((N, steps))
    jf = {j: np.empty((N, steps, 2)) for j in force_joints}
    met: dict = {}
    params = _drive_for(mech.crank, steps).params
    geometry = dict(geometry or {})
    rows = force_chunk(steps, len(mech.vertices))
    for lo in range(0, N, rows):
        hi = min(N, lo + rows)
        g = {n: np.asarray(c, dtype=np.float64).reshape(-1)[lo:hi] for n, c in geometry.items()}
        des = _designs(mech, plan, lengths[lo:hi], scale[lo:hi], g, tolerance)
        model, frows, tb = force_inputs(mech, plan, lengths[lo:hi], scale[lo:hi], body_points(mech, g, hi - lo),
                                        operating, walker, steps, force_joints, out_idx=out_idx)
        p, v, a, st, th, te, bl, it = _run(mech, plan, des, steps, out_idx, velocities, accelerations, method,
                                           max_iterations, P0, signs, blocks, kernel, forces=(model, frows),
                                           job_configs=max(int(job_configs), N * steps))
        fo = collect(mech, operating, walker, model, frows, tb, st, force_joints)
        _force_status(fo, st, th, bl, params)
        pos[lo:hi], vel[lo:hi], acc[lo:hi] = p, v, a
        status[lo:hi], fth[lo:hi], fend[lo:hi], fbl[lo:hi], its[lo:hi] = st, th, te, bl, it
        torque[lo:hi] = fo.torque
        for j in force_joints:
            jf[j][lo:hi] = fo.joint_forces[j]
        for name, col in force_metrics(fo, operating, mech.vertices).items():
            met.setdefault(name, np.empty(N))[lo:hi] = col
    return pos, vel, acc, status, fth, fend, fbl, its, (torque, jf), met
