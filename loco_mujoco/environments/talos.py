"""PAL Talos humanoid (MuJoCo Menagerie, Apache-2.0): 12 leg + 2 torso joints; arms, grippers, head."""

from __future__ import annotations

import math

import mujoco

from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.models.menagerie import load_menagerie_spec


class Talos(LocoEnv):
    """PAL Talos. ``disable_arms`` (default) also fixes the head and the grippers."""

    TASKS = {
        "walk": Task(target_velocity=1.25, description="walk forward at human walking speed"),
        "carry": Task(target_velocity=1.0, description="walk forward while carrying a load"),
    }
    HOME_KEY = 0
    LEG_ROOTS = ("leg_left_1_link", "leg_right_1_link")
    ROOT_HEIGHT_RANGE = (0.6, 1.5)  # base_link height (m); home 1.08
    MAX_TILT = math.pi / 4
    _UPPER_BODY_PREFIXES = ("arm_", "gripper_", "head_")

    def load_spec(self) -> mujoco.MjSpec:
        return load_menagerie_spec("pal_talos", "scene_motor")

    def fixed_joints(self, spec: mujoco.MjSpec, disable_arms: bool) -> list[str]:
        upper = [j.name for j in spec.joints if j.name.startswith(self._UPPER_BODY_PREFIXES)]
        if disable_arms:
            return upper
        # with arms enabled the passive gripper linkage stays fixed: it has no motor of its own
        actuated = {a.target for a in spec.actuators}
        return [j for j in upper if j.startswith("gripper_") and j not in actuated]
