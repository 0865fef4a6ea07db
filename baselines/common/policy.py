"""Gaussian policy with a state-independent log standard deviation, sampled cheaply at every step.

The policy is a Mushroom-RL ``TorchPolicy`` (so Mushroom's TRPO can train it too), with two paths:

* the **torch path** (``distribution_t``, ``log_prob_t``, ...) used by the learners on whole batches;
* the **numpy path** (``draw_action``) used by ``Core`` at every environment step. A 33 -> 512 -> 256 -> 11
  MLP on one observation costs ~11 us in numpy against ~27 us in torch (and ~150 us through Mushroom's
  ``GaussianTorchPolicy``, which also builds a ``MultivariateNormal`` per step); ``draw_actions`` does one
  forward pass for a batch of states (the N environments of :mod:`baselines.common.batched`). The numpy
  copies of the weights are rebuilt lazily after ``set_weights`` / ``load_state_dict`` or a standardizer update.

Exploration noise comes from the policy's own ``numpy.random.Generator`` (part of its state dict), so a
seeded agent collects the same actions run after run and after a resume.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np
import torch
from mushroom_rl.policy import TorchPolicy
from torch import nn
from torch.distributions import Independent, Normal

from baselines.common.networks import build_mlp
from baselines.common.standardizer import RunningStandardizer

_NUMPY_ACTIVATIONS = {
    nn.ReLU: lambda h: np.maximum(h, 0.0, out=h),
    nn.Tanh: lambda h: np.tanh(h, out=h),
    nn.Identity: lambda h: h,
}


class EvaluationModeMixin:
    """``evaluation_mode``: deterministic or seeded stochastic actions for evaluation, without consuming the
    policy's own exploration generator (``self.rng``; ``self.deterministic`` selects the action rule)."""

    @contextmanager
    def evaluation_mode(self, deterministic: bool, seed: int | None = None) -> Iterator[None]:
        """Deterministic actions or stochastic ones from a separate generator; training noise untouched."""
        saved = self.deterministic, self.rng
        self.deterministic, self.rng = deterministic, np.random.default_rng(seed)
        try:
            yield
        finally:
            self.deterministic, self.rng = saved


class GaussianPolicy(EvaluationModeMixin, TorchPolicy):
    """``a ~ N(mu(standardize(s)), diag(exp(log_std))^2)``; ``mu`` an MLP, ``log_std`` a free parameter."""

    def __init__(self, obs_dim: int, act_dim: int, hidden: Sequence[int] = (512, 256), activation: str = "relu",
                 std_0: float = 1.0, standardizer: RunningStandardizer | None = None, seed: int = 0,
                 generator: torch.Generator | None = None):
        super().__init__(use_cuda=False)
        if not std_0 > 0:
            raise ValueError(f"std_0 must be > 0, got {std_0}")
        self.obs_dim, self.act_dim = int(obs_dim), int(act_dim)
        self.mean_net = build_mlp(obs_dim, act_dim, hidden, activation, output_std=1e-3, generator=generator)
        self.log_std = nn.Parameter(torch.full((act_dim,), math.log(std_0)))
        self.standardizer = standardizer
        self.rng = np.random.default_rng(seed)
        self.deterministic = False  # evaluation: return the mean action
        self._weights_version = 0
        self._cache_key: tuple[int, int] | None = None
        self._np_layers: list[tuple[np.ndarray, np.ndarray, Any]] = []
        self._np_std = np.ones(act_dim)

    # ---- per-step sampling (numpy) ----------------------------------------------------------------------
    def draw_action(self, state: np.ndarray) -> np.ndarray:
        mean = self.mean_numpy(state)
        if self.deterministic:
            return mean.astype(np.float64)
        return mean + self._np_std * self.rng.standard_normal(self.act_dim)

    def draw_actions(self, states: np.ndarray) -> np.ndarray:
        """Actions for a batch of states ``(n, obs_dim)``: one forward pass, noise ``(n, act_dim)`` from ``rng``.

        Row ``i`` is what ``draw_action(states[i])`` would give; the noise stream is consumed in the same
        order as ``n`` calls of ``draw_action`` on the rows in turn.
        """
        mean = self.mean_numpy(states)
        if self.deterministic:
            return mean.astype(np.float64)
        return mean + self._np_std * self.rng.standard_normal(mean.shape)

    def mean_numpy(self, state: np.ndarray) -> np.ndarray:
        """The mean action for one state (shape ``(obs_dim,)``) or a batch, in float32 numpy."""
        self._sync_numpy()
        h = self.standardizer.normalize(state) if self.standardizer is not None else np.asarray(state, np.float32)
        for weight_t, bias, activation in self._np_layers:
            h = h @ weight_t
            h += bias
            h = activation(h)
        return h

    def invalidate_cache(self) -> None:
        """Call after changing parameters in place by other means than ``set_weights`` / ``load_state_dict``."""
        self._weights_version += 1

    def _sync_numpy(self) -> None:
        key = (self._weights_version, self.standardizer.version if self.standardizer is not None else 0)
        if key == self._cache_key:
            return
        layers, modules = [], list(self.mean_net)
        for i in range(0, len(modules), 2):
            linear, activation = modules[i], modules[i + 1]
            layers.append((linear.weight.detach().numpy().T.copy(), linear.bias.detach().numpy().copy(),
                           _NUMPY_ACTIVATIONS[type(activation)]))
        self._np_layers = layers
        self._np_std = np.exp(self.log_std.detach().numpy().astype(np.float64))
        self._cache_key = key

    # ---- batch operations (torch), the TorchPolicy interface ------------------------------------------------
    def mean_t(self, state: torch.Tensor) -> torch.Tensor:
        x = state.float()
        if self.standardizer is not None:
            x = self.standardizer.normalize_torch(x)
        return self.mean_net(x)

    def distribution_t(self, state: torch.Tensor) -> Independent:
        return Independent(Normal(self.mean_t(state), torch.exp(self.log_std)), 1)

    def log_prob_t(self, state: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return self.distribution_t(state).log_prob(action)[:, None]

    def entropy_t(self, state: torch.Tensor | None = None) -> torch.Tensor:
        return self.act_dim / 2 * math.log(2 * math.pi * math.e) + torch.sum(self.log_std)

    def draw_action_t(self, state: torch.Tensor) -> torch.Tensor:
        with torch.no_grad():
            mean = self.mean_t(state)
            noise = torch.from_numpy(self.rng.standard_normal(tuple(mean.shape)).astype(np.float32))
            return mean + torch.exp(self.log_std) * noise

    def parameters(self) -> list[nn.Parameter]:
        """Mean-network parameters, then ``log_std`` (the order of the flat weight vector)."""
        return [*self.mean_net.parameters(), self.log_std]

    def get_weights(self) -> np.ndarray:
        return torch.nn.utils.parameters_to_vector(self.parameters()).detach().numpy().copy()

    def set_weights(self, weights: np.ndarray | torch.Tensor) -> None:
        with torch.no_grad():
            torch.nn.utils.vector_to_parameters(torch.as_tensor(weights, dtype=torch.float32), self.parameters())
        self.invalidate_cache()

    # ---- checkpoints ------------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """Network, log-std and the exploration generator (the standardizer belongs to the agent)."""
        return {"mean_net": {k: v.clone() for k, v in self.mean_net.state_dict().items()},
                "log_std": self.log_std.detach().clone(), "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.mean_net.load_state_dict(state["mean_net"])
        with torch.no_grad():
            self.log_std.copy_(state["log_std"])
        self.rng.bit_generator.state = state["rng"]
        self.invalidate_cache()
