"""LS-IQ: Least Squares Inverse Q-Learning (Al-Hafez et al., 2023), on the off-policy actor-critic loop.

IQ-Learn's chi-squared regulariser taken over the mixture of expert and policy data bounds the implicit reward to
``r in [-1/c, 1/c]``, hence the value to ``|Q| <= Q_max = 1 / (c (1 - gamma))`` (``c = reg_mult``). Every target
bootstraps from ``y = gamma V~(s')``, where ``V~`` is the target critics' soft value clipped to ``[-Q_max, Q_max]``,
or the form's floor ``V_min`` when ``s'`` is absorbing. Each critic ``j`` minimises, by ``loss_form``:

    "least_squares" (default; the paper's form, two regressions):
    L(Q_j) = E_expert[(Q_j(s, a) - Q_max)^2]  +  E_{s ~ expert + policy}[(V_j(s) - (-1/c + y))^2]

    "chi2" (IQ-Learn's objective with LS-IQ's bounded targets and fixed expert target):
    L(Q_j) = E_expert[(Q_j(s, a) - Q_max)^2]  +  E_{s ~ expert + policy}[V_j(s) - y]
             +  c E_{expert + policy}[(Q_j(s, a) - y)^2]

with ``V_j(s) = Q_j(s, a~) - alpha log pi(a~|s)``, ``a~ ~ pi(.|s)``. In both, expert pairs are pulled to the upper
bound and every state's value down. The least-squares form regresses each state's value onto the lowest reward
``-1/c`` plus the bootstrap, so states from which the agent never meets the expert settle at ``V_min = -Q_max``
(results/README.md: "critic saturated"); the chi-squared form lowers values by a constant gradient that the
regulariser on the implicit reward ``Q - y`` of the pairs taken balances at ``r = -1/(2c)`` where only the agent
goes, so its floor is ``V_min = -Q_max / 2``. An absorbing state is worth ``V_min`` (the lowest reward forever), not
zero: with zero, ending an episode would be worth more than living at a negative reward, and with a positive reward
the agent would be rewarded for merely surviving.

With ``from_observations: true`` (LSIQfO) the expert's actions come from an inverse-dynamics model learned on
the agent's own transitions; otherwise from the dataset (``train.expert_actions: auto`` gives inverse-dynamics
actions by ``mj_inverse`` where the dataset has none).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from baselines.common.offpolicy import CriticBatch, OffPolicyConfig, OffPolicyImitation

LOSS_FORMS = ("least_squares", "chi2")


@dataclass
class LSIQConfig(OffPolicyConfig):
    reg_mult: float = 0.5  # c: implicit rewards in [-1/c, 1/c], values in +-1/(c (1 - gamma))
    loss_form: str = "least_squares"  # or "chi2" (module docstring)

    def validate(self) -> None:
        super().validate()
        if not self.reg_mult > 0:
            raise ValueError(f"reg_mult must be > 0, got {self.reg_mult}")
        check_loss_form(self.loss_form)


def check_loss_form(loss_form: str) -> None:
    """ValueError naming the valid forms unless ``loss_form`` is one of them."""
    if loss_form not in LOSS_FORMS:
        raise ValueError(f"loss_form must be one of {LOSS_FORMS}, got {loss_form!r}")


def q_bound(reg_mult: float, gamma: float) -> float:
    """``Q_max = 1 / (c (1 - gamma))``, the largest value LS-IQ's targets can take."""
    return 1.0 / (reg_mult * (1.0 - gamma))


def value_floor(reg_mult: float, gamma: float, loss_form: str = "least_squares") -> float:
    """``V_min``, the value of the lowest implicit reward forever: ``-Q_max`` (least squares), ``-Q_max / 2`` (chi2)."""
    check_loss_form(loss_form)
    return -q_bound(reg_mult, gamma) / (1.0 if loss_form == "least_squares" else 2.0)


def lsiq_bootstrap(next_v: torch.Tensor, absorbing: torch.Tensor, gamma: float, reg_mult: float,
                   loss_form: str = "least_squares") -> torch.Tensor:
    """``y = gamma clip(V'(s'), -Q_max, Q_max)``, or ``gamma V_min`` where ``s'`` is absorbing."""
    q_max = q_bound(reg_mult, gamma)
    floor = value_floor(reg_mult, gamma, loss_form)
    return gamma * torch.where(absorbing > 0, floor, next_v.clamp(-q_max, q_max))


def lsiq_value_target(next_v: torch.Tensor, absorbing: torch.Tensor, gamma: float, reg_mult: float) -> torch.Tensor:
    """The least-squares form's value target ``-1/c + y``: ``-Q_max`` exactly at absorbing states."""
    return -1.0 / reg_mult + lsiq_bootstrap(next_v, absorbing, gamma, reg_mult)


def lsiq_loss(batch: CriticBatch, reg_mult: float,
              loss_form: str = "least_squares") -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    """The LS-IQ critic loss of ``loss_form`` (module docstring), summed over the critics."""
    q_max = q_bound(reg_mult, batch.gamma)
    expert_term = (batch.q[:, batch.n_agent:] - q_max).square().mean(1)
    if loss_form == "least_squares":
        target = lsiq_value_target(batch.next_v, batch.absorbing, batch.gamma, reg_mult)
        value_term = (batch.v - target).square().mean(1)
        loss = (expert_term + value_term).sum()
        return loss, {"expert_term": expert_term.mean(), "value_term": value_term.mean(), "value_target": target.mean()}
    y = lsiq_bootstrap(batch.next_v, batch.absorbing, batch.gamma, reg_mult, loss_form)
    reward = batch.q - y  # implicit reward of each (s, a), per critic
    value_term = (batch.v - y).mean(1)
    chi2 = reg_mult * reward.square().mean(1)
    loss = (expert_term + value_term + chi2).sum()
    return loss, {"expert_term": expert_term.mean(), "value_term": value_term.mean(), "chi2_term": chi2.mean(),
                  "reward_agent": reward[:, :batch.n_agent].mean(), "reward_expert": reward[:, batch.n_agent:].mean()}


class LSIQ(OffPolicyImitation):
    name = "lsiq"
    config_class = LSIQConfig
    config: LSIQConfig

    @property
    def uses_agent_values(self) -> bool:  # type: ignore[override]
        """The least-squares form never reads the agent's Q(s, a) (those rows skip the critic pass); chi2 does."""
        return self.config.loss_form == "chi2"

    def critic_loss(self, batch: CriticBatch) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        return lsiq_loss(batch, self.config.reg_mult, self.config.loss_form)
