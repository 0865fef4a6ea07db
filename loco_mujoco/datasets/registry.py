"""Which motion sources build which task's dataset, and building them into the cache with their provenance."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from tqdm import tqdm

from loco_mujoco.datasets.human_gait import gait_from_motion, mirror
from loco_mujoco.datasets.motion import Motion
from loco_mujoco.datasets.retarget import (
    HumanoidRetarget,
    QuadrupedRetarget,
    RetargetedMotion,
    retarget_human,
    retarget_quadruped,
)
from loco_mujoco.datasets.sources.fetch import cache_dir
from loco_mujoco.datasets.trajectory import TrajectoryDataset
from loco_mujoco.rotations import axis_angle_quat, quat_mul

if TYPE_CHECKING:
    from loco_mujoco.core.loco_env import LocoEnv

# Bump when the retargeting changes: cached datasets built by older code are then rebuilt.
BUILD_VERSION = 5
FREQUENCY = 100.0


class DatasetUnavailableError(RuntimeError):
    """A task has no dataset of the requested kind, or its sources cannot be found."""


@dataclass(frozen=True)
class Clip:
    """One source file (relative to the sources folder), optionally trimmed to [start, end) seconds."""

    path: str
    start: float = 0.0
    end: float | None = None


@dataclass(frozen=True)
class Recipe:
    """The clips that make a task's dataset, and whether to add their left/right mirror images."""

    clips: tuple[Clip, ...]
    mirror: bool = False


_WALK = (Clip("deepmimic/humanoid3d_long_walk1.txt"), Clip("deepmimic/humanoid3d_long_walk2.txt"),
         Clip("deepmimic/humanoid3d_long_walk3.txt"), Clip("deepmimic/humanoid3d_walk.txt"),
         Clip("opensim/subject01_walk1_ik.mot"), Clip("cmu/07_02.bvh"), Clip("cmu/08_03.bvh"))
_RUN = (Clip("opensim/subject02_running_arms_ik.mot"), Clip("deepmimic/humanoid3d_run.txt"),
        Clip("deepmimic/humanoid3d_jog.txt"), *(Clip(f"cmu/{c}.bvh") for c in
                                                ("09_01", "09_03", "09_04", "09_07", "09_08", "16_35", "16_36",
                                                 "16_45", "35_17", "35_23", "35_24", "35_25", "35_26", "127_07")))
_SIE_RUNS = tuple(Clip(f"noncommercial/deepmimic-sie-runs/sie_humanoid3d_run_forward{i:02d}.txt")
                  for i in range(0, 16, 2))
_A1 = "noncommercial/a1-retargeted/"

# Per dataset kind and task: variants in order of preference. "permissive" variants come first.
RECIPES: dict[str, dict[str, dict[str, Recipe]]] = {
    "human": {
        "walk": {"permissive": Recipe(_WALK)},
        "run": {"permissive": Recipe(_RUN), "noncommercial": Recipe(_RUN + _SIE_RUNS)},
        "carry": {"permissive": Recipe((Clip("cmu/70_02.bvh"), Clip("cmu/70_13.bvh")) + _WALK)},
    },
    "quadruped": {
        "simple": {"noncommercial": Recipe(tuple(Clip(f"{_A1}{c}.txt") for c in
                                                 ("trot0", "trot1", "trot2", "pace0", "pace1", "pace2")))},
        "hard": {"noncommercial": Recipe(tuple(Clip(f"{_A1}{c}.txt") for c in
                                               ("left_turn0", "left_turn1", "right_turn0", "right_turn1")))},
    },
}


def dataset_kind(env_cls: type[LocoEnv]) -> str:
    spec = getattr(env_cls, "RETARGET", None)
    if isinstance(spec, HumanoidRetarget):
        return "human"
    if isinstance(spec, QuadrupedRetarget):
        return "quadruped"
    raise DatasetUnavailableError(f"{env_cls.__name__} has no retargeting spec, so no real datasets")


def variants(env_cls: type[LocoEnv], task: str) -> dict[str, Recipe]:
    """The dataset variants of a task, preferred first (permissive before non-commercial)."""
    recipes = RECIPES[dataset_kind(env_cls)]
    if task not in recipes:
        raise DatasetUnavailableError(f"{env_cls.__name__}.{task} has no real dataset; tasks with one: "
                                      f"{sorted(t for t in recipes if t in env_cls.TASKS)}")
    return recipes[task]


def resolve_variant(env_cls: type[LocoEnv], task: str, variant: str | None) -> str:
    options = variants(env_cls, task)
    if variant is None:
        return next(iter(options))
    if variant not in options:
        raise DatasetUnavailableError(f"{env_cls.__name__}.{task} has no dataset variant {variant!r}; "
                                      f"variants: {list(options)}")
    return variant


def _load_motion(relpath: str) -> Motion:
    from loco_mujoco.datasets.sources.fetch import source_path

    path = source_path(relpath)
    if path.suffix == ".bvh":
        from loco_mujoco.datasets.sources.bvh import load_bvh
        return load_bvh(path)
    if path.suffix in (".mot", ".sto"):
        from loco_mujoco.datasets.sources.opensim import load_opensim
        return load_opensim(path)
    if "a1-retargeted" in relpath:
        from loco_mujoco.datasets.sources.dog import load_a1_json
        return load_a1_json(path)
    if "deepmimic" in relpath:
        from loco_mujoco.datasets.sources.deepmimic import load_deepmimic
        return load_deepmimic(path, source_path("deepmimic/humanoid3d.txt"))
    raise DatasetUnavailableError(f"no parser for source {relpath}")


def _trim(motion: Motion, clip: Clip) -> Motion:
    if clip.start == 0.0 and clip.end is None:
        return motion
    t = motion.time - motion.time[0]
    keep = (t >= clip.start) & (t < (clip.end if clip.end is not None else np.inf))
    return Motion(motion.name, motion.time[keep], motion.root_pos[keep], motion.root_quat[keep], motion.joint_names,
                  motion.joint_angles[keep], {k: v[keep] for k, v in motion.keypoints.items()},
                  None if motion.joint_velocities is None else motion.joint_velocities[keep], motion.skeleton,
                  motion.source, motion.meta)


def _align_heading(traj: RetargetedMotion, seconds: float = 1.0) -> None:
    """Rotate and shift a trajectory in the ground plane so it starts at the origin heading along +x."""
    n = min(len(traj.qpos) - 1, int(seconds * traj.frequency))
    disp = traj.qpos[n, :2] - traj.qpos[0, :2]
    if np.linalg.norm(disp) < 0.05:
        return
    angle = -np.arctan2(disp[1], disp[0])
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    traj.qpos[:, :2] = (traj.qpos[:, :2] - traj.qpos[0, :2]) @ rot.T
    traj.qvel[:, :2] = traj.qvel[:, :2] @ rot.T
    traj.qpos[:, 3:7] = quat_mul(axis_angle_quat([0.0, 0.0, 1.0], angle), traj.qpos[:, 3:7])


def _retarget_env(env_cls: type[LocoEnv], task: str, mode: str | None) -> LocoEnv:
    return env_cls(task=task, mode=mode, disable_arms=False, reward_type="none")


def cache_path(env_cls: type[LocoEnv], task: str, variant: str, mode: str | None = None) -> Path:
    """The cache file of a dataset; its name carries a hash of everything that determines its content."""
    from loco_mujoco.datasets.sources.fetch import SOURCE_FILES

    recipe = variants(env_cls, task)[variant]
    key = json.dumps({"version": BUILD_VERSION, "recipe": asdict(recipe), "frequency": FREQUENCY,
                      "sources": [SOURCE_FILES[c.path].sha256 for c in recipe.clips]}, sort_keys=True)
    digest = hashlib.sha256(key.encode()).hexdigest()[:12]
    name = ".".join([env_cls.__name__, task] + ([mode] if mode else []) + ["real", variant, digest])
    return cache_dir() / "datasets" / f"{name}.npz"


def load_dataset(env_cls: type[LocoEnv], task: str, variant: str | None = None, rebuild: bool = False,
                 progress: bool = True, mode: str | None = None) -> TrajectoryDataset:
    """The task's real dataset from the cache, building it first if needed.

    For body-size environments, mode ``all`` joins the datasets of every size (each retargeted onto its
    own body) and records each trajectory's size in ``metadata["sizes"]``.
    """
    variant = resolve_variant(env_cls, task, variant)
    sizes = getattr(env_cls, "SIZES", None)
    if sizes and mode == "all":
        parts = [load_dataset(env_cls, task, variant, rebuild, progress, size) for size in sizes]
        return join_sizes(parts, sizes)
    path = cache_path(env_cls, task, variant, mode)
    if path.exists() and not rebuild:
        return TrajectoryDataset.load(path)
    dataset = build_dataset(env_cls, task, variant, progress=progress, mode=mode)
    dataset.save(path)
    dataset.source_file = path
    return dataset


def combine_quality(qualities: list[dict[str, float]], frames: np.ndarray) -> dict[str, float]:
    """Quality figures of several trajectories as one: maxima stay maxima, the rest are frame-weighted means."""
    return {k: float(np.max([q[k] for q in qualities])) if k.endswith("max_m") else
            float(np.average([q[k] for q in qualities], weights=frames)) for k in qualities[0]}


def join_sizes(parts: list[TrajectoryDataset], sizes: tuple[str, ...]) -> TrajectoryDataset:
    """One dataset from the per-size datasets of a body-size environment, trajectories labelled by size."""
    first = parts[0]
    splits = np.concatenate([[0], np.cumsum([p.n_frames for p in parts])])
    split_points = np.concatenate([p.split_points[:-1] + off for p, off in zip(parts, splits[:-1], strict=True)]
                                  + [[splits[-1]]])
    metadata = dict(first.metadata)
    metadata["mode"] = "all"
    metadata["sizes"] = [size for p, size in zip(parts, sizes, strict=True) for _ in range(p.n_trajectories)]
    metadata["trajectories"] = [t for p in parts for t in p.metadata["trajectories"]]
    metadata["per_size"] = {size: {k: p.metadata[k] for k in ("mean_forward_speed", "mean_speed", "quality")}
                            for p, size in zip(parts, sizes, strict=True)}
    frames = np.array([p.n_frames for p in parts], dtype=float)
    metadata["quality"] = combine_quality([p.metadata["quality"] for p in parts], frames)
    for key in ("mean_forward_speed", "mean_speed"):
        metadata[key] = float(np.average([p.metadata[key] for p in parts], weights=frames))
    metadata["seconds"] = float(sum(p.metadata["seconds"] for p in parts))
    return TrajectoryDataset(np.concatenate([p.qpos for p in parts]), np.concatenate([p.qvel for p in parts]),
                             split_points, first.frequency, first.joint_names, metadata)


def build_dataset(env_cls: type[LocoEnv], task: str, variant: str | None = None,
                  progress: bool = True, mode: str | None = None) -> TrajectoryDataset:
    """Parse, retarget and concatenate a task's clips into a dataset with provenance and quality figures."""
    from loco_mujoco.datasets.sources.fetch import SOURCE_FILES

    variant = resolve_variant(env_cls, task, variant)
    recipe = variants(env_cls, task)[variant]
    env = _retarget_env(env_cls, task, mode)
    model, base = env.model, env.home_qpos(env.model)
    spec = env_cls.RETARGET
    trajectories: list[RetargetedMotion] = []
    label = ".".join([env_cls.__name__, task] + ([mode] if mode else []))
    for clip in tqdm(recipe.clips, desc=f"building {label} ({variant})", disable=not progress,
                     unit="clip"):
        motion = _trim(_load_motion(clip.path), clip)
        if isinstance(spec, HumanoidRetarget):
            gait = gait_from_motion(motion, FREQUENCY)
            gaits = [gait, mirror(gait)] if recipe.mirror else [gait]
            outs = [retarget_human(g, model, spec, base) for g in gaits]
        else:
            outs = [retarget_quadruped(motion, model, spec, base, FREQUENCY)]
        for out in outs:
            out.source = clip.path
            _align_heading(out)
            trajectories.append(out)
    env.stop()
    qpos = np.concatenate([t.qpos for t in trajectories])
    qvel = np.concatenate([t.qvel for t in trajectories])
    splits = np.concatenate([[0], np.cumsum([len(t.qpos) for t in trajectories])])
    frames = np.array([len(t.qpos) for t in trajectories], dtype=float)
    quality = combine_quality([t.quality for t in trajectories], frames)
    sources = []
    for clip in recipe.clips:
        info = SOURCE_FILES[clip.path]
        sources.append({"path": clip.path, "licence": info.licence, "commercial_use": info.commercial_use,
                        "url": info.url, "sha256": info.sha256})
    commercial = all(s["commercial_use"] for s in sources)
    metadata = {
        "env": env_cls.__name__, "task": task, "mode": mode, "dataset_type": "real", "variant": variant,
        "frequency": FREQUENCY, "seconds": float((frames - 1).sum() / FREQUENCY),
        "mean_forward_speed": quality["mean_forward_speed_mps"],
        "mean_speed": quality["mean_speed_mps"], "quality": quality,
        "licences": sorted({s["licence"] for s in sources}), "commercial_use": commercial,
        "noncommercial": not commercial, "sources": sources, "build_version": BUILD_VERSION,
        "trajectories": [{"name": t.name, "source": t.source, "frames": len(t.qpos), "quality": t.quality}
                         for t in trajectories],
    }
    joint_names = tuple(model.joint(j).name for j in range(model.njnt))
    return TrajectoryDataset(qpos, qvel, splits, FREQUENCY, joint_names, metadata)
