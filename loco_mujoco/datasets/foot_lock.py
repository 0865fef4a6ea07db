"""Foot-locked retargeting: inverse kinematics that keeps each stance foot where it landed.

After the joint mapping and the odometry root (:mod:`retarget`), each foot's stance phases are found with
height and speed hysteresis (walking gets no flight phase: a gap between stances extends the nearer one).
A stance foot gets one anchor for its whole phase (position and yaw, sole flat on the floor); a swing foot
leaves one anchor and reaches the next flat and without horizontal speed, following the source's foot path
(scaled to the robot) in between and clearing the floor. Differential inverse kinematics (``mink``, one QP
per iteration with the joint limits as constraints, warm-started from the previous frame) then moves the
legs and the root to meet those targets while the pelvis follows the source and every other joint keeps its
mapped angle.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation, Slerp

GRAVITY = 9.81
# Froude number v^2 / (g * leg length) below which a clip is walking (people switch to running near 0.5).
WALK_FROUDE = 0.5


@dataclass(frozen=True)
class FootLockSettings:
    """Stance detection and target shaping; lengths are for a human-sized leg and scale with the robot's."""

    stance_on_height: float = 0.02  # m: a foot lower than this ...
    stance_on_speed: float = 0.6  # m/s: ... and slower than this lands
    stance_off_height: float = 0.04  # m: a stance foot higher than this ...
    stance_off_speed: float = 1.2  # m/s: ... or faster than this lifts off
    min_phase: float = 0.06  # s: shorter stance or swing phases are noise
    swing_clearance: float = 0.04  # m: least height of the sole at mid-swing
    # contact point, and foot orientation about its (roll, pitch, yaw) axes: roll is the goal a 5-joint leg
    # cannot always meet
    stance_cost: tuple[float, tuple[float, float, float]] = (100.0, (1.0, 10.0, 10.0))
    swing_cost: tuple[float, float] = (10.0, 2.0)
    pelvis_cost: tuple[float, float] = (1.0, 5.0)
    posture_cost: float = 0.1
    damping: float = 1e-2  # penalises moving away from the previous frame's solution: no jumps between IK branches
    tolerance: float = 1e-4  # m: stance feet closer than this to their anchor end a frame's iterations
    max_iterations: int = 4


def is_walking(mean_speed: float, leg_length: float) -> bool:
    """Walking (no flight phase) when the Froude number of the mean speed is below ``WALK_FROUDE``."""
    return mean_speed ** 2 / (GRAVITY * leg_length) < WALK_FROUDE


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of True in a 1-D bool array."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], mask.astype(np.int8), [0]])))
    return list(zip(edges[::2], edges[1::2], strict=True))


def _drop_short(mask: np.ndarray, n_min: int) -> np.ndarray:
    """Fill False runs shorter than ``n_min`` inside the clip, then remove True runs shorter than it."""
    out = mask.copy()
    for a, b in _runs(~out):
        if b - a < n_min and a > 0 and b < len(out):
            out[a:b] = True
    for a, b in _runs(out):
        if b - a < n_min:
            out[a:b] = False
    return out


def stance_phases(height: np.ndarray, speed: np.ndarray, frequency: float, walking: bool,
                  settings: FootLockSettings, scale: float = 1.0) -> np.ndarray:
    """Stance flags (N, feet) from sole height (m) and horizontal speed (m/s) with hysteresis.

    Walking has no flight: a frame with no foot in stance extends the stance of the lower foot next to it.
    """
    n, n_feet = height.shape
    on_h, off_h = settings.stance_on_height * scale, settings.stance_off_height * scale
    on_v, off_v = settings.stance_on_speed * scale, settings.stance_off_speed * scale
    stance = np.zeros((n, n_feet), dtype=bool)
    for f in range(n_feet):
        state = height[0, f] < off_h and speed[0, f] < off_v
        for t in range(n):
            if state:
                state = height[t, f] <= off_h and speed[t, f] <= off_v
            else:
                state = height[t, f] < on_h and speed[t, f] < on_v
            stance[t, f] = state
        stance[:, f] = _drop_short(stance[:, f], max(2, int(round(settings.min_phase * frequency))))
    if not stance.any():  # nothing ever lands: the lowest foot carries each frame
        stance[np.arange(n), height.argmin(axis=1)] = True
    if walking:
        for a, b in _runs(~stance.any(axis=1)):
            if a == 0 or b == n:  # a gap at an end: the foot lower during the gap stands
                stance[a:b, height[a:b].mean(axis=0).argmin()] = True
                continue
            ending = np.flatnonzero(stance[a - 1])  # feet whose stance ends at the gap
            starting = np.flatnonzero(stance[b])  # feet whose stance begins after it
            options = [(f, "ending") for f in ending] + [(f, "starting") for f in starting]
            foot, _ = min(options, key=lambda o: height[a:b, o[0]].mean())
            stance[a:b, foot] = True
    return stance


def _smootherstep(u: np.ndarray) -> np.ndarray:
    """0 -> 1 with zero first and second derivatives at both ends."""
    u = np.clip(u, 0.0, 1.0)
    return u * u * u * (u * (6.0 * u - 15.0) + 10.0)


def _yaw_matrix(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _yaw_of(rel: np.ndarray) -> np.ndarray:
    """Heading angle of rotations (..., 3, 3): the direction their x axis points in the ground plane."""
    return np.arctan2(rel[..., 1, 0], rel[..., 0, 0])


@dataclass
class FootTargets:
    """Per-frame pose targets of each foot body: position (N, feet, 3), rotation (N, feet, 3, 3), stance flags."""

    position: np.ndarray
    rotation: np.ndarray
    stance: np.ndarray


def _stance_poses(foot_rot: np.ndarray, flat_rot: np.ndarray, sole: np.ndarray, radius: np.ndarray,
                  anchor_xy: np.ndarray, yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """Foot poses through one stance phase: the source's tilt (heel strike, heel rise) about the sole point that
    is lowest, that point where it lies when the foot is flat at the anchor. Rolls without slipping."""
    rel = foot_rot @ flat_rot.T  # rotation from the flat pose, (n, 3, 3)
    psi = _yaw_of(rel)
    c, s = np.cos(psi), np.sin(psi)
    undo = np.zeros_like(rel)
    undo[:, 0, 0], undo[:, 0, 1], undo[:, 1, 0], undo[:, 1, 1], undo[:, 2, 2] = c, s, -s, c, 1.0
    tilt = undo @ rel  # what remains without the heading
    anchor_rot = _yaw_matrix(yaw)
    rot = anchor_rot[None] @ tilt @ flat_rot[None]
    local = np.einsum("nij,kj->nki", rot, sole)  # sole points relative to the origin, (n, K, 3)
    pivot = (local[..., 2] - radius).argmin(axis=1)
    flat_local = (anchor_rot @ flat_rot) @ sole.T  # (3, K): sole points in the flat anchored pose
    idx = np.arange(len(rot))
    pos = np.empty((len(rot), 3))
    pos[:, :2] = anchor_xy + flat_local[:2, pivot].T - local[idx, pivot, :2]
    pos[:, 2] = radius[pivot] - local[idx, pivot, 2]
    return pos, rot


def foot_targets(foot_pos: np.ndarray, foot_rot: np.ndarray, stance: np.ndarray, flat_rot: np.ndarray,
                 sole: np.ndarray, radius: np.ndarray, clearance: float) -> FootTargets:
    """Anchored stance poses and swing paths between them, from the mapped feet (N, feet, 3) / (N, feet, 3, 3).

    ``flat_rot`` (feet, 3, 3) is each foot body's rotation when its sole lies flat with zero heading and
    ``sole`` (feet, K, 3) its sole points (centres of spheres of ``radius`` (feet, K)) in the foot body's frame.
    """
    n, n_feet = stance.shape
    pos = foot_pos.copy()
    rot = foot_rot.copy()
    for f in range(n_feet):
        rel_yaw = _yaw_of(foot_rot[:, f] @ flat_rot[f].T)
        runs = _runs(stance[:, f])
        for a, b in runs:
            xy = np.median(foot_pos[a:b, f, :2], axis=0)  # where the origin stands when the foot is flat
            yaw = float(np.arctan2(np.sin(rel_yaw[a:b]).mean(), np.cos(rel_yaw[a:b]).mean()))
            pos[a:b, f], rot[a:b, f] = _stance_poses(foot_rot[a:b, f], flat_rot[f], sole[f], radius[f], xy, yaw)
        # Swing phases: from the pose at lift-off (or the mapped pose at the clip's start) to the one at landing.
        for a, b in _runs(~stance[:, f]):
            i0, i1 = max(a - 1, 0), min(b, n - 1)  # the frames that bound the swing
            p0 = pos[i0, f] if a > 0 else foot_pos[i0, f]
            r0 = rot[i0, f] if a > 0 else foot_rot[i0, f]
            p1 = pos[i1, f] if b < n else foot_pos[i1, f]
            r1 = rot[i1, f] if b < n else foot_rot[i1, f]
            frames = np.arange(a, b)
            u = (frames - (a - 1)) / max(b - (a - 1), 1)
            s = _smootherstep(u)[:, None]
            window = np.sin(np.pi * u) ** 2  # source detail fades in after lift-off and out before touch-down
            mapped = foot_pos[frames, f]
            chord = foot_pos[i0, f] + s * (foot_pos[i1, f] - foot_pos[i0, f])
            path = p0 + s * (p1 - p0) + window[:, None] * (mapped - chord)
            base = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([r0, r1])))(s[:, 0])
            mapped_rot = Rotation.from_matrix(foot_rot[frames, f])
            chord_rot = Slerp([0.0, 1.0], Rotation.from_matrix(foot_rot[[i0, i1], f]))(s[:, 0])
            detail = (chord_rot.inv() * mapped_rot).as_rotvec() * window[:, None]
            rot[frames, f] = (base * Rotation.from_rotvec(detail)).as_matrix()
            # The sole leaves the floor at once and clears it: a swing foot never skims the ground.
            lowest = path[:, 2] + (np.einsum("nj,kj->nk", rot[frames, f, 2], sole[f]) - radius[f]).min(axis=1)
            path[:, 2] += np.maximum(0.0, clearance * np.sqrt(np.sin(np.pi * u)) - lowest)
            pos[frames, f] = path
    return FootTargets(pos, rot, stance)


def _sole_point_task():
    """A mink task pinning one point fixed in a body (the foot's contact point) to a world position."""
    import mink

    class SolePointTask(mink.Task):
        k = 3

        def __init__(self, model: mujoco.MjModel, body: str):
            super().__init__(cost=np.zeros(3), gain=1.0, lm_damping=0.0)
            self.body = model.body(body).id
            self.point = np.zeros(3)  # in the body frame
            self.target = np.zeros(3)  # in the world

        def world_point(self, configuration) -> np.ndarray:
            data = configuration.data
            return data.xpos[self.body] + data.xmat[self.body].reshape(3, 3) @ self.point

        def compute_error(self, configuration) -> np.ndarray:
            return self.world_point(configuration) - self.target

        def compute_jacobian(self, configuration) -> np.ndarray:
            jac = np.zeros((3, configuration.nv))
            mujoco.mj_jac(configuration.model, configuration.data, jac, None, self.world_point(configuration),
                          self.body)
            return jac

    return SolePointTask


def contact_points(rotation: np.ndarray, sole: np.ndarray, radius: np.ndarray, softness: float = 0.002,
                   ) -> np.ndarray:
    """The sole point a foot rests on, (N, feet, 3) in the foot frame: the average of its sole points weighted
    by a soft minimum of their height, so that it moves continuously from heel to flat foot to toes."""
    height = np.einsum("nfj,fkj->nfk", rotation[:, :, 2], sole) - radius[None]
    w = np.exp(-(height - height.min(axis=2, keepdims=True)) / softness)
    return np.einsum("nfk,fkj->nfj", w / w.sum(axis=2, keepdims=True), sole)


def track(model: mujoco.MjModel, qpos: np.ndarray, feet: tuple[str, ...], targets: FootTargets, sole: np.ndarray,
          radius: np.ndarray, settings: FootLockSettings) -> tuple[np.ndarray, float]:
    """Differential IK through the frames: each frame starts from the previous solution.

    A stance foot's contact point is pinned where its target pose puts it; its pose is a softer goal.
    Returns the solved ``qpos`` (N, nq) and the largest stance contact-point error (m).
    """
    import mink

    configuration = mink.Configuration(model, qpos[0])
    foot_tasks = [mink.FrameTask(b, "body", position_cost=1.0, orientation_cost=1.0) for b in feet]
    point_cls = _sole_point_task()
    point_tasks = [point_cls(model, b) for b in feet]
    root_body = model.body(int(model.jnt_bodyid[0])).name
    pelvis = mink.FrameTask(root_body, "body", position_cost=settings.pelvis_cost[0],
                            orientation_cost=settings.pelvis_cost[1])
    posture = mink.PostureTask(model, cost=settings.posture_cost)
    tasks = [*foot_tasks, *point_tasks, pelvis, posture]
    limits = [mink.ConfigurationLimit(model)]
    contact = contact_points(targets.rotation, sole, radius)
    contact_world = targets.position + np.einsum("nfij,nfj->nfi", targets.rotation, contact)
    out = np.empty_like(qpos)
    worst = 0.0
    for t in range(len(qpos)):
        for f, (task, point) in enumerate(zip(foot_tasks, point_tasks, strict=True)):
            stance = targets.stance[t, f]
            cost = settings.stance_cost if stance else settings.swing_cost
            task.set_position_cost(cost[0] / 100.0 if stance else cost[0])
            task.set_orientation_cost(cost[1])
            task.set_target(mink.SE3.from_rotation_and_translation(
                mink.SO3.from_matrix(targets.rotation[t, f]), targets.position[t, f]))
            point.cost[:] = cost[0] if stance else 0.0
            point.point, point.target = contact[t, f], contact_world[t, f]
        pelvis.set_target(mink.SE3.from_rotation_and_translation(mink.SO3(qpos[t, 3:7]), qpos[t, :3]))
        posture.set_target(qpos[t])
        stance_err = 0.0
        for _ in range(settings.max_iterations if t else 3 * settings.max_iterations):
            velocity = mink.solve_ik(configuration, tasks, 1.0, "daqp", damping=settings.damping, limits=limits)
            configuration.integrate_inplace(velocity, 1.0)
            stance_err = max((float(np.linalg.norm(p.compute_error(configuration)))
                              for p, st in zip(point_tasks, targets.stance[t], strict=True) if st), default=0.0)
            if stance_err < settings.tolerance:
                break
        worst = max(worst, stance_err)
        out[t] = configuration.q
    return out, worst
