"""VAIL: Variational Adversarial Imitation Learning (Peng et al., 2019), on Mushroom-RL's Core with TRPO.

The discriminator is a variational bottleneck (:class:`~baselines.common.discriminators.VariationalDiscriminator`):
its encoder maps the expert's or the policy's **states** (kinematic mask; with ``use_next_states`` the
``(s, s')`` pair) to a Gaussian latent of size 128, and a linear decoder gives the logit. Its loss is

    BCE(logits(z), label) + beta * (E[KL(q(z|x) || N(0, I))] - info_constraint),   z ~ q(z|x),

and after every step the multiplier follows ``beta = max(0, beta + lr_beta * (KL - info_constraint))``.
The bottleneck stops the discriminator from separating expert and policy perfectly, which would leave the
policy without a useful reward gradient. The policy maximises ``-log(1 - D(mean latent))`` with TRPO.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from baselines.common.adversarial import AdversarialConfig, AdversarialImitation
from baselines.common.discriminators import AdaptiveBeta, VariationalDiscriminator, bernoulli_entropy


@dataclass
class VAILConfig(AdversarialConfig):
    info_constraint: float = 0.1  # target E[KL] of the latent, in nats
    lr_beta: float = 1e-5  # step of the multiplier's dual ascent
    beta_init: float = 0.1
    latent_dim: int = 128
    use_next_states: bool = False  # discriminate (s, s') instead of s
    disc_entropy_coef: float = 0.0  # the bottleneck already regularises


class VAIL(AdversarialImitation):
    name = "vail"
    config_class = VAILConfig
    config: VAILConfig

    def __init__(self, *args: Any, **kwargs: Any):
        super().__init__(*args, **kwargs)
        self.beta = AdaptiveBeta(self.config.info_constraint, self.config.lr_beta, self.config.beta_init)
        self._last_kl = 0.0

    def discriminator_input_dim(self, n_obs: int, n_act: int) -> int:
        return 2 * n_obs if self.config.use_next_states else n_obs

    def policy_inputs(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> np.ndarray:
        if self.config.use_next_states:
            return np.concatenate([state[:, self.obs_mask], next_state[:, self.obs_mask]], axis=1, dtype=np.float32)
        return np.ascontiguousarray(state[:, self.obs_mask], dtype=np.float32)

    def expert_inputs(self, idx: np.ndarray) -> np.ndarray:
        if self.config.use_next_states:
            return np.concatenate([self.expert.states[idx], self.expert.next_states[idx]], axis=1)
        return self.expert.states[idx]

    def build_discriminator(self, in_dim: int, generator: torch.Generator) -> nn.Module:
        return VariationalDiscriminator(in_dim, self.config.disc_hidden, self.config.disc_activation,
                                        self.config.latent_dim, generator)

    def discriminator_loss(self, x: torch.Tensor, labels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        out = self.discriminator(x, generator=self._torch_generator)
        kl = out.kl().mean()
        loss = F.binary_cross_entropy_with_logits(out.logits, labels)
        loss = loss + self.beta.value * (kl - self.config.info_constraint)
        if self.config.disc_entropy_coef:
            loss = loss - self.config.disc_entropy_coef * bernoulli_entropy(out.logits).mean()
        self._last_kl = kl.item()
        return loss, out.logits

    def after_discriminator_step(self) -> None:
        self.beta.update(self._last_kl)

    def train_discriminator(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> dict[str, float]:
        stats = super().train_discriminator(state, action, next_state)
        return {**stats, "disc_kl": self._last_kl, "beta": self.beta.value}

    def extra_state(self) -> dict[str, Any]:
        return {"beta": self.beta.value, "last_kl": self._last_kl}

    def load_extra_state(self, state: dict[str, Any]) -> None:
        self.beta.value, self._last_kl = float(state["beta"]), float(state["last_kl"])
