"""The forces effect's base leg generated per topology: loads, multipliers and member forces in scalars.

The table-driven base leg (``_forces._base_leg``) walks the plan's blocks and equations through index
arrays at every sample, with the loads, multipliers and incidence forces in arrays. For a plan whose
kinds have a scalar form with reactions (``SCALAR["reactions"]`` in the kind's module, ``explorer.kinds``:
dyads and rigid-body joints) this module writes the same computation out for one topology and one set
of members (``_forces.ForceModel``'s incidences), as the sweep's generated code does:

* every vertex's position (``X3``, ``Y3``) and acceleration (``AX3``, ``AY3``, m/s²) at a sample, every
  load (``R0_3x``: right-hand side 0 at vertex 3), multiplier (``lam0_4``: distance equation 4) and
  incidence force (``F0_12x``) is a local scalar;
* each block's Jacobian (columns, inverse) is taken once per sample in plan order with its singularity
  check (its kind's ``forces_geometry`` snippet), and its multipliers for each right-hand side in reverse
  plan order (``reactions``); each equation's pull on its member's pins is its equation type's
  ``PULL_SCALAR`` (``explorer.kinds.eq_distance``, ``eq_attach``);
* right-hand side 0 (inertia and weight) is written out with its loads; the others (loads that do not
  change with the sample, ``fs.Rc`` and ``fs.Fc``) share one loop over the right-hand sides.

The arithmetic is the table-driven base leg's, operation for operation and in the same order, so its
results are the same bit for bit (tests/test_forces_scalar.py); it is only faster. The generated
function has the table-driven one's signature and is bound into the forces effect of one design by
``_forces.design_forces_with``; ``_codegen`` writes it into the generated forces kernel's module.
"""

from __future__ import annotations

import hashlib

from ..kinds import KINDS, eq_attach, eq_distance


def scalar_forces(topo) -> bool:
    """Whether the base leg of ``topo`` (``_inputs.Topology``) can be generated: every kind has a scalar
    form with reactions, and the plan has no slide equations."""
    return (topo.kind.shape[0] > 0 and topo.slide.shape[0] == 0
            and all(KINDS[int(k)].SCALAR is not None and "reactions" in KINDS[int(k)].SCALAR for k in topo.kind))


def force_key(fm) -> tuple:
    """What the generated base leg depends on besides the topology: the members' incidences of
    ``fm`` (``_forces.ForceModel``)."""
    return tuple(a.tobytes() for a in (fm.inc_vertex, fm.dinc, fm.ainc, fm.body_pq, fm.body_inc, fm.fixed,
                                       fm.fixed_inc)) + (int(fm.tip_inc), int(fm.foot), int(fm.foot_inc))


def _blocks(topo) -> list[tuple]:
    """(kind module, {column name: value, "k": block, "v": its vertex}) of each block in plan order."""
    out = []
    for k in range(topo.kind.shape[0]):
        mod = KINDS[int(topo.kind[k])]
        names = {c: int(topo.blk[k, j]) for j, c in enumerate(mod.COLUMNS)}
        out.append((mod, dict(names, k=k, v=names["vertex"])))
    return out


def _lines(snippet: str, **names) -> list[str]:
    return snippet.format(**names).splitlines()


def _indent(lines: list[str], n: int) -> list[str]:
    return [" " * n + ln if ln.strip() else "" for ln in lines]


def base_leg_source(topo, fm) -> tuple[str, str]:
    """(name, source) of the generated base leg for ``topo`` and the members of ``fm``
    (``_forces.ForceModel``): a Numba function with ``_forces._base_leg``'s signature and results."""
    blocks = _blocks(topo)
    dist_a = [int(v) for v in topo.dist_a]
    dist_b = [int(v) for v in topo.dist_b]
    att = [tuple(int(x) for x in row) for row in topo.att_vpq]
    nb = fm.body_pq.shape[0]
    nl = len(dist_a) - nb
    K = fm.inc_vertex.shape[0]
    dinc = [tuple(int(x) for x in row) for row in fm.dinc]
    ainc = [tuple(int(x) for x in row) for row in fm.ainc]
    tip = int(topo.tip)
    tip_inc = int(fm.tip_inc)
    fixed = [(int(v), int(c)) for v, c in zip(fm.fixed, fm.fixed_inc)]
    # every vertex the code reads or loads (for a forces kernel, out_idx is every vertex)
    nv = 1 + max(int(topo.tip), int(fm.foot), *(int(v) for v in topo.out_idx), *(int(v) for v in fm.inc_vertex),
                 *dist_a, *dist_b, *(x for row in att for x in row))
    # the multipliers each block sets (an equation no block sets keeps 0, as the table-driven scratch does)
    set_d, set_a = set(), set()
    for mod, names in blocks:
        if "eq_a" in names:
            set_d |= {names["eq_a"], names["eq_b"]}
        elif "eq" in names and mod.NAME == "ATTACH":
            set_a.add(names["eq"])

    def solve(r: str) -> list[str]:
        """Right-hand side r's multipliers (reverse plan order), pulls, tip and frame, and its stores."""
        out = []
        for mod, names in reversed(blocks):
            out += _lines(mod.SCALAR["reactions"], r=r, **names)
        for e in range(len(dist_a)):
            if e not in set_d:
                out.append(f"lam{r}_{e} = 0.0")
        for t in range(len(att)):
            if t not in set_a:
                out += [f"lamx{r}_{t} = 0.0", f"lamy{r}_{t} = 0.0"]
        # every row's pull on its member's pins, equation by equation
        for e in range(len(dist_a)):
            out += _lines(eq_distance.PULL_SCALAR, r=r, e=e, a=dist_a[e], b=dist_b[e], ia=dinc[e][0], ib=dinc[e][1])
        for t in range(len(att)):
            out += _lines(eq_attach.PULL_SCALAR, r=r, t=t, ij=ainc[t][0], ip=ainc[t][1], iq=ainc[t][2])
        # the crank's force on the tip, the motor torque, the frame's force
        out += [f"F{r}_{tip_inc}x += R{r}_{tip}x", f"F{r}_{tip_inc}y += R{r}_{tip}y",
                f"bx = R{r}_{tip}x", f"by = R{r}_{tip}y", f"t_ = (tx * R{r}_{tip}y - ty * R{r}_{tip}x) * unit"]
        if r == "0":
            out += ["t_ += mc * gravity * tx * unit * 0.5",
                    "bx += -mc * omega * omega * unit * tx * 0.5",
                    "by += -mc * omega * omega * unit * ty * 0.5 + mc * gravity"]
        else:  # the crank's share of a unit body acceleration along x, then y
            out += ["if moving and r == 1:", "    t_ -= mc * ty * unit * 0.5", "    bx += mc",
                    "elif moving and r == 2:", "    t_ += mc * tx * unit * 0.5", "    by += mc"]
        out += [f"tau[u, {r}] = t_", "frx = -bx", "fry = -by"]
        for v, c in fixed:
            out += [f"F{r}_{c}x += R{r}_{v}x", f"F{r}_{c}y += R{r}_{v}y", f"frx -= R{r}_{v}x", f"fry -= R{r}_{v}y"]
        out += [f"frame[u, {r}, 0] = frx", f"frame[u, {r}, 1] = fry"]
        for kk in range(K):
            out += [f"Fu[{r}, {kk}, 0] = F{r}_{kk}x", f"Fu[{r}, {kk}, 1] = F{r}_{kk}y"]
        return out

    # right-hand side 0: inertia and weight, loads from the accelerations
    rhs0 = [f"R0_{v}{c} = 0.0" for v in range(nv) for c in "xy"] + [f"F0_{kk}{c} = 0.0" for kk in range(K) for c in "xy"]
    acc_v = sorted({*dist_a[:nl], *dist_b[:nl], *(int(v) for row in fm.body_pq for v in row)})
    rhs0 += [f"AX{v} = A[u, {v}, 0] * s2\nAY{v} = A[u, {v}, 1] * s2" for v in acc_v]
    for e in range(nl):
        a, b = dist_a[e], dist_b[e]
        ia, ib = dinc[e]
        rhs0 += [f"if lm_{e} > 0.0:",
                 f"    da = m6_{e} * (2.0 * AX{a} + AX{b})", f"    db = m6_{e} * (AX{a} + 2.0 * AX{b})",
                 f"    R0_{a}x += da", f"    R0_{b}x += db", f"    F0_{ia}x -= da", f"    F0_{ib}x -= db",
                 f"    da = m6_{e} * (2.0 * AY{a} + AY{b}) + lg_{e}", f"    db = m6_{e} * (AY{a} + 2.0 * AY{b}) + lg_{e}",
                 f"    R0_{a}y += da", f"    R0_{b}y += db", f"    F0_{ia}y -= da", f"    F0_{ib}y -= db"]
    for bi in range(nb):
        p, q = (int(x) for x in fm.body_pq[bi])
        ip, iq = (int(x) for x in fm.body_inc[bi])
        rhs0 += [f"if mb_{bi} > 0.0 or Jb_{bi} > 0.0:",
                 f"    apx = AX{p}", f"    apy = AY{p}", f"    agx = AX{q} - apx", f"    agy = AY{q} - apy",
                 f"    aGx = apx + ub_{bi} * agx - wb_{bi} * agy", f"    aGy = apy + ub_{bi} * agy + wb_{bi} * agx",
                 f"    fqx = mb_{bi} * (ub_{bi} * apx + wb_{bi} * apy) + Jb_{bi} * agx",
                 f"    fqy = mb_{bi} * (-wb_{bi} * apx + ub_{bi} * apy) + Jb_{bi} * agy",
                 f"    fpx = mb_{bi} * aGx - fqx", f"    fpy = mb_{bi} * aGy - fqy",
                 f"    dqx = fqx + mb_{bi} * gravity * wb_{bi}", f"    dqy = fqy + mb_{bi} * gravity * ub_{bi}",
                 f"    dpx = fpx - mb_{bi} * gravity * wb_{bi}", f"    dpy = fpy + mb_{bi} * gravity * (1.0 - ub_{bi})",
                 f"    R0_{p}x += dpx", f"    R0_{p}y += dpy", f"    R0_{q}x += dqx", f"    R0_{q}y += dqy",
                 f"    F0_{ip}x -= dpx", f"    F0_{ip}y -= dpy", f"    F0_{iq}x -= dqx", f"    F0_{iq}y -= dqy"]
    rhs0 += solve("0")
    # right-hand sides 1 …: loads that do not change with the sample
    rhsr = [f"Rr_{v}x = Rc[r, {v}, 0]\nRr_{v}y = Rc[r, {v}, 1]" for v in range(nv)]
    rhsr += [f"Fr_{kk}x = Fc[r, {kk}, 0]\nFr_{kk}y = Fc[r, {kk}, 1]" for kk in range(K)]
    rhsr += solve("r")

    per_design = []
    for e in range(nl):
        per_design += [f"lm_{e} = fr.link_mass[i, {e}]", f"m6_{e} = fs.link6[{e}]", f"lg_{e} = fs.linkg[{e}]"]
    for bi in range(nb):
        per_design += [f"mb_{bi} = fm.body_mass[{bi}]", f"Jb_{bi} = fr.body_J[i, {bi}]",
                       f"ub_{bi} = fr.body_cuv[i, {bi}, 0]", f"wb_{bi} = fr.body_cuv[i, {bi}, 1]"]
    for t in range(len(att)):
        per_design += [f"ut_{t} = uv[{t}, 0]", f"wt_{t} = uv[{t}, 1]"]
    for mod, names in blocks:
        per_design += _lines(mod.SCALAR["forces_init"], **names)
    geometry = [f"X{v} = pos[u, {v}, 0]\nY{v} = pos[u, {v}, 1]" for v in range(nv)]
    geometry += ["tx = X{0} - cx".format(tip), "ty = Y{0} - cy".format(tip)]
    for mod, names in blocks:
        geometry += _lines(mod.SCALAR["forces_geometry"], **names)
    body = [
        "pos = fs.pos", "A = fs.acc", "Fi = fs.Fi", "tau = fs.tau", "frame = fs.frame", "act = fs.act",
        "Rc = fs.Rc", "Fc = fs.Fc", "nr = act.shape[0]", "S = pos.shape[0]", "moving = fm.moving",
        "gravity = fm.gravity", "unit = fm.unit", "omega = fm.omega", "s2 = unit * omega * omega",
        "mc = fr.crank_mass[i]", "tol = SINGULAR_TOL", *per_design,
        "for u in range(S):",
        *_indent("\n".join(geometry).splitlines(), 4),
        "    Fu = Fi[u]",
        "    copy21 = active(u, Fu, fs, nrhs, moving, Fx, weightless)",
        "    if act[0]:  # inertia and weight",
        *_indent("\n".join(rhs0).splitlines(), 8),
        "    for r in range(1, nr):  # the loads that do not change with the sample",
        "        if act[r]:",
        *_indent("\n".join(rhsr).splitlines(), 12),
        "    if copy21:",
        "        copy_21(u, Fu, fs)",
        "return -1, -1",
    ]
    text = "\n".join(_indent(body, 4))
    name = "base_leg_" + hashlib.sha1(text.encode()).hexdigest()[:16]
    head = [
        "@njit(cache=True, nogil=True)",
        "def base_leg(i, table, topo, uv, sd, cx, cy, fm, fr, fs, nrhs, Fx, weightless):",
        '    """The base leg of design i at every sample, generated for one topology (``_forces_scalar``):',
        "    ``_forces._base_leg``'s results. Returns (block, sample) of the first singular Jacobian, or",
        '    (-1, -1)."""',
    ]
    return name, "\n".join(head) + "\n" + text + "\n"
