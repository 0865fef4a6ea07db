"""TRPO with cheap Fisher-vector products: a drop-in subclass of Mushroom-RL's ``TRPO``.

Same algorithm as ``mushroom_rl.algorithms.actor_critic.TRPO`` (Schulman et al., 2015): GAE advantages,
the surrogate gradient ``g``, the natural direction ``F^-1 g`` by conjugate gradient on the damped Fisher
``F + cg_damping * I``, a step scaled to ``max_kl``, a backtracking line search that accepts the first step
with ``KL <= 1.5 max_kl`` and no loss of surrogate, then the critic regression on the GAE targets.

Where Mushroom's version spends its time (reference settings, 25 CG iterations: Fisher-vector products take
87% of its fit and 57% of the whole VAIL loop on UnitreeH1.walk, see bench/training_throughput.py), and what
changes here:

1. **The Fisher is built once per fit.** Mushroom recomputes the policy forward pass, the KL and its
   gradient (``create_graph=True``) for every product, i.e. 26 times per fit. Here the operator
   ``v -> F v`` is set up once per fit, in one of two exact forms:

   * ``fisher="analytic"`` (default for :class:`~baselines.common.policy.GaussianPolicy`): for a Gaussian
     with a state-independent log-std, the Hessian of ``mean KL(pi_old || pi)`` at ``theta_old`` is
     ``J^T diag(1/sigma^2) J / N`` on the mean-network weights (J: Jacobian of the mean) and ``2 I`` on the
     log-std, with no cross terms. ``J v`` and ``J^T u`` are written out for the MLP's ``Linear`` /
     activation layers from quantities computed once per fit (each layer's input and the Jacobian of the
     mean w.r.t. its pre-activation), so a product costs about two forward passes and no autograd graph.
   * ``fisher="autograd"`` (any mean network): the KL gradient graph is built once with
     ``create_graph=True`` and each product is a single ``grad(g_kl . v)`` through that retained graph.

   Both equal Mushroom's double-backward product (tested to float32 round-off).
2. **The Fisher is estimated on a subsample** (``fisher_fraction``, 20% as in OpenAI baselines' TRPO). The
   surrogate gradient, the line search's KL and surrogate checks and the critic use the whole batch.
3. **One forward pass where Mushroom does several**: the old distribution, the old log-probabilities and the
   surrogate graph come from one pass (at ``theta_old`` they coincide); each line-search trial evaluates the
   surrogate and the KL from a single no-grad pass; the critic is evaluated on the states plus the next
   states that end a segment (every other next state is the following state) instead of on both arrays.
4. **The critic regression overlaps the next rollout.** The critic is next needed by the following fit's
   GAE, so its minibatch epochs run in a background thread (one torch thread) while ``Core`` steps the
   environment on the other core; ``synchronize()`` waits for it and is called before anything reads or
   changes the critic or the shared standardizer (start of the next fit, ``state_dict``, ``stop``). The
   minibatch orders are drawn before the thread starts, so the results do not depend on timing.
5. **Per-step sampling** lives in the policy (numpy forward, see :mod:`baselines.common.policy`).
6. **Threads**: ``n_threads`` sets ``torch.set_num_threads`` for the policy update
   (see :func:`default_num_threads`).

One difference from Mushroom-RL 1.10.2 beyond round-off: on CPU its ``_conjugate_gradient`` takes ``p`` and
``r`` as two numpy views of the same gradient buffer (``b.detach().cpu().numpy()`` twice), so ``r -= v * z``
also changes ``p`` and the first direction update becomes ``(1 + mu) r`` instead of ``r + mu p``; the
iterates then lose conjugacy. This class runs textbook CG; with that aliasing removed, a fit on the whole
batch moves the policy as Mushroom's does (tests/test_baselines.py).

Randomness (Fisher subsample, critic minibatch order) comes from the learner's own seeded generator;
``state_dict`` / ``load_state_dict`` cover the policy, critic, critic optimiser, generator and iteration.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from mushroom_rl.algorithms.actor_critic import TRPO
from mushroom_rl.core import MDPInfo
from mushroom_rl.policy import TorchPolicy
from torch import nn

from baselines.common import gemm

FisherOperator = Callable[[torch.Tensor], torch.Tensor]


def default_num_threads() -> int:
    """Torch threads for the learner: one per available core, at most 2 (measured in bench/training_throughput.py)."""
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        cores = os.cpu_count() or 1
    return max(1, min(2, cores))


def dataset_to_arrays(dataset: Sequence[tuple]) -> tuple[np.ndarray, ...]:
    """A Mushroom dataset (list of ``(s, a, r, s', absorbing, last)``) as six arrays (float32 / bool)."""
    state, action, reward, next_state, absorbing, last = zip(*dataset, strict=True)
    return (np.asarray(state, dtype=np.float32), np.asarray(action, dtype=np.float32),
            np.asarray(reward, dtype=np.float32), np.asarray(next_state, dtype=np.float32),
            np.asarray(absorbing, dtype=bool), np.asarray(last, dtype=bool))


def gaussian_log_prob(action: torch.Tensor, mean: torch.Tensor, log_std: torch.Tensor) -> torch.Tensor:
    """Log-density of a diagonal Gaussian, summed over action dimensions."""
    z = (action - mean) * torch.exp(-log_std)
    return -0.5 * torch.sum(z * z, dim=-1) - torch.sum(log_std) - 0.5 * mean.shape[-1] * math.log(2 * math.pi)


def gaussian_kl(mean_p: torch.Tensor, log_std_p: torch.Tensor, mean_q: torch.Tensor,
                log_std_q: torch.Tensor) -> torch.Tensor:
    """Mean over the batch of ``KL(N(mean_p, std_p) || N(mean_q, std_q))`` for diagonal Gaussians."""
    var_p, var_q = torch.exp(2 * log_std_p), torch.exp(2 * log_std_q)
    kl = log_std_q - log_std_p + (var_p + (mean_p - mean_q) ** 2) / (2 * var_q) - 0.5
    return torch.mean(torch.sum(kl, dim=-1))


def supports_analytic_fisher(policy: Any) -> bool:
    """True for a policy with ``mean_t``, ``log_std`` and ``mean_net``: alternating ``Linear`` / activation."""
    net = getattr(policy, "mean_net", None)
    if not (isinstance(net, nn.Sequential) and hasattr(policy, "log_std") and hasattr(policy, "mean_t")):
        return False
    modules = list(net)
    return (len(modules) % 2 == 0 and all(isinstance(m, nn.Linear) for m in modules[0::2])
            and all(isinstance(m, (nn.ReLU, nn.Tanh, nn.Identity)) for m in modules[1::2]))


def _flat(tensors: Sequence[torch.Tensor]) -> torch.Tensor:
    return torch.cat([t.reshape(-1) for t in tensors])


class FastTRPO(TRPO):
    """Mushroom's ``TRPO`` with the Fisher built once per fit, on a subsample; same constructor plus:

    The policy must be a Gaussian with a state-independent log-std exposing ``mean_t(obs)`` and ``log_std``
    (:class:`~baselines.common.policy.GaussianPolicy`), besides the ``TorchPolicy`` interface.

    Args:
        fisher_fraction: fraction of the batch on which the Fisher is estimated (1.0: the whole batch).
        fisher: ``"analytic"``, ``"autograd"`` or ``"auto"`` (analytic when the policy supports it).
        n_threads: ``torch.set_num_threads`` value (process-wide); None leaves torch's setting alone.
        overlap_critic: fit the critic in a background thread that overlaps the next rollout.
        seed: seed of the generator for the Fisher subsample and the critic's minibatch order.
    """

    def __init__(self, mdp_info: MDPInfo, policy: TorchPolicy, critic_params: dict[str, Any], ent_coeff: float = 0.0,
                 max_kl: float = 5e-3, lam: float = 0.97, n_epochs_line_search: int = 10, n_epochs_cg: int = 25,
                 cg_damping: float = 1e-2, cg_residual_tol: float = 1e-10,
                 critic_fit_params: dict[str, Any] | None = None, fisher_fraction: float = 0.2,
                 fisher: str = "auto", n_threads: int | None = None, overlap_critic: bool = True, seed: int = 0):
        super().__init__(mdp_info, policy, critic_params, ent_coeff, max_kl, lam, n_epochs_line_search, n_epochs_cg,
                         cg_damping, cg_residual_tol, critic_fit_params)
        unknown = set(self._critic_fit_params) - {"n_epochs"}
        if unknown:
            raise ValueError(f"FastTRPO critic_fit_params supports only n_epochs, got {sorted(unknown)}")
        if not 0.0 < fisher_fraction <= 1.0:
            raise ValueError(f"fisher_fraction must be in (0, 1], got {fisher_fraction}")
        if not (hasattr(policy, "mean_t") and isinstance(getattr(policy, "log_std", None), nn.Parameter)):
            raise TypeError(f"FastTRPO needs a GaussianPolicy-like policy (mean_t, log_std), "
                            f"got {type(policy).__name__}")
        if fisher == "auto":
            fisher = "analytic" if supports_analytic_fisher(policy) else "autograd"
        if fisher not in ("analytic", "autograd"):
            raise ValueError(f"fisher must be 'analytic', 'autograd' or 'auto', got {fisher!r}")
        if fisher == "analytic" and not supports_analytic_fisher(policy):
            raise ValueError(f"fisher='analytic' needs a GaussianPolicy-like MLP policy, got {type(policy).__name__}")
        self._fisher_fraction = float(fisher_fraction)
        self._fisher_kind = fisher
        self._rng = np.random.default_rng(seed)
        if n_threads is not None:
            torch.set_num_threads(int(n_threads))
        self._overlap_critic = bool(overlap_critic)
        self._critic_job: _BackgroundJob | None = None
        self.last_stats: dict[str, float] = {}

    @property
    def critic(self) -> nn.Module:
        return self._V.model.network

    @property
    def critic_optimizer(self) -> torch.optim.Optimizer:
        return self._V.model._optimizer

    # ---- one fit ----------------------------------------------------------------------------------------
    def fit(self, dataset: Sequence[tuple], **info: Any) -> None:
        self.fit_arrays(*dataset_to_arrays(dataset))

    def fit_arrays(self, state: np.ndarray, action: np.ndarray, reward: np.ndarray, next_state: np.ndarray,
                   absorbing: np.ndarray, last: np.ndarray) -> dict[str, float]:
        """One TRPO iteration on a batch of transitions in time order; returns its statistics.

        With ``overlap_critic`` the returned ``critic_loss`` is NaN: the critic is still training; it is filled
        into ``last_stats`` by :meth:`synchronize`.
        """
        self.synchronize()
        x = np.ascontiguousarray(state, dtype=np.float32)
        xn = np.ascontiguousarray(next_state, dtype=np.float32)
        obs, act = torch.from_numpy(x), torch.from_numpy(np.ascontiguousarray(action, dtype=np.float32))

        # 1. Critic targets and advantages (GAE), advantages standardized as in Mushroom.
        v_target, np_adv = self._gae(x, xn, np.asarray(reward, np.float64), np.asarray(absorbing, bool),
                                     np.asarray(last, bool))
        np_adv = (np_adv - np.mean(np_adv)) / (np.std(np_adv) + 1e-8)
        adv = torch.from_numpy(np_adv.astype(np.float32))

        # 2. Surrogate and its gradient at theta_old; the same pass gives the old distribution.
        params = self.policy.parameters()
        mean = self.policy.mean_t(obs)
        log_std = self.policy.log_std
        old_mean, old_log_std = mean.detach(), log_std.detach().clone()
        log_prob = gaussian_log_prob(act, mean, log_std)
        old_log_prob = log_prob.detach()
        loss = self._surrogate(log_prob, old_log_prob, adv)
        prev_loss = loss.item()
        g = _flat(torch.autograd.grad(loss, params))

        # 3. Natural direction by conjugate gradient on the subsampled Fisher.
        fvp = self._fisher_operator(obs[self._fisher_indices(len(x))])
        stepdir = self._conjugate_gradient_t(g, fvp)

        # 4. Step of KL max_kl along it, backtracking line search on the whole batch.
        n_tried, kl, new_loss = self._line_search_t(obs, act, adv, old_log_prob, old_mean, old_log_std, prev_loss,
                                                    stepdir, fvp)

        self._iter += 1
        self.last_stats = {"surrogate": prev_loss, "surrogate_new": new_loss, "kl": kl, "line_search_steps": n_tried,
                           "critic_loss": math.nan, "entropy": float(self.policy.entropy_t().item()),
                           "v_target_mean": float(np.mean(v_target))}

        # 5. Critic regression on the GAE targets (in the background: the next rollout does not need it).
        n_epochs = self._critic_fit_params.get("n_epochs", 1)
        orders = [self._rng.permutation(len(x)) for _ in range(n_epochs)]
        if self._overlap_critic:
            self._critic_job = _BackgroundJob(self._fit_critic, x.copy(), v_target, orders)  # x may be the caller's
        else:
            self.last_stats["critic_loss"] = self._fit_critic(x, v_target, orders)
        return self.last_stats

    def synchronize(self) -> None:
        """Wait for the background critic fit (re-raising its error) and record its loss."""
        job, self._critic_job = self._critic_job, None
        if job is not None:
            self.last_stats["critic_loss"] = job.result()

    def stop(self) -> None:
        """Called by ``Core`` at the end of ``learn`` / ``evaluate``: no critic fit outlives it."""
        self.synchronize()

    def _surrogate(self, log_prob: torch.Tensor, old_log_prob: torch.Tensor, adv: torch.Tensor) -> torch.Tensor:
        """``mean(ratio * adv) + ent_coeff * entropy``, maximised (Mushroom's ``_compute_loss``)."""
        ratio = torch.exp(log_prob - old_log_prob)
        entropy = self.policy.entropy_t() if self._ent_coeff() != 0 else 0.0
        return torch.mean(ratio * adv) + self._ent_coeff() * entropy

    # ---- advantages -------------------------------------------------------------------------------------
    def _values(self, x: np.ndarray, xn: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """V(s) and V(s') with one critic pass over the states plus the next states that end a segment."""
        n = len(x)
        inner = ~ends[:-1]
        chained = np.array_equal(xn[:-1][inner], x[1:][inner])  # Core's datasets always are
        with torch.no_grad():
            if chained:
                out = self.critic(torch.from_numpy(np.concatenate([x, xn[ends]])))[:, 0].double().numpy()
                v, v_next = out[:n], np.empty(n)
                v_next[:-1] = v[1:]
                v_next[ends] = out[n:]
            else:
                v = self.critic(torch.from_numpy(x))[:, 0].double().numpy()
                v_next = self.critic(torch.from_numpy(xn))[:, 0].double().numpy()
        return v, v_next

    def _gae(self, x: np.ndarray, xn: np.ndarray, r: np.ndarray, absorbing: np.ndarray,
             last: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mushroom's ``compute_gae``: the batch's final transition is treated as a truncated episode end."""
        ends = last.copy()
        ends[-1] = True
        v, v_next = self._values(x, xn, ends)
        gamma, lam = self.mdp_info.gamma, self._lambda()
        delta = (r + gamma * v_next * ~absorbing - v).tolist()
        carry = (~ends).tolist()
        adv = [0.0] * len(delta)
        gae = 0.0
        for k in range(len(delta) - 1, -1, -1):
            gae = delta[k] + gamma * lam * gae if carry[k] else delta[k]
            adv[k] = gae
        np_adv = np.asarray(adv)
        return (np_adv + v).astype(np.float32), np_adv

    # ---- Fisher-vector products -------------------------------------------------------------------------
    def _fisher_indices(self, n: int) -> np.ndarray:
        m = max(1, int(round(self._fisher_fraction * n)))
        if m >= n:
            return np.arange(n)
        return np.sort(self._rng.choice(n, size=m, replace=False))

    def _fisher_operator(self, obs: torch.Tensor) -> FisherOperator:
        """``v -> (F + cg_damping I) v`` with ``F`` the KL Hessian at theta_old on ``obs``, set up once."""
        fvp = self._analytic_fisher(obs) if self._fisher_kind == "analytic" else self._autograd_fisher(obs)
        damping = self._cg_damping()
        return lambda v: fvp(v) + damping * v

    def _autograd_fisher(self, obs: torch.Tensor) -> FisherOperator:
        params = self.policy.parameters()
        with torch.no_grad():
            old_dist = self.policy.distribution_t(obs)
        kl = torch.mean(torch.distributions.kl.kl_divergence(old_dist, self.policy.distribution_t(obs)))
        grad_kl = _flat(torch.autograd.grad(kl, params, create_graph=True))  # the graph every product reuses

        def fvp(v: torch.Tensor) -> torch.Tensor:
            return _flat(torch.autograd.grad(grad_kl @ v, params, retain_graph=True)).detach()

        return fvp

    def _analytic_fisher(self, obs: torch.Tensor) -> FisherOperator:
        """``F = J^T diag(exp(-2 log_std)) J / N`` on the mean network, ``2 I`` on ``log_std``.

        ``J v`` is the mean's forward-mode derivative along ``v = (V_i, c_i)_i``: with ``h_i`` the input of layer
        ``i`` and ``s_i`` its activation's slope, ``dz_i = W_i dh_i + V_i h_i + c_i`` and ``dh_{i+1} = s_i * dz_i``;
        ``J^T u`` is the backward pass of ``u`` (``delta_i = (delta_{i+1} W_{i+1}) * s_i``, blocks ``delta_i^T h_i``
        and ``sum delta_i``). The inputs and activations are kept once per fit; a product then costs four matrix
        products per layer, all of them large (oneDNN's, :mod:`baselines.common.gemm`), where contracting with
        per-sample Jacobians ``d mean / d z_i`` (``N x act_dim x width``) was memory-bound: 1.5 against 2.3 ms per
        product and 0.6 against 12.9 ms of setup on UnitreeH1's 200-row subsample, same values to 1e-7.
        """
        policy = self.policy
        modules = list(policy.mean_net)
        linears, activations = modules[0::2], modules[1::2]
        n_layers, n = len(linears), obs.shape[0]
        inputs: list[torch.Tensor] = []  # h_i, the input of each Linear layer
        outputs: list[torch.Tensor] = []  # each activation's output, from which its slope follows
        with torch.no_grad():
            h = obs.float()
            if policy.standardizer is not None:
                h = policy.standardizer.normalize_torch(h)
            for linear, activation in zip(linears, activations, strict=True):
                inputs.append(h)
                h = activation(gemm.linear(h, linear.weight, linear.bias))
                outputs.append(h)
            precision = torch.exp(-2.0 * policy.log_std.detach()) / n
        sizes = [p.numel() for p in policy.parameters()]

        def slope(grad: torch.Tensor, i: int) -> torch.Tensor:
            """``grad * s_i``: through layer ``i``'s activation at the kept point."""
            if isinstance(activations[i], nn.ReLU):
                return torch.ops.aten.threshold_backward(grad, outputs[i], 0.0)
            if isinstance(activations[i], nn.Tanh):
                return torch.ops.aten.tanh_backward(grad, outputs[i])
            return grad

        def fvp(v: torch.Tensor) -> torch.Tensor:
            with torch.no_grad():
                pieces = torch.split(v, sizes)  # weight_0, bias_0, weight_1, bias_1, ..., log_std
                # J v: the change of the mean action along v, forward mode.
                d_h = None
                for i in range(n_layers):
                    d_z = gemm.linear(inputs[i], pieces[2 * i].view_as(linears[i].weight), pieces[2 * i + 1])
                    if d_h is not None:
                        d_z += gemm.linear(d_h, linears[i].weight)
                    d_h = slope(d_z, i)
                # J^T (diag(precision) J v), backward mode.
                out: list[torch.Tensor] = [torch.empty(0)] * (2 * n_layers)
                delta = slope(d_h * precision, n_layers - 1)
                for i in range(n_layers - 1, -1, -1):
                    out[2 * i], out[2 * i + 1] = gemm.mm(delta.t(), inputs[i]).reshape(-1), delta.sum(dim=0)
                    if i > 0:
                        delta = slope(gemm.mm(delta, linears[i].weight), i - 1)
                out.append(2.0 * pieces[-1])
                return torch.cat(out)

        return fvp

    def _conjugate_gradient_t(self, b: torch.Tensor, fvp: FisherOperator) -> torch.Tensor:
        """Mushroom's ``_conjugate_gradient``, on torch tensors and a prebuilt operator."""
        p, r = b.clone(), b.clone()
        x = torch.zeros_like(b)
        r2 = torch.dot(r, r)
        for _ in range(self._n_epochs_cg()):
            z = fvp(p)
            v = r2 / torch.dot(p, z)
            x += v * p
            r -= v * z
            r2_new = torch.dot(r, r)
            p = r + (r2_new / r2) * p
            r2 = r2_new
            if r2 < self._cg_residual_tol():
                break
        return x

    # ---- line search ------------------------------------------------------------------------------------
    def _line_search_t(self, obs: torch.Tensor, act: torch.Tensor, adv: torch.Tensor, old_log_prob: torch.Tensor,
                       old_mean: torch.Tensor, old_log_std: torch.Tensor, prev_loss: float, stepdir: torch.Tensor,
                       fvp: FisherOperator) -> tuple[int, float, float]:
        """Mushroom's ``_line_search``; returns (trials, KL of the kept policy, its surrogate)."""
        shs = 0.5 * torch.dot(stepdir, fvp(stepdir)).item()
        params = self.policy.parameters()
        theta_old = torch.nn.utils.parameters_to_vector(params).detach().clone()
        if not (math.isfinite(shs) and shs > 0):  # zero gradient: nothing to do
            return 0, 0.0, prev_loss
        full_step = stepdir / math.sqrt(shs / self._max_kl())
        stepsize, max_kl = 1.0, self._max_kl.get_value()
        for trial in range(1, self._n_epochs_line_search() + 1):
            self.policy.set_weights(theta_old + full_step * stepsize)
            with torch.no_grad():
                mean = self.policy.mean_t(obs)
                log_std = self.policy.log_std
                new_loss = self._surrogate(gaussian_log_prob(act, mean, log_std), old_log_prob, adv).item()
                kl = gaussian_kl(old_mean, old_log_std, mean, log_std).item()
            if kl <= max_kl * 1.5 and new_loss - prev_loss >= 0:
                return trial, kl, new_loss
            stepsize *= 0.5
        self.policy.set_weights(theta_old)
        return self._n_epochs_line_search(), 0.0, prev_loss

    # ---- critic -----------------------------------------------------------------------------------------
    def _fit_critic(self, x: np.ndarray, v_target: np.ndarray, orders: list[np.ndarray]) -> float:
        """One pass of shuffled minibatches per order (Mushroom's ``TorchApproximator.fit``); last pass's mean loss."""
        net, optimizer, loss_fn = self.critic, self.critic_optimizer, self._V.model._loss or F.mse_loss
        n = len(x)
        batch_size = self._V.model._batch_size or n
        inputs, targets = torch.from_numpy(x), torch.from_numpy(v_target.reshape(n, 1))
        losses: list[float] = []
        for epoch_order in orders:
            order = torch.from_numpy(epoch_order)
            losses = []
            for start in range(0, n, batch_size):
                idx = order[start:start + batch_size]
                loss = loss_fn(net(inputs[idx]), targets[idx])
                optimizer.zero_grad()
                loss.backward()
                optimizer.step()
                losses.append(loss.item())
        return float(np.mean(losses))

    # ---- checkpoints ------------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """Policy, critic, critic optimiser, generator and iteration (shared standardizers: the agent's)."""
        self.synchronize()
        return {"policy": self.policy.state_dict(), "critic": self.critic.state_dict(),
                "critic_optimizer": self.critic_optimizer.state_dict(), "iter": int(self._iter),
                "rng": self._rng.bit_generator.state}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.synchronize()
        self.policy.load_state_dict(state["policy"])
        self.critic.load_state_dict(state["critic"])
        self.critic_optimizer.load_state_dict(state["critic_optimizer"])
        self._iter = int(state["iter"])
        self._rng.bit_generator.state = state["rng"]


class _BackgroundJob(threading.Thread):
    """``fn(*args)`` in a daemon thread with one torch thread (the other core steps the environment)."""

    def __init__(self, fn: Callable[..., float], *args: Any):
        super().__init__(daemon=True, name="critic-fit")
        self._fn, self._args = fn, args
        self._value: float = math.nan
        self._error: BaseException | None = None
        self.start()

    def run(self) -> None:
        torch.set_num_threads(1)  # per thread: the main thread keeps its own setting
        try:
            self._value = self._fn(*self._args)
        except BaseException as err:  # re-raised in the main thread by result()
            self._error = err

    def result(self) -> float:
        self.join()
        if self._error is not None:
            raise self._error
        return self._value
