"""LS-IQ: Least Squares Inverse Q-Learning (Al-Hafez et al., 2023), on the off-policy actor-critic loop.

IQ-Learn's chi-squared regulariser taken over the mixture of expert and policy data turns the inverse soft-Q
objective into two least-squares regressions with a bounded implicit reward ``r in [-1/c, 1/c]``, hence a
bounded value ``|Q| <= Q_max = 1 / (c (1 - gamma))`` (``c = reg_mult``). Each critic ``j`` minimises

    L(Q_j) = E_expert[(Q_j(s, a) - Q_max)^2]  +  E_{s ~ expert + policy}[(V_j(s) - y(s, s'))^2],

    y = r_min(s') + gamma (1 - absorbing) clip(V'(s'), -Q_max, Q_max),
    r_min = -1/c, or -1/(c (1 - gamma)) = -Q_max when s' is absorbing,

with ``V_j(s) = Q_j(s, a~) - alpha log pi(a~|s)``, ``a~ ~ pi(.|s)`` and ``V'`` the target critics' soft value:
expert pairs are pulled to the upper bound, every state's value towards the lower reward plus the clipped
bootstrap. An absorbing state is a state that yields ``r_min`` forever (value ``-Q_max``), not zero: with
zero, ending an episode would be worth more than living at a negative reward, and with a positive reward the
agent would be rewarded for merely surviving; the explicit value removes both biases. Every target lies in
``[-Q_max, Q_max]``.

With ``from_observations: true`` (LSIQfO) the expert's actions come from an inverse-dynamics model learned on
the agent's own transitions; otherwise from the dataset (``train.expert_actions: auto`` gives inverse-dynamics
actions by ``mj_inverse`` where the dataset has none).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from baselines.common.offpolicy import CriticBatch, OffPolicyConfig, OffPolicyImitation


@dataclass
class LSIQConfig(OffPolicyConfig):
    reg_mult: float = 0.5  # c: implicit rewards in [-1/c, 1/c], values in +-1/(c (1 - gamma))

    def validate(self) -> None:
        super().validate()
        if not self.reg_mult > 0:
            raise ValueError(f"reg_mult must be > 0, got {self.reg_mult}")


def q_bound(reg_mult: float, gamma: float) -> float:
    """``Q_max = 1 / (c (1 - gamma))``, the largest value LS-IQ's targets can take."""
    return 1.0 / (reg_mult * (1.0 - gamma))


def lsiq_value_target(next_v: torch.Tensor, absorbing: torch.Tensor, gamma: float, reg_mult: float) -> torch.Tensor:
    """``y = r_min + gamma (1 - absorbing) clip(V'(s'), -Q_max, Q_max)``, ``r_min = -Q_max`` at absorbing states."""
    q_max = q_bound(reg_mult, gamma)
    r_min = -(1.0 / reg_mult) * (1.0 + absorbing * (gamma / (1.0 - gamma)))
    return r_min + gamma * (1.0 - absorbing) * next_v.clamp(-q_max, q_max)


def lsiq_loss(batch: CriticBatch, reg_mult: float) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The LS-IQ critic loss (module docstring), summed over the critics."""
    q_max = q_bound(reg_mult, batch.gamma)
    expert_term = (batch.q[:, batch.n_agent:] - q_max).square().mean(1)
    target = lsiq_value_target(batch.next_v, batch.absorbing, batch.gamma, reg_mult)
    value_term = (batch.v - target).square().mean(1)
    loss = (expert_term + value_term).sum()
    return loss, {"expert_term": expert_term.mean(), "value_term": value_term.mean(), "value_target": target.mean()}


class LSIQ(OffPolicyImitation):
    name = "lsiq"
    config_class = LSIQConfig
    config: LSIQConfig
    uses_agent_values = False  # the loss reads the expert's Q(s, a) and every state's V, never the agent's Q(s, a)

    def critic_loss(self, batch: CriticBatch) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        return lsiq_loss(batch, self.config.reg_mult)
