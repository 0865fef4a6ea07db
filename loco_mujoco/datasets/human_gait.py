"""Human motion in anatomical terms: leg joint angles by meaning plus the pelvis path, from any human source.

Every human source (OpenSim coordinates or ``.trc`` surface markers, BVH or DeepMimic keypoints) becomes a
:class:`HumanGait` at a common frame rate; retargeting maps it onto a robot's joints by meaning. Angles are in
radians with the anatomical signs: hip flexion moves the thigh forward, adduction towards the midline, internal
rotation turns the toes in, knee flexion bends the knee, ankle dorsiflexion lifts the toes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import butter, filtfilt

from loco_mujoco.datasets.motion import Motion, MotionFormatError

LEG_ANGLES = ("hip_flexion", "hip_adduction", "hip_rotation", "knee_flexion", "ankle_dorsiflexion")
SIDES = ("l", "r")

# Which keypoints are hip, knee, ankle and toe for each keypoint skeleton.
_LEG_KEYPOINTS = {
    "bvh-cmu": {"l": ("LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase"),
                "r": ("RightUpLeg", "RightLeg", "RightFoot", "RightToeBase")},
    "deepmimic": {"l": ("left_hip", "left_knee", "left_ankle", "left_toe"),
                  "r": ("right_hip", "right_knee", "right_ankle", "right_toe")},
}
# Surface markers of the OpenSim example gait protocol (``.trc``): joint centres are estimated from them first
# (:func:`marker_joint_centres`) under these keypoint names.
MARKER_SKELETON = "opensim-markers"
_JOINT_CENTRES = {side: tuple(f"{side}_{joint}" for joint in ("hip", "knee", "ankle", "toe")) for side in SIDES}
_PELVIS_MARKERS = ("R.ASIS", "L.ASIS", "V.Sacral")
_THIGH_MARKERS = ("Thigh.Upper", "Thigh.Front", "Thigh.Rear")
_SHANK_MARKERS = ("Shank.Upper", "Shank.Front", "Shank.Rear")
_FOOT_MARKERS = ("Heel", "Midfoot.Sup", "Toe.Lat", "Toe.Med")
# A functional knee centre needs the knee to bend: the smallest singular value that locates it must reach this
# fraction of the largest (about 16 deg of sinusoidal knee range; walking gives 0.18); a static trial cannot.
MIN_KNEE_MOTION = 0.05
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
    elif motion.skeleton == MARKER_SKELETON:
        gait = _gait_from_keypoints(replace(motion, keypoints=marker_joint_centres(motion)), _JOINT_CENTRES)
    elif motion.skeleton in _LEG_KEYPOINTS:
        gait = _gait_from_keypoints(motion, _LEG_KEYPOINTS[motion.skeleton])
    else:
        raise ValueError(f"{motion.source or motion.name}: skeleton {motion.skeleton!r} is not a human source; "
                         f"human skeletons are {sorted(['opensim', MARKER_SKELETON, *_LEG_KEYPOINTS])}")
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


def marker_joint_centres(motion: Motion) -> dict[str, np.ndarray]:
    """Hip, knee, ankle and toe centres ``{side}_{joint}`` (N, 3) estimated from OpenSim gait surface markers.

    - hip: the Harrington et al. (2007) regression from the pelvis markers (:func:`_hip_centres`);
    - ankle: midway between the Heel and Midfoot.Sup markers (:func:`_ankle_centre`);
    - knee: the functional knee axis of the thigh and shank marker clusters (SCoRE/SARA, Ehrig et al. 2006,
      2007), at the point of that axis nearest the hip-ankle line (:func:`_knee_centre`);
    - toe: the forefoot, midway between the Toe.Lat and Toe.Med markers (metatarsal heads), so that toe
      bending at push-off does not read as ankle motion.
    """
    leg_markers = (*_THIGH_MARKERS, *_SHANK_MARKERS, *_FOOT_MARKERS)
    _require_markers(motion, [*_PELVIS_MARKERS, *(f"{s}.{m}" for s in "RL" for m in leg_markers)])
    kp = motion.keypoints
    hips = _hip_centres(kp["R.ASIS"], kp["L.ASIS"], kp["V.Sacral"])
    centres = {}
    for side, prefix, word in (("r", "R.", "right"), ("l", "L.", "left")):
        try:
            knee, ankle, toe = _leg_centres({m: kp[prefix + m] for m in leg_markers}, hips[side])
        except ValueError as err:
            raise MotionFormatError(motion.source or motion.name, f"{word} knee: {err}") from None
        centres.update({f"{side}_hip": hips[side], f"{side}_knee": knee, f"{side}_ankle": ankle, f"{side}_toe": toe})
    return centres


def _leg_centres(marker: dict[str, np.ndarray], hip: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Knee, ankle and toe centres of one leg from its markers (names without the side prefix)."""
    ankle = _ankle_centre(marker["Heel"], marker["Midfoot.Sup"])
    thigh = _rigid_frames([marker[m] for m in _THIGH_MARKERS])
    shank = _rigid_frames([marker[m] for m in _SHANK_MARKERS])
    knee = _knee_centre(thigh, shank, hip, ankle)
    return knee, ankle, 0.5 * (marker["Toe.Lat"] + marker["Toe.Med"])


def _require_markers(motion: Motion, names: list[str]) -> None:
    missing = [n for n in names if n not in motion.keypoints]
    if missing:
        raise MotionFormatError(motion.source or motion.name, f"missing marker(s) {missing} needed to estimate "
                                "the leg joint centres")


def _hip_centres(r_asis: np.ndarray, l_asis: np.ndarray, sacral: np.ndarray) -> dict[str, np.ndarray]:
    """Hip joint centres by the Harrington et al. (2007, J Biomech 40:595) regression, in metres.

    Pelvis frame at the mid-ASIS point: y to the left along the ASIS line, x forward (from the sacral marker,
    which stands in for the mid-PSIS point, made normal to y), z up. With pelvis width PW (inter-ASIS distance)
    and depth PD (mid-ASIS to sacral marker): x = -0.24 PD - 9.9 mm, z = -0.30 PW - 10.9 mm,
    y = +-(0.33 PW + 7.3 mm). PW and PD are the clip medians: one subject, one pelvis.
    """
    mid = 0.5 * (r_asis + l_asis)
    y = _unit(l_asis - r_asis)
    back = mid - sacral
    x = _unit(back - np.sum(back * y, axis=1, keepdims=True) * y)
    z = np.cross(x, y)
    width = float(np.median(np.linalg.norm(l_asis - r_asis, axis=1)))
    depth = float(np.median(np.linalg.norm(back, axis=1)))
    forward, up, lateral = -0.24 * depth - 0.0099, -0.30 * width - 0.0109, 0.33 * width + 0.0073
    return {side: mid + forward * x + sign * lateral * y + up * z for side, sign in (("l", 1.0), ("r", -1.0))}


def _ankle_centre(heel: np.ndarray, midfoot_sup: np.ndarray) -> np.ndarray:
    """The ankle (talocrural) centre, taken midway between the Heel and Midfoot.Sup markers.

    Without malleolus markers this is an anatomical approximation: the talus sits between the calcaneal
    tuberosity and the navicular. On the walk_free trials the point lies 7-8 cm in front of the heel marker
    (about a quarter of the 0.28 m foot) and 7.7-8.0 cm above the floor with the foot flat, close to the
    malleolus height of 0.039 x body height (Winter 2009) for this 1.8 m subject. It moves with the foot, so the
    ankle-to-toe vector is rigid in the foot and gives the ankle angle directly.
    """
    return 0.5 * (heel + midfoot_sup)


def _rigid_frames(markers: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (N, 3, 3) and origin (N, 3) of a marker cluster: the least-squares rigid motion (Kabsch) of its
    first-frame shape about its centroid."""
    points = np.stack(markers, axis=1)  # (N, M, 3)
    origin = points.mean(axis=1)
    rel = points - origin[:, None]
    cov = np.einsum("mi,nmj->nij", rel[0], rel)  # sum_m ref_m q_m^T
    u, _, vt = np.linalg.svd(cov)
    flip = np.sign(np.linalg.det(u @ vt))
    vt[:, 2] *= flip[:, None]  # a proper rotation, not a reflection
    return np.transpose(u @ vt, (0, 2, 1)), origin


def _knee_centre(thigh: tuple[np.ndarray, np.ndarray], shank: tuple[np.ndarray, np.ndarray], hip: np.ndarray,
                 ankle: np.ndarray) -> np.ndarray:
    """The knee centre from the thigh and shank cluster frames, by the functional SCoRE/SARA fit.

    SCoRE (Ehrig et al. 2006, J Biomech 39:2798) finds the point fixed in both segments: ``R_t c_t + o_t =
    R_s c_s + o_s`` for every frame, a linear least-squares problem in (c_t, c_s). The knee is nearly a hinge,
    so that system has one near-null direction: the knee axis in both segments (SARA, Ehrig et al. 2007,
    J Biomech 40:2150). The least-squares solution without that direction fixes the point up to a shift along
    the axis; the shift puts the knee nearest the hip-ankle line (median over the clip), so the leg is straight
    in the frontal plane as a robot's is, instead of the knee sitting out at the lateral thigh clusters.
    """
    (rot_t, org_t), (rot_s, org_s) = thigh, shank
    system = np.concatenate([rot_t, -rot_s], axis=2).reshape(-1, 6)
    u, sv, vt = np.linalg.svd(system, full_matrices=False)
    if sv[4] < MIN_KNEE_MOTION * sv[0]:
        raise ValueError(f"too little knee motion to locate the knee functionally (singular values "
                         f"{np.round(sv, 3).tolist()})")
    local = vt[:5].T @ ((u[:, :5].T @ (org_s - org_t).reshape(-1)) / sv[:5])
    axis = vt[5]

    def world(c: np.ndarray) -> np.ndarray:
        return 0.5 * (np.einsum("nij,j->ni", rot_t, c[:3]) + org_t + np.einsum("nij,j->ni", rot_s, c[3:]) + org_s)

    point, direction = world(local), world(axis) - world(np.zeros(6))
    shift = float(np.median(_closest_on_line(point, direction, hip, ankle - hip)))
    return world(local + shift * axis)


def _closest_on_line(p: np.ndarray, d: np.ndarray, q: np.ndarray, e: np.ndarray) -> np.ndarray:
    """Per frame, the ``t`` for which ``p + t d`` is nearest the line ``q + s e``."""
    w = p - q
    dd, de, ee = np.sum(d * d, axis=1), np.sum(d * e, axis=1), np.sum(e * e, axis=1)
    dw, ew = np.sum(d * w, axis=1), np.sum(e * w, axis=1)
    return (de * ew - ee * dw) / (dd * ee - de * de)


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
