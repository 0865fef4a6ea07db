import os
import tempfile  # noqa: E402

os.environ.setdefault("MUJOCO_GL", "egl")
# Datasets are built into a fresh cache per test session: tests never read a user's cache or a stale build.
os.environ["LOCO_MUJOCO_CACHE"] = tempfile.mkdtemp(prefix="loco_mujoco_test_cache_")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import torch  # noqa: E402

# Under pytest-xdist (`make test` runs one worker per CPU) every worker gets one torch thread: two processes with
# two threads each on two cores collapse torch's throughput (156 -> 4-40 updates/s measured here).
if os.environ.get("PYTEST_XDIST_WORKER"):
    torch.set_num_threads(1)

import loco_mujoco as lm  # noqa: E402
import loco_mujoco.evaluation.references as reference_policies  # noqa: E402

# The protocol's 1,000 random-action episodes per reference set cost 20-40 s per task and settings: the tests' runs
# and evaluations (scores of untrained agents) take 20, a test of the default sets its own.
reference_policies.RANDOM_EPISODES = 20

# Every task name without a dataset type; of the body-size modes only "all" and the smallest ("1").
BASE_TASKS = [t for t in lm.list_tasks() if t.split(".")[-1] not in ("real", "perfect", "preference")
              and t.split(".")[-1] not in ("2", "3", "4")]

# Config overrides for a training run small enough for a test (through the real Trainer): tiny networks, 200 steps
# per fit, 400 per epoch, 100-step episodes.
TINY_TRAINING = {"env": {"horizon": 100},
                 "train": {"n_steps": 1200, "epoch_steps": 400, "n_eval_episodes": 2, "n_steps_per_fit": 200},
                 "agent": {"n_threads": 1, "policy_hidden": [32], "critic_hidden": [32],
                           "disc_hidden": [32], "disc_batch_size": 128, "train_disc_every": 1}}


@pytest.fixture(autouse=True)
def _seed_global_torch_rng():
    """Each test starts from the same torch global RNG state, so its draws do not depend on which tests a
    pytest-xdist worker happened to run before it."""
    torch.manual_seed(0)


@pytest.fixture(scope="session")
def make_env():
    """Build each (name, kwargs) environment once per session; tests reset it before use."""
    cache = {}

    def _make(name, **kwargs):
        key = (name, tuple(sorted(kwargs.items())))
        if key not in cache:
            cache[key] = lm.LocoEnv.make(name, **kwargs)
        env = cache[key]
        env.seed(0)
        env.reset()
        return env

    return _make


def random_rollout(env, seed, n_steps):
    """Observations, rewards and absorbing flags of a seeded random-action rollout with resets."""
    env.seed(seed)
    rng = np.random.default_rng(seed)
    obs = [env.reset()]
    rewards, absorbing = [], []
    n_act = env.info.action_space.shape[0]
    for _ in range(n_steps):
        o, r, a, _ = env.step(rng.uniform(-1, 1, n_act))
        obs.append(o.copy())
        rewards.append(r)
        absorbing.append(a)
        if a:
            obs.append(env.reset())
    return np.array(obs), np.array(rewards), np.array(absorbing)
