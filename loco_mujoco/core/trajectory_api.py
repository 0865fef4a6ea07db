"""The dataset side of every environment: expert-state starts, ``create_dataset`` and kinematic replay."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np
from tqdm import tqdm

from loco_mujoco.datasets.trajectory import TrajectoryDataset


class TrajectoryMixin:
    """Mixed into :class:`LocoEnv`; relies on its model, data, observation index arrays, RNG and
    ``dataset_subject()`` (the embodiment as the datasets layer sees it)."""

    def _init_trajectories(self, random_start: bool, init_step_no: int | None, dataset_variant: str | None,
                           dataset_path: str | Path | None) -> None:
        if random_start and init_step_no is not None:
            raise ValueError("give either random_start=True or init_step_no=k, not both")
        if init_step_no is not None and (not isinstance(init_step_no, (int, np.integer)) or init_step_no < 0):
            raise ValueError(f"init_step_no must be a non-negative int, got {init_step_no!r}")
        self.random_start = bool(random_start)
        self.init_step_no = init_step_no
        self.dataset_variant = dataset_variant
        self.dataset_path = Path(dataset_path) if dataset_path is not None else None
        if self.dataset_path is not None and not self.dataset_path.is_file():
            raise FileNotFoundError(f"dataset_path {self.dataset_path} "
                                    f"{'is a folder' if self.dataset_path.is_dir() else 'does not exist'}; "
                                    "give a dataset .npz (ours, or the original LocoMuJoCo format)")
        self._dataset: TrajectoryDataset | None = None
        self._dataset_cols: tuple[np.ndarray, np.ndarray] | None = None
        self._goals_cache: np.ndarray | None = None

    # ---- the dataset ------------------------------------------------------------------------------
    @property
    def dataset(self) -> TrajectoryDataset:
        """This task's dataset (built into the cache on first use), in the full model's layout."""
        if self._dataset is None:
            if self.dataset_path is not None:
                from loco_mujoco.datasets.loco_format import load_any_dataset
                self._dataset = load_any_dataset(self.dataset_subject(), self.dataset_path)
            elif self.dataset_type == "real":
                # retargeted clips, or rollouts of our quadruped controller (which sits above the environments)
                from loco_mujoco.controllers.datasets import load_real_dataset
                from loco_mujoco.datasets.registry import resolve_variant

                subject = self.dataset_subject()
                variant = resolve_variant(subject, self.task_name, self.dataset_variant)
                self._dataset = load_real_dataset(subject, self.task_name, variant, mode=self.mode)
            else:  # perfect / preference: rolled out by our agents, built into the cache on first use
                from loco_mujoco.agent_datasets import agent_dataset_path

                name = ".".join([type(self).__name__, self.task_name] + ([self.mode] if self.mode else [])
                                + [self.dataset_type])
                self._dataset = TrajectoryDataset.load(agent_dataset_path(name))
            if self.init_step_no is not None and self.init_step_no >= self._dataset.n_frames:
                raise ValueError(f"init_step_no={self.init_step_no} but the dataset has "
                                 f"{self._dataset.n_frames} frames")
        return self._dataset

    def _dataset_columns(self) -> tuple[np.ndarray, np.ndarray]:
        """Columns of the dataset's qpos and qvel that make up this env's qpos and qvel."""
        if self._dataset_cols is None:
            ds, m = self.dataset, self._model
            from loco_mujoco.datasets.trajectory import joint_layout
            q_at, v_at = joint_layout(ds.joint_names)
            qcols, vcols = [], []
            for j in range(m.njnt):
                name = m.joint(j).name
                if name not in q_at:
                    raise ValueError(f"dataset has no joint {name!r} that {type(self).__name__} needs; "
                                     f"it has {list(ds.joint_names)}")
                qcols.append(q_at[name])
                vcols.append(v_at[name])
            self._dataset_cols = (np.concatenate(qcols), np.concatenate(vcols))
        return self._dataset_cols

    def dataset_states(self, frames: np.ndarray | slice | None = None) -> tuple[np.ndarray, np.ndarray]:
        """This env's (qpos, qvel) at dataset ``frames`` (all by default)."""
        qcols, vcols = self._dataset_columns()
        frames = slice(None) if frames is None else frames
        return self.dataset.qpos[frames][:, qcols], self.dataset.qvel[frames][:, vcols]

    def dataset_observations(self, frames: np.ndarray | slice | None = None) -> np.ndarray:
        """Observations of dataset frames in this env's observation layout (vectorised)."""
        frames = slice(None) if frames is None else frames
        qpos, qvel = self.dataset_states(frames)
        parts = [qpos[:, self._qpos_idx], qvel[:, self._qvel_idx]]
        if self._n_foot:  # motion data has no forces: NaN, so that using them by mistake shows
            parts.append(np.full((len(qpos), self._n_foot), np.nan))
        parts += self._dataset_extras(frames, len(qpos))
        return np.concatenate(parts, axis=1)

    def _dataset_extras(self, frames: np.ndarray | slice, n: int) -> list[np.ndarray]:
        """The extra observation entries (see ``extra_observations``) of the ``n`` dataset ``frames``; NaN where
        the motion data cannot know them (the carried load)."""
        out = [self._dataset_goals()[frames]] if self.GOAL_OBSERVATION else []
        if self.has_load:
            out.append(np.full((n, 1), np.nan))
        return out

    def _dataset_goals(self) -> np.ndarray:
        """Goal (cos, sin, speed) of every dataset frame: its root velocity averaged over 0.5 s, as a direction in
        the root's heading frame (like the velocity reward) and a speed."""
        if getattr(self, "_goals_cache", None) is None:
            from scipy.ndimage import uniform_filter1d

            ds = self.dataset
            width = max(1, int(0.5 * ds.frequency))
            vel = np.empty((ds.n_frames, 2))
            for i in range(ds.n_trajectories):  # average within each trajectory, never across two
                sl = ds.trajectory_slice(i)
                vel[sl] = uniform_filter1d(ds.qvel[sl, :2], width, axis=0, mode="nearest")
            qw, qx, qy, qz = ds.qpos[:, 3:7].T  # the free root joint comes first in every dataset's qpos
            yaw = np.arctan2(2.0 * (qx * qy + qw * qz), 1.0 - 2.0 * (qy * qy + qz * qz))
            heading = np.arctan2(vel[:, 1], vel[:, 0]) - yaw
            self._goals_cache = np.stack([np.cos(heading), np.sin(heading), np.hypot(vel[:, 0], vel[:, 1])], axis=1)
        return self._goals_cache

    def transition_frames(self) -> np.ndarray:
        """Dataset frames that start a transition (every frame but each trajectory's last), in order."""
        keep = np.ones(self.dataset.n_frames, dtype=bool)
        keep[self.dataset.split_points[1:] - 1] = False  # the last frame of a trajectory has no successor
        return np.flatnonzero(keep)

    def dataset_task_rewards(self) -> np.ndarray:
        """The task reward of every dataset transition (see ``transition_frames``): what the expert earns per step
        along its own frames, the 100 of the normalised score."""
        obs = self.dataset_observations()
        action = np.zeros(self._n_act)
        idx = self.transition_frames()
        out = np.empty(len(idx))
        try:
            for k, i in enumerate(idx):
                self._set_reward_context(int(i))
                out[k] = self._reward_fn(obs[i], action, obs[i + 1])
        finally:
            self._set_reward_context(None)
        return out

    def _set_reward_context(self, frame: int | None) -> None:
        """Set what the reward depends on besides the observation (e.g. a body size's target speed) to that of
        dataset ``frame``; ``None`` restores the current episode's."""

    def create_dataset(self) -> dict[str, np.ndarray]:
        """Transitions of the dataset: ``states, next_states, absorbing, last`` (and ``actions`` if it has them)."""
        ds = self.dataset
        obs = self.dataset_observations()
        ends = ds.split_points[1:] - 1
        idx = self.transition_frames()
        last = np.zeros(len(idx), dtype=bool)
        last[np.searchsorted(idx, ends - 1)] = True
        absorbing = ds.absorbing[idx + 1].astype(bool) if ds.absorbing is not None else np.zeros(len(idx), dtype=bool)
        out = {"states": obs[idx], "next_states": obs[idx + 1], "absorbing": absorbing, "last": last}
        if ds.actions is not None:
            out["actions"] = ds.actions[idx]
        return out

    # ---- starting from the dataset ----------------------------------------------------------------
    def _start_frame(self) -> int | None:
        if self.init_step_no is not None:
            _ = self.dataset  # validates the step number
            return int(self.init_step_no)
        if self.random_start:
            return int(self._rng.integers(self.dataset.n_frames))
        return None

    def _set_dataset_state(self, frame: int) -> None:
        qpos, qvel = self.dataset_states(np.array([frame]))
        self._data.qpos[:] = qpos[0]
        self._data.qvel[:] = qvel[0]
        if self.GOAL_OBSERVATION:
            self._goal[:] = self._dataset_goals()[frame]

    # ---- replay -----------------------------------------------------------------------------------
    def _episode_slices(self, n_episodes: int | None, n_steps_per_episode: int | None) -> list[slice]:
        ds = self.dataset
        n = ds.n_trajectories if n_episodes is None else min(int(n_episodes), ds.n_trajectories)
        slices = [ds.trajectory_slice(i) for i in range(n)]
        if n_steps_per_episode is not None:
            slices = [slice(s.start, min(s.stop, s.start + int(n_steps_per_episode))) for s in slices]
        return slices

    def play_trajectory(self, n_episodes: int | None = None, n_steps_per_episode: int | None = None,
                        render: bool = False, record: bool = False, video_path: str | Path | None = None,
                        width: int = 640, height: int = 480, progress: bool = False) -> dict[str, Any]:
        """Replay the dataset kinematically, checking each state against the fall criteria.

        Returns frame counts, the fraction of frames that would count as fallen, the first fallen frame of
        each episode (or -1), and the video path when ``record`` (frames rendered offscreen).
        """
        m, d = self._model, self._data
        frames_rgb: list[np.ndarray] = []
        fallen_first: list[int] = []
        n_frames = n_fallen = 0
        for sl in tqdm(self._episode_slices(n_episodes, n_steps_per_episode), disable=not progress,
                       desc="replay", unit="episode"):
            obs = self.dataset_observations(sl)
            qpos, qvel = self.dataset_states(sl)
            first = -1
            for t in range(len(obs)):
                fallen = self.is_absorbing(obs[t])
                if fallen and first < 0:
                    first = t
                n_fallen += fallen
                if render or record:
                    d.qpos[:], d.qvel[:] = qpos[t], qvel[t]
                    mujoco.mj_forward(m, d)
                    frames_rgb.append(self.render_rgb(width, height))
            n_frames += len(obs)
            fallen_first.append(first)
        result: dict[str, Any] = {"frames": n_frames, "fallen_frames": int(n_fallen),
                                  "fallen_fraction": n_fallen / max(n_frames, 1), "first_fallen": fallen_first}
        if record and frames_rgb:
            from loco_mujoco.demo import write_video
            path = Path(video_path or f"{type(self).__name__}.{self.task_name}.replay.mp4")
            write_video(frames_rgb, path, int(round(self.dataset.frequency)))
            result["video"] = str(path)
        elif render:
            result["frames_rgb"] = frames_rgb
        return result

    def play_trajectory_from_velocity(self, n_episodes: int | None = None,
                                      n_steps_per_episode: int | None = None) -> dict[str, Any]:
        """Integrate the dataset's velocities from each episode's first state and compare with its positions.

        A consistent dataset drifts little: ``root_drift_per_second`` (m/s) is the root position error at
        the end of each episode divided by its duration.
        """
        m = self._model
        dt = 1.0 / self.dataset.frequency
        drifts, joint_errors = [], []
        for sl in self._episode_slices(n_episodes, n_steps_per_episode):
            qpos, qvel = self.dataset_states(sl)
            q = qpos[0].copy()
            for t in range(len(qpos) - 1):
                mujoco.mj_integratePos(m, q, qvel[t], dt)  # explicit Euler: no telescoping back to qpos
            duration = (len(qpos) - 1) * dt
            drifts.append(float(np.linalg.norm(q[:3] - qpos[-1, :3]) / duration))
            joint_errors.append(float(np.sqrt(np.mean((q[7:] - qpos[-1, 7:]) ** 2))))
        return {"root_drift_per_second": drifts, "max_root_drift_per_second": max(drifts),
                "joint_rms_error_end": joint_errors}

    def dataset_target_velocity(self) -> float:
        """The task reward's target speed: the dataset's mean forward speed (mean speed for goal-vector tasks)."""
        key = "mean_speed" if self.GOAL_OBSERVATION else "mean_forward_speed"
        return float(self.dataset.metadata[key])
