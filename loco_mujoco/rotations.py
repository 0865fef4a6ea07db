"""Quaternion helpers shared by models and datasets. Quaternions are (w, x, y, z), as in MuJoCo."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product ``a * b`` of quaternions (..., 4), broadcast over leading dimensions."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], axis=-1)


def quat_conj(q: np.ndarray) -> np.ndarray:
    """Conjugate (the inverse of a unit quaternion)."""
    return np.asarray(q, dtype=float) * np.array([1.0, -1.0, -1.0, -1.0])


def axis_angle_quat(axis: np.ndarray, angle: np.ndarray | float) -> np.ndarray:
    """Quaternions (..., 4) of rotations by ``angle`` about the (normalised) ``axis``."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * axis], axis=-1)


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Vector(s) ``v`` rotated by unit quaternion(s) ``q``."""
    return Rotation.from_quat(np.asarray(q, dtype=float)[..., [1, 2, 3, 0]]).apply(v)


def quat_to_mat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (3, 3) or (N, 3, 3) of unit quaternion(s)."""
    return Rotation.from_quat(np.asarray(q, dtype=float)[..., [1, 2, 3, 0]]).as_matrix()


def mat_to_quat(mats: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) of rotation matrices (3, 3) or (N, 3, 3), with w >= 0."""
    q = Rotation.from_matrix(mats).as_quat()[..., [3, 0, 1, 2]]
    return np.where(q[..., :1] < 0, -q, q)


def continuous(q: np.ndarray) -> np.ndarray:
    """A quaternion sequence (N, 4) with signs flipped so consecutive frames agree (w >= 0 first)."""
    q = np.array(q, dtype=float)
    if q[0, 0] < 0:
        q[0] *= -1
    for i in range(1, len(q)):
        if np.dot(q[i], q[i - 1]) < 0:
            q[i] *= -1
    return q
