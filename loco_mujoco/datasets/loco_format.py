"""Datasets in the original LocoMuJoCo ``.npz`` layout: loading them onto our robots and exporting ours."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from loco_mujoco.datasets.motion import MotionFormatError
from loco_mujoco.datasets.resample import resample_angles, resample_quat
from loco_mujoco.datasets.retarget import velocities
from loco_mujoco.datasets.sources.loco_npz import OLD_ROOT_OFFSET, load_loco_npz
from loco_mujoco.datasets.subject import DatasetSubject, HasDatasetSubject, as_subject
from loco_mujoco.datasets.trajectory import FORMAT, TrajectoryDataset


def load_any_dataset(subject: DatasetSubject | HasDatasetSubject, path: str | Path,
                     frequency: float = 100.0) -> TrajectoryDataset:
    """A dataset file of ours, or an original LocoMuJoCo ``.npz`` converted onto ``subject``'s full model."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"dataset file {path} {'is a folder' if path.is_dir() else 'does not exist'}; "
                                "give a dataset .npz (ours, or the original LocoMuJoCo format)")
    try:
        with np.load(path, allow_pickle=False) as data:
            ours = "format" in data.files and str(data["format"]) == FORMAT
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as err:  # not an .npz, pickled, truncated
        raise MotionFormatError(path, f"not a dataset file: expected an .npz of ours or of the original "
                                      f"LocoMuJoCo ({type(err).__name__}: {str(err)[:120]})") from None
    return TrajectoryDataset.load(path) if ours else convert_loco_npz(subject, path, frequency)


def convert_loco_npz(subject: DatasetSubject | HasDatasetSubject, path: str | Path,
                     frequency: float = 100.0) -> TrajectoryDataset:
    """Map an original-format file's joints onto ours by ``subject.old_format_joints`` and resample it onto the
    full model of its first task (built without an environment)."""
    subject = as_subject(subject)
    old_names = subject.old_format_joints
    if not old_names:
        raise ValueError(f"{subject.name} has no mapping from the original LocoMuJoCo joint names")
    motion = load_loco_npz(path, root_offset=OLD_ROOT_OFFSET[subject.name])
    target = subject.target(subject.tasks[0], None)
    model, base = target.model, target.home_qpos
    splits = np.asarray(motion.meta.get("split_points", [0, motion.n_frames]), dtype=int)
    if splits[0] != 0 or splits[-1] != motion.n_frames:
        splits = np.concatenate([[0], splits[(splits > 0) & (splits < motion.n_frames)], [motion.n_frames]])
    qpos_parts, qvel_parts, lengths = [], [], []
    for a, b in zip(splits[:-1], splits[1:], strict=False):
        t_src = motion.time[a:b]
        t_new = np.arange(t_src[0], t_src[-1] + 1e-9, 1.0 / frequency)
        q = np.tile(base, (len(t_new), 1))
        q[:, :3] = resample_angles(t_src, motion.root_pos[a:b], t_new)
        q[:, 3:7] = resample_quat(t_src, motion.root_quat[a:b], t_new)
        for old, new in old_names.items():
            if old in motion.joint_names:
                adr = model.jnt_qposadr[model.joint(new).id]
                q[:, adr] = resample_angles(t_src, motion.angle(old)[a:b, None], t_new)[:, 0]
        qpos_parts.append(q)
        qvel_parts.append(velocities(model, q, frequency))
        lengths.append(len(q))
    metadata = {"env": subject.name, "task": None, "dataset_type": "real", "variant": "file",
                "frequency": frequency, "source_file": str(path), "format": "loco-mujoco-npz",
                "mean_forward_speed": float(np.mean(np.concatenate(qvel_parts)[:, 0])),
                "mean_speed": float(np.mean(np.linalg.norm(np.concatenate(qvel_parts)[:, :2], axis=1))),
                "seconds": float(sum(n - 1 for n in lengths) / frequency)}
    joint_names = tuple(model.joint(j).name for j in range(model.njnt))
    return TrajectoryDataset(np.concatenate(qpos_parts), np.concatenate(qvel_parts),
                             np.concatenate([[0], np.cumsum(lengths)]), frequency, joint_names, metadata)
