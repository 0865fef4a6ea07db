"""Unitree H1 humanoid (MuJoCo Menagerie, BSD-3-Clause): 10 leg joints + torso; 8 arm joints."""

from __future__ import annotations

import math

import mujoco

from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.models.menagerie import load_menagerie_spec


class UnitreeH1(LocoEnv):
    """Unitree H1. Arms are welded in the home pose unless ``disable_arms=False``."""

    TASKS = {
        "walk": Task(target_velocity=1.25, description="walk forward at human walking speed"),
        "run": Task(target_velocity=2.5, description="run forward"),
        "carry": Task(target_velocity=1.0, description="walk forward while carrying a load"),
    }
    HOME_KEY = "home"
    ARM_JOINTS = tuple(f"{side}_{j}" for side in ("left", "right")
                       for j in ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow"))
    LEG_ROOTS = ("left_hip_yaw_link", "right_hip_yaw_link")
    ROOT_HEIGHT_RANGE = (0.6, 1.5)  # pelvis height (m); home 0.98
    MAX_TILT = math.pi / 4

    def load_spec(self) -> mujoco.MjSpec:
        return load_menagerie_spec("unitree_h1", "scene")
