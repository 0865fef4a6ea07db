"""Adversarial imitation baselines: the algorithms run, the discriminator learns, checkpoints resume exactly,
and the fast TRPO's Fisher-vector product equals the double-backward one of Mushroom-RL's TRPO."""

import copy
import io
import math

import numpy as np
import pytest
import torch

import loco_mujoco as lm

# isort: split
from mushroom_rl.algorithms.actor_critic import TRPO  # noqa: E402
from mushroom_rl.core import Core, MDPInfo  # noqa: E402
from mushroom_rl.utils.spaces import Box  # noqa: E402
from sklearn.metrics import roc_auc_score  # noqa: E402

from baselines import make_agent  # noqa: E402
from baselines.common import (  # noqa: E402
    CSVLogger,
    ExpertData,
    FastTRPO,
    GaussianPolicy,
    MushroomMLP,
    RunningStandardizer,
    evaluate,
)
from baselines.common.expert_data import kinematic_obs_mask  # noqa: E402

STEPS_PER_FIT = 200
# One torch thread: fast on a busy machine, and the same float results from run to run.
SMALL = {"n_threads": 1}


@pytest.fixture(scope="module", autouse=True)
def restore_torch_threads():
    """The agents set torch's (process-wide) thread count; leave it as the other tests found it."""
    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


@pytest.fixture(scope="module")
def env():
    return lm.LocoEnv.make("UnitreeH1.walk", horizon=STEPS_PER_FIT)


@pytest.fixture(scope="module")
def expert_with_actions(env):
    """The real dataset has no actions; GAIL's smoke test gets made-up ones (shape is all that matters)."""
    data = env.create_dataset()
    actions = np.random.default_rng(0).uniform(-1, 1, (len(data["states"]), env.info.action_space.shape[0]))
    return ExpertData({**data, "actions": actions}, kinematic_obs_mask(env))


def learn(agent, env, n_fits: int) -> None:
    Core(agent, env).learn(n_steps=n_fits * STEPS_PER_FIT, n_steps_per_fit=STEPS_PER_FIT, quiet=True)


@pytest.mark.parametrize("algorithm", ["gail", "vail", "gaifo"])
def test_each_algorithm_runs_three_fits_with_finite_losses(env, expert_with_actions, algorithm):
    expert = expert_with_actions if algorithm == "gail" else None
    agent = make_agent(algorithm, env, {**SMALL, "train_disc_every": 1}, seed=0, expert=expert)
    learn(agent, env, 3)
    stats = agent.last_stats
    assert agent.fit_count == 3
    for key in ("disc_loss", "disc_reward_mean", "surrogate", "surrogate_new", "kl", "critic_loss", "entropy"):
        assert math.isfinite(stats[key]), (key, stats)
    assert 0.0 <= stats["kl"] <= 1.5 * agent.config.max_kl
    assert all(torch.isfinite(p).all() for p in agent.policy.parameters())
    if algorithm == "vail":
        assert math.isfinite(stats["disc_kl"]) and stats["beta"] >= 0.0


def test_gail_without_expert_actions_names_gaifo(env):
    with pytest.raises(ValueError, match="GAIfO"):
        make_agent("gail", env, SMALL)


def test_unknown_config_key_raises(env):
    with pytest.raises(ValueError, match="unknown VAILConfig keys \\['disc_lrr'\\]"):
        make_agent("vail", env, {"disc_lrr": 1e-3})
    with pytest.raises(ValueError, match="unknown algorithm"):
        make_agent("airl", env)
    with pytest.raises(ValueError, match="learner must be"):
        make_agent("gaifo", env, {"learner": "ppo"})
    with pytest.raises(ValueError, match=r"GAIfOConfig.policy_hidden must be tuple\[int, ...\]"):
        make_agent("gaifo", env, {"policy_hidden": [512, "256"]})


def random_policy_states(env, n: int, seed: int) -> np.ndarray:
    """States of a seeded uniform-random policy, restarting after each fall."""
    rng = np.random.default_rng(seed)
    states, obs = [], env.reset()
    for _ in range(n):
        states.append(obs.copy())
        obs, _, absorbing, _ = env.step(rng.uniform(-1, 1, env.info.action_space.shape[0]))
        if absorbing:
            obs = env.reset()
    return np.array(states, dtype=np.float32)


@pytest.mark.parametrize("algorithm", ["vail", "gaifo"])
def test_discriminator_separates_expert_from_random_policy(env, algorithm):
    config = {**SMALL, "disc_lr": 1e-3, "disc_batch_size": 512}
    agent = make_agent(algorithm, env, config, seed=0)
    train, held_out = random_policy_states(env, 1024, seed=1), random_policy_states(env, 512, seed=2)
    rng = np.random.default_rng(3)
    no_action = np.zeros((256, env.info.action_space.shape[0]), np.float32)
    for _ in range(200):  # 200 steps on 256 policy + 256 expert transitions
        idx = rng.integers(0, len(train) - 1, 256)
        agent.train_discriminator(train[idx], no_action, train[idx + 1])
    expert = agent.expert
    idx = np.random.default_rng(4).choice(len(expert), 500, replace=False)
    full = np.zeros((len(idx), env.info.observation_space.shape[0]), np.float32)
    expert_s, expert_sn = full.copy(), full.copy()
    expert_s[:, agent.obs_mask], expert_sn[:, agent.obs_mask] = expert.states[idx], expert.next_states[idx]
    r_expert = agent.reward(expert_s, no_action[:1].repeat(len(idx), 0), expert_sn)
    r_policy = agent.reward(held_out[:-1], no_action[:1].repeat(len(held_out) - 1, 0), held_out[1:])
    labels = np.r_[np.ones(len(r_expert)), np.zeros(len(r_policy))]
    auc = roc_auc_score(labels, np.r_[r_expert, r_policy])
    print(f"{algorithm}: AUC {auc:.3f}")
    assert auc > 0.9


def flat_state(state) -> dict:
    """Every tensor and value in a (nested) state dict, keyed by path."""
    out = {}

    def walk(prefix, value):
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}/{k}", v)
        elif isinstance(value, (list, tuple)):
            for i, v in enumerate(value):
                walk(f"{prefix}/{i}", v)
        else:
            out[prefix] = value

    walk("", state)
    return out


def assert_same_state(a, b) -> None:
    fa, fb = flat_state(a), flat_state(b)
    assert fa.keys() == fb.keys()
    for key in fa:
        if isinstance(fa[key], torch.Tensor):
            assert torch.equal(fa[key], fb[key]), key
        else:
            assert fa[key] == fb[key], key


def test_state_dict_round_trip_resumes_exactly(env):
    config = {**SMALL, "train_disc_every": 2}  # the discriminator trains before and after the checkpoint
    uninterrupted = make_agent("vail", env, config, seed=7)
    for _ in range(4):
        learn(uninterrupted, env, 1)

    first_half = make_agent("vail", env, config, seed=7)
    for _ in range(2):
        learn(first_half, env, 1)
    buffer = io.BytesIO()
    torch.save(first_half.state_dict(), buffer)
    buffer.seek(0)
    checkpoint = torch.load(buffer, weights_only=True)  # plain tensors and Python values only
    resumed = make_agent("vail", env, config, seed=123)  # a different seed: everything must come from the file
    resumed.load_state_dict(checkpoint)
    assert_same_state(resumed.state_dict(), first_half.state_dict())
    for _ in range(2):
        learn(resumed, env, 1)

    assert_same_state(resumed.state_dict(), uninterrupted.state_dict())
    assert resumed.last_stats == uninterrupted.last_stats
    states = random_policy_states(env, 5, seed=0)
    actions_a = [uninterrupted.draw_action(s) for s in states]
    actions_b = [resumed.draw_action(s) for s in states]
    np.testing.assert_array_equal(actions_a, actions_b)


def fast_critic_params(learner: FastTRPO) -> dict:
    net = learner.critic
    return dict(network=MushroomMLP, input_shape=(7,), output_shape=(1,), hidden=(8,), standardizer=net.standardizer,
                optimizer={"class": torch.optim.Adam, "params": {"lr": 1e-3}}, loss=torch.nn.functional.mse_loss,
                batch_size=16)


def small_learner(activation: str, fisher: str, **kwargs) -> FastTRPO:
    obs_dim, act_dim = 7, 3
    info = MDPInfo(Box(-np.ones(obs_dim), np.ones(obs_dim)), Box(-np.ones(act_dim), np.ones(act_dim)), 0.99, 100)
    standardizer = RunningStandardizer(obs_dim)
    standardizer.update(np.random.default_rng(0).normal(1.0, 2.0, (50, obs_dim)))
    policy = GaussianPolicy(obs_dim, act_dim, hidden=(16, 8), activation=activation, std_0=0.7,
                            standardizer=standardizer, generator=torch.Generator().manual_seed(0))
    with torch.no_grad():  # a non-trivial policy: output layer and log-std away from their initial values
        policy.mean_net[-2].weight.normal_(0, 0.5, generator=torch.Generator().manual_seed(1))
        policy.log_std.copy_(torch.tensor([-0.3, 0.1, 0.4]))
    policy.invalidate_cache()
    critic_params = dict(network=MushroomMLP, input_shape=(obs_dim,), output_shape=(1,), hidden=(8,),
                         standardizer=standardizer, optimizer={"class": torch.optim.Adam, "params": {"lr": 1e-3}},
                         loss=torch.nn.functional.mse_loss, batch_size=16)
    kwargs = {"fisher": fisher, "fisher_fraction": 1.0, "overlap_critic": False, **kwargs}
    return FastTRPO(info, policy, critic_params, **kwargs)


@pytest.mark.parametrize("activation", ["relu", "tanh"])
@pytest.mark.parametrize("fisher", ["analytic", "autograd"])
def test_fisher_vector_product_equals_double_backward(activation, fisher):
    learner = small_learner(activation, fisher)
    obs = torch.from_numpy(np.random.default_rng(2).normal(1.0, 2.0, (32, 7)).astype(np.float32))
    fvp = learner._fisher_operator(obs)
    with torch.no_grad():
        old_dist = learner.policy.distribution_t(obs)
    n_params = sum(p.numel() for p in learner.policy.parameters())
    for seed in range(3):
        v = torch.from_numpy(np.random.default_rng(seed).normal(size=n_params).astype(np.float32))
        reference = TRPO._fisher_vector_product_t(learner, v, obs, old_dist)  # Mushroom: recomputes everything
        torch.testing.assert_close(fvp(v), reference, rtol=1e-4, atol=1e-6)


def synthetic_dataset(n: int, obs_dim: int, act_dim: int, seed: int) -> list[tuple]:
    """Core-style transitions: chained states, an episode end every 25 steps, one fall."""
    rng = np.random.default_rng(seed)
    states = rng.normal(1.0, 2.0, (n + 1, obs_dim))
    dataset = []
    for k in range(n):
        last = (k + 1) % 25 == 0 or k == 60
        next_state = states[k + 1] if not last else rng.normal(1.0, 2.0, obs_dim)
        dataset.append((states[k], rng.normal(size=act_dim), float(rng.normal()), next_state, k == 60, last))
    return dataset


class MushroomTRPOSeparateCGVectors(TRPO):
    """Mushroom's TRPO with one fix: on CPU its ``_conjugate_gradient`` takes ``p`` and ``r`` as two numpy views
    of the gradient's buffer, so ``r -= v * z`` also changes ``p`` and the first direction update is wrong.
    This copy of its loop differs only by the two ``.copy()`` calls."""

    def _conjugate_gradient(self, b, obs, old_pol_dist):
        p, r = b.detach().numpy().copy(), b.detach().numpy().copy()
        x = np.zeros_like(p)
        r2 = r.dot(r)
        for _ in range(self._n_epochs_cg()):
            z = self._fisher_vector_product(p, obs, old_pol_dist).detach().cpu().numpy()
            v = r2 / p.dot(z)
            x += v * p
            r -= v * z
            r2_new = r.dot(r)
            p = r + r2_new / r2 * p
            r2 = r2_new
            if r2 < self._cg_residual_tol():
                break
        return x


def test_mushroom_conjugate_gradient_overwrites_its_input_on_cpu():
    """Why the reference above has its own CG loop: Mushroom's aliases p and r (and so the gradient)."""
    learner = small_learner("relu", "analytic")
    obs = torch.from_numpy(np.random.default_rng(2).normal(size=(32, 7)).astype(np.float32))
    with torch.no_grad():
        old_dist = learner.policy.distribution_t(obs)
    b = torch.from_numpy(np.random.default_rng(0).normal(size=len(learner.policy.get_weights())).astype(np.float32))
    b_before = b.clone()
    TRPO._conjugate_gradient(learner, b, obs, old_dist)
    assert not torch.equal(b, b_before)


def test_fast_trpo_update_equals_mushroom_trpo_on_the_whole_batch():
    """With the Fisher on the whole batch, one FastTRPO fit moves the policy as Mushroom's TRPO.fit does
    (5 CG iterations: beyond that, float32 round-off grows through the CG recursion in both)."""
    fast = small_learner("relu", "analytic", n_epochs_cg=5)
    mushroom = MushroomTRPOSeparateCGVectors(fast.mdp_info, copy.deepcopy(fast.policy), fast_critic_params(fast),
                                             max_kl=5e-3, lam=0.97, n_epochs_cg=5, cg_damping=1e-2)
    mushroom._V.model.network.load_state_dict(fast.critic.state_dict())
    dataset = synthetic_dataset(200, 7, 3, seed=0)
    theta_0 = fast.policy.get_weights()
    fast.fit(dataset)
    mushroom.fit(dataset)
    step_fast, step_mushroom = fast.policy.get_weights() - theta_0, mushroom.policy.get_weights() - theta_0
    assert np.abs(step_mushroom).max() > 1e-3
    np.testing.assert_allclose(step_fast, step_mushroom, rtol=0, atol=1e-4 * np.abs(step_mushroom).max())


def test_policy_numpy_path_matches_torch_path():
    learner = small_learner("tanh", "analytic")
    policy = learner.policy
    states = np.random.default_rng(5).normal(1.0, 2.0, (10, 7))
    with torch.no_grad():
        torch_mean = policy.mean_t(torch.from_numpy(states)).numpy()
    np.testing.assert_allclose(policy.mean_numpy(states), torch_mean, rtol=1e-5, atol=1e-6)
    policy.set_weights(policy.get_weights() * 0.5)  # the numpy copy must follow the weights
    with torch.no_grad():
        torch_mean = policy.mean_t(torch.from_numpy(states)).numpy()
    np.testing.assert_allclose(policy.mean_numpy(states), torch_mean, rtol=1e-5, atol=1e-6)


def test_running_standardizer_matches_batch_statistics():
    rng = np.random.default_rng(0)
    batches = [rng.normal(1e4, 1e-2, (n, 3)) for n in (1, 7, 100, 3)]  # large mean, tiny spread
    standardizer = RunningStandardizer(3)
    for batch in batches:
        standardizer.update(batch)
    everything = np.concatenate(batches)
    np.testing.assert_allclose(standardizer.mean, everything.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(standardizer.var, everything.var(axis=0), rtol=1e-6)
    restored = RunningStandardizer(3)
    restored.load_state_dict(standardizer.state_dict())
    np.testing.assert_array_equal(restored.normalize(everything), standardizer.normalize(everything))


def test_evaluate_reports_returns_and_lengths(env):
    agent = make_agent("gaifo", env, SMALL, seed=0)
    rng_before = agent.policy.rng.bit_generator.state
    for deterministic in (True, False):
        result = evaluate(agent, env, n_episodes=2, deterministic=deterministic)
        assert result["episodes"] == 2 and 0 < result["L"] <= STEPS_PER_FIT
        assert math.isfinite(result["R"]) and math.isfinite(result["J"])
        # Task rewards are >= 0 here, so the discounted return is at most the undiscounted one.
        assert 0.0 <= result["J"] <= result["R"] + 1e-9
        assert result["task_reward"] == pytest.approx(result["R"] / result["L"])  # equal-length episodes or not
    assert agent.policy.rng.bit_generator.state == rng_before  # evaluation never uses the training noise


def test_csv_logger_appends_and_widens(tmp_path):
    logger = CSVLogger(tmp_path, tensorboard=False)
    logger.log(1000, R=1.5, L=20)
    logger.log(2000, R=torch.tensor(2.5), L=30, beta=0.1)  # a new key widens the header, keeping old rows
    CSVLogger(tmp_path, tensorboard=False).log(3000, R=3.5)  # a resumed run appends to the same file
    lines = (tmp_path / "progress.csv").read_text().splitlines()
    assert lines == ["step,R,L,beta", "1000,1.5,20,", "2000,2.5,30,0.1", "3000,3.5,,"]
