"""The evaluation protocol: ``EPISODES`` episodes from dataset start states drawn with ``SEED``, every
figure a mean with a 95% interval and an IQM.

A policy is any callable ``obs -> action`` (normalised actions in [-1, 1]), so agents of any library can be
evaluated the same way. The env must start episodes from dataset states (``random_start=True``, the
default of every training config); re-seeding it with ``seed`` draws the same start frames (and loads,
body sizes, randomized dynamics) on every call, so two policies evaluated with one seed meet the same
episodes. Training runs evaluate every epoch with the first ``n_eval_episodes`` (10) of these episodes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from tqdm import tqdm

from loco_mujoco.evaluation.intervals import summarize

EPISODES = 50
SEED = 12345  # the evaluation seed of every training config (train.eval_seed)

Policy = Callable[[np.ndarray], np.ndarray]


@dataclass
class Episode:
    """One evaluation episode: its start frame (None: the home pose), per-step task rewards and, when recorded,
    the simulator's qpos and the observations at every step including the first (``length + 1`` rows)."""

    start_frame: int | None
    rewards: np.ndarray
    absorbing: bool
    qpos: np.ndarray | None = None
    observations: np.ndarray | None = None

    @property
    def length(self) -> int:
        return len(self.rewards)

    @property
    def undiscounted_return(self) -> float:
        return float(self.rewards.sum())

    def discounted_return(self, gamma: float) -> float:
        return float(np.sum(self.rewards * gamma ** np.arange(len(self.rewards))))


@dataclass
class Evaluation:
    """Episodes of one policy under the protocol, and their summaries."""

    episodes: list[Episode]
    gamma: float

    @property
    def returns(self) -> np.ndarray:
        return np.array([e.undiscounted_return for e in self.episodes])

    @property
    def lengths(self) -> np.ndarray:
        return np.array([e.length for e in self.episodes], dtype=float)

    @property
    def discounted_returns(self) -> np.ndarray:
        return np.array([e.discounted_return(self.gamma) for e in self.episodes])

    def statistics(self) -> dict[str, float]:
        """Mean R (return), J (discounted return), L (length) and task reward per step, as training logs them."""
        rewards = np.concatenate([e.rewards for e in self.episodes])
        return {"R": float(self.returns.mean()), "J": float(self.discounted_returns.mean()),
                "L": float(self.lengths.mean()), "task_reward": float(rewards.mean()), "episodes": len(self.episodes)}

    def summary(self) -> dict[str, dict]:
        """R, J and L each as mean, 95% interval and IQM."""
        return {"R": summarize(self.returns), "J": summarize(self.discounted_returns), "L": summarize(self.lengths)}


def evaluation_task(task: str, env_kwargs: dict | None = None) -> tuple[str, dict]:
    """The task name and env settings an agent of ``task`` is evaluated on: the real task, whatever dataset it
    trained on (``UnitreeH1.walk.perfect`` -> ``UnitreeH1.walk``, with the perfect data's settings such as PD
    control), so that every agent of a task meets the same start states and the same references."""
    kwargs = dict(env_kwargs or {})
    parts = task.split(".")
    if parts[-1] not in ("perfect", "preference", "real"):
        return task, kwargs
    base = ".".join(parts[:-1])
    if parts[-1] != "real" and kwargs.get("dataset_path") is None:
        from loco_mujoco.agent_datasets import agent_recipe, recipe_settings

        if agent_recipe(task) is not None:
            kwargs = {**recipe_settings(task), **{k: v for k, v in kwargs.items() if v is not None}}
    return base, kwargs


def evaluation_env(task: str, env_kwargs: dict | None = None, seed: int = SEED):
    """The environment of the protocol for agents of ``task`` (see :func:`evaluation_task`)."""
    from loco_mujoco import LocoEnv

    base, kwargs = evaluation_task(task, env_kwargs)
    return LocoEnv.make(base, **{"random_start": True, **kwargs}, seed=seed)


def run_episodes(env, policy: Policy, n_episodes: int = EPISODES, seed: int = SEED, record: bool = False,
                 progress: bool = False, desc: str = "evaluating") -> Evaluation:
    """Run ``n_episodes`` episodes of ``policy`` on ``env`` re-seeded with ``seed``; ``record`` keeps states."""
    if not isinstance(n_episodes, (int, np.integer)) or n_episodes < 1:
        raise ValueError(f"n_episodes must be a positive int, got {n_episodes!r}")
    horizon = int(env.info.horizon)
    env.seed(seed)
    episodes = []
    for _ in tqdm(range(n_episodes), disable=not progress, desc=desc, unit="episode", leave=False):
        obs = env.reset()
        start = getattr(env, "episode_start_frame", None)
        rewards = np.empty(horizon)
        qpos = [env.data.qpos.copy()] if record else None
        observations = [obs.copy()] if record else None
        absorbing = False
        t = 0
        while t < horizon:
            obs, reward, absorbing, _ = env.step(policy(obs))
            rewards[t] = reward
            t += 1
            if record:
                qpos.append(env.data.qpos.copy())
                observations.append(obs.copy())
            if absorbing:
                break
        episodes.append(Episode(start, rewards[:t].copy(), bool(absorbing),
                                np.array(qpos) if record else None, np.array(observations) if record else None))
    return Evaluation(episodes, float(env.info.gamma))
