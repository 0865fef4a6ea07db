"""A model-based trotting controller for quadrupeds in LocoEnv (written and tuned for the Unitree A1).

The method, in the order it runs at every control step (100 Hz):

1. **Gait scheduler.** A trot: the diagonal pairs (FR, RL) and (FL, RR) alternate, each foot in stance for
   ``duty`` of the ``period``. The clock is the simulation time, so the gait restarts with every env reset.
2. **Commands.** The commanded body-frame velocity (forward, lateral) is approached at a bounded acceleration
   (no jump from standing); the trunk's position reference integrates it, so the velocity feedback has an
   integral-like term. A goal heading, if given, sets the yaw rate by a proportional law.
3. **Swing feet.** Each swinging foot follows a Cartesian path (smoothstep across, raised cosine up) from where
   it lifted off to a Raibert foothold: under its hip at touchdown, plus half a stance of travel, plus a
   capture-point term ``sqrt(h / g)`` times the velocity error. Cartesian PD on the path becomes joint torques
   through the foot Jacobian (``J^T F``), plus the leg's bias torques (``qfrc_bias``) and the joints' own
   damping at the path's velocity, so that damping brakes deviations from the path, not the path; where the
   model's damping is low (domain randomization), the controller adds the rest up to ``swing_joint_damping``.
4. **Stance feet (balance QP).** A PD law on the trunk's position, height, orientation and velocities gives a
   desired base acceleration ``a``; the floating base's rows of the equations of motion (MuJoCo's mass matrix and
   bias forces, so the legs' mass, 60 % of the A1's, counts exactly) turn it into the generalised force the
   stance feet must produce, ``J_b^T f = M_bb a + c_b``. The foot forces ``f`` solve a weighted least-squares QP
   inside linearised friction cones: writing each force as a non-negative mix of the cone's four edge vectors
   makes it a non-negative least-squares problem, which ``scipy.optimize.nnls`` solves exactly (no QP package).
   Stance torques are ``tau = c_l + M_lb a - J_l^T f`` plus the joints' damping at their current speed.

The controller works out joint torques. With ``control="torque"`` the action is the torque over the motor limit;
with ``control="pd"`` it is the servo target ``q + qdot dt / 2 + tau / kp``, which applies ``tau`` on average
over the control step. It reads the state from the env's MjData into its own MjData and never writes the env's.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import mujoco
import numpy as np
from scipy.optimize import nnls

GRAVITY = 9.81
LEGS = ("FR", "FL", "RR", "RL")  # legs as Menagerie quadrupeds name them; FR+RL and FL+RR are the trot pairs
LEG_JOINTS = ("hip", "thigh", "calf")


@dataclass(frozen=True)
class TrotSettings:
    """Gait, foothold and feedback settings; the defaults are tuned for the A1 at 0-1.2 m/s."""

    period: float = 0.34  # s, one gait cycle
    duty: float = 0.5  # fraction of the cycle a foot is in stance
    swing_height: float = 0.08  # m, foot clearance the swing path asks for at mid-swing
    body_height: float = 0.27  # m, trunk origin above the floor (the A1's home pose)
    foot_radius: float = 0.02  # m, the foot sphere: its centre is this high when it touches the floor
    touchdown_depth: float = 0.005  # m, swing paths end this far below the floor, so that feet land firmly
    swing_lag: float = 0.1  # fraction of the swing at each end that moves the foot only up or down (no scuffing)
    max_acceleration: float = 1.0  # m/s^2, how fast the velocity reference follows a new command
    max_yaw_rate: float = 1.0  # rad/s, limit of the heading law
    heading_gain: float = 2.0  # 1/s, yaw rate per rad of heading error
    foothold_limit: float = 0.15  # m, largest feedback offset of a foothold
    mu: float = 0.5  # friction coefficient the stance forces respect (the A1's feet have 0.8)
    # trunk feedback, as accelerations: 1/s^2 on errors, 1/s on velocity errors
    kp_xy: float = 30.0
    kd_xy: float = 12.0
    max_position_error: float = 0.1  # m, the position reference is dragged along beyond this (no wind-up)
    kp_z: float = 300.0
    kd_z: float = 30.0
    kp_rot: float = 300.0
    kd_rot: float = 30.0
    max_yaw_error: float = 0.2  # rad, likewise for the yaw reference
    # swing feet: N/m and N s/m
    kp_swing: float = 600.0
    kd_swing: float = 15.0
    swing_joint_damping: float = 2.0  # N m s/rad: the joints' own damping, topped up to this in swing legs
    # QP weights: base force rows (N), base moment rows (N m), regulariser on the cone-edge weights
    w_force: float = 1.0
    w_moment: float = 100.0
    w_reg: float = 1e-3


def yaw_of(quat: np.ndarray) -> float:
    """Heading (rad) of a (w, x, y, z) quaternion."""
    w, x, y, z = quat
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def wrap_angle(angle: float) -> float:
    """``angle`` in [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


class QuadrupedController:
    """Trotting controller (method in the module docstring): ``env.step(controller())`` after ``env.reset()``.

    Command it with :meth:`command`: a body-frame velocity (forward, lateral; m/s) and a yaw rate (rad/s), or a
    world heading (rad) to turn towards. ``env`` is a LocoEnv of a quadruped whose legs are named FR, FL, RR, RL
    (``<leg>_{hip,thigh,calf}_joint``, a foot sphere on each calf), built with ``control="torque"`` or ``"pd"``.
    A new episode (the env's clock going back) is noticed by itself; :meth:`reset` forces one.
    """

    def __init__(self, env: Any, settings: TrotSettings | None = None, forward: float = 0.0, lateral: float = 0.0,
                 yaw_rate: float = 0.0, heading: float | None = None):
        if env.control not in ("torque", "pd"):
            raise ValueError(f"QuadrupedController needs control='torque' or 'pd', not {env.control!r}")
        self.env = env
        self.settings = s = settings or TrotSettings()
        self.model = m = env.model
        self.data = mujoco.MjData(m)  # our own: the env's MjData is only read
        self.dt = float(env.dt)
        self.trunk = m.body("trunk").id
        self.foot_bodies = np.array([m.body(f"{leg}_calf").id for leg in LEGS])
        self.foot_geoms = np.array([next(g for g in range(m.ngeom) if m.geom_bodyid[g] == b
                                         and m.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE)
                                    for b in self.foot_bodies])
        self.leg_dofs = np.array([[m.joint(f"{leg}_{j}_joint").dofadr[0] for j in LEG_JOINTS] for leg in LEGS])
        self.act_qpos = m.jnt_qposadr[m.actuator_trnid[:, 0]]
        self.act_dofs = m.jnt_dofadr[m.actuator_trnid[:, 0]]
        pd = env.control == "pd"
        self.torque_limit = (m.actuator_forcerange if pd else m.actuator_ctrlrange)[:, 1].copy()
        self.kp = m.actuator_gainprm[:, 0].copy() if pd else None  # PD servos: torque = kp (target - q)
        # Nominal footholds: the home pose's feet relative to the trunk, in its heading frame.
        home = mujoco.MjData(m)
        home.qpos[:] = env.home_qpos(m)
        home.qpos[:3] = 0.0
        mujoco.mj_kinematics(m, home)
        self.hip_offsets = home.geom_xpos[self.foot_geoms, :2].copy()
        self.phase_offsets = np.array([0.0, 0.5, 0.5, 0.0])
        # Friction-pyramid edges (columns): f = E @ lam with lam >= 0 keeps |fx|, |fy| <= mu fz.
        self.edges = np.array([[s.mu, s.mu, -s.mu, -s.mu], [s.mu, -s.mu, s.mu, -s.mu], [1.0, 1.0, 1.0, 1.0]])
        self.row_weights = np.sqrt(np.array([s.w_force] * 3 + [s.w_moment] * 3))
        self._jac = np.zeros((4, 3, m.nv))
        self._mass = np.zeros((m.nv, m.nv))
        self._legs = np.arange(4)[:, None]
        self.command(forward, lateral, yaw_rate, heading)
        self.reset()

    # ---- commands ---------------------------------------------------------------------------------
    def command(self, forward: float = 0.0, lateral: float = 0.0, yaw_rate: float = 0.0,
                heading: float | None = None) -> None:
        """Set the body-frame velocity (m/s) and yaw rate (rad/s), or a world heading (rad) to turn towards."""
        self.cmd_velocity = np.array([forward, lateral], dtype=float)
        self.cmd_yaw_rate = float(yaw_rate)
        self.cmd_heading = None if heading is None else float(heading)

    def config(self) -> dict[str, Any]:
        """Method, control mode and settings, JSON-ready (for dataset metadata)."""
        return {"method": "trot; Raibert + capture-point footholds; Cartesian swing PD; balance QP on the "
                          "floating-base dynamics with a friction pyramid, solved as NNLS",
                "control": self.env.control, "settings": asdict(self.settings)}

    def reset(self) -> None:
        """Start afresh at the next call (references from the state then)."""
        self._time: float | None = None

    # ---- the control step -------------------------------------------------------------------------
    def __call__(self, obs: np.ndarray | None = None) -> np.ndarray:
        """The normalised action for the env's current state (``obs`` is accepted for the agent interface)."""
        d, m, s = self.data, self.model, self.settings
        env_d = self.env.data
        d.qpos[:] = env_d.qpos
        d.qvel[:] = env_d.qvel
        d.time = env_d.time
        # Only what the controller uses (a twentieth of mj_forward): kinematics, mass matrix, bias forces.
        mujoco.mj_kinematics(m, d)
        mujoco.mj_comPos(m, d)
        mujoco.mj_crb(m, d)
        mujoco.mj_comVel(m, d)
        mujoco.mj_rne(m, d, 0, d.qfrc_bias)
        if self._time is None or d.time < self._time:
            self._restart()
        self._time = d.time

        yaw = yaw_of(d.qpos[3:7])
        yaw_rate = self._update_references(yaw)
        v_des = _rot2(yaw) @ self._v_ref  # world xy

        phase = (d.time / s.period + self.phase_offsets) % 1.0
        stance = phase < s.duty
        swing_s = np.clip((phase - s.duty) / (1.0 - s.duty), 0.0, 1.0)  # 0 -> 1 through swing
        feet = d.geom_xpos[self.foot_geoms]
        lifted = self._was_stance & ~stance
        self._liftoff[lifted] = feet[lifted]
        self._was_stance = stance

        for i in range(4):
            mujoco.mj_jac(m, d, self._jac[i], None, feet[i], self.foot_bodies[i])
        mujoco.mj_fullM(m, d, self._mass)
        jt = self._jac[self._legs, :, self.leg_dofs]  # (4, 3 dofs, 3 xyz): each leg's J^T
        qd = d.qvel[self.leg_dofs]
        damping = m.dof_damping[self.leg_dofs]  # read each step: domain randomization changes it

        acc = self._base_acceleration(v_des, yaw_rate)
        tau = d.qfrc_bias[self.leg_dofs] + self._mass[self.leg_dofs, :6] @ acc  # (4, 3)
        if stance.any():
            forces = self._stance_forces(stance, self._mass[:6, :6] @ acc + d.qfrc_bias[:6])
            tau[stance] += damping[stance] * qd[stance] - np.einsum("kdx,kx->kd", jt[stance], forces[stance])
        swing = ~stance
        if swing.any():
            target, target_vel = self._swing_paths(swing_s[swing], swing, yaw, yaw_rate, v_des)
            foot_vel = self._jac[swing] @ d.qvel
            force = s.kp_swing * (target - feet[swing]) + s.kd_swing * (target_vel - foot_vel)
            # the joint speeds that move the foot along the path, at the base's current motion
            path_qd = np.linalg.solve(np.transpose(jt[swing], (0, 2, 1)),
                                      (target_vel - self._jac[swing, :, :6] @ d.qvel[:6])[..., None])[..., 0]
            top_up = np.maximum(s.swing_joint_damping - damping[swing], 0.0)
            tau[swing] += np.einsum("kdx,kx->kd", jt[swing], force) + damping[swing] * path_qd \
                + top_up * (path_qd - qd[swing])
        torque = np.zeros(m.nv)
        torque[self.leg_dofs] = tau
        return self._action(torque[self.act_dofs])

    def _restart(self) -> None:
        """A new episode: references from the current state, swing paths from the current feet."""
        d = self.data
        self._v_ref = np.zeros(2)
        self._p_ref = d.qpos[:2].copy()
        self._yaw_ref = yaw_of(d.qpos[3:7])
        self._liftoff = d.geom_xpos[self.foot_geoms].copy()
        self._was_stance = np.ones(4, dtype=bool)

    def _update_references(self, yaw: float) -> float:
        """Move the velocity and yaw references on by one step; return the yaw rate to follow."""
        s = self.settings
        step = self.cmd_velocity - self._v_ref
        norm = float(np.linalg.norm(step))
        limit = s.max_acceleration * self.dt
        self._v_ref = self.cmd_velocity.copy() if norm <= limit else self._v_ref + step * (limit / norm)
        if self.cmd_heading is not None:
            rate = float(np.clip(s.heading_gain * wrap_angle(self.cmd_heading - yaw), -s.max_yaw_rate,
                                 s.max_yaw_rate))
        else:
            rate = self.cmd_yaw_rate
        err = float(np.clip(wrap_angle(self._yaw_ref + rate * self.dt - yaw), -s.max_yaw_error, s.max_yaw_error))
        self._yaw_ref = yaw + err
        return rate

    def _base_acceleration(self, v_des: np.ndarray, yaw_rate: float) -> np.ndarray:
        """Desired base acceleration in MuJoCo's free-joint coordinates: linear (world), angular (body frame)."""
        s, d = self.settings, self.data
        self._p_ref += v_des * self.dt
        err = self._p_ref - d.qpos[:2]
        norm = float(np.linalg.norm(err))
        if norm > s.max_position_error:
            err *= s.max_position_error / norm
            self._p_ref = d.qpos[:2] + err
        acc = np.empty(6)
        acc[:2] = s.kp_xy * err + s.kd_xy * (v_des - d.qvel[:2])
        acc[2] = s.kp_z * (s.body_height - d.qpos[2]) - s.kd_z * d.qvel[2]
        rot = d.xmat[self.trunk].reshape(3, 3)
        rel = rot.T @ _rot_z(self._yaw_ref)  # desired orientation in the body frame (roll = pitch = 0)
        rot_err = 0.5 * np.array([rel[2, 1] - rel[1, 2], rel[0, 2] - rel[2, 0], rel[1, 0] - rel[0, 1]])
        omega_des = rot[2] * yaw_rate  # world (0, 0, yaw_rate) in the body frame
        acc[3:] = s.kp_rot * rot_err + s.kd_rot * (omega_des - d.qvel[3:6])
        return acc

    def _stance_forces(self, stance: np.ndarray, wrench: np.ndarray) -> np.ndarray:
        """Foot forces (4, 3), world frame, whose generalised force on the base best matches ``wrench``."""
        idx = np.flatnonzero(stance)
        n = 4 * len(idx)
        jb = self._jac[idx, :, :6]  # (k, 3, 6): base columns of the stance feet's Jacobians
        a = np.einsum("kxb,xe->bke", jb, self.edges).reshape(6, n) * self.row_weights[:, None]
        lhs = np.vstack([a, math.sqrt(self.settings.w_reg) * np.eye(n)])
        lam, _ = nnls(lhs, np.concatenate([wrench * self.row_weights, np.zeros(n)]))
        forces = np.zeros((4, 3))
        forces[idx] = lam.reshape(len(idx), 4) @ self.edges.T
        return forces

    def _swing_paths(self, s_swing: np.ndarray, swing: np.ndarray, yaw: float, yaw_rate: float,
                     v_des: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities (k, 3), world frame, of the swing feet on their paths to their footholds."""
        s, d = self.settings, self.data
        t_stance, t_swing = s.duty * s.period, (1.0 - s.duty) * s.period
        t_left = ((1.0 - s_swing) * t_swing)[:, None]
        # where the hip will be at mid-stance, turning with the commanded yaw rate
        angle = yaw + yaw_rate * (t_left[:, 0] + 0.5 * t_stance)
        c, sn = np.cos(angle), np.sin(angle)
        off = self.hip_offsets[swing]
        hips = d.qpos[:2] + np.stack([c * off[:, 0] - sn * off[:, 1], sn * off[:, 0] + c * off[:, 1]], axis=1)
        feedback = math.sqrt(s.body_height / GRAVITY) * (d.qvel[:2] - v_des)
        norm = float(np.linalg.norm(feedback))
        if norm > s.foothold_limit:
            feedback *= s.foothold_limit / norm
        foothold = hips + v_des * (t_left + 0.5 * t_stance) + feedback
        start = self._liftoff[swing, :2]
        across = 1.0 - 2.0 * s.swing_lag
        u = np.clip((s_swing - s.swing_lag) / across, 0.0, 1.0)  # progress across, after lifting off
        blend = (u * u * (3.0 - 2.0 * u))[:, None]
        dblend = (6.0 * u * (1.0 - u) / across)[:, None]
        target = np.empty((len(s_swing), 3))
        target_vel = np.empty_like(target)
        target[:, :2] = start + (foothold - start) * blend
        target_vel[:, :2] = (foothold - start) * dblend / t_swing
        target[:, 2] = s.foot_radius - s.touchdown_depth * s_swing + s.swing_height * 0.5 * (
            1.0 - np.cos(2.0 * math.pi * s_swing))
        target_vel[:, 2] = (s.swing_height * math.pi * np.sin(2.0 * math.pi * s_swing) - s.touchdown_depth) / t_swing
        return target, target_vel

    def _action(self, torque: np.ndarray) -> np.ndarray:
        """The normalised action that applies ``torque`` (per actuator) over the coming control step."""
        torque = np.clip(torque, -self.torque_limit, self.torque_limit)
        if self.kp is None:
            ctrl = torque
        else:
            d = self.data
            ctrl = d.qpos[self.act_qpos] + 0.5 * self.dt * d.qvel[self.act_dofs] + torque / self.kp
        return np.clip(self.env.ctrl_to_action(ctrl), -1.0, 1.0)


def _rot2(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


def _rot_z(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
