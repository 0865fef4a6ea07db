"""GAIL: Generative Adversarial Imitation Learning (Ho & Ermon, 2016), on Mushroom-RL's Core with TRPO.

The discriminator sees expert **state-action pairs** ``(s[kinematic mask], a)`` against the policy's and is
trained with binary cross-entropy (plus a small Bernoulli-entropy bonus); the policy maximises
``-log(1 - D(s, a))`` with TRPO (see :mod:`baselines.common.adversarial` for the shared loop).

Datasets without actions: real motion-capture data has no actions, and GAIL cannot be trained on it. The
constructor then raises a ``ValueError`` that points to GAIfO (:mod:`baselines.gaifo`), which discriminates
``(s, s')`` instead, or to VAIL on states. Nothing is substituted silently.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from baselines.common.adversarial import AdversarialConfig, AdversarialImitation
from baselines.common.discriminators import Discriminator, gail_loss
from baselines.common.expert_data import ExpertData


@dataclass
class GAILConfig(AdversarialConfig):
    """GAIL uses the shared hyperparameters as they are."""


class GAIL(AdversarialImitation):
    name = "gail"
    config_class = GAILConfig

    def check_expert(self, expert: ExpertData) -> None:
        if not expert.has_actions:
            raise ValueError("GAIL needs expert actions, and this dataset has none (real motion capture never "
                             "does). Use GAIfO (baselines.gaifo, algorithm 'gaifo'), which discriminates state / "
                             "next-state pairs, or VAIL on states.")

    def discriminator_input_dim(self, n_obs: int, n_act: int) -> int:
        return n_obs + n_act

    def policy_inputs(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> np.ndarray:
        # The discriminator sees the action the environment executed: Gaussian samples clipped to its bounds.
        space = self.mdp_info.action_space
        executed = np.clip(action, space.low, space.high)
        return np.concatenate([state[:, self.obs_mask], executed], axis=1, dtype=np.float32)

    def expert_inputs(self, idx: np.ndarray) -> np.ndarray:
        return np.concatenate([self.expert.states[idx], self.expert.actions[idx]], axis=1)

    def build_discriminator(self, in_dim: int, generator: torch.Generator) -> nn.Module:
        return Discriminator(in_dim, self.config.disc_hidden, self.config.disc_activation, generator)

    def discriminator_loss(self, x: torch.Tensor, labels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        logits = self.discriminator(x)
        return gail_loss(logits, labels, self.config.disc_entropy_coef), logits
