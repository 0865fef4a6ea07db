"""Expert transitions from ``env.create_dataset()``, restricted to what a discriminator should see.

The discriminator sees only the entries of the observation selected by the environment's kinematic mask
(``env.get_kinematic_obs_mask()``, True = kinematic entry); environments without one expose everything.
Real motion-capture datasets have no actions: only GAIfO and VAIL (states / next states) can use them.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def kinematic_obs_mask(env: Any) -> np.ndarray:
    """Boolean mask over the observation: the environment's kinematic mask, or all True if it has none.

    Accepts a boolean mask or an array of indices from ``get_kinematic_obs_mask``.
    """
    obs_dim = env.info.observation_space.shape[0]
    get_mask = getattr(env, "get_kinematic_obs_mask", None)
    if get_mask is None:
        return np.ones(obs_dim, dtype=bool)
    raw = np.asarray(get_mask())
    if raw.dtype == bool:
        if raw.shape != (obs_dim,):
            raise ValueError(f"kinematic mask has shape {raw.shape}, observation has {obs_dim} entries")
        return raw.copy()
    mask = np.zeros(obs_dim, dtype=bool)
    mask[raw.astype(np.intp)] = True
    return mask


class ExpertData:
    """Masked expert ``states`` / ``next_states`` (float32), ``absorbing`` flags (all False where the dataset has
    none) and, where the dataset has them, ``actions``."""

    def __init__(self, dataset: dict[str, np.ndarray], obs_mask: np.ndarray):
        self.obs_mask = np.asarray(obs_mask, dtype=bool)
        self.states = np.ascontiguousarray(dataset["states"][:, self.obs_mask], dtype=np.float32)
        self.next_states = np.ascontiguousarray(dataset["next_states"][:, self.obs_mask], dtype=np.float32)
        actions = dataset.get("actions")
        self.actions = None if actions is None else np.ascontiguousarray(actions, dtype=np.float32)
        absorbing = dataset.get("absorbing")
        self.absorbing = np.zeros(len(self.states), bool) if absorbing is None else np.asarray(absorbing, bool)
        if len(self.states) == 0:
            raise ValueError("the expert dataset is empty")

    @classmethod
    def from_env(cls, env: Any) -> ExpertData:
        return cls(env.create_dataset(), kinematic_obs_mask(env))

    @property
    def has_actions(self) -> bool:
        return self.actions is not None

    def __len__(self) -> int:
        return len(self.states)

    def sample_indices(self, n: int, rng: np.random.Generator) -> np.ndarray:
        """``n`` transition indices drawn uniformly without replacement (with replacement if n > len)."""
        return rng.choice(len(self), size=n, replace=n > len(self))
