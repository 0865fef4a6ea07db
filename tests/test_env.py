import math
import warnings

import mujoco
import numpy as np
import pytest
from conftest import BASE_TASKS, random_rollout

import loco_mujoco as lm
from loco_mujoco.core.loco_env import PhysicsDivergedWarning


@pytest.mark.parametrize("name", BASE_TASKS)
def test_every_task_constructs_steps_and_matches_its_spaces(make_env, name):
    env = make_env(name)
    obs_space, act_space = env.info.observation_space, env.info.action_space
    obs = env.reset()
    assert obs.shape == obs_space.shape and obs.dtype == np.float64
    assert act_space.shape == (env.model.nu,)
    np.testing.assert_array_equal(act_space.low, -1.0)
    np.testing.assert_array_equal(act_space.high, 1.0)
    assert obs_space.low.shape == obs_space.high.shape == obs.shape
    assert env.info.horizon == 1000 and math.isclose(env.info.dt, 0.01)
    assert not env.is_absorbing(obs), "the home pose must not count as fallen"
    for _ in range(20):
        obs, reward, absorbing, info = env.step(np.zeros(act_space.shape))
        assert obs.shape == obs_space.shape and np.all(np.isfinite(obs))
        assert np.all(obs >= obs_space.low) and np.all(obs <= obs_space.high)
        assert isinstance(reward, float) and 0.0 <= reward <= 1.0
        assert set(info) >= {"root_pos", "root_vel", "fallen", "physics_diverged"}
        assert info["root_vel"][0] == obs[env.get_obs_idx("dq_root")[0]]
        if absorbing:
            break


@pytest.mark.parametrize("name", BASE_TASKS)
def test_observation_excludes_horizontal_root_position_and_matches_mushroom_helper(make_env, name):
    env = make_env(name)
    obs = env.reset()
    n_extra = sum(dim for _, dim in env.extra_observations())  # goal, body-size code
    assert obs.shape == (env.model.nq - 2 + env.model.nv + n_extra,)
    np.testing.assert_array_equal(obs[: env.model.nq - 2], env.data.qpos[2:])
    np.testing.assert_array_equal(obs[env.model.nq - 2 : env.model.nq - 2 + env.model.nv], env.data.qvel)
    for _ in range(5):
        obs, *_ = env.step(np.full(env.model.nu, 0.3))
    helper_obs = env.obs_helper._build_obs(env.data)  # Mushroom's own (slow, per-key) construction
    np.testing.assert_array_equal(obs[: len(helper_obs)], helper_obs)


@pytest.mark.parametrize("name", ["UnitreeH1.walk", "Talos.walk", "UnitreeA1.hard"])
def test_same_seed_same_rollout_different_seed_different_rollout(make_env, name):
    env = make_env(name)
    obs_a, rew_a, abs_a = random_rollout(env, seed=3, n_steps=150)
    obs_b, rew_b, abs_b = random_rollout(env, seed=3, n_steps=150)
    np.testing.assert_array_equal(obs_a, obs_b)
    np.testing.assert_array_equal(rew_a, rew_b)
    np.testing.assert_array_equal(abs_a, abs_b)
    obs_c, _, _ = random_rollout(env, seed=4, n_steps=150)
    assert obs_c.shape != obs_a.shape or not np.array_equal(obs_c, obs_a)


def test_a1_hard_draws_the_goal_heading_from_the_seed(make_env):
    env = make_env("UnitreeA1.hard")
    goal = env.get_obs_idx("goal_velocity")
    headings = []
    for seed in (0, 0, 1):
        env.seed(seed)
        obs = env.reset()
        assert math.isclose(obs[goal[0]] ** 2 + obs[goal[1]] ** 2, 1.0)
        headings.append(math.atan2(obs[goal[1]], obs[goal[0]]))
    assert headings[0] == headings[1] != headings[2]
    simple = make_env("UnitreeA1.simple")
    goal = simple.reset()[simple.get_obs_idx("goal_velocity")]
    np.testing.assert_array_equal(goal, [1.0, 0.0, simple.target_velocity])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_action_raises_naming_the_actuator(make_env, bad):
    env = make_env("UnitreeH1.walk")
    action = np.zeros(env.model.nu)
    action[3] = bad
    with pytest.raises(ValueError, match=r"NaN or inf at indices \[3\] \(left_knee\)"):
        env.step(action)


def test_wrong_action_shape_raises(make_env):
    env = make_env("UnitreeH1.walk")
    with pytest.raises(ValueError, match=r"shape \(11,\)"):
        env.step(np.zeros(19))


def test_step_does_not_modify_the_callers_action(make_env):
    env = make_env("UnitreeH1.walk")
    action = np.full(env.model.nu, 3.0)
    env.step(action)
    np.testing.assert_array_equal(action, 3.0)


@pytest.mark.parametrize("name, arm_joint, n_arm", [("UnitreeH1.walk", "left_elbow", 8),
                                                    ("Talos.walk", "arm_left_4_joint", 14)])
def test_disabled_arms_remove_their_joints_from_observation_and_action(name, arm_joint, n_arm):
    env_off = lm.LocoEnv.make(name)
    env_on = lm.LocoEnv.make(name, disable_arms=False)
    assert f"q_{arm_joint}" not in env_off.obs_names and f"q_{arm_joint}" in env_on.obs_names
    assert env_on.info.action_space.shape[0] - env_off.info.action_space.shape[0] == n_arm
    assert env_on.info.observation_space.shape[0] - env_off.info.observation_space.shape[0] >= 2 * n_arm
    assert arm_joint not in [env_off.model.joint(j).name for j in range(env_off.model.njnt)]
    assert env_on.step(np.zeros(env_on.model.nu))[0].shape == env_on.info.observation_space.shape


def test_disabled_arms_are_welded_in_the_home_pose():
    on, off = lm.LocoEnv.make("Talos.walk", disable_arms=False), lm.LocoEnv.make("Talos.walk")
    on.reset()
    off.reset()
    for body in ("arm_left_7_link", "arm_right_4_link", "head_2_link"):
        np.testing.assert_allclose(on.data.body(body).xpos, off.data.body(body).xpos, atol=1e-9)
        np.testing.assert_allclose(on.data.body(body).xquat, off.data.body(body).xquat, atol=1e-9)


def test_get_obs_idx_names_entries_and_rejects_unknown(make_env):
    env = make_env("UnitreeH1.walk")
    obs = env.reset()
    knee = env.get_obs_idx("q_left_knee")
    assert knee.shape == (1,) and obs[knee[0]] == env.data.joint("left_knee").qpos[0]
    assert env.get_obs_idx("q_root").shape == (5,)  # height + quaternion
    assert env.get_obs_idx("dq_root").shape == (6,)
    with pytest.raises(KeyError, match="q_left_knee"):
        env.get_obs_idx("q_left_kne")


def test_reset_from_an_observation_restores_it(make_env):
    env = make_env("Talos.walk")
    for _ in range(10):
        target, *_ = env.step(np.full(env.model.nu, 0.2))
    target = target.copy()
    env.reset()
    np.testing.assert_allclose(env.reset(target), target)
    with pytest.raises(ValueError, match="shape"):
        env.reset(target[:-1])


@pytest.mark.parametrize("name", BASE_TASKS)
def test_fall_detection_on_height_and_tilt(make_env, name):
    env = make_env(name)
    obs = env.reset().copy()
    z = env.get_obs_idx("q_root")[0]
    low = obs.copy()
    low[z] = env.root_height_range[0] - 0.01
    assert env.is_absorbing(low)
    tilted = obs.copy()
    angle = env.MAX_TILT + 0.05  # rotate about the x axis past the bound
    tilted[z + 1 : z + 5] = [math.cos(angle / 2), math.sin(angle / 2), 0.0, 0.0]
    assert env.is_absorbing(tilted)
    tilted[z + 1 : z + 5] = [math.cos((angle - 0.1) / 2), math.sin((angle - 0.1) / 2), 0.0, 0.0]
    assert not env.is_absorbing(tilted)


def test_torque_robot_without_torque_falls_and_reports_it(make_env):
    env = make_env("UnitreeH1.walk")
    for _ in range(300):
        _, _, absorbing, info = env.step(np.zeros(env.model.nu))
        if absorbing:
            break
    assert absorbing and info["fallen"] and not info["physics_diverged"]


@pytest.mark.parametrize("name, seconds", [("UnitreeH1.walk", 1.0), ("Talos.walk", 3.0), ("UnitreeA1.simple", 3.0)])
def test_pd_control_holds_the_home_pose(name, seconds):
    env = lm.LocoEnv.make(name, control="pd")
    obs = env.reset()
    # the action that targets the home joint angles
    m = env.model
    home = np.array([env.data.joint(m.actuator(i).trnid[0]).qpos[0] for i in range(m.nu)])
    action = env.ctrl_to_action(home)
    np.testing.assert_allclose(env.action_to_ctrl(action), home)
    z0 = obs[0]
    for _ in range(int(seconds / env.dt)):  # H1 drifts backwards after ~1.4 s under pure joint PD
        obs, _, absorbing, _ = env.step(action)
        assert not absorbing
    assert abs(obs[0] - z0) < 0.1


def test_pd_mode_maps_actions_onto_joint_ranges():
    env = lm.LocoEnv.make("UnitreeH1.walk", control="pd")
    m = env.model
    knee = m.actuator("left_knee").id
    np.testing.assert_allclose(m.actuator_ctrlrange[knee], m.jnt_range[m.joint("left_knee").id])
    np.testing.assert_allclose(m.actuator_forcerange[knee], [-300, 300])
    torque_env = lm.LocoEnv.make("UnitreeH1.walk")
    np.testing.assert_allclose(torque_env.model.actuator_ctrlrange[knee], [-300, 300])


def test_physics_divergence_terminates_the_episode_with_a_flag(make_env):
    env = make_env("UnitreeA1.simple")
    before = env.reset().copy()
    env.data.qvel[6] = np.nan
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        obs, _, absorbing, info = env.step(np.zeros(env.model.nu))
    assert absorbing and info["physics_diverged"]
    assert np.all(np.isfinite(obs)) and np.array_equal(obs, before)
    assert any(issubclass(w.category, PhysicsDivergedWarning) for w in caught)
    assert np.all(np.isfinite(env.reset()))


def test_mushroom_raising_warning_hook_is_not_left_installed(make_env):
    make_env("UnitreeH1.walk")
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><body><freejoint/><geom size='.1'/></body>"
                                           "</worldbody></mujoco>")
    data = mujoco.MjData(model)
    data.qvel[0] = np.nan
    mujoco.mj_step(model, data)  # a MuJoCo warning: Mushroom's hook would raise RuntimeError here
    assert data.warning[mujoco.mjtWarning.mjWARN_BADQVEL].number == 1


def test_missing_model_explains_how_to_get_it(monkeypatch, tmp_path):
    monkeypatch.setenv("MENAGERIE_ROOT", str(tmp_path))
    with pytest.raises(FileNotFoundError, match="MENAGERIE_ROOT") as err:
        lm.LocoEnv.make("UnitreeH1.walk")
    assert "internet" in str(err.value)


@pytest.mark.parametrize("name", BASE_TASKS)
def test_simulation_defaults_are_100hz_and_the_embodiments_integrator(make_env, name):
    env = make_env(name)
    muscle = env.control == "muscle"  # implicitfast at 5 ms x 2 (bench/timestep_study.py), others at 2 ms x 5
    assert env.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert env.model.opt.timestep == (0.005 if muscle else 0.002)
    assert math.isclose(env.model.opt.timestep * env._n_substeps, 0.01) and math.isclose(env.info.dt, 0.01)


@pytest.mark.parametrize("name, robot, entry, key", [("UnitreeH1.walk", "unitree_h1", "scene", "home"),
                                                      ("UnitreeA1.simple", "unitree_a1", "scene", "home")])
def test_episodes_start_from_the_menagerie_home_keyframe(name, robot, entry, key):
    from loco_mujoco.models.menagerie import menagerie_xml

    reference = mujoco.MjModel.from_xml_path(str(menagerie_xml(robot, entry)))
    env = lm.LocoEnv.make(name, disable_arms=False)
    env.reset()
    np.testing.assert_array_equal(env.data.qpos, reference.key(key).qpos)
    np.testing.assert_array_equal(env.data.qvel, 0.0)
