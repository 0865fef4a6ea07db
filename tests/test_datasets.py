"""Task datasets: quality bounds, replay, velocity consistency, layout, provenance and reproducibility."""

import hashlib

import numpy as np
import pytest

import loco_mujoco as lm
from loco_mujoco.datasets import registry
from loco_mujoco.datasets.sources.fetch import default_sources_root

pytestmark = pytest.mark.skipif(default_sources_root() is None, reason="needs ../shared/mocap or LOCO_MUJOCO_SOURCES")

# Upper bounds on the quality figures (m/s for sliding, m for heights) and the mean speed range per dataset.
BOUNDS = {
    "UnitreeH1.walk": {"sliding": 0.15, "speed": (0.5, 1.5)},
    "UnitreeH1.run": {"sliding": 0.05, "speed": (2.0, 4.0)},
    "Talos.walk": {"sliding": 0.25, "speed": (0.4, 1.5)},
    # simulated by our controller: MuJoCo's soft contacts let the loaded feet sink about 1-2.5 cm
    "UnitreeA1.simple": {"sliding": 0.10, "speed": (0.4, 1.5), "penetration": 0.03, "float": -0.02},
    "Atlas.walk": {"sliding": 0.25, "speed": (0.5, 1.5)},
    "Atlas.carry": {"sliding": 0.25, "speed": (0.5, 1.5)},
    "HumanoidTorque.walk": {"sliding": 0.25, "speed": (0.5, 1.5)},
    "HumanoidTorque.run": {"sliding": 0.05, "speed": (2.0, 4.0)},
    "HumanoidTorque4Ages.walk.1": {"sliding": 0.25, "speed": (0.2, 1.0)},  # 0.86 m tall
    "HumanoidTorque4Ages.run.3": {"sliding": 0.05, "speed": (1.5, 4.0)},
    "HumanoidMuscle.walk": {"sliding": 0.25, "speed": (0.5, 1.5)},
    "HumanoidMuscle.run": {"sliding": 0.05, "speed": (2.0, 4.0)},
    "HumanoidMuscle4Ages.walk.2": {"sliding": 0.25, "speed": (0.3, 1.2)},
}


@pytest.mark.parametrize("name", list(BOUNDS))
def test_built_dataset_meets_quality_bounds(make_env, name):
    meta = make_env(name).dataset.metadata
    q = meta["quality"]
    assert q["ground_penetration_max_m"] <= BOUNDS[name].get("penetration", 0.005)
    assert BOUNDS[name].get("float", 0.0) <= q["stance_float_mean_m"] <= 0.005
    assert q["foot_sliding_mps"] <= BOUNDS[name]["sliding"]
    assert q["joint_limit_clipped_fraction"] <= 0.05
    lo, hi = BOUNDS[name]["speed"]
    assert lo <= meta["mean_forward_speed"] <= hi
    assert meta["frequency"] == 100.0 and meta["seconds"] > 4.0


@pytest.mark.parametrize("name", list(BOUNDS))
def test_kinematic_replay_stays_upright_and_velocities_integrate(make_env, name):
    env = make_env(name)
    replay = env.play_trajectory()
    assert replay["frames"] == env.dataset.n_frames
    assert replay["fallen_fraction"] <= 0.05
    drift = env.play_trajectory_from_velocity()
    assert len(drift["root_drift_per_second"]) == env.dataset.n_trajectories
    assert drift["max_root_drift_per_second"] < 0.05


@pytest.mark.parametrize("name", list(BOUNDS))
def test_create_dataset_matches_the_observation_layout(make_env, name):
    env = make_env(name)
    data = env.create_dataset()
    ds = env.dataset
    n = ds.n_frames - ds.n_trajectories
    obs_dim = env.info.observation_space.shape[0]
    assert data["states"].shape == data["next_states"].shape == (n, obs_dim)
    assert data["absorbing"].shape == data["last"].shape == (n,)
    assert data["last"].sum() == ds.n_trajectories and data["last"][-1]
    assert not data["absorbing"].any()
    if ds.actions is None:  # retargeted motion has states only
        assert "actions" not in data
    else:  # simulated by a controller: the actions it passed to env.step
        assert data["actions"].shape == (n, env.info.action_space.shape[0])
        assert np.all(np.abs(data["actions"]) <= 1.0)
    inner = np.flatnonzero(~data["last"][:-1])
    np.testing.assert_array_equal(data["states"][inner + 1], data["next_states"][inner])
    # A dataset state is exactly what the env observes after resetting to it.
    env.reset(data["states"][10])
    known = np.isfinite(data["states"][10])  # a carried load is unknown in motion data: NaN
    assert known[env.get_kinematic_obs_mask()].all()
    np.testing.assert_allclose(env._build_observation()[known], data["states"][10][known])


def test_walking_dataset_is_long_enough_and_marked_permissive(make_env):
    env = make_env("UnitreeH1.walk")
    assert len(env.create_dataset()["states"]) >= 5000
    meta = env.dataset.metadata
    assert meta["commercial_use"] and not meta["noncommercial"]
    assert env.target_velocity == pytest.approx(meta["mean_forward_speed"])


def test_noncommercial_data_is_marked_and_never_the_default_where_permissive_exists(make_env):
    meta = make_env("UnitreeA1.simple").dataset.metadata  # our controller's rollouts
    assert not meta["noncommercial"] and meta["licences"] == ["MIT"] and meta["generator"] == "controller"
    dog = lm.LocoEnv.make("UnitreeA1.simple", dataset_variant="noncommercial", reward_type="none").dataset
    assert dog.metadata["noncommercial"] and "CC-BY-NC-4.0" in dog.metadata["licences"]
    for kind in registry.RECIPES.values():
        for task, variants in kind.items():
            names = list(variants)
            if "permissive" in names:
                assert names[0] == "permissive", task
    env = lm.LocoEnv.make("UnitreeH1.run", dataset_variant="noncommercial", reward_type="none")
    meta = env.dataset.metadata
    assert meta["noncommercial"] and "CC-BY-NC-4.0" in meta["licences"]


def test_same_build_gives_byte_identical_files(tmp_path):
    digests = []
    for i in range(2):
        ds = registry.build_dataset(lm.UnitreeH1.dataset_subject(), "run", progress=False)
        path = ds.save(tmp_path / f"run{i}.npz")
        digests.append(hashlib.sha256(path.read_bytes()).hexdigest())
    assert digests[0] == digests[1]
    again = registry.TrajectoryDataset.load(tmp_path / "run0.npz")
    np.testing.assert_array_equal(again.qpos, ds.qpos)
    assert again.metadata == ds.metadata


def test_unknown_variant_and_missing_dataset_type_raise_clear_errors():
    with pytest.raises(registry.DatasetUnavailableError, match="variants"):
        _ = lm.LocoEnv.make("UnitreeH1.walk", dataset_variant="bogus", reward_type="none").dataset
    with pytest.raises(ValueError, match="no 'perfect' dataset.*types with data for it: real;"):
        lm.LocoEnv.make("UnitreeH1.run.perfect", reward_type="none")


@pytest.mark.parametrize("env_name, file", [("UnitreeH1.walk", "02-constspeed_UnitreeH1.npz"),
                                             ("UnitreeH1.run", "05-run_UnitreeH1.npz"),
                                             ("Talos.walk", "02-constspeed_TALOS.npz")])
def test_original_format_files_load_and_replay(env_name, file):
    path = default_sources_root() / "loco-mujoco-format" / file
    env = lm.LocoEnv.make(env_name, dataset_path=str(path), reward_type="none")
    assert env.dataset.n_frames == 100  # 1 s at 500 Hz resampled to 100 Hz
    assert env.play_trajectory()["fallen_fraction"] == 0.0
    assert env.play_trajectory_from_velocity()["max_root_drift_per_second"] < 0.05
    # The legs move: this is motion, not a frozen pose.
    assert np.ptp(env.create_dataset()["states"][:, env.get_obs_idx("q_left_hip_pitch" if "H1" in env_name
                                                                   else "q_leg_left_3_joint")]) > 0.2


def test_corrupt_dataset_file_raises_naming_it(tmp_path):
    bad = tmp_path / "broken.npz"
    bad.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(Exception, match="broken.npz"):
        registry.TrajectoryDataset.load(bad)
