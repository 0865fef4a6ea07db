"""LocoEnv: the Mushroom-RL MuJoCo environment every embodiment derives from.

An embodiment subclass only declares its model (where it comes from, which joints are arms, the home
pose), its tasks and its fall bounds; everything else (observation layout, control mode, rewards,
termination, seeding) lives here. The hot path ``step`` uses index arrays prepared at construction.
"""

from __future__ import annotations

import difflib
import math
import os
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import mujoco
import numpy as np
from mushroom_rl.core import MDPInfo
from mushroom_rl.utils.mujoco import ObservationType
from mushroom_rl.utils.spaces import Box

from loco_mujoco._compat import MuJoCo
from loco_mujoco.core import implicit_reuse, parameters
from loco_mujoco.core import rewards as rw
from loco_mujoco.core.embodiment_model import (
    LOAD_BODY,
    EmbodimentModelMixin,
    ModelChoice,
    box_inertia,
    qpos_in_layout,
)
from loco_mujoco.core.task_names import DATASET_TYPES, DEFAULT_DATASET_TYPE, parse_task_name, register_environment
from loco_mujoco.core.trajectory_api import TrajectoryMixin
from loco_mujoco.datasets.subject import DatasetSubject, RetargetTarget
from loco_mujoco.models import spec_edit

if TYPE_CHECKING:
    from loco_mujoco.datasets.retarget import HumanoidRetarget, QuadrupedRetarget

OBSERVATION_GROUPS = ("positions", "velocities", "foot_forces", "weight", "env_type", "goal")
LOAD_MASSES = (0.1, 1.0, 5.0, 10.0)  # kg, one drawn per episode unless weight_mass= fixes it

# Simulation defaults, chosen by bench/timestep_study.py (see BENCHMARKS.md): implicit-in-velocity
# integration at 2 ms is as stable as 1 ms with 10 substeps on every robot here and twice as fast.
DEFAULT_TIMESTEP = 0.002
DEFAULT_N_SUBSTEPS = 5
DEFAULT_INTEGRATOR = mujoco.mjtIntegrator.mjINT_IMPLICITFAST


@dataclass(frozen=True)
class Task:
    """What a task asks for: the forward speed its reward targets (until datasets provide it)."""

    target_velocity: float
    description: str = ""


def _sum_is_finite(x: np.ndarray) -> bool:
    """Cheap finiteness check for the hot path: one reduction instead of an element-wise test.

    A non-finite element always makes the sum non-finite; a finite sum can only overflow to inf for
    huge finite values, so callers confirm with ``np.isfinite`` before reporting an error.
    """
    total = x.sum()
    return total == total and total not in (math.inf, -math.inf)


class PhysicsDivergedWarning(RuntimeWarning):
    """The simulation produced non-finite values; the episode was terminated."""


class LocoEnv(TrajectoryMixin, EmbodimentModelMixin, MuJoCo):
    """Base class of all locomotion environments. Build one with ``LocoEnv.make("UnitreeH1.walk")``."""

    # ---- declared by each embodiment -------------------------------------------------------------
    TASKS: ClassVar[dict[str, Task]] = {}
    MODES: ClassVar[tuple[str, ...]] = ()
    DATASET_TYPES: ClassVar[tuple[str, ...]] = DATASET_TYPES
    DEFAULT_CONTROL: ClassVar[str] = "torque"
    CONTROLS: ClassVar[tuple[str, ...]] = ("torque", "pd")  # the control modes this embodiment offers
    TASK_REWARD: ClassVar[str] = "target_velocity"
    ARM_JOINTS: ClassVar[tuple[str, ...]] = ()
    LEG_ROOTS: ClassVar[tuple[str, str] | None] = None  # (left, right) for self-collision filtering
    ROOT_HEIGHT_RANGE: ClassVar[tuple[float, float]] = (0.0, math.inf)
    MAX_TILT: ClassVar[float] = math.pi / 2  # fallen when the root's z axis leans more than this (rad)
    GOAL_OBSERVATION: ClassVar[bool] = False
    HOME_KEY: ClassVar[str | int] = 0  # keyframe (name or index) that holds the home pose
    CARRY_BODY: ClassVar[str | None] = None  # body the load of the "carry" task is attached to
    CARRY_OFFSET: ClassVar[tuple[float, float, float]] = (0.3, 0.0, 0.0)  # load position in that body's frame
    TIMESTEP: ClassVar[float] = DEFAULT_TIMESTEP
    N_SUBSTEPS: ClassVar[int] = DEFAULT_N_SUBSTEPS
    INTEGRATOR: ClassVar[int] = DEFAULT_INTEGRATOR
    # Implicit integrators: build and factorise M - h D once per control step and reuse it in the other physics
    # steps (core/implicit_reuse.py); worth it where D is costly (muscles). Instances may switch it off with
    # `env.reuse_implicit_factor = False` for MuJoCo's exact mj_step.
    REUSE_IMPLICIT_FACTOR: ClassVar[bool] = False
    RETARGET: ClassVar[HumanoidRetarget | QuadrupedRetarget | None] = None  # how motion maps on: real datasets
    OLD_FORMAT_JOINTS: ClassVar[Mapping[str, str]] = {}  # original LocoMuJoCo joint names -> ours, for its files
    SIZES: ClassVar[tuple[str, ...]] = ()  # body sizes (modes) whose datasets mode "all" joins

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if cls.TASKS:
            register_environment(cls)
            cls.register()  # Mushroom-RL's registry: Environment.make("UnitreeH1.walk") works too

    def __init__(
        self,
        task: str | None = None,
        mode: str | None = None,
        dataset_type: str = DEFAULT_DATASET_TYPE,
        control: str | None = None,
        disable_arms: bool | None = None,
        reward_type: str = "task",
        reward_params: dict[str, Any] | None = None,
        timestep: float | None = None,
        n_substeps: int | None = None,
        horizon: int = 1000,
        gamma: float = 0.99,
        seed: int | None = None,
        random_start: bool = False,
        init_step_no: int | None = None,
        dataset_variant: str | None = None,
        dataset_path: str | None = None,
        domain_randomization_config: str | Path | Mapping | None = None,
        weight_mass: float | None = None,
        use_foot_forces: bool | None = None,
        **viewer_params: Any,
    ):
        """Build the model for ``task`` and compile it once.

        Args:
            task: one of ``TASKS`` (default: the first).
            mode: one of ``MODES`` for environments that have them.
            dataset_type: ``real``, ``perfect`` or ``preference``.
            control: ``torque`` (normalised motor torques), ``pd`` (normalised joint targets) or, for
                musculoskeletal models, ``muscle`` (excitations).
            disable_arms: remove arm (and head) joints and actuators; arms are welded at the home pose.
            reward_type: ``task`` (the task's own), ``target_velocity``, ``velocity_vector``, ``custom``
                (``reward_params={"callback": f}``) or ``none``.
            timestep, n_substeps: physics step and steps per control step (control runs at 100 Hz);
                default: the embodiment's ``TIMESTEP`` and ``N_SUBSTEPS``.
            random_start: start each episode from a random dataset state; ``init_step_no``: from that frame.
            dataset_variant: ``permissive`` or ``noncommercial`` where a task has both (default: the first).
            dataset_path: a dataset file to use instead (ours, or the original LocoMuJoCo ``.npz`` format).
            domain_randomization_config: ``"default"`` (the embodiment's shipped config), a YAML path or a
                mapping; parameters are sampled at every reset (see :mod:`loco_mujoco.core.randomization`).
            weight_mass: carry tasks only: the load's mass (kg) instead of one drawn from ``LOAD_MASSES``.
            use_foot_forces: append each foot's ground-reaction force (world frame, N) to the observation.
        """
        # Arguments first, before any work: misspelt names land in viewer_params, so those are checked too.
        parameters.check_unknown(viewer_params, parameters.env_parameter_names(type(self))
                                 | set(parameters.VIEWER_PARAMETERS), f"keyword arguments for {type(self).__name__}")
        parameters.check_values(dict(
            task=task, mode=mode, dataset_type=dataset_type, control=control, disable_arms=disable_arms,
            reward_type=reward_type, reward_params=reward_params, timestep=timestep, n_substeps=n_substeps,
            horizon=horizon, gamma=gamma, seed=seed, random_start=random_start, init_step_no=init_step_no,
            dataset_variant=dataset_variant, dataset_path=dataset_path, weight_mass=weight_mass,
            domain_randomization_config=domain_randomization_config, use_foot_forces=use_foot_forces))
        task, mode = self.resolve_task_mode(task, mode)
        self._validate_choice("dataset_type", dataset_type, self.DATASET_TYPES)
        if dataset_type != DEFAULT_DATASET_TYPE and dataset_path is None:  # agent data: its settings travel with it
            settings = self._agent_dataset_settings(task, mode, dataset_type, {
                "control": control, "disable_arms": disable_arms, "timestep": timestep, "n_substeps": n_substeps,
                "use_foot_forces": use_foot_forces, "weight_mass": weight_mass,
                "domain_randomization_config": domain_randomization_config})
            control, disable_arms, timestep, n_substeps = (settings[k] for k in (
                "control", "disable_arms", "timestep", "n_substeps"))
            use_foot_forces, weight_mass = settings["use_foot_forces"], settings["weight_mass"]
            domain_randomization_config = settings["domain_randomization_config"]
        disable_arms = True if disable_arms is None else disable_arms
        use_foot_forces = False if use_foot_forces is None else use_foot_forces
        control = control or self.DEFAULT_CONTROL
        self._validate_choice(f"control for {type(self).__name__}", control, self.CONTROLS)
        self._validate_choice("reward_type", reward_type, rw.REWARD_TYPES)
        timestep = self.TIMESTEP if timestep is None else timestep
        n_substeps = self.N_SUBSTEPS if n_substeps is None else n_substeps
        if not (timestep > 0 and int(n_substeps) >= 1):
            raise ValueError(f"timestep must be > 0 and n_substeps >= 1, got {timestep} and {n_substeps}")

        self.task_name = task
        self.mode = mode
        self.dataset_type = dataset_type
        self.control = control
        self.disable_arms = disable_arms
        self.task = self.TASKS[task]
        self.has_load = self.carries_load(task)
        if weight_mass is not None:
            if not self.has_load:
                raise ValueError(f"weight_mass is only for carry tasks; {type(self).__name__}.{task} carries nothing")
            if not (isinstance(weight_mass, (int, float)) and math.isfinite(weight_mass) and weight_mass > 0):
                raise ValueError(f"weight_mass must be a positive number of kg, got {weight_mass!r}")
        self.weight_mass = None if weight_mass is None else float(weight_mass)
        self.use_foot_forces = bool(use_foot_forces)
        self._rng = np.random.default_rng(seed)
        self._init_trajectories(random_start, init_step_no, dataset_variant, dataset_path)

        model = self.compile_spec(self.build_spec(control=control, disable_arms=disable_arms))
        joint_names = [model.joint(j).name for j in range(model.njnt)]
        observation_spec = [(f"q_{n}", n, ObservationType.JOINT_POS) for n in joint_names]
        observation_spec += [(f"dq_{n}", n, ObservationType.JOINT_VEL) for n in joint_names]

        previous_hook = mujoco.get_mju_user_warning()
        super().__init__(model, [], observation_spec, gamma, horizon, timestep=timestep,
                         n_substeps=int(n_substeps), **self._default_viewer_params(viewer_params))
        # Mushroom installs a process-wide hook that raises on any MuJoCo warning; we detect divergence
        # ourselves (see step) and leave other MuJoCo users in the process undisturbed.
        mujoco.set_mju_user_warning(previous_hook)
        self._model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        self.reuse_implicit_factor = self.REUSE_IMPLICIT_FACTOR
        if self.reuse_implicit_factor:
            implicit_reuse.check_supported(self._model)

        self._setup_observation(joint_names)
        self._randomizer = None
        self.randomization_enabled = domain_randomization_config is not None
        if domain_randomization_config is not None:
            from loco_mujoco.core.randomization import DomainRandomizer, load_config

            config = load_config(domain_randomization_config, type(self))
            self._randomizer = DomainRandomizer(config, self._model, never={"Bodies": (LOAD_BODY,)})
        self._setup_action()
        self._init_qpos = self.home_qpos(self._model)
        self.target_velocity = self.task.target_velocity
        self._target_from_dataset = False
        if reward_type != "none" and "target_velocity" not in (reward_params or {}):
            self.target_velocity = self._target_velocity_from_dataset()
        self._goal[:] = (1.0, 0.0, self.target_velocity)
        self._root_height_range = tuple(self.ROOT_HEIGHT_RANGE)
        self._reward_fn = self._make_reward(reward_type, reward_params or {})
        self._diverged_warned = False
        self._cos_max_tilt = math.cos(self.MAX_TILT)
        self._mdp_info = MDPInfo(Box(self._obs_low, self._obs_high), Box(-np.ones(self._n_act), np.ones(self._n_act)),
                                 gamma, horizon, self.dt)

    # ---- construction ---------------------------------------------------------------------------
    @classmethod
    def resolve_task_mode(cls, task: str | None, mode: str | None) -> tuple[str, str | None]:
        """``task`` and ``mode`` checked against ``TASKS`` and ``MODES``; None gives the first of each."""
        task = task if task is not None else next(iter(cls.TASKS))
        cls._validate_choice("task", task, tuple(cls.TASKS))
        if cls.MODES:
            mode = mode if mode is not None else cls.MODES[0]
            cls._validate_choice("mode", mode, cls.MODES)
        elif mode is not None:
            raise ValueError(f"{cls.__name__} has no modes, got mode={mode!r}")
        return task, mode

    @classmethod
    def dataset_subject(cls) -> DatasetSubject:
        """This embodiment as the datasets layer sees it: name, tasks, sizes, retargeting spec and model builder."""
        return DatasetSubject(name=cls.__name__, tasks=tuple(cls.TASKS), retarget=cls.RETARGET,
                              target=cls.retarget_target, sizes=tuple(cls.SIZES),
                              old_format_joints=dict(cls.OLD_FORMAT_JOINTS))

    @classmethod
    def retarget_target(cls, task: str | None = None, mode: str | None = None) -> RetargetTarget:
        """The model that motion of ``task`` (and ``mode``) is retargeted onto: the full model (arms free, the carry
        load included) in the default control mode, and its home pose. Builds no environment."""
        task, mode = cls.resolve_task_mode(task, mode)
        model, home = cls.compile_model(ModelChoice(task, mode, cls.DEFAULT_CONTROL, disable_arms=False))
        label = ".".join([cls.__name__, task] + ([mode] if mode else []))
        return RetargetTarget(label, model, home, cls.RETARGET)

    @classmethod
    def dataset_types_with_data(cls, task: str, mode: str | None = None) -> tuple[str, ...]:
        """The dataset types of ``task`` that have data: ``real`` where a recipe exists, agent data where shipped."""
        from loco_mujoco.agent_datasets import agent_recipe
        from loco_mujoco.datasets.registry import DatasetUnavailableError, variants

        types = []
        try:
            if variants(cls.dataset_subject(), task):
                types.append(DEFAULT_DATASET_TYPE)
        except DatasetUnavailableError:
            pass
        base = ".".join([cls.__name__, task] + ([mode] if mode else []))
        types += [t for t in cls.DATASET_TYPES if t != DEFAULT_DATASET_TYPE and agent_recipe(f"{base}.{t}")]
        return tuple(types)

    def _agent_dataset_settings(self, task: str, mode: str | None, dataset_type: str,
                                given: dict[str, Any]) -> dict[str, Any]:
        """``given`` env settings completed by those the agent dataset was recorded with; a conflict raises."""
        from loco_mujoco.agent_datasets import agent_recipe, recipe_settings

        name = ".".join([type(self).__name__, task] + ([mode] if mode else []) + [dataset_type])
        if agent_recipe(name) is None:
            have = self.dataset_types_with_data(task, mode)
            raise ValueError(f"{name} has no data: {type(self).__name__}.{task} has no '{dataset_type}' dataset. "
                             f"Dataset types with data for it: {', '.join(have) or 'none'}"
                             + ("; or pass dataset_path= a dataset file" if dataset_type != "real" else ""))
        out = dict(given)
        for key, value in recipe_settings(name).items():
            if given.get(key) is None:
                out[key] = value
            elif given[key] != value:
                raise ValueError(f"{name} was recorded with {key}={value!r}, but {key}={given[key]!r} was given; "
                                 f"leave {key} unset to use the dataset's setting, or use the real dataset")
        return out


    @classmethod
    def make(cls, name: str, **kwargs: Any) -> LocoEnv:
        """Build an environment from a task name ``<Env>.<task>[.<mode>][.<dataset_type>]``."""
        from loco_mujoco.core.task_names import environment_class

        parsed = parse_task_name(name)
        env_cls = environment_class(parsed.env)
        return env_cls(task=parsed.task, mode=parsed.mode, dataset_type=parsed.dataset_type, **kwargs)

    @classmethod
    def generate(cls, task: str | None = None, *rest: str, **kwargs: Any) -> LocoEnv:
        """Mushroom-RL's factory hook: ``Environment.make("UnitreeH1.walk.real")`` lands here."""
        return LocoEnv.make(".".join([cls.__name__] + ([task] if task else [next(iter(cls.TASKS))]) + list(rest)),
                            **kwargs)

    def build_spec(self, control: str, disable_arms: bool) -> mujoco.MjSpec:
        """This environment's MjSpec: its ``load_spec`` through ``assemble_spec``; remembers the home pose."""
        spec, self._home_by_joint = self.assemble_spec(self.load_spec(), self._model_choice(control, disable_arms))
        return spec

    def _model_choice(self, control: str, disable_arms: bool) -> ModelChoice:
        """What this environment's model depends on; embodiments with model switches add them as options."""
        return ModelChoice(self.task_name, self.mode, control, disable_arms, self.use_foot_forces)

    def home_qpos(self, model: mujoco.MjModel) -> np.ndarray:
        """The home pose (from the model's keyframe) in ``model``'s qpos layout."""
        return qpos_in_layout(self._home_by_joint, model)

    @staticmethod
    def load_model(xml_file: Any) -> mujoco.MjModel:
        """Accept an already compiled MjModel (we build ours from an MjSpec) besides Mushroom's inputs."""
        if isinstance(xml_file, mujoco.MjModel):
            return xml_file
        if isinstance(xml_file, mujoco.MjSpec):
            return xml_file.compile()
        return MuJoCo.load_model(xml_file)

    def _setup_observation(self, joint_names: list[str]) -> None:
        """Index arrays from qpos/qvel into the observation; the root's x and y are left out."""
        m = self._model
        root = m.joint(spec_edit.ROOT_JOINT)
        self.obs_helper.remove_obs(f"q_{spec_edit.ROOT_JOINT}", 0)
        self.obs_helper.remove_obs(f"q_{spec_edit.ROOT_JOINT}", 1)
        skip = {int(root.qposadr[0]), int(root.qposadr[0]) + 1}
        qpos_idx, qvel_idx = [], []
        for name in joint_names:
            j = m.joint(name)
            width_q, width_v = spec_edit.qpos_width(j.type[0]), spec_edit.dof_width(j.type[0])
            qpos_idx += [i for i in range(int(j.qposadr[0]), int(j.qposadr[0]) + width_q) if i not in skip]
            qvel_idx += list(range(int(j.dofadr[0]), int(j.dofadr[0]) + width_v))
        self._qpos_idx = np.array(qpos_idx, dtype=np.intp)
        self._qvel_idx = np.array(qvel_idx, dtype=np.intp)
        self._n_qpos_obs = len(qpos_idx)
        n_joint_obs = len(qpos_idx) + len(qvel_idx)
        self._qpos_view, self._qvel_view = self._data.qpos, self._data.qvel  # fixed buffers: cache views
        self._n_foot = 0
        if self.use_foot_forces:
            ids = [m.sensor(f"foot_force_{f}").id for f in self.foot_bodies()]
            self._foot_sensor_idx = np.concatenate([np.arange(m.sensor_adr[i], m.sensor_adr[i] + 3) for i in ids])
            self._n_foot = len(self._foot_sensor_idx)
            self.obs_helper.add_obs("foot_forces", self._n_foot)
            n_joint_obs += self._n_foot
            self._sensordata = self._data.sensordata
        extras = self.extra_observations()
        for name, dim in extras:
            self.obs_helper.add_obs(name, dim)
        self._n_extra = sum(dim for _, dim in extras)
        self._extra = np.zeros(self._n_extra)  # goal, body-size code ...: written at reset, copied per step
        self._goal = self._extra[:3] if self.GOAL_OBSERVATION else np.zeros(3)
        self._obs_buffer_len = n_joint_obs + self._n_extra
        self._extra_offset = n_joint_obs

        self._obs_idx = {k: np.asarray(v, dtype=np.intp) for k, v in self.obs_helper.obs_idx_map.items()}
        low = np.full(self._obs_buffer_len, -np.inf)
        high = np.full(self._obs_buffer_len, np.inf)
        quat = self._obs_idx[f"q_{spec_edit.ROOT_JOINT}"][1:5]  # a unit quaternion stays in [-1, 1]
        low[quat], high[quat] = -1.0, 1.0
        if self.GOAL_OBSERVATION:
            goal = self._obs_idx["goal_velocity"]
            low[goal[:2]], high[goal[:2]] = -1.0, 1.0
        self._obs_low, self._obs_high = low, high
        root_q = self._obs_idx[f"q_{spec_edit.ROOT_JOINT}"]
        self._root_z_i, self._qx_i, self._qy_i = int(root_q[0]), int(root_q[2]), int(root_q[3])
        self._vel_root_idx = self._obs_idx[f"dq_{spec_edit.ROOT_JOINT}"]

    def extra_observations(self) -> list[tuple[str, int]]:
        """Named observation entries after the joint states, constant within an episode (goal, load mass)."""
        return ([("goal_velocity", 3)] if self.GOAL_OBSERVATION else []) + ([("weight", 1)] if self.has_load else [])

    def _setup_action(self) -> None:
        """Actions in [-1, 1] map linearly onto each actuator's ctrlrange (torque or joint target)."""
        m = self._model
        if not np.all(m.actuator_ctrllimited):
            raise ValueError("every actuator needs a ctrlrange to normalise actions")
        lo, hi = m.actuator_ctrlrange[:, 0].copy(), m.actuator_ctrlrange[:, 1].copy()
        self._ctrl_center = (hi + lo) / 2.0
        self._ctrl_half = (hi - lo) / 2.0
        self._n_act = m.nu
        self._ctrl_view = self._data.ctrl
        self.actuator_names = [m.actuator(i).name for i in range(m.nu)]

    def _make_reward(self, reward_type: str, params: dict[str, Any]) -> rw.RewardFn:
        if reward_type == "task":
            reward_type = self.TASK_REWARD
        vel = self._vel_root_idx
        allowed = {"target_velocity": {"target_velocity"}, "custom": {"callback"}}.get(reward_type, set())
        unknown = set(params) - allowed
        if unknown:
            raise ValueError(f"unknown reward_params {sorted(unknown)} for reward_type '{reward_type}'; "
                             f"valid: {sorted(allowed) or 'none'}")
        quat = self._obs_idx[f"q_{spec_edit.ROOT_JOINT}"][1:5]  # (w, x, y, z) after the root height
        if reward_type == "target_velocity":
            return rw.TargetVelocityReward(vel[:2], quat, params.get("target_velocity", self.target_velocity))
        if reward_type == "velocity_vector":
            if not self.GOAL_OBSERVATION:
                raise ValueError(f"reward_type 'velocity_vector' needs a goal in the observation; "
                                 f"{type(self).__name__} has none. Use 'target_velocity'.")
            return rw.VelocityVectorReward(vel[:2], quat, self._obs_idx["goal_velocity"], self.target_velocity)
        if reward_type == "custom":
            if "callback" not in params:
                raise ValueError("reward_type 'custom' needs reward_params={'callback': f(state, action, next_state)}")
            return rw.CustomReward(params["callback"])
        return rw.NoReward()

    def _target_velocity_from_dataset(self) -> float:
        """The dataset's mean forward speed; the task's nominal speed, with a warning, if no dataset can be had."""
        from loco_mujoco.datasets.registry import DatasetUnavailableError
        from loco_mujoco.datasets.sources.fetch import CacheDirError

        try:
            speed = self.dataset_target_velocity()
            self._target_from_dataset = True
            return speed
        except (DatasetUnavailableError, OSError) as err:  # no recipe, or sources neither local nor downloadable
            if self.dataset_path is not None or isinstance(err, CacheDirError):
                raise  # the user's own file, or a cache variable pointing nowhere: never papered over
            warnings.warn(f"{type(self).__name__}.{self.task_name}: no dataset to take the target speed from "
                          f"({err}); using the nominal {self.task.target_velocity} m/s", stacklevel=3)
            return self.task.target_velocity

    @staticmethod
    def _validate_choice(what: str, value: Any, valid: tuple[str, ...]) -> None:
        if value not in valid:
            raise ValueError(f"invalid {what} {value!r}; valid: {', '.join(map(str, valid))}")

    @staticmethod
    def _default_viewer_params(params: dict[str, Any]) -> dict[str, Any]:
        if not os.environ.get("DISPLAY"):
            params = {"headless": True, **params}
        return params

    # ---- the MDP --------------------------------------------------------------------------------
    def seed(self, seed: int | None) -> None:
        """Seed this environment's own generator (goal sampling, later: start states, randomization)."""
        self._rng = np.random.default_rng(seed)

    def reset(self, obs: np.ndarray | None = None) -> np.ndarray:
        """Start an episode from ``obs`` (an observation in this env's layout) if given, else from a dataset
        state (``init_step_no`` or ``random_start``), else from the home pose."""
        m, d = self._model, self._data
        frame = None if obs is not None else self._start_frame()
        self.episode_start_frame = frame  # the dataset frame this episode starts from (None: home pose or obs)
        self._prepare_episode(frame)
        mujoco.mj_resetData(m, d)
        d.qpos[:] = self._init_qpos
        self._reset_goal()
        if obs is not None:
            self._write_observation(obs)
        elif frame is not None:
            self._set_dataset_state(frame)
        mujoco.mj_forward(m, d)
        self._obs = self._build_observation()
        return self._obs

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, dict[str, Any]]:
        action = self.apply_action(action)
        self.step_physics()
        return self.finish_step(action)

    def apply_action(self, action: np.ndarray) -> np.ndarray:
        """The first part of ``step``: check ``action``, clip it to [-1, 1] and write the ctrl it commands.

        Returns the clipped copy, which ``finish_step`` takes. ``step(a)`` is ``apply_action``, ``step_physics``,
        ``finish_step``; a batched collector calls the three itself to run the physics of several environments
        in threads (``mj_step`` releases the GIL).
        """
        action = self._check_action(action)
        np.clip(action, -1.0, 1.0, out=action)
        self._ctrl_view[:] = self.action_to_ctrl(action)
        return action

    def finish_step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, dict[str, Any]]:
        """The last part of ``step``, after ``step_physics``: observation, absorbing flag, reward and info, for the
        clipped ``action`` that ``apply_action`` returned."""
        obs = self._build_observation()
        diverged = not _sum_is_finite(obs)
        if diverged:
            diverged = self._handle_divergence(obs)
            if diverged:
                obs = self._obs.copy()
        absorbing = diverged or self.is_absorbing(obs)
        reward = self.reward(self._obs, action, obs, absorbing)
        info = {
            "root_pos": self._qpos_view[:3].copy(),
            "root_vel": self._qvel_view[:3].copy(),
            "fallen": absorbing,
            "physics_diverged": diverged,
        }
        self._obs = obs
        return obs, reward, absorbing, info

    def step_physics(self) -> None:
        """Advance the physics by one control step (``n_substeps`` physics steps) with the current ``ctrl``."""
        m, d = self._model, self._data
        if self.reuse_implicit_factor and m.opt.integrator in implicit_reuse.IMPLICIT_INTEGRATORS:
            implicit_reuse.step_reusing_factor(m, d, self._n_substeps)
        else:
            mujoco.mj_step(m, d, self._n_substeps)

    def _check_action(self, action: Any) -> np.ndarray:
        a = np.array(action, dtype=np.float64)  # a copy: the caller's array is never modified
        if a.shape != (self._n_act,):
            raise ValueError(f"action must have shape ({self._n_act},) for {type(self).__name__} "
                             f"({self.control} control), got shape {a.shape}")
        if not _sum_is_finite(a):
            bad = np.flatnonzero(~np.isfinite(a))
            if bad.size:
                names = [self.actuator_names[i] for i in bad]
                raise ValueError(f"action contains NaN or inf at indices {bad.tolist()} ({', '.join(names)}); "
                                 f"actions must be finite numbers in [-1, 1]")
        return a

    def action_to_ctrl(self, action: np.ndarray) -> np.ndarray:
        """The MuJoCo ctrl (torque, or joint target in PD mode) that a normalised action commands."""
        return self._ctrl_center + self._ctrl_half * action

    def ctrl_to_action(self, ctrl: np.ndarray) -> np.ndarray:
        """The normalised action that commands ``ctrl``; e.g. PD targets of a pose."""
        return (np.asarray(ctrl, dtype=np.float64) - self._ctrl_center) / self._ctrl_half

    def _handle_divergence(self, obs: np.ndarray) -> bool:
        if np.all(np.isfinite(obs)):  # a finite sum overflowing: not a divergence
            return False
        if not self._diverged_warned:
            warnings.warn(f"{type(self).__name__}: the simulation diverged (non-finite state); the episode was "
                          "terminated as absorbing and info['physics_diverged'] is True. Reset before stepping "
                          "again. Frequent divergence means the timestep is too large for this model.",
                          PhysicsDivergedWarning, stacklevel=3)
            self._diverged_warned = True
        return True

    def _build_observation(self) -> np.ndarray:
        obs = np.empty(self._obs_buffer_len)
        n = self._n_qpos_obs
        obs[:n] = self._qpos_view[self._qpos_idx]
        m = n + len(self._qvel_idx)
        obs[n:m] = self._qvel_view[self._qvel_idx]
        if self._n_foot:  # ground reaction on each foot: minus the force the foot exerts on the floor
            np.negative(self._sensordata[self._foot_sensor_idx], out=obs[m:m + self._n_foot])
            m += self._n_foot
        if self._n_extra:
            obs[m:] = self._extra
        return obs

    def _write_observation(self, obs: np.ndarray) -> None:
        obs = np.asarray(obs, dtype=np.float64)
        if obs.shape != (self._obs_buffer_len,):
            raise ValueError(f"observation must have shape ({self._obs_buffer_len},), got {obs.shape}")
        n = self._n_qpos_obs
        n_state = n + len(self._qvel_idx)
        if not np.all(np.isfinite(obs[:n_state])):
            raise ValueError("the joint states of the observation to reset from contain NaN or inf")
        self._data.qpos[self._qpos_idx] = obs[:n]
        self._data.qvel[self._qvel_idx] = obs[n:n_state]
        if self._n_extra:  # foot forces are measured, not set; NaN extras (an unknown load) keep this episode's
            extra = obs[n_state + self._n_foot :]
            known = np.isfinite(extra)
            self._extra[known] = extra[known]
            self._extra_written()

    def _extra_written(self) -> None:
        """Called when a reset observation set the extra entries; subclasses apply them (e.g. the body size)."""

    def _prepare_episode(self, frame: int | None) -> None:
        """Called first at every reset with the dataset frame the episode starts from (or None): choose this
        episode's body (size, load) and dynamics (randomization), all in the compiled model, in place."""
        restored = self._randomizer is not None and self._randomizer.restore()
        changed = self._select_body(frame) or restored
        if self.has_load:
            mass = self.weight_mass if self.weight_mass is not None else \
                LOAD_MASSES[int(self._rng.integers(len(LOAD_MASSES)))]
            self.set_load_mass(mass, update=False)
            changed = True
        if self._randomizer is not None and self.randomization_enabled:
            self._randomizer.apply(self._rng, self._data)  # recomputes the derived constants itself
        elif changed:
            mujoco.mj_setConst(self._model, self._data)

    def _select_body(self, frame: int | None) -> bool:
        """Pick this episode's body before randomization; True if the model changed (e.g. a body size)."""
        return False

    def set_load_mass(self, mass: float, update: bool = True) -> None:
        """Give the carried load ``mass`` kg (a box, inertia to match) and show it in the observation."""
        b = self._model.body(LOAD_BODY).id
        self._model.body_mass[b] = mass
        self._model.body_inertia[b] = box_inertia(mass)
        self._extra[self._obs_idx["weight"] - self._extra_offset] = mass
        self.current_load_mass = float(mass)
        if update:
            mujoco.mj_setConst(self._model, self._data)

    # ---- masks ----------------------------------------------------------------------------------
    def observation_groups(self) -> dict[str, np.ndarray]:
        """Indices of each observation group this environment has (see ``OBSERVATION_GROUPS``)."""
        names = list(self._obs_idx)
        groups = {"positions": np.concatenate([self._obs_idx[k] for k in names if k.startswith("q_")]),
                  "velocities": np.concatenate([self._obs_idx[k] for k in names if k.startswith("dq_")])}
        for group, key in (("foot_forces", "foot_forces"), ("weight", "weight"), ("env_type", "env_type"),
                           ("goal", "goal_velocity")):
            if key in self._obs_idx:
                groups[group] = self._obs_idx[key].copy()
        return groups

    def get_mask(self, groups: Iterable[str]) -> np.ndarray:
        """Boolean mask over the observation that hides ``groups`` (False there, True elsewhere).

        Groups: ``positions``, ``velocities``, ``foot_forces``, ``weight`` (carried load), ``env_type``
        (body size), ``goal``, as far as this environment has them; e.g. ``obs[env.get_mask(["weight"])]``
        is the partially observable task's observation.
        """
        if isinstance(groups, str):
            groups = [groups]
        available = self.observation_groups()
        mask = np.ones(self._obs_buffer_len, dtype=bool)
        for group in groups:
            if group not in available:
                known = "" if group in OBSERVATION_GROUPS else f" (groups are {', '.join(OBSERVATION_GROUPS)})"
                raise ValueError(f"{type(self).__name__} has no observation group {group!r}{known}; "
                                 f"this environment has: {', '.join(available)}")
            mask[available[group]] = False
        return mask

    def get_kinematic_obs_mask(self) -> np.ndarray:
        """Mask of the kinematic entries (joint positions and velocities): what a discriminator compares with
        motion data, which has no forces, loads, sizes or goals."""
        groups = self.observation_groups()
        return self.get_mask([g for g in groups if g not in ("positions", "velocities")])

    def _reset_goal(self) -> None:
        """Embodiments with a goal in the observation choose it here (default: forward at target speed)."""

    def is_absorbing(self, obs: np.ndarray) -> bool:
        """Fallen: root height outside ``root_height_range`` or root tilted more than ``MAX_TILT``."""
        return self._fallen(obs, *self._root_height_range)

    def _fallen(self, obs: np.ndarray, lo: float, hi: float) -> bool:
        """Root height of ``obs`` outside [lo, hi], or its z axis tilted more than ``MAX_TILT``."""
        z = obs[self._root_z_i]
        qx, qy = obs[self._qx_i], obs[self._qy_i]
        up_z = 1.0 - 2.0 * (qx * qx + qy * qy)  # z component of the root's z axis in the world
        return bool(z < lo or z > hi or up_z < self._cos_max_tilt)

    def reward(self, obs: np.ndarray, action: np.ndarray, next_obs: np.ndarray, absorbing: bool) -> float:
        return self._reward_fn(obs, action, next_obs)

    # ---- queries --------------------------------------------------------------------------------
    def get_obs_idx(self, name: str) -> np.ndarray:
        """Indices of observation entry ``name`` (``q_<joint>``, ``dq_<joint>``, ``q_root`` ...)."""
        if name not in self._obs_idx:
            close = difflib.get_close_matches(name, list(self._obs_idx), n=3)
            hint = f" Did you mean {', '.join(map(repr, close))}?" if close else ""
            raise KeyError(f"no observation entry '{name}' in {type(self).__name__}.{hint} "
                           f"Valid: {', '.join(self._obs_idx)}")
        return self._obs_idx[name].copy()

    @property
    def root_height_range(self) -> tuple[float, float]:
        """Root heights (m) outside which the robot counts as fallen, for the current body size."""
        return self._root_height_range

    @property
    def obs_names(self) -> list[str]:
        """Observation entries in order."""
        return list(self._obs_idx)

    @property
    def model(self) -> mujoco.MjModel:
        return self._model

    @property
    def data(self) -> mujoco.MjData:
        return self._data

    def render_rgb(self, width: int = 640, height: int = 480) -> np.ndarray:
        """An offscreen RGB frame (H, W, 3) from a camera that follows the robot."""
        renderer = getattr(self, "_rgb_renderer", None)
        if renderer is None or (renderer.width, renderer.height) != (width, height):
            if renderer is not None:
                renderer.close()
            self._model.vis.global_.offwidth = max(self._model.vis.global_.offwidth, width)
            self._model.vis.global_.offheight = max(self._model.vis.global_.offheight, height)
            renderer = self._rgb_renderer = mujoco.Renderer(self._model, height, width)
            cam = self._rgb_camera = mujoco.MjvCamera()
            cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
            cam.trackbodyid = int(self._model.joint(spec_edit.ROOT_JOINT).bodyid[0])
            cam.distance = 2.0 * max(float(self._model.stat.extent), 0.75)
            cam.elevation, cam.azimuth = -15.0, 135.0
        renderer.update_scene(self._data, camera=self._rgb_camera)
        return renderer.render()

    def stop(self) -> None:
        renderer = getattr(self, "_rgb_renderer", None)
        if renderer is not None:
            renderer.close()
            self._rgb_renderer = None
        super().stop()
