"""What a sweep asks for: tasks x algorithms x seeds and shared settings, from the command line or a YAML file.

A sweep file holds the command line's keys (``tasks``, ``algos``, ``seeds``, ``steps``, ``out``, ``set``,
``cpus_per_trial``, ``threads``) and two that only a file gives: ``seeds_by_task`` (other seeds for some tasks, e.g.
``{UnitreeH1.walk: [0, 1, 2]}``) and ``exclude`` (``TASK/ALGO`` pairs left out of the product). A value given on the
command line wins over the file's (``--seeds`` replaces ``seeds_by_task`` too), and ``--set`` items are applied
after the file's ``set``. Everything is checked before any trial starts, and every error names the file, the key
and what is valid. ``sweeps/table.yaml`` is such a file: the reported table's grid.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from baselines.config import SECTIONS, ConfigError, parse_overrides

KEYS = ("tasks", "algos", "seeds", "seeds_by_task", "exclude", "steps", "out", "set", "cpus_per_trial", "threads")
DEFAULT_OUT = "runs"


class SweepSpecError(ValueError):
    """A sweep file or option is malformed; the message names it and what is valid."""


@dataclass
class SweepSpec:
    """A validated sweep: one trial per (task, algorithm, seed) of :meth:`runs`, each in
    ``<out>/<task>/<algo>/seed<N>``."""

    tasks: list[str]
    algos: list[str]
    seeds: list[int]
    seeds_by_task: dict[str, list[int]] = field(default_factory=dict)  # replaces ``seeds`` for these tasks
    exclude: set[tuple[str, str]] = field(default_factory=set)  # (task, algo) pairs not run
    steps: int | None = None  # None: each configuration's train.n_steps
    out: Path = Path(DEFAULT_OUT)
    overrides: dict[str, dict[str, Any]] = field(default_factory=dict)  # --set, by section
    cpus_per_trial: float = 1.0
    threads: int = 1  # torch threads per trial

    def seeds_of(self, task: str) -> list[int]:
        """The seeds ``task`` runs with."""
        return self.seeds_by_task.get(task, self.seeds)

    def runs(self) -> list[tuple[str, str, int]]:
        """Every (task, algorithm, seed) of the sweep, task by task, in the order the keys list them."""
        return [(task, algo, seed) for task in self.tasks for algo in self.algos
                if (task, algo) not in self.exclude for seed in self.seeds_of(task)]


def read_sweep_file(path: str | Path) -> dict[str, Any]:
    """The keys of a sweep file, checked for names and types (not yet merged with the command line)."""
    path = Path(path)
    try:
        data = yaml.safe_load(path.read_text())
    except OSError as err:
        raise SweepSpecError(f"cannot read sweep file {path}: {err.strerror}") from None
    except yaml.YAMLError as err:
        raise SweepSpecError(f"{path} is not valid YAML: {err}") from None
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise SweepSpecError(f"{path} must be a mapping of {', '.join(KEYS)}; got a {type(data).__name__}")
    values: dict[str, Any] = {}
    for key, value in data.items():
        name = str(key).replace("-", "_")
        if name not in KEYS:
            close = difflib.get_close_matches(name, KEYS, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SweepSpecError(f"{path}: unknown key {key!r}{hint}; valid keys: {', '.join(KEYS)}")
        values[name] = _check_value(name, value, f"{path}: {key}")
    return values


def _check_value(name: str, value: Any, where: str) -> Any:
    """``value`` of key ``name`` in its normal form (lists for tasks, algos, seeds); raises naming ``where``."""
    if name == "seeds_by_task":
        if not isinstance(value, dict) or not value:
            raise SweepSpecError(f"{where} must map task names to lists of seeds, e.g. {{UnitreeH1.walk: [0, 1, 2]}}; "
                                 f"got {value!r}")
        return {str(task): _check_value("seeds", seeds, f"{where}: {task}") for task, seeds in value.items()}
    if name == "exclude":
        items = value if isinstance(value, list) else [value]
        bad = [v for v in items if not isinstance(v, str) or v.count("/") != 1 or "" in v.split("/")]
        if bad or not items:
            raise SweepSpecError(f"{where} must be a list of TASK/ALGO pairs, e.g. ['HumanoidMuscle.walk/gail']; "
                                 f"got {value!r}")
        return [tuple(v.split("/")) for v in dict.fromkeys(items)]
    if name in ("tasks", "algos", "seeds"):
        items = value if isinstance(value, list) else [value]
        kind = int if name == "seeds" else str
        bad = [v for v in items if not isinstance(v, kind) or isinstance(v, bool)]
        if bad or not items:
            what = "integers" if kind is int else "names"
            raise SweepSpecError(f"{where} must be a non-empty list of {what}, e.g. "
                                 f"{[0, 1] if kind is int else ['UnitreeH1.walk']}; got {value!r}")
        return list(dict.fromkeys(items))  # duplicates would run one folder twice
    if name in ("steps", "threads"):
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise SweepSpecError(f"{where} must be a whole number of at least 1, got {value!r}")
        return value
    if name == "cpus_per_trial":
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0:
            raise SweepSpecError(f"{where} must be a positive number of CPUs (fractions allowed), got {value!r}")
        return float(value)
    if name == "out":
        if not isinstance(value, str) or not value:
            raise SweepSpecError(f"{where} must be a folder path, got {value!r}")
        return value
    return _check_set(value, where)


def _check_set(value: Any, where: str) -> dict[str, dict[str, Any]]:
    """``set`` as override sections: a list of ``SECTION.KEY=VALUE`` strings, or ``{section: {key: value}}``."""
    try:
        if isinstance(value, list) and all(isinstance(v, str) for v in value):
            return parse_overrides(value)
        if isinstance(value, dict):
            unknown = [s for s in value if s not in SECTIONS]
            if unknown:
                raise ConfigError(f"unknown sections {unknown}; valid: {', '.join(SECTIONS)}")
            bad = [s for s, v in value.items() if not isinstance(v, dict)]
            if bad:
                raise ConfigError(f"section {bad[0]!r} must be a mapping of keys to values")
            return {section: dict(value.get(section) or {}) for section in SECTIONS}
    except ConfigError as err:
        raise SweepSpecError(f"{where}: {err}") from None
    raise SweepSpecError(f"{where} must be a list of SECTION.KEY=VALUE strings (e.g. ['agent.max_kl=0.01']) or a "
                         f"mapping such as {{agent: {{max_kl: 0.01}}}}; got {value!r}")


def build_spec(file_values: dict[str, Any], cli_values: dict[str, Any]) -> SweepSpec:
    """The sweep from a file's keys and the command line's (``None`` = not given; ``set`` a list of strings)."""
    from baselines import ALGORITHMS

    values = dict(file_values)
    for name, value in cli_values.items():
        if name == "set" or value is None:
            continue
        values[name] = _check_value(name, value, f"--{name.replace('_', '-')}")
    missing = [name for name in ("tasks", "algos") if name not in values]
    if missing:
        raise SweepSpecError(f"the sweep needs {' and '.join(missing)}: give --{' --'.join(missing)} or put them "
                             f"in the --config file")
    unknown = [a for a in values["algos"] if a not in ALGORITHMS]
    if unknown:
        raise SweepSpecError(f"unknown algorithms {unknown}; valid: {', '.join(sorted(ALGORITHMS))}")
    # checked against the file's own tasks and algorithms (a typo), then applied to those the sweep runs
    own_tasks, own_algos = file_values.get("tasks", values["tasks"]), file_values.get("algos", values["algos"])
    seeds_by_task = {} if cli_values.get("seeds") is not None else values.get("seeds_by_task", {})
    _require_in_sweep("seeds_by_task", [(task,) for task in seeds_by_task], (own_tasks,))
    exclude = values.get("exclude", [])
    _require_in_sweep("exclude", exclude, (own_tasks, own_algos))
    overrides = {section: dict(v) for section, v in values.get("set", {}).items()}
    try:
        for section, v in parse_overrides(cli_values.get("set") or []).items():
            overrides.setdefault(section, {}).update(v)
    except ConfigError as err:
        raise SweepSpecError(f"--set: {err}") from None
    return SweepSpec(tasks=values["tasks"], algos=values["algos"], seeds=values.get("seeds", [0]),
                     seeds_by_task=seeds_by_task, exclude=set(exclude), steps=values.get("steps"),
                     out=Path(values.get("out", DEFAULT_OUT)), overrides=overrides,
                     cpus_per_trial=values.get("cpus_per_trial", 1.0), threads=values.get("threads", 1))


def _require_in_sweep(key: str, entries: list[tuple[str, ...]], allowed: tuple[list[str], ...]) -> None:
    """Raise naming ``key``'s first entry whose task (and algorithm) the sweep does not have: a typo there would
    otherwise run the plain product silently."""
    for entry in entries:
        for value, valid in zip(entry, allowed, strict=True):
            if value not in valid:
                raise SweepSpecError(f"{key}: {'/'.join(entry)!r} names {value!r}, which is not in the sweep; "
                                     f"valid: {', '.join(valid)}")
