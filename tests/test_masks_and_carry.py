"""Carry loads, observation masks and foot forces."""

import numpy as np
import pytest

import loco_mujoco as lm
from loco_mujoco.core.loco_env import LOAD_BODY, LOAD_MASSES, OBSERVATION_GROUPS


@pytest.mark.parametrize("name", ["UnitreeH1.carry", "Talos.carry", "Atlas.carry"])
def test_carry_mass_follows_the_set_and_shows_in_the_observation(name):
    env = lm.LocoEnv.make(name, seed=0, reward_type="none")
    weight = env.get_obs_idx("weight")
    load = env.model.body(LOAD_BODY).id
    seen = []
    for _ in range(60):
        obs = env.reset()
        mass = env.model.body_mass[load]
        assert mass in LOAD_MASSES and obs[weight][0] == mass
        assert env.model.body_subtreemass[0] == pytest.approx(env.model.body_mass.sum())  # derived constants follow
        seen.append(mass)
        obs, *_ = env.step(np.zeros(env.model.nu))
        assert obs[weight][0] == mass
    counts = np.array([seen.count(m) for m in LOAD_MASSES])
    assert np.all(counts >= 6)  # every mass of the set drawn (expected 15 each)


def test_fixed_weight_mass_and_its_errors():
    env = lm.LocoEnv.make("UnitreeH1.carry", weight_mass=7.5, reward_type="none")
    for _ in range(3):
        assert env.reset()[env.get_obs_idx("weight")][0] == 7.5
    # heavier load, same actions: the robot is pulled down and forward differently
    with pytest.raises(ValueError, match="only for carry tasks"):
        lm.LocoEnv.make("UnitreeH1.walk", weight_mass=5.0)
    with pytest.raises(ValueError, match="positive number"):
        lm.LocoEnv.make("UnitreeH1.carry", weight_mass=-1.0)


def test_heavier_load_changes_the_dynamics():
    light = lm.LocoEnv.make("UnitreeH1.carry", weight_mass=0.1, reward_type="none")
    heavy = lm.LocoEnv.make("UnitreeH1.carry", weight_mass=10.0, reward_type="none")
    for env in (light, heavy):
        env.reset()
        for _ in range(30):
            env.step(np.zeros(env.model.nu))
    assert not np.allclose(light.data.qpos, heavy.data.qpos, atol=1e-3)


@pytest.mark.parametrize("name, kwargs", [("UnitreeH1.carry", {"use_foot_forces": True}),
                                          ("UnitreeA1.hard", {"use_foot_forces": True}),
                                          ("HumanoidTorque4Ages.walk.all", {}),
                                          ("HumanoidMuscle.walk", {})])
def test_every_mask_has_the_right_length_and_hides_exactly_its_group(name, kwargs):
    env = lm.LocoEnv.make(name, reward_type="none", **kwargs)
    dim = env.info.observation_space.shape[0]
    groups = env.observation_groups()
    covered = np.zeros(dim, dtype=int)
    for group, idx in groups.items():
        assert group in OBSERVATION_GROUPS
        mask = env.get_mask([group])
        assert mask.shape == (dim,) and mask.dtype == bool
        np.testing.assert_array_equal(np.flatnonzero(~mask), np.sort(idx))
        covered[idx] += 1
    np.testing.assert_array_equal(covered, 1)  # the groups partition the observation
    assert env.get_mask(list(groups)).sum() == 0 and env.get_mask([]).all()
    kin = env.get_kinematic_obs_mask()
    np.testing.assert_array_equal(kin, ~env.get_mask(["positions", "velocities"]))
    with pytest.raises(ValueError, match="has no observation group"):
        env.get_mask(["weights"])


def test_groups_exist_only_where_the_env_has_them():
    assert set(lm.LocoEnv.make("UnitreeH1.walk", reward_type="none").observation_groups()) == {"positions",
                                                                                             "velocities"}
    carry = lm.LocoEnv.make("UnitreeH1.carry", reward_type="none", use_foot_forces=True)
    assert set(carry.observation_groups()) == {"positions", "velocities", "foot_forces", "weight"}
    assert set(lm.LocoEnv.make("HumanoidTorque4Ages.walk.all", reward_type="none").observation_groups()) == {
        "positions", "velocities", "env_type"}
    assert "goal" in lm.LocoEnv.make("UnitreeA1.simple", reward_type="none").observation_groups()
    with pytest.raises(ValueError, match="no observation group 'weight'"):
        lm.LocoEnv.make("UnitreeH1.walk", reward_type="none").get_mask(["weight"])


def test_foot_forces_carry_the_body_weight_when_standing():
    env = lm.LocoEnv.make("UnitreeH1.walk", control="pd", use_foot_forces=True, reward_type="none")
    obs = env.reset()
    m = env.model
    home = np.array([env.data.joint(m.actuator(i).trnid[0]).qpos[0] for i in range(m.nu)])
    for _ in range(50):
        obs, *_ = env.step(env.ctrl_to_action(home))
    forces = obs[env.get_obs_idx("foot_forces")].reshape(2, 3)
    weight = m.body_subtreemass[0] * -m.opt.gravity[2]
    assert forces[:, 2].sum() == pytest.approx(weight, rel=0.05)  # the ground holds the robot up
    assert np.all(forces[:, 2] > 0.2 * weight)  # on both feet
    data = env.create_dataset()
    assert np.isnan(data["states"][:, env.get_obs_idx("foot_forces")]).all()  # motion data has no forces
    assert np.isfinite(data["states"][:, env.get_kinematic_obs_mask()]).all()


def test_acceptance_command_shape():
    e = lm.LocoEnv.make("UnitreeH1.carry", domain_randomization_config="default")
    e.reset()
    assert e.get_mask(["weight"]).sum() == e.info.observation_space.shape[0] - 1
