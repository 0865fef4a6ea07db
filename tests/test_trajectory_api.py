"""Starting episodes from the dataset, and the dataset API through the Gymnasium wrapper."""

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import loco_mujoco as lm
from loco_mujoco.datasets.retarget import joint_axes
from loco_mujoco.datasets.sources.fetch import default_sources_root

pytestmark = pytest.mark.skipif(default_sources_root() is None, reason="needs ../shared/mocap or LOCO_MUJOCO_SOURCES")


def test_init_step_no_starts_from_that_dataset_frame():
    env = lm.LocoEnv.make("UnitreeH1.walk", init_step_no=123)
    np.testing.assert_allclose(env.reset(), env.dataset_observations(np.array([123]))[0])


def test_random_start_is_seeded_and_varies():
    env = lm.LocoEnv.make("Talos.walk", random_start=True)
    starts = []
    for seed in (3, 3, 4):
        env.seed(seed)
        starts.append(env.reset().copy())
    np.testing.assert_array_equal(starts[0], starts[1])
    assert not np.allclose(starts[0], starts[2])
    dataset_obs = env.dataset_observations()
    assert np.min(np.abs(dataset_obs - starts[2]).max(axis=1)) < 1e-12  # it is one of the dataset's states


def test_a1_dataset_start_carries_the_motion_goal():
    env = lm.LocoEnv.make("UnitreeA1.simple", init_step_no=50)
    goal = env.reset()[env.get_obs_idx("goal_velocity")]
    assert goal[0] > 0.8 and goal[2] > 0.2  # heading forward at walking pace


def test_bad_start_arguments_raise():
    with pytest.raises(ValueError, match="not both"):
        lm.LocoEnv.make("UnitreeH1.walk", random_start=True, init_step_no=0)
    with pytest.raises(ValueError, match="init_step_no"):
        lm.LocoEnv.make("UnitreeH1.walk", init_step_no=10**7).reset()


@pytest.mark.parametrize("env_cls", [lm.UnitreeH1, lm.Talos])
def test_hip_flexion_maps_to_a_joint_that_swings_the_foot_forward(env_cls):
    env = env_cls(disable_arms=False, reward_type="none")
    m, d = env.model, mujoco.MjData(env.model)
    leg = env_cls.RETARGET.legs["l"]
    axis = joint_axes(m)[leg.hip_flexion]
    d.qpos[3] = 1.0
    mujoco.mj_kinematics(m, d)
    foot = m.body(leg.foot_body).id
    before = d.xpos[foot].copy()
    d.qpos[m.jnt_qposadr[m.joint(leg.hip_flexion).id]] = 0.3 * np.sign(axis @ [0, -1, 0])
    mujoco.mj_kinematics(m, d)
    assert d.xpos[foot][0] - before[0] > 0.1


def test_gymnasium_wrapper_exposes_the_dataset():
    env = gym.make("LocoMujoco", env_name="UnitreeH1.walk", init_step_no=5)
    data = env.unwrapped.create_dataset()
    assert data["states"].dtype == np.float32
    assert data["states"].shape[1:] == env.observation_space.shape
    obs, _ = env.reset(seed=0)
    np.testing.assert_allclose(obs, data["states"][5], rtol=1e-6, atol=1e-6)
    assert env.unwrapped.play_trajectory(n_episodes=1, n_steps_per_episode=50)["frames"] == 50
    assert env.unwrapped.play_trajectory_from_velocity(n_episodes=1)["max_root_drift_per_second"] < 0.05
