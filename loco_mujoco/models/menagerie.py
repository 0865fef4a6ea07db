"""Locate MuJoCo Menagerie models through the ``mujoco-menagerie`` package, offline-first."""

from __future__ import annotations

import os
from pathlib import Path

import mujoco

_SHARED_DEFAULT = Path(__file__).resolve().parents[2].parent / "shared" / "menagerie"


class ModelNotFoundError(FileNotFoundError):
    """A robot model is neither in MENAGERIE_ROOT nor in the download cache, and could not be fetched."""


def default_menagerie_root() -> Path | None:
    """``$MENAGERIE_ROOT`` if set, else ``../shared/menagerie`` beside the checkout when it exists."""
    env = os.environ.get("MENAGERIE_ROOT")
    if env:
        return Path(env)
    return _SHARED_DEFAULT if _SHARED_DEFAULT.is_dir() else None


def menagerie_xml(robot: str, entry: str) -> Path:
    """Path of ``entry`` (an entry point such as ``scene``) of Menagerie robot ``robot``."""
    import mujoco_menagerie

    root = default_menagerie_root()
    cache = mujoco_menagerie.Cache(root=root) if root is not None else mujoco_menagerie.Cache()
    try:
        return mujoco_menagerie.get(robot).xml(entry, cache=cache)
    except mujoco_menagerie.MenagerieError as err:
        where = f"MENAGERIE_ROOT={root}" if root is not None else "the menagerie download cache"
        raise ModelNotFoundError(
            f"Model '{robot}' (entry '{entry}') is not available from {where}: {err}. "
            "Connect to the internet once so that mujoco-menagerie can download it, or set "
            "MENAGERIE_ROOT to a folder holding the Menagerie models (e.g. ../shared/menagerie)."
        ) from err


def load_menagerie_spec(robot: str, entry: str) -> mujoco.MjSpec:
    """Parse a Menagerie entry point into an editable MjSpec."""
    return mujoco.MjSpec.from_file(str(menagerie_xml(robot, entry)))
