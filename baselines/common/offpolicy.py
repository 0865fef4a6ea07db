"""The loop shared by IQ-Learn, LS-IQ and SQIL: a SAC-style off-policy actor-critic ``Agent`` on ``Core``.

``Core.learn(n_steps=..., n_steps_per_fit=1)`` calls :meth:`fit` after every environment step; ``fit``

1. appends the transitions to the replay buffer (:class:`~baselines.common.replay.ReplayBuffer`);
2. once the buffer holds ``warmup`` transitions, runs ``updates_per_step`` updates per transition. One
   update draws ``batch_size`` agent transitions and ``batch_size`` expert transitions (rows ``[:B]`` and
   ``[B:]`` of every batch tensor) and, from one set of forward passes:

   * **critic**: minimises the algorithm's :meth:`critic_loss` over the twin critics ``Q_1, Q_2`` (each
     critic gets the loss on its own values), given ``q = Q_j(s, a)``, ``v = Q_j(s, a~) - alpha log pi(a~|s)``
     with ``a~ ~ pi(.|s)``, and the target ``V'(s') = min_j Qt_j(s', a') - alpha log pi(a'|s')``,
     ``a' ~ pi(.|s')`` (``Qt``: the target critics, no gradient);
   * **actor**: minimises ``mean_s [alpha log pi(a~|s) - min_j Q_j(s, a~)]`` over agent and expert states;
   * **temperature**: fixed ``alpha``, or with ``learn_alpha`` minimises ``-log(alpha) (log pi + target_entropy)``;
   * **targets**: ``Qt <- Qt + tau (Q - Qt)``.

   Per update that is one actor pass over the ``4B`` rows ``[s; s']``, one target pass over ``[s', a']`` and
   one pass of the online critics over the ``4B`` rows ``[s, a; s, a~]`` (each layer of both critics one
   batched matrix product). Autograd differentiates only the algorithm's loss w.r.t. the values; the backward
   passes through critics and actor are written out (:meth:`~baselines.common.twin_critic.TwinCritic.backward`,
   :meth:`~baselines.common.squashed_policy.TanhGaussianPolicy.squash_backward` and ``backward_kept``): the
   critic's weight gradients and the actor's gradient through ``a~`` come from the same products (rows whose
   cotangent is zero are skipped: LS-IQ's loss has no term on the agent's ``Q(s, a)``), so the actor step
   uses the critic before its step, as in Mushroom-RL's SAC. The Adam steps call the fused kernel directly
   (:func:`fused_adam_step`). Same losses, same order, same numbers up to float rounding as the autograd
   version (tests/test_offpolicy.py compares them).

The observation standardizer is fitted once, on the expert's states (like BC), so runs are reproducible and
the critic's inputs never drift. Networks see the observation entries the expert data knows: those of its
mask that are finite in every expert state (motion capture cannot know e.g. a carried load, which the
dataset marks NaN: the expert cannot show what to do with it). Expert actions come from the dataset (or
``train.expert_actions: inverse_dynamics``); with ``from_observations`` they are predicted by an inverse
dynamics model learned online on the agent's transitions (:mod:`baselines.common.inverse_model`).

Reproducibility: every random stream (index sampling, network initialisation, batch noise, exploration) is a
seeded generator in :meth:`state_dict`; the replay buffer is saved apart (:meth:`save_buffer`). A run resumed
from both continues exactly as the uninterrupted one (tests/test_offpolicy.py).
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import torch
from mushroom_rl.core import Agent, MDPInfo

from baselines.common.agent_config import AgentConfig
from baselines.common.expert_data import ExpertData
from baselines.common.fast_trpo import default_num_threads
from baselines.common.inverse_model import InverseDynamicsModel
from baselines.common.replay import ReplayBuffer
from baselines.common.squashed_policy import TanhGaussianPolicy
from baselines.common.standardizer import RunningStandardizer
from baselines.common.twin_critic import TwinCritic


@dataclass
class OffPolicyConfig(AgentConfig):
    """Hyperparameters shared by the off-policy imitation agents (defaults: the issue's starting point)."""

    actor_hidden: tuple[int, ...] = (256, 256)
    critic_hidden: tuple[int, ...] = (256, 256)
    n_critics: int = 2  # SAC's min over 2 critics against overestimation; configs/defaults.yaml gives LS-IQ 1
    # (its clipped targets bound Q; 1.5-1.7x faster updates)
    activation: str = "relu"
    critic_layer_norm: bool = False  # LayerNorm in the critics' hidden layers: bounds how far Q can extrapolate
    actor_lr: float = 3e-5
    critic_lr: float = 3e-4
    batch_size: int = 256  # agent transitions per update; as many expert transitions are added
    replay_capacity: int = 1_000_000
    initial_samples: int = 10_000  # agent transitions before the first update (see set_budget)
    updates_per_step: int = 1
    tau: float = 0.005
    alpha: float = 1e-3  # temperature (fixed unless learn_alpha)
    learn_alpha: bool = False
    alpha_lr: float = 3e-4
    target_entropy: float | None = None  # None: -action dimension
    log_std_min: float = -5.0
    log_std_max: float = 2.0
    obs_clip: float = 10.0  # standardized inputs are clipped to [-obs_clip, obs_clip]
    from_observations: bool = False  # expert actions from an inverse-dynamics model learned online
    inverse_model_hidden: tuple[int, ...] = (256, 256)
    inverse_model_lr: float = 3e-4
    n_threads: int | None = None  # torch threads; None: default_num_threads()

    def validate(self) -> None:
        for name in ("batch_size", "replay_capacity", "initial_samples", "updates_per_step", "n_critics"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        for name in ("actor_lr", "critic_lr", "alpha", "alpha_lr", "obs_clip", "inverse_model_lr"):
            if not float(getattr(self, name)) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0.0 < self.tau <= 1.0:
            raise ValueError(f"tau must be in (0, 1], got {self.tau}")
        if not self.log_std_min < self.log_std_max:
            raise ValueError(f"log_std_min ({self.log_std_min}) must be < log_std_max ({self.log_std_max})")
        if self.activation not in ("relu", "tanh"):
            raise ValueError(f"activation must be 'relu' or 'tanh', got {self.activation!r}")


@dataclass
class CriticBatch:
    """What an algorithm's critic loss sees; rows ``[:n_agent]`` are the agent's, ``[n_agent:]`` the expert's.

    ``q`` and ``v`` have one row per critic (shape ``(n_critics, 2B)``) and carry the critic's gradient;
    ``next_v`` (``(2B,)``, no gradient) is ``V'(s')`` from the target critics, ``absorbing`` is 1.0 where
    ``s'`` is absorbing.
    """

    q: torch.Tensor
    v: torch.Tensor
    next_v: torch.Tensor
    absorbing: torch.Tensor
    n_agent: int
    gamma: float


def fused_adam_step(optimizer: torch.optim.Optimizer) -> None:
    """``optimizer.step()`` for a fused, single-group Adam without AMSGrad whose state exists: the same kernel call
    (``torch._fused_adam_``, step counts incremented first, as ``torch.optim.Adam`` does), without the generic
    wrapper's per-step grouping, hooks and checks (~0.1 ms). Anything else goes through ``optimizer.step()``."""
    group = optimizer.param_groups[0]
    params, state = group["params"], optimizer.state
    if (len(optimizer.param_groups) != 1 or not isinstance(optimizer, torch.optim.Adam) or not group["fused"]
            or group["amsgrad"] or group["decoupled_weight_decay"] or group["differentiable"]
            or len(state) != len(params) or any(p.grad is None for p in params)):
        optimizer.step()
        return
    states = [state[p] for p in params]
    steps = [s["step"] for s in states]
    torch._foreach_add_(steps, 1)
    beta1, beta2 = group["betas"]
    torch._fused_adam_(params, [p.grad for p in params], [s["exp_avg"] for s in states],
                       [s["exp_avg_sq"] for s in states], [], steps, amsgrad=False, lr=group["lr"], beta1=beta1,
                       beta2=beta2, weight_decay=group["weight_decay"], eps=group["eps"], maximize=group["maximize"],
                       grad_scale=None, found_inf=None)


class OffPolicyImitation(Agent):
    """Base class: see the module docstring. Subclasses set ``name``, ``config_class`` and :meth:`critic_loss`."""

    name: ClassVar[str] = ""
    family: ClassVar[str] = "offpolicy"  # configs/defaults.yaml: families.offpolicy
    config_class: ClassVar[type[OffPolicyConfig]] = OffPolicyConfig
    uses_policy_values: ClassVar[bool] = True  # False: critic_loss ignores batch.v (no critic gradient through it)
    # False: critic_loss ignores the agent's Q(s, a) (batch.q[:, :n_agent]), so those B rows skip the critic pass
    # (LS-IQ); the logged q_agent is then measured once per Core.learn, on the latest B replay transitions
    uses_agent_values: ClassVar[bool] = True

    def __init__(self, mdp_info: MDPInfo, expert: ExpertData, config: OffPolicyConfig | dict | None = None,
                 seed: int = 0):
        if not isinstance(config, OffPolicyConfig):
            config = self.config_class.from_dict(config)
        self.config = config
        space = mdp_info.action_space
        act_dim = space.shape[0]
        if not (np.all(space.low == -1.0) and np.all(space.high == 1.0)):
            raise ValueError(f"{self.name} expects actions normalised to [-1, 1], got [{space.low}, {space.high}]")
        if expert.obs_mask.shape != mdp_info.observation_space.shape:
            raise ValueError(f"expert mask has {expert.obs_mask.shape[0]} entries, the observation "
                             f"{mdp_info.observation_space.shape[0]}")
        # The networks see the entries the expert data knows: its mask's, less those unknown (NaN) in any state.
        known = np.all(np.isfinite(expert.states), axis=0) & np.all(np.isfinite(expert.next_states), axis=0)
        obs_mask = expert.obs_mask.copy()
        obs_mask[np.flatnonzero(expert.obs_mask)[~known]] = False
        if not known.any():
            raise ValueError(f"{self.name}: the expert data knows none of the observation entries")
        if not (expert.has_actions or config.from_observations):
            raise ValueError(f"{self.name} needs expert actions: use a dataset with actions (<task>.perfect), "
                             "train.expert_actions: inverse_dynamics / auto, or agent.from_observations: true")
        obs_dim = int(obs_mask.sum())
        self.n_threads = config.n_threads if config.n_threads is not None else default_num_threads()
        torch.set_num_threads(self.n_threads)

        # Every random stream derives from `seed`: index sampling (numpy), network initialisation and batch noise
        # (torch), exploration (the policy's numpy generator).
        seeds = [int(s) for s in np.random.SeedSequence(seed).generate_state(3)]
        self._rng = np.random.default_rng(seeds[0])
        self._generator = torch.Generator().manual_seed(seeds[1])

        self.obs_standardizer = RunningStandardizer(obs_dim, clip=config.obs_clip)
        self.obs_standardizer.update(expert.states[:, known])
        policy = TanhGaussianPolicy(obs_mask, act_dim, self.obs_standardizer, config.actor_hidden, config.activation,
                                    config.log_std_min, config.log_std_max, seed=seeds[2], generator=self._generator)
        self.critic = TwinCritic(obs_dim, act_dim, config.critic_hidden, config.activation, n=config.n_critics,
                                 generator=self._generator, layer_norm=config.critic_layer_norm)
        self.target_critic = self.critic.make_target()
        self.actor_optimizer = torch.optim.Adam(policy.parameters(), lr=config.actor_lr, fused=True)
        self.critic_optimizer = torch.optim.Adam(self.critic.parameters(), lr=config.critic_lr, fused=True)
        self.log_alpha = torch.tensor(math.log(config.alpha), requires_grad=config.learn_alpha)
        self.alpha_optimizer = torch.optim.Adam([self.log_alpha], lr=config.alpha_lr) if config.learn_alpha else None
        self.target_entropy = -float(act_dim) if config.target_entropy is None else float(config.target_entropy)
        self.inverse_model = (InverseDynamicsModel(obs_dim, act_dim, config.inverse_model_hidden,
                                                   config.inverse_model_lr, self._generator)
                              if config.from_observations else None)

        self.buffer = ReplayBuffer(config.replay_capacity, obs_dim, act_dim)
        self.expert = expert
        self._expert_states = torch.from_numpy(np.ascontiguousarray(expert.states[:, known]))
        self._expert_next_states = torch.from_numpy(np.ascontiguousarray(expert.next_states[:, known]))
        self._expert_absorbing = torch.from_numpy(expert.absorbing.astype(np.float32))
        self._expert_actions = (torch.from_numpy(np.clip(expert.actions, -1.0, 1.0).astype(np.float32))
                                if expert.has_actions and not config.from_observations else None)
        # numpy views of the same memory, for the gathers of _sample_rows
        self._expert_states_np = self._expert_states.numpy()
        self._expert_next_states_np = self._expert_next_states.numpy()
        self._expert_absorbing_np = self._expert_absorbing.numpy()
        self._expert_actions_np = None if self._expert_actions is None else self._expert_actions.numpy()
        self.warmup = config.initial_samples
        self.transitions = 0  # environment transitions fitted
        self.updates = 0
        self._replay_expected: int | None = None  # buffer count of the checkpoint last loaded (see load_buffer)
        self._stats_sum: torch.Tensor | None = None  # running sums of the update statistics since the last stop()
        self._stats_count = 0
        self._stats_keys: list[str] = []
        self._stats: dict[str, float] = {}
        super().__init__(mdp_info, policy)

    @classmethod
    def from_env(cls, env: Any, config: OffPolicyConfig | dict | None = None, seed: int = 0,
                 expert: ExpertData | None = None) -> OffPolicyImitation:
        """The agent for ``env``, with expert data from ``env.create_dataset()`` unless ``expert`` is given."""
        return cls(env.info, expert if expert is not None else ExpertData.from_env(env), config, seed)

    # ---- what an algorithm defines ----------------------------------------------------------------------
    def critic_loss(self, batch: CriticBatch) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """The loss minimised by both critics (summed over them) and named scalar statistics (tensors)."""
        raise NotImplementedError

    # ---- the schedule -----------------------------------------------------------------------------------
    def set_budget(self, n_steps: int) -> None:
        """Scale the warm-up to a run of ``n_steps`` environment steps: ``min(initial_samples, n_steps // 10)``
        transitions (at least ``batch_size``) are collected before the first update. Call it before
        ``load_state_dict``, which restores the value a checkpointed run used."""
        self.warmup = max(min(self.config.initial_samples, int(n_steps) // 10), self.config.batch_size)

    def updates_in(self, n_steps: int) -> int:
        """Updates the next ``n_steps`` transitions will make: none for those still filling the warm-up (a fresh
        run's first ``warmup``, or a resumed one's while its replay buffer refills)."""
        waiting = max(self.warmup - self.buffer.n_added - 1, 0)
        return max(int(n_steps) - waiting, 0) * self.config.updates_per_step

    @property
    def alpha(self) -> float:
        return float(self.log_alpha.exp())

    # ---- the fit ----------------------------------------------------------------------------------------
    def fit(self, dataset: list[tuple], **info: Any) -> None:
        """Store ``dataset``'s transitions; after the warm-up, ``updates_per_step`` updates for each of them."""
        if torch.get_num_threads() != self.n_threads:
            torch.set_num_threads(self.n_threads)
        mask = self.policy.obs_mask
        n_updates = 0
        for state, action, _reward, next_state, absorbing, _last in dataset:
            self.buffer.add(state[mask], action, next_state[mask], absorbing)
            self.transitions += 1
            if self.buffer.n_added >= self.warmup:  # the buffer's own count: a warm start refills it first
                n_updates += self.config.updates_per_step
        for _ in range(n_updates):
            self.update()

    def update(self) -> None:
        """One update of critic, actor, temperature and target critics (see the module docstring)."""
        states, action, absorbing = self._sample_rows()  # states: x (rows [:n]) then x' (rows [n:])
        n = action.shape[0]
        policy, critic = self.policy, self.critic
        noise = torch.randn((2, n, policy.act_dim), generator=self._generator)
        alpha = self.log_alpha.detach().exp()
        with torch.no_grad():
            # One actor pass over [x; x'] and one pass of the online critics over [x, a; x, a~] (a~ ~ pi(.|x)).
            out, actor_inputs = policy.forward_kept(states)
            sampled, log_probs = policy.squash_t(out, noise.view(2 * n, -1))
            x, x_next = states[:n], states[n:]
            new_action, log_prob, next_log_prob = sampled[:n], log_probs[:n], log_probs[n:]
            next_q, _ = self.target_critic(torch.cat([x_next, sampled[n:]], 1))
            next_v = next_q.amin(0) - alpha * next_log_prob
            b = self.config.batch_size
            skipped = 0 if self.uses_agent_values else b  # leading rows of [x, a] left out of the critic pass
            critic_input = torch.cat([torch.cat([x[skipped:], action[skipped:]], 1), torch.cat([x, new_action], 1)])
            values, hidden = critic(critic_input, keep=True)
            if skipped:  # placeholders the loss never reads (checked below)
                values = torch.cat([values.new_zeros(values.shape[0], skipped), values], 1)
        # The critic loss is differentiated by autograd w.r.t. the values only; the rest is written out below.
        if self.uses_policy_values:
            leaf = values.detach().requires_grad_()
            q, q_new = leaf[:, :n], leaf[:, n:]
        else:
            leaf = values[:, :n].detach().requires_grad_()
            q, q_new = leaf, values[:, n:]
        batch = CriticBatch(q=q, v=q_new - alpha * log_prob, next_v=next_v, absorbing=absorbing,
                            n_agent=self.config.batch_size, gamma=self.mdp_info.gamma)
        critic_loss, stats = self.critic_loss(batch)
        (grad_values,) = torch.autograd.grad(critic_loss, leaf, allow_unused=True, materialize_grads=True)
        with torch.no_grad():
            # The actor minimises mean(alpha log pi - min_j Q_j(s, a~)): the critics' action gradient of
            # -min_j Q_j / n goes down the critic layers with the loss's cotangent (critic before its step).
            q_min, argmin = values[:, n:].min(0)
            # Rows whose cotangent is zero add nothing (LS-IQ's loss has no term on the agent's Q(s, a)): skip them.
            loss_start = b if not grad_values[:, :b].any() else 0
            if loss_start < skipped:
                raise RuntimeError(f"{self.name}.critic_loss reads the agent's Q(s, a), but uses_agent_values is False")
            grad_action = critic.backward(critic_input, hidden, grad_values[:, loss_start:], loss_start - skipped,
                                          argmin, -1.0 / n)
            policy.backward_kept(actor_inputs, policy.squash_backward(out[:n], noise[0], new_action, alpha / n,
                                                                      grad_action))
        fused_adam_step(self.critic_optimizer)
        fused_adam_step(self.actor_optimizer)
        if self.alpha_optimizer is not None:
            self.log_alpha.grad = -(log_prob + self.target_entropy).mean()  # d/d(log alpha) of the alpha loss
            self.alpha_optimizer.step()
        self.critic.soft_update(self.target_critic, self.config.tau)
        self.updates += 1
        with torch.no_grad():
            stats = {"critic_loss": critic_loss, "actor_loss": (alpha * log_prob - q_min).mean(),
                     **({"q_agent": values[:, :b].mean()} if self.uses_agent_values else {}),
                     "q_expert": values[:, b:n].mean(), "v_next": next_v.mean(),
                     "entropy": -log_prob.mean(), "alpha": alpha, **stats, **self._inverse_model_stats}
            self._accumulate(stats)

    def _sample(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
        """Standardized ``(x, a, x', absorbing)`` of ``batch_size`` agent then ``batch_size`` expert transitions."""
        states, action, absorbing = self._sample_rows()
        n = action.shape[0]
        return states[:n], action, states[n:], absorbing

    def _sample_rows(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """:meth:`_sample` as ``(states, a, absorbing)``: ``states`` holds ``x`` in rows ``[:2B]`` and ``x'`` in rows
        ``[2B:]``. Gathered by numpy into one array, standardized in place."""
        b, buf, obs_dim = self.config.batch_size, self.buffer, self.buffer.obs_dim
        agent_idx = self._rng.integers(buf.size, size=b)
        expert_idx = self._rng.integers(len(self.expert), size=b)
        states = np.empty((4 * b, obs_dim), np.float32)
        for rows, source, idx in ((slice(0, b), buf.states, agent_idx),
                                  (slice(b, 2 * b), self._expert_states_np, expert_idx),
                                  (slice(2 * b, 3 * b), buf.next_states, agent_idx),
                                  (slice(3 * b, 4 * b), self._expert_next_states_np, expert_idx)):
            np.take(source, idx, axis=0, out=states[rows])
        states = self.obs_standardizer.normalize(states)
        states = torch.from_numpy(states)
        action = np.empty((2 * b, buf.act_dim), np.float32)
        np.take(buf.actions, agent_idx, axis=0, out=action[:b])
        absorbing = np.empty(2 * b, np.float32)
        np.take(buf.absorbing, agent_idx, out=absorbing[:b])
        np.take(self._expert_absorbing_np, expert_idx, out=absorbing[b:])
        action = torch.from_numpy(action)
        if self.inverse_model is not None:  # fit f(s, s') on the agent's transitions, then label the expert's
            x, x_next = states[:2 * b], states[2 * b:]
            loss = self.inverse_model.fit(x[:b], x_next[:b], action[:b])
            action[b:] = self.inverse_model.predict(x[b:], x_next[b:])
            self._inverse_model_stats = {"inverse_model_loss": loss}
        else:
            np.take(self._expert_actions_np, expert_idx, axis=0, out=action.numpy()[b:])
            self._inverse_model_stats = {}
        return states, action, torch.from_numpy(absorbing)

    def expert_rows(self, idx: np.ndarray) -> tuple[torch.Tensor, torch.Tensor]:
        """Standardized expert states at ``idx`` and the actions the critics are trained with there (the dataset's,
        clipped to [-1, 1], or the inverse model's labels of ``(s, s')``), for probing the critics."""
        x = torch.from_numpy(self.obs_standardizer.normalize(self._expert_states_np[idx]))
        if self.inverse_model is None:
            return x, torch.from_numpy(self._expert_actions_np[idx])
        x_next = torch.from_numpy(self.obs_standardizer.normalize(self._expert_next_states_np[idx]))
        return x, self.inverse_model.predict(x, x_next)

    # ---- statistics -------------------------------------------------------------------------------------
    def _accumulate(self, stats: dict[str, torch.Tensor]) -> None:
        values = torch.stack([torch.as_tensor(v, dtype=torch.float32) for v in stats.values()])
        if self._stats_sum is None or self._stats_keys != list(stats):
            self._stats_keys, self._stats_sum, self._stats_count = list(stats), torch.zeros_like(values), 0
        self._stats_sum += values
        self._stats_count += 1

    def stop(self) -> None:
        """Called by ``Core`` at the end of ``learn``: the statistics become the means over its updates."""
        if self._stats_count:
            means = (self._stats_sum / self._stats_count).tolist()
            self._stats = {"updates": float(self.updates), "replay_size": float(self.buffer.size),
                           **dict(zip(self._stats_keys, means, strict=True))}
            if not self.uses_agent_values:
                self._stats["q_agent"] = self._latest_agent_value()
            self._stats_sum, self._stats_count = None, 0

    def _latest_agent_value(self) -> float:
        """Mean of the critics' ``Q(s, a)`` over the latest ``batch_size`` replay transitions (no random draw)."""
        buf = self.buffer
        idx = (buf.n_added - 1 - np.arange(min(self.config.batch_size, buf.size))) % buf.capacity
        x = torch.from_numpy(self.obs_standardizer.normalize(buf.states[idx]).astype(np.float32))
        with torch.no_grad():
            values, _ = self.critic(torch.cat([x, torch.from_numpy(buf.actions[idx])], 1))
        return float(values.mean())

    @property
    def last_stats(self) -> dict[str, float]:
        """Means of the update statistics over the last ``Core.learn`` call (what the trainer logs each epoch)."""
        return dict(self._stats)

    # ---- checkpoints ------------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """Everything but the replay buffer (see :meth:`save_buffer`), as a snapshot of tensors and Python values
        (``torch.load(weights_only=True)``)."""
        state = {"algorithm": self.name, "config": self.config.to_dict(), "policy": self.policy.state_dict(),
                 "critic": self.critic.state_dict(), "target_critic": self.target_critic.state_dict(),
                 "actor_optimizer": self.actor_optimizer.state_dict(),
                 "critic_optimizer": self.critic_optimizer.state_dict(), "log_alpha": self.log_alpha.detach(),
                 "alpha_optimizer": None if self.alpha_optimizer is None else self.alpha_optimizer.state_dict(),
                 "inverse_model": None if self.inverse_model is None else self.inverse_model.state_dict(),
                 "obs_standardizer": self.obs_standardizer.state_dict(), "rng": self._rng.bit_generator.state,
                 "torch_rng": self._generator.get_state(), "warmup": self.warmup, "updates": self.updates,
                 "transitions": self.transitions, "replay_transitions": self.buffer.n_added, "stats": dict(self._stats),
                 "stats_keys": list(self._stats_keys), "stats_count": self._stats_count,
                 "stats_sum": None if self._stats_sum is None else self._stats_sum}
        return copy.deepcopy(state)

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Restore :meth:`state_dict`; then :meth:`load_buffer` with the buffer saved beside it."""
        if state["algorithm"] != self.name:
            raise ValueError(f"checkpoint of {state['algorithm']!r} cannot be loaded into {self.name!r}")
        if (state["inverse_model"] is None) != (self.inverse_model is None):
            raise ValueError("the checkpoint and this agent disagree on from_observations")
        self.policy.load_state_dict(state["policy"])
        self.critic.load_state_dict(state["critic"])
        self.target_critic.load_state_dict(state["target_critic"])
        self.actor_optimizer.load_state_dict(state["actor_optimizer"])
        self.critic_optimizer.load_state_dict(state["critic_optimizer"])
        with torch.no_grad():
            self.log_alpha.copy_(state["log_alpha"])
        if self.alpha_optimizer is not None and state["alpha_optimizer"] is not None:
            self.alpha_optimizer.load_state_dict(state["alpha_optimizer"])
        if self.inverse_model is not None:
            self.inverse_model.load_state_dict(state["inverse_model"])
        self.obs_standardizer.load_state_dict(state["obs_standardizer"])
        self._rng.bit_generator.state = state["rng"]
        self._generator.set_state(state["torch_rng"])
        self.warmup, self.updates = int(state["warmup"]), int(state["updates"])
        self.transitions = int(state["transitions"])
        self._replay_expected = int(state["replay_transitions"])
        self._stats = dict(state["stats"])
        self._stats_keys, self._stats_count = list(state["stats_keys"]), int(state["stats_count"])
        self._stats_sum = None if state["stats_sum"] is None else state["stats_sum"].clone()

    def save_buffer(self, path: str | Path) -> None:
        """Write the replay buffer to ``path`` (a compressed ``.npz``, written atomically); save it together with
        :meth:`state_dict`, whose ``transitions`` count it must match when loaded."""
        self.buffer.save(path)

    def load_buffer(self, path: str | Path) -> None:
        """Load the buffer saved with the checkpoint just loaded by :meth:`load_state_dict` (without one: a buffer
        of this agent's current moment); a buffer of another moment of the run raises ``ValueError``. Without it
        (a warm start) the agent refills an empty buffer for ``warmup`` transitions before it updates again."""
        buffer = ReplayBuffer(self.buffer.capacity, self.buffer.obs_dim, self.buffer.act_dim)
        buffer.load(path)
        expected = self.buffer.n_added if self._replay_expected is None else self._replay_expected
        if buffer.n_added != expected:
            raise ValueError(f"{path} holds the replay buffer after {buffer.n_added:,} transitions, the agent's is "
                             f"after {expected:,}: they are not from the same moment of the run")
        self.buffer, self._replay_expected = buffer, None
