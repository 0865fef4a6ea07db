"""Dynamics randomization: distributions, seeding, nominal values, config errors, derived quantities."""

import gymnasium
import mujoco
import numpy as np
import pytest
import yaml

import loco_mujoco as lm
from loco_mujoco.core.randomization import RandomizationConfigError, default_config_path

CONFIG = {
    "Default": {"Bodies": {"exclude": ["pelvis"], "mass": {"uniform_range_delta": 0.2, "relative": True}},
                "Joints": {"damping": {"uniform_range": [1.0, 3.0]}}},
    "Joints": {"left_knee": {"damping": {"sigma": 0.5}, "armature": {"uniform_range_delta": [0.0, 0.1]}}},
    "Bodies": {"torso_link": {"mass": {"sigma": 1.0}}},
    "Geoms": {"torso": {"friction": {"uniform_range": [0.3, 0.9]}}},
    "Global": {"gravity": {"sigma": 0.2}, "floor_friction": {"uniform_range": [0.5, 1.0]}},
}


def make(config=CONFIG, seed=0, **kwargs):
    return lm.LocoEnv.make("UnitreeH1.walk", domain_randomization_config=config, seed=seed, reward_type="none",
                           **kwargs)


def test_sampled_parameters_follow_their_distributions():
    env = make()
    nominal = lm.LocoEnv.make("UnitreeH1.walk", reward_type="none").model
    m = env.model
    knee_dof = m.jnt_dofadr[m.joint("left_knee").id]
    hip_dof = m.jnt_dofadr[m.joint("right_hip_pitch").id]
    body_ids = [m.body(n).id for n in ("left_knee_link", "right_hip_pitch_link")]
    torso, pelvis, floor = m.body("torso_link").id, m.body("pelvis").id, m.geom("floor").id
    ankle_geom = m.geom("torso").id
    rows = []
    for _ in range(2000):
        env.reset()
        rows.append([m.dof_damping[knee_dof], m.dof_damping[hip_dof], m.dof_armature[knee_dof],
                     *(m.body_mass[body_ids] / nominal.body_mass[body_ids]), m.body_mass[torso], m.body_mass[pelvis],
                     m.geom_friction[ankle_geom, 0], m.geom_friction[floor, 0], m.opt.gravity[2]])
    r = np.array(rows)
    n = len(r)
    tol = 4 / np.sqrt(n)  # ~4 standard errors, in units of the distribution's std
    knee_nominal = nominal.dof_damping[knee_dof]
    assert abs(r[:, 0].mean() - knee_nominal) < tol * 0.5 and abs(r[:, 0].std() - 0.5) < 0.05  # sigma 0.5
    u = np.sqrt(1 / 12)  # std of U(0, 1)
    assert r[:, 1].min() >= 1.0 and r[:, 1].max() <= 3.0 and abs(r[:, 1].mean() - 2.0) < tol * 2 * u
    arm0 = nominal.dof_armature[knee_dof]
    assert r[:, 2].min() >= arm0 and r[:, 2].max() <= arm0 + 0.1 and abs(r[:, 2].mean() - arm0 - 0.05) < tol * 0.1 * u
    for k in (3, 4):  # relative +-20%
        assert r[:, k].min() >= 0.8 - 1e-12 and r[:, k].max() <= 1.2 + 1e-12
        assert abs(r[:, k].mean() - 1.0) < tol * 0.4 * u and abs(r[:, k].std() - 0.4 * u) < 0.02
    torso0 = nominal.body_mass[torso]
    assert abs(r[:, 5].mean() - torso0) < tol and abs(r[:, 5].std() - 1.0) < 0.08  # listed: its own sigma
    assert np.all(r[:, 6] == nominal.body_mass[pelvis])  # excluded from the default
    assert r[:, 7].min() >= 0.3 and r[:, 7].max() <= 0.9 and abs(r[:, 7].mean() - 0.6) < tol * 0.6 * u
    assert r[:, 8].min() >= 0.5 and r[:, 8].max() <= 1.0
    assert abs(r[:, 9].mean() + 9.81) < tol * 0.2 and abs(r[:, 9].std() - 0.2) < 0.02


def test_same_seed_same_parameters_and_rollout_different_seed_different():
    def run(seed):
        env = make(seed=seed)
        masses, obs = [], []
        for _ in range(3):
            obs.append(env.reset())
            masses.append(env.model.body_mass.copy())
            for _ in range(20):
                o, *_ = env.step(np.full(env.model.nu, 0.2))
            obs.append(o)
        return np.array(masses), np.array(obs)

    a, b, c = run(7), run(7), run(8)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])
    assert not np.array_equal(a[0], c[0])


def test_nominal_values_return_when_randomization_is_off():
    plain = lm.LocoEnv.make("UnitreeH1.walk", reward_type="none").model
    env = make()
    env.reset()
    assert not np.array_equal(env.model.body_mass, plain.body_mass)
    env.randomization_enabled = False
    env.reset()
    for field in ("body_mass", "body_inertia", "dof_damping", "dof_armature", "geom_friction", "body_subtreemass",
                  "dof_invweight0", "actuator_acc0"):
        np.testing.assert_array_equal(getattr(env.model, field), getattr(plain, field), err_msg=field)
    np.testing.assert_array_equal(env.model.opt.gravity, plain.opt.gravity)


def test_derived_quantities_follow_the_randomized_masses():
    env = make()
    for _ in range(3):
        env.reset()
        m = env.model
        assert m.body_subtreemass[0] == pytest.approx(m.body_mass.sum())
        fresh = mujoco.MjData(m)
        mujoco.mj_setConst(m, fresh)  # recomputing changes nothing: they are consistent
        assert m.body_subtreemass[0] == pytest.approx(m.body_mass.sum())


def test_full_inertia_stays_physical_and_geom_mass_moves_the_body_mass():
    env = make({"Bodies": {"pelvis": {"fullinertia": {"sigma": 0.5, "relative": True}}},
                "Geoms": {"torso": {"mass": {"uniform_range": [20.0, 21.0]}}}})
    m = env.model
    pelvis, torso = m.body("pelvis").id, m.body("torso_link").id
    base = lm.LocoEnv.make("UnitreeH1.walk", reward_type="none").model
    geom = m.geom("torso").id
    assert m.geom_type[geom] == mujoco.mjtGeom.mjGEOM_BOX
    nominal_geom_mass = 1000.0 * 8 * np.prod(m.geom_size[geom])  # MuJoCo's default density x volume
    for _ in range(50):
        env.reset()
        d = m.body_inertia[pelvis]
        assert np.all(d > 0) and np.all(d <= (d.sum() - d) + 1e-12)  # positive definite, triangle inequality
        added = m.body_mass[torso] - base.body_mass[torso]
        assert 20.0 - nominal_geom_mass - 1e-9 <= added <= 21.0 - nominal_geom_mass + 1e-9
        # the body's centre of mass moves towards the geom by the mass-weighted amount
        expected = (base.body_mass[torso] * base.body_ipos[torso] + added * m.geom_pos[geom]) / m.body_mass[torso]
        np.testing.assert_allclose(m.body_ipos[torso], expected, atol=1e-12)


@pytest.mark.parametrize("config, match", [
    ({"Joints": {"left_kne": {"damping": {"sigma": 1}}}}, "left_knee"),
    ({"Joints": {"left_knee": {"dampin": {"sigma": 1}}}}, "damping"),
    ({"Joints": {"left_knee": {"damping": {"sigma": -1}}}}, "sigma must be a number >= 0"),
    ({"Joints": {"left_knee": {"damping": {"uniform_range": [2, 1]}}}}, "lo <= hi"),
    ({"Joints": {"left_knee": {"damping": {"sigma": 1, "uniform_range": [0, 1]}}}}, "exactly one"),
    ({"Bodies": {"pelvis": {"mass": {"gaussian": 1}}}}, "unknown keys"),
    ({"Default": {"Bodies": {"exclude": ["nope"]}}}, "nope"),
    ({"Gravity": {"sigma": 1}}, "unknown sections"),
    ({"Global": {"wind": {"sigma": 1}}}, "wind"),
])
def test_malformed_config_raises_naming_the_entry(config, match):
    with pytest.raises(RandomizationConfigError, match=match):
        make(config)


def test_config_files_default_and_errors(tmp_path):
    path = tmp_path / "dr.yaml"
    path.write_text(yaml.safe_dump(CONFIG))
    assert len(make(str(path))._randomizer.plan) == len(make(CONFIG)._randomizer.plan)
    (tmp_path / "bad.yaml").write_text("Joints: [oops\n")
    with pytest.raises(RandomizationConfigError, match="not valid YAML"):
        make(str(tmp_path / "bad.yaml"))
    with pytest.raises(RandomizationConfigError, match="not found"):
        make(str(tmp_path / "missing.yaml"))


@pytest.mark.parametrize("name", ["UnitreeH1.walk", "Talos.walk", "UnitreeA1.simple", "Atlas.walk",
                                  "HumanoidTorque.walk", "HumanoidMuscle.walk", "HumanoidTorque4Ages.walk.all"])
def test_every_robot_ships_a_default_config_that_runs(name):
    env = lm.LocoEnv.make(name, domain_randomization_config="default", reward_type="none", seed=1)
    assert default_config_path(type(env)).is_file() and len(env._randomizer.plan) > 50
    for _ in range(3):
        obs = env.reset()
        for _ in range(10):
            obs, _, absorbing, info = env.step(np.zeros(env.model.nu))
            assert np.all(np.isfinite(obs)) and not info["physics_diverged"]


def test_gymnasium_wrapper_takes_the_config():
    env = gymnasium.make("LocoMujoco", env_name="UnitreeH1.walk", domain_randomization_config="default")
    env.reset(seed=3)
    m1 = env.unwrapped.unwrapped_loco.model.body_mass.copy()
    env.reset(seed=3)
    np.testing.assert_array_equal(env.unwrapped.unwrapped_loco.model.body_mass, m1)
