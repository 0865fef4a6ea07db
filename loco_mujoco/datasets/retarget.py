"""Retargeting: human gait onto humanoid robots and quadruped motion onto quadrupeds, by joint meaning.

Joint angles are mapped by meaning (see :mod:`human_gait`), clipped to the robot's limits, and the root path
is rebuilt from the robot's own legs: its height puts the lowest foot on the ground (plus the source's
flight phases, scaled by leg length), and its horizontal motion is the odometry of the stance feet, so feet
do not slide while in contact and treadmill trials (no pelvis travel) move forward at the belt speed.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy.ndimage import percentile_filter, uniform_filter1d
from scipy.spatial.transform import Rotation

from loco_mujoco.datasets.foot_lock import FootLockSettings, foot_targets, is_walking, stance_phases, track
from loco_mujoco.datasets.human_gait import SIDES, HumanGait
from loco_mujoco.datasets.motion import Motion
from loco_mujoco.datasets.resample import resample_angles, resample_quat
from loco_mujoco.metrics.contacts import contact_figures, foot_contacts
from loco_mujoco.models.posture import apply_joint_couplings
from loco_mujoco.rotations import quat_to_mat

# A source's root must rise this far (m) above what its legs reach before the frame counts as flight.
FLIGHT_MARGIN = 0.025
ODOMETRY_SPEED_TOLERANCE = 0.5  # m/s: how far a stance foot's speed may stray from the body's before it is doubted

# Rotation axis (pelvis frame) and sign of each anatomical angle, per side: robot angle = angle * (axis . joint axis).
_ANATOMICAL_AXES = {
    "hip_flexion": {"l": (0, -1, 0), "r": (0, -1, 0)},
    "hip_adduction": {"l": (-1, 0, 0), "r": (1, 0, 0)},
    "hip_rotation": {"l": (0, 0, -1), "r": (0, 0, 1)},
    "knee_flexion": {"l": (0, 1, 0), "r": (0, 1, 0)},
    "ankle_dorsiflexion": {"l": (0, -1, 0), "r": (0, -1, 0)},
}


@dataclass(frozen=True)
class LegJoints:
    """A humanoid leg: the joint playing each anatomical role, and the body whose geoms form the sole."""

    hip_rotation: str
    hip_adduction: str
    hip_flexion: str
    knee_flexion: str
    ankle_dorsiflexion: str
    foot_body: str
    ankle_roll: str | None = None


@dataclass(frozen=True)
class HumanoidRetarget:
    """How human gait maps onto a humanoid: its legs, and how close a foot must be to the ground to be in contact."""

    legs: dict[str, LegJoints]
    contact_height: float = 0.01


@dataclass(frozen=True)
class QuadrupedRetarget:
    """How a quadruped motion maps onto a quadruped: joint names pass through, feet by body."""

    feet: tuple[str, ...]
    contact_height: float = 0.02


@dataclass
class RetargetedMotion:
    """One trajectory on a robot: full-model ``qpos`` (N, nq) and ``qvel`` (N, nv) at ``frequency``."""

    name: str
    qpos: np.ndarray
    qvel: np.ndarray
    frequency: float
    quality: dict[str, float]
    source: str


class _Feet:
    """Sole points of each foot (collision geoms of the foot body and its descendants, e.g. toes, as points with
    radii) and vectorised foot kinematics."""

    def __init__(self, model: mujoco.MjModel, bodies: tuple[str, ...]):
        self.model = model
        foot_ids = [model.body(b).id for b in bodies]
        owner = {}  # body id -> index of the foot whose subtree holds it
        for b in range(model.nbody):
            a = b
            while a > 0 and a not in foot_ids:
                a = int(model.body_parentid[a])
            if a in foot_ids:
                owner[b] = foot_ids.index(a)
        points: list[list[np.ndarray]] = [[] for _ in bodies]
        radii: list[list[float]] = [[] for _ in bodies]
        point_bodies: list[list[int]] = [[] for _ in bodies]
        for g in range(model.ngeom):
            b = int(model.geom_bodyid[g])
            if b not in owner or not (model.geom_contype[g] or model.geom_conaffinity[g]):
                continue
            f = owner[b]
            pts, rad = _geom_points(model, g)
            points[f].extend(pts)
            radii[f].extend([rad] * len(pts))
            point_bodies[f].extend([b] * len(pts))
        if not all(points):
            missing = [b for b, p in zip(bodies, points, strict=False) if not p]
            raise ValueError(f"feet {missing} have no collision geoms to stand on")
        width = max(len(p) for p in points)
        # Pad with copies of the first point so every foot has the same number of points.
        self.points = np.stack([np.array(p + [p[0]] * (width - len(p))) for p in points])
        self.radii = np.stack([np.array(r + [r[0]] * (width - len(r))) for r in radii])
        self.point_bodies = np.stack([np.array(pb + [pb[0]] * (width - len(pb))) for pb in point_bodies])

    def body_poses(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every body's world position (N, nbody, 3) and rotation (N, nbody, 3, 3) at each configuration."""
        data = mujoco.MjData(self.model)
        n = len(qpos)
        xpos = np.empty((n, self.model.nbody, 3))
        xmat = np.empty((n, self.model.nbody, 3, 3))
        for t in range(n):
            data.qpos[:] = qpos[t]
            mujoco.mj_kinematics(self.model, data)
            xpos[t] = data.xpos
            xmat[t] = data.xmat.reshape(-1, 3, 3)
        return xpos, xmat

    def sole_points(self, qpos: np.ndarray, poses: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """World positions of the sole points, (N, feet, points, 3), with the radius taken off z."""
        xpos, xmat = self.body_poses(qpos) if poses is None else poses
        pb = self.point_bodies
        pts = xpos[:, pb] + np.einsum("tfkij,fkj->tfki", xmat[:, pb], self.points)
        pts[..., 2] -= self.radii[None]
        return pts


def _geom_points(model: mujoco.MjModel, g: int) -> tuple[list[np.ndarray], float]:
    """Points (in the body frame) and a radius whose swept spheres bound a geom from below."""
    size, kind = model.geom_size[g], model.geom_type[g]
    rot = quat_to_mat(model.geom_quat[g])
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        local, radius = [np.zeros(3)], size[0]
    elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        local, radius = [np.array([0, 0, s * size[1]]) for s in (-1, 1)], size[0]
    elif kind == mujoco.mjtGeom.mjGEOM_BOX:
        local = [np.array([a, b, c]) * size for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)]
        radius = 0.0
    elif kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:  # surface points along 98 directions (mm-accurate lowest point)
        grid = np.array([[a, b, c] for a in (-1, -0.5, 0, 0.5, 1) for b in (-1, -0.5, 0, 0.5, 1)
                         for c in (-1, -0.5, 0, 0.5, 1) if (a, b, c) != (0, 0, 0)])
        dirs = np.unique(grid / np.linalg.norm(grid, axis=1, keepdims=True), axis=0)
        local, radius = list(dirs * size), 0.0
    elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        ang = np.linspace(0, 2 * np.pi, 16, endpoint=False)
        local = [np.array([size[0] * np.cos(a), size[0] * np.sin(a), s * size[1]]) for a in ang for s in (-1, 1)]
        radius = 0.0
    elif kind == mujoco.mjtGeom.mjGEOM_MESH:
        mesh = model.geom_dataid[g]
        start, count = model.mesh_vertadr[mesh], model.mesh_vertnum[mesh]
        verts = model.mesh_vert[start:start + count]
        # Keep the lowest vertices in the body frame at rest: the sole.
        body_verts = verts @ rot.T + model.geom_pos[g]
        keep = body_verts[:, 2] <= body_verts[:, 2].min() + 0.02
        return list(body_verts[keep]), 0.0
    else:
        raise ValueError(f"geom {model.geom(g).name or g} of type {kind} cannot be a foot")
    return [rot @ p + model.geom_pos[g] for p in local], float(radius)


def joint_axes(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    """Each hinge's axis in the root frame with every joint at zero and the root at identity."""
    data = mujoco.MjData(model)
    data.qpos[:] = 0
    data.qpos[3] = 1.0
    mujoco.mj_kinematics(model, data)
    return {model.joint(j).name: data.xaxis[j].copy() for j in range(model.njnt)
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE}


def _joint_limits(model: mujoco.MjModel, name: str) -> tuple[int, float, float]:
    j = model.joint(name)
    lo, hi = (j.range if model.jnt_limited[j.id] else (-np.inf, np.inf))
    return int(model.jnt_qposadr[j.id]), float(lo), float(hi)


def retarget_human(gait: HumanGait, model: mujoco.MjModel, spec: HumanoidRetarget, base_qpos: np.ndarray,
                   foot_lock: bool = True, walk: bool | None = None,
                   lock_settings: FootLockSettings | None = None) -> RetargetedMotion:
    """Map a human gait onto a humanoid; joints not in the legs keep ``base_qpos`` (the home pose).

    With ``foot_lock`` the legs are then solved by inverse kinematics so that stance feet do not slide (see
    :mod:`foot_lock`); ``walk`` (default: decided from the Froude number) forbids flight phases.
    """
    n = gait.n_frames
    qpos = np.tile(base_qpos, (n, 1))
    axes = joint_axes(model)
    clipped = total = 0
    for side in SIDES:
        leg = spec.legs[side]
        for role, axis_by_side in _ANATOMICAL_AXES.items():
            joint = getattr(leg, role)
            alignment = float(np.dot(axes[joint], axis_by_side[side]))
            if abs(alignment) < 0.9:
                raise ValueError(f"joint {joint} (axis {axes[joint].round(2)}) does not rotate about the "
                                 f"{role} axis {axis_by_side[side]}")
            adr, lo, hi = _joint_limits(model, joint)
            value = np.sign(alignment) * gait.angles[side][role]
            clipped += int(np.sum((value < lo) | (value > hi)))
            total += n
            qpos[:, adr] = np.clip(value, lo, hi)
        if leg.ankle_roll is not None:  # keep the sole parallel to the pelvis: undo the hip's roll
            sign = 1.0 if side == "r" else -1.0
            alignment = float(np.dot(axes[leg.ankle_roll], (1, 0, 0)))
            adr, lo, hi = _joint_limits(model, leg.ankle_roll)
            qpos[:, adr] = np.clip(-np.sign(alignment) * sign * gait.angles[side]["hip_adduction"], lo, hi)
    qpos = apply_joint_couplings(model, qpos)
    rot = Rotation.from_euler("ZX", np.stack([gait.pelvis_yaw, gait.pelvis_roll], axis=1))
    qpos[:, 3:7] = rot.as_quat()[:, [3, 0, 1, 2]]
    foot_bodies = tuple(spec.legs[s].foot_body for s in SIDES)
    feet = _Feet(model, foot_bodies)
    robot_leg = _standing_root_height(model, feet, base_qpos)
    scale = robot_leg / gait.leg_length
    # the flight margin is a length of the human body: it scales with the robot's legs like the motion does
    source_z = scale * gait.pelvis_pos[:, 2]
    mapped = _ground_and_odometry(qpos, feet, source_z, gait.frequency, spec.contact_height,
                                  FLIGHT_MARGIN * scale)
    walking = is_walking(travel_speed(mapped, gait.frequency), robot_leg) if walk is None else walk
    if walking:  # people do not fly when they walk: the root stays on the legs
        mapped = _ground_and_odometry(qpos, feet, source_z, gait.frequency, spec.contact_height, np.inf)
    worst = None
    if foot_lock:
        qpos, worst = _lock_feet(model, mapped, feet, foot_bodies, gait.frequency, walking, scale, lock_settings)
    else:
        qpos = mapped
    quality = motion_quality(qpos, feet, gait.frequency, spec.contact_height)
    if worst is not None:
        quality["foot_lock_error_max_m"] = worst
    quality["walking"] = float(walking)
    quality["joint_limit_clipped_fraction"] = clipped / max(total, 1)
    quality["leg_length_scale"] = scale
    qvel = velocities(model, qpos, gait.frequency)
    return RetargetedMotion(gait.name, qpos, qvel, gait.frequency, quality, gait.source)


def retarget_quadruped(motion: Motion, model: mujoco.MjModel, spec: QuadrupedRetarget, base_qpos: np.ndarray,
                       frequency: float = 100.0) -> RetargetedMotion:
    """Put a quadruped motion whose joint names are the robot's onto the robot, re-grounded, at ``frequency``."""
    time = np.arange(0.0, motion.duration + 1e-9, 1.0 / frequency) + motion.time[0]
    n = len(time)
    qpos = np.tile(base_qpos, (n, 1))
    angles = resample_angles(motion.time, motion.joint_angles, time)
    clipped = 0
    for i, name in enumerate(motion.joint_names):
        adr, lo, hi = _joint_limits(model, name)
        clipped += int(np.sum((angles[:, i] < lo) | (angles[:, i] > hi)))
        qpos[:, adr] = np.clip(angles[:, i], lo, hi)
    qpos[:, 3:7] = resample_quat(motion.time, motion.root_quat, time)
    root_z = resample_angles(motion.time, motion.root_pos[:, 2:3], time)[:, 0]
    feet = _Feet(model, spec.feet)
    qpos = _ground_and_odometry(qpos, feet, root_z, frequency, spec.contact_height)
    quality = motion_quality(qpos, feet, frequency, spec.contact_height)
    quality["joint_limit_clipped_fraction"] = clipped / max(n * len(motion.joint_names), 1)
    quality["leg_length_scale"] = 1.0
    qvel = velocities(model, qpos, frequency)
    return RetargetedMotion(motion.name, qpos, qvel, frequency, quality, motion.source)


def _standing_root_height(model: mujoco.MjModel, feet: _Feet, base_qpos: np.ndarray) -> float:
    """Root height with every leg joint at zero (legs straight) and the lowest sole point on the ground."""
    q = base_qpos.copy()
    q[7:] = 0.0
    q[:3] = 0.0
    q[3:7] = (1, 0, 0, 0)
    return float(-feet.sole_points(q[None])[..., 2].min())


def _ground_and_odometry(qpos: np.ndarray, feet: _Feet, source_root_z: np.ndarray, frequency: float,
                         contact_height: float, flight_margin: float = FLIGHT_MARGIN) -> np.ndarray:
    """Set the root position from the legs: lowest foot on the ground, flight from the source, stance odometry."""
    dt = 1.0 / frequency
    qpos = qpos.copy()
    qpos[:, :3] = 0.0
    rel = feet.sole_points(qpos)  # root at the origin: positions relative to the root, world-oriented
    foot_low = rel[..., 2].min(axis=2)  # (N, feet)
    z_kin = -foot_low.min(axis=1)
    # Flight: the source root rises above what its legs reach. Measure against a 1 s lower envelope.
    excess = source_root_z - z_kin
    window = max(3, int(round(frequency)))
    envelope = percentile_filter(excess, 10, size=window, mode="nearest")
    lift = np.maximum(0.0, excess - envelope - flight_margin)
    root_z = z_kin + lift
    ground = root_z[:, None] + foot_low  # each foot's height above the ground
    contact = foot_contacts(ground, contact_height)
    lowest = rel[..., 2].argmin(axis=2)  # (N, feet): the lowest sole point is where the foot touches
    vel_rel = np.gradient(rel[..., :2], dt, axis=0)
    idx = np.arange(len(qpos))[:, None]
    contact_vel = vel_rel[idx, np.arange(rel.shape[1])[None], lowest]  # (N, feet, 2)
    # Odometry trusts the feet nearest the ground most: a foot just touching down or lifting off still moves.
    height_w = contact * np.exp(-(ground - ground.min(axis=1, keepdims=True)) / 0.003)
    has_contact = height_w.sum(axis=1) > 0
    if not has_contact.any():
        raise ValueError("no foot ever touches the ground; cannot place the root")
    root_v = _weighted_root_velocity(contact_vel, height_w, has_contact)
    # Second pass: a planted foot moves against the body at the body's speed. A swinging foot that skims the
    # floor does not, so weight each foot by how well it agrees with the smoothed first estimate.
    smooth = uniform_filter1d(root_v, size=max(3, int(round(0.3 * frequency))), axis=0, mode="nearest")
    mismatch = np.linalg.norm(contact_vel + smooth[:, None, :], axis=2)
    agree_w = height_w * np.exp(-((mismatch / ODOMETRY_SPEED_TOLERANCE) ** 2))
    usable = agree_w.sum(axis=1) > 1e-6 * height_w.sum(axis=1)
    root_v = np.where(usable[:, None], _weighted_root_velocity(contact_vel, np.where(usable[:, None], agree_w,
                                                                                      height_w), has_contact),
                      root_v)
    root_xy = np.concatenate([np.zeros((1, 2)), np.cumsum(0.5 * (root_v[1:] + root_v[:-1]) * dt, axis=0)])
    qpos[:, :2] = root_xy
    qpos[:, 2] = root_z
    return qpos


def _travel(qpos: np.ndarray, frequency: float) -> tuple[np.ndarray, int]:
    """The root's displacement velocity over 1 s (the whole clip if shorter), so that the sway within a stride
    is not speed, and the half window in frames."""
    half = max(1, min(int(round(frequency / 2)), (len(qpos) - 1) // 2))
    return (qpos[2 * half:, :2] - qpos[:-2 * half, :2]) / (2 * half * (1.0 / frequency)), half


def travel_speed(qpos: np.ndarray, frequency: float) -> float:
    """Mean speed of the root's travel (see :func:`_travel`), m/s."""
    return float(np.mean(np.linalg.norm(_travel(qpos, frequency)[0], axis=1)))


def motion_quality(qpos: np.ndarray, feet: _Feet, frequency: float, contact_height: float) -> dict[str, float]:
    """Contact figures of a trajectory on a flat floor at z = 0.

    A foot is in contact when its lowest sole point is within ``contact_height`` of the floor (no speed term);
    sliding is the horizontal speed of that point then. Forward speed is the root's velocity along its heading;
    speed and travel-forward speed are those of its displacement over 1 s (the sway within a stride is not
    travel), the latter along the heading smoothed over 1 s; the heading change is that heading's range (deg).
    """
    dt = 1.0 / frequency
    pts = feet.sole_points(qpos)  # (N, feet, points, 3)
    lowest = pts[..., 2].argmin(axis=2)
    vel = np.gradient(pts[..., :2], dt, axis=0)
    contact_vel = vel[np.arange(len(qpos))[:, None], np.arange(pts.shape[1])[None], lowest]
    root_v = np.gradient(qpos[:, :2], dt, axis=0)
    heading = Rotation.from_quat(qpos[:, [4, 5, 6, 3]]).apply([1.0, 0.0, 0.0])[:, :2]
    yaw = uniform_filter1d(np.unwrap(np.arctan2(heading[:, 1], heading[:, 0])), size=max(1, int(round(frequency))),
                           mode="nearest")
    heading /= np.linalg.norm(heading, axis=1, keepdims=True)
    travel, half = _travel(qpos, frequency)
    along = np.stack([np.cos(yaw[half:len(qpos) - half]), np.sin(yaw[half:len(qpos) - half])], axis=1)
    return {
        **contact_figures(pts[..., 2].min(axis=2), contact_vel, contact_height),
        "mean_forward_speed_mps": float(np.mean(np.sum(root_v * heading, axis=1))),
        "mean_speed_mps": travel_speed(qpos, frequency),
        "mean_travel_forward_mps": float(np.mean(np.sum(travel * along, axis=1))),
        "heading_change_deg": float(np.degrees(yaw.max() - yaw.min())),
    }


def _zero_pose_feet(model: mujoco.MjModel, feet: _Feet, foot_ids: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Each foot body's rotation with all joints at zero and the root upright (its sole then lies flat), and the
    centres of its sole spheres (radius ``feet.radii``) in its own frame, (feet, K, 3)."""
    q = np.zeros(model.nq)
    q[3] = 1.0
    xpos, xmat = feet.body_poses(q[None])
    centres = feet.sole_points(q[None], (xpos, xmat))[0]  # (feet, K, 3), world, radius taken off z
    centres[..., 2] += feet.radii
    rot = xmat[0, foot_ids]
    return rot, np.einsum("fji,fkj->fki", rot, centres - xpos[0, foot_ids][:, None])


def _lock_feet(model: mujoco.MjModel, qpos: np.ndarray, feet: _Feet, foot_bodies: tuple[str, ...], frequency: float,
               walking: bool, scale: float, settings: FootLockSettings | None) -> tuple[np.ndarray, float]:
    """Stance phases, anchored foot targets and the IK that meets them (see :mod:`foot_lock`)."""
    settings = settings or FootLockSettings()
    foot_ids = [model.body(b).id for b in foot_bodies]
    xpos, xmat = feet.body_poses(qpos)
    pts = feet.sole_points(qpos, (xpos, xmat))
    height = pts[..., 2].min(axis=2)
    lowest = pts[..., 2].argmin(axis=2)
    vel = np.gradient(pts[..., :2], 1.0 / frequency, axis=0)
    speed = np.linalg.norm(vel[np.arange(len(qpos))[:, None], np.arange(pts.shape[1])[None], lowest], axis=2)
    stance = stance_phases(height, speed, frequency, walking, settings, scale)
    flat_rot, sole = _zero_pose_feet(model, feet, foot_ids)
    targets = foot_targets(xpos[:, foot_ids], xmat[:, foot_ids], stance, flat_rot, sole, feet.radii,
                           settings.swing_clearance * scale)
    # The pelvis moves with the stance feet: by how far their anchors lie from where the mapping put them.
    shift = np.where(stance[..., None], targets.position[..., :2] - xpos[:, foot_ids, :2], 0.0).sum(axis=1)
    count = stance.sum(axis=1)
    frames = np.arange(len(qpos))
    prior = qpos.copy()
    for k in range(2):
        shift[:, k] = np.interp(frames, frames[count > 0], shift[count > 0, k] / count[count > 0])
    prior[:, :2] += uniform_filter1d(shift, size=max(1, int(round(0.2 * frequency))), axis=0, mode="nearest")
    solved, worst = track(model, prior, foot_bodies, targets, sole, feet.radii, settings)
    # Where the legs could not meet their targets, a sole may dip into the floor: lift the body out of it.
    solved[:, 2] += np.maximum(0.0, -feet.sole_points(solved)[..., 2].min(axis=(1, 2)))
    return solved, worst


def _weighted_root_velocity(contact_vel: np.ndarray, weights: np.ndarray, has_contact: np.ndarray) -> np.ndarray:
    """Root velocity as minus the weighted contact-point velocity; flight frames interpolated between stances."""
    root_v = np.full((len(contact_vel), 2), np.nan)
    w = weights[has_contact]
    root_v[has_contact] = -(contact_vel[has_contact] * w[:, :, None]).sum(axis=1) / w.sum(axis=1, keepdims=True)
    frames = np.arange(len(contact_vel))
    for k in range(2):  # flight: constant-velocity interpolation between stance phases
        root_v[~has_contact, k] = np.interp(frames[~has_contact], frames[has_contact], root_v[has_contact, k])
    return root_v


def velocities(model: mujoco.MjModel, qpos: np.ndarray, frequency: float) -> np.ndarray:
    """Joint velocities by central differences on the configuration manifold (one-sided at the ends)."""
    n = len(qpos)
    qvel = np.empty((n, model.nv))
    dt = 1.0 / frequency
    for t in range(n):
        a, b = max(t - 1, 0), min(t + 1, n - 1)
        mujoco.mj_differentiatePos(model, qvel[t], (b - a) * dt, qpos[a], qpos[b])
    return qvel
