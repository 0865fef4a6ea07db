"""IQ-Learn: Inverse soft-Q Learning for Imitation (Garg et al., 2021), on the off-policy actor-critic loop.

The critic is the soft-Q function of the policy and of an implicit reward ``r(s, a) = Q(s, a) - gamma V'(s')``
at once. Each critic ``j`` minimises the inverse soft-Q objective with the chi-squared regulariser (online
form: on expert and policy samples)

    L(Q_j) = -E_expert[Q_j(s, a) - y]  +  value term  +  chi2_coef * E_{expert + policy}[(Q_j(s, a) - y)^2],

    y = gamma (1 - absorbing) V'(s'),

    value term = E_{s ~ expert + policy}[V_j(s) - y]     (loss_mode "value")
               = (1 - gamma) E_{s ~ expert}[V_j(s)]       (loss_mode "v0": expert states stand in for the
                                                          initial-state distribution)

with ``V_j(s) = Q_j(s, a~) - alpha log pi(a~|s)``, ``a~ ~ pi(.|s)``, and ``V'`` the target critics' soft value.
The first term raises the implicit reward of expert pairs, the value term lowers the values of the states
visited, and ``chi2_coef = 1/(4 * 0.5)`` is the paper's chi-squared weight. The actor is SAC's on the learned Q.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from baselines.common.offpolicy import CriticBatch, OffPolicyConfig, OffPolicyImitation


@dataclass
class IQLearnConfig(OffPolicyConfig):
    loss_mode: str = "value"  # "value" or "v0"
    chi2_coef: float = 0.5  # weight of the chi-squared regulariser, 1/(4 alpha_chi2) with alpha_chi2 = 0.5

    def validate(self) -> None:
        super().validate()
        if self.loss_mode not in ("value", "v0"):
            raise ValueError(f"loss_mode must be 'value' or 'v0', got {self.loss_mode!r}")
        if self.chi2_coef < 0:
            raise ValueError(f"chi2_coef must be >= 0, got {self.chi2_coef}")


def iq_loss(batch: CriticBatch, loss_mode: str, chi2_coef: float) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The IQ-Learn critic loss (module docstring), summed over the critics."""
    y = batch.gamma * (1.0 - batch.absorbing) * batch.next_v
    reward = batch.q - y  # implicit reward of each (s, a), per critic
    expert_term = -reward[:, batch.n_agent:].mean(1)
    if loss_mode == "value":
        value_term = (batch.v - y).mean(1)
    else:
        value_term = (1.0 - batch.gamma) * batch.v[:, batch.n_agent:].mean(1)
    chi2 = chi2_coef * reward.square().mean(1)
    loss = (expert_term + value_term + chi2).sum()
    return loss, {"expert_term": expert_term.mean(), "value_term": value_term.mean(), "chi2_term": chi2.mean(),
                  "reward_agent": reward[:, :batch.n_agent].mean(), "reward_expert": reward[:, batch.n_agent:].mean()}


class IQLearn(OffPolicyImitation):
    name = "iq_learn"
    config_class = IQLearnConfig
    config: IQLearnConfig

    def critic_loss(self, batch: CriticBatch) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        return iq_loss(batch, self.config.loss_mode, self.config.chi2_coef)
