"""Four body sizes of a human embodiment: modes ``1``-``4`` pick one, mode ``all`` samples one per episode.

Sizes are geometric scalings of the adult model by stature (see :mod:`loco_mujoco.models.scaling`).
Children's statures are the medians of boys and girls in the WHO growth standards (2 years: 86 cm,
5 years: 110 cm) and the WHO 2007 growth reference (12 years: 150 cm); the adult is the model itself.
In mode ``all`` the four compiled models share one MjModel: at reset the arrays that differ between
sizes are copied into it (no recompilation), and a one-hot size code is appended to the observation.
"""

from __future__ import annotations

from typing import Any, ClassVar

import mujoco
import numpy as np

from loco_mujoco.core import rewards as rw
from loco_mujoco.models.scaling import scale_spec

SIZES: tuple[str, ...] = ("1", "2", "3", "4")
SIZE_MODES: tuple[str, ...] = ("all", *SIZES)
SIZE_AGES = {"1": "about 2 years", "2": "about 5 years", "3": "about 12 years", "4": "adult"}
CHILD_STATURE_M = {"1": 0.86, "2": 1.10, "3": 1.50}
_STAT_FIELDS = ("meaninertia", "meanmass", "meansize", "extent")


class BodySizesMixin:
    """Put before the embodiment class: ``class HumanoidTorque4Ages(BodySizesMixin, HumanoidTorque)``."""

    MODES: ClassVar[tuple[str, ...]] = SIZE_MODES
    SIZES: ClassVar[tuple[str, ...]] = SIZES
    ADULT_STATURE_M: ClassVar[float] = 1.78

    @classmethod
    def statures(cls) -> dict[str, float]:
        """Standing height (m) of each size."""
        return {**CHILD_STATURE_M, "4": cls.ADULT_STATURE_M}

    @classmethod
    def size_factor(cls, size: str) -> float:
        """Length scale of ``size`` relative to the adult model."""
        return cls.statures()[size] / cls.ADULT_STATURE_M

    def __init__(self, *args: Any, **kwargs: Any):
        self._spec_size: str | None = None
        super().__init__(*args, **kwargs)
        if self.mode == "all":
            self._setup_all_sizes()
            self._apply_size(SIZES[-1])
        else:
            self._root_height_range = self._height_range(self.size_factor(self.mode))

    def load_spec(self) -> mujoco.MjSpec:
        spec = super().load_spec()
        size = self._spec_size or (self.mode if self.mode != "all" else SIZES[-1])
        if size != SIZES[-1]:
            scale_spec(spec, self.size_factor(size))
        return spec

    def extra_observations(self) -> list[tuple[str, int]]:
        extra = super().extra_observations()
        return extra + [("env_type", len(SIZES))] if self.mode == "all" else extra

    def _height_range(self, factor: float) -> tuple[float, float]:
        """The fall bounds of a body ``factor`` times the adult's height."""
        lo, hi = self.ROOT_HEIGHT_RANGE
        return lo * factor, hi * factor

    # ---- mode "all" -------------------------------------------------------------------------------
    def _compile_size(self, size: str) -> tuple[mujoco.MjModel, np.ndarray]:
        self._spec_size = size
        try:
            spec = self.build_spec(control=self.control, disable_arms=self.disable_arms)
            spec.option.integrator = self.INTEGRATOR
            model = spec.compile()
            return model, self.home_qpos(model)
        finally:
            self._spec_size = None

    def _setup_all_sizes(self) -> None:
        compiled = {size: self._compile_size(size) for size in SIZES}
        base = compiled[SIZES[-1]][0]
        fields = [name for name in dir(base) if not name.startswith("_")
                  and isinstance(getattr(base, name), np.ndarray)
                  and any(not np.array_equal(getattr(base, name), getattr(m, name)) for m, _ in compiled.values())]
        self._size_arrays = {size: {name: getattr(m, name).copy() for name in fields} for size, (m, _) in
                             compiled.items()}
        self._size_stats = {size: {k: float(getattr(m.stat, k)) for k in _STAT_FIELDS} for size, (m, _) in
                            compiled.items()}
        self._size_home = {size: home for size, (_, home) in compiled.items()}
        self._size_code_idx = self._obs_idx["env_type"]
        self._code_slice = slice(int(self._size_code_idx[0] - self._extra_offset),
                                 int(self._size_code_idx[-1] - self._extra_offset) + 1)
        self._factors = np.array([self.size_factor(s) for s in SIZES])
        self.current_size = SIZES[-1]

    def _apply_size(self, size: str) -> None:
        """Make the simulated body this size: copy its model arrays, home pose, fall bounds, code, target."""
        m = self._model
        for name, value in self._size_arrays[size].items():
            getattr(m, name)[...] = value
        for name, value in self._size_stats[size].items():
            setattr(m.stat, name, value)
        self._init_qpos = self._size_home[size]
        k = SIZES.index(size)
        code = self._extra[self._code_slice]
        code[:] = 0.0
        code[k] = 1.0
        self._root_height_range = self._height_range(self._factors[k])
        per_size = self._dataset_per_size_speed(size)
        if per_size is not None and isinstance(self._reward_fn, rw.TargetVelocityReward):
            self._reward_fn.target_velocity = per_size
        self.current_size = size

    def _dataset_per_size_speed(self, size: str) -> float | None:
        if not getattr(self, "_target_from_dataset", False) or self._dataset is None:
            return None
        return float(self._dataset.metadata["per_size"][size]["mean_forward_speed"])

    def _set_reward_context(self, frame: int | None) -> None:
        if self.mode != "all" or not isinstance(self._reward_fn, rw.TargetVelocityReward):
            return
        size = self._frame_size(frame) if frame is not None else getattr(self, "current_size", None)
        per_size = self._dataset_per_size_speed(size) if size is not None else None
        if per_size is not None:
            self._reward_fn.target_velocity = per_size

    def _frame_size(self, frame: int) -> str:
        traj = int(self.dataset.trajectory_of_frame(frame))
        return str(self.dataset.metadata["sizes"][traj])

    def _select_body(self, frame: int | None) -> bool:
        if self.mode != "all":
            return super()._select_body(frame)
        size = self._frame_size(frame) if frame is not None else SIZES[int(self._rng.integers(len(SIZES)))]
        self._apply_size(size)
        return False  # the copied arrays include every derived constant of that size's compiled model

    def _extra_written(self) -> None:
        super()._extra_written()
        if self.mode == "all":
            code = self._extra[self._code_slice]
            if not (np.isclose(code.sum(), 1.0) and np.isin(code, (0.0, 1.0)).all()):
                raise ValueError(f"env_type entries of the reset observation must be one-hot over sizes "
                                 f"{SIZES}, got {code.tolist()}")
            self._apply_size(SIZES[int(np.argmax(code))])

    def _dataset_extras(self, frames: np.ndarray | slice, n: int) -> list[np.ndarray]:
        extras = super()._dataset_extras(frames, n)
        if self.mode != "all":
            return extras
        ds = self.dataset
        sizes = np.repeat([SIZES.index(s) for s in ds.metadata["sizes"]], np.diff(ds.split_points))
        return extras + [np.eye(len(SIZES))[sizes[frames]]]

    def is_absorbing(self, obs: np.ndarray) -> bool:
        if self.mode != "all":
            return super().is_absorbing(obs)
        # the observation's own size: replays mix sizes
        return self._fallen(obs, *self._height_range(float(self._factors @ obs[self._size_code_idx])))
