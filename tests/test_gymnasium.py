import gymnasium
import numpy as np
import pytest
from conftest import BASE_TASKS
from gymnasium.utils.env_checker import check_env

import loco_mujoco  # noqa: F401  (registers the LocoMujoco id)


@pytest.mark.parametrize("name", BASE_TASKS)
def test_check_env_passes(name):
    env = gymnasium.make("LocoMujoco", env_name=name)
    check_env(env.unwrapped, skip_render_check=True)
    assert env.observation_space.dtype == np.float32 and env.action_space.dtype == np.float32
    assert env.observation_space.shape == env.unwrapped.unwrapped_loco.info.observation_space.shape


def _rollout(env, seed, n):
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [obs]
    for _ in range(n):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        out.append(np.append(obs, reward))
        if terminated or truncated:
            out.append(env.reset()[0])
    return out


def test_reset_seed_makes_the_rollout_reproducible():
    env = gymnasium.make("LocoMujoco", env_name="UnitreeA1.hard")
    a, b = _rollout(env, 7, 120), _rollout(env, 7, 120)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    c = _rollout(env, 8, 120)
    assert len(a) != len(c) or not all(np.array_equal(x, y) for x, y in zip(a, c, strict=False))


def test_terminated_on_fall_truncated_at_horizon():
    env = gymnasium.make("LocoMujoco", env_name="UnitreeH1.walk", horizon=5, control="pd")
    env.reset(seed=0)
    flags = [env.step(np.zeros(env.action_space.shape, np.float32))[2:4] for _ in range(5)]
    assert flags[:4] == [(False, False)] * 4 and flags[4] == (False, True)
    env = gymnasium.make("LocoMujoco", env_name="UnitreeH1.walk")
    env.reset(seed=0)
    for _ in range(300):
        _, _, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, np.float32))
        if terminated:
            break
    assert terminated and not truncated and info["fallen"]


def test_rgb_array_rendering_offscreen():
    env = gymnasium.make("LocoMujoco", env_name="UnitreeA1.simple", render_mode="rgb_array", width=96, height=64)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (64, 96, 3) and frame.dtype == np.uint8
    assert frame.std() > 5  # a real picture, not a blank buffer
    env.close()


def test_invalid_render_mode_and_env_name_are_rejected():
    from loco_mujoco.gymnasium_env import LocoGymEnv

    with pytest.raises(ValueError, match="rgb_array"):
        LocoGymEnv("UnitreeH1.walk", render_mode="depth_array")
    with pytest.raises(ValueError, match="UnitreeH1.walk"):
        gymnasium.make("LocoMujoco", env_name="UnitreeH1.wlak")
