import math

import numpy as np
import pytest

import loco_mujoco as lm


def _step(env, value=0.1):
    env.reset()
    return env.step(np.full(env.model.nu, value))


def test_target_velocity_reward_matches_its_formula():
    env = lm.LocoEnv.make("UnitreeH1.run")
    assert env.target_velocity == env.dataset.metadata["mean_forward_speed"] > 2.0  # running, from the dataset
    obs, reward, _, info = _step(env)
    assert math.isclose(reward, math.exp(-((info["root_vel"][0] - env.target_velocity) ** 2)))
    env2 = lm.LocoEnv.make("UnitreeH1.walk", reward_params={"target_velocity": 0.0})
    obs2, reward2, _, _ = _step(env2)
    assert math.isclose(reward2, math.exp(-obs2[env2.get_obs_idx("dq_root")[0]] ** 2))


def test_velocity_vector_reward_tracks_the_goal_vector():
    env = lm.LocoEnv.make("UnitreeA1.hard", seed=5)
    obs, reward, _, info = _step(env)
    goal = env.goal_velocity
    assert math.isclose(np.linalg.norm(goal), env.dataset.metadata["mean_speed"])
    assert math.isclose(reward, math.exp(-np.sum((info["root_vel"][:2] - goal) ** 2)))


def test_custom_reward_receives_states_and_action():
    seen = {}

    def callback(state, action, next_state):
        seen.update(state=state.copy(), action=action.copy(), next_state=next_state.copy())
        return float(next_state[0])

    env = lm.LocoEnv.make("Talos.walk", reward_type="custom", reward_params={"callback": callback})
    start = env.reset().copy()
    obs, reward, _, _ = env.step(np.full(env.model.nu, 0.5))
    assert reward == obs[0]
    np.testing.assert_array_equal(seen["state"], start)
    np.testing.assert_array_equal(seen["action"], 0.5)


def test_custom_reward_must_return_a_finite_number():
    env = lm.LocoEnv.make("UnitreeA1.simple", reward_type="custom", reward_params={"callback": lambda s, a, n: "x"})
    with pytest.raises(ValueError, match="must return a float"):
        _step(env)
    env = lm.LocoEnv.make("UnitreeA1.simple", reward_type="custom",
                          reward_params={"callback": lambda s, a, n: float("nan")})
    with pytest.raises(ValueError, match="non-finite"):
        _step(env)


def test_reward_configuration_errors_are_explained():
    with pytest.raises(ValueError, match="callback"):
        lm.LocoEnv.make("UnitreeH1.walk", reward_type="custom")
    with pytest.raises(ValueError, match="must be callable"):
        lm.LocoEnv.make("UnitreeH1.walk", reward_type="custom", reward_params={"callback": 3})
    with pytest.raises(ValueError, match="goal"):
        lm.LocoEnv.make("UnitreeH1.walk", reward_type="velocity_vector")
    with pytest.raises(ValueError, match="unknown reward_params"):
        lm.LocoEnv.make("UnitreeH1.walk", reward_params={"target_speed": 1.0})


def test_no_reward_is_zero():
    env = lm.LocoEnv.make("UnitreeH1.walk", reward_type="none")
    assert _step(env)[1] == 0.0
