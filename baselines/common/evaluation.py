"""Evaluate an agent: undiscounted return R, discounted return J, episode length L, mean task reward.

The rewards are the environment's own (task) rewards, never the discriminator's. Deterministic evaluation
uses the mean action; stochastic evaluation samples from a generator seeded by ``seed``, so evaluating
never consumes the policy's training noise (which keeps resumed runs identical to uninterrupted ones).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mushroom_rl.core import Core


def episode_statistics(dataset: list[tuple], gamma: float) -> dict[str, float]:
    """R, J, L and the mean per-step reward of the episodes in a Mushroom dataset (list of transitions)."""
    returns, discounted, lengths = [], [], []
    ret = disc = 0.0
    discount, length = 1.0, 0
    rewards = np.array([t[2] for t in dataset], dtype=np.float64)
    for transition, reward in zip(dataset, rewards, strict=True):
        ret += reward
        disc += discount * reward
        discount *= gamma
        length += 1
        if transition[-1]:  # last step of an episode
            returns.append(ret)
            discounted.append(disc)
            lengths.append(length)
            ret = disc = 0.0
            discount, length = 1.0, 0
    return {"R": float(np.mean(returns)), "J": float(np.mean(discounted)), "L": float(np.mean(lengths)),
            "task_reward": float(rewards.mean()), "episodes": len(returns)}


def evaluate(agent: Any, env: Any, n_episodes: int = 10, deterministic: bool = True, seed: int = 0) -> dict[str, float]:
    """Run ``n_episodes`` full episodes and return their mean R, J, L and mean task reward per step.

    ``agent.policy`` must offer ``evaluation_mode`` (:class:`~baselines.common.policy.GaussianPolicy`).
    """
    policy = agent.policy
    if not hasattr(policy, "evaluation_mode"):
        raise TypeError(f"{type(policy).__name__} has no evaluation_mode; use baselines.common.GaussianPolicy")
    with policy.evaluation_mode(deterministic=deterministic, seed=seed):
        dataset = Core(agent, env).evaluate(n_episodes=n_episodes, quiet=True)
    stats = episode_statistics(dataset, env.info.gamma)
    return {**stats, "deterministic": bool(deterministic)}
