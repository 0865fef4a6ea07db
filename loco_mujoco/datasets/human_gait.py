"""Human motion in anatomical terms: leg joint angles by meaning plus the pelvis path, from any human source.

Every human source (OpenSim coordinates, BVH or DeepMimic keypoints) becomes a :class:`HumanGait` at a common
frame rate; retargeting maps it onto a robot's joints by meaning. Angles are in radians with the anatomical
signs: hip flexion moves the thigh forward, adduction towards the midline, internal rotation turns the toes
in, knee flexion bends the knee, ankle dorsiflexion lifts the toes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import butter, filtfilt

from loco_mujoco.datasets.motion import Motion

LEG_ANGLES = ("hip_flexion", "hip_adduction", "hip_rotation", "knee_flexion", "ankle_dorsiflexion")
SIDES = ("l", "r")

# Which keypoints are hip, knee, ankle and toe for each keypoint skeleton.
_LEG_KEYPOINTS = {
    "bvh-cmu": {"l": ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase"),
                "r": ("RightUpLeg", "RightLeg", "RightFoot", "RightToeBase")},
    "deepmimic": {"l": ("left_hip", "left_knee", "left_ankle", "left_toe"),
                  "r": ("right_hip", "right_knee", "right_ankle", "right_toe")},
}
# Standing pelvis height of the OpenSim gait models (gait2392 / Hamner 2010), used to scale their motion.
OPENSIM_LEG_LENGTH = 0.93
# Hip yaw estimated from the foot heading is clipped here (rad); beyond it the estimate is noise.
MAX_HIP_YAW = 0.6


@dataclass
class HumanGait:
    """Anatomical leg angles ``angles[side][name]`` (N,), pelvis position (N, 3), heading and list (N,)."""

    name: str
    frequency: float
    angles: dict[str, dict[str, np.ndarray]]
    pelvis_pos: np.ndarray
    pelvis_yaw: np.ndarray
    pelvis_roll: np.ndarray
    leg_length: float
    source: str
    mirrored: bool = False

    @property
    def n_frames(self) -> int:
        return len(self.pelvis_pos)

    @property
    def duration(self) -> float:
        return (self.n_frames - 1) / self.frequency


def gait_from_motion(motion: Motion, frequency: float = 100.0, cutoff_hz: float = 8.0) -> HumanGait:
    """Anatomical gait of a human motion, resampled to ``frequency`` and low-pass filtered at ``cutoff_hz``."""
    if motion.skeleton == "opensim":
        gait = _gait_from_opensim(motion)
    elif motion.skeleton in _LEG_KEYPOINTS:
        gait = _gait_from_keypoints(motion, _LEG_KEYPOINTS[motion.skeleton])
    else:
        raise ValueError(f"{motion.source or motion.name}: skeleton {motion.skeleton!r} is not a human source; "
                         f"human skeletons are {sorted(['opensim', *_LEG_KEYPOINTS])}")
    return _resample(gait, motion.time, frequency, cutoff_hz)


def _gait_from_opensim(motion: Motion) -> HumanGait:
    knee_sign = float(motion.meta.get("knee_flexion_sign", 1.0))
    angles = {}
    for side in SIDES:
        angles[side] = {
            "hip_flexion": motion.angle(f"hip_flexion_{side}"),
            # About their clip medians, as for keypoint sources: no anatomical offsets on straight robot legs.
            "hip_adduction": _centered(motion.angle(f"hip_adduction_{side}")),
            "hip_rotation": _centered(motion.angle(f"hip_rotation_{side}")),
            "knee_flexion": knee_sign * motion.angle(f"knee_angle_{side}"),
            "ankle_dorsiflexion": motion.angle(f"ankle_angle_{side}"),
        }
    pelvis = motion.meta["pelvis"]
    return HumanGait(motion.name, motion.frequency, angles, motion.root_pos.copy(),
                     np.unwrap(pelvis["pelvis_rotation"]), pelvis["pelvis_list"], OPENSIM_LEG_LENGTH, motion.source)


def _centered(x: np.ndarray) -> np.ndarray:
    return x - np.median(x)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _rotate_z(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=1)


def _rotate_x(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([v[:, 0], c * v[:, 1] - s * v[:, 2], s * v[:, 1] + c * v[:, 2]], axis=1)


def _rotate_y(v: np.ndarray, angle: np.ndarray) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.stack([c * v[:, 0] + s * v[:, 2], v[:, 1], -s * v[:, 0] + c * v[:, 2]], axis=1)


def _gait_from_keypoints(motion: Motion, names: dict[str, tuple[str, str, str, str]]) -> HumanGait:
    """Angles from segment directions, decomposed in the yaw-roll-pitch order of a robot hip.

    The pelvis frame comes from the line between the hip joints (heading and list). Hip rotation is the
    foot's heading relative to the pelvis and hip adduction the thigh's list, both about their clip median
    so a subject's anatomical toe-out and thigh convergence are not copied onto a robot's straight legs.
    """
    kp = motion.keypoints
    lateral = kp[names["l"][0]] - kp[names["r"][0]]
    yaw = np.unwrap(np.arctan2(-lateral[:, 0], lateral[:, 1]))
    roll = np.arctan2(lateral[:, 2], np.linalg.norm(lateral[:, :2], axis=1))
    angles: dict[str, dict[str, np.ndarray]] = {}
    leg_lengths = []
    for side in SIDES:
        hip, knee, ankle, toe = (kp[n] for n in names[side])
        to_pelvis = (lambda v: _rotate_x(_rotate_z(v, -yaw), -roll))  # noqa: E731
        thigh, shank, foot = to_pelvis(knee - hip), to_pelvis(ankle - knee), to_pelvis(toe - ankle)
        leg_lengths.append(np.median(np.linalg.norm(knee - hip, axis=1) + np.linalg.norm(ankle - knee, axis=1)))
        rot_z = np.zeros(len(thigh))
        for _ in range(2):  # the foot's heading about the shank sets the hip yaw, which changes roll and pitch
            t = _unit(_rotate_z(thigh, -rot_z))
            rot_x = np.arctan2(t[:, 1], -t[:, 2])
            rot_y = np.arctan2(-t[:, 0], np.hypot(t[:, 1], t[:, 2]))
            knee_flex = np.arccos(np.clip(np.sum(_unit(thigh) * _unit(shank), axis=1), -1.0, 1.0))
            f = _rotate_y(_rotate_x(_rotate_z(foot, -rot_z), -rot_x), -(rot_y + knee_flex))
            foot_yaw = np.arctan2(f[:, 1], f[:, 0])
            rot_z = np.clip(rot_z + foot_yaw - np.median(foot_yaw), -MAX_HIP_YAW, MAX_HIP_YAW)
        rot_x = rot_x - np.median(rot_x)
        toe_down = np.arctan2(-f[:, 2], f[:, 0])
        # Neutral ankle: the foot's pitch while it is flat on the ground (the lowest 30% of ankle heights).
        flat = ankle[:, 2] <= np.quantile(ankle[:, 2], 0.3)
        dorsi = -(toe_down - np.median(toe_down[flat]) - np.median((rot_y + knee_flex)[flat]))
        sign = 1.0 if side == "r" else -1.0
        angles[side] = {
            "hip_flexion": -rot_y, "hip_adduction": sign * rot_x, "hip_rotation": sign * rot_z,
            "knee_flexion": knee_flex, "ankle_dorsiflexion": dorsi,
        }
    hips = 0.5 * (kp[names["l"][0]] + kp[names["r"][0]])
    leg = float(np.mean(leg_lengths)) + float(np.median(np.minimum(kp[names["l"][2]][:, 2], kp[names["r"][2]][:, 2])))
    return HumanGait(motion.name, motion.frequency, angles, hips, yaw, roll, leg, motion.source)


def _resample(gait: HumanGait, time: np.ndarray, frequency: float, cutoff_hz: float) -> HumanGait:
    """Low-pass filter at the source rate (zero phase), then cubic-interpolate onto a uniform grid."""
    src_rate = (len(time) - 1) / (time[-1] - time[0])
    new_time = np.arange(0.0, time[-1] - time[0] + 1e-9, 1.0 / frequency) + time[0]

    def smooth(x: np.ndarray) -> np.ndarray:
        if cutoff_hz < 0.5 * src_rate and len(x) > 27:
            b, a = butter(4, cutoff_hz / (0.5 * src_rate))
            x = filtfilt(b, a, x, axis=0)
        return CubicSpline(time, x, axis=0)(new_time)

    angles = {side: {k: smooth(v) for k, v in sides.items()} for side, sides in gait.angles.items()}
    return replace(gait, frequency=frequency, angles=angles, pelvis_pos=smooth(gait.pelvis_pos),
                   pelvis_yaw=smooth(gait.pelvis_yaw), pelvis_roll=smooth(gait.pelvis_roll))


def mirror(gait: HumanGait) -> HumanGait:
    """The left/right mirror image: sides swapped, lateral position, heading and list negated."""
    pos = gait.pelvis_pos * np.array([1.0, -1.0, 1.0])
    angles = {"l": dict(gait.angles["r"]), "r": dict(gait.angles["l"])}
    return replace(gait, name=f"{gait.name}_mirrored", angles=angles, pelvis_pos=pos, pelvis_yaw=-gait.pelvis_yaw,
                   pelvis_roll=-gait.pelvis_roll, mirrored=not gait.mirrored)
