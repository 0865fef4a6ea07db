"""Export a trained agent's policy (see :mod:`loco_mujoco.policy_export`): what datasets, pretrained agents and
any numpy user load without torch or the training code. Both policy kinds export: the Gaussian policy of the
on-policy agents and BC, and the tanh-squashed Gaussian of the off-policy agents (IQ-Learn, LS-IQ, SQIL)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from torch import nn

from baselines.common.policy import GaussianPolicy
from baselines.common.squashed_policy import TanhGaussianPolicy
from loco_mujoco.policy_export import GAUSSIAN, TANH_GAUSSIAN, write_export

_ACTIVATION_NAMES = {nn.ReLU: "relu", nn.Tanh: "tanh"}


def _mlp_layers(net: nn.Sequential) -> tuple[list[tuple[np.ndarray, np.ndarray]], str]:
    """(weight, bias) copies of an MLP built by ``build_mlp`` and its hidden activation's name."""
    modules = list(net)
    layers = [(m.weight.detach().numpy().copy(), m.bias.detach().numpy().copy()) for m in modules[0::2]]
    hidden = {type(m) for m in modules[1:-1:2]}
    if len(hidden) > 1 or not isinstance(modules[-1], nn.Identity):
        raise ValueError(f"cannot export a policy with activations {[type(m).__name__ for m in modules[1::2]]}")
    return layers, _ACTIVATION_NAMES[hidden.pop()] if hidden else "relu"


def policy_arrays(policy: GaussianPolicy | TanhGaussianPolicy) -> dict[str, Any]:
    """The keyword arguments of :func:`~loco_mujoco.policy_export.write_export` for ``policy``: its layers,
    activation, standardizer and distribution (log-std for a Gaussian, log-std bounds and the observation mask
    for a tanh-Gaussian)."""
    if isinstance(policy, TanhGaussianPolicy):
        layers, activation = _mlp_layers(policy.net)
        std = policy.standardizer
        return {"layers": layers, "activation": activation, "log_std": None, "obs_mean": std.mean32,
                "obs_inv_std": std.inv_std32, "obs_clip": std.clip, "distribution": TANH_GAUSSIAN,
                "log_std_bounds": (policy.log_std_min, policy.log_std_max), "obs_mask": policy.obs_mask.copy()}
    if not isinstance(policy, GaussianPolicy):
        raise TypeError(f"cannot export a {type(policy).__name__}; exportable: GaussianPolicy, TanhGaussianPolicy")
    layers, activation = _mlp_layers(policy.mean_net)
    std = policy.standardizer
    if std is None:
        mean, inv_std, clip = np.zeros(policy.obs_dim, np.float32), np.ones(policy.obs_dim, np.float32), np.inf
    else:
        std._refresh()
        mean, inv_std, clip = std.mean32, std.inv_std32, std.clip
    return {"layers": layers, "activation": activation, "log_std": policy.log_std.detach().numpy().copy(),
            "obs_mean": mean, "obs_inv_std": inv_std, "obs_clip": clip, "distribution": GAUSSIAN}


def export_agent(agent: Any, out_dir: str | Path, card: dict[str, Any], config: dict[str, Any],
                 overwrite: bool = False) -> Path:
    """Write the export of ``agent.policy`` to ``out_dir`` with ``card`` and the run ``config``."""
    return write_export(out_dir, **policy_arrays(agent.policy), card=card, config=config, overwrite=overwrite)


def export_checkpoint(checkpoint: str | Path, out_dir: str | Path, evaluation: dict[str, Any] | None = None,
                      overwrite: bool = False) -> Path:
    """Write the export of ``checkpoint``'s policy to ``out_dir``, with ``evaluation`` figures on its card."""
    from baselines.training import build, load_checkpoint, run_config_from_checkpoint

    state = load_checkpoint(checkpoint)
    run = run_config_from_checkpoint(state)
    _, agent = build(run)
    agent.load_state_dict(state["agent"])
    card = run_card(run, int(state["steps"]), evaluation, source_checkpoint=str(Path(checkpoint).as_posix()))
    return export_agent(agent, out_dir, card, run.to_dict(), overwrite=overwrite)


def run_card(run: Any, steps: int, evaluation: dict[str, Any] | None = None, **extra: Any) -> dict[str, Any]:
    """The card of an export of ``run``'s policy after ``steps`` training steps (``evaluation``: protocol figures)."""
    return {"task": run.task, "algorithm": run.algorithm, "seed": run.seed, "steps": int(steps),
            "env": dict(run.env), **extra, "evaluation": evaluation or {}, "format": "loco_mujoco.policy/1"}
