"""The original LocoMuJoCo ``.npz`` trajectory layout (read and write).

One 1-D array per ``q_<joint>`` / ``dq_<joint>`` at 500 Hz; the free root is three slide joints then three
hinges on the root body, applied in the listed order (world axes from the old XMLs of robfiras/loco-mujoco):

- ``pelvis`` (UnitreeH1, UnitreeG1, Talos, Atlas): tx slide x, tz slide y, ty slide z; tilt hinge (0,-1,0),
  list (1,0,0), rotation (0,0,1).
- ``pelvis_opensim`` (HumanoidTorque/HumanoidMuscle; body quat Rx(90) so local axes map to world): as
  ``pelvis`` but tz slides along -y. ``root_quat`` excludes the fixed body quat (identity = upright).
- ``trunk`` (UnitreeA1): tx x, ty y, tz z; rotation hinge (0,0,1), list (1,0,0), tilt (0,1,0) (the order of
  the dataset keys and of ``UnitreeA1._get_observation_specification``).

Slide values are offsets from the root body's XML position (:data:`OLD_ROOT_OFFSET`).
"""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from loco_mujoco.atomic_write import atomic_write
from loco_mujoco.datasets.motion import Motion, MotionFormatError
from loco_mujoco.rotations import axis_angle_quat, quat_mul

FREQUENCY = 500.0
ROOT_FAMILIES: dict[str, tuple[tuple[str, tuple[float, float, float]], ...]] = {
    "pelvis": (("pelvis_tx", (1, 0, 0)), ("pelvis_tz", (0, 1, 0)), ("pelvis_ty", (0, 0, 1)),
               ("pelvis_tilt", (0, -1, 0)), ("pelvis_list", (1, 0, 0)), ("pelvis_rotation", (0, 0, 1))),
    "pelvis_opensim": (("pelvis_tx", (1, 0, 0)), ("pelvis_tz", (0, -1, 0)), ("pelvis_ty", (0, 0, 1)),
                       ("pelvis_tilt", (0, -1, 0)), ("pelvis_list", (1, 0, 0)), ("pelvis_rotation", (0, 0, 1))),
    "trunk": (("trunk_tx", (1, 0, 0)), ("trunk_ty", (0, 1, 0)), ("trunk_tz", (0, 0, 1)),
              ("trunk_rotation", (0, 0, 1)), ("trunk_list", (1, 0, 0)), ("trunk_tilt", (0, 1, 0))),
}
# Root body position in the old XMLs (robfiras/loco-mujoco environments/data/*): the slides are offsets from it.
OLD_ROOT_OFFSET: dict[str, tuple[float, float, float]] = {
    "UnitreeH1": (0.0, 0.0, 1.045),      # unitree_h1/h1.xml, body pelvis
    "UnitreeG1": (0.0, 0.0, 0.755),      # unitree_g1/g1.xml, body pelvis
    "Talos": (0.0, 0.0, 1.085),          # talos/talos.xml, body pelvis
    "Atlas": (0.0, 0.0, 0.94),           # atlas/model.xml, body pelvis
    "UnitreeA1": (0.0, 0.0, 0.43),       # quadrupeds/unitree_a1_torque.xml, body trunk
    "HumanoidTorque": (0.0, 0.0, 0.975),  # humanoid/humanoid_torque.xml, body pelvis (family pelvis_opensim)
}
ROBOT_ROOT_FAMILY = {"UnitreeH1": "pelvis", "UnitreeG1": "pelvis", "Talos": "pelvis", "Atlas": "pelvis",
                     "UnitreeA1": "trunk", "HumanoidTorque": "pelvis_opensim"}
_META_KEYS = ("split_points", "goal_speed", "dir_arrow")


def _detect_family(path: Path, q_names: list[str]) -> str:
    for family in ("pelvis", "trunk"):
        if any(n.startswith(family + "_") for n in q_names):
            return family
    expected = {f: [f"q_{j}" for j, _ in chain] for f, chain in ROOT_FAMILIES.items() if f != "pelvis_opensim"}
    raise MotionFormatError(path, f"unknown root joints: expected the keys of one family {expected}")


def load_loco_npz(path: str | Path, root_offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
                  root_family: str | None = None) -> Motion:
    """Read a LocoMuJoCo ``.npz``; the root family is detected from the keys unless given."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as archive:
            arrays = {k: archive[k] for k in archive.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
        raise MotionFormatError(path, f"not a readable .npz archive: {err}") from err
    q_names = [k[2:] for k in arrays if k.startswith("q_")]
    dq_names = [k[3:] for k in arrays if k.startswith("dq_")]
    if not q_names:
        raise MotionFormatError(path, "no q_<joint> arrays")
    for j in q_names:
        if j not in dq_names:
            raise MotionFormatError(path, f"missing dq_{j} for q_{j}")
    for j in dq_names:
        if j not in q_names:
            raise MotionFormatError(path, f"dq_{j} has no matching q_{j}")
    family = root_family or _detect_family(path, q_names)
    if family not in ROOT_FAMILIES:
        raise ValueError(f"unknown root family {family!r}; known: {list(ROOT_FAMILIES)}")
    chain = ROOT_FAMILIES[family]
    missing = [f"q_{j}" for j, _ in chain if j not in q_names]
    if missing:
        raise MotionFormatError(path, f"missing root joint array(s) {missing} of family {family!r}")
    n = None
    for key in (f"{p}{j}" for j in q_names for p in ("q_", "dq_")):
        arr = arrays[key]
        if arr.ndim != 1 or not np.issubdtype(arr.dtype, np.number):
            raise MotionFormatError(path, f"{key} must be a 1-D numeric array, has shape {arr.shape} {arr.dtype}")
        if n is None:
            n, first = len(arr), key
        elif len(arr) != n:
            raise MotionFormatError(path, f"unequal array lengths: {first} has {n} values, {key} has {len(arr)}")
        if not np.all(np.isfinite(arr)):
            raise MotionFormatError(path, f"{key} contains NaN or infinite values")
    root_names = [j for j, _ in chain]
    joints = [j for j in q_names if j not in root_names]
    q = {j: arrays[f"q_{j}"].astype(float) for j in q_names}
    root_pos = sum(q[j][:, None] * np.asarray(ax, float) for j, ax in chain[:3]) + np.asarray(root_offset, float)
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    for j, ax in chain[3:]:
        quat = quat_mul(quat, axis_angle_quat(ax, q[j]))
    frequency = float(arrays.pop("frequency")) if "frequency" in arrays else FREQUENCY
    meta = {"format": "loco-mujoco-npz", "root_family": family, "root_joint_names": root_names,
            "root_offset": tuple(float(v) for v in root_offset), "frequency": frequency,
            "root_velocity": np.stack([arrays[f"dq_{j}"] for j in root_names], axis=1).astype(float)}
    meta.update({k: arrays[k] for k in _META_KEYS if k in arrays})
    known = {f"{p}{j}" for j in q_names for p in ("q_", "dq_")} | set(_META_KEYS)
    extra = {k: v for k, v in arrays.items() if k not in known}
    if extra:
        meta["extra_arrays"] = extra
    return Motion(name=path.stem, time=np.arange(n) / frequency, root_pos=root_pos, root_quat=quat,
                  joint_names=tuple(joints), joint_angles=np.stack([q[j] for j in joints], axis=1) if joints else None,
                  joint_velocities=(np.stack([arrays[f"dq_{j}"] for j in joints], axis=1).astype(float)
                                    if joints else None),
                  skeleton="loco-mujoco", source=str(path), meta=meta)


def root_coordinates(motion: Motion, root_offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
                     root_family: str = "pelvis") -> dict[str, np.ndarray]:
    """Recover the six root joint values (slides, then hinges unwrapped over time) of ``root_family``."""
    chain = ROOT_FAMILIES[root_family]
    rel = motion.root_pos - np.asarray(root_offset, float)
    out = {j: rel @ np.asarray(ax, float) for j, ax in chain[:3]}
    hinges = chain[3:]
    seq = "".join("XYZ"[int(np.flatnonzero(ax)[0])] for _, ax in hinges)
    angles = Rotation.from_quat(motion.root_quat[:, [1, 2, 3, 0]]).as_euler(seq)
    for i, (j, ax) in enumerate(hinges):
        out[j] = np.unwrap(angles[:, i] * float(np.sum(ax)))
    return out


def _write_npz(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """A stored (uncompressed) zip of ``.npy`` members with fixed timestamps, written atomically."""
    with atomic_write(path) as handle, zipfile.ZipFile(handle, "w", zipfile.ZIP_STORED) as archive:
        for key, arr in arrays.items():
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.ascontiguousarray(arr), allow_pickle=False)
            info = zipfile.ZipInfo(f"{key}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.external_attr = 0o644 << 16
            archive.writestr(info, buf.getvalue())


def save_loco_npz(path: str | Path, motion: Motion, root_offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
                  split_points: np.ndarray | None = None, root_family: str = "pelvis") -> None:
    """Write ``motion`` in the LocoMuJoCo ``.npz`` layout; byte-identical for identical input."""
    if motion.joint_velocities is None:
        raise ValueError(f"{motion.name}: joint_velocities are required to write a LocoMuJoCo .npz")
    if root_family not in ROOT_FAMILIES:
        raise ValueError(f"unknown root family {root_family!r}; known: {list(ROOT_FAMILIES)}")
    root_names = [j for j, _ in ROOT_FAMILIES[root_family]]
    clash = sorted(set(root_names) & set(motion.joint_names))
    if clash:
        raise ValueError(f"{motion.name}: joint names {clash} collide with the root joints")
    q_root = root_coordinates(motion, root_offset, root_family)
    dq_root = motion.meta.get("root_velocity")
    same_layout = motion.meta.get("root_joint_names") == root_names
    if dq_root is None or not same_layout or np.shape(dq_root) != (motion.n_frames, 6):
        dq_root = np.stack([np.gradient(q_root[j], motion.time) for j in root_names], axis=1)
    arrays = {f"q_{j}": q_root[j] for j in root_names}
    arrays.update({f"q_{j}": motion.joint_angles[:, i] for i, j in enumerate(motion.joint_names)})
    arrays.update({f"dq_{j}": dq_root[:, i] for i, j in enumerate(root_names)})
    arrays.update({f"dq_{j}": motion.joint_velocities[:, i] for i, j in enumerate(motion.joint_names)})
    for key in ("dir_arrow", "goal_speed"):
        if key in motion.meta:
            arrays[key] = np.asarray(motion.meta[key])
    split = split_points if split_points is not None else motion.meta.get("split_points")
    if split is not None:
        arrays["split_points"] = np.asarray(split, dtype=np.int64)
    if not np.isclose(motion.frequency, FREQUENCY, rtol=1e-6):
        arrays["frequency"] = np.asarray(motion.frequency)
    arrays.update(motion.meta.get("extra_arrays", {}))
    _write_npz(Path(path), arrays)
