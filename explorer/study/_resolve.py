"""Solving the designs of a results file again (issue 40: store reads and writes files only; the solving is
study's). :func:`resolve_series` re-solves variants of a lean file (``[scene] store = "metrics"``) exactly as
its run solved them; :data:`RESOLVER` is what :mod:`explorer.store` asks (:class:`~explorer.store.Resolver`),
registered when :mod:`explorer.study` is imported; :func:`open_results` opens a results file with it (what
:func:`explorer.open_results` is)."""

from __future__ import annotations

import json

import h5py

from ..kernels import assemble, simulate_batch
from ..mechanism import Mechanism
from ..store import Resolver, register_resolver, stored_designs, stored_mechanism, stored_operating
from ..store import open_results as _open_results


def resolve_series(f: h5py.File, variants, *, mechanism: Mechanism | None = None, solve: dict | None = None,
                   study: dict | None = None, operating=None, vertices=None, velocities: bool | None = None):
    """Solve again, from their stored designs, variants of a lean results file ``f`` exactly as the run
    solved them (its root attribute ``series_solve``: the same vertices, velocities, accelerations,
    steps, tolerance, method and forces): the :class:`~explorer.kernels.Batch` whose ``paths``,
    ``velocities``, ``accelerations``, ``torque`` and ``forces`` are, bit for bit, what a study storing
    its series writes for them (each design is solved apart from the others, whatever the batch).

    variants : (n,) increasing variant indices, or a slice of them. mechanism, solve, study,
    operating : the file's nominal mechanism, ``series_solve`` and ``study_resolved`` (parsed) and
    operating point, when the caller has them already (read from ``f`` otherwise). vertices,
    velocities : solve these vertices, or velocities, where the run did not (``explorer metrics``
    asking for the foot or its velocities of a study that solved neither); the rest stays the run's."""
    if solve is None:
        solve = json.loads(f.attrs["series_solve"])
    if study is None:
        study = json.loads(f.attrs["study_resolved"])
    if mechanism is None:
        mechanism = stored_mechanism(f)
    lengths, crank, moved = stored_designs(f, variants)
    extra = {}
    if moved:
        extra["geometry"] = moved
    if solve["forces"]:
        from ..mechanism import walker_from_dict
        if operating is None:
            operating = stored_operating(study["operating"], "its study")
        walker = walker_from_dict(study.get("walker") or {}, "its study", "walker", base=mechanism.walker)
        extra.update(forces=True, operating=operating, walker=walker, force_joints=list(solve["force_joints"]))
    radii = crank if mechanism.crank is not None else None
    return simulate_batch(mechanism, lengths, radii, int(solve["steps"]),
                          vertices=list(solve["vertices"] if vertices is None else vertices),
                          velocities=bool(solve["velocities"] or velocities), accelerations=bool(solve["accelerations"]),
                          tolerance=float(solve["tolerance"]), method=str(solve["method"]), **extra)


#: How explorer solves designs of a results file again: the lean re-solve and the nominal's assembly.
RESOLVER = register_resolver(Resolver(series=resolve_series, assemble=assemble))


def open_results(path, resolver: Resolver | None = None):
    """:func:`explorer.store.open_results` with explorer's re-solver (:data:`RESOLVER`) unless another is given:
    a lean file's series re-solve, bit for bit, as its run solved them."""
    return _open_results(path, resolver=RESOLVER if resolver is None else resolver)
