"""Policy exports: a trained policy as plain arrays, runnable with numpy alone.

An export is a folder with three files:

- ``policy.safetensors``: the network (``layers.<i>.weight`` (out, in) and ``layers.<i>.bias``, float32) and
  the observation standardizer (``obs_mean``, ``obs_inv_std``, ``obs_clip``, float32); a Gaussian policy adds
  ``log_std``; a policy that sees only some observation entries adds ``obs_mask`` (bool, one per entry of the
  env's observation). No header metadata: safetensors writes it in a random order, and the file must be
  byte-identical per policy.
- ``config.yaml``: the resolved run configuration it was trained with.
- ``card.json``: task, env settings, algorithm, seed, training steps and evaluation figures; ``policy`` names
  the hidden activation and the action distribution (below; absent means ``gaussian``).

With ``x = clip((obs[obs_mask] - obs_mean) * obs_inv_std, -clip, clip)`` and ``f`` an MLP with the named
activation after every layer but the last, the two distributions are

- ``gaussian`` (the on-policy agents and BC): deterministic action ``f(x)``; stochastic ones add
  ``exp(log_std) * N(0, 1)``;
- ``tanh_gaussian`` (the off-policy agents): ``f(x) = [mu, log_std]``, deterministic action ``tanh(mu)``;
  stochastic ones ``tanh(mu + exp(clip(log_std, log_std_min, log_std_max)) * N(0, 1))``, the bounds on the card.

The arithmetic matches each training-time policy's numpy path in float32, so an export acts exactly as its
checkpoint did.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from loco_mujoco.atomic_write import atomic_write

WEIGHTS = "policy.safetensors"
CARD = "card.json"
CONFIG = "config.yaml"
MAX_BYTES = 1_000_000  # an export stays small enough to commit
_ACTIVATIONS = {"relu": lambda x: np.maximum(x, 0.0, out=x), "tanh": lambda x: np.tanh(x, out=x),
                "identity": lambda x: x}
GAUSSIAN, TANH_GAUSSIAN = "gaussian", "tanh_gaussian"
DISTRIBUTIONS = (GAUSSIAN, TANH_GAUSSIAN)


class ExportError(ValueError):
    """A policy export is missing, incomplete or malformed; the message names the folder and the problem."""


@dataclass
class PolicyExport:
    """A loaded export: call :meth:`draw_action` on observations of its task's environment."""

    path: Path
    weights: list[tuple[np.ndarray, np.ndarray]]  # (W^T (in, out), b) per layer, float32
    activation: str
    log_std: np.ndarray | None  # gaussian only: the state-independent log standard deviation
    obs_mean: np.ndarray
    obs_inv_std: np.ndarray
    obs_clip: float
    card: dict[str, Any]
    config: dict[str, Any]
    distribution: str = GAUSSIAN
    obs_index: np.ndarray | None = None  # entries of the observation the network sees; None: all of them
    obs_dim: int = 0  # length of the env's observation
    log_std_bounds: tuple[float, float] | None = None  # tanh_gaussian only

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
        if not isinstance(card, dict):
            raise ExportError(f"{path / CARD}: expected a JSON object, got {type(card).__name__}")
        try:
            return cls._from_arrays(path, tensors, card, config)
        except KeyError as err:
            raise ExportError(f"{path / WEIGHTS}: missing or invalid {err}; expected layers.<i>.weight/bias, "
                              "obs_mean, obs_inv_std, obs_clip, and log_std for a Gaussian policy") from None

    @classmethod
    def _from_arrays(cls, path: Path, tensors: dict[str, np.ndarray], card: dict[str, Any],
                     config: dict[str, Any]) -> PolicyExport:
        """The export of ``tensors`` and its card; raises ``KeyError`` for a missing entry, ``ExportError`` for
        arrays that do not fit together."""
        policy = card.get("policy", {})
        activation = policy.get("activation", "relu")
        if activation not in _ACTIVATIONS:
            raise KeyError(f"activation {activation!r}")
        distribution = policy.get("distribution", GAUSSIAN)
        if distribution not in DISTRIBUTIONS:
            raise ExportError(f"{path / CARD}: policy.distribution {distribution!r} is not one of "
                              f"{', '.join(DISTRIBUTIONS)}")
        n_layers = len([k for k in tensors if k.startswith("layers.") and k.endswith(".weight")])
        # Gaussian: contiguous W^T, as GaussianPolicy caches it; tanh-Gaussian: the transposed view of W that
        # TanhGaussianPolicy multiplies with. Either way BLAS gets the same operands as at training time.
        transpose = (lambda w: np.ascontiguousarray(w.T)) if distribution == GAUSSIAN else (lambda w: w.T)
        weights = [(transpose(tensors[f"layers.{i}.weight"]), tensors[f"layers.{i}.bias"]) for i in range(n_layers)]
        obs_mean, obs_inv_std, obs_clip = tensors["obs_mean"], tensors["obs_inv_std"], float(tensors["obs_clip"])
        mask = tensors.get("obs_mask")
        if mask is not None and (mask.dtype != bool or mask.ndim != 1):
            raise ExportError(f"{path / WEIGHTS}: obs_mask must be a 1-d bool array, got {mask.dtype} {mask.shape}")
        obs_index = None if mask is None else np.flatnonzero(mask)
        log_std = tensors["log_std"].astype(np.float64) if distribution == GAUSSIAN else None
        bounds = (float(policy["log_std_min"]), float(policy["log_std_max"])) if distribution == TANH_GAUSSIAN \
            else None
        export = cls(path, weights, activation, log_std, obs_mean, obs_inv_std, obs_clip, card, config, distribution,
                     obs_index, len(mask) if mask is not None else int(np.size(obs_mean)), bounds)
        export._check_shapes()
        return export

    def _check_shapes(self) -> None:
        """Raise :class:`ExportError` unless the arrays chain into one network of the declared distribution."""
        n_in = self.obs_dim if self.obs_index is None else len(self.obs_index)
        problems = []
        if not self.weights:
            problems.append("no layers")
        if np.shape(self.obs_mean) != (n_in,) or np.shape(self.obs_inv_std) != (n_in,):
            problems.append(f"obs_mean {np.shape(self.obs_mean)} and obs_inv_std {np.shape(self.obs_inv_std)} do "
                            f"not match the {n_in} observation entries the network sees")
        for i, (w_t, b) in enumerate(self.weights):
            if w_t.ndim != 2 or w_t.shape[0] != n_in or b.shape != (w_t.shape[1],):
                problems.append(f"layers.{i} (weight {w_t.T.shape}, bias {b.shape}) does not take {n_in} inputs")
                break
            n_in = w_t.shape[1]
        if self.distribution == GAUSSIAN and np.shape(self.log_std) != (n_in,):
            problems.append(f"log_std has shape {np.shape(self.log_std)} for {n_in} actions")
        if self.distribution == TANH_GAUSSIAN and n_in % 2:
            problems.append(f"a tanh-Gaussian network needs an even output ([mu, log_std]), got {n_in}")
        if problems:
            raise ExportError(f"{self.path / WEIGHTS}: {'; '.join(problems)}")

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

    @property
    def act_dim(self) -> int:
        n_out = self.weights[-1][0].shape[1]
        return n_out if self.distribution == GAUSSIAN else n_out // 2

    def mean_action(self, obs: np.ndarray) -> np.ndarray:
        """The mean of the action distribution for one observation or a batch (float32): the deterministic action
        of a Gaussian policy, ``mu`` before the squashing of a tanh-Gaussian one."""
        out = self._forward(obs)
        return out if self.distribution == GAUSSIAN else out[..., :self.act_dim]

    def _forward(self, obs: np.ndarray) -> np.ndarray:
        """The network's output for one observation or a batch (float32)."""
        x = obs if self.obs_index is None else np.asarray(obs)[..., self.obs_index]
        h = (np.asarray(x, dtype=np.float32) - self.obs_mean) * self.obs_inv_std
        np.clip(h, -self.obs_clip, self.obs_clip, out=h)
        act = _ACTIVATIONS[self.activation]
        for i, (w_t, b) in enumerate(self.weights):
            h = h @ w_t
            h += b
            if i < len(self.weights) - 1:
                h = act(h)
        return h

    def draw_action(self, obs: np.ndarray, rng: np.random.Generator | None = None) -> np.ndarray:
        """The deterministic action, or with ``rng`` a sample (float64; see the module docstring)."""
        if self.distribution == GAUSSIAN:
            mean = self.mean_action(obs).astype(np.float64)
            if rng is None:
                return mean
            return mean + np.exp(self.log_std) * rng.standard_normal(mean.shape)
        out = self._forward(obs)
        mean = out[..., :self.act_dim].astype(np.float64)
        if rng is None:
            return np.tanh(mean)
        log_std = np.clip(out[..., self.act_dim:], *self.log_std_bounds)
        return np.tanh(mean + np.exp(log_std) * rng.standard_normal(mean.shape))


def write_export(path: str | Path, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                 log_std: np.ndarray | None, obs_mean: np.ndarray, obs_inv_std: np.ndarray, obs_clip: float,
                 card: dict[str, Any], config: dict[str, Any], overwrite: bool = False, *,
                 distribution: str = GAUSSIAN, log_std_bounds: tuple[float, float] | None = None,
                 obs_mask: np.ndarray | None = None) -> Path:
    """Write an export folder; ``layers`` are (weight (out, in), bias) pairs. A ``gaussian`` policy gives
    ``log_std``, a ``tanh_gaussian`` one ``log_std_bounds`` instead; ``obs_mask`` (bool over the env's
    observation) when the network sees only some entries. Refuses to replace an existing export unless
    ``overwrite``, and to write one over ``MAX_BYTES``."""
    from safetensors.numpy import save

    path = Path(path)
    if (path / WEIGHTS).exists() and not overwrite:
        raise FileExistsError(f"{path} already holds a policy export; choose another folder or pass overwrite")
    if activation not in _ACTIVATIONS:
        raise ExportError(f"activation must be one of {', '.join(_ACTIVATIONS)}, got {activation!r}")
    if distribution not in DISTRIBUTIONS:
        raise ExportError(f"distribution must be one of {', '.join(DISTRIBUTIONS)}, got {distribution!r}")
    if (distribution == GAUSSIAN) != (log_std is not None) or (distribution == TANH_GAUSSIAN) != (
            log_std_bounds is not None):
        raise ExportError("a gaussian policy needs log_std (and no log_std_bounds), a tanh_gaussian one "
                          f"log_std_bounds (and no log_std); got {distribution} with log_std "
                          f"{'set' if log_std is not None else 'None'}, log_std_bounds {log_std_bounds}")
    tensors = {"obs_mean": np.asarray(obs_mean, np.float32), "obs_inv_std": np.asarray(obs_inv_std, np.float32),
               "obs_clip": np.array(obs_clip, np.float32)}
    if log_std is not None:
        tensors["log_std"] = np.asarray(log_std, np.float32)
    if obs_mask is not None and not np.all(obs_mask):  # all entries: no mask, as before masks existed
        tensors["obs_mask"] = np.asarray(obs_mask, bool)
    for i, (w, b) in enumerate(layers):
        tensors[f"layers.{i}.weight"] = np.ascontiguousarray(w, dtype=np.float32)
        tensors[f"layers.{i}.bias"] = np.asarray(b, np.float32)
    size = sum(t.nbytes for t in tensors.values())
    if size > MAX_BYTES:
        raise ExportError(f"the policy's arrays take {size:,} bytes, over the {MAX_BYTES:,} an export may hold")
    path.mkdir(parents=True, exist_ok=True)
    with atomic_write(path / WEIGHTS, "wb") as f:  # save_file's own writes left the weights 0600, private to one user
        f.write(save(tensors))
    policy = {"activation": activation, "format": "loco_mujoco.policy/1"}
    if distribution == TANH_GAUSSIAN:  # Gaussian cards stay as they were before other distributions existed
        policy.update(distribution=distribution, log_std_min=float(log_std_bounds[0]),
                      log_std_max=float(log_std_bounds[1]))
    write_card(path, {**card, "policy": policy})
    (path / CONFIG).write_text(yaml.safe_dump(config, sort_keys=False))
    return path


def write_card(path: str | Path, card: dict[str, Any]) -> Path:
    """Write ``card`` as the card of the export folder ``path`` (sorted keys, one space indent)."""
    with atomic_write(Path(path) / CARD, "w") as handle:
        handle.write(json.dumps(card, indent=1, sort_keys=True, default=float) + "\n")
    return Path(path) / CARD
