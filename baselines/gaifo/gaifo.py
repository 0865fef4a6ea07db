"""GAIfO: Generative Adversarial Imitation from Observation (Torabi, Warnell & Stone, 2018).

GAIL without actions: the discriminator sees expert **state transitions** ``(s, s')`` (both restricted to the
kinematic mask) against the policy's, so it trains on real motion-capture datasets, which have no actions.
The policy maximises ``-log(1 - D(s, s'))`` with TRPO (shared loop: :mod:`baselines.common.adversarial`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from baselines.common.adversarial import AdversarialConfig, AdversarialImitation
from baselines.common.discriminators import Discriminator, gail_loss


@dataclass
class GAIfOConfig(AdversarialConfig):
    """GAIfO uses the shared hyperparameters as they are."""


class GAIfO(AdversarialImitation):
    name = "gaifo"
    config_class = GAIfOConfig

    def discriminator_input_dim(self, n_obs: int, n_act: int) -> int:
        return 2 * n_obs

    def policy_inputs(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> np.ndarray:
        return np.concatenate([state[:, self.obs_mask], next_state[:, self.obs_mask]], axis=1, dtype=np.float32)

    def expert_inputs(self, idx: np.ndarray) -> np.ndarray:
        return np.concatenate([self.expert.states[idx], self.expert.next_states[idx]], axis=1)

    def build_discriminator(self, in_dim: int, generator: torch.Generator) -> nn.Module:
        return Discriminator(in_dim, self.config.disc_hidden, self.config.disc_activation, generator)

    def discriminator_loss(self, x: torch.Tensor, labels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        logits = self.discriminator(x)
        return gail_loss(logits, labels, self.config.disc_entropy_coef), logits
