"""Shims that let mushroom-rl 1.10.2 run on the numpy 2 / torch >= 2.6 / mujoco 4 stack we install.

Imported once by ``loco_mujoco/__init__.py`` before anything touches mushroom-rl.
"""

from __future__ import annotations

import os
import warnings

# Offscreen rendering needs an OpenGL backend chosen before mujoco's GL modules are imported.
# Without a display EGL is the one that works headless; an explicit MUJOCO_GL always wins.
if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"

with warnings.catch_warnings():
    # mushroom_rl's viewer imports glfw, which warns that there is no X11 display on a headless machine.
    warnings.filterwarnings("ignore", message=".*DISPLAY.*")
    warnings.filterwarnings("ignore", module="glfw")
    import mushroom_rl.core.serialization as _serialization
    from mushroom_rl.environments.mujoco import MuJoCo, MultiMuJoCo  # noqa: F401


def _load_torch_full(zip_file, name):
    """torch >= 2.6 defaults to weights_only=True, which cannot read mushroom's pickled agents."""
    import torch

    with zip_file.open(name, "r") as f:
        return torch.load(f, weights_only=False)


_serialization.Serializable._load_torch = staticmethod(_load_torch_full)
