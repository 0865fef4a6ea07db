"""Pretrained agents: ``load(task, algo, seed)`` acting on the Mushroom-RL and the Gymnasium env, errors that name
what exists, the committed VAIL agent's card score reproduced under the protocol (``evaluate.py --pretrained``),
and the off-policy (tanh-Gaussian) export round trip."""

import json
import re
import shutil

import numpy as np
import pytest
import torch
from mushroom_rl.core import Core

from baselines import make_agent
from baselines.common.expert_data import ExpertData
from baselines.export import export_agent
from baselines.pretrained import PretrainedId, PretrainedNotFoundError, available, load
from loco_mujoco.agent_datasets import pretrained_root
from loco_mujoco.policy_export import ExportError, PolicyExport

SMALL = {"actor_hidden": [32, 32], "critic_hidden": [32, 32], "batch_size": 32, "initial_samples": 100,
         "n_threads": 1}


@pytest.fixture(scope="module")
def vail():
    return load("UnitreeH1.walk", "vail")


@pytest.fixture(scope="module")
def walk_env(vail):
    return vail.make_env()


def test_available_lists_the_committed_agents_only():
    agents = available()
    assert PretrainedId("UnitreeH1.walk", "vail", 0) in agents
    assert PretrainedId("UnitreeH1.walk", "gaifo", 0) in agents
    assert PretrainedId("UnitreeH1.walk.perfect", "bc", 0) in agents
    assert not {a.algorithm for a in agents} & {"preference", "datasets"}  # other folders under a task
    vail_agents = available(algo="vail")
    assert PretrainedId("UnitreeH1.walk", "vail", 0) in vail_agents and {a.algorithm for a in vail_agents} == {"vail"}
    assert vail_agents == sorted(vail_agents)
    for agent in agents:  # each card agrees with its folder (load checks)
        policy = load(agent.task, agent.algorithm, agent.seed)
        assert (policy.task, policy.algorithm, policy.seed) == (agent.task, agent.algorithm, agent.seed)


def test_vail_acts_on_the_mushroom_and_the_gymnasium_env(vail, walk_env):
    assert vail.card["algorithm"] == "vail" and "ci95" in vail.card["evaluation"]["score"]
    assert vail.env_spec() == ("UnitreeH1.walk", {"control": "pd", "gamma": 0.99, "horizon": 1000,
                                                  "random_start": True})
    assert (vail.obs_dim, vail.act_dim) == (33, 11)
    env = walk_env
    gym_env = vail.make_gymnasium_env()
    assert env.control == "pd" and gym_env.unwrapped.unwrapped_loco.control == "pd"
    env.seed(3)
    obs = env.reset()
    gym_obs, _ = gym_env.reset(seed=3)
    np.testing.assert_array_equal(gym_obs, obs.astype(np.float32))  # one start state, two dtypes
    for _ in range(10):
        action, gym_action = vail.draw_action(obs), vail.draw_action(gym_obs)
        assert action.dtype == np.float64 and gym_action.dtype == np.float32
        for a in (action, gym_action):
            assert a.shape == (11,) and np.all(np.isfinite(a)) and np.all(np.abs(a) <= 1.0)
        assert gym_env.action_space.contains(gym_action)
        # the network computes in float32: the same observation gives the same action in either dtype
        np.testing.assert_array_equal(vail.draw_action(obs.astype(np.float32)), action.astype(np.float32))
        obs, _, absorbing, _ = env.step(action)
        gym_obs, _, terminated, _, _ = gym_env.step(gym_action)
        assert not absorbing and not terminated
    batch = np.stack([obs, obs + 0.01])
    actions = vail.draw_action(batch)
    assert actions.shape == (2, 11)
    np.testing.assert_allclose(actions[0], vail.draw_action(obs), atol=1e-6)
    with pytest.raises(ValueError, match=r"shape \(33,\) or \(n, 33\), got \(32,\)"):
        vail.draw_action(obs[:32])


def test_stochastic_actions_are_seeded(vail, walk_env):
    obs = walk_env.dataset_observations()[::1000][:5]
    draws = [np.array([p.draw_action(o) for o in obs])
             for p in (load("UnitreeH1.walk", "vail", deterministic=False, noise_seed=1),
                       load("UnitreeH1.walk", "vail", deterministic=False, noise_seed=1),
                       load("UnitreeH1.walk", "vail", deterministic=False, noise_seed=2))]
    np.testing.assert_array_equal(draws[0], draws[1])
    assert not np.array_equal(draws[0], draws[2])
    assert not np.array_equal(draws[0], np.array([vail.draw_action(o) for o in obs]))
    assert np.all(np.abs(draws[0]) <= 1.0)


def test_unknown_task_algo_or_seed_name_the_valid_ones(tmp_path):
    with pytest.raises(PretrainedNotFoundError, match=r"task 'UnitreeH1.wlk' \(did you mean 'UnitreeH1.walk'\?\); "
                                                      r"valid: (?:[\w.]+, )*UnitreeH1\.walk, UnitreeH1\.walk\.perfect"):
        load("UnitreeH1.wlk", "vail")
    with pytest.raises(PretrainedNotFoundError,
                       match=r"algorithm 'sac' for UnitreeH1.walk; valid: (?:\w+, )*gaifo, (?:\w+, )*vail\b"):
        load("UnitreeH1.walk", "sac")
    with pytest.raises(PretrainedNotFoundError, match="with seed 7; valid seeds: 0"):
        load("UnitreeH1.walk", "vail", 7)
    with pytest.raises(TypeError, match="seed must be an int, got str"):
        load("UnitreeH1.walk", "vail", "0")
    with pytest.raises(PretrainedNotFoundError, match="no pretrained agents under"):
        load("UnitreeH1.walk", "vail", root=tmp_path)
    assert load("UnitreeH1.walk.real", "VAIL").task == "UnitreeH1.walk"  # the default dataset type, any case
    shutil.copytree(pretrained_root() / "UnitreeH1.walk/vail/seed0", tmp_path / "UnitreeH1.walk/gail/seed0")
    with pytest.raises(ExportError, match="misfiled"):
        load("UnitreeH1.walk", "gail", root=tmp_path)


def test_evaluate_cli_reproduces_the_card_score(vail, tmp_path, capsys):
    """The full protocol (50 episodes, ~4 s): the score lands inside the 95% interval on the card."""
    from experiments.evaluate import main

    out = tmp_path / "eval.json"
    assert main(["--pretrained", "UnitreeH1.walk", "vail", "0", "--json", str(out)]) == 0
    results = json.loads(out.read_text())
    card = vail.card["evaluation"]
    assert results["protocol"] == {"episodes": card["protocol"]["episodes"], "seed": card["protocol"]["seed"]}
    assert results["pretrained"].endswith("UnitreeH1.walk/vail/seed0") and results["steps"] == 38_200_000
    low, high = card["score"]["ci95"]
    assert low <= results["deterministic"]["score"]["mean"] <= high, (results["deterministic"]["score"], low, high)
    assert "its card: score 16.9 [12.0, 24.0]" in capsys.readouterr().out
    assert main(["--pretrained", "UnitreeH1.walk", "sac"]) == 2
    assert re.search(r"valid: (?:\w+, )*gaifo, (?:\w+, )*vail\n", capsys.readouterr().err)  # sorted
    assert main(["--pretrained", "UnitreeH1.walk", "vail", "zero"]) == 2


def test_offpolicy_agent_exports_and_reloads_with_the_same_actions(walk_env, tmp_path):
    # The round trip needs a trained network, not good data: the real dataset's states with random actions (no
    # perfect dataset to build), and the networks do not see the root height, so the export must keep the mask.
    data = walk_env.create_dataset()
    data["actions"] = np.random.default_rng(0).uniform(-1.0, 1.0, (len(data["states"]), 11))
    mask = np.ones(data["states"].shape[1], bool)
    mask[0] = False
    threads = torch.get_num_threads()
    try:
        agent = make_agent("lsiq", walk_env, config=SMALL, seed=0, expert=ExpertData(data, mask))
        walk_env.seed(0)
        Core(agent, walk_env).learn(n_steps=200, n_steps_per_fit=1, quiet=True)  # 100 updates: off the init
    finally:
        torch.set_num_threads(threads)
    card = {"task": "UnitreeH1.walk.perfect", "algorithm": "lsiq", "seed": 0, "steps": 200, "env": {"horizon": 100},
            "evaluation": {}}
    export_agent(agent, tmp_path / "UnitreeH1.walk.perfect/lsiq/seed0", card, {"agent": SMALL})
    weights = tmp_path / "UnitreeH1.walk.perfect/lsiq/seed0/policy.safetensors"
    assert weights.stat().st_mode & 0o777 == 0o644  # readable by every user of a shared checkout
    policy = load("UnitreeH1.walk.perfect", "lsiq", root=tmp_path)
    assert policy.export.distribution == "tanh_gaussian" and policy.card["policy"]["log_std_min"] == -5.0
    assert (policy.obs_dim, policy.act_dim) == (33, 11) and policy.export.obs_index[0] == 1

    states = data["states"][::50][:200]
    with agent.policy.evaluation_mode(deterministic=True):
        expected = np.array([agent.draw_action(s) for s in states])
    actions = np.array([policy.draw_action(s) for s in states])
    np.testing.assert_array_equal(actions, expected)  # bit for bit: tanh(mean), the same float32 arithmetic
    assert np.ptp(actions, axis=0).max() > 0.05  # the actions depend on the state: a trained network, not its init
    np.testing.assert_allclose(policy.draw_action(states), expected, atol=1e-6)  # a batch at once
    shifted = states[0].copy()
    shifted[0] += 1.0
    np.testing.assert_array_equal(policy.draw_action(shifted), actions[0])  # the masked entry is ignored

    with agent.policy.evaluation_mode(deterministic=False, seed=7):
        expected = np.array([agent.draw_action(s) for s in states[:20]])
    stochastic = load("UnitreeH1.walk.perfect", "lsiq", root=tmp_path, deterministic=False, noise_seed=7)
    np.testing.assert_array_equal(np.array([stochastic.draw_action(s) for s in states[:20]]), expected)

    card_path = tmp_path / "UnitreeH1.walk.perfect/lsiq/seed0/card.json"
    broken = json.loads(card_path.read_text())
    broken["policy"]["distribution"] = "beta"
    card_path.write_text(json.dumps(broken))
    with pytest.raises(ExportError, match="distribution 'beta' is not one of gaussian, tanh_gaussian"):
        PolicyExport.load(card_path.parent)
