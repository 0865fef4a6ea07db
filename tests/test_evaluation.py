"""The evaluation protocol: intervals that cover, reproducible episodes, references and the normalised score."""

import json
import math

import numpy as np
import pytest

import loco_mujoco as lm
from loco_mujoco.evaluation import protocol
from loco_mujoco.evaluation.intervals import iqm, iqm_interval, mean_interval, modal_share, summarize
from loco_mujoco.evaluation.references import (
    hold_pose_policy,
    random_policy,
    references,
    stand_still_scores,
    zero_policy,
)

REPORTED_TASKS = [t for t in lm.list_tasks() if t.split(".")[-1] not in ("real", "perfect", "preference")]


def test_mean_interval_covers_the_true_mean_of_a_skewed_distribution():
    """1,000 repetitions of 50 exponential draws (skewness 2): the 95% interval holds the true mean 93-97% of
    the time."""
    rng = np.random.default_rng(2026)
    covered = 0
    for rep in range(1000):
        x = rng.exponential(1.0, size=50)
        lo, hi = mean_interval(x, reps=1000, seed=rep)
        covered += lo <= 1.0 <= hi
    assert 930 <= covered <= 970, covered


def test_mean_interval_stays_bounded_and_covers_when_most_episodes_reach_the_horizon():
    """1,000 samples of 50 episode lengths, 80% at the horizon of 1000 and the rest uniform on [100, 1000]: the
    95% interval holds the true mean 93-97% of the time and never spans more than a fifth of the horizon (the
    studentized interval spanned up to 10^13 on such samples)."""
    rng = np.random.default_rng(2026)
    true_mean = 0.8 * 1000.0 + 0.2 * 550.0
    covered, widest = 0, 0.0
    for rep in range(1000):
        x = np.where(rng.random(50) < 0.8, 1000.0, rng.uniform(100.0, 1000.0, 50))
        lo, hi = mean_interval(x, reps=1000, seed=rep)
        covered += lo <= true_mean <= hi
        widest = max(widest, hi - lo)
    assert 930 <= covered <= 970, covered
    assert widest < 200.0, widest
    a1_vail = np.r_[np.full(45, 1000.0), [143.0, 247.0, 366.0, 895.0, 907.0]]  # its stochastic lengths
    assert modal_share(a1_vail) == 0.9
    lo, hi = mean_interval(a1_vail)
    assert 850.0 < lo < a1_vail.mean() < hi <= 1000.0, (lo, hi)  # studentized: [541, 989]


def test_interval_and_iqm_basics():
    x = np.array([1.0, 2.0, 3.0, 4.0, 100.0, 5.0, 6.0, 7.0])
    assert iqm(x) == pytest.approx(np.mean(np.sort(x)[2:6]))  # the middle half
    lo, hi = mean_interval(x)
    assert lo < x.mean() < hi
    lo, hi = iqm_interval(x)
    assert lo <= iqm(x) <= hi
    assert mean_interval(np.full(10, 3.0)) == (3.0, 3.0)
    assert all(math.isnan(v) for v in mean_interval(np.array([1.0])))
    degenerate = summarize(np.array([1.0, 1.0, 1.0, 2.0]))  # resamples often constant: falls back, stays finite
    assert np.all(np.isfinite(degenerate["ci95"] + degenerate["iqm_ci95"]))
    lengths = np.r_[np.full(40, 1000.0), np.linspace(100.0, 900.0, 10)]  # most episodes reach the horizon
    lo, hi = iqm_interval(lengths)  # BCa undefined (every resample's IQM >= the sample's): percentile interval
    assert math.isfinite(lo) and lo <= iqm(lengths) == 1000.0 == hi
    s = summarize(x)
    assert s["n"] == 8 and s["mean"] == pytest.approx(x.mean()) and s["ci95"][0] < s["ci95"][1]
    assert summarize(x) == s  # seeded: the same interval every time
    with pytest.raises(ValueError, match="finite"):
        summarize(np.array([1.0, np.nan]))
    with pytest.raises(ValueError, match="no values"):
        summarize(np.array([]))


def test_protocol_episodes_are_reproducible_and_start_from_dataset_frames():
    env = lm.LocoEnv.make("UnitreeH1.walk", random_start=True, control="pd")
    a = protocol.run_episodes(env, random_policy(env, 1), n_episodes=6, seed=7, record=True)
    b = protocol.run_episodes(env, random_policy(env, 1), n_episodes=6, seed=7, record=True)
    c = protocol.run_episodes(env, random_policy(env, 1), n_episodes=6, seed=8)
    np.testing.assert_array_equal(a.returns, b.returns)
    assert [e.start_frame for e in a.episodes] == [e.start_frame for e in b.episodes]
    assert [e.start_frame for e in a.episodes] != [e.start_frame for e in c.episodes]
    qpos, _ = env.dataset_states(np.array([e.start_frame for e in a.episodes]))
    np.testing.assert_array_equal(np.array([e.qpos[0] for e in a.episodes]), qpos)  # each starts at its frame
    for e in a.episodes:
        assert e.qpos.shape == (e.length + 1, env.model.nq) and e.observations.shape[0] == e.length + 1
        assert e.length == env.info.horizon or e.absorbing
    stats = a.statistics()
    assert stats["episodes"] == 6 and stats["R"] == pytest.approx(a.returns.mean())
    assert stats["J"] < stats["R"]
    with pytest.raises(ValueError, match="n_episodes"):
        protocol.run_episodes(env, zero_policy(env), n_episodes=0)


def test_references_are_cached_per_settings_and_define_the_score(tmp_path, monkeypatch):
    monkeypatch.setenv("LOCO_MUJOCO_CACHE", str(tmp_path))
    refs = references("UnitreeH1.walk", {"control": "pd"}, episodes=10)
    files = list((tmp_path / "references").glob("*.json"))
    assert len(files) == 1
    assert references("UnitreeH1.walk", {"control": "pd"}, episodes=10) == refs  # read back from the cache
    data = json.loads(files[0].read_text())
    data["random_return"] = -1.0  # the cache is what is read: a changed file shows
    files[0].write_text(json.dumps(data))
    assert references("UnitreeH1.walk", {"control": "pd"}, episodes=10).random_return == -1.0
    other = references("UnitreeH1.walk", {"control": "torque"}, episodes=10)
    assert len(list((tmp_path / "references").glob("*.json"))) == 2 and other.env_settings != refs.env_settings
    assert refs.normalized_score(refs.random_return) == pytest.approx(0.0)
    assert refs.normalized_score(refs.expert_return) == pytest.approx(100.0)
    assert refs.expert_return == pytest.approx(1000 * refs.expert_reward_per_step)
    assert refs.expert_return > 10 * refs.random_return > 0


def test_references_default_to_the_protocols_random_episodes_and_report_their_standard_error(tmp_path, monkeypatch):
    """Without ``episodes`` the random reference runs ``RANDOM_EPISODES`` episodes (1,000; conftest lowers it for the
    tests); the first of them are the episodes a shorter run gives (same seeds), and the file records how many and
    the mean's standard error."""
    from loco_mujoco.evaluation import references as module

    assert module.VERSION == 2
    monkeypatch.setenv("LOCO_MUJOCO_CACHE", str(tmp_path))
    monkeypatch.setattr(module, "RANDOM_EPISODES", 12)
    env = lm.LocoEnv.make("UnitreeH1.walk", control="pd", random_start=True)
    returns = protocol.run_episodes(env, module.random_policy(env), 12).returns
    refs = references("UnitreeH1.walk", {"control": "pd"})
    assert refs.random_episodes == 12
    assert refs.random_return == pytest.approx(returns.mean())
    assert refs.random_return_se == pytest.approx(returns.std(ddof=1) / np.sqrt(12))
    fewer = references("UnitreeH1.walk", {"control": "pd"}, episodes=4)
    assert fewer.random_return == pytest.approx(returns[:4].mean()) and fewer.random_episodes == 4


def test_hold_pose_policy_targets_the_home_pose():
    env = lm.LocoEnv.make("Atlas.walk", control="pd")
    env.reset()
    action = hold_pose_policy(env)(None)
    joints = env.model.actuator_trnid[:, 0]
    np.testing.assert_allclose(env.action_to_ctrl(action), env.home_qpos(env.model)[env.model.jnt_qposadr[joints]])


@pytest.mark.parametrize("task", REPORTED_TASKS)
def test_standing_still_scores_at_most_5(task):
    """Zero action and a controller holding the home pose, both from the home pose, score <= 5 on every task."""
    refs = references(task)
    scores = stand_still_scores(refs)
    assert refs.expert_return > refs.random_return + 100, refs
    assert scores["zero"] <= 5.0 and scores["hold"] <= 5.0, scores


VAIL_PRETRAINED = ["--pretrained", "UnitreeH1.walk", "vail"]  # the committed VAIL agent (38.2M steps)


def _without_trajectory(env, k):
    """Make ``env`` use its dataset minus trajectory ``k``; returns that trajectory's qpos and observations."""
    from loco_mujoco.datasets.trajectory import TrajectoryDataset

    ds = env.dataset
    held = ds.trajectory_slice(k)
    held_qpos, _ = env.dataset_states(held)
    held_obs = env.dataset_observations(held)
    keep = [ds.trajectory_slice(i) for i in range(ds.n_trajectories) if i != k]
    split = np.concatenate([[0], np.cumsum([s.stop - s.start for s in keep])])
    env._dataset = TrajectoryDataset(np.concatenate([ds.qpos[s] for s in keep]),
                                     np.concatenate([ds.qvel[s] for s in keep]), split, ds.frequency,
                                     ds.joint_names, ds.metadata)
    env._dataset_cols = env._goals_cache = None
    return held_qpos, held_obs


# At 12 and 24 episodes VAIL and random came within 3% on the joint Frechet distance (and swapped) on a CPU whose
# OpenBLAS built the dataset with other last bits.
EPISODES = 40


def test_metrics_rank_held_out_expert_above_vail_above_random():
    """With one trajectory left out of the reference, that trajectory is closer to the rest than the trained VAIL
    agent, which is closer than a random policy, on every trajectory distance, the gait deviation and every
    distribution metric."""
    from baselines.common.evaluation import evaluate_agent
    from baselines.pretrained import load
    from loco_mujoco.evaluation.imitation import imitation_metrics

    agent = load("UnitreeH1.walk", "vail")
    env = lm.LocoEnv.make(agent.task, seed=0, **agent.card["env"])
    held_qpos, held_obs = _without_trajectory(env, 0)
    mask = env.get_kinematic_obs_mask()
    rest = env.dataset_observations()[:, mask]
    scale = rest.std(axis=0) + 1e-6
    episodes = []  # the held-out clip as episodes, each compared with the motion after its nearest rest frame
    for s in np.linspace(0, len(held_obs) - 200, 6).astype(int):
        nearest = int(np.argmin(np.linalg.norm((rest - held_obs[s, mask]) / scale, axis=1)))
        seg = slice(s, s + env.info.horizon + 1)
        episodes.append(protocol.Episode(nearest, np.zeros(len(held_qpos[seg]) - 1), False, held_qpos[seg],
                                         held_obs[seg]))
    held = protocol.Evaluation(episodes, 0.99)
    vail = evaluate_agent(agent, env, EPISODES, True, protocol.SEED, record=True)
    rnd = protocol.run_episodes(env, random_policy(env, 1), EPISODES, protocol.SEED, record=True)
    results = [imitation_metrics(env, ev) for ev in (held, vail, rnd)]
    for name in results[0]["trajectory"]:
        h, v, r = (np.mean(m["trajectory"][name]) for m in results)
        # The discrete Frechet distance is a maximum over the episode: a random agent's few steps before it falls
        # can have a smaller one than the agent's 1,000 walking steps (VAIL 1.89 vs random 1.83 rad on an AVX2 host,
        # where the rollouts differ in the last bits from the AVX-512 one's), so it only has to rank the expert first.
        assert (h < v < r) if not name.startswith("frechet") else (h < v and h < r), (name, h, v, r)
    h, v, r = (np.nanmean(m["gait"]["deviation"]) for m in results)
    assert h < v < r, ("gait_deviation", h, v, r)
    for name in results[0]["distribution"]["agent"]:
        h, v, r = (m["distribution"]["agent"][name] for m in results)
        assert h < v < r, (name, h, v, r)


def test_evaluate_cli_reports_score_interval_and_metrics(tmp_path):
    from experiments.evaluate import main

    out = tmp_path / "eval.json"
    assert main([*VAIL_PRETRAINED, "--episodes", "4", "--metrics", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    det = res["deterministic"]
    assert det["score"]["n"] == 4 and len(det["returns"]) == 4
    lo, hi = det["score"]["ci95"]
    assert lo <= det["score"]["mean"] <= hi
    refs = res["references"]
    expected = 100 * (np.mean(det["returns"]) - refs["random_return"]) / (refs["expert_return"] - refs["random_return"])
    assert det["score"]["mean"] == pytest.approx(expected)
    m = res["metrics"]
    assert set(m["trajectory"]) == {f"{k}_{p}" for k in ("euclidean", "dtw", "frechet") for p in ("joints", "sites")}
    assert all(len(v) == 4 and min(v) >= 0 for v in m["trajectory"].values())
    assert set(m["gait"]["agent"]) == set(m["gait"]["expert"]) and "cadence" in m["gait"]["agent"]
    assert 0.5 <= m["distribution"]["expert"]["classifier_auc"] < m["distribution"]["agent"]["classifier_auc"]
    with pytest.raises(SystemExit):
        main([*VAIL_PRETRAINED, "--episodes", "0"])


def test_evaluate_cli_lists_references(tmp_path, capsys):
    from experiments.evaluate import main

    out = tmp_path / "refs.json"
    assert main(["--references", "UnitreeH1.walk", "Talos.walk", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    assert [r["task"] for r in rows] == ["UnitreeH1.walk", "Talos.walk"]
    assert all(r["expert_return"] > r["random_return"] > r["hold_return"] - 50 for r in rows)
    printed = capsys.readouterr().out
    assert "UnitreeH1.walk" in printed and "hold score" in printed
    assert "UnitreeH1.walk: measured under random_start=True" in printed  # its defaults: torque control

    assert main(["--references", "UnitreeH1.walk", "--env", "control=pd", "horizon=1000", "--json", str(out)]) == 0
    (pd,) = json.loads(out.read_text())
    assert pd["env_settings"] == {"control": "'pd'", "horizon": "1000", "random_start": "True"}
    assert pd["expert_return"] == pytest.approx(rows[0]["expert_return"])  # the same frames, the same reward
    assert pd["hold_return"] != rows[0]["hold_return"]  # held by the PD servos, not by torques
    assert "measured under control='pd', horizon=1000" in capsys.readouterr().out
    assert main(["--references", "UnitreeH1.walk", "--env", "control=bogus"]) == 2
    assert "invalid control for UnitreeH1 'bogus'; valid: torque, pd" in capsys.readouterr().err
    assert main(["--references", "UnitreeH1.walk", "--env", "pd"]) == 2
    assert "--env takes KEY=VALUE settings (e.g. control=pd), got 'pd'" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # an agent is evaluated under the settings it trained with
        main([*VAIL_PRETRAINED, "--env", "control=torque"])
