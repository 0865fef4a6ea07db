"""Reference policies and the normalised score: 0 = a uniformly random policy, 100 = the expert.

The expert's return is the task reward per step its dataset frames earn, times the horizon. The random
policy's is measured under the evaluation protocol. Two stand-still policies show that standing earns
nothing: zero action, and a controller holding the home pose (a PD law for torque and PD servos, a stretch
reflex for muscles), both started from the home pose. All four are computed by code and cached per task,
dataset (a digest of its states) and env settings, under ``$LOCO_MUJOCO_CACHE/references``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from typing import Any

import mujoco
import numpy as np

from loco_mujoco.atomic_write import atomic_write
from loco_mujoco.evaluation.protocol import SEED, Policy, evaluation_task, run_episodes

VERSION = 2  # bump when the reward, the protocol or a reference policy changes (2: 1,000 random episodes)
# Random-action returns spread widely (sd 16.4 R on Talos.walk, 13.4 on UnitreeH1.walk): the protocol's 50 episodes
# left random R within +-2.2-2.5 (+-0.5 score points, shared by every agent of a task); 1,000 leave +-0.4-0.5.
RANDOM_EPISODES = 1000
STAND_STILL_EPISODES = 5
# Settings that do not change what an episode earns, left out of the cache key.
_NOT_IN_KEY = {"seed", "viewer_params"}


@dataclass(frozen=True)
class References:
    """Returns of the four reference policies on one task under one set of env settings."""

    task: str
    horizon: int
    expert_reward_per_step: float
    expert_return: float
    random_return: float
    random_length: float
    zero_return: float
    zero_length: float
    hold_return: float
    hold_length: float
    dataset_digest: str
    env_settings: dict
    random_episodes: int = 0  # 0: measured before version 2 recorded it (50 episodes)
    random_return_se: float = float("nan")  # standard error of random_return

    def normalized_score(self, returns: np.ndarray | float) -> np.ndarray | float:
        """100 * (R - random) / (expert - random)."""
        span = self.expert_return - self.random_return
        return 100.0 * (np.asarray(returns, dtype=float) - self.random_return) / span


def random_policy(env, seed: int = SEED) -> Policy:
    """Uniform random actions in [-1, 1] from a generator seeded with ``seed``."""
    rng = np.random.default_rng(seed)
    n = env.info.action_space.shape[0]
    return lambda obs: rng.uniform(-1.0, 1.0, n)


def zero_policy(env) -> Policy:
    """Zero action: no torque, PD targets at the middle of each joint range, half excitation of each muscle."""
    action = np.zeros(env.info.action_space.shape[0])
    return lambda obs: action


def hold_pose_policy(env) -> Policy:
    """Hold the home pose: PD servos target it, torque motors apply a PD law towards it (the env's PD gains:
    peak torque at 0.25 rad error), muscles follow a stretch reflex (excited as they lengthen past their
    home length, fully at 2 cm)."""
    m, d = env.model, env.data
    home = env.home_qpos(m)
    if env.control == "muscle":
        probe = mujoco.MjData(m)
        probe.qpos[:] = home
        mujoco.mj_forward(m, probe)
        rest = probe.actuator_length.copy()
        return lambda obs: np.clip(2.0 * np.clip(50.0 * (d.actuator_length - rest) + 2.0 * d.actuator_velocity,
                                                 0.0, 1.0) - 1.0, -1.0, 1.0)
    joints = m.actuator_trnid[:, 0]
    qadr, vadr = m.jnt_qposadr[joints], m.jnt_dofadr[joints]
    target = home[qadr]
    if env.control == "pd":
        action = np.clip(env.ctrl_to_action(target), -1.0, 1.0)
        return lambda obs: action
    peak = np.abs(m.actuator_ctrlrange).max(axis=1)
    kp, kd = 4.0 * peak, 4.0 * peak / 25.0
    return lambda obs: np.clip(env.ctrl_to_action(kp * (target - d.qpos[qadr]) - kd * d.qvel[vadr]), -1.0, 1.0)


def dataset_digest(env) -> str:
    """sha256 (first 16 hex digits) of the dataset's states: references go stale when the data change."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(env.dataset.qpos).tobytes())
    h.update(np.ascontiguousarray(env.dataset.qvel).tobytes())
    return h.hexdigest()[:16]


def _settings(env_kwargs: dict[str, Any]) -> dict[str, str]:
    return {k: repr(v) for k, v in sorted(env_kwargs.items()) if k not in _NOT_IN_KEY}


def _cache_file(task: str, key: dict):
    from loco_mujoco.datasets.sources.fetch import cache_dir

    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:12]
    return cache_dir() / "references" / f"{task}.{digest}.json"


def compute_references(task: str, env_kwargs: dict[str, Any] | None = None, episodes: int | None = None,
                       seed: int = SEED, progress: bool = False, env=None) -> References:
    """Measure the four references of ``task`` for ``LocoEnv.make(task, **env_kwargs)`` (no cache); ``env``, if
    given, is that environment already built; ``episodes`` random-action episodes (default ``RANDOM_EPISODES``)."""
    from loco_mujoco import LocoEnv

    episodes = RANDOM_EPISODES if episodes is None else episodes

    task, kwargs = evaluation_task(task, env_kwargs)
    kwargs = {"random_start": True, **kwargs}
    env = env if env is not None else LocoEnv.make(task, **kwargs)
    horizon = int(env.info.horizon)
    per_step = float(env.dataset_task_rewards().mean())
    rnd = run_episodes(env, random_policy(env, seed), episodes, seed, progress=progress, desc=f"{task} random")
    standing = LocoEnv.make(task, **{**kwargs, "random_start": False, "init_step_no": None})
    zero = run_episodes(standing, zero_policy(standing), STAND_STILL_EPISODES, seed)
    hold = run_episodes(standing, hold_pose_policy(standing), STAND_STILL_EPISODES, seed)
    for e in (env, standing):
        e.stop()
    return References(task=task, horizon=horizon, expert_reward_per_step=per_step, expert_return=per_step * horizon,
                      random_return=float(rnd.returns.mean()), random_length=float(rnd.lengths.mean()),
                      zero_return=float(zero.returns.mean()), zero_length=float(zero.lengths.mean()),
                      hold_return=float(hold.returns.mean()), hold_length=float(hold.lengths.mean()),
                      dataset_digest=dataset_digest(env), env_settings=_settings(kwargs), random_episodes=episodes,
                      random_return_se=float(rnd.returns.std(ddof=1) / np.sqrt(episodes)) if episodes > 1 else 0.0)


def references(task: str, env_kwargs: dict[str, Any] | None = None, episodes: int | None = None, seed: int = SEED,
               refresh: bool = False, progress: bool = False) -> References:
    """The cached references of ``task`` under ``env_kwargs``, computed on first use (or when ``refresh``);
    ``episodes`` random-action episodes (default ``RANDOM_EPISODES``)."""
    from loco_mujoco import LocoEnv

    episodes = RANDOM_EPISODES if episodes is None else episodes

    task, kwargs = evaluation_task(task, env_kwargs)
    kwargs = {"random_start": True, **kwargs}
    env = LocoEnv.make(task, **kwargs)  # its dataset names the cache file; measured on directly when missing
    key = {"version": VERSION, "task": task, "settings": _settings(kwargs), "dataset": dataset_digest(env),
           "episodes": episodes, "seed": seed}
    path = _cache_file(task, key)
    if path.exists() and not refresh:
        env.stop()
        return References(**json.loads(path.read_text()))
    refs = compute_references(task, kwargs, episodes, seed, progress, env=env)
    with atomic_write(path, "w") as handle:
        handle.write(json.dumps(asdict(refs), indent=1))
    return refs


def stand_still_scores(refs: References) -> dict[str, float]:
    """Normalised scores of the two stand-still policies (both must stay near 0)."""
    return {"zero": float(refs.normalized_score(refs.zero_return)),
            "hold": float(refs.normalized_score(refs.hold_return))}

