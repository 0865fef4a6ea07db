"""Batched on-policy collection (baselines/common/batched.py): the batch it hands to the fit, threads, the
``train.n_envs`` switch, reproducibility and exact resume of batched training runs."""

import math

import numpy as np
import pytest
import torch

import loco_mujoco as lm

# isort: split
from conftest import TINY_TRAINING  # noqa: E402
from test_training import assert_identical, progress_rows, tiny_run  # noqa: E402

from baselines.common.batched import BatchedCollector, EnvThreadPool, env_seeds  # noqa: E402
from baselines.common.fast_trpo import dataset_to_arrays  # noqa: E402
from baselines.common.policy import GaussianPolicy  # noqa: E402
from baselines.config import ConfigError, load_run_config  # noqa: E402
from baselines.training import Trainer, load_checkpoint  # noqa: E402

HORIZON = 15  # short episodes: the batches hold horizon ends as well as falls


@pytest.fixture(scope="module", autouse=True)
def restore_torch_threads():
    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


def make_envs(n: int, seed: int = 3) -> list:
    return [lm.LocoEnv.make("UnitreeH1.walk", control="pd", random_start=True, horizon=HORIZON, seed=s)
            for s in env_seeds(seed, n)]


class Recorder:
    """An agent that records the batches it is handed and never changes its (small, random) policy."""

    preprocessors: list = []

    def __init__(self, env, seed: int = 5):
        self.policy = GaussianPolicy(env.info.observation_space.shape[0], env.info.action_space.shape[0],
                                     hidden=(32,), std_0=0.5, seed=seed,
                                     generator=torch.Generator().manual_seed(seed))
        self.batches: list[tuple[np.ndarray, ...]] = []

    def fit_arrays(self, *arrays):
        self.batches.append(tuple(a.copy() for a in arrays))

    def stop(self):
        pass


def naive_batches(policy, envs, steps_per_env: int, n_fits: int) -> list[tuple[np.ndarray, ...]]:
    """The reference: ``env.step`` on each env in turn, Core's episode rules, transitions env by env."""
    n = len(envs)
    states, episode_steps = [env.reset() for env in envs], [0] * n
    out = []
    for _ in range(n_fits):
        rows: list[list[tuple]] = [[] for _ in envs]
        for _ in range(steps_per_env):
            actions = policy.draw_actions(np.array(states))
            for i, env in enumerate(envs):
                obs, reward, absorbing, _ = env.step(actions[i])
                episode_steps[i] += 1
                last = absorbing or episode_steps[i] >= HORIZON
                rows[i].append((states[i], actions[i], reward, obs, absorbing, last))
                states[i], episode_steps[i] = (env.reset(), 0) if last else (obs, episode_steps[i])
        arrays = dataset_to_arrays([t for env_rows in rows for t in env_rows])
        arrays[5][steps_per_env - 1::steps_per_env] = True  # each env's segment ends with the batch
        out.append(arrays)
    return out


def test_split_step_is_step():
    a, b = make_envs(1, seed=0) + make_envs(1, seed=0)
    a.reset(), b.reset()
    rng = np.random.default_rng(0)
    for _ in range(40):
        action = rng.uniform(-1.2, 1.2, a.info.action_space.shape[0])
        obs, reward, absorbing, info = a.step(action)
        clipped = b.apply_action(action)
        b.step_physics()
        obs_b, reward_b, absorbing_b, info_b = b.finish_step(clipped)
        np.testing.assert_array_equal(obs, obs_b)
        assert (reward, absorbing) == (reward_b, absorbing_b)
        np.testing.assert_array_equal(info["root_pos"], info_b["root_pos"])
        if absorbing:
            a.reset(), b.reset()


def test_draw_actions_equals_draw_action_row_by_row():
    env = make_envs(1)[0]
    p, q = Recorder(env).policy, Recorder(env).policy
    states = np.random.default_rng(1).standard_normal((6, env.info.observation_space.shape[0]))
    batch = p.draw_actions(states)
    rows = np.stack([q.draw_action(s) for s in states])
    assert batch.shape == (6, env.info.action_space.shape[0]) and batch.dtype == np.float64
    np.testing.assert_allclose(batch, rows, rtol=0, atol=1e-6)  # one product vs six: float32 rounding only
    assert p.rng.bit_generator.state == q.rng.bit_generator.state  # the same noise consumed
    with p.evaluation_mode(deterministic=True):
        np.testing.assert_array_equal(p.draw_actions(states), p.mean_numpy(states).astype(np.float64))


@pytest.mark.parametrize("n_envs, n_threads", [(3, 1), (3, 2), (4, 3)])
def test_the_batch_is_a_plain_loop_over_the_envs_env_by_env(n_envs, n_threads):
    steps_per_env, n_fits = 20, 3
    envs = make_envs(n_envs)
    agent = Recorder(envs[0])
    collector = BatchedCollector(agent, envs, n_threads=n_threads)
    assert collector.n_threads == n_threads
    collector.learn(n_steps=n_fits * steps_per_env * n_envs, n_steps_per_fit=steps_per_env * n_envs)
    collector.close()
    expected = naive_batches(Recorder(envs[0]).policy, make_envs(n_envs), steps_per_env, n_fits)
    assert len(agent.batches) == n_fits
    obs_dim, act_dim = envs[0].info.observation_space.shape[0], envs[0].info.action_space.shape[0]
    n = steps_per_env * n_envs
    for got, want in zip(agent.batches, expected, strict=True):
        assert [a.shape for a in got] == [(n, obs_dim), (n, act_dim), (n,), (n, obs_dim), (n,), (n,)]
        assert [a.dtype for a in got] == [np.float32] * 4 + [bool] * 2
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)
        x, _, _, xn, absorbing, last = got
        ends = last.reshape(n_envs, steps_per_env)
        assert ends[:, -1].all()  # each env's segment ends the GAE's trajectory
        assert np.all(last[absorbing])
        inner = ~last[:-1]
        np.testing.assert_array_equal(xn[:-1][inner], x[1:][inner])  # contiguous within each segment
    assert collector.episodes > 0  # episode ends inside the batches (falls and the short horizon)


def test_thread_pool_runs_every_item_once_and_reraises():
    pool = EnvThreadPool(7, 3)
    assert [list(c) for c in pool.chunks] == [[0, 1], [2, 3, 4], [5, 6]]
    seen = []
    pool.run(seen.append)
    assert sorted(seen) == list(range(7))

    def fail(i):
        if i == 5:
            raise RuntimeError("env 5 broke")

    with pytest.raises(RuntimeError, match="env 5 broke"):
        pool.run(fail)
    seen.clear()
    pool.run(seen.append)  # usable after an error
    pool.close()
    pool.run(seen.append)  # after close: everything in the caller's thread
    assert sorted(seen) == sorted(list(range(7)) * 2)


def test_n_envs_is_validated():
    overrides = {k: dict(v) for k, v in TINY_TRAINING.items()}
    for bad, match in [({"n_envs": 0}, "n_envs must be >= 1"), ({"n_envs": 3}, "multiple of train.n_envs"),
                       ({"env_threads": -1}, "env_threads must be >= 0")]:
        with pytest.raises(ConfigError, match=match):
            load_run_config("UnitreeH1.walk", "vail", overrides={**overrides, "train": {**overrides["train"], **bad}})
    with pytest.raises(ConfigError, match="on-policy"):
        load_run_config("UnitreeH1.walk.perfect", "sqil", overrides={"train": {"n_envs": 2}})
    assert load_run_config("UnitreeH1.walk", "vail").train.n_envs == 1


def batched_run(n_steps: int, n_envs: int = 4, env_threads: int = 0):
    run = tiny_run(n_steps=n_steps)
    run.train.n_envs, run.train.env_threads = n_envs, env_threads
    return run


def test_batched_training_is_reproducible_whatever_the_threads_and_its_losses_are_finite(tmp_path):
    a = Trainer(batched_run(400, env_threads=2), tmp_path / "a", progress=False)
    b = Trainer(batched_run(400, env_threads=1), tmp_path / "b", progress=False)
    assert (a.collector.n_envs, a.collector.n_threads, b.collector.n_threads) == (4, 2, 1)
    assert len({env.model for env in a.collector.envs}) == 4 and a.collector.envs[0] is a.env
    a.train(), b.train()
    stats = a.agent.last_stats
    for key in ("disc_loss", "critic_loss", "surrogate", "surrogate_new", "kl", "disc_reward_mean"):
        assert math.isfinite(stats[key]), key
    assert stats["fit"] == 2
    ca, cb = load_checkpoint(tmp_path / "a"), load_checkpoint(tmp_path / "b")
    assert_identical(ca["agent"], cb["agent"])
    assert_identical(ca["env_rngs"], cb["env_rngs"])
    assert len(ca["env_rngs"]) == 4 and ca["env_rngs"][0] == ca["env_rng"]
    assert progress_rows(tmp_path / "a") == progress_rows(tmp_path / "b")
    one = Trainer(tiny_run(n_steps=400), tmp_path / "one", progress=False)
    assert one.collector is None  # n_envs 1: Core with one environment, as before


def test_batched_resume_reproduces_the_uninterrupted_run_exactly(tmp_path):
    Trainer(batched_run(1200), tmp_path / "straight", progress=False).train()
    Trainer(batched_run(400), tmp_path / "split", progress=False).train()  # "killed" after one epoch
    resumed = Trainer(batched_run(1200), tmp_path / "split", resume=True, progress=False)
    assert (resumed.epoch, resumed.steps, resumed.run.train.n_envs) == (1, 400, 4)
    resumed.train()
    a, b = load_checkpoint(tmp_path / "straight"), load_checkpoint(tmp_path / "split")
    assert a["steps"] == b["steps"] == 1200
    for key in ("agent", "env_rng", "env_rngs", "torch_rng"):
        assert_identical(a[key], b[key], key)
    assert progress_rows(tmp_path / "straight") == progress_rows(tmp_path / "split")
