"""Names that moved to another room keep their old import path for one release.

A package whose names moved defines ``__getattr__ = moved(__name__, {name: new_module, ...})``: the old
spelling (``from explorer.study import sensitivity``) still works, returns the very object at the new
home (``explorer.analysis.sensitivity``) and warns once with a :class:`DeprecationWarning` naming it.
The new home is imported only when an old name is used, so the package itself never imports a room
later in the pipeline (tests/test_import_graph.py; the table of every moved name is :data:`MOVED`).
"""

from __future__ import annotations

import importlib
import warnings

#: old package -> {name: new module}: every name re-exported for one release (read by the tests).
MOVED: dict[str, dict[str, str]] = {}


def moved(package: str, names: dict[str, str]):
    """The module ``__getattr__`` of ``package`` that forwards each moved name to its new module."""
    MOVED.setdefault(package, {}).update(names)

    def __getattr__(name: str):
        home = names.get(name)
        if home is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        warnings.warn(f"{package}.{name} moved to {home}.{name}; the old path goes in the next release",
                      DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(home), name)

    return __getattr__
