"""Behaviour cloning: it fits the expert's actions, resumes exactly, and refuses data it cannot use."""

import numpy as np
import pytest
import torch

import loco_mujoco as lm
from baselines import make_agent
from baselines.common.expert_data import ExpertData
from baselines.config import load_run_config
from baselines.training import Trainer, load_checkpoint

SMALL = {"policy_hidden": [64], "batch_size": 128, "n_threads": 1}


@pytest.fixture(scope="module")
def perfect_env():
    return lm.LocoEnv.make("UnitreeH1.walk.perfect")


def test_bc_fits_the_expert_actions(perfect_env):
    agent = make_agent("bc", perfect_env, config=SMALL, seed=0)
    states, actions = agent.states.numpy()[:2000], agent.actions.numpy()[:2000]
    before = np.mean((agent.policy.mean_numpy(states) - actions) ** 2)
    agent.fit_offline(400)
    after = np.mean((agent.policy.mean_numpy(states) - actions) ** 2)
    assert after < 0.5 * before, (before, after)
    assert agent.last_stats["bc_nll"] < 0 and agent.gradient_steps == 400
    with pytest.raises(RuntimeError, match="fit_offline"):
        agent.fit([])


def test_bc_needs_actions_and_full_observations(perfect_env):
    data = perfect_env.create_dataset()
    full = np.ones(data["states"].shape[1], dtype=bool)
    with pytest.raises(ValueError, match="needs expert actions"):
        make_agent("bc", perfect_env, expert=ExpertData({k: v for k, v in data.items() if k != "actions"}, full))
    masked = full.copy()
    masked[0] = False
    with pytest.raises(ValueError, match="full, finite observations"):
        make_agent("bc", perfect_env, expert=ExpertData(data, masked))


def test_bc_runs_resume_exactly(tmp_path):
    def run(n_steps):
        return load_run_config("UnitreeH1.walk.perfect", "bc", overrides={
            "train": {"n_steps": n_steps, "epoch_steps": 100, "n_eval_episodes": 1}, "env": {"horizon": 50},
            "agent": SMALL})

    torch_threads = torch.get_num_threads()
    try:
        Trainer(run(200), tmp_path / "straight", progress=False).train()
        Trainer(run(100), tmp_path / "split", progress=False).train()
        Trainer(run(200), tmp_path / "split", resume=True, progress=False).train()
    finally:
        torch.set_num_threads(torch_threads)
    a, b = (load_checkpoint(tmp_path / d)["agent"] for d in ("straight", "split"))
    for key in ("mean_net",):
        for name, tensor in a["policy"][key].items():
            assert torch.equal(tensor, b["policy"][key][name]), name
    assert torch.equal(a["policy"]["log_std"], b["policy"]["log_std"])
    assert a["rng"] == b["rng"] and a["gradient_steps"] == b["gradient_steps"] == 200
