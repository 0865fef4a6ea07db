"""Poses of a compiled model: its joint couplings satisfied, its height above the floor."""

from __future__ import annotations

import mujoco
import numpy as np


def apply_joint_couplings(model: mujoco.MjModel, qpos: np.ndarray) -> np.ndarray:
    """Satisfy the model's joint-coupling equalities in every frame of ``qpos`` (N, nq) or (nq,).

    Each follower joint gets the polynomial of its leader, ``q1 - q1_0 = sum_k c_k (q2 - q2_0)^k``
    (e.g. the knee translations that musculoskeletal models drive from the knee angle).
    """
    qpos = np.array(qpos, dtype=float)
    frames = qpos.reshape(-1, model.nq)
    for e in range(model.neq):
        if model.eq_type[e] != mujoco.mjtEq.mjEQ_JOINT or model.eq_obj2id[e] < 0 or not model.eq_active0[e]:
            continue
        a1 = model.jnt_qposadr[model.eq_obj1id[e]]
        a2 = model.jnt_qposadr[model.eq_obj2id[e]]
        x = frames[:, a2] - model.qpos0[a2]
        frames[:, a1] = model.qpos0[a1] + np.polynomial.polynomial.polyval(x, model.eq_data[e][:5])
    return qpos


def lowest_point(model: mujoco.MjModel, data: mujoco.MjData, geoms: list[int], floor: str = "floor") -> float:
    """Height (m) above the floor plane of the lowest point of ``geoms`` in the current pose (after
    ``mj_kinematics``): MuJoCo's exact geom distance, for any geom type."""
    floor_id = model.geom(floor).id
    fromto = np.zeros(6)
    return min(mujoco.mj_geomDistance(model, data, g, floor_id, 10.0, fromto) for g in geoms)
