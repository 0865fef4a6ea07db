"""The A1 trotting controller: speed tracking over a minute, turning, goal directions, and its datasets."""

from __future__ import annotations

import math

import numpy as np
import pytest

from loco_mujoco.controllers import QuadrupedController, build_controller_dataset, rollout, tracking
from loco_mujoco.controllers.datasets import commands, controller_env
from loco_mujoco.controllers.quadruped import wrap_angle, yaw_of


@pytest.fixture(scope="module")
def env():
    env = controller_env("UnitreeA1.simple", control="pd")
    yield env
    env.stop()


@pytest.mark.parametrize("speed", [0.3, 0.6, 0.9])
def test_trots_a_minute_at_the_commanded_speed(env, speed):
    run = rollout(env, QuadrupedController(env), 60.0, speed)
    assert run.fall_time is None, f"fell at {run.fall_time} s"
    fig = tracking(run, env.dt)
    assert fig["seconds"] == pytest.approx(60.0)
    assert abs(fig["achieved_forward_mps"] - speed) <= 0.1 * speed, fig
    assert abs(fig["achieved_lateral_mps"]) < 0.05 and abs(fig["heading_change_rad"]) < 0.1, fig


def test_torque_control_tracks_as_well():
    env = controller_env("UnitreeA1.simple", control="torque")
    fig = tracking(rollout(env, QuadrupedController(env), 10.0, 0.6), env.dt)
    env.stop()
    assert not fig["fell"] and abs(fig["achieved_forward_mps"] - 0.6) <= 0.06, fig


@pytest.mark.parametrize("goal", [math.pi / 2, -0.75 * math.pi])
def test_turns_to_a_goal_heading(env, goal):
    env.reset()
    controller = QuadrupedController(env, forward=0.5, heading=goal)
    for _ in range(int(6.0 / env.dt)):
        _, _, fell, _ = env.step(controller())
        assert not fell
    assert abs(wrap_angle(goal - yaw_of(env.data.qpos[3:7]))) < 0.05


def test_follows_a_goal_direction_in_the_heading_frame():
    env = controller_env("UnitreeA1.hard", control="pd")
    forward, lateral = 0.6 * math.cos(2.0), 0.6 * math.sin(2.0)  # backwards and to the left
    run = rollout(env, QuadrupedController(env), 10.0, forward, lateral)
    goal = run.observations[:, env.get_obs_idx("goal_velocity")]
    env.stop()
    np.testing.assert_allclose(goal, np.tile([math.cos(2.0), math.sin(2.0), 0.6], (len(goal), 1)))
    fig = tracking(run, 0.01)
    assert not fig["fell"] and fig["relative_error"] < 0.1, fig


def test_dataset_is_deterministic_and_well_formed(tmp_path):
    a = build_controller_dataset("UnitreeA1.hard", seed=3, progress=False, seconds=0.5)
    b = build_controller_dataset("UnitreeA1.hard", seed=3, progress=False, seconds=0.5)
    assert a.save(tmp_path / "a.npz").read_bytes() == b.save(tmp_path / "b.npz").read_bytes()
    assert commands("hard", 4) != commands("hard", 3)

    assert a.n_trajectories == 8 and a.frequency == 100.0 and a.duration == pytest.approx(4.0)
    last = a.split_points[1:] - 1
    assert np.isnan(a.actions[last]).all()
    taken = np.delete(a.actions, last, axis=0)
    assert np.isfinite(taken).all() and np.abs(taken).max() <= 1.0
    assert not a.absorbing.any()
    meta = a.metadata
    assert (meta["dataset_type"], meta["variant"], meta["generator"]) == ("real", "permissive", "controller")
    assert meta["commercial_use"] and not meta["noncommercial"] and meta["licences"] == ["MIT"]
    assert meta["env_settings"]["control"] == "pd" and len(meta["trajectories"]) == 8
    for key in ("env", "task", "frequency", "seconds", "mean_forward_speed", "mean_speed", "quality", "sources"):
        assert key in meta
    # the goal each trajectory's observations carry is its command
    for i, (forward, lateral) in enumerate(commands("hard", 3)):
        goal = a.observations[a.split_points[i], -3:]
        np.testing.assert_allclose(goal[:2] * goal[2], [forward, lateral], atol=1e-12)


def test_env_replays_the_dataset_file(tmp_path):
    from loco_mujoco import LocoEnv

    path = build_controller_dataset("simple", progress=False, seconds=0.5).save(tmp_path / "simple.npz")
    env = LocoEnv.make("UnitreeA1.simple", dataset_path=str(path))
    data = env.create_dataset()
    env.stop()
    assert len(data["states"]) == 3 * 50 and np.isfinite(data["actions"]).all()


def test_dataset_file_is_cached_by_content(tmp_path, monkeypatch):
    from loco_mujoco.controllers import datasets

    monkeypatch.setenv("LOCO_MUJOCO_CACHE", str(tmp_path))
    built = []
    monkeypatch.setattr(datasets, "build_controller_dataset", lambda name, seed, progress: built.append(name) or
                        build_controller_dataset(name, seed, progress, seconds=0.2))
    path = datasets.controller_dataset_path("simple", progress=False)
    assert path.name.startswith("UnitreeA1.simple.real.permissive.") and path.is_file()
    assert datasets.controller_dataset_path("simple", progress=False) == path and built == ["UnitreeA1.simple"]
