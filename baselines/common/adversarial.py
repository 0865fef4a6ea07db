"""The loop shared by GAIL, VAIL and GAIfO: an adversarial-imitation ``Agent`` around a TRPO learner.

``Core`` collects ``n_steps_per_fit`` transitions with the policy, then calls ``fit(dataset)`` (or, with several
environments, :class:`~baselines.common.batched.BatchedCollector` calls ``fit_arrays`` with their transitions as
arrays, each environment's segment contiguous), which

1. updates the observation standardizer shared by policy and critic (once per fit, on the whole batch);
2. every ``train_disc_every``-th fit, trains the discriminator on the batch (label 0) against as many expert
   transitions (label 1), in minibatches of ``disc_batch_size``;
3. replaces the environment's rewards with the discriminator reward ``-log(1 - D)``;
4. runs one TRPO update: :class:`~baselines.common.fast_trpo.FastTRPO` (``learner="fast"``) or Mushroom-RL's
   unmodified ``TRPO`` with its ``GaussianTorchPolicy`` (``learner="mushroom"``, kept for benchmarks).

An algorithm module only says what the discriminator sees and how it is trained (``policy_inputs``,
``expert_inputs``, ``build_discriminator``, ``discriminator_loss``). Configuration is a dataclass built from a
plain dict (unknown keys raise); ``state_dict`` / ``load_state_dict`` hold everything needed to resume exactly.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import torch
import torch.nn.functional as F
from mushroom_rl.algorithms.actor_critic import TRPO
from mushroom_rl.core import Agent, MDPInfo
from mushroom_rl.policy import GaussianTorchPolicy
from torch import nn

from baselines.common.agent_config import AgentConfig
from baselines.common.expert_data import ExpertData
from baselines.common.fast_trpo import FastTRPO, dataset_to_arrays, default_num_threads
from baselines.common.networks import MushroomMLP
from baselines.common.policy import GaussianPolicy
from baselines.common.standardizer import RunningStandardizer


@dataclass
class AdversarialConfig(AgentConfig):
    """Hyperparameters shared by the adversarial imitation agents (defaults: the issue's starting point)."""

    # policy: Gaussian, MLP mean, state-independent std
    policy_hidden: tuple[int, ...] = (512, 256)
    policy_activation: str = "relu"
    std_0: float = 1.0
    # critic (value function)
    critic_hidden: tuple[int, ...] = (512, 256)
    critic_lr: float = 1e-4
    critic_batch_size: int = 256
    critic_epochs: int = 5
    # TRPO
    learner: str = "fast"  # "fast": FastTRPO; "mushroom": unmodified Mushroom-RL TRPO + GaussianTorchPolicy
    gae_lambda: float = 0.97
    max_kl: float = 5e-3
    n_epochs_cg: int = 25
    n_epochs_line_search: int = 10
    cg_damping: float = 1e-2
    cg_residual_tol: float = 1e-10
    policy_entropy_coef: float = 0.0
    fisher_fraction: float = 0.2  # fast learner only
    fisher: str = "auto"  # fast learner only: "analytic", "autograd" or "auto"
    n_threads: int | None = None  # torch threads; None: default_num_threads()
    overlap_critic: bool = True  # fast learner only: critic fit overlaps the next rollout (background thread)
    # discriminator
    disc_hidden: tuple[int, ...] = (512, 256)
    disc_activation: str = "tanh"
    disc_lr: float = 5e-5
    disc_batch_size: int = 2048
    disc_epochs: int = 1  # passes over (batch + as many expert samples) when the discriminator trains
    train_disc_every: int = 3  # train the discriminator at every n-th fit
    disc_entropy_coef: float = 1e-3  # Bernoulli-entropy bonus of the plain discriminator
    obs_clip: float = 10.0  # standardized inputs are clipped to [-obs_clip, obs_clip]

    def validate(self) -> None:
        if self.learner not in ("fast", "mushroom"):
            raise ValueError(f"learner must be 'fast' or 'mushroom', got {self.learner!r}")
        for name in ("critic_batch_size", "critic_epochs", "n_epochs_cg", "n_epochs_line_search",
                     "disc_batch_size", "disc_epochs", "train_disc_every"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)}")
        for name in ("std_0", "critic_lr", "disc_lr", "max_kl", "obs_clip"):
            if not float(getattr(self, name)) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")



class AdversarialImitation(Agent):
    """Base class: see the module docstring. Subclasses set ``name`` and ``config_class``."""

    name: ClassVar[str] = ""
    family: ClassVar[str] = "adversarial"  # configs/defaults.yaml: families.adversarial
    config_class: ClassVar[type[AdversarialConfig]] = AdversarialConfig

    def __init__(self, mdp_info: MDPInfo, expert: ExpertData, config: AdversarialConfig | dict | None = None,
                 seed: int = 0):
        if not isinstance(config, AdversarialConfig):
            config = self.config_class.from_dict(config)
        self.config = config
        self.expert = expert
        self.check_expert(expert)
        self.obs_mask = expert.obs_mask
        obs_dim, act_dim = mdp_info.observation_space.shape[0], mdp_info.action_space.shape[0]
        if self.obs_mask.shape != (obs_dim,):
            raise ValueError(f"expert mask has {self.obs_mask.shape[0]} entries, the observation {obs_dim}")

        # Every random stream derives from `seed`: expert sampling / discriminator minibatches (numpy),
        # network initialisation and VAIL's latent noise (torch), exploration noise, the learner's generator.
        seeds = [int(s) for s in np.random.SeedSequence(seed).generate_state(5)]
        self._rng = np.random.default_rng(seeds[0])
        self._torch_generator = torch.Generator().manual_seed(seeds[1])

        self.obs_standardizer = RunningStandardizer(obs_dim, clip=config.obs_clip)
        self.learner = self._build_learner(mdp_info, obs_dim, act_dim, policy_seed=seeds[2], learner_seed=seeds[3],
                                           critic_seed=seeds[4])
        super().__init__(mdp_info, self.learner.policy)

        in_dim = self.discriminator_input_dim(int(self.obs_mask.sum()), act_dim)
        self.discriminator = self.build_discriminator(in_dim, self._torch_generator)
        self.disc_optimizer = torch.optim.Adam(self.discriminator.parameters(), lr=config.disc_lr, fused=True)
        self.disc_standardizer = RunningStandardizer(in_dim, clip=config.obs_clip)
        self.fit_count = 0
        self._fit_stats: dict[str, float] = {}
        self._disc_stats: dict[str, float] = {}

    @classmethod
    def from_env(cls, env: Any, config: AdversarialConfig | dict | None = None, seed: int = 0,
                 expert: ExpertData | None = None) -> AdversarialImitation:
        """The agent for ``env``, with expert data from ``env.create_dataset()`` unless ``expert`` is given."""
        return cls(env.info, expert if expert is not None else ExpertData.from_env(env), config, seed)

    def _build_learner(self, mdp_info: MDPInfo, obs_dim: int, act_dim: int, policy_seed: int, learner_seed: int,
                       critic_seed: int) -> TRPO:
        c = self.config
        critic_params = dict(network=MushroomMLP, input_shape=(obs_dim,), output_shape=(1,), hidden=c.critic_hidden,
                             activation="relu", output_std=1e-3, standardizer=self.obs_standardizer, seed=critic_seed,
                             onednn=c.learner == "fast",  # Mushroom's TRPO as written: nn.Linear products
                             optimizer={"class": torch.optim.Adam, "params": {"lr": c.critic_lr, "fused": True}},
                             loss=F.mse_loss,
                             batch_size=c.critic_batch_size)
        trpo_args = dict(ent_coeff=c.policy_entropy_coef, max_kl=c.max_kl, lam=c.gae_lambda,
                         n_epochs_line_search=c.n_epochs_line_search, n_epochs_cg=c.n_epochs_cg,
                         cg_damping=c.cg_damping, cg_residual_tol=c.cg_residual_tol,
                         critic_fit_params={"n_epochs": c.critic_epochs})
        n_threads = c.n_threads if c.n_threads is not None else default_num_threads()
        if c.learner == "fast":
            policy = GaussianPolicy(obs_dim, act_dim, c.policy_hidden, c.policy_activation, c.std_0,
                                    standardizer=self.obs_standardizer, seed=policy_seed,
                                    generator=self._torch_generator)
            return FastTRPO(mdp_info, policy, critic_params, fisher_fraction=c.fisher_fraction, fisher=c.fisher,
                            n_threads=n_threads, overlap_critic=c.overlap_critic, seed=learner_seed, **trpo_args)
        torch.set_num_threads(n_threads)
        policy = GaussianTorchPolicy(MushroomMLP, (obs_dim,), (act_dim,), std_0=c.std_0, hidden=c.policy_hidden,
                                     activation=c.policy_activation, output_std=1e-3,
                                     standardizer=self.obs_standardizer, seed=policy_seed, onednn=False)
        return TRPO(mdp_info, policy, critic_params, **trpo_args)

    # ---- what an algorithm defines ----------------------------------------------------------------------
    def check_expert(self, expert: ExpertData) -> None:
        """Raise if the expert data cannot train this algorithm (GAIL without actions)."""

    def discriminator_input_dim(self, n_obs: int, n_act: int) -> int:
        raise NotImplementedError

    def policy_inputs(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> np.ndarray:
        """Discriminator inputs (float32, unstandardized) of the policy's transitions."""
        raise NotImplementedError

    def expert_inputs(self, idx: np.ndarray) -> np.ndarray:
        """Discriminator inputs (float32, unstandardized) of the expert transitions ``idx``."""
        raise NotImplementedError

    def build_discriminator(self, in_dim: int, generator: torch.Generator) -> nn.Module:
        raise NotImplementedError

    def discriminator_loss(self, x: torch.Tensor, labels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(loss, logits) on standardized inputs ``x``; label 1 = expert."""
        raise NotImplementedError

    def after_discriminator_step(self) -> None:
        """Hook after each optimiser step (VAIL's multiplier update)."""

    def extra_state(self) -> dict[str, Any]:
        return {}

    def load_extra_state(self, state: dict[str, Any]) -> None:
        pass

    # ---- the fit ----------------------------------------------------------------------------------------
    def fit(self, dataset: list[tuple], **info: Any) -> None:
        """One fit on a Mushroom dataset (``Core``'s list of ``(s, a, r, s', absorbing, last)``)."""
        self._fit(*dataset_to_arrays(dataset), dataset=dataset)

    def fit_arrays(self, state: np.ndarray, action: np.ndarray, env_reward: np.ndarray, next_state: np.ndarray,
                   absorbing: np.ndarray, last: np.ndarray) -> None:
        """One fit on the six arrays of ``dataset_to_arrays`` (float32 states, actions and rewards, bool flags),
        transitions in time order within each trajectory segment and ``last`` true at each segment's end (an
        episode end, or where a segment stops inside an episode: the GAE treats both as ends, as it treats the
        final transition of a batch). What :class:`~baselines.common.batched.BatchedCollector` hands over."""
        self._fit(state, action, env_reward, next_state, absorbing, last, dataset=None)

    def _fit(self, x: np.ndarray, u: np.ndarray, env_reward: np.ndarray, xn: np.ndarray, absorbing: np.ndarray,
             last: np.ndarray, dataset: list[tuple] | None) -> None:
        self.synchronize()  # the previous fit's critic may still be training; it reads obs_standardizer
        self.fit_count += 1
        self.obs_standardizer.update(x)
        stats: dict[str, float] = {"fit": self.fit_count, "env_reward_mean": float(env_reward.mean())}
        if self.fit_count % self.config.train_disc_every == 0:
            self._disc_stats = self.train_discriminator(x, u, xn)
        stats.update(self._disc_stats)  # the latest discriminator training's figures
        reward = self.reward(x, u, xn)
        stats["disc_reward_mean"] = float(reward.mean())
        if isinstance(self.learner, FastTRPO):
            self.learner.fit_arrays(x, u, reward, xn, absorbing, last)
        elif dataset is not None:
            self.learner.fit([(t[0], t[1], r, *t[3:]) for t, r in zip(dataset, reward.tolist(), strict=True)])
        else:
            self.learner.fit(list(zip(x, u, reward.tolist(), xn, absorbing.tolist(), last.tolist(), strict=True)))
        self._fit_stats = stats

    def synchronize(self) -> None:
        """Wait for the learner's background work (the fast learner's critic fit)."""
        if isinstance(self.learner, FastTRPO):
            self.learner.synchronize()

    def stop(self) -> None:
        """Called by ``Core`` at the end of ``learn`` / ``evaluate``."""
        self.synchronize()

    @property
    def last_stats(self) -> dict[str, float]:
        """Statistics of the last fit: discriminator, rewards and the learner's (waits for the critic)."""
        self.synchronize()
        return {**self._fit_stats, **getattr(self.learner, "last_stats", {})}

    def reward(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> np.ndarray:
        """The discriminator reward ``-log(1 - D)`` of each transition (float32)."""
        x = self.disc_standardizer.normalize_torch(torch.from_numpy(self.policy_inputs(state, action, next_state)))
        with torch.no_grad():
            return self.discriminator.reward(x).numpy()

    def train_discriminator(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> dict[str, float]:
        """``disc_epochs`` passes over the policy batch plus as many expert transitions; returns statistics."""
        policy_in = self.policy_inputs(state, action, next_state)
        n = len(policy_in)
        losses, correct_expert, correct_policy = [], 0, 0
        for _ in range(self.config.disc_epochs):
            expert_in = self.expert_inputs(self.expert.sample_indices(n, self._rng))
            inputs = np.concatenate([policy_in, expert_in])
            labels = np.concatenate([np.zeros(n, np.float32), np.ones(n, np.float32)])
            self.disc_standardizer.update(inputs)
            x_all = self.disc_standardizer.normalize_torch(torch.from_numpy(inputs))
            y_all = torch.from_numpy(labels)
            order = torch.from_numpy(self._rng.permutation(2 * n))
            for start in range(0, 2 * n, self.config.disc_batch_size):
                idx = order[start:start + self.config.disc_batch_size]
                loss, logits = self.discriminator_loss(x_all[idx], y_all[idx])
                self.disc_optimizer.zero_grad()
                loss.backward()
                self.disc_optimizer.step()
                self.after_discriminator_step()
                losses.append(loss.item())
                expert = y_all[idx] > 0.5
                correct_expert += int((logits.detach()[expert] > 0).sum())
                correct_policy += int((logits.detach()[~expert] <= 0).sum())
        n_seen = n * self.config.disc_epochs
        return {"disc_loss": float(np.mean(losses)), "disc_acc_expert": correct_expert / n_seen,
                "disc_acc_policy": correct_policy / n_seen}

    # ---- checkpoints ------------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, Any]:
        """Everything needed to resume exactly; tensors and Python values only (``torch.load(weights_only=True)``)."""
        if not isinstance(self.learner, FastTRPO):
            raise NotImplementedError("exact checkpoints need learner='fast' (Mushroom's TRPO uses global RNGs)")
        self.synchronize()
        return {"algorithm": self.name, "config": self.config.to_dict(), "fit_count": self.fit_count,
                "obs_standardizer": self.obs_standardizer.state_dict(),
                "disc_standardizer": self.disc_standardizer.state_dict(),
                "discriminator": self.discriminator.state_dict(), "disc_optimizer": self.disc_optimizer.state_dict(),
                "rng": self._rng.bit_generator.state, "torch_rng": self._torch_generator.get_state(),
                "learner": self.learner.state_dict(), "extra": self.extra_state(),
                "disc_stats": dict(self._disc_stats)}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        if state["algorithm"] != self.name:
            raise ValueError(f"checkpoint of {state['algorithm']!r} cannot be loaded into {self.name!r}")
        if not isinstance(self.learner, FastTRPO):
            raise NotImplementedError("exact checkpoints need learner='fast'")
        self.synchronize()
        self.fit_count = int(state["fit_count"])
        self.obs_standardizer.load_state_dict(state["obs_standardizer"])
        self.disc_standardizer.load_state_dict(state["disc_standardizer"])
        self.discriminator.load_state_dict(state["discriminator"])
        self.disc_optimizer.load_state_dict(state["disc_optimizer"])
        self._rng.bit_generator.state = state["rng"]
        self._torch_generator.set_state(state["torch_rng"])
        self.learner.load_state_dict(state["learner"])
        self.load_extra_state(state["extra"])
        self._disc_stats = dict(state.get("disc_stats", {}))
