"""Policy exports: a trained policy as plain arrays, runnable with numpy alone.

An export is a folder with three files:

- ``policy.safetensors``: the mean network (``layers.<i>.weight`` (out, in) and ``layers.<i>.bias``, float32),
  ``log_std`` and the observation standardizer (``obs_mean``, ``obs_inv_std``, ``obs_clip``, float32). No
  header metadata: safetensors writes it in a random order, and the file must be byte-identical per policy.
- ``card.json`` also names the hidden activation (``policy.activation``).
- ``config.yaml``: the resolved run configuration it was trained with.
- ``card.json``: task, env settings, algorithm, seed, training steps and evaluation figures.

``a = mu(clip((obs - obs_mean) * obs_inv_std, -clip, clip))``, ``mu`` an MLP with the named activation after
every layer but the last; stochastic actions add ``exp(log_std) * N(0, 1)``. The arithmetic matches the
training-time policy's numpy path in float32, so an export acts exactly as its checkpoint did.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

WEIGHTS = "policy.safetensors"
CARD = "card.json"
CONFIG = "config.yaml"
MAX_BYTES = 1_000_000  # an export stays small enough to commit
_ACTIVATIONS = {"relu": lambda x: np.maximum(x, 0.0, out=x), "tanh": lambda x: np.tanh(x, out=x),
                "identity": lambda x: x}


class ExportError(ValueError):
    """A policy export is missing, incomplete or malformed; the message names the folder and the problem."""


@dataclass
class PolicyExport:
    """A loaded export: call :meth:`draw_action` on observations of its task's environment."""

    path: Path
    weights: list[tuple[np.ndarray, np.ndarray]]  # (W^T (in, out), b) per layer, float32
    activation: str
    log_std: np.ndarray
    obs_mean: np.ndarray
    obs_inv_std: np.ndarray
    obs_clip: float
    card: dict[str, Any]
    config: dict[str, Any]

    @classmethod
    def load(cls, path: str | Path) -> PolicyExport:
        """Read the export in folder ``path``."""
        from safetensors.numpy import load_file

        path = Path(path)
        missing = [name for name in (WEIGHTS, CARD, CONFIG) if not (path / name).is_file()]
        if missing:
            raise ExportError(f"{path} is not a policy export: missing {', '.join(missing)} "
                              f"(an export holds {WEIGHTS}, {CARD} and {CONFIG})")
        try:
            tensors = load_file(str(path / WEIGHTS))
            card = json.loads((path / CARD).read_text())
            config = yaml.safe_load((path / CONFIG).read_text())
        except Exception as err:  # noqa: BLE001  (safetensors, JSON and YAML each raise their own errors)
            raise ExportError(f"{path}: unreadable export ({type(err).__name__}: {err})") from None
        n_layers = len([k for k in tensors if k.startswith("layers.") and k.endswith(".weight")])
        try:
            weights = [(np.ascontiguousarray(tensors[f"layers.{i}.weight"].T), tensors[f"layers.{i}.bias"])
                       for i in range(n_layers)]
            activation = card.get("policy", {}).get("activation", "relu")
            if activation not in _ACTIVATIONS:
                raise KeyError(f"activation {activation!r}")
            return cls(path, weights, activation, tensors["log_std"].astype(np.float64), tensors["obs_mean"],
                       tensors["obs_inv_std"], float(tensors["obs_clip"]), card, config)
        except KeyError as err:
            raise ExportError(f"{path / WEIGHTS}: missing or invalid {err}; expected layers.<i>.weight/bias, "
                              "log_std, obs_mean, obs_inv_std, obs_clip") from None

    @property
    def task(self) -> str:
        return str(self.card["task"])

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The env settings the policy was trained with (``LocoEnv.make(export.task, **export.env_kwargs)``)."""
        return dict(self.card.get("env", {}))

    @property
    def sha256(self) -> str:
        """sha256 of the weights file: names this exact policy in the datasets built from it."""
        return hashlib.sha256((self.path / WEIGHTS).read_bytes()).hexdigest()

    def mean_action(self, obs: np.ndarray) -> np.ndarray:
        """The deterministic action for one observation or a batch (float32)."""
        h = (np.asarray(obs, dtype=np.float32) - self.obs_mean) * self.obs_inv_std
        np.clip(h, -self.obs_clip, self.obs_clip, out=h)
        act = _ACTIVATIONS[self.activation]
        for i, (w_t, b) in enumerate(self.weights):
            h = h @ w_t
            h += b
            if i < len(self.weights) - 1:
                h = act(h)
        return h

    def draw_action(self, obs: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """The mean action, or with ``rng`` a sample ``mean + exp(log_std) * N(0, 1)`` (float64)."""
        mean = self.mean_action(obs).astype(np.float64)
        if rng is None:
            return mean
        return mean + np.exp(self.log_std) * rng.standard_normal(mean.shape)


def write_export(path: str | Path, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                 log_std: np.ndarray, obs_mean: np.ndarray, obs_inv_std: np.ndarray, obs_clip: float,
                 card: dict[str, Any], config: dict[str, Any], overwrite: bool = False) -> Path:
    """Write an export folder; ``layers`` are (weight (out, in), bias) pairs. Refuses to replace an existing
    export unless ``overwrite``, and to write one over ``MAX_BYTES``."""
    from safetensors.numpy import save_file

    path = Path(path)
    if (path / WEIGHTS).exists() and not overwrite:
        raise FileExistsError(f"{path} already holds a policy export; choose another folder or pass overwrite")
    if activation not in _ACTIVATIONS:
        raise ExportError(f"activation must be one of {', '.join(_ACTIVATIONS)}, got {activation!r}")
    tensors = {"log_std": np.asarray(log_std, np.float32), "obs_mean": np.asarray(obs_mean, np.float32),
               "obs_inv_std": np.asarray(obs_inv_std, np.float32), "obs_clip": np.array(obs_clip, np.float32)}
    for i, (w, b) in enumerate(layers):
        tensors[f"layers.{i}.weight"] = np.ascontiguousarray(w, dtype=np.float32)
        tensors[f"layers.{i}.bias"] = np.asarray(b, np.float32)
    size = sum(t.nbytes for t in tensors.values())
    if size > MAX_BYTES:
        raise ExportError(f"the policy's arrays take {size:,} bytes, over the {MAX_BYTES:,} an export may hold")
    path.mkdir(parents=True, exist_ok=True)
    save_file(tensors, str(path / WEIGHTS))
    card = {**card, "policy": {"activation": activation, "format": "loco_mujoco.policy/1"}}
    (path / CARD).write_text(json.dumps(card, indent=1, sort_keys=True, default=float) + "\n")
    (path / CONFIG).write_text(yaml.safe_dump(config, sort_keys=False))
    return path
