"""Task rewards. In an imitation benchmark the reward is an evaluation metric, not a training signal.

A reward is a callable ``f(state, action, next_state) -> float`` on observations in the env's layout.

The velocity rewards measure speed in the root's own heading frame (the root's x axis projected on the
floor), never along the world's x axis: an episode may start from any dataset frame, facing any way, and
the expert's own frames must earn what a robot doing the same thing earns. The tolerance scales with the
target speed, so standing still earns almost nothing: ``exp(-(1 / SPEED_TOLERANCE)^2) = 0.0019`` per step.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

RewardFn = Callable[[np.ndarray, np.ndarray, np.ndarray], float]

REWARD_TYPES = ("task", "target_velocity", "velocity_vector", "custom", "none")
SPEED_TOLERANCE = 0.4  # the reward's width as a fraction of the target speed: 0.4 * v* off the target earns 1/e
MIN_TOLERANCE = 0.1  # m/s: the width never shrinks below this, so a slow target is still reachable


def heading_xy(qw: float, qx: float, qy: float, qz: float) -> tuple[float, float]:
    """Unit vector of the root's x axis projected on the floor (its heading), from its (w, x, y, z) quaternion."""
    hx = 1.0 - 2.0 * (qy * qy + qz * qz)
    hy = 2.0 * (qx * qy + qw * qz)
    norm = math.hypot(hx, hy)
    if norm < 1e-9:  # root x axis vertical: no heading; treat as facing +x
        return 1.0, 0.0
    return hx / norm, hy / norm


def speed_tolerance(target_speed: float) -> float:
    """Width (m/s) of the velocity rewards' Gaussian for a target speed."""
    return max(SPEED_TOLERANCE * abs(target_speed), MIN_TOLERANCE)


class NoReward:
    """Zero everywhere: for pure imitation where the learner must not see a task signal."""

    def __call__(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> float:
        return 0.0


class TargetVelocityReward:
    """``exp(-((v_f - v*) / w)^2)``: ``v_f`` the root's horizontal velocity along its own heading after the step,
    ``w = max(0.4 v*, 0.1 m/s)``."""

    def __init__(self, vxy_index: np.ndarray, quat_index: np.ndarray, target_velocity: float):
        self.vx, self.vy = (int(i) for i in vxy_index)
        self.qw, self.qx, self.qy, self.qz = (int(i) for i in quat_index)
        self.target_velocity = float(target_velocity)

    @property
    def target_velocity(self) -> float:
        return self._target

    @target_velocity.setter
    def target_velocity(self, value: float) -> None:
        self._target = float(value)
        self._inv_width = 1.0 / speed_tolerance(self._target)

    def forward_speed(self, obs: np.ndarray) -> float:
        """Horizontal root velocity (m/s) along the root's heading."""
        hx, hy = heading_xy(obs[self.qw], obs[self.qx], obs[self.qy], obs[self.qz])
        return float(obs[self.vx]) * hx + float(obs[self.vy]) * hy

    def __call__(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> float:
        err = (self.forward_speed(next_state) - self._target) * self._inv_width
        return math.exp(-err * err)


class VelocityVectorReward:
    """``exp(-(||v_h - v*_h|| / w)^2)``: ``v_h`` the root's horizontal velocity in its heading frame, ``v*_h`` the
    goal (cos, sin, speed) of the observation, also in that frame; ``w = max(0.4 s, 0.1 m/s)`` for the task's
    nominal speed ``s``."""

    def __init__(self, vxy_index: np.ndarray, quat_index: np.ndarray, goal_index: np.ndarray, nominal_speed: float):
        self.vx, self.vy = (int(i) for i in vxy_index)
        self.qw, self.qx, self.qy, self.qz = (int(i) for i in quat_index)
        self.cos_i, self.sin_i, self.speed_i = (int(i) for i in goal_index)
        self._inv_width = 1.0 / speed_tolerance(nominal_speed)

    def __call__(self, state: np.ndarray, action: np.ndarray, next_state: np.ndarray) -> float:
        s = next_state
        hx, hy = heading_xy(s[self.qw], s[self.qx], s[self.qy], s[self.qz])
        vx, vy = float(s[self.vx]), float(s[self.vy])
        forward, left = vx * hx + vy * hy, -vx * hy + vy * hx  # world velocity in the heading frame
        speed = float(s[self.speed_i])
        ex = (forward - speed * float(s[self.cos_i])) * self._inv_width
        ey = (left - speed * float(s[self.sin_i])) * self._inv_width
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
