"""Evaluate an agent under the protocol of :mod:`loco_mujoco.evaluation.protocol`: R (undiscounted return), J
(discounted), L (episode length) and the mean task reward per step, each per episode.

The rewards are the environment's own (task) rewards, never the discriminator's. Deterministic evaluation
uses the mean action; stochastic evaluation samples from a generator seeded by ``seed``, so evaluating
never consumes the policy's training noise (which keeps resumed runs identical to uninterrupted ones).
"""

from __future__ import annotations

from typing import Any

from loco_mujoco.evaluation.protocol import Evaluation, run_episodes


def evaluate_agent(agent: Any, env: Any, n_episodes: int, deterministic: bool = True, seed: int = 0,
                   record: bool = False, progress: bool = False) -> Evaluation:
    """The agent's episodes under the protocol (``env`` re-seeded with ``seed``); ``record`` keeps the states.

    ``agent`` is a Mushroom-RL agent whose ``policy`` offers ``evaluation_mode`` (the baselines' policies), or a
    policy offering ``evaluation_mode`` and ``draw_action`` itself (a pretrained agent,
    :class:`~baselines.pretrained.PretrainedPolicy`).
    """
    policy = getattr(agent, "policy", agent)
    if not hasattr(policy, "evaluation_mode"):
        raise TypeError(f"{type(policy).__name__} has no evaluation_mode; use baselines.common.GaussianPolicy")
    with policy.evaluation_mode(deterministic=deterministic, seed=seed):
        return run_episodes(env, agent.draw_action, n_episodes, seed, record=record, progress=progress,
                            desc="deterministic" if deterministic else "stochastic")


def evaluate(agent: Any, env: Any, n_episodes: int = 10, deterministic: bool = True, seed: int = 0) -> dict[str, float]:
    """Mean R, J, L and task reward per step of ``n_episodes`` episodes (what training logs every epoch)."""
    stats = evaluate_agent(agent, env, n_episodes, deterministic, seed).statistics()
    return {**stats, "deterministic": bool(deterministic)}
