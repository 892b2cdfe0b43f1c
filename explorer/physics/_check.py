"""``physics_check``: the physics check of a shortlist of a results file, stored as its ``physics`` metrics.

For each chosen design (the default ranking's top N, or given variants): its cycle is solved again
(every vertex, with velocities, as the study solved it), its walker scene becomes a MuJoCo model
(:func:`~explorer.physics._model.build_model`, in this process: milliseconds) and the models run in
worker processes (:func:`~explorer.physics._simulate.run_model`), a progress bar counting them. The
figures go into the results file as ``/metrics/physics_*`` (NaN for every design not checked), through
a renamed copy (:func:`~explorer.store.update_metrics`): at the end, every :data:`CHECKPOINT_S`
seconds of a long run, and on Ctrl-C or SIGTERM, so a design checked is never lost to an interrupt
(a kill -9 loses the designs since the last checkpoint, never the file).

Each physics dataset carries the attribute ``physics`` (JSON): the settings (pitch, turns, settle,
timestep, foot radius, friction, servo, the loaded-foot threshold, the impact window), the MuJoCo
version, the legs, the body's mass, and ``checked``: {variant: "ok" or "failed: why"}. A file holds the
figures of one set of settings: checking with others replaces them only with ``force``.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

import numpy as np

from ..errors import UserError, signals_held
from ._model import Settings, build_model
from ._simulate import PHYSICS_METRICS, PhysicsFailure, run_model

#: Seconds between two writes of the designs checked so far (each a copy of the file renamed over it).
CHECKPOINT_S = 60.0
#: Designs checked by default: the default ranking's top five.
DEFAULT_TOP = 5
#: The settings a stored figure depends on (compared with a new check's; the MuJoCo version is recorded only).
PITCHES = ("held", "free")
MAX_TURNS = 100


def _text(s) -> str:
    return s.decode() if isinstance(s, bytes) else str(s)


def stored_physics(res) -> dict | None:
    """The ``physics`` attribute of a results file's physics metrics (``res`` an open
    :class:`~explorer.store.Results`), parsed; None when the file holds none."""
    g = res.file.get("metrics")
    if g is None or "physics_travel" not in g or "physics" not in g["physics_travel"].attrs:
        return None
    try:
        return json.loads(_text(g["physics_travel"].attrs["physics"]))
    except (TypeError, ValueError):
        return None


def describe_settings(s: dict) -> str:
    """"pitch held, 3 turns after 0.5 settling" from a stored settings dict."""
    return f"pitch {s.get('pitch')}, {s.get('turns')} turns after {s.get('settle'):g} settling"


def check_arguments(pitch, turns, workers, top, variants) -> tuple[str, int, int | None]:
    if pitch not in PITCHES:
        raise UserError(f"--pitch: expected one of {', '.join(PITCHES)}, got {pitch!r}")
    if isinstance(turns, bool) or not isinstance(turns, (int, np.integer)) or not 1 <= turns <= MAX_TURNS:
        raise UserError(f"--turns: expected a whole number of crank turns from 1 to {MAX_TURNS}, got {turns!r}")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, (int, np.integer))
                                or not 1 <= workers <= 1024):
        raise UserError(f"--workers: expected a whole number of processes from 1 to 1024, got {workers!r}")
    if top is not None and variants:
        raise UserError("--top and --variant: give one of them (the default ranking's top N, or the variants)")
    if top is not None and (isinstance(top, bool) or not isinstance(top, (int, np.integer)) or top < 1):
        raise UserError(f"--top: expected a whole number of designs >= 1, got {top!r}")
    return pitch, int(turns), (None if workers is None else int(workers))


def _walker(res):
    from ..mechanism import walker_from_dict
    return walker_from_dict(res.study.get("walker") or {}, f"{res.filename} (its study)", "walker",
                            base=res.mechanism.walker)


def _refuse(res) -> None:
    """One line for a results file whose mechanism the physics check cannot model."""
    from ..gait import available_metrics
    mech, p = res.mechanism, res.filename
    if mech.crank is None:
        raise UserError(f"{p}: mechanism {mech.name!r} is driven along a path, not by a crank: it has no walker "
                        f"for the physics check to run")
    why = available_metrics(mech)["travel"]
    if why is not None:
        raise UserError(f"{p}: the physics check needs a foot that lifts and steps: {why}")
    if mech.sliders:
        names = ", ".join(s.name for s in mech.sliders)
        raise UserError(f"{p}: mechanism {mech.name!r} has sliders ({names}): the physics check models pin joints "
                        f"and rigid members only")


def _operating(res):
    """The operating point, with what the physics check needs (one line naming the key otherwise)."""
    op = res.operating
    src = _text(res.attrs.get("study_source", res.filename))
    if op is None or op.unit is None or op.rpm is None:
        key = "unit" if op is None or op.unit is None else "rpm"
        raise UserError(f"{res.filename}: the physics check needs the study's [operating] {key} (its study {src} "
                        f"gives none): metres per model unit, the crank's rpm and the body's mass (load, kg); add "
                        f"them to the study's [operating] table and run it again")
    if not op.load > 0:
        raise UserError(f"{res.filename}: the physics check needs the body's mass: [operating] load (kg) > 0 in "
                        f"the study {src}, got {op.load!r}")
    if not op.gravity > 0:
        raise UserError(f"{res.filename}: the physics check needs gravity: [operating] gravity > 0 in the study "
                        f"{src}, got {op.gravity!r} (a walker with no weight does not walk)")
    return op


def _worker_init():  # a worker ignores Ctrl-C: the parent stops it (and keeps what is done)
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _job(job):
    """Run one model in a worker: (variant, metrics dict or None, failure text or None)."""
    v, model, samples, kin = job
    try:
        out = run_model(model, samples, kin)
        out.pop("series", None)
        out["massless"] = model.massless
        return v, out, None
    except PhysicsFailure as exc:
        return v, None, str(exc)
    except Exception as exc:  # noqa: BLE001 - MuJoCo refusing a model: that design fails, the others go on
        return v, None, f"MuJoCo: {' '.join(str(exc).split())[:200]}"


def physics_check(path, variants=None, top: int | None = None, pitch: str = "held", turns: int = 3,
                  workers: int | None = None, progress: bool = False, force: bool = False,
                  settings: Settings | None = None, write: bool = True, on_result=None,
                  where: str | None = None) -> dict:
    """The physics check of a shortlist of the results file ``path`` (a complete file of a crank-driven
    walker with an ``[operating]`` table giving ``unit``, ``rpm`` and ``load``, the body's mass).

    variants : the variants to check (ints), or None for the default ranking's ``top`` (default 5).
    pitch : "held" (the body slides only) or "free" (it may pitch about the crank centre).
    turns : whole crank turns measured after half a turn of settling.
    workers : processes (default: the CPUs this process may use, at most one per design; 1 runs here).
    force : replace physics figures stored with other settings (else a UserError says so).
    settings : a :class:`~explorer.physics.Settings` for everything else (``pitch`` and ``turns`` win).
    write : store the figures in the file (False: only return them).
    on_result : called with (variant, metrics dict or None, failure or None) as each design finishes.
    where : a filter of the ranked designs (``explorer rank --where``'s language, e.g. "bob < 0.2"): the
        default ranking's ``top`` of the designs it keeps. Not with ``variants``.

    Returns a dict: ``path``; ``settings`` (dict); ``mujoco`` (version); ``legs``; ``checked``
    {variant: {metric: value, "cpu_s": s}}; ``failed`` {variant: why}; ``skipped`` [(variant, why)] (not
    simulated: a failed variant, a cycle that does not solve); ``order`` (the variants as chosen);
    ``how`` (the selection, in words); ``wall_s``; ``cpu_s`` (the simulations' CPU-s); ``written``.
    A KeyboardInterrupt (Ctrl-C, SIGTERM) keeps the designs already checked: they are written, then it
    is raised again, its message saying what was kept."""
    from .._extras import require
    from ..store import OutputLock, check_updatable, update_metrics
    from ..study import open_results  # with explorer's re-solver (store only reads files)

    mujoco = require("mujoco", "explorer physics")
    pitch, turns, workers = check_arguments(pitch, turns, workers, top, variants)
    if where is not None and variants:
        raise UserError("--where and --variant: give one of them (--where filters the default ranking's top N)")
    t0 = time.perf_counter()
    base = settings or Settings()
    st = Settings(**{**base.__dict__, "pitch": pitch, "turns": turns})
    p = check_updatable(path) if write else path
    lock = OutputLock(p).acquire() if write else None
    checked, failed = {}, {}
    state = {"written": False, "last": time.perf_counter(), "jobs": 0}
    try:
        with open_results(p) as res:
            prep = _prepare(res, variants, top, st, where)
        jobs = prep["jobs"]
        state["jobs"] = len(jobs)
        new = st.as_dict()
        prior = prep["prior"]
        old_settings = (prior or {}).get("settings")
        replace = old_settings is not None and old_settings != new
        if replace and not force and write:
            n_old = len(prior.get("checked") or {})
            raise UserError(f"{p}: holds the physics figures of {n_old} design{'s' if n_old != 1 else ''} "
                            f"checked with {describe_settings(old_settings)}; pass --force to replace them with "
                            f"{describe_settings(new)} (those designs become NaN: not checked)")
        keep = {} if replace or prior is None else dict(prior.get("checked") or {})
        op, walker = prep["operating"], prep["walker"]
        info = {"settings": new, "mujoco": mujoco.__version__, "legs": walker.legs,
                "mirrored": list(walker.mirrored), "body_mass": float(op.load), "rpm": float(op.rpm),
                "description": "explorer physics: each design's walker scene as a planar MuJoCo model, measured over "
                               "whole turns (explorer.physics); checked: {variant: 'ok' or 'failed: why'}"}

        def commit():
            if not write:
                return
            rows = sorted(set(checked) | set(failed))
            values = {m: [checked[v][m] if v in checked else math.nan for v in rows] for m in PHYSICS_METRICS}
            marks = {**keep, **{str(v): "ok" for v in checked}, **{str(v): f"failed: {failed[v]}" for v in failed}}
            attrs = {m: {"physics": json.dumps({**info, "checked": marks}), "units": _unit(m)}
                     for m in PHYSICS_METRICS}
            update_metrics(p, rows, values, attrs, clear=PHYSICS_METRICS if replace else ())
            state["written"] = True
            state["last"] = time.perf_counter()

        def take(v, out, why):
            if out is not None:
                checked[v] = out
            else:
                failed[v] = why
            if on_result is not None:
                on_result(v, out, why)
            if write and time.perf_counter() - state["last"] > CHECKPOINT_S:
                commit()

        try:
            _run_jobs(jobs, workers, take, progress)
        except KeyboardInterrupt:
            with signals_held():  # a second Ctrl-C must not cut this write
                if checked or failed:
                    commit()
            raise
        if checked or failed or replace:
            commit()
    except KeyboardInterrupt as exc:
        word = "terminated" if type(exc).__name__ == "Terminated" else "interrupted"
        done = len(checked) + len(failed)
        if not done:
            raise type(exc)(f"{p}: {word} before any design was checked; the file is as it was") from None
        raise type(exc)(f"{p}: {word}: kept the physics figures of {done} design{'s' if done != 1 else ''} checked "
                        f"({state['jobs'] - done} not checked: run `explorer physics` again for them)") from None
    finally:
        if lock is not None:
            lock.release()
    return {"path": p, "settings": new, "mujoco": mujoco.__version__, "legs": walker.legs, "checked": checked,
            "failed": failed, "skipped": prep["skipped"], "order": prep["chosen"], "how": prep["how"],
            "wall_s": time.perf_counter() - t0, "cpu_s": sum(o["cpu_s"] for o in checked.values()),
            "written": state["written"], "operating": op}


def _prepare(res, variants, top, st: Settings, where: str | None = None) -> dict:
    """The designs to check and their models: ``jobs`` [(variant, Model, samples, kinematic travel m/turn)],
    ``skipped`` [(variant, why)], ``chosen``, ``how`` (in words), ``prior`` (the stored physics attribute),
    ``operating``, ``walker``. One line (UserError) for a file the check cannot model."""
    from ..kernels import simulate
    _refuse(res)
    op = _operating(res)
    walker = _walker(res)
    if variants:
        chosen = list(dict.fromkeys(res.check_variant(v) for v in variants))
        how = f"variant{'s' if len(chosen) > 1 else ''} {', '.join(map(str, chosen))}"
    else:
        k = DEFAULT_TOP if top is None else int(top)
        chosen = [int(v) for v in res.rank(top=k, where=where, columns=["variant"])["variant"]]  # in blocks of rows
        how = (f"the default ranking's top {k}" + (f" where {where}" if where is not None else "")
               + (f" ({len(chosen)} ranked)" if len(chosen) < k else ""))
    df = res.frame_rows(chosen)  # the chosen rows alone (indexed by variant)
    solver = res.study.get("study", {})
    jobs, skipped = [], []
    for v in chosen:
        status = str(df.at[v, "status"])
        if status != "ok":
            skipped.append((v, f"failed ({status})" if status != "not-run" else "not run"))
            continue
        try:
            mech_v = res.variant_mechanism(v)
            cyc = simulate(mech_v, res.steps, velocities=True, tolerance=float(solver.get("tolerance", 1e-11)),
                           method=str(solver.get("method", "block")))
            if not cyc.ok:
                raise UserError(f"its cycle does not solve again ({cyc.failure.message if cyc.failure else 'failed'})")
            model = build_model(mech_v, cyc.positions, cyc.velocities, walker, op, st)
        except UserError as exc:
            skipped.append((v, str(exc)))
            continue
        kin = float(df.at[v, "travel"]) * float(op.unit) if "travel" in df.columns else math.nan
        jobs.append((v, model, res.steps, kin if math.isfinite(kin) else None))
    return {"jobs": jobs, "skipped": skipped, "chosen": chosen, "how": how, "prior": stored_physics(res),
            "operating": op, "walker": walker}


def _run_jobs(jobs, workers, take, progress: bool) -> None:
    """Run the jobs (here for one worker, else in a pool of worker processes), calling ``take`` with each
    result as it comes; a KeyboardInterrupt stops the workers at once (what ``take`` got is kept)."""
    bar = None
    if progress and jobs and hasattr(sys.stderr, "isatty") and sys.stderr.isatty():
        from tqdm import tqdm
        bar = tqdm(total=len(jobs), unit="design", desc="physics", file=sys.stderr, leave=False)
    pool = None
    try:
        n_workers = max(1, min(workers if workers is not None else _cpus(), len(jobs)))
        if n_workers == 1:
            for job in jobs:
                take(*_job(job))
                if bar is not None:
                    bar.update(1)
            return
        import multiprocessing as mp
        ctx = mp.get_context("forkserver")  # workers forked from a clean server (no threads, no Numba state)
        ctx.set_forkserver_preload(["mujoco", "explorer.physics._simulate"])
        # a Ctrl-C while the pool starts its workers (seconds on a loaded machine: the forkserver preloads
        # MuJoCo) is held until the pool is made, then stops it below: raised inside the constructor, it left
        # a worker being started, which then found the pool's semaphores gone (the command unlinks them as
        # it exits) and printed a traceback after the command's one line
        with signals_held():
            pool = ctx.Pool(n_workers, initializer=_worker_init)
        for got in pool.imap_unordered(_job, jobs):
            take(*got)
            if bar is not None:
                bar.update(1)
        pool.close()
        pool.join()
        pool = None
    finally:
        if pool is not None:  # an interrupt or an error: stop the workers now, not after their designs
            pool.terminate()
            pool.join()
        if bar is not None:
            bar.close()


def _unit(name: str) -> str:
    from ..gait import metric
    return metric(name).unit


def _cpus() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1
