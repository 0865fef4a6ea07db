"""The agent's own transitions for off-policy learning: preallocated numpy arrays, a ring of fixed capacity.

Each row is one transition ``(s, a, s', absorbing)`` as the learner sees it (observations already masked to
what the critic uses). Adding writes in place, sampling gathers rows by index; nothing is kept per sample in
Python. The buffer is saved apart from the checkpoint (it is large: 1e6 H1 transitions are ~300 MB of float32)
as a compressed ``.npz`` written atomically; ``n_added`` (transitions ever added) lets the agent check that a
buffer file belongs to the checkpoint it is loaded with.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from loco_mujoco.atomic_write import atomic_write

_FIELDS = ("states", "actions", "next_states", "absorbing")


class ReplayBuffer:
    """Ring buffer of ``capacity`` transitions; ``size`` rows are valid, the next one is written at ``position``."""

    def __init__(self, capacity: int, obs_dim: int, act_dim: int):
        if capacity < 1:
            raise ValueError(f"replay capacity must be >= 1, got {capacity}")
        self.capacity, self.obs_dim, self.act_dim = int(capacity), int(obs_dim), int(act_dim)
        self.states = np.zeros((self.capacity, self.obs_dim), np.float32)
        self.actions = np.zeros((self.capacity, self.act_dim), np.float32)
        self.next_states = np.zeros((self.capacity, self.obs_dim), np.float32)
        self.absorbing = np.zeros(self.capacity, np.float32)  # 1.0 where s' is absorbing (float: used in targets)
        self.size = 0
        self.position = 0
        self.n_added = 0

    def __len__(self) -> int:
        return self.size

    def add(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray, absorbing: bool) -> None:
        """Store one transition (overwriting the oldest once full)."""
        i = self.position
        self.states[i] = state
        self.actions[i] = action
        self.next_states[i] = next_state
        self.absorbing[i] = absorbing
        self.position = (i + 1) % self.capacity
        self.size = min(self.size + 1, self.capacity)
        self.n_added += 1

    # ---- files ------------------------------------------------------------------------------------------
    def save(self, path: str | Path) -> None:
        """Write the valid rows and the counters to ``path`` (compressed ``.npz``; atomic: a temp file, then rename)."""
        n = self.size
        with atomic_write(path, "wb") as f:
            np.savez_compressed(f, **{name: getattr(self, name)[:n] for name in _FIELDS},
                                counters=np.array([self.capacity, self.size, self.position, self.n_added], np.int64))

    def load(self, path: str | Path) -> None:
        """Replace the contents with those saved at ``path``; the dimensions and capacity must match."""
        with np.load(Path(path)) as data:
            capacity, size, position, n_added = (int(v) for v in data["counters"])
            if capacity != self.capacity:
                raise ValueError(f"{path}: a buffer of capacity {capacity:,}, this agent's holds {self.capacity:,} "
                                 "(agent.replay_capacity must match the run that saved it)")
            arrays = {name: data[name] for name in _FIELDS}
        if arrays["states"].shape != (size, self.obs_dim) or arrays["actions"].shape != (size, self.act_dim):
            raise ValueError(f"{path}: transitions of shape {arrays['states'].shape} / {arrays['actions'].shape}, "
                             f"expected ({size}, {self.obs_dim}) / ({size}, {self.act_dim})")
        for name, values in arrays.items():
            getattr(self, name)[:size] = values
        self.size, self.position, self.n_added = size, position, n_added
