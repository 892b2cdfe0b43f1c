"""The physics check of a shortlist (``explorer physics``): each design's walker scene as a planar MuJoCo
model, stepped natively, measured over whole turns, stored as the ``physics`` metrics of its results file.

* :func:`physics_check` (:mod:`._check`): choose the designs, build their models, run them in worker
  processes, write the figures (through a renamed copy of the file);
* :func:`build_model` (:mod:`._model`): the MJCF text of one design's walker scene (:class:`Settings`);
* :func:`run_model` (:mod:`._simulate`): step it and measure whole turns (:data:`PHYSICS_METRICS`).

MuJoCo is an optional dependency: ``pip install 'explorer[physics]'``.
"""

from ._check import DEFAULT_TOP, describe_settings, physics_check, stored_physics
from ._model import Settings, build_model
from ._simulate import PHYSICS_METRICS, PhysicsFailure, run_model

__all__ = ["DEFAULT_TOP", "PHYSICS_METRICS", "PhysicsFailure", "Settings", "build_model", "describe_settings",
           "physics_check", "run_model", "stored_physics"]
