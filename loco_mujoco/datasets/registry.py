"""Which motion sources build which task's dataset, and building them into the cache with their provenance."""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from pathlib import Path

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
from loco_mujoco.datasets.subject import DatasetSubject, HasDatasetSubject, RetargetTarget, as_subject
from loco_mujoco.datasets.trajectory import TrajectoryDataset
from loco_mujoco.rotations import axis_angle_quat, quat_mul

# An embodiment: its DatasetSubject, or anything that gives one (an environment class), see ``as_subject``.
Subject = DatasetSubject | HasDatasetSubject

# Bump when the retargeting changes: cached datasets built by older code are then rebuilt.
BUILD_VERSION = 6
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
    """The clips that make a task's dataset, and whether to add their left/right mirror images.

    A recipe with a ``generator`` has no clips: its data is simulated by code above the environments (the
    quadruped controller, :mod:`loco_mujoco.controllers`), which the datasets layer never runs.
    """

    clips: tuple[Clip, ...]
    mirror: bool = False
    generator: str | None = None


class GeneratedDatasetError(DatasetUnavailableError):
    """The variant is simulated above the datasets layer (see ``Recipe.generator``), not built from clips."""


_WALK = (Clip("deepmimic/humanoid3d_long_walk1.txt"), Clip("deepmimic/humanoid3d_long_walk2.txt"),
         Clip("deepmimic/humanoid3d_long_walk3.txt"), Clip("deepmimic/humanoid3d_walk.txt"),
         Clip("opensim/subject01_walk1_ik.mot"), Clip("cmu/07_02.bvh"), Clip("cmu/08_03.bvh"),
         *(Clip(f"opensim/walk_free_0{i}.trc") for i in (1, 2, 3)))
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
    "quadruped": {  # permissive: rollouts of our trotting controller (loco_mujoco/controllers), with actions
        "simple": {"permissive": Recipe((), generator="controller"),
                   "noncommercial": Recipe(tuple(Clip(f"{_A1}{c}.txt") for c in
                                                 ("trot0", "trot1", "trot2", "pace0", "pace1", "pace2")))},
        "hard": {"permissive": Recipe((), generator="controller"),
                 "noncommercial": Recipe(tuple(Clip(f"{_A1}{c}.txt") for c in
                                               ("left_turn0", "left_turn1", "right_turn0", "right_turn1")))},
    },
}


def dataset_kind(subject: Subject) -> str:
    """``human`` or ``quadruped``: which recipes apply, by the kind of the embodiment's retargeting spec."""
    subject = as_subject(subject)
    if isinstance(subject.retarget, HumanoidRetarget):
        return "human"
    if isinstance(subject.retarget, QuadrupedRetarget):
        return "quadruped"
    raise DatasetUnavailableError(f"{subject.name} has no retargeting spec, so no real datasets")


def variants(subject: Subject, task: str) -> dict[str, Recipe]:
    """The dataset variants of a task, preferred first (permissive before non-commercial)."""
    subject = as_subject(subject)
    recipes = RECIPES[dataset_kind(subject)]
    if task not in recipes:
        raise DatasetUnavailableError(f"{subject.name}.{task} has no real dataset; tasks with one: "
                                      f"{sorted(t for t in recipes if t in subject.tasks)}")
    return recipes[task]


def resolve_variant(subject: Subject, task: str, variant: str | None) -> str:
    """``variant``, checked against the task's variants; None gives the preferred one."""
    subject = as_subject(subject)
    options = variants(subject, task)
    if variant is None:
        return next(iter(options))
    if variant not in options:
        raise DatasetUnavailableError(f"{subject.name}.{task} has no dataset variant {variant!r}; "
                                      f"variants: {list(options)}")
    return variant


def _load_motion(relpath: str) -> Motion:
    from loco_mujoco.datasets.sources.fetch import source_path

    path = source_path(relpath)
    if "a1-retargeted" in relpath:
        from loco_mujoco.datasets.sources.dog import load_a1_json
        return load_a1_json(path)
    return load_motion_file(path)


MOTION_SUFFIXES = (".bvh", ".mot", ".sto", ".trc", ".txt")


def load_motion_file(path: str | Path) -> Motion:
    """Parse a human motion file by its kind: BVH, OpenSim coordinates (.mot/.sto) or markers (.trc), DeepMimic
    (.txt; its character file ``humanoid3d.txt`` beside it, else the shared one)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"motion file {path} {'is a folder' if path.is_dir() else 'does not exist'}")
    suffix = path.suffix.lower()
    if suffix == ".bvh":
        from loco_mujoco.datasets.sources.bvh import load_bvh
        return load_bvh(path)
    if suffix in (".mot", ".sto"):
        from loco_mujoco.datasets.sources.opensim import load_opensim
        return load_opensim(path)
    if suffix == ".trc":
        from loco_mujoco.datasets.sources.opensim import load_trc
        return load_trc(path)
    if suffix == ".txt":
        from loco_mujoco.datasets.sources.deepmimic import load_deepmimic
        from loco_mujoco.datasets.sources.fetch import source_path

        character = path.with_name("humanoid3d.txt")
        return load_deepmimic(path, character if character.is_file() else source_path("deepmimic/humanoid3d.txt"))
    raise DatasetUnavailableError(f"no parser for {path}: motion files are {', '.join(MOTION_SUFFIXES)}")


def retarget_file(path: str | Path, target: RetargetTarget, foot_lock: bool = True,
                  walk: bool | None = None) -> RetargetedMotion:
    """Retarget one human motion file onto ``target`` at the datasets' frame rate, heading along +x."""
    if not isinstance(target.spec, HumanoidRetarget):
        raise DatasetUnavailableError(f"{target.label} is not a humanoid: only human motion files can be "
                                      "retargeted from a file")
    gait = gait_from_motion(load_motion_file(path), FREQUENCY)
    out = retarget_human(gait, target.model, target.spec, target.home_qpos, foot_lock=foot_lock, walk=walk)
    out.source = str(path)
    _align_heading(out)
    return out


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


def cache_path(subject: Subject, task: str, variant: str, mode: str | None = None) -> Path:
    """The cache file of a dataset; its name carries a hash of everything that determines its content."""
    from loco_mujoco.datasets.sources.fetch import SOURCE_FILES

    subject = as_subject(subject)
    recipe = variants(subject, task)[variant]
    key = json.dumps({"version": BUILD_VERSION, "recipe": asdict(recipe), "frequency": FREQUENCY,
                      "sources": [SOURCE_FILES[c.path].sha256 for c in recipe.clips]}, sort_keys=True)
    digest = hashlib.sha256(key.encode()).hexdigest()[:12]
    name = ".".join([subject.name, task] + ([mode] if mode else []) + ["real", variant, digest])
    return cache_dir() / "datasets" / f"{name}.npz"


def _refuse_generated(subject: DatasetSubject, task: str, variant: str) -> None:
    generator = variants(subject, task)[variant].generator
    if generator is not None:
        raise GeneratedDatasetError(f"{subject.name}.{task} [{variant}] is simulated by the {generator}, above the "
                                    "datasets layer: load it through the environment (LocoEnv.make(...).dataset)")


def load_dataset(subject: Subject, task: str, variant: str | None = None, rebuild: bool = False,
                 progress: bool = True, mode: str | None = None) -> TrajectoryDataset:
    """The task's real dataset from the cache, building it first if needed.

    For body-size environments, mode ``all`` joins the datasets of every size (each retargeted onto its
    own body) and records each trajectory's size in ``metadata["sizes"]``.
    """
    subject = as_subject(subject)
    variant = resolve_variant(subject, task, variant)
    sizes = subject.sizes
    if sizes and mode == "all":
        parts = [load_dataset(subject, task, variant, rebuild, progress, size) for size in sizes]
        return join_sizes(parts, sizes)
    _refuse_generated(subject, task, variant)
    path = cache_path(subject, task, variant, mode)
    if path.exists() and not rebuild:
        return TrajectoryDataset.load(path)
    dataset = build_dataset(subject, task, variant, progress=progress, mode=mode)
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


def build_dataset(subject: Subject, task: str, variant: str | None = None,
                  progress: bool = True, mode: str | None = None) -> TrajectoryDataset:
    """Parse, retarget and concatenate a task's clips into a dataset with provenance and quality figures.

    The clips are retargeted onto ``subject.target(task, mode)``: the compiled model alone, no environment.
    """
    from loco_mujoco.datasets.sources.fetch import SOURCE_FILES

    subject = as_subject(subject)
    variant = resolve_variant(subject, task, variant)
    _refuse_generated(subject, task, variant)
    recipe = variants(subject, task)[variant]
    target = subject.target(task, mode)
    model, base, spec = target.model, target.home_qpos, target.spec
    trajectories: list[RetargetedMotion] = []
    label = ".".join([subject.name, task] + ([mode] if mode else []))
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
        "env": subject.name, "task": task, "mode": mode, "dataset_type": "real", "variant": variant,
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
