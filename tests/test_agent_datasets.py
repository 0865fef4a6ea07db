"""Policy exports and the perfect / preference datasets rolled out from them."""

import hashlib
import shutil
import warnings

import numpy as np
import pytest
from conftest import TINY_TRAINING

import loco_mujoco as lm
from loco_mujoco import agent_datasets
from loco_mujoco.agent_datasets import AGENT_RECIPES, changed_exports, pretrained_root, recorded_build, sha256_file
from loco_mujoco.policy_export import MAX_BYTES, ExportError, PolicyExport

# A tiny GAIfO run trained here (finished runs keep only their export in git, so no checkpoint is relied on).
TINY_GAIFO = {**TINY_TRAINING, "train": {**TINY_TRAINING["train"], "n_steps": 400, "n_eval_episodes": 1}}
GAIFO_EXPORT = agent_datasets.pretrained_root() / "UnitreeH1.walk/gaifo/seed0"
VAIL_EXPORT = agent_datasets.pretrained_root() / "UnitreeH1.walk/vail/seed0"


def test_export_acts_exactly_like_its_checkpoint(tmp_path):
    from baselines.config import load_run_config
    from baselines.export import export_checkpoint
    from baselines.training import Trainer, build, load_checkpoint, make_env, run_config_from_checkpoint

    Trainer(load_run_config("UnitreeH1.walk", "gaifo", seed=3, overrides=TINY_GAIFO), tmp_path / "run",
            progress=False).train()
    checkpoint = tmp_path / "run" / "checkpoint.pt"
    path = export_checkpoint(checkpoint, tmp_path / "export", evaluation={"note": "test"})
    assert sum(f.stat().st_size for f in path.iterdir()) < MAX_BYTES
    export = PolicyExport.load(path)
    assert export.task == "UnitreeH1.walk" and export.env_kwargs["control"] == "pd"
    assert export.card["algorithm"] == "gaifo" and export.card["steps"] == 400 and export.card["seed"] == 3
    state = load_checkpoint(checkpoint)
    run = run_config_from_checkpoint(state)
    _, agent = build(run)
    agent.load_state_dict(state["agent"])
    obs = make_env(run, seed=0).dataset_observations()[:300]
    np.testing.assert_array_equal(export.mean_action(obs), agent.policy.mean_numpy(obs))
    with pytest.raises(FileExistsError, match="already holds"):
        export_checkpoint(checkpoint, path)
    committed = PolicyExport.load(GAIFO_EXPORT)  # the finished 20M run's export, in the same format
    assert committed.card["algorithm"] == "gaifo" and committed.card["steps"] == 20_000_000
    assert committed.env_kwargs == {**export.env_kwargs, "horizon": 1000} and committed.sha256 != export.sha256
    rng = np.random.default_rng(0)
    sample = export.draw_action(obs[0], rng)
    assert sample.shape == (11,) and not np.array_equal(sample, export.draw_action(obs[0]))


def test_broken_exports_raise_naming_the_folder(tmp_path):
    with pytest.raises(ExportError, match="missing policy.safetensors, card.json, config.yaml"):
        PolicyExport.load(tmp_path)
    shutil.copytree(VAIL_EXPORT, tmp_path / "e")
    (tmp_path / "e" / "policy.safetensors").write_bytes(b"garbage")
    with pytest.raises(ExportError, match="unreadable export"):
        PolicyExport.load(tmp_path / "e")


def test_perfect_dataset_has_actions_and_replays_exactly():
    env = lm.LocoEnv.make("UnitreeH1.walk.perfect")
    assert env.control == "pd"  # the dataset's setting, without asking
    assert env.target_velocity == lm.LocoEnv.make("UnitreeH1.walk", control="pd").target_velocity
    data = env.create_dataset()
    assert len(data["actions"]) >= 50_000 and data["states"].shape == (len(data["actions"]), 33)
    assert np.all(np.abs(data["actions"]) <= 1.0) and not data["absorbing"].any()
    ds = env.dataset
    meta = ds.metadata
    assert meta["type"] == "perfect" and meta["agents"][0]["sha256"] == PolicyExport.load(VAIL_EXPORT).sha256
    sl = ds.trajectory_slice(3)
    replay = lm.LocoEnv.make("UnitreeH1.walk.perfect", init_step_no=sl.start)
    replay.reset()
    for t in range(sl.start, sl.stop - 1):  # open loop from the stored first state: the same states, bit for bit
        replay.step(ds.actions[t])
        np.testing.assert_array_equal(replay.data.qpos, ds.qpos[t + 1])
        np.testing.assert_array_equal(replay.data.qvel, ds.qvel[t + 1])
    assert np.isnan(ds.actions[sl.stop - 1]).all()  # a trajectory's last frame has no action


def test_same_export_and_seed_build_a_byte_identical_file(tmp_path):
    export = PolicyExport.load(VAIL_EXPORT)
    digests = []
    for i, seed in enumerate((3, 3, 4)):
        path = agent_datasets.perfect_dataset(export, seed, min_transitions=1500, progress=False).save(
            tmp_path / f"{i}.npz")
        digests.append(hashlib.sha256(path.read_bytes()).hexdigest())
    assert digests[0] == digests[1] != digests[2]


@pytest.mark.parametrize("name", sorted(n for n in AGENT_RECIPES if n.endswith(".preference")))
def test_preference_sets_are_ranked_by_return(name):
    env = lm.LocoEnv.make(name)
    sets = env.dataset.metadata["sets"]
    assert len(sets) >= 4
    by_rank = sorted(sets, key=lambda s: s["rank"])
    means = [s["mean_return"] for s in by_rank]
    assert all(a > b for a, b in zip(means, means[1:], strict=False)), means  # strictly ordered
    for s in sets:
        assert s["mean_return"] == pytest.approx(np.mean(s["returns"]))
    fell = sum(len(s["lengths"]) for s in sets) - sum(length == 1000 for s in sets for length in s["lengths"])
    assert env.create_dataset()["absorbing"].sum() == fell  # every episode that ended early ended in a fall


@pytest.mark.parametrize("name", sorted(AGENT_RECIPES))
def test_shipped_datasets_use_the_exports_their_build_record_names(name):
    """Replacing an export (a table run that went on to a larger budget) silently changed UnitreeH1.walk.preference
    once; every recipe's exports must be the ones its committed build record names."""
    digest, exports = recorded_build(name)
    assert digest is not None and len(digest) == 64, f"{name}: no build record at {sha256_file(name)}"
    assert sorted(exports) == sorted(AGENT_RECIPES[name].exports)
    assert changed_exports(name) == [], f"{name}: rebuild and run build_datasets.py --record {name}"


def test_a_replaced_export_is_named(tmp_path, monkeypatch):
    name = "UnitreeH1.walk.perfect"
    export = AGENT_RECIPES[name].exports[0]
    shutil.copytree(pretrained_root() / export, tmp_path / export)
    shutil.copytree(pretrained_root() / "UnitreeH1.walk" / "datasets", tmp_path / "UnitreeH1.walk" / "datasets")
    other = pretrained_root() / "UnitreeH1.walk" / "gaifo" / "seed0" / "policy.safetensors"
    monkeypatch.setenv("LOCO_MUJOCO_PRETRAINED", str(tmp_path))
    assert changed_exports(name) == []
    shutil.copy(other, tmp_path / export / "policy.safetensors")
    assert changed_exports(name) == [export]


def test_settings_travel_with_the_data_and_conflicts_raise():
    with pytest.raises(ValueError, match="recorded with control='pd', but control='torque'"):
        lm.LocoEnv.make("UnitreeH1.walk.perfect", control="torque")
    assert lm.LocoEnv.make("UnitreeH1.walk.perfect", control="pd").control == "pd"
    with pytest.raises(ValueError, match="Dataset types with data for it: real"):
        lm.LocoEnv.make("UnitreeA1.hard.preference")


def test_a_build_that_differs_from_the_committed_one_warns(tmp_path, monkeypatch):
    root = tmp_path / "pretrained"
    shutil.copytree(agent_datasets.pretrained_root(), root)
    (root / "UnitreeH1.walk/datasets/perfect.sha256").write_text("0" * 64 + "  UnitreeH1.walk.perfect\n")
    monkeypatch.setenv("LOCO_MUJOCO_PRETRAINED", str(root))
    monkeypatch.setenv("LOCO_MUJOCO_CACHE", str(tmp_path / "cache"))
    monkeypatch.setitem(agent_datasets.AGENT_RECIPES, "UnitreeH1.walk.perfect",
                        agent_datasets.AgentRecipe(exports=("UnitreeH1.walk/vail/seed0",), min_transitions=500))
    with pytest.warns(agent_datasets.DatasetBuildMismatchWarning, match="differs"):
        agent_datasets.agent_dataset_path("UnitreeH1.walk.perfect", progress=False)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        agent_datasets.agent_dataset_path("UnitreeH1.walk.perfect", progress=False)  # cached: no rebuild, no warning
