"""Pretrained agents in one call::

    from baselines.pretrained import available, load

    policy = load("UnitreeH1.walk", "vail")       # seed 0; available() lists every (task, algorithm, seed)
    env = policy.make_env()                        # the task's env with the settings it was trained with
    action = policy.draw_action(env.reset())

An agent is a policy export (:mod:`loco_mujoco.policy_export`) in ``pretrained/<task>/<algo>/seed<N>/`` (or under
``$LOCO_MUJOCO_PRETRAINED``): weights, observation standardizer, resolved config and card. It runs with numpy
alone, offline; the loader never builds an agent or a torch network.

Observation conventions: the Mushroom-RL env (``LocoEnv``) gives float64 observations, the Gymnasium env
(``gymnasium.make("LocoMujoco", ...)``) float32 ones of the same layout. The network computes in float32 either
way, so both give the same action; it comes back in the observation's convention (float32 for float32
observations, float64 otherwise), shape ``(act_dim,)`` or ``(n, act_dim)`` for a batch, clipped to the action
box [-1, 1] (which the env applies anyway, so clipping changes no rollout).
"""

from __future__ import annotations

import difflib
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from baselines.common.policy import EvaluationModeMixin
from loco_mujoco.agent_datasets import pretrained_root
from loco_mujoco.evaluation.protocol import evaluation_task
from loco_mujoco.policy_export import WEIGHTS, ExportError, PolicyExport

_SEED_DIR = re.compile(r"seed(\d+)")


class PretrainedNotFoundError(ValueError):
    """No pretrained agent for the asked task, algorithm or seed; the message lists those that exist."""


@dataclass(frozen=True, order=True)
class PretrainedId:
    """One pretrained agent: the task its card names, its algorithm and its training seed."""

    task: str
    algorithm: str
    seed: int


def _root(root: str | Path | None) -> Path:
    return Path(root) if root is not None else pretrained_root()


def available(task: str | None = None, algo: str | None = None, root: str | Path | None = None) -> list[PretrainedId]:
    """Every pretrained agent (sorted), optionally only those of ``task`` and/or ``algo``.

    An agent is a folder ``<task>/<algo>/seed<N>`` holding a policy export under ``root`` (default:
    ``$LOCO_MUJOCO_PRETRAINED`` or the repository's ``pretrained/``).
    """
    found = []
    for weights in _root(root).glob(f"*/*/seed*/{WEIGHTS}"):
        folder = weights.parent
        match = _SEED_DIR.fullmatch(folder.name)
        if match:
            found.append(PretrainedId(folder.parent.parent.name, folder.parent.name, int(match.group(1))))
    return sorted(a for a in found if (task is None or a.task == task) and (algo is None or a.algorithm == algo))


def _not_found(what: str, asked: str, valid: list[str], context: str) -> PretrainedNotFoundError:
    close = difflib.get_close_matches(asked, valid, n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return PretrainedNotFoundError(f"no pretrained agent with {what} {asked!r}{context}{hint}; "
                                   f"valid: {', '.join(valid) or 'none'}")


def find(task: str, algo: str, seed: int = 0, root: str | Path | None = None) -> Path:
    """The export folder of ``(task, algo, seed)``; raises :class:`PretrainedNotFoundError` naming what exists."""
    for name, value in (("task", task), ("algo", algo)):
        if not isinstance(value, str):
            raise TypeError(f"{name} must be a str, got {type(value).__name__} {value!r}")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise TypeError(f"seed must be an int, got {type(seed).__name__} {seed!r}")
    base = _root(root)
    agents = available(root=base)
    if not agents:
        raise PretrainedNotFoundError(f"no pretrained agents under {base}; set LOCO_MUJOCO_PRETRAINED to the folder "
                                      "holding <task>/<algo>/seed<N>/ exports (the repository's pretrained/)")
    task = task.removesuffix(".real")  # the real dataset is the default: UnitreeH1.walk.real is UnitreeH1.walk
    algo = algo.lower()
    tasks = sorted({a.task for a in agents})
    if task not in tasks:
        raise _not_found("task", task, tasks, "")
    algos = sorted({a.algorithm for a in agents if a.task == task})
    if algo not in algos:
        raise _not_found("algorithm", algo, algos, f" for {task}")
    seeds = [a.seed for a in agents if a.task == task and a.algorithm == algo]
    if int(seed) not in seeds:
        raise PretrainedNotFoundError(f"no pretrained {algo} agent on {task} with seed {seed}; valid seeds: "
                                      f"{', '.join(map(str, seeds))}")
    return base / task / algo / f"seed{int(seed)}"


def load(task: str, algo: str, seed: int = 0, *, deterministic: bool = True, noise_seed: int | None = None,
         root: str | Path | None = None) -> PretrainedPolicy:
    """The pretrained ``algo`` agent trained on ``task`` with ``seed``, ready to act.

    Its actions are the deterministic ones (the mean, ``tanh`` of the mean for off-policy agents) unless
    ``deterministic=False``: then they are sampled with a generator seeded by ``noise_seed``. Raises
    :class:`PretrainedNotFoundError` listing the valid tasks, algorithms or seeds, and
    :class:`~loco_mujoco.policy_export.ExportError` for a broken export.
    """
    path = find(task, algo, seed, root)
    export = PolicyExport.load(path)
    card = export.card
    expected = {"task": path.parent.parent.name, "algorithm": path.parent.name, "seed": int(seed)}
    wrong = {k: card.get(k) for k, v in expected.items() if card.get(k) != v}
    if wrong:
        raise ExportError(f"{path}: its card says {wrong}, its folder {expected}; the export is misfiled")
    return PretrainedPolicy(export, deterministic, noise_seed)


class PretrainedPolicy(EvaluationModeMixin):
    """A pretrained agent's policy: ``draw_action(obs) -> action`` on its task's Mushroom-RL or Gymnasium env.

    ``card`` holds the task, env settings, algorithm, seed, training steps and its evaluation under the protocol
    (``card["evaluation"]["score"]``: normalised score with a 95% interval); ``config`` the resolved training
    configuration. ``evaluation_mode`` (as on the training-time policies) lets ``evaluate_agent`` run it.
    """

    def __init__(self, export: PolicyExport, deterministic: bool = True, noise_seed: int | None = None):
        self.export = export
        self.card: dict[str, Any] = export.card
        self.config: dict[str, Any] = export.config
        self.deterministic = bool(deterministic)
        self.rng = np.random.default_rng(noise_seed)

    def __repr__(self) -> str:
        return f"PretrainedPolicy({self.algorithm} on {self.task}, seed {self.seed}, {self.export.path})"

    @property
    def task(self) -> str:
        return self.export.task

    @property
    def algorithm(self) -> str:
        return str(self.card["algorithm"])

    @property
    def seed(self) -> int:
        return int(self.card["seed"])

    @property
    def obs_dim(self) -> int:
        return self.export.obs_dim

    @property
    def act_dim(self) -> int:
        return self.export.act_dim

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The env settings it was trained with, as recorded on its card."""
        return self.export.env_kwargs

    def env_spec(self) -> tuple[str, dict[str, Any]]:
        """``(task name, env settings)`` of the env it acts in: the real task with the settings it trained with
        (for an agent trained on ``<task>.perfect`` data, that data's settings such as PD control), as the
        evaluation protocol uses."""
        return evaluation_task(self.task, self.env_kwargs)

    def make_env(self, **overrides: Any) -> Any:
        """Its task's Mushroom-RL env (``LocoEnv``) with the settings it trained with; ``overrides`` replace some."""
        from loco_mujoco import LocoEnv

        name, kwargs = self.env_spec()
        return LocoEnv.make(name, **{**kwargs, **overrides})

    def make_gymnasium_env(self, **overrides: Any) -> Any:
        """Its task's Gymnasium env (``gymnasium.make("LocoMujoco", ...)``) with the settings it trained with."""
        import gymnasium

        import loco_mujoco  # noqa: F401  (registers the id)

        name, kwargs = self.env_spec()
        return gymnasium.make("LocoMujoco", env_name=name, **{**kwargs, **overrides})

    def draw_action(self, obs: np.ndarray) -> np.ndarray:
        """The action for one observation ``(obs_dim,)`` or a batch ``(n, obs_dim)``, in [-1, 1]; float32 for float32
        observations (Gymnasium), float64 otherwise (Mushroom-RL). Deterministic unless ``deterministic`` is
        False, then sampled from ``rng``."""
        obs = np.asarray(obs)
        if obs.ndim not in (1, 2) or obs.shape[-1] != self.obs_dim:
            raise ValueError(f"the {self.algorithm} agent on {self.task} takes observations of shape "
                             f"({self.obs_dim},) or (n, {self.obs_dim}), got {obs.shape}; make its env with "
                             f"make_env() or make_gymnasium_env() (settings {self.env_spec()[1]})")
        if not np.issubdtype(obs.dtype, np.number):
            raise ValueError(f"observations must be numeric, got dtype {obs.dtype}")
        action = self.export.draw_action(obs, None if self.deterministic else self.rng)
        np.clip(action, -1.0, 1.0, out=action)
        return action.astype(np.float32) if obs.dtype == np.float32 else action

    __call__ = draw_action
