"""Continuation over the driver's parameter with branch tracking and adaptive refinement: the array form.

The sweep is written once, as a template (``_sweep_template``); this module holds its *array form*:
the dialect (:data:`ARRAY`) that fills the template's holes with state in (n_vertices, 2) arrays and
a call of a global ``step``, and the rendering, committed as ``_sweep_array.py`` (rewrite it with
``python -c "from explorer.kernels import _sweep; _sweep.write_array_module()"`` after editing the
template or the dialect; tests/test_sweep_template.py fails while they differ). :func:`_specialise`
binds ``step`` to the fast step (plans without coupled blocks) or to the generic block / dense step and jits each copy
under its own name, so each compiles (and caches) only the step it calls, and calls it directly.
(Passing the step as an argument instead disables caching; dispatching through ``@overload``
measured 2x slower.) The kernels generated per topology (``_codegen``) render the same template in
their scalar dialect.

Each step between samples is tried whole. If the step function reports trouble (a branch sign
change, no convergence, an assembly failure, a possible gap between samples, or a move too large
for the local geometry) the step is retried in halves, down to Δ / 2**REFINE_LEVELS. What still
fails at that size is real: the sweep ends there, with the block and the parameter value.

A crank is periodic: after the last sample one more step returns to θ = 2π, and a cycle that does
not close on its start configuration is a branch failure. When a crank cycle fails going forward,
a second sweep runs backward from θ = 0 (clockwise) to find where the reachable range ends on the
other side; samples in between stay NaN (seed 004 leaves unreachable angles empty). A path driver
(time from 0 to T) simply ends at its first failure.
"""

import types
from pathlib import Path

import numpy as np
from numba import njit

from ._kinds_array import fast_step
from ._step import generic_step
from ._sweep_array import sweep, sweep_resumable
from ._sweep_template import (MAX_FORCED, MAX_FORCED_SPAN, REFINE_LEVELS, STATUS_ASSEMBLY, STATUS_BRANCH,
                              STATUS_INVALID, STATUS_NOCONV, STATUS_OK, indexed, render, status_of)

__all__ = ["MAX_FORCED", "MAX_FORCED_SPAN", "REFINE_LEVELS", "STATUS_ASSEMBLY", "STATUS_BRANCH", "STATUS_INVALID",
           "STATUS_NOCONV", "STATUS_OK", "status_of", "sweep", "fast_sweep", "generic_sweep"]


def _place(x):
    """The driven vertex from the driver's unit values x (P1, V1 and A1 from x[0:2], x[2:4], x[4:6])."""
    return [f"P1[tip, 0] = cx + scale * {indexed(x, 0)}",
            f"P1[tip, 1] = cy + scale * {indexed(x, 1)}",
            f"V1[tip, 0] = scale * {indexed(x, 2)}",
            f"V1[tip, 1] = scale * {indexed(x, 3)}",
            f"A1[tip, 0] = scale * {indexed(x, 4)}",
            f"A1[tip, 1] = scale * {indexed(x, 5)}"]


# The names both array forms' state binds first (the topology's and options' fields the holes read).
_NAMES = ["tip = topo.tip", "moving = topo.moving", "out_idx = topo.out_idx", "maxit = opts.maxit",
          "want_vel = opts.want_vel", "want_acc = opts.want_acc", "nv = P_init.shape[0]"]

#: The array form's holes (see ``_sweep_template``). State: P0, V0, A0 the current configuration, Vp
#: the tangent before V0, P1, V1, A1 the trial one, *_first the configuration at sample 0; each step
#: and copy written as a loop (a slice assignment compiles a shape-mismatch error message, seconds of
#: compile time for nothing; rebinding arrays costs atomic reference counting in the hot loop).
ARRAY = {
    "state": lambda args: _NAMES + [
        "P0 = P_init.copy()",
        "P1 = P_init.copy()",
        "V0 = np.zeros((nv, 2))",
        "V1 = np.zeros((nv, 2))",
        "Vp = np.zeros((nv, 2))",
        "A0 = np.zeros((nv, 2))",
        "A1 = np.zeros((nv, 2))",
        "P_first = np.empty((nv, 2))",
        "V_first = np.empty((nv, 2))",
        "A_first = np.empty((nv, 2))",
        "d = np.empty(6)"],
    "restart": lambda args: [f"kf = {args}[0]", f"kb = {args}[1]"],
    "resume": lambda j: [
        "for m in range(moving.shape[0]):",
        "    v = moving[m]",
        "    for ax in range(2):",
        f"        P0[v, ax] = restart_pos[{j}, v, ax]",
        "        V0[v, ax] = 0.0",
        "        Vp[v, ax] = 0.0",
        "        A0[v, ax] = 0.0"],
    "place": _place,
    "step": lambda args: [
        "code, blk, it = step(ctx, signs, P0, V0, Vp, P1, V1, A1, h, hp, tol, maxit, want_acc, checks)",
        "iters += it"],
    "accept": lambda args: [
        "for m in range(moving.shape[0]):",
        "    v = moving[m]",
        "    for ax in range(2):",
        "        Vp[v, ax] = V0[v, ax]",
        "        V0[v, ax] = V1[v, ax]",
        "        P0[v, ax] = P1[v, ax]",
        "        if want_acc:",
        "            A0[v, ax] = A1[v, ax]"],
    "keep_first": lambda args: [
        "for v in range(nv):",
        "    for ax in range(2):",
        "        Vp[v, ax] = V0[v, ax]",
        "        P_first[v, ax] = P0[v, ax]",
        "        V_first[v, ax] = V0[v, ax]",
        "        A_first[v, ax] = A0[v, ax]"],
    "restore_first": lambda args: [
        "for v in range(nv):",
        "    for ax in range(2):",
        "        P0[v, ax] = P_first[v, ax]",
        "        V0[v, ax] = V_first[v, ax]",
        "        Vp[v, ax] = V_first[v, ax]",
        "        A0[v, ax] = A_first[v, ax]"],
    "store": lambda sample: [
        "for j in range(out_idx.shape[0]):",
        "    v = out_idx[j]",
        "    for ax in range(2):",
        f"        out_pos[{sample}, j, ax] = P0[v, ax]",
        "        if want_vel:",
        f"            out_vel[{sample}, j, ax] = V0[v, ax]",
        "        if want_acc:",
        f"            out_acc[{sample}, j, ax] = A0[v, ax]"],
    "closing_gap": lambda args: [
        "gap = 0.0",
        "for v in range(nv):",
        "    gap = max(gap, abs(P0[v, 0] - P_first[v, 0]) + abs(P0[v, 1] - P_first[v, 1]))"],
    "unreached": lambda k: [
        "for j in range(out_idx.shape[0]):",
        "    for ax in range(2):",
        f"        out_pos[{k}, j, ax] = np.nan",
        "        if want_vel:",
        f"            out_vel[{k}, j, ax] = np.nan",
        "        if want_acc:",
        f"            out_acc[{k}, j, ax] = np.nan"],
    "result": lambda args: [f"return {args}"],
    "reenter": lambda args: [],
}
# the loop of whole steps' own holes: the same state (never rendered here: the section is dropped)
ARRAY |= {"fast_enter": lambda args: [], "fast_place": ARRAY["place"], "fast_step": ARRAY["step"],
          "fast_accept": ARRAY["accept"], "fast_store": ARRAY["store"], "fast_leave": lambda args: []}
#: The array form drops the loop of whole steps: inlining the step at a second call site costs
#: seconds of compile time, and the general loop takes those steps the same way.
ARRAY_SECTIONS = {"whole_steps": False}

# The resumable form's int64 and float64 slots (``si``, ``sf``): si[0] says whether a call is a design's
# first (0) or follows the loop of whole steps (1); then the sweep's own variables that live across
# that loop, and the loop's other inputs.
_SAVED = {"si": ("status", "fail_block", "iters", "reached", "back", "phase", "k", "kr", "then", "n_steps", "S"),
          "sf": ("hp", "fail_t", "fail_end", "dt", "dmin")}
_SLOT = {name: (arr, j + (arr == "si")) for arr, names in _SAVED.items() for j, name in enumerate(names)}
#: The slots' sizes: si, sf (the caller makes them, :func:`sweep_scratch`)
SLOTS = (len(_SAVED["si"]) + 1, len(_SAVED["sf"]))
#: (array, slot, name) of what the caller's loop of whole steps reads, the first four also what it writes back
RESUME_SLOTS = tuple((*_SLOT[n], n) for n in ("iters", "reached", "k", "hp", "n_steps", "S", "dt", "dmin"))
# restored on a call after the loop (n_steps, S, dt and dmin the sweep computes again, the same)
_RESTORED = [n for n in _SLOT if n not in ("n_steps", "S", "dt", "dmin")]


@njit(cache=True, nogil=True)
def sweep_scratch(nv):
    """The resumable sweep's scratch, made once per batch (a shared kernel: np.empty's implementations
    would compile again in every caller): room for the driver's values at one parameter, d (6,); the
    state, each (nv, 2): the current configuration P0, V0, A0, the tangent before V0 Vp, the trial one
    P1, V1, A1, the configuration at sample 0 P_first, V_first, A_first; the saved variables si, sf
    (:data:`SLOTS`: int64, float64)."""
    return (np.empty(6), np.empty((nv, 2)), np.empty((nv, 2)), np.empty((nv, 2)), np.empty((nv, 2)), np.empty((nv, 2)),
            np.empty((nv, 2)), np.empty((nv, 2)), np.empty((nv, 2)), np.empty((nv, 2)), np.empty((nv, 2)),
            np.zeros(SLOTS[0], dtype=np.int64), np.zeros(SLOTS[1]))


def _save(flag: int) -> list[str]:
    return [f"si[0] = {flag}"] + [f"{arr}[{j}] = {n}" for n, (arr, j) in _SLOT.items()]


#: The resumable array form (``sweep_resumable``): the array form, its state made by the caller, which
#: takes the loop of whole steps itself: where the template enters that loop, this form saves its
#: variables in ``si``, ``sf`` and returns (1, ...); called again (si[0] == 1) it restores them and
#: goes on after the loop. Its other returns are (0, the five results). A generated kernel
#: (``_codegen``) calls it, compiled once for every topology, and writes only the loop of whole steps
#: itself, in scalars.
RESUMABLE = dict(ARRAY) | {
    "state": lambda args: _NAMES + [
        "resumed = si[0] != 0",
        "if not resumed:",
        "    for v in range(nv):",
        "        for ax in range(2):",
        "            P0[v, ax] = P_init[v, ax]",
        "            P1[v, ax] = P_init[v, ax]",
        "            V0[v, ax] = 0.0",
        "            V1[v, ax] = 0.0",
        "            Vp[v, ax] = 0.0",
        "            A0[v, ax] = 0.0",
        "            A1[v, ax] = 0.0"],
    "reenter": lambda args: ["if resumed:"] + [f"    {n} = {_SLOT[n][0]}[{_SLOT[n][1]}]" for n in _RESTORED],
    "result": lambda args: [f"return 0, {args}"],
}
RESUMABLE_SECTIONS = {"whole_steps": lambda: [
    "if resumed:  # the caller has just taken the whole steps",
    "    resumed = False",
    "else:",
    *("    " + ln for ln in _save(1)),
    "    return 1, status, fail_t, fail_end, fail_block, iters"]}
_RESUMABLE_DEF = ("def sweep_resumable(ctx, topo, drv, opts, P_init, restart_at, restart_pos, signs, cx, cy, scale, "
                  "shortest, tol,\n                    out_pos, out_vel, out_acc, P0, V0, Vp, A0, P1, V1, A1, P_first, "
                  "V_first, A_first, d, si, sf):\n    \"\"\"The sweep (:func:`sweep`, the same arguments first) that "
                  "leaves the loop of whole steps to its caller\n    (``_sweep.RESUMABLE``); the state in the "
                  "arrays after ``out_acc`` (each (n_vertices, 2)), d (6,), si\n    (SLOTS[0],) int64, sf (SLOTS[1],) float64. "
                  "Returns (1, ...) where the caller takes the whole steps, else (0,\n    status, fail_t, fail_end, "
                  "fail_block, iters).\n    \"\"\"\n")

_ARRAY_MODULE = Path(__file__).with_name("_sweep_array.py")
_ARRAY_HEADER = '''"""The sweep's array form: rendered from ``_sweep_template`` by ``_sweep.array_module_source``; do not edit.

Edit the template (``_sweep_template.sweep``) or the array dialect (``_sweep.ARRAY``), then rewrite
this file: ``python -c "from explorer.kernels import _sweep; _sweep.write_array_module()"``
(tests/test_sweep_template.py fails while it differs from a fresh rendering). ``_sweep._specialise``
jits copies of :func:`sweep` with the global ``step`` bound to a step function.
"""

import numpy as np

from explorer.kinds._common import SUSPECT
from ._drive import drive
from ._sweep_template import MAX_FORCED, MAX_FORCED_SPAN, REFINE_LEVELS, STATUS_BRANCH, STATUS_OK, status_of

# The step function the sweep calls; _sweep._specialise binds it in each jitted copy.
step = None


'''


def array_module_source() -> str:
    """The text of ``_sweep_array.py``: the template rendered in the array dialect, and in its
    resumable form (:data:`RESUMABLE`)."""
    return (_ARRAY_HEADER + render(ARRAY, ARRAY_SECTIONS) + "\n\n" + _RESUMABLE_DEF
            + render(RESUMABLE, RESUMABLE_SECTIONS, body_only=True))


def write_array_module() -> Path:
    """Rewrite ``_sweep_array.py`` and ``_batch_array.py`` from the templates (after editing them or the
    array dialects)."""
    _ARRAY_MODULE.write_text(array_module_source(), encoding="utf-8")
    _BATCH_MODULE.write_text(batch_module_source(), encoding="utf-8")
    return _ARRAY_MODULE


#: The batch template's array form (``_sweep_template.batch``): the sweep called through the global
#: ``run_sweep`` on the context ``make_context`` gives (both bound by ``_batch``), the generic
#: context's known vertices and, with forces, the forces' scratch made once per call.
def batch_array_dialect(forces: bool) -> dict:
    state = ["nf_ = topo.fixed.shape[0]",
             "known = np.empty(nf_ + 1 + topo.explicit.shape[0], dtype=np.int64)",
             "known[0] = topo.tip",
             "for f_ in range(nf_):",
             "    known[f_ + 1] = topo.fixed[f_]",
             "for f_ in range(topo.explicit.shape[0]):  # an explicit block's vertex: its first column",
             "    known[nf_ + 1 + f_] = topo.blk[topo.explicit[f_], 0]"]
    if forces:
        state.append("fs = force_scratch(drv.table.shape[0], designs.start.shape[1], fmodel, topo)")
    return {
        "batch_state": lambda args: state,
        "sweep": lambda args: [
            "status, fail_t, fail_end, fail_block, iters = run_sweep(",
            "    make_context(opts, topo, designs, i, known), topo, drv, opts, designs.start[i], designs.restart_at[i],",
            "    designs.restart_pos[i], signs, cx, cy, scale, shortest, tol, out_pos, out_vel, out_acc)"],
    }


#: The batch template's form around a topology's generated loop of whole steps (``_codegen``): each
#: design's sweep the resumable array form (the global ``run_resumable``), called until it is done, the
#: loop of whole steps (``whole``, a first-class function argument: this batch loop is compiled once
#: for every topology, the loop once per topology) taken between its calls.
def batch_whole_dialect(forces: bool) -> dict:
    state = ["maxit = opts.maxit",
             "T = drv.table",
             "d, P0, V0, Vp, A0, P1, V1, A1, P_first, V_first, A_first, si, sf = sweep_scratch(designs.start.shape[1])"]
    if forces:
        state.append("fs = force_scratch(drv.table.shape[0], designs.start.shape[1], fmodel, topo)")
    return {
        "batch_state": lambda args: state,
        "sweep": lambda args: [
            "tab = designs.table[i]",
            "si[0] = 0",
            "while True:",
            "    more, status, fail_t, fail_end, fail_block, iters = run_resumable(",
            "        tab, topo, drv, opts, designs.start[i], designs.restart_at[i], designs.restart_pos[i], signs, cx, cy,",
            "        scale, shortest, tol, out_pos, out_vel, out_acc, P0, V0, Vp, A0, P1, V1, A1, P_first, V_first, A_first,",
            "        d, si, sf)",
            "    if more == 0:",
            "        break",
            "    whole(T, designs.start[i], tab, signs, cx, cy, scale, tol, maxit, out_pos, out_vel, out_acc, P0, V0, Vp,",
            "          A0, si, sf)"],
    }


_BATCH_MODULE = Path(__file__).with_name("_batch_array.py")
_BATCH_HEADER = '''"""The batch loop's array form: rendered from ``_sweep_template.batch`` by ``_sweep.batch_module_source``; do not edit.

Edit the template (``_sweep_template.batch``) or the dialect (``_sweep.batch_array_dialect``), then
rewrite this file: ``python -c "from explorer.kernels import _sweep; _sweep.write_array_module()"``
(tests/test_sweep_template.py fails while it differs from a fresh rendering). ``_batch`` jits copies
of :func:`batch_plain` and :func:`batch_forces` with the globals ``run_sweep``, ``make_context`` and
``design_forces`` bound.
"""

import numpy as np

from ._forces import force_scratch
from ._sweep import sweep_scratch
from ._sweep_template import STATUS_OK, invalid_design, valid_lengths

# Bound in each jitted copy (``_batch``): the sweep, the step's context of design i, the forces effect,
# the resumable sweep.
run_sweep = None
make_context = None
design_forces = None
run_resumable = None
'''


def batch_module_source() -> str:
    """The text of ``_batch_array.py``: the batch template rendered in the array dialect, without and
    with forces, and around a generated loop of whole steps (:func:`batch_whole_dialect`)."""
    out = _BATCH_HEADER
    for dialect, name, extra in ((batch_array_dialect, "batch", ""), (batch_whole_dialect, "batch_whole", ", whole")):
        for forces in (False, True):
            src = render(dialect(forces), {"plain": not forces, "forces": forces}, template="batch")
            args = "topo, drv, opts, signs, fmodel, designs, outs, frows" if forces else "topo, drv, opts, signs, designs, outs"
            src = src.replace("def batch(topo, drv, opts, signs, fmodel, designs, outs, frows):",
                              f"def {name}_{'forces' if forces else 'plain'}({args}{extra}):", 1)
            out += "\n\n" + src
    return out


def _specialise(step_fn, name: str, fn=sweep):
    """Jit a copy of :func:`sweep` (or ``fn``) whose global ``step`` is ``step_fn``, inlined at the sweep's one call
    site, where it runs millions of times. (Inlining through an intermediate inlined function, as an
    earlier version did, made Numba copy the step's IR twice: seconds of compile time.)"""
    env = dict(fn.__globals__, step=step_fn)
    copy = types.FunctionType(fn.__code__, env, fn.__name__, fn.__defaults__, fn.__closure__)
    copy.__qualname__ = f"sweep_{name}"
    copy.__doc__ = fn.__doc__
    return njit(cache=True, nogil=True)(copy) if fn is not sweep else njit(cache=True)(copy)


#: :func:`sweep` with the fast step (no coupled blocks); its context is the design's block table (``_batch.setup``).
fast_sweep = _specialise(fast_step, "fast")
#: :func:`sweep` with the generic block / dense step; its context comes from ``_step.generic_context``.
generic_sweep = _specialise(generic_step, "generic")
#: :func:`sweep_resumable` with the fast step: what the generated kernels call (``_codegen``).
fast_sweep_resumable = _specialise(fast_step, "fast_resumable", sweep_resumable)
