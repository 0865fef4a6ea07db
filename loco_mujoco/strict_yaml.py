"""YAML without silent surprises: a duplicated key is an error (PyYAML keeps the last value without a word).

Types stay as YAML reads them; callers check them against their declared types and never coerce strings to
numbers or booleans (``"no"`` is a string, not False; write ``5.0e-5``, not ``5e-5``, for a float).
"""

from __future__ import annotations

from typing import Any

import yaml


class DuplicateKeyError(ValueError):
    """A mapping in a YAML document holds the same key twice."""


class _StrictLoader(yaml.SafeLoader):
    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: dict[Any, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            line = key_node.start_mark.line + 1
            if key in seen:
                raise DuplicateKeyError(f"duplicate key {key!r} at line {line} (first at line {seen[key]}); "
                                        "each key may appear once per mapping")
            seen[key] = line
        return super().construct_mapping(node, deep=deep)


def load(text: str) -> Any:
    """Parse ``text`` like ``yaml.safe_load``, but a duplicated key raises :class:`DuplicateKeyError`."""
    return yaml.load(text, Loader=_StrictLoader)  # noqa: S506  (a SafeLoader subclass)
