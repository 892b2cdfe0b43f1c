"""The 3-D wrist: a prescribed orientation (keyframes of rotation matrices) interpolated over the driver's
path (slerp, SQUAD, Euler angles), its Euler angles tracked on one branch with gimbal locks reported, and
the angular rates (``wrist_path``; ``wrist_for(mechanism)`` for a mechanism's ``[driver] orientation``).
Used by ``explorer bench rotations`` (:mod:`explorer.bench`) and ``explorer describe``. It sits after
:mod:`explorer.kernels` in the pipeline (it uses the driver's timing laws) and before :mod:`explorer.gait`.
"""

from ._wrist import (INTERPOLATIONS, SEQUENCES, GimbalLock, WristPath, check_sequence, euler_sets, interpolate,
                     lock_distance, orthonormality_defect, project, relative_angle, track, wrist_for, wrist_path)

__all__ = ["INTERPOLATIONS", "SEQUENCES", "GimbalLock", "WristPath", "check_sequence", "euler_sets", "interpolate",
           "lock_distance", "orthonormality_defect", "project", "relative_angle", "track", "wrist_for", "wrist_path"]
