"""Unitree A1 quadruped (MuJoCo Menagerie, BSD-3-Clause): 12 joints, PD position servos by default."""

from __future__ import annotations

import math

import mujoco
import numpy as np

from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.datasets.retarget import QuadrupedRetarget
from loco_mujoco.models.menagerie import load_menagerie_spec


class UnitreeA1(LocoEnv):
    """Unitree A1. The reward tracks a goal velocity vector that is part of the observation, expressed in the
    robot's own heading frame (so the task is the same from any start heading).

    ``simple``: the goal points straight ahead. ``hard``: its direction is drawn uniformly per episode.
    """

    TASKS = {
        "simple": Task(target_velocity=0.6, description="trot straight ahead"),
        "hard": Task(target_velocity=0.6, description="trot in a direction drawn each episode"),
    }
    DEFAULT_CONTROL = "pd"
    TASK_REWARD = "velocity_vector"
    GOAL_OBSERVATION = True
    HOME_KEY = "home"
    ROOT_HEIGHT_RANGE = (0.12, 0.6)  # trunk height (m); home 0.27
    MAX_TILT = math.pi / 3

    @classmethod
    def load_spec(cls) -> mujoco.MjSpec:
        return load_menagerie_spec("unitree_a1", "scene")

    @classmethod
    def pd_gains(cls, spec: mujoco.MjSpec) -> dict[str, tuple[float, float]]:
        """Menagerie's servo stiffness (kp 100); damping comes from the joints' own damping."""
        return {a.target: (100.0, 0.0) for a in spec.actuators}

    def _reset_goal(self) -> None:
        heading = self._rng.uniform(-math.pi, math.pi) if self.task_name == "hard" else 0.0
        self._goal[:] = (math.cos(heading), math.sin(heading), self.target_velocity)

    @property
    def goal_velocity(self) -> np.ndarray:
        """The current goal as an xy velocity (m/s) in the root's heading frame (x ahead, y to the left)."""
        return self._goal[:2] * self._goal[2]


UnitreeA1.RETARGET = QuadrupedRetarget(feet=("FR_calf", "FL_calf", "RR_calf", "RL_calf"), contact_height=0.01)
