"""SQIL: Soft Q Imitation Learning (Reddy et al., 2020), on the off-policy actor-critic loop.

Soft Q-learning with a constant reward: 1 on every expert transition, 0 on every transition of the agent,
from batches that are half expert, half agent. Each critic ``j`` minimises the soft Bellman error

    L(Q_j) = E_{expert + agent}[(Q_j(s, a) - (r + gamma (1 - absorbing) V'(s')))^2],
    r = 1 (expert), 0 (agent),

with ``V'(s') = min_j Qt_j(s', a') - alpha log pi(a'|s')`` from the target critics; the actor is SAC's. The
agent is drawn back towards the expert's states, where the reward is, and its own transitions' values decay.

With ``clip_targets``, ``V'(s')`` is clipped to ``[0, 1 / (1 - gamma)]``, the values rewards of 0 and 1 allow (as
LS-IQ clips to its bounds; the entropy term, ``alpha |log pi| / (1 - gamma)`` at most ~5 with alpha 1e-3, is left
out of the bound). Without it the critics of SQIL diverged on real motion capture: ``q_expert`` 326 after 10k
updates and 718,000 after 90k on Talos.walk, with twin critics (results/README.md, 2026-11-29).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from baselines.common.offpolicy import CriticBatch, OffPolicyConfig, OffPolicyImitation


@dataclass
class SQILConfig(OffPolicyConfig):
    """SQIL's one switch of its own, on top of the off-policy loop's hyperparameters."""

    clip_targets: bool = False  # clip V'(s') to the values rewards in [0, 1] allow (module docstring)


def sqil_rewards(batch: CriticBatch) -> torch.Tensor:
    """0 for the agent's rows, 1 for the expert's."""
    n = batch.q.shape[1]
    return (torch.arange(n) >= batch.n_agent).to(batch.q.dtype)


def sqil_loss(batch: CriticBatch, clip_targets: bool = False) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The SQIL critic loss (module docstring), summed over the critics."""
    next_v = batch.next_v.clamp(0.0, 1.0 / (1.0 - batch.gamma)) if clip_targets else batch.next_v
    target = sqil_rewards(batch) + batch.gamma * (1.0 - batch.absorbing) * next_v
    loss = (batch.q - target).square().mean(1).sum()
    return loss, {"td_target": target.mean()}


class SQIL(OffPolicyImitation):
    name = "sqil"
    config_class = SQILConfig
    config: SQILConfig
    uses_policy_values = False

    def critic_loss(self, batch: CriticBatch) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        return sqil_loss(batch, self.config.clip_targets)
