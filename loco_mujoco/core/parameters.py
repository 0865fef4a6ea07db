"""The one declaration of every environment parameter's type and range.

``LocoEnv`` (and so ``LocoEnv.make``, the Gymnasium wrapper and Mushroom-RL's ``Environment.make``) checks its
arguments against it before any model is compiled, and the YAML configs and the command line check their
``env`` section against it too (``baselines/config.py``), so a wrong value fails the same way everywhere:
with :class:`ParameterError` (a ``ValueError``) naming the parameter, the value and what is valid.
"""

from __future__ import annotations

import difflib
import math
import os
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np


class ParameterError(ValueError):
    """An argument is unknown, of the wrong type or out of range; the message says which and what is valid."""


def _is_int(v: Any) -> bool:
    return isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))


def _is_number(v: Any) -> bool:
    return (_is_int(v) or isinstance(v, (float, np.floating))) and math.isfinite(float(v))


def _is_bool(v: Any) -> bool:
    return isinstance(v, (bool, np.bool_))


def _is_text(v: Any) -> bool:
    return isinstance(v, str)


def _is_path(v: Any) -> bool:
    return isinstance(v, (str, os.PathLike))


@dataclass(frozen=True)
class Parameter:
    """A parameter's rule: ``accepts(value)`` and its text ``valid`` for messages; ``None`` allowed if ``optional``."""

    accepts: Callable[[Any], bool]
    valid: str
    optional: bool = False

    def check(self, name: str, value: Any) -> None:
        if value is None and self.optional:
            return
        if not self.accepts(value):
            raise ParameterError(f"{name} must be {self.valid}{' or None' if self.optional else ''}, got {value!r}"
                                 f" ({type(value).__name__})")


ENV_PARAMETERS: dict[str, Parameter] = {
    "task": Parameter(_is_text, "a task name of the embodiment", optional=True),
    "mode": Parameter(_is_text, "a mode name of the embodiment", optional=True),
    "dataset_type": Parameter(_is_text, "'real', 'perfect' or 'preference'"),
    "control": Parameter(_is_text, "a control mode name of the embodiment ('torque', 'pd' ...)", optional=True),
    "disable_arms": Parameter(_is_bool, "True or False", optional=True),
    "reward_type": Parameter(_is_text, "a reward type name"),
    "reward_params": Parameter(lambda v: isinstance(v, Mapping), "a mapping", optional=True),
    "timestep": Parameter(lambda v: _is_number(v) and v > 0, "a positive number of seconds", optional=True),
    "n_substeps": Parameter(lambda v: _is_int(v) and v >= 1, "an int >= 1", optional=True),
    "horizon": Parameter(lambda v: _is_int(v) and v >= 1, "an int >= 1 (steps per episode)"),
    "gamma": Parameter(lambda v: _is_number(v) and 0 < v <= 1, "a number in (0, 1]"),
    "seed": Parameter(lambda v: _is_int(v) and v >= 0, "an int >= 0", optional=True),
    "random_start": Parameter(_is_bool, "True or False"),
    "init_step_no": Parameter(lambda v: _is_int(v) and v >= 0, "an int >= 0 (a dataset frame)", optional=True),
    "dataset_variant": Parameter(_is_text, "a dataset variant name ('permissive', 'noncommercial')", optional=True),
    "dataset_path": Parameter(_is_path, "a path to a dataset file", optional=True),
    "domain_randomization_config": Parameter(lambda v: _is_path(v) or isinstance(v, Mapping),
                                             "'default', a YAML path or a mapping", optional=True),
    "weight_mass": Parameter(lambda v: _is_number(v) and v > 0, "a positive number of kg", optional=True),
    "use_foot_forces": Parameter(_is_bool, "True or False", optional=True),
    "disable_back_joint": Parameter(_is_bool, "True or False"),  # Atlas
}
# Mushroom-RL's viewer (mushroom_rl.utils.mujoco.viewer.MujocoViewer); anything else is a misspelt parameter.
VIEWER_PARAMETERS = ("width", "height", "start_paused", "custom_render_callback", "record", "camera_params",
                     "default_camera_mode", "hide_menu_on_startup", "geom_group_visualization_on_startup",
                     "headless")


def suggestion(name: str, valid: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest valid name, or nothing."""
    close = difflib.get_close_matches(name, list(valid), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def check_unknown(given: Iterable[str], valid: Iterable[str], what: str) -> None:
    """Raise naming the first unknown name in ``given``, a suggestion and every valid name."""
    valid = sorted(set(valid))
    unknown = sorted(set(given) - set(valid))
    if unknown:
        raise ParameterError(f"unknown {what} {unknown}{suggestion(unknown[0], valid)}; valid: {', '.join(valid)}")


def check_values(values: Mapping[str, Any], prefix: str = "") -> None:
    """Check each value of ``values`` whose name has a rule in ``ENV_PARAMETERS``."""
    for name, value in values.items():
        rule = ENV_PARAMETERS.get(name)
        if rule is not None:
            rule.check(prefix + name, value)


def env_parameter_names(env_cls: type) -> set[str]:
    """The named keyword arguments of ``env_cls``: each ``__init__`` from the class up to ``LocoEnv``."""
    import inspect

    from loco_mujoco.core.loco_env import LocoEnv

    names: set[str] = set()
    for klass in env_cls.__mro__:
        init = klass.__dict__.get("__init__")
        if init is not None:
            params = inspect.signature(init).parameters.values()
            names |= {p.name for p in params if p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}
        if klass is LocoEnv:
            break
    return names - {"self"}
