"""Gymnasium interface: ``gymnasium.make("LocoMujoco", env_name="UnitreeH1.walk", render_mode="rgb_array")``."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from loco_mujoco.core.loco_env import LocoEnv

GYMNASIUM_ID = "LocoMujoco"


class LocoGymEnv(gym.Env):
    """A LocoEnv seen through the Gymnasium API.

    ``terminated`` is True when the robot has fallen (an absorbing state), ``truncated`` when the
    episode reaches the task horizon. Observations and actions are float32.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 100}

    def __init__(self, env_name: str, render_mode: str | None = None, width: int = 640, height: int = 480,
                 **kwargs: Any):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode {render_mode!r} not supported; valid: {self.metadata['render_modes']} "
                             "or None")
        self.env_name = env_name
        self.unwrapped_loco = LocoEnv.make(env_name, **kwargs)
        self.render_mode = render_mode
        self._size = (width, height)
        info = self.unwrapped_loco.info
        self.metadata = {**self.metadata, "render_fps": int(round(1.0 / info.dt))}
        self.observation_space = spaces.Box(info.observation_space.low.astype(np.float32),
                                            info.observation_space.high.astype(np.float32), dtype=np.float32)
        self.action_space = spaces.Box(info.action_space.low.astype(np.float32),
                                       info.action_space.high.astype(np.float32), dtype=np.float32)
        self.horizon = info.horizon
        self._steps = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Reset; ``seed`` seeds the whole rollout. ``options={"obs": obs}`` starts from a given state."""
        super().reset(seed=seed)
        if seed is not None:
            self.unwrapped_loco.seed(seed)
        options = options or {}
        unknown = set(options) - {"obs"}
        if unknown:
            raise ValueError(f"unknown reset options {sorted(unknown)}; valid: ['obs']")
        obs = self.unwrapped_loco.reset(options.get("obs"))
        self._steps = 0
        return obs.astype(np.float32), {}

    def step(self, action: np.ndarray):
        obs, reward, absorbing, info = self.unwrapped_loco.step(action)
        self._steps += 1
        truncated = self._steps >= self.horizon and not absorbing
        return obs.astype(np.float32), float(reward), bool(absorbing), truncated, info

    def render(self) -> np.ndarray | None:
        if self.render_mode == "rgb_array":
            return self.unwrapped_loco.render_rgb(*self._size)
        return None

    def close(self) -> None:
        self.unwrapped_loco.stop()

    def get_obs_idx(self, name: str) -> np.ndarray:
        return self.unwrapped_loco.get_obs_idx(name)

    # ---- the dataset, as on LocoEnv ---------------------------------------------------------------
    @property
    def dataset(self):  # noqa: ANN201 - TrajectoryDataset, imported lazily
        return self.unwrapped_loco.dataset

    def create_dataset(self) -> dict[str, np.ndarray]:
        """Expert transitions in this env's observation layout (float32, like its observations)."""
        data = self.unwrapped_loco.create_dataset()
        return {k: v.astype(np.float32) if v.dtype == np.float64 else v for k, v in data.items()}

    def play_trajectory(self, *args: Any, **kwargs: Any) -> dict[str, Any]:
        return self.unwrapped_loco.play_trajectory(*args, **kwargs)

    def play_trajectory_from_velocity(self, *args: Any, **kwargs: Any) -> dict[str, Any]:
        return self.unwrapped_loco.play_trajectory_from_velocity(*args, **kwargs)

    def get_mask(self, groups: Any) -> np.ndarray:
        """Boolean mask over the observation hiding ``groups`` (see ``LocoEnv.get_mask``)."""
        return self.unwrapped_loco.get_mask(groups)

    def get_kinematic_obs_mask(self) -> np.ndarray:
        """Boolean mask of the joint positions and velocities in the observation."""
        return self.unwrapped_loco.get_kinematic_obs_mask()


def register_gymnasium() -> None:
    """Register the ``LocoMujoco`` id (idempotent)."""
    if GYMNASIUM_ID not in gym.registry:
        gym.register(id=GYMNASIUM_ID, entry_point="loco_mujoco.gymnasium_env:LocoGymEnv",
                     disable_env_checker=False)
