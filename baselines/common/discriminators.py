"""Discriminators for adversarial imitation: a plain one (GAIL, GAIfO) and a variational one (VAIL).

Both output **logits** of "this input comes from the expert". With ``D = sigmoid(logits)`` the policy's
reward is ``-log(1 - D) = softplus(logits)``: positive, and large where the discriminator believes the
policy looks like the expert (Ho & Ermon, 2016). Inputs are standardized by the caller.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from baselines.common.networks import build_mlp, normc_


def bernoulli_entropy(logits: torch.Tensor) -> torch.Tensor:
    """Entropy of ``Bernoulli(sigmoid(logits))``, computed stably from the logits."""
    return (1.0 - torch.sigmoid(logits)) * logits - F.logsigmoid(logits)


def gail_loss(logits: torch.Tensor, labels: torch.Tensor, entropy_coef: float) -> torch.Tensor:
    """Binary cross-entropy (label 1 = expert) minus ``entropy_coef`` times the mean Bernoulli entropy.

    The entropy bonus (1e-3 in the reference agents) keeps the discriminator from saturating early.
    """
    bce = F.binary_cross_entropy_with_logits(logits, labels)
    return bce - entropy_coef * bernoulli_entropy(logits).mean()


def adversarial_reward(logits: torch.Tensor) -> torch.Tensor:
    """``-log(1 - sigmoid(logits))``, i.e. ``softplus(logits)``."""
    return F.softplus(logits)


class Discriminator(nn.Module):
    """MLP from the (standardized) input to one logit; ``[512, 256]`` tanh in the reference setting."""

    def __init__(self, in_dim: int, hidden: Sequence[int] = (512, 256), activation: str = "tanh",
                 generator: torch.Generator | None = None):
        super().__init__()
        self.net = build_mlp(in_dim, 1, hidden, activation, output_std=0.01, generator=generator)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x).squeeze(-1)

    def reward(self, x: torch.Tensor) -> torch.Tensor:
        return adversarial_reward(self(x))


@dataclass
class VariationalOutput:
    logits: torch.Tensor
    mean: torch.Tensor
    log_var: torch.Tensor

    def kl(self) -> torch.Tensor:
        """Per-sample ``KL(N(mean, exp(log_var)) || N(0, I))`` summed over latent dimensions."""
        return 0.5 * torch.sum(self.mean**2 + torch.exp(self.log_var) - self.log_var - 1.0, dim=-1)


class VariationalDiscriminator(nn.Module):
    """Variational discriminator bottleneck (Peng et al., 2019).

    An encoder maps the input to the mean and log-variance of a Gaussian latent ``z`` (size 128); a linear
    decoder maps ``z`` to a logit. Training samples ``z`` (reparameterised, noise from ``generator``) and
    penalises ``KL(q(z|x) || N(0, I))`` above an information constraint (see :class:`AdaptiveBeta`), which
    limits how much the discriminator can know about its input and keeps its gradients informative.
    Rewards use the latent mean (no noise).
    """

    def __init__(self, in_dim: int, hidden: Sequence[int] = (512, 256), activation: str = "tanh",
                 latent_dim: int = 128, generator: torch.Generator | None = None):
        super().__init__()
        self.latent_dim = int(latent_dim)
        self.encoder = build_mlp(in_dim, 2 * self.latent_dim, hidden, activation, output_std=0.01,
                                 generator=generator)
        self.decoder = nn.Linear(self.latent_dim, 1)
        normc_(self.decoder.weight, 0.1, generator)
        nn.init.zeros_(self.decoder.bias)

    def forward(self, x: torch.Tensor, generator: torch.Generator | None = None,
                sample: bool = True) -> VariationalOutput:
        mean, log_var = self.encoder(x).chunk(2, dim=-1)
        z = mean
        if sample:
            noise = torch.randn(mean.shape, generator=generator, dtype=mean.dtype)
            z = mean + torch.exp(0.5 * log_var) * noise
        return VariationalOutput(self.decoder(z).squeeze(-1), mean, log_var)

    def reward(self, x: torch.Tensor) -> torch.Tensor:
        return adversarial_reward(self(x, sample=False).logits)


class AdaptiveBeta:
    """Lagrange multiplier of the information constraint ``E[KL] <= info_constraint``, by dual ascent.

    After each discriminator step: ``beta = max(0, beta + lr_beta * (kl - info_constraint))``.
    """

    def __init__(self, info_constraint: float = 0.1, lr_beta: float = 1e-5, beta: float = 0.1):
        self.info_constraint, self.lr_beta, self.value = float(info_constraint), float(lr_beta), float(beta)

    def update(self, kl: float) -> float:
        self.value = max(0.0, self.value + self.lr_beta * (float(kl) - self.info_constraint))
        return self.value
