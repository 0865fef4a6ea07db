"""PAL Talos humanoid (MuJoCo Menagerie, Apache-2.0): 12 leg + 2 torso joints; arms, grippers, head."""

from __future__ import annotations

import math

import mujoco

from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.models.menagerie import load_menagerie_spec


class Talos(LocoEnv):
    """PAL Talos. The head and the grippers are always fixed; the 14 arm joints unless ``disable_arms=False``."""

    TASKS = {
        "walk": Task(target_velocity=1.25, description="walk forward at human walking speed"),
        "carry": Task(target_velocity=1.0, description="walk forward while carrying a load"),
    }
    HOME_KEY = 0
    LEG_ROOTS = ("leg_left_1_link", "leg_right_1_link")
    ROOT_HEIGHT_RANGE = (0.6, 1.5)  # base_link height (m); home 1.08
    MAX_TILT = math.pi / 4
    _ALWAYS_FIXED_PREFIXES = ("gripper_", "head_")

    def load_spec(self) -> mujoco.MjSpec:
        return load_menagerie_spec("pal_talos", "scene_motor")

    def fixed_joints(self, spec: mujoco.MjSpec, disable_arms: bool) -> list[str]:
        prefixes = self._ALWAYS_FIXED_PREFIXES + (("arm_",) if disable_arms else ())
        return [j.name for j in spec.joints if j.name.startswith(prefixes)]
