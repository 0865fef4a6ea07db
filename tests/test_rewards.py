import math

import numpy as np
import pytest

import loco_mujoco as lm


def _step(env, value=0.1):
    env.reset()
    return env.step(np.full(env.model.nu, value))


def _heading(env, obs):
    w, x, y, z = obs[env.get_obs_idx("q_root")[1:5]]
    h = np.array([1 - 2 * (y * y + z * z), 2 * (x * y + w * z)])
    return h / np.linalg.norm(h)


def test_target_velocity_reward_matches_its_formula():
    env = lm.LocoEnv.make("UnitreeH1.run")
    assert env.target_velocity == env.dataset.metadata["mean_forward_speed"] > 2.0  # running, from the dataset
    obs, reward, _, info = _step(env)
    forward = float(info["root_vel"][:2] @ _heading(env, obs))
    width = 0.4 * env.target_velocity
    assert math.isclose(reward, math.exp(-(((forward - env.target_velocity) / width) ** 2)))
    env2 = lm.LocoEnv.make("UnitreeH1.walk", reward_params={"target_velocity": 0.0})
    obs2, reward2, _, _ = _step(env2)
    forward2 = float(obs2[env2.get_obs_idx("dq_root")[:2]] @ _heading(env2, obs2))
    assert math.isclose(reward2, math.exp(-((forward2 / 0.1) ** 2)))  # the width never drops below 0.1 m/s


def test_velocity_reward_pays_speed_along_the_root_heading_not_world_x():
    env = lm.LocoEnv.make("UnitreeH1.walk")
    obs = env.reset()
    target = env.target_velocity
    quat, vel = env.get_obs_idx("q_root")[1:5], env.get_obs_idx("dq_root")
    for yaw in (0.0, 1.0, math.pi, -2.5):
        o = obs.copy()
        o[quat] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        o[vel[0]], o[vel[1]] = target * math.cos(yaw), target * math.sin(yaw)  # walking at the target speed
        assert math.isclose(env.reward(obs, None, o, False), 1.0)
        o[vel[0]], o[vel[1]] = 0.0, 0.0  # standing still earns exp(-(1/0.4)^2)
        assert env.reward(obs, None, o, False) < 0.002
        o[vel[0]], o[vel[1]] = -target * math.sin(yaw), target * math.cos(yaw)  # sideways
        assert env.reward(obs, None, o, False) < 0.002


def test_expert_frames_earn_the_same_reward_facing_any_heading():
    """Rotating a whole trajectory about the vertical axis (e.g. to face +x) leaves its task rewards unchanged."""
    from loco_mujoco.core.loco_env import LocoEnv

    for name in ("UnitreeH1.walk", "Atlas.walk", "UnitreeA1.hard"):
        env = LocoEnv.make(name)
        original = env.dataset_task_rewards()
        ds = env.dataset
        sl = ds.trajectory_slice(0)
        qw, qz = ds.qpos[sl.start, 3], ds.qpos[sl.start, 6]
        # undo the first frame's yaw and turn by 1 rad more, so the rotation is never the identity (the A1's
        # controller data starts facing +x)
        angle = -2.0 * math.atan2(qz, qw) + 1.0
        c, s = math.cos(angle), math.sin(angle)
        rot = np.array([[c, -s], [s, c]])
        vx_before = ds.qvel[:, 0].copy()
        ds.qpos[:, :2] = ds.qpos[:, :2] @ rot.T
        ds.qvel[:, :2] = ds.qvel[:, :2] @ rot.T
        from loco_mujoco.rotations import axis_angle_quat, quat_mul

        ds.qpos[:, 3:7] = quat_mul(axis_angle_quat([0.0, 0.0, 1.0], angle), ds.qpos[:, 3:7])
        env._goals_cache = None
        assert not np.allclose(ds.qvel[:, 0], vx_before)  # world-frame x speeds did change
        rotated = env.dataset_task_rewards()
        assert abs(rotated.mean() - original.mean()) <= 0.05 * original.mean()
        np.testing.assert_allclose(rotated, original, atol=1e-9)
        assert original.mean() > 0.4, name  # the expert earns a good share of the maximum of 1 per step


def test_velocity_vector_reward_tracks_the_goal_in_the_heading_frame():
    env = lm.LocoEnv.make("UnitreeA1.hard", seed=5)
    obs, reward, _, info = _step(env)
    goal = env.goal_velocity
    assert math.isclose(np.linalg.norm(goal), env.dataset.metadata["mean_speed"])
    h = _heading(env, obs)
    v_local = np.array([info["root_vel"][:2] @ h, info["root_vel"][:2] @ np.array([-h[1], h[0]])])
    width = 0.4 * env.target_velocity
    assert math.isclose(reward, math.exp(-np.sum(((v_local - goal) / width) ** 2)))


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
