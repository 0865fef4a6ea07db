"""PAL Talos humanoid (MuJoCo Menagerie, Apache-2.0): 12 leg + 2 torso joints; arms, grippers, head."""

from __future__ import annotations

import math

import mujoco

from loco_mujoco.core.embodiment_model import ModelChoice
from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.datasets.retarget import HumanoidRetarget, LegJoints
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
    CARRY_BODY = "torso_2_link"  # carry task: the load sits in front of the chest, welded to this body
    CARRY_OFFSET = (0.3, 0.0, 0.0)
    _ALWAYS_FIXED_PREFIXES = ("gripper_", "head_")

    @classmethod
    def load_spec(cls) -> mujoco.MjSpec:
        return load_menagerie_spec("pal_talos", "scene_motor")

    @classmethod
    def fixed_joints(cls, spec: mujoco.MjSpec, choice: ModelChoice) -> list[str]:
        prefixes = cls._ALWAYS_FIXED_PREFIXES + (("arm_",) if choice.disable_arms else ())
        return [j.name for j in spec.joints if j.name.startswith(prefixes)]


Talos.RETARGET = HumanoidRetarget(legs={
    side[0]: LegJoints(hip_rotation=f"leg_{side}_1_joint", hip_adduction=f"leg_{side}_2_joint",
                       hip_flexion=f"leg_{side}_3_joint", knee_flexion=f"leg_{side}_4_joint",
                       ankle_dorsiflexion=f"leg_{side}_5_joint", ankle_roll=f"leg_{side}_6_joint",
                       foot_body=f"leg_{side}_6_link")
    for side in ("left", "right")})
# Joint names of the original LocoMuJoCo Talos model (legs and torso), for its .npz datasets.
Talos.OLD_FORMAT_JOINTS = {
    **{f"{old}_{s[0]}": f"leg_{s}_{i}_joint" for s in ("left", "right") for old, i in
       (("hip_rotation", 1), ("hip_adduction", 2), ("hip_flexion", 3), ("knee_angle", 4), ("ankle_angle", 5))},
    "back_bkz": "torso_1_joint", "back_bky": "torso_2_joint",
}
