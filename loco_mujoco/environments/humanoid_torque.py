"""Torque-driven human skeleton (after Hamner et al. 2010), our own MJCF from the robot facts.

Joints carry the OpenSim coordinate names (``hip_flexion_r``, ``knee_angle_r`` ...): 3 lumbar, 7 per leg
(hip 3, knee, ankle, subtalar, toes), 7 per arm; each driven by a motor at its peak joint torque.
"""

from __future__ import annotations

import math

import mujoco

from loco_mujoco.core.body_sizes import BodySizesMixin
from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.core.sized_model import SizedModelMixin
from loco_mujoco.datasets.retarget import HumanoidRetarget, LegJoints
from loco_mujoco.models.authoring import load_own_spec

HUMAN_ARM_JOINTS = tuple(f"{j}_{s}" for s in ("r", "l") for j in
                         ("arm_flex", "arm_add", "arm_rot", "elbow_flex", "pro_sup", "wrist_flex", "wrist_dev"))
HUMAN_RETARGET = HumanoidRetarget(legs={
    s: LegJoints(hip_rotation=f"hip_rotation_{s}", hip_adduction=f"hip_adduction_{s}",
                 hip_flexion=f"hip_flexion_{s}", knee_flexion=f"knee_angle_{s}",
                 ankle_dorsiflexion=f"ankle_angle_{s}", foot_body=f"calcn_{s}")
    for s in ("l", "r")},
    # The long flat feet pass within 1 cm of the floor in swing; 5 mm tells swing from stance.
    contact_height=0.005)


class HumanoidTorque(LocoEnv):
    """Adult human skeleton, 86.6 kg, 1.8 m tall. Arms are welded at the sides unless ``disable_arms=False``."""

    TASKS = {
        "walk": Task(target_velocity=1.25, description="walk forward at human walking speed"),
        "run": Task(target_velocity=2.5, description="run forward"),
    }
    HOME_KEY = "home"
    ARM_JOINTS = HUMAN_ARM_JOINTS
    LEG_ROOTS = ("femur_l", "femur_r")
    ROOT_HEIGHT_RANGE = (0.6, 1.5)  # pelvis height (m); home 0.975
    MAX_TILT = math.pi / 4
    RETARGET = HUMAN_RETARGET

    @classmethod
    def load_spec(cls) -> mujoco.MjSpec:
        return load_own_spec("humanoid_torque")


class HumanoidTorque4Ages(SizedModelMixin, BodySizesMixin, HumanoidTorque):
    """The skeleton at four statures: mode 1 (0.86 m, ~2 years), 2 (1.10 m, ~5 years), 3 (1.50 m, ~12 years),
    4 (1.78 m, adult), or ``all`` (one sampled per episode, size code in the observation)."""

    ADULT_STATURE_M = 1.78  # top of the head to the sole in the home pose of humanoid_torque.xml
