"""Boston Dynamics Atlas (v5, DRC), our own MJCF from the robot facts: 12 leg, 3 back and 12 arm joints."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import mujoco

from loco_mujoco.core.embodiment_model import ModelChoice
from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.datasets.retarget import HumanoidRetarget, LegJoints
from loco_mujoco.models.authoring import load_own_spec

DISABLE_BACK_JOINT = True  # the back is welded at the home pose by default, as upstream


class Atlas(LocoEnv):
    """Atlas, 171.7 kg of hydraulic humanoid. Back and arms are welded at the home pose unless
    ``disable_back_joint=False`` / ``disable_arms=False``."""

    TASKS = {
        "walk": Task(target_velocity=1.25, description="walk forward at human walking speed"),
        "carry": Task(target_velocity=1.0, description="walk forward while carrying a load"),
    }
    HOME_KEY = "home"
    ARM_JOINTS = tuple(f"{s}_arm_{j}" for s in ("l", "r") for j in ("shz", "shx", "ely", "elx", "wry", "wrx"))
    BACK_JOINTS = ("back_bkz", "back_bky", "back_bkx")
    LEG_ROOTS = ("l_uglut", "r_uglut")
    ROOT_HEIGHT_RANGE = (0.55, 1.4)  # pelvis height (m); home 0.93
    MAX_TILT = math.pi / 4
    CARRY_BODY = "utorso"  # carry task: the load sits in front of the chest, welded to this body
    CARRY_OFFSET = (0.3, 0.0, 0.15)

    def __init__(self, *args: Any, disable_back_joint: bool = DISABLE_BACK_JOINT, **kwargs: Any):
        """``disable_back_joint``: weld the three back joints at the home pose (default, as upstream)."""
        from loco_mujoco.core.parameters import ENV_PARAMETERS

        ENV_PARAMETERS["disable_back_joint"].check("disable_back_joint", disable_back_joint)
        self.disable_back_joint = disable_back_joint
        super().__init__(*args, **kwargs)

    @classmethod
    def load_spec(cls) -> mujoco.MjSpec:
        return load_own_spec("atlas")

    def _model_choice(self, control: str, disable_arms: bool) -> ModelChoice:
        return replace(super()._model_choice(control, disable_arms),
                       options={"disable_back_joint": self.disable_back_joint})

    @classmethod
    def fixed_joints(cls, spec: mujoco.MjSpec, choice: ModelChoice) -> list[str]:
        back = choice.options.get("disable_back_joint", DISABLE_BACK_JOINT)
        return list(cls.ARM_JOINTS if choice.disable_arms else ()) + list(cls.BACK_JOINTS if back else ())


Atlas.RETARGET = HumanoidRetarget(legs={
    s: LegJoints(hip_rotation=f"hip_rotation_{s}", hip_adduction=f"hip_adduction_{s}",
                 hip_flexion=f"hip_flexion_{s}", knee_flexion=f"knee_angle_{s}",
                 ankle_dorsiflexion=f"ankle_angle_{s}", foot_body=f"{s}_foot")
    for s in ("l", "r")},
    contact_height=0.005)  # flat box feet pass close to the floor in swing, as the human's do
