"""Run configurations from YAML: shared defaults, then the algorithm's defaults, then the task's file.

Layout (``configs/`` at the repository root)::

    configs/defaults.yaml            env / train / agent sections shared by every run, plus
                                     ``algorithms: {gail: {...}, vail: {...}, gaifo: {...}}`` agent defaults
    configs/<algorithm>/<task>.yaml  what this task changes for this algorithm (env / train / agent sections)

Sections are merged key by key in that order. Every key is checked: ``env`` keys against the environment's
constructor, ``agent`` keys against the algorithm's config dataclass, ``train`` keys against
:class:`TrainConfig`. Anything unknown or malformed raises :class:`ConfigError` naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import difflib
import inspect
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from baselines.common.adversarial import AdversarialConfig, convert_config_value

CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"
SECTIONS = ("env", "train", "agent")
# Environment constructor arguments a config may not set: the task name and the seed come from the launcher.
_ENV_RESERVED = {"self", "task", "mode", "dataset_type", "seed"}


class ConfigError(ValueError):
    """A configuration file or value is malformed; the message names the file, the key and what is valid."""


@dataclass
class TrainConfig:
    """How long to train and how often to evaluate and checkpoint (one epoch = one ``Core.learn`` call)."""

    n_steps: int = 10_000_000  # environment steps in total
    epoch_steps: int = 100_000  # steps between evaluations and checkpoints; a multiple of n_steps_per_fit
    n_eval_episodes: int = 10  # deterministic evaluation episodes per epoch
    n_eval_episodes_stochastic: int = 0  # additional stochastic evaluation episodes per epoch (0: none)
    eval_seed: int = 12345  # seed of the evaluation environment (the same start states at every epoch)
    expert_actions: str = "dataset"  # "dataset" or "inverse_dynamics" (GAIL on data without actions)

    def validate(self, n_steps_per_fit: int) -> None:
        for name in ("n_steps", "epoch_steps", "n_eval_episodes"):
            if getattr(self, name) < 1:
                raise ConfigError(f"train.{name} must be >= 1, got {getattr(self, name)}")
        if self.n_eval_episodes_stochastic < 0:
            raise ConfigError(f"train.n_eval_episodes_stochastic must be >= 0, got {self.n_eval_episodes_stochastic}")
        if self.epoch_steps % n_steps_per_fit:
            raise ConfigError(f"train.epoch_steps ({self.epoch_steps}) must be a multiple of agent.n_steps_per_fit "
                              f"({n_steps_per_fit}) so that every epoch ends on a fit")
        if self.expert_actions not in ("dataset", "inverse_dynamics"):
            raise ConfigError(f"train.expert_actions must be 'dataset' or 'inverse_dynamics', "
                              f"got {self.expert_actions!r}")


@dataclass
class RunConfig:
    """A resolved run: task, algorithm, seed and the three validated sections."""

    task: str
    algorithm: str
    seed: int
    env: dict[str, Any]
    train: TrainConfig
    agent: AdversarialConfig
    sources: list[str]  # the files merged, in order
    init_from: dict[str, Any] | None = None  # warm start: the checkpoint, its steps and its run config

    def to_dict(self) -> dict[str, Any]:
        out = {"task": self.task, "algorithm": self.algorithm, "seed": self.seed, "env": dict(self.env),
               "train": dataclasses.asdict(self.train), "agent": self.agent.to_dict(), "sources": list(self.sources)}
        if self.init_from is not None:
            out["init_from"] = self.init_from
        return out


def config_path(task: str, algorithm: str, config_dir: Path = CONFIG_DIR) -> Path:
    return Path(config_dir) / algorithm / f"{task}.yaml"


def load_run_config(task: str, algorithm: str, seed: int = 0, config_dir: str | Path = CONFIG_DIR,
                    overrides: dict[str, dict[str, Any]] | None = None) -> RunConfig:
    """The merged, validated configuration of ``algorithm`` on ``task`` (``overrides`` last, same sections)."""
    from baselines import ALGORITHMS
    from loco_mujoco.core.task_names import environment_class, parse_task_name

    if algorithm not in ALGORITHMS:
        raise ConfigError(f"unknown algorithm {algorithm!r}; valid: {', '.join(ALGORITHMS)}")
    parsed = parse_task_name(task)  # raises with suggestions
    config_dir = Path(config_dir)
    defaults_file = config_dir / "defaults.yaml"
    defaults = read_yaml(defaults_file, allowed=(*SECTIONS, "algorithms"))
    algorithm_defaults = defaults.pop("algorithms", {}) or {}
    _require_mapping(algorithm_defaults, defaults_file, "algorithms")
    unknown = sorted(set(algorithm_defaults) - set(ALGORITHMS))
    if unknown:
        raise ConfigError(f"{defaults_file}: unknown algorithms {unknown} under 'algorithms'; "
                          f"valid: {', '.join(ALGORITHMS)}")
    task_file = config_path(task, algorithm, config_dir)
    if not task_file.exists():
        raise ConfigError(f"no config for {algorithm} on {task}: {task_file} does not exist. Every task has one "
                          f"file per algorithm under {config_dir}/<algorithm>/; see "
                          f"{', '.join(sorted(p.stem for p in (config_dir / algorithm).glob('*.yaml'))[:5])}, ...")
    task_config = read_yaml(task_file, allowed=SECTIONS)

    merged: dict[str, dict[str, Any]] = {s: {} for s in SECTIONS}
    layers = [(defaults_file, defaults), (defaults_file, {"agent": algorithm_defaults.get(algorithm) or {}}),
              (task_file, task_config), ("overrides", overrides or {})]
    for source, layer in layers:
        for section in SECTIONS:
            values = layer.get(section) or {}
            _require_mapping(values, source, section)
            merged[section].update(values)

    agent_class = ALGORITHMS[algorithm].config_class
    try:
        agent = agent_class.from_dict(merged["agent"])
    except ValueError as err:
        raise ConfigError(f"agent section ({task_file} on {defaults_file}): {err}") from None
    train = _dataclass_from_dict(TrainConfig, merged["train"], "train", task_file)
    train.validate(agent.n_steps_per_fit)
    env_class = environment_class(parsed.env)
    _check_env_keys(env_class, merged["env"], task_file)
    return RunConfig(task=task, algorithm=algorithm, seed=int(seed), env=merged["env"], train=train, agent=agent,
                     sources=[str(defaults_file), str(task_file)])


def parse_overrides(items: list[str]) -> dict[str, dict[str, Any]]:
    """``["agent.n_steps_per_fit=5000", ...]`` as override sections; values are read as YAML (numbers, lists)."""
    overrides: dict[str, dict[str, Any]] = {s: {} for s in SECTIONS}
    for item in items:
        name, sep, text = item.partition("=")
        section, dot, key = name.strip().partition(".")
        if not sep or not dot or not key:
            raise ConfigError(f"override {item!r} must look like SECTION.KEY=VALUE, e.g. agent.max_kl=0.01")
        if section not in SECTIONS:
            raise ConfigError(f"override {item!r}: unknown section {section!r}; valid: {', '.join(SECTIONS)}")
        try:
            overrides[section][key] = yaml.safe_load(text)
        except yaml.YAMLError as err:
            raise ConfigError(f"override {item!r}: the value is not valid YAML ({err})") from None
    return overrides


def read_yaml(path: Path, allowed: tuple[str, ...]) -> dict[str, Any]:
    """A YAML mapping with only ``allowed`` top-level keys (an empty file is an empty mapping)."""
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        raise ConfigError(f"config file {path} does not exist") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise ConfigError(f"{path} is not valid YAML: {err}") from None
    if data is None:
        return {}
    _require_mapping(data, path, "the top level")
    unknown = sorted(set(data) - set(allowed))
    if unknown:
        raise ConfigError(f"{path}: unknown sections {unknown}; valid: {', '.join(allowed)}")
    return data


def _require_mapping(value: Any, source: Any, where: str) -> None:
    if not isinstance(value, dict):
        raise ConfigError(f"{source}: {where} must be a mapping of key: value, got {type(value).__name__} {value!r}")


def _dataclass_from_dict(cls: type, values: dict[str, Any], section: str, source: Path) -> Any:
    hints = typing.get_type_hints(cls)
    unknown = sorted(set(values) - set(hints))
    if unknown:
        raise ConfigError(f"{source}: unknown {section} keys {unknown}{_suggest(unknown[0], hints)}; "
                          f"valid: {', '.join(sorted(hints))}")
    try:
        converted = {key: convert_config_value(section, key, hints[key], value) for key, value in values.items()}
    except ValueError as err:
        raise ConfigError(f"{source}: {err}") from None
    return cls(**converted)


def env_parameters(env_class: type) -> set[str]:
    """Keyword arguments a config may give ``env_class``: the named parameters of each ``__init__`` from the
    class up to ``LocoEnv`` (whose ``**viewer_params`` go to rendering, not to the task)."""
    from loco_mujoco.core.loco_env import LocoEnv

    names: set[str] = set()
    for klass in env_class.__mro__:
        init = klass.__dict__.get("__init__")
        if init is not None:
            params = inspect.signature(init).parameters.values()
            names |= {p.name for p in params if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}
        if klass is LocoEnv:
            break
    return names - _ENV_RESERVED


def _check_env_keys(env_class: type, values: dict[str, Any], source: Path) -> None:
    valid = env_parameters(env_class)
    unknown = sorted(set(values) - valid)
    if unknown:
        raise ConfigError(f"{source}: unknown env keys {unknown} for {env_class.__name__}"
                          f"{_suggest(unknown[0], valid)}; valid: {', '.join(sorted(valid))}")


def _suggest(key: str, valid: Any) -> str:
    close = difflib.get_close_matches(key, list(valid), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
