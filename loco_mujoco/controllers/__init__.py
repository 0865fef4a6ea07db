"""Model-based controllers that generate permissive datasets (see :mod:`loco_mujoco.controllers.datasets`)."""

from loco_mujoco.controllers.datasets import (
    CONTROLLER_RECIPES,
    build_controller_dataset,
    controller_dataset_path,
    rollout,
    tracking,
)
from loco_mujoco.controllers.quadruped import QuadrupedController, TrotSettings

__all__ = ["CONTROLLER_RECIPES", "QuadrupedController", "TrotSettings", "build_controller_dataset",
           "controller_dataset_path", "rollout", "tracking"]
