"""Who solves designs for store: store reads and writes files only (issue 40), so the two places a reader
needs designs solved ask a :class:`Resolver` instead of calling the kernels.

* A lean file (``[scene] store = "metrics"``) stores no series: :class:`~explorer.store.Results` re-solves the
  series it is asked for, bit for bit, through ``resolver.series`` (:func:`explorer.study.resolve_series`).
* A variant's mechanism (:func:`~explorer.store.variant_mechanism`) assembles on the nominal's branch: its guess
  is the nominal's configuration at the first sample, ``resolver.assemble`` (:func:`explorer.kernels.assemble`).

``open_results(path, resolver=...)`` takes one; without it, the resolver that :mod:`explorer.study` registers
(:func:`register_resolver`) when it is imported. A reader that opened a file through ``explorer.store`` alone,
before anything imported :mod:`explorer.study`, gets it on the first re-solve: store imports the package named
:data:`RESOLVER_HOME` by name then (as :mod:`explorer._moved`'s forwards do, so no import runs back up the
pipeline) and uses what it registered.
"""

from __future__ import annotations

from dataclasses import dataclass
from importlib import import_module
from typing import Callable

from ..errors import UserError


@dataclass(frozen=True)
class Resolver:
    """How designs of a results file are solved again.

    series(f, variants, *, mechanism, solve, study, operating, vertices=None, velocities=None) -> Batch :
        re-solve variants (an increasing (n,) index array or a slice) of the open lean file ``f`` exactly as
        its run did (its ``series_solve``); the :class:`~explorer.kernels.Batch` whose series are, bit for bit,
        what a study storing them writes.
    assemble(mechanism) -> (positions (n_vertices, 2), failure or None) : the mechanism at its first sample,
        on the branch its guess selects."""

    series: Callable
    assemble: Callable


#: The package whose import registers the default resolver.
RESOLVER_HOME = "explorer.study"

_REGISTERED: list[Resolver] = []


def register_resolver(resolver: Resolver) -> Resolver:
    """Make ``resolver`` the one every :class:`~explorer.store.Results` opened without its own uses."""
    if not isinstance(resolver, Resolver):
        raise TypeError(f"expected a Resolver, got {type(resolver).__name__}")
    _REGISTERED[:] = [resolver]
    return resolver


def registered_resolver() -> Resolver:
    """The registered resolver (importing :data:`RESOLVER_HOME` first if none is registered yet)."""
    if not _REGISTERED:
        import_module(RESOLVER_HOME)
    if not _REGISTERED:
        raise UserError(f"no re-solver registered: import {RESOLVER_HOME} (or open the file with "
                        f"explorer.open_results) to re-solve designs of a results file")
    return _REGISTERED[0]
