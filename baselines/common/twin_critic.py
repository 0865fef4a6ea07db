"""Twin Q-networks differentiated by hand, with a soft-updated target copy.

The ``n`` critics ``Q_j(s, a)`` are MLPs of the same shape on ``[standardized s, a]`` whose layers are stored
stacked (``weight: (n, fan_in, fan_out)``, ``bias: (n, 1, fan_out)``). They are evaluated critic by critic: each
layer is one product with its bias and ReLU fused, on oneDNN (:mod:`baselines.common.gemm`: twice torch's
batched product on this project's AMD machine, where ``torch.bmm`` goes to MKL's AVX2 kernels).

:meth:`TwinCritic.backward` is the backward pass written out from the activations :meth:`TwinCritic.forward`
kept, without autograd: the weight gradients of a loss on the values and, from the same products, the actor's
gradient ``d min_j Q_j(s, a) / da``. A value is a scalar, so ``dQ_j/dz`` (``z``: a layer's pre-activation) is
propagated once per row whatever the cotangent, and the loss's and the actor's cotangents enter as row scales
(tests/test_offpolicy.py checks it against autograd). :meth:`TwinCritic.action_gradient` is the actor's part
alone.

Weights use normc like :func:`~baselines.common.networks.build_mlp` (hidden 1.0, output 1e-3), drawn from an
explicit generator.

With ``layer_norm`` every hidden layer is ``act(LN(W h + b))``, LN without learned scale or shift (the next layer's
weights carry them): a row's features then have norm at most ``sqrt(width)``, so a value cannot extrapolate beyond
``|w_out| sqrt(width) + b_out`` on states and actions no data pins down. That is what keeps the critics of the
imitation learners, trained on half expert transitions whose policy actions are never executed, from diverging
(Ball et al., 2023, "Efficient online RL with offline data", the same symmetric expert/agent sampling).
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import torch
from torch import nn

from baselines.common import gemm
from baselines.common.networks import normc_

_ACTIVATIONS = {"relu": torch.relu_, "tanh": torch.tanh_}  # in place on the fresh pre-activations
_LN_EPS = 1e-5  # torch.nn.LayerNorm's


class TwinCritic(nn.Module):
    """``n`` critics on ``x = [s, a]``; ``forward(x)`` -> ``(n, N)`` values."""

    def __init__(self, obs_dim: int, act_dim: int, hidden: Sequence[int] = (256, 256), activation: str = "relu",
                 n: int = 2, generator: torch.Generator | None = None, layer_norm: bool = False):
        super().__init__()
        if activation not in _ACTIVATIONS:
            raise ValueError(f"unknown critic activation {activation!r}; valid: {', '.join(_ACTIVATIONS)}")
        if not hidden:
            raise ValueError("the critic needs at least one hidden layer")
        self.n, self.obs_dim, self.activation, self.layer_norm = int(n), int(obs_dim), activation, bool(layer_norm)
        self._n_hidden = len(hidden)
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
        # Plain lists of the same Parameters: indexing an nn.ParameterList (let alone slicing it, which builds a new
        # module) costs more than a small kernel. Updates are in place, so the lists stay valid.
        self._weights, self._biases = list(self.weights), list(self.biases)

    def forward(self, x: torch.Tensor, keep: bool = False) -> tuple[torch.Tensor, list[list[torch.Tensor]]]:
        """``(values, hidden)``: every critic's value of each row of ``x = [s, a]`` (``(N, obs_dim + act_dim)`` ->
        ``(n, N)``) and, with ``keep``, the hidden activations (``hidden[layer][j]``: critic ``j``'s, ``(N, width)``;
        with ``layer_norm`` followed by each layer's normalised pre-activations and ``(N, 1)`` inverse deviations).
        Critic by critic, each layer one product with its bias (and ReLU) fused (:func:`~baselines.common.gemm.linear`);
        the last layer one matrix-vector product per critic."""
        relu = self.activation == "relu" and not self.layer_norm
        n_hidden = self._n_hidden
        hidden = [[] for _ in range(3 * n_hidden if self.layer_norm else n_hidden)]
        values = []
        for j in range(self.n):
            h = x
            for i, (weight, bias) in enumerate(zip(self._weights[:-1], self._biases[:-1], strict=True)):
                h = gemm.linear(h, weight[j].t(), bias[j, 0], relu=relu)
                if self.layer_norm:
                    h, _, inv_std = torch.ops.aten.native_layer_norm(h, [h.shape[1]], None, None, _LN_EPS)
                    hidden[n_hidden + i].append(h)
                    hidden[2 * n_hidden + i].append(inv_std)
                    h = torch.relu(h) if self.activation == "relu" else torch.tanh(h)
                elif not relu:
                    h = _ACTIVATIONS[self.activation](h)
                hidden[i].append(h)
            values.append(torch.mv(h, self._weights[-1][j, :, 0]))
        values = torch.stack(values).add_(self._biases[-1].view(-1, 1))
        return values, hidden if keep else []

    def backward(self, x: torch.Tensor, hidden: Sequence[Sequence[torch.Tensor]], grad_values: torch.Tensor,
                 loss_start: int = 0, action_critic: torch.Tensor | None = None,
                 action_scale: float = 1.0) -> torch.Tensor | None:
        """The backward pass of :meth:`forward` (run on ``x`` with ``keep``, activations ``hidden``), written out.

        Sets every weight's and bias's ``.grad`` (replacing it) to the gradient of ``sum_ji grad_values[j, i]
        Q_j(x_{loss_start + i})``. With ``action_critic`` (``(M,)`` critic indices for the last ``M`` rows of ``x``) it
        also returns ``action_scale * dQ_c(s, a)/da`` with ``c = action_critic[i]`` for each of those rows
        (``(M, act_dim)``): the actor's gradient of ``min_j Q_j`` where ``action_critic`` is the argmin.

        A critic's value is a scalar, so the gradient of any cotangent ``c_ji`` w.r.t. a pre-activation ``z`` of row
        ``i`` is ``c_ji P_ji`` with ``P = dQ_j/dz`` the same for every cotangent: ``P`` goes down the layers once per
        row (a loss on the values of ``[s, a~]`` and the actor share those rows: one pass serves both) and the
        cotangents enter as row scales, ``dW = (c * input)^T P``, ``db = c^T P``. Action rows outside the loss's
        rows go down only the critic the actor differentiates (:meth:`_selected_action_gradient`)."""
        weights, biases = self._weights, self._biases
        n_loss, n_total = grad_values.shape[1], x.shape[0]
        n_actions = 0 if action_critic is None else action_critic.shape[0]
        first_action = n_total - n_actions
        shared = n_actions > 0 and first_action < loss_start + n_loss  # action rows among the loss's: P serves both
        start = min(loss_start, first_action) if shared else loss_start  # P is needed for rows [start:stop]
        stop = n_total if shared else loss_start + n_loss
        loss = slice(loss_start - start, loss_start - start + n_loss)
        weight_grads, bias_grads = [torch.empty_like(w) for w in weights], [torch.empty_like(b) for b in biases]
        action_grads = []
        with torch.no_grad():
            for j in range(self.n):
                c = grad_values[j]
                kept = [h[j][start:stop] for h in hidden]
                last = self._n_hidden - 1
                # as c^T h: the matrix-vector product reads h along its rows
                torch.mv(kept[last][loss].t(), c, out=weight_grads[-1][j, :, 0])
                bias_grads[-1][j] = c.sum()
                p = self._hidden_backward(weights[-1][j, :, 0], kept, last)  # dQ/dz of the last hidden layer
                for i in range(last, -1, -1):
                    below = kept[i - 1] if i else x[start:stop]
                    p_loss = p[loss]
                    weight_grads[i][j] = gemm.mm((below[loss] * c.unsqueeze(1)).t(), p_loss)
                    torch.mv(p_loss.t(), c, out=bias_grads[i][j, 0])
                    if i:
                        p = self._hidden_backward(gemm.linear(p, weights[i][j]), kept, i - 1, inplace=True)
                if shared:
                    action_grads.append(gemm.mm(p[p.shape[0] - n_actions:], weights[0][j, self.obs_dim:].t()))
            for param, grad in zip(weights + biases, weight_grads + bias_grads, strict=True):
                param.grad = grad
            if not n_actions:
                return None
            if not shared:
                return self._selected_action_gradient(hidden, first_action, action_critic, action_scale)
            grad = torch.stack(action_grads)
            index = action_critic.view(1, n_actions, 1).expand(1, n_actions, grad.shape[2])
            return grad.gather(0, index).squeeze(0).mul_(action_scale)

    def _selected_action_gradient(self, hidden: Sequence[Sequence[torch.Tensor]], first: int, critic: torch.Tensor,
                                  scale: float) -> torch.Tensor:
        """``scale * dQ_c(s, a)/da`` for rows ``first + i`` with ``c = critic[i]``: each row down its critic only
        (gathered per critic: half the products of going down both)."""
        weights = self._weights
        grad = torch.empty(critic.shape[0], weights[0].shape[1] - self.obs_dim)
        for j in range(self.n):
            index = (critic == j).nonzero().squeeze(1)
            if not index.numel():
                continue
            rows = index + first
            kept = [h[j].index_select(0, rows) for h in hidden]
            p = self._hidden_backward(weights[-1][j, :, 0], kept, self._n_hidden - 1)
            for i in range(self._n_hidden - 1, 0, -1):
                p = self._hidden_backward(gemm.linear(p, weights[i][j]), kept, i - 1, inplace=True)
            grad.index_copy_(0, index, gemm.mm(p, weights[0][j, self.obs_dim:].t()).mul_(scale))
        return grad

    def action_gradient(self, hidden: Sequence[Sequence[torch.Tensor]], grad_values: torch.Tensor) -> torch.Tensor:
        """``sum_j grad_values[j] * dQ_j(s, a)/da`` (``(N, act_dim)``) for the rows whose hidden activations (as kept
        by :meth:`forward`) are ``hidden``: the backward pass written out, no graph, current weights."""
        weights = self._weights
        with torch.no_grad():
            total = None
            for j in range(self.n):
                kept = [h[j] for h in hidden]
                grad = self._hidden_backward(grad_values[j].unsqueeze(1) * weights[-1][j, :, 0], kept,
                                             self._n_hidden - 1)
                for i in range(self._n_hidden - 1, 0, -1):
                    grad = self._hidden_backward(gemm.linear(grad, weights[i][j]), kept, i - 1)
                grad = gemm.mm(grad, weights[0][j, self.obs_dim:].t())
                total = grad if total is None else total.add_(grad)
            return total

    def _hidden_backward(self, grad: torch.Tensor, kept: Sequence[torch.Tensor], layer: int,
                         inplace: bool = False) -> torch.Tensor:
        """The gradient w.r.t. hidden layer ``layer``'s pre-activation ``z`` (``W h + b``) from ``grad`` w.r.t. its
        activation, for one critic's ``kept`` tensors (as :meth:`forward` keeps them). ``inplace``: ``grad`` is
        a fresh ``(N, width)`` tensor that may be overwritten. Through LN: ``dz = (g - mean(g) - z^ mean(g z^)) / sd``
        with ``g`` the gradient w.r.t. the normalised ``z^``."""
        if not self.layer_norm:
            return self._activation_backward(grad, kept[layer], out=grad if inplace else None)
        n = self._n_hidden
        normalised, inv_std = kept[n + layer], kept[2 * n + layer]
        if self.activation == "relu":  # relu(z^) > 0 exactly where z^ > 0
            g = torch.ops.aten.threshold_backward(grad, normalised, 0.0)
        else:
            g = torch.ops.aten.tanh_backward(grad, kept[layer])
        projection = (g * normalised).mean(1, keepdim=True)
        return g.sub_(g.mean(1, keepdim=True)).sub_(normalised * projection).mul_(inv_std)

    def _activation_backward(self, grad: torch.Tensor, h: torch.Tensor,
                             out: torch.Tensor | None = None) -> torch.Tensor:
        """The gradient w.r.t. the pre-activation from ``grad`` w.r.t. the activation ``h`` (broadcast to ``h``)."""
        if self.activation == "relu":  # relu's backward: grad where h > 0
            if out is None:
                return torch.ops.aten.threshold_backward(grad, h, 0.0)
            return torch.ops.aten.threshold_backward.grad_input(grad, h, 0.0, grad_input=out)
        if out is None:  # tanh's: grad (1 - h^2)
            return torch.ops.aten.tanh_backward(grad, h)
        return torch.ops.aten.tanh_backward.grad_input(grad, h, grad_input=out)

    def make_target(self) -> TwinCritic:
        """A frozen copy (no gradients) to be moved towards this critic by :meth:`soft_update`."""
        target = copy.deepcopy(self)
        target.requires_grad_(False)
        return target

    def soft_update(self, target: TwinCritic, tau: float) -> None:
        """``target <- target + tau * (self - target)``, all tensors in one fused call."""
        with torch.no_grad():
            torch._foreach_lerp_(target._weights + target._biases, self._weights + self._biases, tau)
