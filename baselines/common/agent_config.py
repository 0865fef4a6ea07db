"""The base of every algorithm's config dataclass: built from plain dicts (YAML), checked key by key."""

from __future__ import annotations

import dataclasses
import math
import typing
from typing import Any


class AgentConfig:
    """Mixin for ``@dataclass`` agent configs: ``from_dict`` (unknown keys and wrong types raise ``ValueError``),
    ``validate`` (ranges; subclasses extend it) and ``to_dict`` (plain YAML-able values)."""

    @classmethod
    def from_dict(cls, values: dict[str, Any] | None) -> Any:
        """Build from a plain dict (e.g. YAML). Unknown keys and values of the wrong type raise ``ValueError``.

        Values are converted where that is unambiguous: lists to tuples, ints to floats. Strings are never read
        as numbers or booleans (write ``5.0e-5``: YAML 1.1 reads ``5e-5`` as a string).
        """
        values = dict(values or {})
        hints = typing.get_type_hints(cls)
        unknown = sorted(set(values) - set(hints))
        if unknown:
            raise ValueError(f"unknown {cls.__name__} keys {unknown}; valid keys: {', '.join(sorted(hints))}")
        config = cls(**{key: convert_config_value(cls.__name__, key, hints[key], value)
                        for key, value in values.items()})
        config.validate()
        return config

    def validate(self) -> None:
        """Check ranges; raise ``ValueError`` naming the key."""

    def to_dict(self) -> dict[str, Any]:
        return {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(self).items()}


def convert_config_value(config_name: str, key: str, hint: Any, value: Any) -> Any:
    """``value`` as the type ``hint`` of field ``key``, or a ``ValueError`` that names the key."""
    def fail() -> ValueError:
        return ValueError(f"{config_name}.{key} must be {hint.__name__ if isinstance(hint, type) else hint}, "
                          f"got {value!r}")

    if hint is float:  # ints widen to float; strings never become numbers ("5e-5" is a string in YAML 1.1)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise fail()
        return float(value)
    if hint is int or hint == (int | None):
        if value is None and hint is not int:
            return None
        integral = isinstance(value, int) or (isinstance(value, float) and value.is_integer())
        if isinstance(value, bool) or not integral:
            raise fail()
        return int(value)
    if hint is bool or hint is str:
        if not isinstance(value, hint):
            raise fail()
        return value
    if typing.get_origin(hint) is tuple:  # tuple[int, ...]: layer sizes
        if not isinstance(value, (list, tuple)) or not all(isinstance(v, int) and v > 0 for v in value):
            raise fail()
        return tuple(value)
    return value
