"""Resampling motion onto a uniform time grid: cubic splines for angles and positions, slerp for rotations."""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, Slerp


def resample_angles(time: np.ndarray, values: np.ndarray, new_time: np.ndarray) -> np.ndarray:
    """Cubic-spline ``values`` (N, k) from ``time`` onto ``new_time`` (clamped to the source interval)."""
    return CubicSpline(time, values, axis=0)(np.clip(new_time, time[0], time[-1]))


def resample_quat(time: np.ndarray, quat_wxyz: np.ndarray, new_time: np.ndarray) -> np.ndarray:
    """Slerp unit quaternions (w, x, y, z) onto ``new_time``."""
    rot = Rotation.from_quat(quat_wxyz[:, [1, 2, 3, 0]])
    out = Slerp(time, rot)(np.clip(new_time, time[0], time[-1])).as_quat()
    return out[:, [3, 0, 1, 2]]
