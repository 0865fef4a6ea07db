"""Twin Q-networks evaluated in one batched pass, with a soft-updated target copy.

The ``n`` critics ``Q_j(s, a)`` are MLPs of the same shape on ``[standardized s, a]`` whose layers are stored
stacked (``weight: (n, fan_in, fan_out)``, ``bias: (n, 1, fan_out)``), so each layer of all critics is one
batched matrix product (``torch.bmm``): one kernel and one autograd node per layer instead of ``n``. Hidden
layers add the bias and apply the activation in place on the product (hot in cache), where ``baddbmm`` would
first copy the broadcast bias into a fresh output.

:meth:`action_gradient` is the backward pass of given value gradients to the actions, written out from the
activations :meth:`forward` kept: the actor's gradient ``d min_j Q_j(s, a) / da`` then needs no second
autograd pass through the critics (nor their weight gradients, which the actor does not use).

Weights use normc like :func:`~baselines.common.networks.build_mlp` (hidden 1.0, output 1e-3), drawn from an
explicit generator.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import torch
from torch import nn

from baselines.common.networks import normc_

_ACTIVATIONS = {"relu": torch.relu_, "tanh": torch.tanh_}  # in place on the fresh pre-activations


class TwinCritic(nn.Module):
    """``n`` critics on ``x = [s, a]``; ``forward(x)`` -> ``(n, N)`` values."""

    def __init__(self, obs_dim: int, act_dim: int, hidden: Sequence[int] = (256, 256), activation: str = "relu",
                 n: int = 2, generator: torch.Generator | None = None):
        super().__init__()
        if activation not in _ACTIVATIONS:
            raise ValueError(f"unknown critic activation {activation!r}; valid: {', '.join(_ACTIVATIONS)}")
        if not hidden:
            raise ValueError("the critic needs at least one hidden layer")
        self.n, self.obs_dim, self.activation = int(n), int(obs_dim), activation
        sizes = [obs_dim + act_dim, *hidden, 1]
        weights, biases = [], []
        for i in range(len(sizes) - 1):
            weight = torch.empty(self.n, sizes[i], sizes[i + 1])
            for j in range(self.n):
                weight[j] = normc_(torch.empty(sizes[i + 1], sizes[i]), 1e-3 if i == len(sizes) - 2 else 1.0,
                                   generator).t()
            weights.append(weight)
            biases.append(torch.zeros(self.n, 1, sizes[i + 1]))
        self.weights = nn.ParameterList([nn.Parameter(w) for w in weights])
        self.biases = nn.ParameterList([nn.Parameter(b) for b in biases])

    def forward(self, x: torch.Tensor, keep: bool = False) -> tuple[torch.Tensor, list[torch.Tensor]]:
        """``(values, hidden)``: every critic's value of each row of ``x = [s, a]`` (``(N, obs_dim + act_dim)`` ->
        ``(n, N)``) and, with ``keep``, the hidden activations (each ``(n, N, width)``)."""
        activate = _ACTIVATIONS[self.activation]
        h = x.expand(self.n, -1, -1)
        hidden = []
        for weight, bias in zip(self.weights[:-1], self.biases[:-1], strict=True):
            h = activate(torch.bmm(h, weight).add_(bias))  # bias added in cache, not copied in first
            hidden.append(h)
        values = torch.baddbmm(self.biases[-1], h, self.weights[-1]).squeeze(-1)
        return values, hidden if keep else []

    def action_gradient(self, hidden: Sequence[torch.Tensor], grad_values: torch.Tensor) -> torch.Tensor:
        """``sum_j grad_values[j] * dQ_j(s, a)/da`` (``(N, act_dim)``) for the rows whose hidden activations (as kept
        by :meth:`forward`) are ``hidden``: the backward pass written out, no graph, current weights."""
        with torch.no_grad():
            grad = grad_values.unsqueeze(-1) * self.weights[-1].transpose(1, 2)  # d/d(last hidden activation)
            for i in range(len(hidden) - 1, -1, -1):
                h = hidden[i]
                if self.activation == "relu":  # d/d(pre-activation): relu's backward, grad where h > 0
                    grad = torch.ops.aten.threshold_backward(grad, h, 0.0)
                else:
                    grad = grad * (1.0 - h * h)
                weight = self.weights[i] if i > 0 else self.weights[0][:, self.obs_dim:]
                grad = torch.bmm(grad, weight.transpose(1, 2))
            return grad.sum(0)

    def make_target(self) -> TwinCritic:
        """A frozen copy (no gradients) to be moved towards this critic by :meth:`soft_update`."""
        target = copy.deepcopy(self)
        target.requires_grad_(False)
        return target

    def soft_update(self, target: TwinCritic, tau: float) -> None:
        """``target <- target + tau * (self - target)``, all tensors in one fused call."""
        with torch.no_grad():
            torch._foreach_lerp_(list(target.parameters()), list(self.parameters()), tau)
