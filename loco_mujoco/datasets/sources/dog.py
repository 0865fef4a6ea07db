"""Dog motion capture: raw keypoint text files and their Unitree A1 retargets (AMP JSON) to :class:`Motion`.

Both sources are CC BY-NC 4.0 (AI4Animation dog mocap): datasets built from them are non-commercial.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from loco_mujoco.datasets.motion import Y_UP_TO_Z_UP, Motion, MotionFormatError, is_float
from loco_mujoco.rotations import continuous, mat_to_quat

N_KEYPOINTS = 27
DOG_KEYPOINTS = {0: "pelvis", 3: "neck", 6: "left_shoulder", 10: "left_front_toe", 11: "right_shoulder",
                 15: "right_front_toe", 16: "left_hip", 19: "left_hind_toe", 20: "right_hip", 23: "right_hind_toe"}
KEYPOINT_NAMES = tuple(DOG_KEYPOINTS.get(i, f"kp{i}") for i in range(N_KEYPOINTS))
A1_JOINTS = tuple(f"{leg}_{part}_joint" for leg in ("FR", "FL", "RR", "RL") for part in ("hip", "thigh", "calf"))
# AMP_for_hardware frame layout (rsl_rl/datasets/motion_loader.py): 61 values per frame.
_A1_LAYOUT = {"root_pos": (0, 3), "root_quat_xyzw": (3, 7), "joints": (7, 19), "toe_pos_local_raw": (19, 31),
              "root_lin_vel_local": (31, 34), "root_ang_vel_local": (34, 37), "joint_vel": (37, 49),
              "toe_vel_local_raw": (49, 61)}
A1_FRAME_SIZE = 61


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _clip_info(path: Path) -> dict | None:
    """Trim frames of this clip from ``dog_clips_info.txt`` next to it (first ``(n)`` = start, second = end)."""
    info = path.with_name("dog_clips_info.txt")
    clip = path.stem.removesuffix("_joint_pos")
    if not info.is_file():
        return None
    for line in info.read_text(encoding="utf-8").splitlines():
        tokens = line.split()
        if len(tokens) >= 2 and tokens[1] == clip:
            frames = [int(f) for f in re.findall(r"\((\d+)\)", line)]
            return {"original_name": tokens[0].rstrip("*"), "trim_start_frame": frames[0] if frames else None,
                    "trim_end_frame": frames[1] if len(frames) > 1 else None}
    return None


def _trunk_quat(path: Path, kp: dict[str, np.ndarray]) -> np.ndarray:
    """Trunk frame: x from pelvis to neck, y towards the left shoulder/hip (orthogonalised), z = x cross y."""
    x = kp["neck"] - kp["pelvis"]
    left = 0.5 * (_unit(kp["left_shoulder"] - kp["right_shoulder"]) + _unit(kp["left_hip"] - kp["right_hip"]))
    y = left - np.sum(left * _unit(x), axis=1, keepdims=True) * _unit(x)
    bad = np.flatnonzero((np.linalg.norm(x, axis=1) < 1e-6) | (np.linalg.norm(y, axis=1) < 1e-6))
    if len(bad):
        raise MotionFormatError(path, f"degenerate trunk frame (coincident keypoints) in row {bad[0] + 1}")
    x, y = _unit(x), _unit(y)
    mats = np.stack([x, y, np.cross(x, y)], axis=2)
    return continuous(mat_to_quat(mats))


def load_dog_keypoints(path: str | Path, frequency: float = 60.0) -> Motion:
    """Parse a dog keypoint file (27 x xyz per line, metres, Y-up) into a Z-up :class:`Motion`."""
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise MotionFormatError(path, f"cannot read file: {err}") from err
    rows = []
    for k, line in enumerate((ln for ln in lines if ln.strip()), start=1):
        tokens = [t for t in re.split(r"[,\s]+", line.strip()) if t]
        if len(tokens) != 3 * N_KEYPOINTS:
            raise MotionFormatError(path, f"row {k} has {len(tokens)} values, expected {3 * N_KEYPOINTS}")
        try:
            rows.append([float(t) for t in tokens])
        except ValueError:
            bad = next(t for t in tokens if not is_float(t))
            raise MotionFormatError(path, f"non-numeric value {bad!r} in row {k}") from None
    if len(rows) < 2:
        raise MotionFormatError(path, f"too few frames: {len(rows)} (need at least 2)")
    data = np.array(rows)
    if not np.all(np.isfinite(data)):
        raise MotionFormatError(path, f"NaN or infinite value in row {np.argwhere(~np.isfinite(data))[0][0] + 1}")
    xyz = data.reshape(len(data), N_KEYPOINTS, 3) @ Y_UP_TO_Z_UP.T
    keypoints = {name: xyz[:, i] for i, name in enumerate(KEYPOINT_NAMES)}
    meta = {"format": "dog-keypoints", "frequency": frequency, "licence": "CC-BY-NC-4.0"}
    clip = _clip_info(path)
    if clip:
        meta["clip_info"] = clip
    return Motion(name=path.stem.removesuffix("_joint_pos"), time=np.arange(len(data)) / frequency,
                  root_pos=keypoints["pelvis"].copy(), root_quat=_trunk_quat(path, keypoints), keypoints=keypoints,
                  skeleton="dog-keypoints", source=str(path), meta=meta)


def load_a1_json(path: str | Path) -> Motion:
    """Parse an AMP_for_hardware A1 retarget (JSON, 61 values per frame, Z-up) into a :class:`Motion`.

    The file's toe positions/velocities are kept raw in ``meta`` and not used as keypoints: the retarget
    script evaluates the FL, FR, RL, RR foot chains with the FR, FL, RR, RL joint angles, so they are not the
    robot's feet.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise MotionFormatError(path, f"not a readable JSON motion file: {err}") from err
    if not isinstance(doc, dict) or not isinstance(doc.get("Frames"), list):
        raise MotionFormatError(path, "missing 'Frames' list")
    duration = doc.get("FrameDuration")
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not duration > 0:
        raise MotionFormatError(path, f"missing or invalid 'FrameDuration': {duration!r}")
    for k, frame in enumerate(doc["Frames"], start=1):
        if not isinstance(frame, list) or len(frame) != A1_FRAME_SIZE:
            size = len(frame) if isinstance(frame, list) else type(frame).__name__
            raise MotionFormatError(path, f"frame {k} has {size} values, expected {A1_FRAME_SIZE}")
        bad = [v for v in frame if isinstance(v, bool) or not isinstance(v, (int, float))]
        if bad:
            raise MotionFormatError(path, f"non-numeric value {bad[0]!r} in frame {k}")
    data = np.array(doc["Frames"], dtype=float).reshape(len(doc["Frames"]), A1_FRAME_SIZE)
    if not np.all(np.isfinite(data)):
        raise MotionFormatError(path, f"NaN or infinite value in frame {np.argwhere(~np.isfinite(data))[0][0] + 1}")
    if len(data) < 2:
        raise MotionFormatError(path, f"too few frames: {len(data)} (need at least 2)")
    part = {key: data[:, a:b] for key, (a, b) in _A1_LAYOUT.items()}
    quat = part["root_quat_xyzw"][:, [3, 0, 1, 2]]
    norm = np.linalg.norm(quat, axis=1)
    if np.any(np.abs(norm - 1) > 1e-3):
        raise MotionFormatError(path, f"root quaternion is not unit in frame {np.argmax(np.abs(norm - 1)) + 1}")
    meta = {"format": "amp-a1-json", "frame_duration": float(duration), "licence": "CC-BY-NC-4.0",
            **{k: doc[k] for k in doc if k != "Frames"},
            **{k: part[k] for k in ("root_lin_vel_local", "root_ang_vel_local", "toe_pos_local_raw",
                                    "toe_vel_local_raw")}}
    return Motion(name=path.stem, time=np.arange(len(data)) * float(duration), root_pos=part["root_pos"],
                  root_quat=quat / norm[:, None], joint_names=A1_JOINTS, joint_angles=part["joints"],
                  joint_velocities=part["joint_vel"], skeleton="a1", source=str(path), meta=meta)
