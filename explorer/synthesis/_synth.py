"""``explorer synth``: from target points to designs, by the curve atlas and a polish.

1. **Look-up** (:meth:`explorer.synthesis._atlas.Atlas.query`): the atlas designs whose paths best match
   the target, each moved onto it by the best similarity transform (position, rotation, scale).
2. **Polish**: the ``starts`` best of them advanced together by the batched bounded
   Levenberg–Marquardt (:func:`explorer.synthesis.batched_lm`) over every design parameter the atlas
   varies *and* its gauge (the crank centre and the first ground pivot: where the design stands, how
   it is turned and how big it is), on the real kinematics (``simulate_batch``, ``steps`` crank steps,
   the path between samples by cubic Hermite interpolation); the best distinct answers finished by
   scipy's least squares (:func:`explorer.synthesis.polish`). The residuals are those of a study's polish:
   untimed, each target point's crank angle is a variable (the literature's untimed formulation,
   "closest" matching); timed, the foot at each point's crank angle (explorer's crank angle in the
   target's frame: counter-clockwise from +x), or with a free phase the angles plus one shared shift.
   The constraints a synthesis sees are the mechanism's: a design must turn a full cycle (one that does
   not gets a huge residual, so the step is refused).
3. **Results file**: the ``top`` best distinct designs, best first, written as a one-generation
   optimisation of the atlas's mechanism (``[optimize]`` over the polished parameters, ``[target]`` the
   points): ``explorer rank``, ``show``, ``plot``, ``animate``, ``export`` read it like any results
   file. Its root attribute ``synthesis`` (JSON) records the atlas, the look-up and the timings.

With ``mechanism = "any"`` each family's atlas is queried and polished, and the file holds the designs
of the family whose best design matches best (the others' bests are in the summary).
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UserError
from ._atlas import (DEFAULT_DESIGNS, DISTINCT, FAMILIES, _designs, atlas_mechanism, build_atlas, default_path, diverse,
                     family_source, open_atlas)

#: Designs a synthesis writes by default, and look-up candidates it polishes.
TOP = 10
STARTS = 256
#: The polish: every start SCOUT_ITERATIONS batched Levenberg–Marquardt iterations on the path at
#: SCOUT_STEPS crank steps, the KEEP best distinct answers LM_ITERATIONS more at ``steps`` (then again
#: from their points matched in order), then the finish (explorer.synthesis._polish.finish).
SCOUT_ITERATIONS = 12
KEEP = 8
LM_ITERATIONS = 100
SCOUT_STEPS = 90
#: Look-up candidates ranked before the polish's starts are picked (distinct ones, :func:`diverse`).
POOL = 512


@dataclass
class SynthSummary:
    """What :func:`synthesize` did. path : the results file; family; error : the best design's RMS
    distance to the target points (model units; ``path_error``); size : the target's RMS radius about
    its centroid (model units) and ``relative`` = error / size; designs : the written designs' path_error,
    best first; timings (seconds: ``open``, ``query``, ``polish``, ``write``) and ``cpu_s``; atlas :
    the atlas file; others : {family: best error} of the families not written (``any``)."""

    path: Path
    family: str
    error: float
    size: float
    designs: list
    timings: dict
    cpu_s: float
    atlas: Path
    built: bool = False
    others: dict = field(default_factory=dict)
    candidates: int = 0

    @property
    def relative(self) -> float:
        return self.error / self.size if self.size > 0 else math.nan

    def text(self) -> str:
        t = self.timings
        lines = [f"synth {self.family}: best path_error {self.error:.6g} (RMS distance to the {self.points} target points; "
                 f"{self.relative:.3g} of the target's size {self.size:.6g}) → {self.path}",
                 f"  {len(self.designs)} designs, path_error " + ", ".join(f"{e:.4g}" for e in self.designs[:10]),
                 f"  atlas {self.atlas}{' (built now)' if self.built else ''}: look-up {t.get('query', 0):.2f} s "
                 f"(open {t.get('open', 0):.2f} s), polish {t.get('polish', 0):.2f} s of {self.candidates} candidates, "
                 f"write {t.get('write', 0):.2f} s; {self.cpu_s:.1f} CPU-s in all"]
        for fam, e in self.others.items():
            lines.append(f"  {fam}: best path_error {e:.6g} (not written)")
        lines.append(f"  shown by: explorer rank {self.path} --by path_error ; explorer show {self.path} --variant 0 ; "
                     f"explorer plot {self.path} --top 3 --by path_error -o synth.png")
        return "\n".join(lines)

    points: int = 0
    __str__ = text


def read_target(path, *, timed: bool):
    """(points (M, 2), angles (M,) radians or None) from a CSV with columns x, y[, angle_deg]. With
    ``timed`` the angle column is required; without, it is not used. UserError (one line) for a bad
    file (explorer.gait.load_target's checks: NaN, a missing column, ...)."""
    from ..gait import load_target
    t = load_target({"csv": str(path)}, source=str(path), key="target")
    if timed and t.angles is None:
        raise UserError(f"{path}: --timed needs an angle_deg column (the crank angle of each point, degrees)")
    return np.array(t.points), (np.array(t.angles) if timed else None)


def _check_count(source, family, points, n_params, timed, free_phase):
    M = len(points)
    if timed:
        unknowns = n_params + int(free_phase)
        if 2 * M < unknowns:
            raise UserError(f"{source}: {M} timed points give {2 * M} equations for the {unknowns} unknowns of a "
                            f"{family} ({n_params} design parameters{' and the phase' if free_phase else ''}); give at "
                            f"least {math.ceil(unknowns / 2)} points")
    elif M < n_params:
        raise UserError(f"{source}: {M} points for a {family} with {n_params} design parameters: an untimed target "
                        f"needs at least {n_params} points (each point's crank angle is one more unknown)")


def _size(points) -> float:
    c = points - points.mean(axis=0)
    return float(np.sqrt(np.mean(np.sum(c * c, axis=1))))


def _get_atlas(family, atlas, build, designs, progress, echo):
    """(opened atlas, built now?)."""
    if atlas is not None:
        return open_atlas(atlas, family=family), False
    path = default_path(family)
    built = False
    if not path.exists():
        if not build:
            raise UserError(f"{path}: no atlas of {family!r} (build it: explorer atlas build {family}; or drop --no-build "
                            f"to build it now)")
        if echo:
            echo(f"building the {family} atlas ({designs:,} designs) in {path.parent} ...")
        build_atlas(family, designs, progress=progress)
        built = True
    return open_atlas(path, family=family), built


def self_kind(mech, p):
    return mech.parameter_kind(p)


class _Posed:
    """A synthesis problem on one atlas: the polished parameters, their bounds, the batch solve and
    the residuals."""

    def __init__(self, atlas, points, angles, free_phase, steps, cands=()):
        from ..kernels import simulate_batch
        from ._polish import PathResiduals
        self.atlas, self.mech = atlas, atlas.mech
        self.names = atlas.spec.synth
        # bounds wide enough never to hold an answer, and no wider: the polish's finite-difference
        # steps are 1e-8 of their span (explorer.synthesis._polish)
        size = max(_size(points), 1e-300)
        self.size = size
        c = points.mean(axis=0)
        reach = max(size, max(abs(v) for cd in cands for p, v in cd.params.items()
                              if self_kind(atlas.mech, p) == "length") if cands else size)
        lo, hi = [], []
        for p in self.names:
            if self.mech.parameter_kind(p) == "length":
                lo.append(1e-3 * min([cd.params[p] for cd in cands] + [size]))
                hi.append(20.0 * reach)
            else:
                ctr = c[0] if p.endswith(".x") else c[1]
                lo.append(ctr - 20.0 * reach)
                hi.append(ctr + 20.0 * reach)
        self.lower, self.upper = np.array(lo), np.array(hi)
        mech = self.mech

        def simulate(X):
            lengths, crank, geometry = _designs(mech, self.names, X)
            b = simulate_batch(mech, lengths, crank, steps, geometry=geometry, vertices=[mech.foot], velocities=True)
            return b.paths[mech.foot], b.velocities[mech.foot], b.status == 0

        def simulate_coarse(X):
            lengths, crank, geometry = _designs(mech, self.names, X)
            b = simulate_batch(mech, lengths, crank, SCOUT_STEPS, geometry=geometry, vertices=[mech.foot],
                               velocities=True)
            return b.paths[mech.foot], b.velocities[mech.foot], b.status == 0

        match = "timed" if angles is not None else "closest"
        kw = dict(match=match, angles=angles, phase="free" if free_phase else "fixed")
        self.res = PathResiduals(simulate, points, **kw)
        self.scout = PathResiduals(simulate_coarse, points, **kw)

    def x(self, params: dict) -> np.ndarray:
        return np.clip(np.array([params[p] for p in self.names]), self.lower, self.upper)


def _polish(posed, cands, starts, finish):
    """Polished designs (X (n, k), cost (n,)), best first, from the candidates."""
    from ._polish import finish as finish_best
    from ._polish import scout_and_polish
    cands = list(cands[:starts])
    S0 = np.array([posed.x(c.params) for c in cands])
    if len(S0) == 0:
        return np.empty((0, len(posed.names))), np.empty(0)
    lm = scout_and_polish(posed.res, S0, posed.lower, posed.upper, coarse=posed.scout, keep=KEEP,
                          scout_iterations=SCOUT_ITERATIONS, iterations=LM_ITERATIONS)
    Xf, ff, _ = finish_best(posed.res, lm, posed.lower, posed.upper, finish)
    Xs, fs = [lm.X, Xf], [lm.cost, ff]
    Xs, fs = np.vstack(Xs), np.concatenate(fs)
    order = np.argsort(np.where(np.isfinite(fs), fs, np.inf), kind="stable")
    Xs, fs = Xs[order], fs[order]
    keep = np.isfinite(fs)
    return Xs[keep], fs[keep]


def synthesize(target, *, mechanism: str = "fourbar", timed: bool = False, closed: bool = False,
               free_phase: bool = False, output=None, force: bool = False, top: int = TOP, starts: int = STARTS,
               atlas=None, build: bool = True, designs: int = DEFAULT_DESIGNS, progress: bool = True,
               name: str | None = None, steps: int = 360, scan: int | None = None, echo=None) -> SynthSummary:
    """Synthesise designs whose foot passes through target points (the module docstring).

    target : a CSV file (columns x, y and, with ``timed``, angle_deg) or an array (M, 2) (with
    ``timed``: (M, 3), the third column degrees). mechanism : a family of :data:`FAMILIES` or "any".
    closed : the points are a closed curve (the index look-up) rather than a stretch of path.
    free_phase : timed angles known up to a common shift. output : the results file (default
    ``results/synth-<family>.h5``), overwritten only with ``force``. top : designs written. starts :
    look-up candidates polished. atlas : an atlas file (default: the family's cached one, built with
    ``designs`` designs on first use unless ``build`` is false). scan : designs the open and timed
    look-ups scan (default 200,000, the atlas's first). echo : a callable for progress lines (the CLI's print).

    Returns a :class:`SynthSummary`; UserError (one line) for a bad target, too few points, a missing
    atlas with ``build = False``, an atlas of another family or version, an existing output.
    """
    t_all, c_all = time.perf_counter(), time.process_time()
    if mechanism != "any" and mechanism not in FAMILIES:
        raise UserError(f"--mechanism: expected one of {', '.join(FAMILIES)} or any, got {mechanism!r}")
    if isinstance(top, bool) or not isinstance(top, int) or not 1 <= top <= 1000:
        raise UserError(f"--top: expected a whole number from 1 to 1,000, got {top!r}")
    if isinstance(starts, bool) or not isinstance(starts, int) or not 1 <= starts <= 10000:
        raise UserError(f"--starts: expected a whole number from 1 to 10,000, got {starts!r}")
    if free_phase and not timed:
        raise UserError("--free-phase applies to a timed target (--timed)")
    source = str(target) if not isinstance(target, np.ndarray) else "<target>"
    if isinstance(target, np.ndarray):
        arr = np.asarray(target, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] != (3 if timed else 2) or not np.all(np.isfinite(arr)):
            raise UserError(f"target: expected finite points (M, {3 if timed else 2}), got shape {arr.shape}")
        points, angles = arr[:, :2].copy(), (np.radians(arr[:, 2]) if timed else None)
    else:
        points, angles = read_target(target, timed=timed)
    families = list(FAMILIES) if mechanism == "any" else [mechanism]
    for fam in families:
        mech, _ = atlas_mechanism(fam)
        from ._atlas import atlas_spec
        _check_count(source, fam, points, len(atlas_spec(mech, fam).synth), timed, free_phase)
    if len(points) < 2 or not _size(points) > 0:
        raise UserError(f"{source}: the target's points must not all coincide")
    if closed and angles is None and np.allclose(points[0], points[-1]):
        points = points[:-1]  # a closed curve drawn back to its first point: that point once
    label = mechanism if mechanism != "any" else "any"
    out = Path(output) if output is not None else Path("results") / f"synth-{label}.h5"
    if out.exists() and not force:
        raise UserError(f"{out}: results file exists; pass --force to overwrite it")
    timings = {"open": 0.0, "query": 0.0, "polish": 0.0}
    best = None
    others = {}
    built_any = False
    n_cand = 0
    for fam in families:
        t0 = time.perf_counter()
        at, built = _get_atlas(fam, atlas if mechanism != "any" else None, build, designs, progress, echo)
        built_any |= built
        t1 = time.perf_counter()
        pool = at.query(points, angles, closed=closed, free_phase=free_phase, k=max(POOL, starts), scan=scan)
        cands = diverse(at, pool, starts, distinct=DISTINCT)
        t2 = time.perf_counter()
        posed = _Posed(at, points, angles, free_phase, steps, cands)
        X, cost = _polish(posed, cands, starts, finish=min(2, top))
        t3 = time.perf_counter()
        timings["open"] += t1 - t0
        timings["query"] += t2 - t1
        timings["polish"] += t3 - t2
        n_cand += len(cands)
        err = math.sqrt(cost[0] / len(points)) if len(cost) else math.inf
        if best is None or err < best[0]:
            if best is not None:
                others[best[1]] = best[0]
            best = (err, fam, at, posed, X, cost)
        else:
            others[fam] = err
    err, fam, at, posed, X, cost = best
    if len(X) == 0:
        raise UserError(f"{source}: no atlas design of {fam!r} could be fitted to the target (every candidate fails to "
                        f"turn a full cycle)")
    from ._polish import distinct_best
    pick = distinct_best(X, cost, posed.lower, posed.upper, top, distinct=1e-7)
    X = X[pick]
    t3 = time.perf_counter()
    path = _write(out, force, at, posed, X, points, angles, free_phase, steps, name or f"synth-{fam}",
                  {"atlas": str(at.path), "family": fam, "atlas_designs": len(at), "closed": bool(closed),
                   "timed": bool(timed), "free_phase": bool(free_phase), "candidates": n_cand,
                   "rows": [], "timings": timings})
    timings["write"] = time.perf_counter() - t3
    from ..study import open_results  # with explorer's re-solver (store only reads files)
    with open_results(path) as r:
        df = r.frame()
        pe = df.loc[df["status"].astype(str) != "not-run", "path_error"].to_numpy(dtype=np.float64)
    s = SynthSummary(path, fam, float(pe[0]), _size(points), [float(v) for v in pe], timings,
                     time.process_time() - c_all, at.path, built_any, others, n_cand)
    s.points = len(points)
    s.timings["total"] = time.perf_counter() - t_all
    return s


def _write(out, force, at, posed, X, points, angles, free_phase, steps, name, info) -> Path:
    """The results file of designs X (n, k) (a one-generation optimisation, see the module docstring)."""
    from ..errors import signals_held
    from ..store import OutputLock
    from ..study import load_study
    from ..study.runner import design_solver, designs_from_x, optimize_writer
    mech_file = family_source(at.family) if at.family in FAMILIES else None
    tmp_mech = None
    if mech_file is None:
        tmp_mech = Path(str(out) + ".mechanism.toml")
        tmp_mech.parent.mkdir(parents=True, exist_ok=True)
        tmp_mech.write_text(at.attrs["mechanism"], encoding="utf-8")
        mech_file = str(tmp_mech)
    names = posed.names
    span = np.abs(X).max(axis=0) + _size(points)
    bounds = {}
    for j, p in enumerate(names):
        if at.mech.parameter_kind(p) == "length":
            bounds[p] = [float(X[:, j].min()) / 10.0, float(X[:, j].max()) * 10.0]
        else:
            bounds[p] = [float(X[:, j].min() - 10 * span[j]), float(X[:, j].max() + 10 * span[j])]
    tgt = {"points": points.tolist(), "match": "timed" if angles is not None else "closest",
           "closed": bool(info.get("closed"))}
    if angles is not None:
        tgt["angles_deg"] = np.degrees(angles).tolist()
        if free_phase:
            tgt["phase"] = "free"
    data = {"study": {"name": name, "mechanism": mech_file, "steps": int(steps)},
            "scene": {"metrics": ["path_error"], "velocities": True},
            "target": tgt,
            "optimize": {"algorithm": "de", "population": max(4, len(X)), "generations": 1,
                         "objectives": ["path_error"], "polish": False, "screen": False, "bounds": bounds},
            "output": {"path": str(out)}}
    try:
        study = load_study(data, source=f"explorer synth ({info['family']})")
        out.parent.mkdir(parents=True, exist_ok=True)
        with OutputLock(out):
            if out.exists():
                if not force:
                    raise UserError(f"{out}: results file exists; pass --force to overwrite it")
            writer = optimize_writer(out, study)
            try:
                lengths, crank, geometry = designs_from_x(study, X)
                batch, metrics = design_solver(study)(lengths, crank, geometry)
                with signals_held():
                    writer.write_chunk(0, lengths, crank, batch, metrics, geometry=geometry, partial=True)
                    writer.f.attrs["synthesis"] = json.dumps(info)
                writer.finish()
            finally:
                with signals_held():
                    writer.close()
    finally:
        if tmp_mech is not None:
            tmp_mech.unlink(missing_ok=True)
    return out
