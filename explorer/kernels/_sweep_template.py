"""The sweep, written once: continuation over the driver's parameter with branch tracking and refinement.

:func:`sweep` below is a template: valid Python whose control flow (the moves, their refinement, the
backward sweep after a crank cycle fails, the closing check, the failure report) is the sweep's one
home, with *holes* where the two forms of the sweep keep their state differently. It is rendered
(:func:`render`) into

* the **array form** (``_sweep``'s dialect): state in (n_vertices, 2) arrays, the step a call that
  ``_sweep._specialise`` binds to the fast DYAD / ATTACH step or the generic one. The rendering is
  committed as ``_sweep_array.py`` (so lint, coverage and tracebacks see it); tests/test_sweep_template.py
  re-renders it and compares the text;
* the **scalar form** (``_codegen``'s dialect): one topology's loop of whole steps (the
  ``whole_steps`` section), every vertex's state in local scalars and every block written out,
  rendered when a topology is first simulated; the rest of its sweep is the array form made
  resumable (``_sweep.RESUMABLE``, also in ``_sweep_array.py``), shared by every topology.

A hole is one statement, ``[targets =] hole.NAME(arguments)`` or ``return hole.NAME(...)``: a dialect
replaces the whole line with its own statements, at the line's indentation. The targets and arguments
say what the hole reads and binds in the template; :data:`HOLES` fixes them, and :func:`render` refuses
a template whose holes differ from it (so a hole cannot change meaning under the dialects' feet).
``if hole.NAME():`` opens a *section*: a dialect keeps its body (without the ``if``) or drops it.

The holes:

* ``d = hole.state(P_init)``: the dialect's state at the design's start, and ``d``, room for the
  driver's values at one parameter (6,);
* ``kf, kb = hole.restart(restart_at)``: the samples where the sweep resumes forward and backward (0: none);
* ``hole.resume(j)``: the state made the first pass's configuration ``restart_pos[j]``, at rest;
* ``hole.place(X)``: the driven vertex's trial position and tangent (and second derivative) from
  the driver's unit values ``X`` (a row of the driver table, or ``d``): centre + scale · X;
* ``code, blk, iters = hole.step(h, hp, checks, iters)``: every block placed at the trial driver
  position, a step of h after one of hp; checks: run the gap and move checks (the step is not at the
  smallest size). code: ``explorer.kinds._common``' OK (0), INFEASIBLE, SIGN, NOCONV or SUSPECT; blk: the failing
  block or −1; the Newton iterations are added to iters;
* ``hole.accept()``: the trial state made current, the previous tangent kept (the predictor's curvature);
* ``hole.keep_first()``: after sample 0, its configuration kept (the closing check, the backward
  sweep's start) and the previous tangent set to the current one; ``hole.restore_first()``: that
  configuration made current again;
* ``hole.store(sample)``: the requested rows written at sample ``sample``;
* ``gap = hole.closing_gap()``: the largest |Δx| + |Δy| between the state and the configuration at sample 0;
* ``hole.unreached(k)``: sample k's rows set to NaN;
* ``return hole.result(status, fail_t, fail_end, fail_block, iters)``: the design's outcome;
* ``hole.reenter()``: before the loop of moves, the sweep's own variables set (a dialect whose sweep
  leaves off at the loop of whole steps and is called again there restores them here);
* section ``whole_steps``: whole forward steps in a loop of their own, each accepted at its first try
  (the scalar form's fast path; the array form drops it: inlining the step twice there costs seconds
  of compile time). The first step that needs more leaves that loop untaken and is taken by the
  general loop, whole and then halved, so the results are the same bit for bit. Its own holes let a
  dialect keep the state differently in that loop: ``hole.fast_enter()`` and ``hole.fast_leave()``
  before and after it (the state loaded into the loop's form, and written back), and
  ``fast_place``, ``fast_step``, ``fast_accept``, ``fast_store``: ``place``, ``step``, ``accept``,
  ``store`` in that loop. (The generated kernels keep their state in scalars in this loop alone, and
  in arrays, through code shared by every topology, elsewhere: ``_codegen``.)

Constants and :func:`status_of` live here, beside the template that uses them (``_sweep``
re-exports them: the status codes are public).
"""

from __future__ import annotations

import ast
import functools
import inspect
import re
import textwrap

import numpy as np
from numba import njit

from ..kinds._common import INFEASIBLE, SIGN, SUSPECT
from ._drive import drive

# Per-variant status codes (public: they are stored in results files).
STATUS_OK = 0
STATUS_ASSEMBLY = 1
STATUS_BRANCH = 2
STATUS_NOCONV = 3
STATUS_INVALID = 4

REFINE_LEVELS = 16

# Steps accepted at the smallest size (with the gap and move checks off) allowed between two samples.
# Passing a fold tangentially takes a few thousand (the Hermite margin spans ~1e-3 of the parameter);
# past an eighth of the interval the design sits on a toggle over a stretch, and the sweep ends
# ("no-convergence") rather than crawl on at Δ / 2**REFINE_LEVELS.
MAX_FORCED = 2 ** (REFINE_LEVELS - 3)
# ... or, where more, the steps that span this fraction of the whole driver range: a fold passed
# tangentially stays within the Hermite margin over a stretch of the parameter that does not shrink
# with the sample spacing (seed 004's arm: 3.8 ms of its 10 s, an eighth of the spacing at 360 samples).
MAX_FORCED_SPAN = 1e-3


# Lengths outside this range are "invalid": their squares (the residuals are in squared lengths)
# would underflow to 0 or overflow to inf (NaN compares false, so NaN is invalid as well).
MIN_LENGTH = 1e-150
MAX_LENGTH = 1e150


@njit(cache=True)
def valid_lengths(L, scale):
    """True if every link length and the driver scale (crank radius) lie in [MIN_LENGTH, MAX_LENGTH]:
    finite, positive, and with squares that neither underflow nor overflow in double precision."""
    ok = MIN_LENGTH <= scale <= MAX_LENGTH
    for e in range(L.shape[0]):
        ok = ok and MIN_LENGTH <= L[e] <= MAX_LENGTH
    return ok


@njit(cache=True, nogil=True)
def invalid_design(outs, i):
    """Design i's outputs (``_inputs.Outputs``) as an invalid design's: NaN rows, status invalid, no
    failure block, no iterations. A kernel of its own, shared by every batch kernel: written out in each
    generated kernel it cost 0.5 CPU-s of its compile. (Loops: a slice assignment compiles for about
    a second more.)"""
    for r_ in range(outs.pos.shape[1]):
        for j_ in range(outs.pos.shape[2]):
            outs.pos[i, r_, j_, 0] = np.nan
            outs.pos[i, r_, j_, 1] = np.nan
    for r_ in range(outs.vel.shape[1]):
        for j_ in range(outs.vel.shape[2]):
            outs.vel[i, r_, j_, 0] = np.nan
            outs.vel[i, r_, j_, 1] = np.nan
    for r_ in range(outs.acc.shape[1]):
        for j_ in range(outs.acc.shape[2]):
            outs.acc[i, r_, j_, 0] = np.nan
            outs.acc[i, r_, j_, 1] = np.nan
    outs.status[i] = STATUS_INVALID
    outs.fail_t[i] = 0.0
    outs.fail_end[i] = np.nan
    outs.fail_block[i] = -1
    outs.iters[i] = 0


@njit(cache=True)
def status_of(code):
    """Map a step's trouble code to the per-variant status it ends a sweep with."""
    if code == INFEASIBLE:
        return STATUS_ASSEMBLY
    if code == SIGN:
        return STATUS_BRANCH
    return STATUS_NOCONV  # NOCONV, or a SUSPECT step that never resolved


class _Hole:
    """The marker of the template's holes; the template is rendered, never run."""

    def __getattr__(self, name):
        if name.startswith("__"):  # what introspection asks (hasattr, copy, inspect): an ordinary object's answer
            raise AttributeError(name)
        raise RuntimeError(f"hole.{name}: the sweep template is rendered (_sweep_template.render), not run")


hole = _Hole()
# What the batch template's forces section reads and its renderings bind: the forces' scratch (made by
# the ``batch_state`` hole) and the forces effect of one design (``_forces.design_forces_*``).
fs = None
design_forces = None


def sweep(ctx, topo, drv, opts, P_init, restart_at, restart_pos, signs, cx, cy, scale, shortest, tol, out_pos, out_vel,
          out_acc):
    """Solve one design at every sample of its driver, writing the requested rows.

    ctx: the step's context (a block table, or a ``GenericContext``); topo, drv, opts: the
    ``_inputs`` Topology, Drive and Options. The driver's S samples are t_k = k·t_end/S (closed: a
    crank, t_end = 2π) or k·t_end/(S−1) (open: a path from 0 to t_end). P_init (n_vertices, 2):
    start of the first Newton solve (the design assembled on the nominal's branch where the closed form
    can, ``_batch.setup``). restart_at (2,) int64, restart_pos (2 or 0, n_vertices, 2): where the
    vectorised first pass (``_vector``) left off, forward and backward (0: nowhere), and its
    configurations there (see below). signs (n_blocks,): the
    branch each block keeps. (cx, cy), scale: the design's crank centre and radius. shortest: its
    shortest dyad length; tol: Newton's stopping distance (model units).
    out_pos[k, j] = position of vertex topo.out_idx[j] at sample k, likewise out_vel (d/dparameter)
    and out_acc when asked; NaN where not reached. Returns (status, failure parameter or NaN, end of the
    unreachable range or NaN, failing block or −1, total Newton iterations).

    One loop makes every move, so the step is inlined (and compiled) once: phase 0 solves sample 0
    (a zero step from P_init, checks off), phase 1 steps forward, and phase 2, after a crank cycle
    fails, steps backward from θ = 0 to the other end of the reachable range.

    Resuming (method "auto"): where the first pass solved samples 0 … restart_at[0] exactly (closed-form
    roots that passed its every check, already in the outputs), the forward sweep resumes at sample
    restart_at[0] from restart_pos[0] (a zero move there, as at sample 0), and where it solved samples
    restart_at[1] … S−1 and the step back to θ = 2π, the backward sweep resumes at restart_at[1]
    from restart_pos[1]. Every failure is still found, located and reported by this sweep; should a
    resumed configuration not solve, the sweep goes the whole way from sample 0 instead.
    """
    d = hole.state(P_init)
    kf, kb = hole.restart(restart_at)
    kind = drv.kind
    prm = drv.prm
    T = drv.table
    t_end = drv.t_end
    closed = drv.closed
    S = T.shape[0]
    dt = t_end / S if closed else t_end / (S - 1)
    dmin = dt / 2.0 ** REFINE_LEVELS
    n_steps = S if closed else S - 1
    status = STATUS_OK
    fail_t = np.nan
    fail_end = np.nan
    fail_block = -1
    iters = 0
    reached = 0  # samples 0 .. reached-1 are solved going forward
    back = S  # samples back .. S-1 are solved going backward (crank cycles that fail)
    hp = 0.0  # the last step taken (the predictor's curvature term needs it)
    phase = 0
    k = 0
    kr = 0  # the sample a resume (phase 3) solves, and the phase it goes on in
    then = 1
    hole.reenter()
    while True:  # one move per pass, from parameter t0 to t1 (either direction)
        if phase == 0:
            t0 = 0.0
            t1 = 0.0
            row = 0
        elif phase == 3:
            t0 = kr * dt
            t1 = t0
            row = kr
        elif phase == 1:
            if hole.whole_steps():
                # The common case in a loop of its own: whole steps forward, each accepted at its first
                # try. The first step that needs more (refinement, or a failure) leaves it untaken and
                # is taken below, whole and then halved, as every other step is.
                hole.fast_enter()
                while k < n_steps:
                    h = (k + 1) * dt - k * dt
                    if not abs(h) > 1.5 * dmin:
                        break
                    checks = True
                    row = k + 1 if k + 1 < S else 0
                    hole.fast_place(T[row])
                    iters_before = iters
                    code, blk, iters = hole.fast_step(h, hp, checks, iters)
                    if code != 0:
                        iters = iters_before
                        break
                    hole.fast_accept()
                    hp = h
                    if k + 1 < S:
                        sample = k + 1
                        reached = k + 2
                        hole.fast_store(sample)
                    k += 1
                hole.fast_leave()
            if k >= n_steps:
                break
            # the last step of a crank cycle returns to θ = 2π, whose driver values are sample 0's
            t0 = k * dt
            t1 = (k + 1) * dt
            row = (k + 1) % S
        else:
            # the forward failure lies in (t[reached-1], t[reached]]: sweep back into that interval
            if k < reached - 1:
                break
            t0 = (k + 1) * dt
            t1 = k * dt
            row = k
        # the move: tried whole, halved where the step reports trouble, doubled again after success
        span = t1 - t0
        hs = span
        t = t0
        forced = 0
        max_forced = max(MAX_FORCED, int(MAX_FORCED_SPAN * t_end / dmin))
        while True:
            last = abs(hs) >= abs(t1 - t) - 0.5 * dmin
            h = t1 - t if last else hs
            if last:
                hole.place(T[row])
            else:
                drive(kind, prm, t + h, d)
                hole.place(d)
            checks = abs(h) > 1.5 * dmin
            code, blk, iters = hole.step(h, hp, checks, iters)
            if code == 0:
                if not checks:
                    forced += 1
                    if forced > max_forced:  # sitting on a toggle for a stretch: no trustworthy continuation
                        code = SUSPECT
                        break
                hole.accept()
                hp = h
                t += h
                if last:
                    break
                hs = 2.0 * hs if abs(2.0 * hs) <= abs(span) else span
            elif checks:
                hs = 0.5 * h
            else:
                break
        ok = code == 0
        tf = t + h  # where a failed move failed (t is the last parameter reached)
        sample = -1  # the sample this move reached, if it is to be stored
        if phase == 3:
            phase = then
            if not ok:  # the resumed configuration did not solve: the whole way from sample 0 instead
                hole.restore_first()
                hp = 0.0
                k = 0 if then == 1 else S - 1
                continue
            sample = kr
            if then == 1:
                k = kr
                reached = kr + 1
            else:
                k = kr - 1
                back = kr
            hole.store(sample)
            continue
        if not ok and phase < 2:
            status = status_of(code)
            fail_t = tf  # 0 when sample 0 itself fails
            fail_block = blk
            if phase == 0 or not closed:
                break
            # the other end of the reachable range: sweep clockwise from θ = 0
            hole.restore_first()
            hp = 0.0
            fail_end = fail_t
            phase = 2
            k = S - 1
            if kb > reached:  # resume the backward sweep where the first pass left off
                hole.resume(1)
                kr = kb
                then = 2
                phase = 3
            continue
        if phase == 0:
            hole.keep_first()
            sample = 0
            reached = 1
            phase = 1
        elif phase == 1:
            if k + 1 < S:
                sample = k + 1
                reached = k + 2
            k += 1
        else:
            if not ok:
                fail_end = tf
                break
            if k >= reached:
                sample = k
                back = k
            k -= 1
        if sample >= 0:
            hole.store(sample)
        if sample == 0 and kf > 0:  # resume the forward sweep where the first pass left off
            hole.resume(0)
            hp = 0.0
            kr = kf
            then = 1
            phase = 3
    if status == STATUS_OK and closed:
        gap = hole.closing_gap()
        if gap > max(1e-4 * shortest, 10.0 * tol):
            status = STATUS_BRANCH
            fail_t = t_end
    for k in range(reached, back):
        hole.unreached(k)
    return hole.result(status, fail_t, fail_end, fail_block, iters)


def batch(topo, drv, opts, signs, fmodel, designs, outs, frows):
    """Every design (row) of ``designs`` through the sweep, serially, writing ``outs`` in place (and,
    with forces, the forces effect of each design into ``frows``): the one per-design loop of every
    sweep kernel, rendered calling the sweep (the array form), or calling the resumable sweep and a
    topology's generated loop of whole steps by turns (``_sweep.batch_whole_dialect``).

    topo, drv, opts, designs, outs: the ``_inputs`` named tuples (``designs`` set up by
    ``_batch.setup``); signs (n_blocks,): the nominal's branch of each block; fmodel, frows: the
    forces effect's shared inputs and per-row inputs and outputs (``_forces.ForceModel`` and
    ``ForceRows``; without forces the kernel takes neither). The per-row arguments come last
    (``designs``, ``outs``, ``frows``), for ``_rows.parallel_rows``. A design with a length outside the valid range is
    "invalid", its rows NaN. With forces (section ``forces``) the sweep stores every vertex's
    position, tangent and second derivative in per-design scratch, the forces effect reads them
    there when the design is ok, and the requested rows (``fmodel.out_idx``) are copied out: a forces
    study holds no position array it does not store.
    """
    hole.batch_state()
    for i in range(designs.scale.shape[0]):
        L = designs.dist[i]
        scale = designs.scale[i]
        if not valid_lengths(L, scale):
            invalid_design(outs, i)
            continue
        cx = designs.center[i, 0]
        cy = designs.center[i, 1]
        shortest = designs.shortest[i]
        tol = designs.tol[i]
        if hole.plain():
            out_pos = outs.pos[i]
            out_vel = outs.vel[i]
            out_acc = outs.acc[i]
        if hole.forces():
            out_pos = fs.pos
            out_vel = fs.vel
            out_acc = fs.acc
        status, fail_t, fail_end, fail_block, iters = hole.sweep(i, shortest, tol, out_pos, out_vel, out_acc)
        if hole.forces():
            if status == STATUS_OK:
                design_forces(i, designs.table[i], topo, designs.uv[i], designs.slide[i], cx, cy, fmodel, frows, fs)
            # the requested rows of the scratch, as the plain sweep stores them
            oi = fmodel.out_idx
            for r_ in range(outs.pos.shape[1]):
                for j_ in range(oi.shape[0]):
                    v_ = oi[j_]
                    outs.pos[i, r_, j_, 0] = fs.pos[r_, v_, 0]
                    outs.pos[i, r_, j_, 1] = fs.pos[r_, v_, 1]
            for r_ in range(outs.vel.shape[1]):
                for j_ in range(oi.shape[0]):
                    v_ = oi[j_]
                    outs.vel[i, r_, j_, 0] = fs.vel[r_, v_, 0]
                    outs.vel[i, r_, j_, 1] = fs.vel[r_, v_, 1]
            for r_ in range(outs.acc.shape[1]):
                for j_ in range(oi.shape[0]):
                    v_ = oi[j_]
                    outs.acc[i, r_, j_, 0] = fs.acc[r_, v_, 0]
                    outs.acc[i, r_, j_, 1] = fs.acc[r_, v_, 1]
        outs.status[i] = status
        outs.fail_t[i] = fail_t
        outs.fail_end[i] = fail_end
        outs.fail_block[i] = fail_block
        outs.iters[i] = iters


#: The batch template's holes and sections (see :func:`batch`): ``batch_state`` (the kernel's
#: scratch, before the loop over designs), ``sweep`` (design i's sweep: calls, leaving its five
#: results in the names it binds); sections ``plain`` (the sweep writes the outputs)
#: and ``forces`` (it writes per-design scratch; the forces effect and the copy follow).
BATCH_HOLES = {
    "batch_state": ("", ""),
    "sweep": ("status, fail_t, fail_end, fail_block, iters", "i, shortest, tol, out_pos, out_vel, out_acc"),
}
BATCH_SECTIONS = ("plain", "forces")


#: Each hole: (what its statement binds or "return", its arguments), None where they may vary.
HOLES = {
    "state": ("d", "P_init"),
    "restart": ("kf, kb", "restart_at"),
    "resume": ("", None),
    "place": ("", None),
    "step": ("code, blk, iters", "h, hp, checks, iters"),
    "accept": ("", ""),
    "keep_first": ("", ""),
    "restore_first": ("", ""),
    "store": ("", "sample"),
    "closing_gap": ("gap", ""),
    "unreached": ("", "k"),
    "result": ("return", "status, fail_t, fail_end, fail_block, iters"),
    "reenter": ("", ""),
    "fast_enter": ("", ""),
    "fast_place": ("", None),
    "fast_step": ("code, blk, iters", "h, hp, checks, iters"),
    "fast_accept": ("", ""),
    "fast_store": ("", "sample"),
    "fast_leave": ("", ""),
}
#: Sections a dialect keeps or drops.
SECTIONS = ("whole_steps",)

_HOLE = re.compile(r"^(?P<ind> *)(?:(?P<ret>return )|(?P<lhs>[\w, ]+?) = )?hole\.(?P<name>\w+)\((?P<args>.*)\)$")
_SECTION = re.compile(r"^(?P<ind> *)if hole\.(?P<name>\w+)\(\):$")


@functools.lru_cache(maxsize=None)
def _template_of(fn) -> tuple[list[str], int]:
    """A template's source lines (def line and docstring included) and the index of its first
    statement after the docstring."""
    lines, _ = inspect.getsourcelines(fn)
    tree = ast.parse(textwrap.dedent("".join(lines))).body[0]
    return [ln.rstrip("\n") for ln in lines], tree.body[1].lineno - 1


def _template() -> tuple[list[str], int]:
    """The sweep template's lines (:func:`_template_of`)."""
    return _template_of(sweep)


def indexed(x: str, i: int) -> str:
    """Element i of the driver values ``x``: ``T[row, i]`` for a table row ``T[row]``, else ``x[i]``."""
    m = re.fullmatch(r"(\w+)\[(.+)\]", x)
    return f"{m.group(1)}[{m.group(2)}, {i}]" if m else f"{x}[{i}]"


def render(holes: dict, sections: dict, *, body_only: bool = False, indent: int = 0, template: str = "sweep",
           only: str | None = None) -> str:
    """The template with every hole filled: ``holes[name](args)`` gives a hole's lines (a list of
    str, indented relative to the hole; ``args`` the argument text), ``sections[name]`` whether a
    section's body is kept, or a function giving the lines that replace the whole section (indented
    relative to its ``if``). ``body_only``: the function's statements without its def line and
    docstring (for inlining into a kernel). ``only``: the body of that section alone (at indentation 0).
    Every line moves right by ``indent`` spaces. ``template``: "sweep" (:func:`sweep`, :data:`HOLES`,
    :data:`SECTIONS`) or "batch" (:func:`batch`, :data:`BATCH_HOLES`, :data:`BATCH_SECTIONS`)."""
    if template == "sweep":
        (lines, first), table, known = _template(), HOLES, SECTIONS
    else:
        (lines, first), table, known = _template_of(batch), BATCH_HOLES, BATCH_SECTIONS
    out: list[str] = []
    drop_below = None  # inside a dropped section: lines indented deeper than this
    dedent = []  # kept sections' indentation levels: their bodies move left by 4
    within = None  # with ``only``: that section's indentation while inside it
    for n, line in enumerate(lines):
        if body_only and n < first:
            continue
        ind = len(line) - len(line.lstrip(" "))
        if line.strip():
            if drop_below is not None:
                if ind > drop_below:
                    continue
                drop_below = None
            while dedent and ind <= dedent[-1]:
                dedent.pop()
            if within is not None and ind <= within:
                within = None
        elif drop_below is not None:
            continue
        m = _SECTION.match(line)
        if m:
            name = m.group("name")
            if name not in known:
                raise ValueError(f"{template} template: unknown section {name!r}")
            if only is not None:
                if name == only:
                    within = ind
                    continue
            elif callable(sections[name]):
                out += [" " * (ind + indent - 4 * len(dedent)) + ln if ln.strip() else "" for ln in sections[name]()]
                drop_below = ind
                continue
            if sections[name]:
                dedent.append(ind)
            else:
                drop_below = ind
            continue
        if only is not None:
            if within is None:
                continue
            ind -= within + 4  # the section's body at indentation 0
        shift = indent - 4 * len(dedent)
        m = _HOLE.match(line)
        if m:
            name = m.group("name")
            lhs = "return" if m.group("ret") else (m.group("lhs") or "")
            if name not in table or table[name][0] != lhs or table[name][1] not in (None, m.group("args")):
                raise ValueError(f"{template} template: hole {line.strip()!r} does not match HOLES[{name!r}]")
            pad = " " * (ind + shift)
            out += [pad + ln if ln.strip() else "" for ln in holes[name](m.group("args"))]
            continue
        if "hole." in line:
            raise ValueError(f"{template} template: a hole must be a statement of its own: {line.strip()!r}")
        out.append(" " * (ind + shift) + line.lstrip(" ") if line.strip() else "")
    return "\n".join(out) + "\n"
