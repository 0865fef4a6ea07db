"""Musculoskeletal humanoid: myo-sim's MyoLeg (80 Hill-type muscles, Apache-2.0) on a rigid torso, muscle-driven.

Actions are muscle excitations: the normalised action in [-1, 1] maps linearly onto each muscle's ctrlrange [0, 1]
(-1: relaxed, +1: fully excited); MuJoCo's activation dynamics turn excitation into activation.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from loco_mujoco.core.body_sizes import BodySizesMixin
from loco_mujoco.core.embodiment_model import ModelChoice
from loco_mujoco.core.loco_env import LocoEnv, Task
from loco_mujoco.core.sized_model import SizedModelMixin
from loco_mujoco.datasets.retarget import HumanoidRetarget, LegJoints
from loco_mujoco.models import spec_edit
from loco_mujoco.models.myo_human import HOME_KEY, apply_coarse_step_settings, load_myo_human_spec


class HumanoidMuscle(LocoEnv):
    """Muscle-actuated human, 75 kg, no arms: free root + 7 anatomical and 7 knee-coupled joints per leg, 80 muscles.

    Observations hold every joint's position and velocity (nq - 2 + nv = 67), not the muscle activations.
    """

    TASKS = {
        "walk": Task(target_velocity=1.25, description="walk forward at human walking speed"),
        "run": Task(target_velocity=2.5, description="run forward"),
    }
    HOME_KEY = HOME_KEY
    DEFAULT_CONTROL = "muscle"
    CONTROLS = ("muscle",)
    # No LEG_ROOTS: myo_human already restricts contacts to soles-floor plus myo-sim's explicit leg-leg pairs;
    # spec_edit.filter_self_collisions would add bitmask contacts between all leg bones on top of those pairs.
    ROOT_HEIGHT_RANGE = (0.6, 1.5)  # pelvis height (m); home 0.945
    # implicitfast at 5 ms x 2 with myo_human.apply_coarse_step_settings (bench/timestep_study.py, BENCHMARKS.md):
    # explicit Euler needs <= 2.5 ms (4 physics steps per control step) because the muscles' force-velocity damping
    # on the light foot is stiff; integrating it implicitly allows 2 steps, 1.4x faster. Bang-bang excitation stays
    # under 25 rad/s (Euler at 5 ms: ~135); the price is ~3x the short-horizon error of Euler at 2.5 ms.
    TIMESTEP = 0.005
    N_SUBSTEPS = 2
    INTEGRATOR = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    # The second physics step of a control step reuses the first one's factorisation of M - h D (D: the 80 muscles'
    # force-velocity damping through their moment arms; core/implicit_reuse.py): 1.14x the physics speed. Bang-bang
    # excitation over 15 seeds: 99th percentile 12.6 rad/s as exact mj_step (12.8); largest 15.5-33.8 rad/s, 4 of
    # 15 seeds above 25 (exact: 16.4-27.8, 1 of 15). `env.reuse_implicit_factor = False` gives exact mj_step.
    REUSE_IMPLICIT_FACTOR = True
    MAX_TILT = math.pi / 4
    LEG_JOINTS = {
        side: dict(hip_rotation=f"hip_rotation_{side}", hip_adduction=f"hip_adduction_{side}",
                   hip_flexion=f"hip_flexion_{side}", knee_flexion=f"knee_angle_{side}",
                   ankle_dorsiflexion=f"ankle_angle_{side}", foot_body=f"calcn_{side}")
        for side in ("l", "r")
    }

    @classmethod
    def load_spec(cls) -> mujoco.MjSpec:
        """The musculoskeletal human on a floor (see :func:`loco_mujoco.models.myo_human.load_myo_human_spec`)."""
        return load_myo_human_spec()

    @classmethod
    def assemble_spec(cls, spec: mujoco.MjSpec, choice: ModelChoice) -> tuple[mujoco.MjSpec, dict[str, np.ndarray]]:
        """The model with its muscles kept as muscles (excitation in [0, 1]); the model has no arms to disable."""
        spec_edit.name_free_joint(spec)
        home = spec_edit.keyframe_qpos(spec, cls.HOME_KEY)
        for act in spec.actuators:  # the action mapping (-1 -> 0, +1 -> 1) relies on this; myo-sim's values
            is_muscle = act.gaintype == mujoco.mjtGain.mjGAIN_MUSCLE and act.dyntype == mujoco.mjtDyn.mjDYN_MUSCLE
            limited = act.ctrllimited == mujoco.mjtLimited.mjLIMITED_TRUE
            if not (is_muscle and limited and list(act.ctrlrange) == [0, 1]):
                raise ValueError(f"actuator '{act.name}' is not a muscle with ctrlrange [0, 1]")
        apply_coarse_step_settings(spec)  # what implicitfast at TIMESTEP needs (armature, actearly, limits, islands)
        return spec, home


HumanoidMuscle.RETARGET = HumanoidRetarget(
    legs={side: LegJoints(**joints) for side, joints in HumanoidMuscle.LEG_JOINTS.items()},
    contact_height=0.005)  # long flat feet skim the floor in swing, as on HumanoidTorque


class HumanoidMuscle4Ages(SizedModelMixin, BodySizesMixin, HumanoidMuscle):
    """The musculoskeletal human at four statures: mode 1 (0.86 m, ~2 years), 2 (1.10 m, ~5 years),
    3 (1.50 m, ~12 years), 4 (1.70 m, adult), or ``all``; muscle forces scale with stature squared."""

    ADULT_STATURE_M = 1.70  # top of the skull mesh in the home pose of the myo-sim model
