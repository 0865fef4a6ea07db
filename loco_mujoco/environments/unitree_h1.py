"""Unitree H1 humanoid (MuJoCo Menagerie, BSD-3-Clause): 10 leg joints + torso; 8 arm joints."""

from __future__ import annotations

import math

import mujoco

from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.datasets.retarget import HumanoidRetarget, LegJoints
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
    CARRY_BODY = "torso_link"  # carry task: the load sits in front of the chest, welded to this body
    CARRY_OFFSET = (0.25, 0.0, 0.15)

    @classmethod
    def load_spec(cls) -> mujoco.MjSpec:
        return load_menagerie_spec("unitree_h1", "scene")


UnitreeH1.RETARGET = HumanoidRetarget(legs={
    side[0]: LegJoints(hip_rotation=f"{side}_hip_yaw", hip_adduction=f"{side}_hip_roll",
                       hip_flexion=f"{side}_hip_pitch", knee_flexion=f"{side}_knee",
                       ankle_dorsiflexion=f"{side}_ankle", foot_body=f"{side}_ankle_link")
    for side in ("left", "right")})
# Joint names of the original LocoMuJoCo H1 model (same axes as Menagerie's), for its .npz datasets.
UnitreeH1.OLD_FORMAT_JOINTS = {
    **{f"{old}_{s[0]}": f"{s}_{new}" for s in ("left", "right") for old, new in
       (("hip_rotation", "hip_yaw"), ("hip_adduction", "hip_roll"), ("hip_flexion", "hip_pitch"),
        ("knee_angle", "knee"), ("ankle_angle", "ankle"))},
    "back_bkz": "torso", "left_elbow": "left_elbow", "right_elbow": "right_elbow",
    **{f"{s[0]}_arm_{old}": f"{s}_shoulder_{new}" for s in ("left", "right") for old, new in
       (("shy", "pitch"), ("shx", "roll"), ("shz", "yaw"))},
}
