"""Imitation metrics of evaluation episodes against the expert's motion (see :mod:`loco_mujoco.metrics`).

Each episode is compared with the dataset frames that follow its start frame in the same trajectory, up to
the end of that trajectory or the horizon. An episode that ended early (a fall) is padded with its last
state: the fallen robot stays where it fell, so failing early never looks close. Trajectory distances use
joint angles (rad) and the pelvis height with the feet's positions relative to the pelvis (m); gait metrics
come from foot contacts; distribution metrics compare the kinematic observations of all episodes (padded
alike) with all dataset frames. Expert values: gait metrics of the matching dataset segments, and
distribution metrics of alternate 1 s chunks of the dataset against the rest (their noise floor: two samples
of one distribution).
"""

from __future__ import annotations

import warnings

import mujoco
import numpy as np

from loco_mujoco import metrics
from loco_mujoco.datasets.retarget import _Feet
from loco_mujoco.evaluation.protocol import Evaluation

TRAJECTORY_METRICS = {"euclidean": metrics.euclidean_distance, "dtw": metrics.dtw_distance,
                      "frechet": metrics.frechet_distance}
DISTRIBUTION_METRICS = {"mmd": metrics.mmd_rbf, "sliced_wasserstein": metrics.sliced_wasserstein,
                        "classifier_auc": metrics.classifier_auc}
MIN_GAIT_STEPS = 50  # shorter overlaps (0.5 s) hold no full stride


def reference_qpos(env, start_frame: int, n_steps: int) -> np.ndarray:
    """Dataset qpos (env layout) from ``start_frame`` to the end of its trajectory, at most ``n_steps`` rows."""
    ds = env.dataset
    stop = ds.trajectory_slice(int(ds.trajectory_of_frame(start_frame))).stop
    qpos, _ = env.dataset_states(slice(start_frame, min(stop, start_frame + n_steps)))
    return qpos


class _Kinematics:
    """Pelvis and foot positions and foot-sole geometry of qpos sequences on one model."""

    def __init__(self, env):
        self.model = env.model
        self.data = mujoco.MjData(self.model)
        self.feet_bodies = env.foot_bodies()
        self.feet = _Feet(self.model, self.feet_bodies)
        root = self.model.joint(0)
        self.body_ids = np.array([int(root.bodyid[0])] + [self.model.body(b).id for b in self.feet_bodies])
        self.contact_height = float(env.RETARGET.contact_height)
        self.dt = float(env.dt)

    def sites(self, qpos: np.ndarray) -> np.ndarray:
        """Pelvis height and each foot's position relative to the pelvis in its heading frame, (T, 1 + 3 * feet):
        the body's posture, free of where it has travelled (the gait metrics measure travel)."""
        xpos = np.empty((len(qpos), len(self.body_ids), 3))
        for t, q in enumerate(qpos):
            self.data.qpos[:] = q
            mujoco.mj_kinematics(self.model, self.data)
            xpos[t] = self.data.xpos[self.body_ids]
        heading = _heading(qpos)
        rel = xpos[:, 1:] - xpos[:, :1]
        forward = np.einsum("tfk,tk->tf", rel[..., :2], heading)
        left = np.einsum("tfk,tk->tf", rel[..., :2], np.stack([-heading[:, 1], heading[:, 0]], axis=1))
        feet = np.stack([forward, left, rel[..., 2]], axis=2).reshape(len(qpos), -1)
        return np.concatenate([xpos[:, 0, 2:3], feet], axis=1)

    def gait(self, qpos: np.ndarray) -> dict[str, float]:
        """Gait metrics of a qpos sequence (NaN for all when shorter than ``MIN_GAIT_STEPS``)."""
        if len(qpos) < MIN_GAIT_STEPS:
            return {k: float("nan") for k in GAIT_KEYS}
        pts = self.feet.sole_points(qpos)  # (T, feet, points, 3)
        lowest = pts[..., 2].argmin(axis=2)
        t_idx, f_idx = np.arange(len(qpos))[:, None], np.arange(pts.shape[1])[None]
        low = pts[t_idx, f_idx, lowest]  # (T, feet, 3)
        return metrics.gait_metrics(low[..., 2], low[..., :2], qpos[:, :2], _heading(qpos), self.dt,
                                    self.contact_height)


def _heading(qpos: np.ndarray) -> np.ndarray:
    """Unit heading (T, 2) of the root: its x axis projected on the floor."""
    qw, qx, qy, qz = qpos[:, 3:7].T
    heading = np.stack([1.0 - 2.0 * (qy * qy + qz * qz), 2.0 * (qx * qy + qw * qz)], axis=1)
    return heading / np.maximum(np.linalg.norm(heading, axis=1, keepdims=True), 1e-9)


GAIT_KEYS = ("forward_speed", "cadence", "stride_length", "duty_factor", "double_support", "foot_clearance",
             "foot_sliding", "symmetry")


def padded(rows: np.ndarray, n: int) -> np.ndarray:
    """The first ``n`` rows of ``rows``, repeating its last row where it is shorter (an episode ended by a fall)."""
    if len(rows) >= n:
        return rows[:n]
    return np.concatenate([rows, np.repeat(rows[-1:], n - len(rows), axis=0)])


def _nanmean(values: list[float]) -> float:
    arr = np.asarray(values, dtype=float)
    return float(np.nanmean(arr)) if np.any(np.isfinite(arr)) else float("nan")


def imitation_metrics(env, evaluation: Evaluation, seed: int = 0) -> dict[str, dict]:
    """Trajectory, gait and distribution metrics of ``evaluation``'s recorded episodes (``record=True``).

    Returns ``{"trajectory": {name_joints|name_sites: per-episode list}, "gait": {"agent": ..., "expert": ...,
    "deviation": per-episode list}, "distribution": {"agent": ..., "expert": ...}}``.
    """
    if any(e.qpos is None for e in evaluation.episodes):
        raise ValueError("imitation metrics need recorded episodes: run_episodes(..., record=True)")
    if any(e.start_frame is None for e in evaluation.episodes):
        raise ValueError("imitation metrics compare episodes with the dataset frames they start from; "
                         "evaluate with random_start=True")
    kin = _Kinematics(env)
    traj: dict[str, list[float]] = {f"{n}_{part}": [] for part in ("joints", "sites") for n in TRAJECTORY_METRICS}
    gait_agent: dict[str, list[float]] = {k: [] for k in GAIT_KEYS}
    gait_expert: dict[str, list[float]] = {k: [] for k in GAIT_KEYS}
    mask = env.get_kinematic_obs_mask()
    agent_parts, deviation = [], []
    for ep in evaluation.episodes:
        ref = reference_qpos(env, ep.start_frame, int(env.info.horizon) + 1)
        agent_parts.append(padded(ep.observations[:, mask], len(ref)))
        agent = padded(ep.qpos, len(ref))
        pairs = {"joints": (agent[:, 7:], ref[:, 7:]), "sites": (kin.sites(agent), kin.sites(ref))}
        for part, (a, b) in pairs.items():
            for name, fn in TRAJECTORY_METRICS.items():
                traj[f"{name}_{part}"].append(fn(a, b))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            n = min(len(ep.qpos), len(ref))  # gait over the steps both really have: no padding
            for key, value in kin.gait(ep.qpos[:n]).items():
                gait_agent[key].append(value)
            for key, value in kin.gait(ref[:n]).items():
                gait_expert[key].append(value)
            # one number per episode: the padded episode's gait against the whole reference segment
            deviation.append(metrics.gait_deviation(kin.gait(agent), kin.gait(ref)))
    expert_states = env.dataset_observations()[:, mask]
    agent_states = np.concatenate(agent_parts)  # padded like the trajectories: early falls weigh as fallen states
    distribution = {name: fn(agent_states, expert_states, seed=seed) for name, fn in DISTRIBUTION_METRICS.items()}
    chunk = max(1, int(round(env.dataset.frequency)))
    held_out = (np.arange(len(expert_states)) // chunk) % 2 == 0
    expert_floor = {name: fn(expert_states[held_out], expert_states[~held_out], seed=seed)
                    for name, fn in DISTRIBUTION_METRICS.items()}
    return {"trajectory": traj,
            "gait": {"agent": {k: _nanmean(v) for k, v in gait_agent.items()},
                     "expert": {k: _nanmean(v) for k, v in gait_expert.items()}, "deviation": deviation},
            "distribution": {"agent": distribution, "expert": expert_floor}}
