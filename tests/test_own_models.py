"""Our own models (Atlas, the human skeleton), body scaling and the four-size environments."""

import numpy as np
import pytest

import loco_mujoco as lm
from loco_mujoco.core.body_sizes import SIZES
from loco_mujoco.environments import Atlas, HumanoidTorque, HumanoidTorque4Ages
from loco_mujoco.models import authoring
from loco_mujoco.models.facts import FactsError, facts_dir, load_facts, total_mass
from loco_mujoco.models.scaling import scale_spec

needs_facts = pytest.mark.skipif(not (facts_dir() / "atlas.yaml").is_file(), reason="needs ../shared/robot-facts")

# Full models: nq (free root 7 + hinges), nv, nu; then the default env's actuators (arms/back welded).
DOF = {"atlas": (32, 31, 25), "humanoid_torque": (38, 37, 31)}
DEFAULT_ACTUATORS = {"Atlas.walk": 10, "HumanoidTorque.walk": 17}


@pytest.mark.parametrize("model", list(authoring.OWN_MODELS))
def test_own_model_compiles_with_documented_dof_and_one_free_root(model):
    m = authoring.load_own_spec(model).compile()
    assert (m.nq, m.nv, m.nu) == DOF[model]
    assert [m.joint(j).name for j in range(m.njnt) if m.jnt_type[j] == 0] == ["root"]
    assert m.nkey == 1 and m.key("home").qpos[3] == 1.0  # upright root at home


@needs_facts
@pytest.mark.parametrize("model", list(authoring.OWN_MODELS))
def test_own_model_matches_its_facts_file(model):
    facts = load_facts(authoring.OWN_MODELS[model][0])
    m = authoring.load_own_spec(model).compile()
    assert m.body_subtreemass[0] == pytest.approx(total_mass(facts), rel=0.01)
    assert m.body_subtreemass[0] == pytest.approx(facts["total_mass"], rel=0.01)
    gears = {a["joint"]: a["gear"] * max(abs(c) for c in a["ctrlrange"]) for a in facts["actuators"]}
    for i in range(m.nu):
        joint = m.joint(m.actuator_trnid[i, 0]).name
        assert m.actuator_gear[i, 0] * np.abs(m.actuator_ctrlrange[i]).max() == pytest.approx(gears[joint])
    # the committed MJCF is exactly what the facts give (regenerate with python -m loco_mujoco.models.authoring)
    assert authoring.authored_xml(model) == authoring.own_model_path(model).read_text()


def test_malformed_facts_file_raises_naming_the_problem(tmp_path):
    bad = tmp_path / "robot.yaml"
    bad.write_text("bodies:\n- name: pelvis\n  parent: world\n  pos: [0, 0, 1]\nactuators: []\n")
    with pytest.raises(FactsError, match="pelvis"):
        load_facts(bad)
    with pytest.raises(FactsError, match="not found"):
        load_facts(tmp_path / "missing.yaml")


@pytest.mark.parametrize("name", list(DEFAULT_ACTUATORS))
def test_default_envs_weld_arms_and_back(name):
    env = lm.LocoEnv.make(name, reward_type="none")
    assert env.model.nu == DEFAULT_ACTUATORS[name]
    full = lm.LocoEnv.make(name, reward_type="none", disable_arms=False,
                           **({"disable_back_joint": False} if name.startswith("Atlas") else {}))
    assert full.model.nu == DOF["atlas" if name.startswith("Atlas") else "humanoid_torque"][2]


@pytest.mark.parametrize("name", ["Atlas.walk", "HumanoidTorque.walk", "HumanoidTorque4Ages.walk.1"])
def test_pd_controller_holds_the_standing_pose_for_two_seconds(name):
    env = lm.LocoEnv.make(name, control="pd", reward_type="none")
    obs = env.reset()
    m = env.model
    home = np.array([env.data.joint(m.actuator(i).trnid[0]).qpos[0] for i in range(m.nu)])
    action = env.ctrl_to_action(home)
    z0 = obs[0]
    for _ in range(int(2.0 / env.dt)):
        obs, _, absorbing, _ = env.step(action)
        assert not absorbing
    assert abs(obs[0] - z0) < 0.02  # the pelvis neither sinks nor topples
    assert np.linalg.norm(env.data.qpos[:2]) < 0.05


def test_scaling_follows_the_power_laws():
    spec_a, spec_b = authoring.load_own_spec("humanoid_torque"), authoring.load_own_spec("humanoid_torque")
    f = 0.6
    scale_spec(spec_b, f)
    a, b = spec_a.compile(), spec_b.compile()
    np.testing.assert_allclose(b.body_mass, a.body_mass * f**3)
    np.testing.assert_allclose(b.body_inertia, a.body_inertia * f**5, rtol=1e-6)
    np.testing.assert_allclose(b.body_pos[2:], a.body_pos[2:] * f)  # below the root body
    np.testing.assert_allclose(b.actuator_gear[:, 0], a.actuator_gear[:, 0] * f**2)
    np.testing.assert_allclose(b.key_qpos[0, 2], a.key_qpos[0, 2] * f)  # standing height
    with pytest.raises(ValueError, match="positive"):
        scale_spec(spec_a, -1.0)


def test_four_sizes_have_mass_in_ratio_height_cubed_and_torque_height_squared():
    envs = {s: lm.LocoEnv.make(f"HumanoidTorque4Ages.walk.{s}", reward_type="none") for s in SIZES}
    adult = envs["4"]
    heights = HumanoidTorque4Ages.statures()
    assert heights == {"1": 0.86, "2": 1.10, "3": 1.50, "4": 1.78}
    for size, env in envs.items():
        f = heights[size] / heights["4"]
        assert env.model.body_subtreemass[0] / adult.model.body_subtreemass[0] == pytest.approx(f**3, rel=1e-6)
        np.testing.assert_allclose(env.model.actuator_ctrlrange, adult.model.actuator_ctrlrange * f**2)
        assert env.root_height_range[0] == pytest.approx(HumanoidTorque.ROOT_HEIGHT_RANGE[0] * f)
        assert not env.is_absorbing(env.reset())


def test_mode_all_samples_every_size_and_shows_it_in_the_observation():
    env = lm.LocoEnv.make("HumanoidTorque4Ages.walk.all", reward_type="none", seed=5)
    code = env.get_obs_idx("env_type")
    masses = {s: lm.LocoEnv.make(f"HumanoidTorque4Ages.walk.{s}", reward_type="none").model.body_subtreemass[0]
              for s in SIZES}
    seen = set()
    for _ in range(40):
        obs = env.reset()
        k = int(np.argmax(obs[code]))
        assert obs[code].sum() == 1.0 and SIZES[k] == env.current_size
        assert env.model.body_subtreemass[0] == pytest.approx(masses[env.current_size])
        assert not env.is_absorbing(obs)
        seen.add(env.current_size)
        for _ in range(3):
            obs, *_ = env.step(np.zeros(env.model.nu))
        np.testing.assert_array_equal(obs[code], np.eye(4)[k])
    assert seen == set(SIZES)
    # resetting from an observation takes its size; a code that is not one-hot is refused
    small = obs.copy()
    small[code] = np.eye(4)[0]
    env.reset(small)
    assert env.current_size == "1"
    small[code] = [0.5, 0.5, 0, 0]
    with pytest.raises(ValueError, match="one-hot"):
        env.reset(small)


def test_mode_all_starts_from_expert_states_of_the_sampled_size():
    env = lm.LocoEnv.make("HumanoidTorque4Ages.walk.all", random_start=True, seed=1)
    ds = env.dataset
    assert sorted(set(ds.metadata["sizes"])) == list(SIZES)
    states = env.create_dataset()["states"]
    code = env.get_obs_idx("env_type")
    assert set(np.argmax(states[:, code], axis=1)) == {0, 1, 2, 3}
    for _ in range(8):
        obs = env.reset()
        match = np.flatnonzero(np.all(np.isclose(states, obs), axis=1))
        assert match.size >= 1  # the start is a dataset state, its size code included
        size_speed = ds.metadata["per_size"][env.current_size]["mean_forward_speed"]
        assert env._reward_fn.target_velocity == pytest.approx(size_speed)
    speeds = [ds.metadata["per_size"][s]["mean_forward_speed"] for s in SIZES]
    assert speeds == sorted(speeds)  # smaller bodies walk slower at the same gait
    assert env.play_trajectory()["fallen_fraction"] <= 0.05


@pytest.mark.parametrize("name", ["Atlas.walk", "Atlas.carry", "HumanoidTorque.walk", "HumanoidTorque.run",
                                  "HumanoidTorque4Ages.run.2"])
def test_new_task_starts_from_expert_states_and_steps(name):
    env = lm.LocoEnv.make(name, random_start=True, seed=2)
    kin = env.get_kinematic_obs_mask()
    states = env.create_dataset()["states"][:, kin]
    obs = env.reset()
    assert np.any(np.all(np.isclose(states, obs[kin]), axis=1))
    for _ in range(10):
        obs, reward, _, _ = env.step(np.zeros(env.model.nu))
        assert np.all(np.isfinite(obs)) and 0.0 <= reward <= 1.0
    assert isinstance(env, (Atlas, HumanoidTorque))


def test_muscle_sizes_scale_forces_by_height_squared_and_lengths_match_recomputation():
    from loco_mujoco.environments import HumanoidMuscle4Ages
    from loco_mujoco.models.myo_human import load_myo_human_spec

    small = lm.LocoEnv.make("HumanoidMuscle4Ages.walk.1", reward_type="none")
    adult = lm.LocoEnv.make("HumanoidMuscle4Ages.walk.4", reward_type="none")
    f = HumanoidMuscle4Ages.size_factor("1")
    assert f == pytest.approx(0.86 / 1.70)
    assert small.model.body_subtreemass[0] == pytest.approx(adult.model.body_subtreemass[0] * f**3, rel=1e-6)
    np.testing.assert_allclose(small.model.actuator_gainprm[:, 2], adult.model.actuator_gainprm[:, 2] * f**2)
    np.testing.assert_allclose(small.model.actuator_lengthrange, adult.model.actuator_lengthrange * f)
    # the compiler, asked to recompute a scaled muscle's length range from the geometry, agrees
    spec = load_myo_human_spec()
    scale_spec(spec, 0.5)
    for i in (0, 40):
        spec.actuators[i].lengthrange = [0.0, 0.0]
    recomputed = spec.compile()
    base = load_myo_human_spec().compile()
    for i in (0, 40):
        np.testing.assert_allclose(recomputed.actuator_lengthrange[i], 0.5 * base.actuator_lengthrange[i], rtol=0.03)
    # tendon (muscle path) lengths at home follow the geometry exactly
    d_small, d_adult = small.data, adult.data
    small.reset()
    adult.reset()
    np.testing.assert_allclose(d_small.ten_length, d_adult.ten_length * f, rtol=1e-6)
