"""Minari export: an agent dataset written as a local Minari dataset reads back transition for transition."""

import numpy as np
import pytest

import loco_mujoco as lm

minari = pytest.importorskip("minari", reason="minari is not installed (pip install 'loco_mujoco[minari]')")
pytest.importorskip("h5py", reason="h5py is not installed (pip install 'loco_mujoco[minari]')")

from loco_mujoco.minari_export import export_minari  # noqa: E402

TASK = "UnitreeH1.walk.perfect"


def test_export_reads_back_exactly_and_refuses_to_overwrite(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset_id = export_minari(TASK)
    assert dataset_id == "loco-mujoco/UnitreeH1-walk-perfect-v0"
    assert (tmp_path / "loco-mujoco" / "UnitreeH1-walk-perfect-v0" / "data").is_dir()

    env = lm.LocoEnv.make(TASK)
    expected = env.create_dataset()
    dataset = minari.load_dataset(dataset_id)
    episodes = list(dataset.iterate_episodes())
    assert len(episodes) == env.dataset.n_trajectories
    assert dataset.total_steps == len(expected["actions"])
    # Stored as float64, as in our files: compared exactly, not to float32 rounding.
    np.testing.assert_array_equal(np.concatenate([ep.actions for ep in episodes]), expected["actions"])
    np.testing.assert_array_equal(np.concatenate([ep.observations[:-1] for ep in episodes]), expected["states"])
    np.testing.assert_array_equal(np.concatenate([ep.observations[1:] for ep in episodes]), expected["next_states"])
    np.testing.assert_allclose(np.concatenate([ep.rewards for ep in episodes]), env.dataset_task_rewards())
    returns = [t["return"] for t in env.dataset.metadata["trajectories"]]
    np.testing.assert_allclose([ep.rewards.sum() for ep in episodes], returns, rtol=1e-9)
    ends = np.concatenate([ep.terminations | ep.truncations for ep in episodes])
    np.testing.assert_array_equal(ends, expected["last"])
    assert not any(ep.terminations.any() for ep in episodes)  # perfect data is cut before any fall

    meta = dataset.storage.metadata
    assert meta["author"] == {"loco_mujoco"} and meta["license"] == "MIT"
    assert meta["loco_mujoco_metadata"]["agents"][0]["sha256"] == env.dataset.metadata["agents"][0]["sha256"]
    assert dataset.observation_space.dtype == np.float64 and dataset.action_space.shape == (11,)
    assert dataset.env_spec.kwargs == {"env_name": "UnitreeH1.walk", "control": "pd", "random_start": True}

    with pytest.raises(FileExistsError, match="overwrite=True"):
        export_minari(TASK)
    assert minari.load_dataset(dataset_id).total_steps == dataset.total_steps  # untouched
    with pytest.raises(ValueError, match="invalid Minari dataset id"):
        export_minari(TASK, "loco-mujoco/UnitreeH1.walk-v0")


def test_cli_replaces_only_with_overwrite(tmp_path, monkeypatch, capsys):
    from experiments.build_datasets import main

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    dataset_id = "test/perfect-v1"
    assert main(["--export-minari", TASK, "--minari-id", dataset_id]) == 0
    n_steps = minari.load_dataset(dataset_id).total_steps
    assert f"{dataset_id}: " in capsys.readouterr().out
    assert main(["--export-minari", TASK, "--minari-id", dataset_id]) == 1
    assert "overwrite" in capsys.readouterr().err
    assert main(["--export-minari", TASK, "--minari-id", dataset_id, "--overwrite"]) == 0
    assert f"{n_steps:,} transitions" in capsys.readouterr().out
    assert minari.load_dataset(dataset_id).total_steps == n_steps


def test_datasets_without_actions_are_refused(tmp_path, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    with pytest.raises(ValueError, match=r"no dataset with actions.*UnitreeH1\.walk\.perfect, UnitreeH1\.walk\."
                                         r"preference"):
        export_minari("UnitreeH1.walk")
    assert not (tmp_path / "loco-mujoco").exists()
