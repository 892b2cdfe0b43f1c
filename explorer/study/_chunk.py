"""The one chunk runner: what every way of running a study (``run_study``, Dask shards, an optimiser)
does with a range of variants — sample them, solve them, compute the metrics the scene asks for."""

from __future__ import annotations

import time

from ..kernels import simulate_batch
from ..kernels import check_dense
from ._sample import study_sampler, study_variants
from ._spec import Study, metric_plan, series_solve  # noqa: F401 (their home is the spec)
from ._yield import YIELD, design_yield


def wants_yield(study: Study) -> bool:
    """Whether the study computes ``yield``: it has a ``[robustness]`` table and its scene asks for
    every metric or names ``yield`` (an optimisation naming it adds it to the scene's metrics)."""
    if study.robustness is None or study.metrics is False:
        return False
    return study.metrics is True or YIELD in study.metrics


def geometry_columns(study: Study, geometry) -> dict | None:
    """{coordinate parameter name: (n,) column} of a chunk's geometry (n, g), None when the study
    moves no coordinate (then the kernels and metrics use the nominal's, as before)."""
    names = study.geometry_names
    if not names or geometry is None:
        return None
    return {name: geometry[:, j] for j, name in enumerate(names)}


def compute_study_metrics(study: Study, paths, velocities, status, lengths, crank, geometry=None) -> dict | None:
    """The scene's metrics of one chunk (None if the scene asks for none): foot paths and velocities
    (n, S, 2), status (n,), lengths (n, n_links), crank (n,), geometry (n, g) in
    ``study.geometry_names`` order (or None: the nominal's pivots)."""
    names, _, want = metric_plan(study)
    if not want:
        return None
    from ..gait import compute_metrics
    return compute_metrics(paths, velocities, status, names, study.band, mechanism=study.mech, lengths=lengths,
                           crank=crank, walker=study.walker, geometry=geometry_columns(study, geometry),
                           target=study.target)


def design_solver(study: Study, timer: dict | None = None, deferred: bool = False):
    """solve(lengths, crank, geometry) → (batch, metrics) for given designs of ``study``'s mechanism:
    lengths (n, n_links) in ``mech.links`` order, crank radii (n,), geometry (n, g) of the coordinates
    in ``study.geometry_names`` order. What a sampled study and an optimiser's generation both run.
    timer : optional dict to which the wall seconds of ``"solve"`` (the kernels) and ``"metrics"`` (the
    metrics, yield included) are added.

    deferred : solve(...) → (batch, finish) instead, where ``finish()`` → metrics computes them (on
    another thread, while the next designs are solved: ``explorer run``'s commit thread).

    Solves only what the scene asks for: its vertices (plus the foot when metrics are asked for),
    velocities when stored or needed by a metric, accelerations when stored, and the forces effect
    (torque, the stored joints' reactions, the force metrics) with ``[scene] forces = true``.
    """
    mech = study.mech
    # before any chunk is solved: the dense method's full-system matrices must fit in memory (a
    # chunk's outputs are bounded by the writer's chunk size, the forces' by ``force_chunk``)
    check_dense(len(mech.vertices), study.method)
    want_metrics = metric_plan(study)[2]
    how = series_solve(study)  # what a lean file records, to re-solve its series bit for bit
    vertices, velocities = how["vertices"], how["velocities"]
    want_yield = wants_yield(study)

    clock = time.perf_counter
    job = study.n_variants * study.steps  # the kernels weigh a per-topology compile against the whole study

    def solve(lengths, crank, geometry):
        t0 = clock()
        radii = crank if mech.crank is not None else None  # a path driver has no crank radius (NaN column)
        moved = geometry_columns(study, geometry)
        extra = {"geometry": moved} if moved else {}  # only a study that moves coordinates passes them
        if study.forces:
            extra.update(forces=True, operating=study.operating, walker=study.walker, force_joints=study.force_joints)
        batch = simulate_batch(mech, lengths, radii, study.steps, vertices=vertices, velocities=velocities,
                               accelerations=study.accelerations, tolerance=study.tolerance, method=study.method,
                               job_configs=job, **extra)
        if timer is not None:
            timer["solve"] = timer.get("solve", 0.0) + (clock() - t0)
        if deferred:
            return batch, lambda: finish(batch, lengths, crank, geometry, moved)
        return batch, finish(batch, lengths, crank, geometry, moved)

    def finish(batch, lengths, crank, geometry, moved):
        """The metrics of the solved ``batch`` (None if the scene asks for none)."""
        foot = mech.foot
        metrics = None
        t1 = clock()
        if want_metrics:
            metrics = compute_study_metrics(study, batch.paths[foot], batch.velocities.get(foot), batch.status,
                                            lengths, crank, geometry)
        if study.forces:  # the forces effect's metrics, always with it
            metrics = {**(metrics or {}), **batch.force_metrics}
        if want_yield:  # copies of each design, cut with the [robustness] error, solved apart
            y = design_yield(mech, lengths, crank, moved, robustness=study.robustness, steps=study.steps,
                             tolerance=study.tolerance, method=study.method, screen=study.screen)
            metrics = {**(metrics or {}), YIELD: y.share}
        if timer is not None:
            timer["metrics"] = timer.get("metrics", 0.0) + (clock() - t1)
        return metrics

    return solve


def chunk_solver(study: Study, timer: dict | None = None, deferred: bool = False):
    """solve(a, b) → (lengths, crank, geometry, batch, metrics) for variants [a, b) of a sampled
    ``study`` (:func:`design_solver` on its sampled designs); geometry is (n, g), the perturbed
    coordinates in ``study.geometry_names`` order ((n, 0) if none). timer : optional dict to which the
    wall seconds of ``"sample"``, ``"solve"`` and ``"metrics"`` are added. deferred : ``metrics`` is a
    function that computes them (:func:`design_solver`)."""
    sampler = study_sampler(study)
    solve_designs = design_solver(study, timer, deferred)

    def solve(a: int, b: int):
        t0 = time.perf_counter()
        lengths, crank, geometry = study_variants(study, a, b, sampler)
        if timer is not None:
            timer["sample"] = timer.get("sample", 0.0) + (time.perf_counter() - t0)
        batch, metrics = solve_designs(lengths, crank, geometry)
        return lengths, crank, geometry, batch, metrics

    return solve
