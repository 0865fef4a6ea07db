"""Running mean / standard deviation of observations, for normalising network inputs.

Statistics are merged batch by batch with the parallel form of Welford's algorithm (Chan, Golub & LeVeque,
1979), in float64: ``mean`` and the sum of squared deviations ``m2`` never subtract two large sums, so the
variance stays accurate over millions of samples. The agent updates a standardizer once per fit, on the
whole batch (never per step), so that the policy used to collect a batch is the one that is updated.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch


class RunningStandardizer:
    """``normalize(x) = clip((x - mean) / std, -clip, clip)`` with ``std = sqrt(var + eps)``.

    Before the first update it is the identity (mean 0, std 1), apart from the clipping.
    """

    def __init__(self, dim: int, clip: float = 10.0, eps: float = 1e-4):
        self.dim, self.clip, self.eps = int(dim), float(clip), float(eps)
        self.count = 0
        self.mean = np.zeros(self.dim)
        self.m2 = np.zeros(self.dim)
        self.version = 0  # bumped at every change; users caching mean/std (the numpy policy) compare it
        self._refresh()

    def update(self, batch: np.ndarray) -> None:
        """Merge the statistics of ``batch`` (shape ``(n, dim)``) into the running ones."""
        batch = np.asarray(batch, dtype=np.float64).reshape(-1, self.dim)
        n_b = batch.shape[0]
        if n_b == 0:
            return
        mean_b = batch.mean(axis=0)
        m2_b = np.square(batch - mean_b).sum(axis=0)
        n_a, n = self.count, self.count + n_b
        delta = mean_b - self.mean
        self.mean = self.mean + delta * (n_b / n)
        self.m2 = self.m2 + m2_b + np.square(delta) * (n_a * n_b / n)
        self.count = n
        self._refresh()

    @property
    def var(self) -> np.ndarray:
        return self.m2 / self.count if self.count > 0 else np.ones(self.dim)

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(self.var + self.eps) if self.count > 0 else np.ones(self.dim)

    def normalize(self, x: np.ndarray) -> np.ndarray:
        """Normalised ``x`` as float32 (numpy)."""
        out = (np.asarray(x, dtype=np.float32) - self.mean32) * self.inv_std32
        return np.clip(out, -self.clip, self.clip, out=out)

    def normalize_torch(self, x: torch.Tensor) -> torch.Tensor:
        """Normalised ``x`` (a float32 tensor); differentiable, statistics are constants."""
        return torch.clamp((x - self._mean_t) * self._inv_std_t, -self.clip, self.clip)

    def _refresh(self) -> None:
        self.mean32 = self.mean.astype(np.float32)
        self.inv_std32 = (1.0 / self.std).astype(np.float32)
        self._mean_t = torch.from_numpy(self.mean32)
        self._inv_std_t = torch.from_numpy(self.inv_std32)
        self.version += 1

    # ---- checkpoints (tensors and Python scalars only: loadable with torch.load(weights_only=True)) ----------
    def state_dict(self) -> dict[str, Any]:
        return {"count": int(self.count), "mean": torch.from_numpy(self.mean.copy()),
                "m2": torch.from_numpy(self.m2.copy()), "clip": self.clip, "eps": self.eps}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        mean = state["mean"].numpy().astype(np.float64)
        if mean.shape != (self.dim,):
            raise ValueError(f"standardizer of dimension {self.dim} cannot load statistics of shape {mean.shape}")
        self.count, self.mean, self.m2 = int(state["count"]), mean.copy(), state["m2"].numpy().astype(np.float64)
        self.clip, self.eps = float(state["clip"]), float(state["eps"])
        self._refresh()
