"""Expert actions for datasets that have none, by inverse dynamics (GAIL needs state-action pairs).

For each transition ``t -> t+1`` of ``env.create_dataset()``: the joint acceleration is the forward difference
of the dataset's velocities, ``mj_inverse`` gives the generalised forces that produce it at ``(qpos_t, qvel_t)``
(contact forces included, from MuJoCo's soft contact model), and each actuator's control is solved from its
affine force law ``force = gain * ctrl + b0 + b1 * length + b2 * velocity`` (torque motors and PD servos alike).
Controls are then normalised like the environment's actions and clipped to [-1, 1]. The root's six forces
(unactuated) are what the motion asks for beyond the robot's means; ``inverse_dynamics_report`` measures them.
Muscle actuators are not affine in the control and are refused.

Soft contacts push only when the feet penetrate the floor, and retargeted feet rest exactly on it, so the
dataset would get no ground reaction and the stance legs no load. The body is therefore sunk by the depth
(found by bisection) at which the median vertical root residual vanishes: the floor then carries the weight
on average, as it does in simulation (H1: about 3.5 mm).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np


def _affine_actuators(model: mujoco.MjModel) -> None:
    affine = (model.actuator_gaintype == mujoco.mjtGain.mjGAIN_FIXED) & \
             np.isin(model.actuator_biastype, (mujoco.mjtBias.mjBIAS_NONE, mujoco.mjtBias.mjBIAS_AFFINE))
    joint_trn = model.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT
    supported = affine & joint_trn & (model.actuator_dyntype == mujoco.mjtDyn.mjDYN_NONE)
    if not np.all(supported):
        bad = [model.actuator(i).name for i in np.flatnonzero(~supported)]
        raise ValueError(f"inverse-dynamics actions need joint actuators without activation dynamics, with a fixed "
                         f"gain and affine bias (motors, PD servos); these are not: "
                         f"{bad[:5]}{' ...' if len(bad) > 5 else ''}")


def _transitions(env: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(frames, qpos, qvel, qacc) of the dataset transitions, in ``create_dataset()`` order."""
    qpos, qvel = env.dataset_states()
    idx = env.transition_frames()
    return idx, qpos, qvel, (qvel[idx + 1] - qvel[idx]) / env.dt


def controls_from_inverse(model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
    """The controls whose actuator forces equal ``data.qfrc_inverse`` on the actuated dofs (after ``mj_inverse``).

    Joint transmissions: actuator length and velocity are ``gear * q`` and ``gear * qdot``, and the joint feels
    ``gear * force``; ``force = gain * ctrl + b0 + b1 * length + b2 * velocity`` is solved for ``ctrl``.
    """
    joint = model.actuator_trnid[:, 0]
    dof = model.jnt_dofadr[joint]
    gear = model.actuator_gear[:, 0]
    length, velocity = gear * data.qpos[model.jnt_qposadr[joint]], gear * data.qvel[dof]
    force = data.qfrc_inverse[dof] / gear
    bias = model.actuator_biasprm
    return (force - bias[:, 0] - bias[:, 1] * length - bias[:, 2] * velocity) / model.actuator_gainprm[:, 0]


def contact_sink(env: Any, n_frames: int = 400, max_depth: float = 0.02) -> float:
    """The depth (m) the body is lowered by so that the median vertical root residual is zero."""
    idx, qpos, qvel, qacc = _transitions(env)
    pick = np.linspace(0, len(idx) - 1, min(n_frames, len(idx))).astype(int)
    model = env._model
    data = mujoco.MjData(model)

    def median_lift(depth: float) -> float:
        lift = []
        for row in pick:
            data.qpos[:], data.qvel[:], data.qacc[:] = qpos[idx[row]], qvel[idx[row]], qacc[row]
            data.qpos[2] -= depth
            mujoco.mj_inverse(model, data)
            lift.append(data.qfrc_inverse[2])
        return float(np.median(lift))

    lo, hi = 0.0, max_depth
    if median_lift(hi) > 0:
        raise ValueError(f"the floor cannot carry {type(env).__name__}'s weight within {max_depth} m of sinking")
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if median_lift(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def inverse_dynamics_controls(env: Any, sink: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(ctrl, root_force) for every transition of ``env.create_dataset()`` (unclipped ctrl, (n, nu); (n, 6)).

    ``sink``: depth the body is lowered by for the contacts (default: :func:`contact_sink`).
    """
    model = env._model
    _affine_actuators(model)
    sink = contact_sink(env) if sink is None else sink
    data = mujoco.MjData(model)
    idx, qpos, qvel, qacc = _transitions(env)
    ctrl = np.empty((len(idx), model.nu))
    root = np.empty((len(idx), 6))
    for row, frame in enumerate(idx):  # one mj_inverse per dataset frame (offline, not in step())
        data.qpos[:], data.qvel[:], data.qacc[:] = qpos[frame], qvel[frame], qacc[row]
        data.qpos[2] -= sink
        mujoco.mj_inverse(model, data)
        ctrl[row] = controls_from_inverse(model, data)
        root[row] = data.qfrc_inverse[:6]
    return ctrl, root


def inverse_dynamics_actions(env: Any) -> np.ndarray:
    """Normalised actions in [-1, 1] (float32, one per ``create_dataset()`` transition) that reproduce the motion."""
    ctrl, _ = inverse_dynamics_controls(env)
    return np.clip(env.ctrl_to_action(ctrl), -1.0, 1.0).astype(np.float32)


def inverse_dynamics_report(env: Any) -> dict[str, float]:
    """How feasible the dataset is for the robot: the contact sink, the share of clipped actions and the
    root's residual force relative to body weight (0 = actuators and floor alone reproduce the motion)."""
    sink = contact_sink(env)
    ctrl, root = inverse_dynamics_controls(env, sink)
    action = env.ctrl_to_action(ctrl)
    weight = float(env._model.body_subtreemass[1] * np.linalg.norm(env._model.opt.gravity))
    return {"sink_m": sink, "clipped_fraction": float(np.mean(np.abs(action) > 1.0)),
            "root_vertical_over_weight_median": float(np.median(root[:, 2]) / weight),
            "root_force_over_weight_median": float(np.median(np.linalg.norm(root[:, :3], axis=1)) / weight)}
