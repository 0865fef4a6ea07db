"""Behaviour cloning (BC): the floor every imitation result is judged against.

A Gaussian policy ``pi(a | s) = N(mu(standardize(s)), diag(exp(log_std))^2)`` is fitted by maximum likelihood
on the expert's state-action pairs, with minibatches ``B`` drawn uniformly from them:

    L(theta) = -1/|B| * sum_{(s, a) in B} log pi_theta(a | s)

The standardizer is fitted once on all expert states. Actions come from the dataset where it has them
(perfect data) and from inverse dynamics on real motion capture (``train.expert_actions: auto``). One
training step is one gradient step, so ``launch.py --steps`` counts gradient steps; no environment step is
taken except to evaluate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch
from mushroom_rl.core import Agent, MDPInfo

from baselines.common.agent_config import AgentConfig
from baselines.common.expert_data import ExpertData
from baselines.common.fast_trpo import default_num_threads
from baselines.common.policy import GaussianPolicy
from baselines.common.standardizer import RunningStandardizer


@dataclass
class BCConfig(AgentConfig):
    """Hyperparameters of behaviour cloning."""

    policy_hidden: tuple[int, ...] = (512, 256)
    policy_activation: str = "relu"
    std_0: float = 0.5  # initial action standard deviation (learned with the mean)
    lr: float = 1e-3
    batch_size: int = 512
    weight_decay: float = 0.0
    obs_clip: float = 10.0  # standardized inputs are clipped to [-obs_clip, obs_clip]
    n_threads: int | None = None  # torch threads; None: default_num_threads()

    def validate(self) -> None:
        if self.batch_size < 1:
            raise ValueError(f"batch_size must be >= 1, got {self.batch_size}")
        for name in ("std_0", "lr", "obs_clip"):
            if not float(getattr(self, name)) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.weight_decay < 0:
            raise ValueError(f"weight_decay must be >= 0, got {self.weight_decay}")


class BC(Agent):
    """Behaviour cloning on ``expert`` (full observations and actions); train with :meth:`fit_offline`."""

    name: ClassVar[str] = "bc"
    family: ClassVar[str] = "offline"  # configs/defaults.yaml: families.offline
    config_class: ClassVar[type[BCConfig]] = BCConfig
    offline: ClassVar[bool] = True  # the trainer calls fit_offline(n) instead of collecting environment steps

    def __init__(self, mdp_info: MDPInfo, expert: ExpertData, config: BCConfig | dict | None = None, seed: int = 0):
        if not isinstance(config, BCConfig):
            config = BCConfig.from_dict(config)
        self.config = config
        obs_dim, act_dim = mdp_info.observation_space.shape[0], mdp_info.action_space.shape[0]
        if not expert.has_actions:
            raise ValueError("BC needs expert actions: use a dataset with actions (e.g. <task>.perfect) or "
                             "train.expert_actions: inverse_dynamics / auto")
        if expert.states.shape[1] != obs_dim or not np.all(np.isfinite(expert.states)):
            raise ValueError(f"BC needs the expert's full, finite observations ({obs_dim} entries); got "
                             f"{expert.states.shape[1]} entries, {int(np.sum(~np.isfinite(expert.states)))} unknown "
                             "(motion data cannot know e.g. a carried load)")
        self.states = torch.from_numpy(expert.states)
        self.actions = torch.from_numpy(np.clip(expert.actions, -1.0, 1.0))
        seeds = [int(s) for s in np.random.SeedSequence(seed).generate_state(2)]
        self._rng = np.random.default_rng(seeds[0])
        generator = torch.Generator().manual_seed(seeds[1])
        self.obs_standardizer = RunningStandardizer(obs_dim, clip=config.obs_clip)
        self.obs_standardizer.update(expert.states)
        policy = GaussianPolicy(obs_dim, act_dim, config.policy_hidden, config.policy_activation, config.std_0,
                                standardizer=self.obs_standardizer, seed=seeds[0], generator=generator)
        self.optimizer = torch.optim.Adam(policy.parameters(), lr=config.lr, weight_decay=config.weight_decay)
        self.n_threads = config.n_threads if config.n_threads is not None else default_num_threads()
        self.gradient_steps = 0
        self._stats: dict[str, float] = {}
        super().__init__(mdp_info, policy)

    @classmethod
    def from_env(cls, env: Any, config: BCConfig | dict | None = None, seed: int = 0,
                 expert: ExpertData | None = None) -> BC:
        """The agent for ``env``; by default the expert is ``env.create_dataset()`` with every observation entry."""
        if expert is None:
            expert = ExpertData(env.create_dataset(), np.ones(env.info.observation_space.shape[0], dtype=bool))
        return cls(env.info, expert, config, seed)

    def fit_offline(self, n_steps: int, callback: Any = None) -> None:
        """``n_steps`` gradient steps of the negative log-likelihood; ``callback(k)`` reports progress."""
        torch.set_num_threads(self.n_threads)
        losses = []
        for step in range(n_steps):
            idx = torch.from_numpy(self._rng.integers(len(self.states), size=self.config.batch_size))
            loss = -self.policy.log_prob_t(self.states[idx], self.actions[idx]).mean()
            self.optimizer.zero_grad(set_to_none=True)
            loss.backward()
            self.optimizer.step()
            losses.append(loss.item())
            if callback is not None and (step + 1) % 100 == 0:
                callback(100)
        if callback is not None and n_steps % 100:
            callback(n_steps % 100)
        self.policy.invalidate_cache()
        self.gradient_steps += n_steps
        with torch.no_grad():
            self._stats = {"bc_nll": float(np.mean(losses[-100:])) if losses else float("nan"),
                           "action_std_mean": float(torch.exp(self.policy.log_std).mean())}

    def fit(self, dataset: Any) -> None:
        raise RuntimeError("BC learns offline from the expert data: call fit_offline(n_steps), not Core.learn")

    @property
    def last_stats(self) -> dict[str, float]:
        """Statistics of the last fit_offline call (what the trainer logs each epoch)."""
        return dict(self._stats)

    def state_dict(self) -> dict[str, Any]:
        """Everything needed to resume exactly: policy, optimiser, standardizer and the minibatch generator."""
        return {"algorithm": self.name, "config": self.config.to_dict(), "policy": self.policy.state_dict(),
                "optimizer": self.optimizer.state_dict(), "obs_standardizer": self.obs_standardizer.state_dict(),
                "rng": self._rng.bit_generator.state, "gradient_steps": self.gradient_steps,
                "stats": dict(self._stats)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if state["algorithm"] != self.name:
            raise ValueError(f"checkpoint of {state['algorithm']!r} cannot be loaded into {self.name!r}")
        self.policy.load_state_dict(state["policy"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.obs_standardizer.load_state_dict(state["obs_standardizer"])
        self._rng.bit_generator.state = state["rng"]
        self.gradient_steps = int(state["gradient_steps"])
        self._stats = dict(state.get("stats", {}))
        self.policy.invalidate_cache()
