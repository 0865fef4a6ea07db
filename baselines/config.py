"""Run configurations from YAML: shared defaults, the algorithm family's, the algorithm's, the embodiment's, then the
task's file.

Layout (``configs/`` at the repository root)::

    configs/defaults.yaml            env / train sections shared by every run; ``families: {adversarial: {train,
                                     agent}, offline: {...}}`` per algorithm family; ``algorithms: {vail: {...}}``
                                     agent defaults per algorithm; ``embodiments: {Atlas: {env: {...}}}``
                                     what every task of an embodiment (environment class) shares
    configs/<algorithm>/<task>.yaml  what this task changes for this algorithm (env / train / agent sections);
                                     ``<task>.<dataset type>`` uses the base task's file unless it has its own

Sections are merged key by key in that order, then command-line overrides; every value remembers the file
(and section path) it came from (:attr:`RunConfig.provenance`, ``launch.py --print-config``). Every key is
checked: ``env`` keys against the environment's constructor, ``agent`` keys against the algorithm's config
dataclass, ``train`` keys against :class:`TrainConfig`. Anything unknown or malformed raises
:class:`ConfigError` naming the file and the key.
"""

from __future__ import annotations

import dataclasses
import difflib
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from baselines.common.agent_config import convert_config_value
from loco_mujoco import strict_yaml

CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"
SECTIONS = ("env", "train", "agent")
# Environment constructor arguments a config may not set: the task name and the seed come from the launcher.
_ENV_RESERVED = {"self", "task", "mode", "dataset_type", "seed"}
EXPERT_ACTIONS = ("dataset", "inverse_dynamics", "auto")


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
    # "dataset", "inverse_dynamics" (GAIL on data without actions) or "auto" (the dataset's where it has them)
    expert_actions: str = "dataset"
    n_steps_per_fit: int = 1000  # on-policy: environment steps between fits; offline: 1
    # on-policy: environments stepped together, one batched policy forward per control step, each contributing
    # n_steps_per_fit / n_envs consecutive steps to a fit (baselines/common/batched.py); 1: Core with one env
    n_envs: int = 1
    env_threads: int = 0  # with n_envs > 1: threads stepping the environments (0: one per core, at most 2)
    # training steps between policy snapshots (``<run>/snapshots/<steps>/``, policy-only exports written with the
    # checkpoint of the first epoch at or past each multiple; the agents of preference datasets); 0: none
    snapshot_every: int = 0

    def validate(self) -> None:
        for name in ("n_steps", "epoch_steps", "n_eval_episodes", "n_steps_per_fit", "n_envs"):
            if getattr(self, name) < 1:
                raise ConfigError(f"train.{name} must be >= 1, got {getattr(self, name)}")
        if self.snapshot_every < 0:
            raise ConfigError(f"train.snapshot_every must be >= 0 (0: no snapshots), got {self.snapshot_every}")
        if self.env_threads < 0:
            raise ConfigError(f"train.env_threads must be >= 0 (0: one per core, at most 2), got {self.env_threads}")
        if self.n_steps_per_fit % self.n_envs:
            valid = [k for k in range(1, min(self.n_steps_per_fit, 16) + 1) if self.n_steps_per_fit % k == 0]
            raise ConfigError(f"train.n_steps_per_fit ({self.n_steps_per_fit}) must be a multiple of train.n_envs "
                              f"({self.n_envs}): every environment contributes as many steps to a fit; n_envs that "
                              f"divide it: {', '.join(map(str, valid))}{', ...' if self.n_steps_per_fit > 16 else ''}")
        if self.n_eval_episodes_stochastic < 0:
            raise ConfigError(f"train.n_eval_episodes_stochastic must be >= 0, got {self.n_eval_episodes_stochastic}")
        if self.epoch_steps % self.n_steps_per_fit:
            raise ConfigError(f"train.epoch_steps ({self.epoch_steps}) must be a multiple of train.n_steps_per_fit "
                              f"({self.n_steps_per_fit}) so that every epoch ends on a fit")
        if self.expert_actions not in EXPERT_ACTIONS:
            raise ConfigError(f"train.expert_actions must be one of {', '.join(EXPERT_ACTIONS)}, "
                              f"got {self.expert_actions!r}")


@dataclass
class RunConfig:
    """A resolved run: task, algorithm, seed and the three validated sections."""

    task: str
    algorithm: str
    seed: int
    env: dict[str, Any]
    train: TrainConfig
    agent: Any  # the algorithm's config dataclass (AdversarialConfig, BCConfig ...)
    sources: list[str]  # the files merged, in order
    init_from: dict[str, Any] | None = None  # warm start: the checkpoint, its steps and its run config
    provenance: dict[str, str] = dataclasses.field(default_factory=dict)  # "section.key" -> where it was set

    def to_dict(self) -> dict[str, Any]:
        out = {"task": self.task, "algorithm": self.algorithm, "seed": self.seed, "env": dict(self.env),
               "train": dataclasses.asdict(self.train), "agent": self.agent.to_dict(), "sources": list(self.sources)}
        if self.init_from is not None:
            out["init_from"] = self.init_from
        return out


def flat_config(config: dict[str, Any], leave_out: tuple[str, ...] = ()) -> dict[str, Any]:
    """``RunConfig.to_dict()`` as ``{"section.key": value}`` for the sections, other keys as they are, less the
    keys named in ``leave_out``: the form in which two runs' configurations are compared."""
    flat = {}
    for key, value in config.items():
        if key in SECTIONS and isinstance(value, dict):
            flat.update({f"{key}.{k}": v for k, v in value.items()})
        else:
            flat[key] = value
    return {k: v for k, v in flat.items() if k not in leave_out}


def config_path(task: str, algorithm: str, config_dir: Path = CONFIG_DIR) -> Path:
    """The task file of ``algorithm`` on ``task``: its own, or for a dataset type its base task's."""
    own = Path(config_dir) / algorithm / f"{task}.yaml"
    parts = task.split(".")
    if own.exists() or parts[-1] not in ("real", "perfect", "preference"):
        return own
    return Path(config_dir) / algorithm / f"{'.'.join(parts[:-1])}.yaml"


def _embodiment_layer(embodiments: dict[str, Any], env: str, defaults_file: Path) -> dict[str, Any]:
    """The ``embodiments: <Env>:`` section of the defaults for the environment class ``env`` ({} if it has none),
    after checking that every embodiment named there exists and sets only known sections."""
    from loco_mujoco.core.task_names import environment_class

    _require_mapping(embodiments, defaults_file, "embodiments")
    for name, layer in embodiments.items():
        try:
            environment_class(name)
        except ValueError as err:
            raise ConfigError(f"{defaults_file}: embodiments.{name}: {err}") from None
        _require_sections(layer or {}, defaults_file, f"embodiments.{name}")
    return embodiments.get(env) or {}


def load_run_config(task: str, algorithm: str, seed: int = 0, config_dir: str | Path = CONFIG_DIR,
                    overrides: dict[str, dict[str, Any]] | None = None) -> RunConfig:
    """The merged, validated configuration of ``algorithm`` on ``task`` (``overrides`` last, same sections)."""
    from baselines import ALGORITHMS
    from loco_mujoco.core.task_names import environment_class, parse_task_name

    if algorithm not in ALGORITHMS:
        raise ConfigError(f"unknown algorithm {algorithm!r}; valid: {', '.join(ALGORITHMS)}")
    family = ALGORITHMS[algorithm].family
    parsed = parse_task_name(task)  # raises with suggestions
    config_dir = Path(config_dir)
    defaults_file = config_dir / "defaults.yaml"
    defaults = read_yaml(defaults_file, allowed=(*SECTIONS, "families", "algorithms", "embodiments"))
    families = defaults.pop("families", {}) or {}
    _require_mapping(families, defaults_file, "families")
    if family not in families:
        raise ConfigError(f"{defaults_file}: no 'families: {family}:' section for {algorithm}; "
                          f"families there: {', '.join(families) or 'none'}")
    family_config = families[family] or {}
    _require_sections(family_config, defaults_file, f"families.{family}")
    algorithm_defaults = defaults.pop("algorithms", {}) or {}
    _require_mapping(algorithm_defaults, defaults_file, "algorithms")
    unknown = sorted(set(algorithm_defaults) - set(ALGORITHMS))
    if unknown:
        raise ConfigError(f"{defaults_file}: unknown algorithms {unknown} under 'algorithms'; "
                          f"valid: {', '.join(ALGORITHMS)}")
    embodiment_config = _embodiment_layer(defaults.pop("embodiments", {}) or {}, parsed.env, defaults_file)
    task_file = config_path(task, algorithm, config_dir)
    if not task_file.exists():
        raise ConfigError(f"no config for {algorithm} on {task}: {task_file} does not exist. Every task has one "
                          f"file per algorithm under {config_dir}/<algorithm>/; see "
                          f"{', '.join(sorted(p.stem for p in (config_dir / algorithm).glob('*.yaml'))[:5])}, ...")
    task_config = read_yaml(task_file, allowed=SECTIONS)

    merged: dict[str, dict[str, Any]] = {s: {} for s in SECTIONS}
    provenance: dict[str, str] = {}
    shown_defaults, shown_task = shown_path(defaults_file), shown_path(task_file)
    layers = [(shown_defaults, defaults), (f"{shown_defaults} [families.{family}]", family_config),
              (f"{shown_defaults} [algorithms.{algorithm}]", {"agent": algorithm_defaults.get(algorithm) or {}}),
              (f"{shown_defaults} [embodiments.{parsed.env}]", embodiment_config), (shown_task, task_config),
              ("command line (--set/--steps/--threads)", overrides or {})]
    for source, layer in layers:
        for section in SECTIONS:
            values = layer.get(section) or {}
            _require_mapping(values, source, section)
            merged[section].update(values)
            provenance.update({f"{section}.{key}": source for key in values})

    agent_class = ALGORITHMS[algorithm].config_class
    try:
        agent = agent_class.from_dict(merged["agent"])
    except ValueError as err:
        raise ConfigError(f"agent section ({task_file} on {defaults_file}): {err}") from None
    train = _dataclass_from_dict(TrainConfig, merged["train"], "train", task_file)
    try:
        if train.n_envs != 1 and family != "adversarial":
            raise ConfigError(f"train.n_envs = {train.n_envs}: several environments per process are for the "
                              f"on-policy algorithms (gail, vail, gaifo); {algorithm} ({family}) takes n_envs: 1")
        train.validate()
    except ConfigError as err:
        raise ConfigError(f"train section ({shown_task} on {shown_defaults}): {err}") from None
    env_class = environment_class(parsed.env)
    _check_env_keys(env_class, merged["env"], task_file, provenance)
    for section, values in (("agent", agent.to_dict()), ("train", dataclasses.asdict(train))):
        for key in values:
            provenance.setdefault(f"{section}.{key}", f"{type(agent if section == 'agent' else train).__name__} "
                                                     "default (baselines)")
    return RunConfig(task=task, algorithm=algorithm, seed=int(seed), env=merged["env"], train=train, agent=agent,
                     sources=[str(defaults_file), str(task_file)], provenance=provenance)


def shown_path(path: Path) -> str:
    """``path`` relative to the working directory where it lies below it (shorter in printed provenance)."""
    try:
        return Path(path).resolve().relative_to(Path.cwd().resolve()).as_posix()
    except ValueError:
        return str(path)


def format_config(run: RunConfig) -> str:
    """The resolved configuration as YAML, each value followed by where it came from."""
    lines = [f"# {run.algorithm} on {run.task}, seed {run.seed}", ""]
    sections = {"env": run.env, "train": dataclasses.asdict(run.train), "agent": run.agent.to_dict()}
    for section, values in sections.items():
        lines.append(f"{section}:")
        for key, value in values.items():
            text = yaml.safe_dump({key: value}, default_flow_style=True, width=1000).strip()[1:-1]
            lines.append(f"  {text:<44} # {run.provenance.get(f'{section}.{key}', '?')}")
    return "\n".join(lines)


def parse_overrides(items: list[str]) -> dict[str, dict[str, Any]]:
    """``["train.n_steps_per_fit=5000", ...]`` as override sections; values are read as YAML (numbers, lists)."""
    overrides: dict[str, dict[str, Any]] = {s: {} for s in SECTIONS}
    for item in items:
        name, sep, text = item.partition("=")
        section, dot, key = name.strip().partition(".")
        if not sep or not dot or not key:
            raise ConfigError(f"override {item!r} must look like SECTION.KEY=VALUE, e.g. agent.max_kl=0.01")
        if section not in SECTIONS:
            raise ConfigError(f"override {item!r}: unknown section {section!r}; valid: {', '.join(SECTIONS)}")
        try:
            overrides[section][key] = strict_yaml.load(text)
        except yaml.YAMLError as err:
            raise ConfigError(f"override {item!r}: the value is not valid YAML ({err})") from None
    return overrides


def read_yaml(path: Path, allowed: tuple[str, ...]) -> dict[str, Any]:
    """A YAML mapping with only ``allowed`` top-level keys (an empty file is an empty mapping)."""
    try:
        text = Path(path).read_text()
    except FileNotFoundError:
        raise ConfigError(f"config file {path} does not exist") from None
    except (UnicodeDecodeError, OSError) as err:
        raise ConfigError(f"config file {path} cannot be read as text ({type(err).__name__}: {err})") from None
    try:
        data = strict_yaml.load(text)
    except strict_yaml.DuplicateKeyError as err:
        raise ConfigError(f"{path}: {err}") from None
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


def _require_sections(value: Any, source: Any, where: str) -> None:
    """A mapping of config sections (env / train / agent) and nothing else."""
    _require_mapping(value, source, where)
    unknown = sorted(set(value) - set(SECTIONS))
    if unknown:
        raise ConfigError(f"{source}: unknown sections {unknown} under {where}; valid: {', '.join(SECTIONS)}")


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
    """Keyword arguments a config may give ``env_class`` (its constructors' named parameters, less the task name
    and seed, which come from the launcher)."""
    from loco_mujoco.core.parameters import env_parameter_names

    return env_parameter_names(env_class) - _ENV_RESERVED


def _check_env_keys(env_class: type, values: dict[str, Any], source: Path, provenance: dict[str, str]) -> None:
    """Names against ``env_class``'s parameters, values against their declared types and ranges."""
    from loco_mujoco.core.parameters import ENV_PARAMETERS, ParameterError

    valid = env_parameters(env_class)
    unknown = sorted(set(values) - valid)
    if unknown:
        raise ConfigError(f"{source}: unknown env keys {unknown} for {env_class.__name__}"
                          f"{_suggest(unknown[0], valid)}; valid: {', '.join(sorted(valid))}")
    for key, value in values.items():
        if key in ENV_PARAMETERS:
            try:
                ENV_PARAMETERS[key].check(f"env.{key}", value)
            except ParameterError as err:
                raise ConfigError(f"{provenance.get(f'env.{key}', source)}: {err}") from None


def _suggest(key: str, valid: Any) -> str:
    close = difflib.get_close_matches(key, list(valid), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""
