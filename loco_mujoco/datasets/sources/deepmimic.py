"""DeepMimic motion JSON (humanoid3d): local joint quaternions, forward kinematics from the character file."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from loco_mujoco.datasets.motion import Y_UP_TO_Z_UP, Motion, MotionFormatError

_DOFS = {"none": 0, "spherical": 4, "revolute": 1, "fixed": 0}
# Toe and heel of humanoid3d's box feet in the ankle frame (box centre 0.045, -0.0225; size 0.177 x 0.055).
_FOOT_POINTS = {"toe": np.array([0.1335, -0.05, 0.0]), "heel": np.array([-0.0435, -0.05, 0.0])}


@dataclass(frozen=True)
class DeepMimicCharacter:
    """The joint tree of a DeepMimic character file: names, parents, attach offsets (Y-up, metres), types."""

    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    types: tuple[str, ...]

    @property
    def frame_width(self) -> int:
        return 1 + 7 + sum(_DOFS[t] for t in self.types)


def load_character(path: str | Path) -> DeepMimicCharacter:
    """Read the ``Skeleton`` of a DeepMimic character file such as ``humanoid3d.txt``."""
    path = Path(path)
    try:
        joints = json.loads(path.read_text())["Skeleton"]["Joints"]
        names = tuple(j["Name"] for j in joints)
        parents = tuple(int(j["Parent"]) for j in joints)
        offsets = np.array([[j["AttachX"], j["AttachY"], j["AttachZ"]] for j in joints], dtype=float)
        types = tuple(j["Type"] for j in joints)
    except (json.JSONDecodeError, KeyError, TypeError) as err:
        raise MotionFormatError(path, f"not a DeepMimic character file ({type(err).__name__}: {err})") from None
    unknown = sorted(set(types) - set(_DOFS))
    if unknown:
        raise MotionFormatError(path, f"unknown joint types {unknown}; known: {sorted(_DOFS)}")
    return DeepMimicCharacter(names, parents, offsets, types)


def load_deepmimic(path: str | Path, character: str | Path | DeepMimicCharacter | None = None) -> Motion:
    """Parse a DeepMimic motion; the character defaults to ``humanoid3d.txt`` beside the motion file."""
    path = Path(path)
    if not isinstance(character, DeepMimicCharacter):
        character = load_character(character or path.with_name("humanoid3d.txt"))
    try:
        frames = json.loads(path.read_text())["Frames"]
    except json.JSONDecodeError as err:
        raise MotionFormatError(path, f"is not valid JSON ({err.msg} at line {err.lineno})") from None
    except (KeyError, TypeError):
        raise MotionFormatError(path, "has no 'Frames' list") from None
    width = character.frame_width
    for k, row in enumerate(frames):
        if not isinstance(row, list) or len(row) != width:
            got = len(row) if isinstance(row, list) else type(row).__name__
            raise MotionFormatError(path, f"frame {k} has {got} values, expected {width} for this character")
    try:
        data = np.asarray(frames, dtype=float)
    except (TypeError, ValueError):
        raise MotionFormatError(path, "frames contain non-numeric values") from None
    if len(data) < 2:
        raise MotionFormatError(path, f"needs at least 2 frames, has {len(data)}")
    if not np.all(np.isfinite(data)):
        raise MotionFormatError(path, "contains NaN or infinite values")
    if np.any(data[:-1, 0] <= 0):
        raise MotionFormatError(path, "frame durations (column 0) must be positive")
    time = np.concatenate([[0.0], np.cumsum(data[:-1, 0])])
    return _forward_kinematics(path, character, data, time)


def _forward_kinematics(path: Path, ch: DeepMimicCharacter, data: np.ndarray, time: np.ndarray) -> Motion:
    n = len(data)
    rot = [np.empty(0)] * len(ch.names)
    pos = [np.empty(0)] * len(ch.names)
    names: list[str] = []
    angles: list[np.ndarray] = []
    col = 8
    for j, (name, parent, kind) in enumerate(zip(ch.names, ch.parents, ch.types, strict=False)):
        if parent < 0:
            pos[j] = data[:, 1:4]
            rot[j] = Rotation.from_quat(data[:, [5, 6, 7, 4]]).as_matrix()
            continue
        if kind == "spherical":
            q = data[:, col:col + 4]
            local_rot = Rotation.from_quat(q[:, [1, 2, 3, 0]])
            local = local_rot.as_matrix()
            rotvec = local_rot.as_rotvec()
            for i, axis in enumerate("xyz"):
                names.append(f"{name}_{axis}")
                angles.append(rotvec[:, i])
        elif kind == "revolute":
            angle = data[:, col]
            local = Rotation.from_rotvec(np.outer(angle, [0.0, 0.0, 1.0])).as_matrix()
            names.append(name)
            angles.append(angle)
        else:
            local = np.broadcast_to(np.eye(3), (n, 3, 3))
        col += _DOFS[kind]
        pos[j] = pos[parent] + rot[parent] @ ch.offsets[j]
        rot[j] = rot[parent] @ local
    keypoints = {name: pos[j] @ Y_UP_TO_Z_UP.T for j, name in enumerate(ch.names)}
    for side in ("left", "right"):
        ankle = ch.names.index(f"{side}_ankle")
        for point, local_pos in _FOOT_POINTS.items():
            keypoints[f"{side}_{point}"] = (pos[ankle] + rot[ankle] @ local_pos) @ Y_UP_TO_Z_UP.T
    root_rot = Y_UP_TO_Z_UP @ rot[0] @ Y_UP_TO_Z_UP.T
    quat_xyzw = Rotation.from_matrix(root_rot).as_quat()
    return Motion(
        name=path.stem, time=time, root_pos=keypoints[ch.names[0]].copy(), root_quat=quat_xyzw[:, [3, 0, 1, 2]],
        joint_names=tuple(names), joint_angles=np.stack(angles, axis=1), keypoints=keypoints,
        skeleton="deepmimic", source=str(path),
    )
