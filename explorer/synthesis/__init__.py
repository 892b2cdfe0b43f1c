"""Path synthesis: from target points to designs whose foot draws them.

``build_atlas(mechanism, designs)`` / ``open_atlas(path)`` are the curve atlas (``explorer atlas``):
many designs of one mechanism, each with its foot path stored as a shape independent of position,
rotation and scale (:mod:`explorer.synthesis._curves`: descriptors and alignment scans, Numba), so
that :meth:`Atlas.query` answers "which design draws this curve?" by a look-up. ``polish`` /
``batched_lm`` / ``scout_and_polish`` / ``finish`` / ``polish_constrained`` are the least squares on a
design's path residuals against the target (:class:`PathResiduals`), from one start or many.
``synthesize(target, mechanism=...)`` is ``explorer synth``: look-up, polish, and a results file.

The target itself (a study's ``[target]`` table, :class:`explorer.gait.Target`) and the path error and
matching (``path_error``, ``path_match``) stay in :mod:`explorer.gait`: ``path_error`` is a metric the
chunk runner computes. This room sits after :mod:`explorer.study` (synthesis writes its designs through
the chunk runner, :mod:`explorer.study.runner`) and before :mod:`explorer.optimize`, whose search on
``path_error`` starts from the atlas's designs and ends with this polish.

Module graph: ``_synth`` → ``_atlas``, ``_polish``; ``_atlas`` → ``_curves``; ``_polish`` → ``_curves``
(the in-order match of target points along a path).
"""

from ._atlas import (FAMILIES as ATLAS_FAMILIES, Atlas, AtlasSpec, atlas_dir, atlas_info, atlas_spec, build_atlas,
                     default_path, diverse, find_atlas, move_parameters, open_atlas, same_branch, structure_key)
from ._polish import (FD_STEP, BatchedLMResult, ConstrainedResiduals, PathResiduals, PolishResult, batched_lm,
                      distinct_best, finish, multistart, polish, polish_constrained, scout_and_polish)
from ._synth import SynthSummary, synthesize

__all__ = ["ATLAS_FAMILIES", "Atlas", "AtlasSpec", "atlas_dir", "atlas_info", "atlas_spec", "build_atlas", "default_path",
           "diverse", "find_atlas", "move_parameters", "open_atlas", "same_branch", "structure_key",
           "FD_STEP", "BatchedLMResult", "ConstrainedResiduals", "PathResiduals", "PolishResult", "batched_lm",
           "distinct_best", "finish", "multistart", "polish", "polish_constrained", "scout_and_polish",
           "SynthSummary", "synthesize"]
