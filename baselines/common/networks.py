"""Multi-layer perceptrons: a builder, the normc initialisation, and a Mushroom-RL-compatible wrapper.

All weights are drawn from an explicit ``torch.Generator`` so that an agent built from a seed is reproducible
without touching torch's global RNG.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
from torch import nn

from baselines.common import gemm

ACTIVATIONS: dict[str, type[nn.Module]] = {"relu": nn.ReLU, "tanh": nn.Tanh, "identity": nn.Identity}


def normc_(weight: torch.Tensor, std: float, generator: torch.Generator | None = None) -> torch.Tensor:
    """In place: Gaussian weights, each output unit's incoming weight vector rescaled to norm ``std``.

    The "normc" initialiser of OpenAI baselines, used by the reference LocoMuJoCo agents (1.0 for hidden
    layers, 1e-3 for the policy's output so that the initial mean action is ~0 for every state).
    """
    with torch.no_grad():
        w = torch.randn(weight.shape, generator=generator, dtype=weight.dtype)
        w *= std / torch.sqrt(torch.sum(w**2, dim=1, keepdim=True))
        weight.copy_(w)
    return weight


def build_mlp(in_dim: int, out_dim: int, hidden: Sequence[int] = (512, 256), activation: str = "relu",
              output_activation: str = "identity", hidden_std: float = 1.0, output_std: float = 1.0,
              generator: torch.Generator | None = None, onednn: bool = True) -> nn.Sequential:
    """``Linear -> activation`` for each hidden size, then ``Linear -> output_activation``.

    Weights use normc (``hidden_std`` / ``output_std``), biases start at zero. The result is a plain
    ``nn.Sequential`` of ``Linear`` and activation modules, which lets :mod:`baselines.common.fast_trpo`
    differentiate it by hand. The ``Linear`` layers are :class:`baselines.common.gemm.Linear` (products on
    oneDNN, same parameters and state dict), or ``torch.nn.Linear`` with ``onednn=False`` (the benchmarks'
    unmodified Mushroom-RL learners).
    """
    for name in (activation, output_activation):
        if name not in ACTIVATIONS:
            raise ValueError(f"unknown activation {name!r}; valid: {', '.join(ACTIVATIONS)}")
    sizes = [in_dim, *hidden, out_dim]
    layers: list[nn.Module] = []
    for i in range(len(sizes) - 1):
        linear = (gemm.Linear if onednn else nn.Linear)(sizes[i], sizes[i + 1])
        last = i == len(sizes) - 2
        normc_(linear.weight, output_std if last else hidden_std, generator)
        nn.init.zeros_(linear.bias)
        layers += [linear, ACTIVATIONS[output_activation if last else activation]()]
    return nn.Sequential(*layers)


class MushroomMLP(nn.Module):
    """An MLP with the constructor Mushroom-RL's ``TorchApproximator`` expects: ``(input_shape, output_shape, ...)``.

    Used for the critic (``Regressor(TorchApproximator, network=MushroomMLP, ...)``) and for the mean of
    Mushroom's own ``GaussianTorchPolicy`` in the unmodified-Mushroom benchmark. ``standardizer`` (a
    :class:`~baselines.common.standardizer.RunningStandardizer`, shared with the policy) normalises the input.
    """

    def __init__(self, input_shape: tuple[int, ...], output_shape: tuple[int, ...], hidden: Sequence[int] = (512, 256),
                 activation: str = "relu", output_std: float = 1e-3, standardizer: Any = None, seed: int = 0,
                 onednn: bool = True, **_mushroom_kwargs: Any):
        super().__init__()
        generator = torch.Generator().manual_seed(seed)
        self.standardizer = standardizer
        self.net = build_mlp(input_shape[0], output_shape[0], hidden, activation, output_std=output_std,
                             generator=generator, onednn=onednn)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x.float()
        if self.standardizer is not None:
            x = self.standardizer.normalize_torch(x)
        return self.net(x)
