"""An embodiment's MuJoCo model, built from its class and a :class:`ModelChoice` alone.

The model never depends on an environment instance, so the datasets layer can have it (through
``LocoEnv.dataset_subject().target``) without constructing an environment, and ``LocoEnv.__init__`` builds its
own through the same ``assemble_spec``. Embodiments declare ``load_spec`` and, where needed, ``fixed_joints``,
``pd_gains`` or ``assemble_spec`` as classmethods.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import mujoco
import numpy as np

from loco_mujoco.models import spec_edit

LOAD_BODY = "carried_load"
LOAD_HALF_SIZE = (0.1, 0.15, 0.1)  # m: a box held in front of the chest


@dataclass(frozen=True)
class ModelChoice:
    """Everything an embodiment's model depends on besides its class.

    ``options`` holds embodiment switches that change the model, e.g. Atlas's ``disable_back_joint``.
    """

    task: str
    mode: str | None
    control: str
    disable_arms: bool
    use_foot_forces: bool = False
    options: Mapping[str, Any] = field(default_factory=dict)


def box_inertia(mass: float) -> np.ndarray:
    """Principal inertia of a solid box of ``mass`` with half sizes ``LOAD_HALF_SIZE``."""
    x, y, z = LOAD_HALF_SIZE
    return mass / 3.0 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])


def qpos_in_layout(by_joint: Mapping[str, np.ndarray], model: mujoco.MjModel) -> np.ndarray:
    """Per-joint qpos entries (e.g. the home pose) laid out as ``model``'s qpos."""
    return np.concatenate([by_joint[model.joint(j).name] for j in range(model.njnt)])


class EmbodimentModelMixin:
    """Mixed into :class:`LocoEnv`: the class-level model building; relies on its declarations (``HOME_KEY``,
    ``ARM_JOINTS``, ``LEG_ROOTS``, ``CARRY_BODY``, ``CARRY_OFFSET``, ``INTEGRATOR``, ``RETARGET``)."""

    @classmethod
    def load_spec(cls) -> mujoco.MjSpec:
        """The unmodified robot model in a scene with a floor named ``floor``."""
        raise NotImplementedError

    @classmethod
    def model_spec(cls, mode: str | None) -> mujoco.MjSpec:
        """The unmodified model of ``mode`` from the class alone; embodiments whose model depends on the mode
        (body sizes) override this."""
        return cls.load_spec()

    @classmethod
    def assemble_spec(cls, spec: mujoco.MjSpec, choice: ModelChoice) -> tuple[mujoco.MjSpec, dict[str, np.ndarray]]:
        """``spec`` (the unmodified model) with the root named, arms handled, collisions filtered, the carry load
        and foot sensors added and the control mode set; and the home pose by joint name."""
        spec_edit.name_free_joint(spec)
        home = spec_edit.keyframe_qpos(spec, cls.HOME_KEY)
        fixed = cls.fixed_joints(spec, choice)
        spec_edit.fix_joints(spec, fixed, {j: float(home[j][0]) for j in fixed})
        if cls.LEG_ROOTS is not None:
            spec_edit.filter_self_collisions(spec, *cls.LEG_ROOTS)
        if cls.carries_load(choice.task):
            cls._add_load(spec)
        if choice.use_foot_forces:
            for foot in cls.foot_bodies():
                spec.add_sensor(name=f"foot_force_{foot}", type=mujoco.mjtSensor.mjSENS_CONTACT,
                                objtype=mujoco.mjtObj.mjOBJ_XBODY, objname=foot, reftype=mujoco.mjtObj.mjOBJ_GEOM,
                                refname="floor", intprm=[2, 3, 1])  # data: force; reduce: net force; 1 slot
        if choice.control == "torque":
            spec_edit.to_torque_control(spec)
        else:
            spec_edit.to_position_control(spec, cls.pd_gains(spec))
        return spec, home

    @classmethod
    def compile_spec(cls, spec: mujoco.MjSpec) -> mujoco.MjModel:
        """Compile an assembled spec with the embodiment's integrator."""
        spec.option.integrator = cls.INTEGRATOR
        return spec.compile()

    @classmethod
    def compile_model(cls, choice: ModelChoice) -> tuple[mujoco.MjModel, np.ndarray]:
        """The compiled model of ``choice`` and its home qpos, without an environment."""
        spec, home = cls.assemble_spec(cls.model_spec(choice.mode), choice)
        model = cls.compile_spec(spec)
        return model, qpos_in_layout(home, model)

    @classmethod
    def carries_load(cls, task: str) -> bool:
        """Whether ``task`` welds a load to the robot: the carry task of an embodiment with a ``CARRY_BODY``."""
        return task == "carry" and cls.CARRY_BODY is not None

    @classmethod
    def fixed_joints(cls, spec: mujoco.MjSpec, choice: ModelChoice) -> list[str]:
        """Joints removed from the model; by default the arm joints when arms are disabled."""
        return [j for j in cls.ARM_JOINTS if spec.joint(j) is not None] if choice.disable_arms else []

    @classmethod
    def pd_gains(cls, spec: mujoco.MjSpec) -> dict[str, tuple[float, float]]:
        """PD gains per actuated joint. Default: peak torque at 0.25 rad error (kp = 4 x peak), kd = kp / 25."""
        gains = {}
        for act in spec.actuators:
            kp = 4.0 * float(np.max(np.abs(spec_edit.torque_range(spec, act))))
            gains[act.target] = (kp, kp / 25.0)
        return gains

    @classmethod
    def foot_bodies(cls) -> tuple[str, ...]:
        """Bodies whose subtrees are the feet (for foot forces): those of the retargeting spec."""
        spec = cls.RETARGET
        if spec is None:
            raise ValueError(f"{cls.__name__} does not declare its feet; use_foot_forces is unavailable")
        if hasattr(spec, "legs"):
            return tuple(spec.legs[side].foot_body for side in sorted(spec.legs))
        return tuple(spec.feet)

    @classmethod
    def _add_load(cls, spec: mujoco.MjSpec) -> None:
        """A box of 1 kg (re-massed every episode) welded in front of ``CARRY_BODY``: the carried load."""
        parent = spec.body(cls.CARRY_BODY)
        if parent is None:
            raise ValueError(f"{cls.__name__}.CARRY_BODY {cls.CARRY_BODY!r} is not a body of the model")
        load = parent.add_body(name=LOAD_BODY, pos=list(cls.CARRY_OFFSET))
        load.explicitinertial = True
        load.mass = 1.0
        load.inertia = box_inertia(1.0)
        load.add_geom(name=LOAD_BODY, type=mujoco.mjtGeom.mjGEOM_BOX, size=list(LOAD_HALF_SIZE),
                      contype=0, conaffinity=0, rgba=[0.6, 0.45, 0.25, 1.0])
