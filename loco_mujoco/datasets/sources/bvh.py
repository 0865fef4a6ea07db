"""BVH motion files (the CMU motion-capture clips): hierarchy, Euler channels and forward kinematics."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from loco_mujoco.datasets.motion import Y_UP_TO_Z_UP, Motion, MotionFormatError

# The CMU converter writes lengths in units of 1/0.45 inch (the ASF "length 0.45" convention).
CMU_METRES_PER_UNIT = 0.0254 / 0.45


@dataclass
class _Joint:
    name: str
    parent: int
    offset: np.ndarray
    channels: list[str]


def _parse_hierarchy(tokens: list[str], path: Path) -> tuple[list[_Joint], int]:
    """Read the HIERARCHY block; returns the joints (end sites included, with no channels) and the next token."""
    joints: list[_Joint] = []
    stack: list[int] = []
    i = 1
    pending: tuple[str, int] | None = None
    try:
        while i < len(tokens):
            tok = tokens[i]
            if tok in ("ROOT", "JOINT"):
                pending = (tokens[i + 1], stack[-1] if stack else -1)
                i += 2
            elif tok == "End":
                parent = stack[-1]
                pending = (f"{joints[parent].name}_end", parent)
                i += 2
            elif tok == "{":
                if pending is None:
                    raise MotionFormatError(path, "'{' without a joint name in HIERARCHY")
                joints.append(_Joint(pending[0], pending[1], np.zeros(3), []))
                stack.append(len(joints) - 1)
                pending = None
                i += 1
            elif tok == "}":
                stack.pop()
                i += 1
                if not stack:
                    return joints, i
            elif tok == "OFFSET":
                joints[stack[-1]].offset = np.array([float(t) for t in tokens[i + 1:i + 4]])
                i += 4
            elif tok == "CHANNELS":
                n = int(tokens[i + 1])
                joints[stack[-1]].channels = tokens[i + 2:i + 2 + n]
                i += 2 + n
            else:
                raise MotionFormatError(path, f"unexpected token {tok!r} in HIERARCHY")
    except (IndexError, ValueError) as err:
        raise MotionFormatError(path, f"HIERARCHY block is truncated or malformed ({err})") from None
    raise MotionFormatError(path, "HIERARCHY block is not closed")


def load_bvh(path: str | Path, metres_per_unit: float = CMU_METRES_PER_UNIT, skip_rest_frame: bool = True) -> Motion:
    """Parse a BVH file; keypoints are every joint's world position from forward kinematics.

    The first motion line of the CMU conversions is the converter's rest pose, dropped by ``skip_rest_frame``.
    """
    path = Path(path)
    text = path.read_text(errors="replace")
    head, sep, motion_text = text.partition("MOTION")
    tokens = head.split()
    if not tokens or tokens[0] != "HIERARCHY":
        raise MotionFormatError(path, "does not start with HIERARCHY")
    if not sep:
        raise MotionFormatError(path, "has no MOTION section")
    joints, _ = _parse_hierarchy(tokens, path)
    lines = [ln.strip() for ln in motion_text.strip().splitlines()]
    try:
        n_frames = int(lines[0].split(":")[1]) if lines[0].startswith("Frames:") else None
        frame_time = float(lines[1].split(":")[1]) if lines[1].startswith("Frame Time:") else None
    except (IndexError, ValueError):
        n_frames = frame_time = None
    if n_frames is None or frame_time is None or frame_time <= 0:
        raise MotionFormatError(path, "MOTION section needs 'Frames: N' and a positive 'Frame Time: dt'")
    rows = [ln for ln in lines[2:] if ln]
    if len(rows) != n_frames:
        raise MotionFormatError(path, f"header says {n_frames} frames but the file has {len(rows)} (truncated?)")
    n_channels = sum(len(j.channels) for j in joints)
    values = np.empty((n_frames, n_channels))
    for k, row in enumerate(rows):
        parts = row.split()
        if len(parts) != n_channels:
            raise MotionFormatError(path, f"frame {k} has {len(parts)} values, expected {n_channels}")
        try:
            values[k] = [float(p) for p in parts]
        except ValueError:
            raise MotionFormatError(path, f"frame {k} has a non-numeric value") from None
    if not np.all(np.isfinite(values)):
        raise MotionFormatError(path, "contains NaN or infinite values")
    if skip_rest_frame:
        values = values[1:]
    return _forward_kinematics(path, joints, values, frame_time, metres_per_unit)


def _forward_kinematics(path: Path, joints: list[_Joint], values: np.ndarray, frame_time: float,
                        scale: float) -> Motion:
    n = len(values)
    rot_world = [np.empty(0)] * len(joints)
    pos_world = [np.empty(0)] * len(joints)
    names: list[str] = []
    angles: list[np.ndarray] = []
    col = 0
    for j, joint in enumerate(joints):
        chans = joint.channels
        cols = {c: values[:, col + i] for i, c in enumerate(chans)}
        col += len(chans)
        rot_chans = [c for c in chans if c.endswith("rotation")]
        if rot_chans:
            seq = "".join(c[0].upper() for c in rot_chans)
            eul = np.stack([cols[c] for c in rot_chans], axis=1)
            local = Rotation.from_euler(seq, eul, degrees=True).as_matrix()
            for c in rot_chans:
                names.append(f"{joint.name}_{c}")
                angles.append(np.deg2rad(cols[c]))
        else:
            local = np.broadcast_to(np.eye(3), (n, 3, 3))
        offset = joint.offset * scale
        if joint.parent < 0:
            trans = np.stack([cols.get(f"{a}position", np.zeros(n)) for a in "XYZ"], axis=1) * scale
            pos_world[j] = offset + trans
            rot_world[j] = local
        else:
            p = joint.parent
            pos_world[j] = pos_world[p] + rot_world[p] @ offset
            rot_world[j] = rot_world[p] @ local
    root = 0
    keypoints = {jt.name: pos_world[j] @ Y_UP_TO_Z_UP.T for j, jt in enumerate(joints)}
    root_rot = Y_UP_TO_Z_UP @ rot_world[root] @ Y_UP_TO_Z_UP.T
    quat_xyzw = Rotation.from_matrix(root_rot).as_quat()
    return Motion(
        name=path.stem, time=np.arange(n) * frame_time, root_pos=keypoints[joints[root].name].copy(),
        root_quat=quat_xyzw[:, [3, 0, 1, 2]], joint_names=tuple(names), joint_angles=np.stack(angles, axis=1),
        keypoints=keypoints, skeleton="bvh-cmu", source=str(path),
        meta={"metres_per_unit": scale, "frame_time": frame_time},
    )
