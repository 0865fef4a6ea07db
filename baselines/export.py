"""Export a trained agent's policy (see :mod:`loco_mujoco.policy_export`): what datasets, pretrained agents and
any numpy user load without torch or the training code."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from torch import nn

from baselines.common.policy import GaussianPolicy
from loco_mujoco.policy_export import write_export

_ACTIVATION_NAMES = {nn.ReLU: "relu", nn.Tanh: "tanh"}


def policy_arrays(policy: GaussianPolicy) -> dict[str, Any]:
    """The arrays of a :class:`GaussianPolicy`: layers, activation, log-std and its standardizer."""
    modules = list(policy.mean_net)
    layers = [(m.weight.detach().numpy().copy(), m.bias.detach().numpy().copy()) for m in modules[0::2]]
    hidden = {type(m) for m in modules[1:-1:2]}
    if len(hidden) > 1 or not isinstance(modules[-1], nn.Identity):
        raise ValueError(f"cannot export a policy with activations {[type(m).__name__ for m in modules[1::2]]}")
    activation = _ACTIVATION_NAMES[hidden.pop()] if hidden else "relu"
    std = policy.standardizer
    if std is None:
        mean, inv_std, clip = np.zeros(policy.obs_dim, np.float32), np.ones(policy.obs_dim, np.float32), np.inf
    else:
        std._refresh()
        mean, inv_std, clip = std.mean32, std.inv_std32, std.clip
    return {"layers": layers, "activation": activation, "log_std": policy.log_std.detach().numpy().copy(),
            "obs_mean": mean, "obs_inv_std": inv_std, "obs_clip": clip}


def export_checkpoint(checkpoint: str | Path, out_dir: str | Path, evaluation: dict[str, Any] | None = None,
                      overwrite: bool = False) -> Path:
    """Write the export of ``checkpoint``'s policy to ``out_dir``, with ``evaluation`` figures on its card."""
    from baselines.training import build, load_checkpoint, run_config_from_checkpoint

    state = load_checkpoint(checkpoint)
    run = run_config_from_checkpoint(state)
    _, agent = build(run)
    agent.load_state_dict(state["agent"])
    card = {"task": run.task, "algorithm": run.algorithm, "seed": run.seed, "steps": int(state["steps"]),
            "env": dict(run.env), "source_checkpoint": str(Path(checkpoint).as_posix()),
            "evaluation": evaluation or {}, "format": "loco_mujoco.policy/1"}
    return write_export(out_dir, **policy_arrays(agent.policy), card=card, config=run.to_dict(), overwrite=overwrite)
