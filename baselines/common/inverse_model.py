"""A learned inverse-dynamics model ``a = f(s, s')`` for imitation from state-only data (LSIQfO-style).

An MLP on the standardized ``[s, s']`` with a tanh output (actions live in ``[-1, 1]``), regressed by mean
squared error on the agent's own transitions, one minibatch per learner update. The expert's transitions,
which have no actions, get ``f(s, s')`` instead. (The analytic alternative, actions from ``mj_inverse``, is
``train.expert_actions: inverse_dynamics`` in :mod:`baselines.common.inverse_dynamics`.)
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
import torch.nn.functional as F

from baselines.common.networks import build_mlp


class InverseDynamicsModel:
    """``predict(x, x_next)``: the action taking standardized ``x`` to ``x_next``; ``fit`` one Adam step of MSE."""

    def __init__(self, obs_dim: int, act_dim: int, hidden: Sequence[int] = (256, 256), lr: float = 3e-4,
                 generator: torch.Generator | None = None):
        self.net = build_mlp(2 * obs_dim, act_dim, hidden, "relu", output_activation="tanh", output_std=1e-2,
                             generator=generator)
        self.optimizer = torch.optim.Adam(self.net.parameters(), lr=lr, fused=True)

    def predict(self, x: torch.Tensor, x_next: torch.Tensor) -> torch.Tensor:
        with torch.no_grad():
            return self.net(torch.cat([x, x_next], dim=-1))

    def fit(self, x: torch.Tensor, x_next: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        """One gradient step on ``mean ||f(x, x_next) - action||^2``; returns the loss (detached)."""
        loss = F.mse_loss(self.net(torch.cat([x, x_next], dim=-1)), action)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        return loss.detach()

    def state_dict(self) -> dict[str, Any]:
        return {"net": self.net.state_dict(), "optimizer": self.optimizer.state_dict()}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.net.load_state_dict(state["net"])
        self.optimizer.load_state_dict(state["optimizer"])
