"""Task names ``<Env>.<task>[.<mode>][.<dataset_type>]``: parsing, validation and listing.

Environment classes register themselves here when they are defined (see ``LocoEnv.__init_subclass__``).
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from loco_mujoco.core.loco_env import LocoEnv

DATASET_TYPES: tuple[str, ...] = ("real", "perfect", "preference")
DEFAULT_DATASET_TYPE = "real"

_ENVIRONMENTS: dict[str, type[LocoEnv]] = {}


@dataclass(frozen=True)
class TaskName:
    """A parsed, validated task name."""

    env: str
    task: str
    mode: str | None
    dataset_type: str

    def __str__(self) -> str:
        parts = [self.env, self.task] + ([self.mode] if self.mode else []) + [self.dataset_type]
        return ".".join(parts)


def register_environment(cls: type[LocoEnv]) -> None:
    """Make ``cls`` reachable by its class name in task names."""
    _ENVIRONMENTS[cls.__name__] = cls


def environment_class(name: str) -> type[LocoEnv]:
    """The environment class registered as ``name``."""
    if name not in _ENVIRONMENTS:
        raise ValueError(_unknown_message(f"environment '{name}'", name, sorted(_ENVIRONMENTS)))
    return _ENVIRONMENTS[name]


def list_tasks(with_data: bool = False) -> list[str]:
    """Every valid task name: each env's tasks and modes, bare and with each dataset type.

    ``with_data=True`` keeps only the names whose dataset exists (a recipe for real data, a shipped agent
    dataset for ``perfect`` and ``preference``): the names ``LocoEnv.make`` builds without an error.
    """
    names = []
    for env_name in sorted(_ENVIRONMENTS):
        cls = _ENVIRONMENTS[env_name]
        for task in cls.TASKS:
            for mode in cls.MODES or (None,):
                base = ".".join([env_name, task] + ([mode] if mode else []))
                types = cls.dataset_types_with_data(task, mode) if with_data else cls.DATASET_TYPES
                if not with_data or DEFAULT_DATASET_TYPE in types:
                    names.append(base)
                names.extend(f"{base}.{dt}" for dt in cls.DATASET_TYPES if dt in types)
    return names


def parse_task_name(name: str) -> TaskName:
    """Split and validate a task name; raise ValueError naming the valid choices and the closest match."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"task name must be a non-empty string like 'UnitreeH1.walk', got {name!r}")
    parts = name.split(".")
    env_name = parts[0]
    if env_name not in _ENVIRONMENTS:
        raise ValueError(_unknown_message(f"environment '{env_name}' in task '{name}'", name, list_tasks(),
                                          valid_hint=f"Valid environments: {', '.join(sorted(_ENVIRONMENTS))}."))
    cls = _ENVIRONMENTS[env_name]
    rest = parts[1:]
    task = rest.pop(0) if rest else None
    mode = dataset_type = None
    if rest and rest[-1] in cls.DATASET_TYPES:
        dataset_type = rest.pop()
    if rest and cls.MODES:
        mode = rest.pop(0)
    valid_for_env = [t for t in list_tasks() if t.split(".")[0] == env_name]
    hint = _grammar_hint(cls)
    if task not in cls.TASKS or rest or (cls.MODES and mode not in cls.MODES):
        raise ValueError(_unknown_message(f"task '{name}'", name, valid_for_env, valid_hint=hint))
    if cls.MODES and mode is None:
        raise ValueError(f"task '{name}' needs a mode. {hint}")
    return TaskName(env_name, task, mode, dataset_type or DEFAULT_DATASET_TYPE)


def _grammar_hint(cls: type[LocoEnv]) -> str:
    hint = f"Valid tasks for {cls.__name__}: {', '.join(cls.TASKS)}"
    if cls.MODES:
        hint += f"; modes: {', '.join(cls.MODES)}"
    return hint + f"; optional dataset type: {', '.join(cls.DATASET_TYPES)} (default {DEFAULT_DATASET_TYPE})."


def _unknown_message(what: str, given: str, valid: list[str], valid_hint: str | None = None) -> str:
    close = difflib.get_close_matches(given, valid, n=3, cutoff=0.5)
    msg = f"Unknown {what}."
    if close:
        msg += " Did you mean " + " or ".join(f"'{c}'" for c in close) + "?"
    msg += " " + (valid_hint or f"Valid choices: {', '.join(valid)}.")
    return msg
