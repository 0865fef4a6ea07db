"""Task rewards. In an imitation benchmark the reward is an evaluation metric, not a training signal.

A reward is a callable ``f(state, action, next_state) -> float`` on observations in the env's layout.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

RewardFn = Callable[[np.ndarray, np.ndarray, np.ndarray], float]

REWARD_TYPES = ("task", "target_velocity", "velocity_vector", "custom", "none")


class NoReward:
    """Zero everywhere: for pure imitation where the learner must not see a task signal."""

    def __call__(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> float:
        return 0.0


class TargetVelocityReward:
    """``exp(-(v_x - v*)^2)`` with ``v_x`` the root's world-frame forward velocity after the step."""

    def __init__(self, vx_index: int, target_velocity: float):
        self.vx_index = int(vx_index)
        self.target_velocity = float(target_velocity)

    def __call__(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> float:
        err = float(next_state[self.vx_index]) - self.target_velocity
        return math.exp(-err * err)


class VelocityVectorReward:
    """``exp(-||v_xy - v*_xy||^2)`` where the goal (cos, sin, speed) is part of the observation."""

    def __init__(self, vxy_index: np.ndarray, goal_index: np.ndarray):
        self.vx, self.vy = (int(i) for i in vxy_index)
        self.cos_i, self.sin_i, self.speed_i = (int(i) for i in goal_index)

    def __call__(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> float:
        speed = float(next_state[self.speed_i])
        ex = float(next_state[self.vx]) - speed * float(next_state[self.cos_i])
        ey = float(next_state[self.vy]) - speed * float(next_state[self.sin_i])
        return math.exp(-(ex * ex + ey * ey))


class CustomReward:
    """Wraps a user callback and checks that it returns one finite number."""

    def __init__(self, callback: RewardFn):
        if not callable(callback):
            raise ValueError(f"reward_params['callback'] must be callable f(state, action, next_state), "
                             f"got {type(callback).__name__}")
        self.callback = callback

    def __call__(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> float:
        value = self.callback(state, action, next_state)
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"custom reward callback must return a float, got {value!r}") from None
        if not math.isfinite(value):
            raise ValueError(f"custom reward callback returned a non-finite value: {value}")
        return value
