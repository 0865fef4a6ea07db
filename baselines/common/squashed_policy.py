"""Tanh-squashed Gaussian policy of the off-policy learners (SAC-style), sampled in numpy at every step.

One MLP maps the standardized, masked observation to ``(mu, log_std)``; ``log_std`` is clipped to
``[log_std_min, log_std_max]`` and the action is ``a = tanh(u)``, ``u ~ N(mu, diag(exp(log_std))^2)``, so it
lies in the environment's normalised box ``[-1, 1]``. Its log-density is

    log pi(a | s) = sum_i [ log N(u_i; mu_i, std_i) - log(1 - tanh(u_i)^2) ],
    log(1 - tanh(u)^2) = 2 (log 2 - u - softplus(-2 u))      (exact, no epsilon)

* ``draw_action`` (called by ``Core`` at every step) runs the MLP in numpy on **views** of the torch
  parameters (the optimiser updates them in place), so nothing is copied after an update; noise comes from
  the policy's own ``numpy.random.Generator`` (part of its state dict).
* ``sample_t`` is the batch path: reparameterised actions and their log-densities, with the Gaussian noise
  passed in (drawn by the learner from its seeded ``torch.Generator``). The learner's actor step runs it
  differentiated by hand, without autograd: ``forward_kept`` (the MLP, keeping each layer's input),
  ``squash_t`` (actions and log-densities from the MLP's output), ``squash_backward`` (the gradient of the
  actor's loss w.r.t. that output) and ``backward_kept`` (the MLP's parameter gradients).
* ``evaluation_mode(deterministic, seed)``: ``tanh(mu)``, or samples from a separate generator.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from mushroom_rl.policy import Policy
from torch import nn

from baselines.common import gemm
from baselines.common.networks import build_mlp
from baselines.common.policy import _NUMPY_ACTIVATIONS, EvaluationModeMixin
from baselines.common.standardizer import RunningStandardizer

_LOG_2 = math.log(2.0)
_HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)


class TanhGaussianPolicy(EvaluationModeMixin, Policy):
    """``a = tanh(u)``, ``u ~ N(mu(x), exp(log_std(x))^2)`` with ``x`` = standardized ``s[obs_mask]``."""

    def __init__(self, obs_mask: np.ndarray, act_dim: int, standardizer: RunningStandardizer,
                 hidden: Sequence[int] = (256, 256), activation: str = "relu", log_std_min: float = -5.0,
                 log_std_max: float = 2.0, seed: int = 0, generator: torch.Generator | None = None):
        super().__init__()
        self.obs_mask = np.asarray(obs_mask, bool)
        self.obs_dim, self.act_dim = int(self.obs_mask.sum()), int(act_dim)
        if standardizer.dim != self.obs_dim:
            raise ValueError(f"standardizer of dimension {standardizer.dim} for {self.obs_dim} observation entries")
        self.standardizer = standardizer
        self.log_std_min, self.log_std_max = float(log_std_min), float(log_std_max)
        self.net = build_mlp(self.obs_dim, 2 * self.act_dim, hidden, activation, output_std=1e-3, generator=generator)
        self.rng = np.random.default_rng(seed)
        self.deterministic = False
        self._bind_numpy()

    # ---- per-step sampling (numpy) ----------------------------------------------------------------------
    def draw_action(self, state: np.ndarray) -> np.ndarray:
        h = self.standardizer.normalize(state[self.obs_mask])
        for weight_t, bias, activation in self._np_layers:
            h = activation(h @ weight_t + bias)
        mean = h[:self.act_dim].astype(np.float64)
        if self.deterministic:
            return np.tanh(mean)
        log_std = np.clip(h[self.act_dim:], self.log_std_min, self.log_std_max)
        return np.tanh(mean + np.exp(log_std) * self.rng.standard_normal(self.act_dim))

    def _bind_numpy(self) -> None:
        """numpy views (no copies) of the MLP's weights, transposed for ``h @ W^T``; valid while updates are in
        place (optimiser steps, ``load_state_dict``)."""
        modules = list(self.net)
        in_place = {nn.ReLU: torch.relu_, nn.Tanh: torch.tanh_, nn.Identity: None}
        self._layers = [(modules[i], in_place[type(modules[i + 1])]) for i in range(0, len(modules), 2)]
        names = {nn.ReLU: "relu", nn.Tanh: "tanh", nn.Identity: "identity"}
        self._activation_names = [names[type(modules[i + 1])] for i in range(0, len(modules), 2)]
        self._np_layers = [(modules[i].weight.detach().numpy().T, modules[i].bias.detach().numpy(),
                            _NUMPY_ACTIVATIONS[type(modules[i + 1])]) for i in range(0, len(modules), 2)]

    # ---- batch operations (torch) -----------------------------------------------------------------------
    def mean_log_std_t(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(mu, clipped log_std)`` for standardized inputs ``x``."""
        mean, log_std = self.net(x).chunk(2, dim=-1)
        return mean, log_std.clamp(self.log_std_min, self.log_std_max)

    def sample_t(self, x: torch.Tensor, noise: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Reparameterised ``(a, log pi(a | s))`` for standardized inputs ``x`` and standard normal ``noise``."""
        return self.squash_t(self.net(x), noise)

    def squash_t(self, out: torch.Tensor, noise: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(a, log pi(a | s))`` from the MLP's output ``out = [mu, log_std]`` (unclipped) and ``noise``."""
        mean, log_std = out[:, :self.act_dim], out[:, self.act_dim:].clamp(self.log_std_min, self.log_std_max)
        u = mean + log_std.exp() * noise
        log_prob = (-0.5 * noise.square() - log_std - _HALF_LOG_2PI - 2.0 * (_LOG_2 - u - F.softplus(-2.0 * u)))
        return torch.tanh(u), log_prob.sum(dim=-1)

    # ---- the learner's actor step, differentiated by hand (no autograd graph) ------------------------------
    def forward_kept(self, x: torch.Tensor) -> tuple[torch.Tensor, list[torch.Tensor]]:
        """``(out, inputs)``: the MLP's output for ``x`` and the input of each of its linear layers (``x`` and the
        hidden activations), for :meth:`backward_kept`. No graph is built; products on
        :func:`~baselines.common.gemm.linear` (bias and ReLU fused)."""
        inputs = []
        h = x
        with torch.no_grad():
            for linear, activation in self._layers:
                inputs.append(h)
                relu = activation is torch.relu_
                h = gemm.linear(h, linear.weight, linear.bias, relu=relu)
                if activation is not None and not relu:
                    activation(h)
        return h, inputs

    def squash_backward(self, out: torch.Tensor, noise: torch.Tensor, action: torch.Tensor,
                        log_prob_weight: torch.Tensor | float, grad_action: torch.Tensor) -> torch.Tensor:
        """Gradient w.r.t. ``out`` (the MLP's output) of ``log_prob_weight * sum_i log pi(a_i | s_i) + sum(a *
        grad_action)``, where ``action = a`` is :meth:`squash_t`'s for ``(out, noise)``.

        With ``a = tanh(u)``, ``u = mu + std * noise``: ``d log pi / du = 2 tanh(u) = 2 a`` (the derivative of
        ``-log(1 - tanh(u)^2)``), ``d log pi / d log_std = -1`` at fixed ``u``, ``du / d log_std = std * noise``;
        the clip passes the gradient where ``log_std_min <= log_std <= log_std_max`` (as ``torch.clamp``)."""
        with torch.no_grad():
            raw_log_std = out[:, self.act_dim:]
            grad_u = grad_action * (1.0 - action.square()) + (2.0 * log_prob_weight) * action
            std = raw_log_std.clamp(self.log_std_min, self.log_std_max).exp()
            grad_log_std = grad_u * std * noise - log_prob_weight
            inside = (raw_log_std >= self.log_std_min) & (raw_log_std <= self.log_std_max)
            grad_log_std = torch.where(inside, grad_log_std, 0.0)
            return torch.cat([grad_u, grad_log_std], 1)

    def backward_kept(self, inputs: Sequence[torch.Tensor], grad_out: torch.Tensor) -> None:
        """Set the MLP's parameter gradients (``.grad``, replaced) for the output cotangent ``grad_out`` of the first
        ``len(grad_out)`` rows of the :meth:`forward_kept` that gave ``inputs``."""
        rows = grad_out.shape[0]
        grad = grad_out
        with torch.no_grad():
            for i in range(len(self._layers) - 1, -1, -1):
                linear = self._layers[i][0]
                h = inputs[i][:rows]
                linear.weight.grad = gemm.mm(grad.t(), h)
                linear.bias.grad = grad.sum(0)
                if i > 0:
                    grad = gemm.mm(grad, linear.weight)
                    if self._activation_names[i - 1] == "relu":  # h is the activation's output
                        torch.ops.aten.threshold_backward.grad_input(grad, h, 0.0, grad_input=grad)
                    elif self._activation_names[i - 1] == "tanh":
                        torch.ops.aten.tanh_backward.grad_input(grad, h, grad_input=grad)

    def parameters(self) -> Iterator[torch.nn.Parameter]:
        return self.net.parameters()

    # ---- checkpoints ------------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """Network and the exploration generator (the standardizer belongs to the agent)."""
        return {"net": {k: v.clone() for k, v in self.net.state_dict().items()}, "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.net.load_state_dict(state["net"])
        self.rng.bit_generator.state = state["rng"]
        self._bind_numpy()
