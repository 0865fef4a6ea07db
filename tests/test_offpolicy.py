"""IQ-Learn, LS-IQ and SQIL: updates on real data, their losses' defining properties, the hand-written backward
passes (critics, actor) and the whole update against autograd, and exact resumption from a checkpoint plus the
replay buffer saved beside it."""

import copy
import json

import numpy as np
import pytest
import torch
from mushroom_rl.core import Core

import loco_mujoco as lm
from baselines import ALGORITHMS, make_agent
from baselines.common import gemm
from baselines.common.expert_data import ExpertData
from baselines.common.offpolicy import CriticBatch, fused_adam_step
from baselines.common.squashed_policy import TanhGaussianPolicy
from baselines.common.standardizer import RunningStandardizer
from baselines.common.twin_critic import TwinCritic
from baselines.config import load_run_config
from baselines.lsiq.lsiq import lsiq_loss, lsiq_value_target, q_bound, value_floor
from baselines.sqil.sqil import sqil_loss, sqil_rewards

OFFPOLICY = ["iq_learn", "lsiq", "sqil"]
SMALL = {"actor_hidden": [32, 32], "critic_hidden": [32, 32], "batch_size": 32, "initial_samples": 100,
         "n_threads": 1}


@pytest.fixture(scope="module")
def env():
    return lm.LocoEnv.make("UnitreeH1.walk.perfect", horizon=100)


@pytest.fixture(scope="module", autouse=True)
def restore_torch_threads():
    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


def learn(agent, env, n_steps, seed=0):
    env.seed(seed)
    Core(agent, env).learn(n_steps=n_steps, n_steps_per_fit=1, quiet=True)


@pytest.mark.parametrize("algorithm", OFFPOLICY)
def test_updates_on_expert_data_give_finite_losses(env, algorithm):
    agent = make_agent(algorithm, env, config=SMALL, seed=0)
    assert ALGORITHMS[algorithm].family == "offpolicy"
    before = [p.detach().clone() for p in agent.policy.parameters()]
    learn(agent, env, 300)
    stats = agent.last_stats
    assert agent.updates == 201 and stats["updates"] == 201 and stats["replay_size"] == 300
    assert all(np.isfinite(v) for v in stats.values()), stats
    assert stats["alpha"] == pytest.approx(1e-3, rel=1e-5)  # fixed temperature
    assert all(not torch.equal(a, b) for a, b in zip(before, agent.policy.parameters(), strict=True))
    with agent.policy.evaluation_mode(deterministic=True, seed=0):  # the mean action, inside the box
        action = agent.draw_action(env.reset())
    assert action.shape == (11,) and np.all(np.abs(action) < 1)


def test_budget_scales_the_warm_up(env):
    agent = make_agent("lsiq", env, config={**SMALL, "initial_samples": 10_000}, seed=0)
    agent.set_budget(50_000)
    assert agent.warmup == 5_000
    agent.set_budget(100)
    assert agent.warmup == SMALL["batch_size"]  # never below one batch


def test_lsiq_targets_and_values_stay_within_the_bound(env):
    gamma, c = 0.99, 0.5
    q_max = q_bound(c, gamma)
    assert q_max == pytest.approx(200.0)
    next_v = torch.tensor([-1e6, -50.0, 0.0, 50.0, 1e6, 1e6])
    absorbing = torch.tensor([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    target = lsiq_value_target(next_v, absorbing, gamma, c)
    assert torch.all(target.abs() <= q_max + 1e-4)
    assert target[0] == pytest.approx(-q_max) and target[-1] == pytest.approx(-q_max)  # absorbing: -Q_max forever
    assert target[2] == pytest.approx(-1 / c)

    # A strong regulariser (Q_max = 2) and a fast critic: the expert's values converge to the bound and no value
    # leaves it by more than the regression error of a tiny network.
    agent = make_agent("lsiq", env, config={**SMALL, "reg_mult": 50.0, "critic_lr": 3e-3}, seed=0)
    bound = q_bound(50.0, agent.mdp_info.gamma)
    learn(agent, env, 600)
    q_all, q_expert = [], []
    for _ in range(10):
        x, action, _, _ = agent._sample()
        with torch.no_grad():
            q, _ = agent.critic(torch.cat([x, action], 1))
        q_all.append(q)
        q_expert.append(q[:, SMALL["batch_size"]:])
    assert 0.9 * bound < torch.cat(q_expert, 1).mean() < 1.1 * bound
    assert torch.cat(q_all, 1).abs().max() < 1.5 * bound


def test_lsiq_loss_forms_written_out():
    gamma, c, b = 0.99, 0.5, 3
    q_max = q_bound(c, gamma)
    gen = torch.Generator().manual_seed(0)
    q, v = 50 * torch.randn((2, 2 * b), generator=gen), 50 * torch.randn((2, 2 * b), generator=gen)
    next_v = torch.tensor([-1e6, -50.0, 0.0, 50.0, 1e6, 20.0])
    absorbing = torch.tensor([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    batch = CriticBatch(q=q, v=v, next_v=next_v, absorbing=absorbing, n_agent=b, gamma=gamma)
    # clipped; an absorbing s' is worth the form's floor: -Q_max (least squares), -Q_max / 2 (chi2)
    y = gamma * torch.tensor([-q_max, -50.0, 0.0, 50.0, q_max, -q_max])
    y_chi2 = torch.cat([y[:-1], torch.tensor([-gamma * q_max / 2])])
    assert value_floor(c, gamma) == pytest.approx(-200.0) and value_floor(c, gamma, "chi2") == pytest.approx(-100.0)
    expert = sum(((q[j, b:] - q_max) ** 2).mean() for j in range(2))
    least_squares = expert + sum(((v[j] - (y - 1 / c)) ** 2).mean() for j in range(2))
    chi2 = expert + sum((v[j] - y_chi2).mean() + c * ((q[j] - y_chi2) ** 2).mean() for j in range(2))
    got, stats = lsiq_loss(batch, c)
    assert got.item() == pytest.approx(least_squares.item(), rel=1e-6) and "chi2_term" not in stats
    got, stats = lsiq_loss(batch, c, "chi2")
    assert got.item() == pytest.approx(chi2.item(), rel=1e-6)
    assert stats["reward_agent"].item() == pytest.approx((q[:, :b] - y_chi2[:b]).mean().item(), rel=1e-6)
    with pytest.raises(ValueError, match="loss_form must be one of"):
        lsiq_loss(batch, c, "iq_like")


def test_lsiq_chi2_form_reads_the_agents_values(env):
    with pytest.raises(ValueError, match="loss_form must be one of .*'sqil_like'"):
        make_agent("lsiq", env, config={**SMALL, "loss_form": "sqil_like"}, seed=0)
    stats = {}
    for form in ("least_squares", "chi2"):
        agent = make_agent("lsiq", env, config={**SMALL, "loss_form": form}, seed=0)
        assert agent.uses_agent_values == (form == "chi2")
        learn(agent, env, 150)
        stats[form] = agent.last_stats
        assert np.isfinite(stats[form]["critic_loss"]) and np.isfinite(stats[form]["q_agent"])
    assert "chi2_term" in stats["chi2"] and "chi2_term" not in stats["least_squares"]
    assert stats["chi2"]["critic_loss"] != stats["least_squares"]["critic_loss"]


def test_sqil_rewards_are_one_for_expert_and_zero_for_agent_samples(env):
    agent = make_agent("sqil", env, config=SMALL, seed=0)
    learn(agent, env, 120)
    x, action, x_next, absorbing = agent._sample()
    b = SMALL["batch_size"]
    expert = agent.obs_standardizer.normalize_torch(agent._expert_states)
    own = agent.obs_standardizer.normalize_torch(torch.from_numpy(agent.buffer.states[:agent.buffer.size]))

    def distance_to_nearest(rows, pool):
        return torch.cdist(rows, pool, compute_mode="donot_use_mm_for_euclid_dist").amin(1).max()

    assert distance_to_nearest(x[:b], own) < 1e-5  # the first half: the agent's own transitions,
    assert distance_to_nearest(x[b:], expert) < 1e-5  # the second: the expert's
    with torch.no_grad():
        q, _ = agent.critic(torch.cat([x, action], 1))
    next_v = torch.randn(2 * b)
    batch = CriticBatch(q=q, v=q, next_v=next_v, absorbing=absorbing, n_agent=b, gamma=0.99)
    rewards = sqil_rewards(batch)
    assert torch.equal(rewards, torch.cat([torch.zeros(b), torch.ones(b)]))
    loss, _ = sqil_loss(batch)
    expected = sum(((q[j] - rewards - 0.99 * (1 - absorbing) * next_v) ** 2).mean() for j in range(2))
    assert loss.item() == pytest.approx(expected.item(), rel=1e-5)
    # clipped targets: V'(s') within [0, 1 / (1 - gamma)] = [0, 100], whatever the critics say
    wild = CriticBatch(q=q, v=q, next_v=next_v * 500.0, absorbing=torch.zeros(2 * b), n_agent=b, gamma=0.99)
    assert (wild.next_v.abs() > 100).any() and (wild.next_v < 0).any()
    loss, stats = sqil_loss(wild, clip_targets=True)
    clipped = rewards + 0.99 * (next_v * 500.0).clamp(0.0, 100.0)
    expected = sum(((q[j] - clipped) ** 2).mean() for j in range(2))
    assert loss.item() == pytest.approx(expected.item(), rel=1e-5)
    assert 0.0 <= stats["td_target"].item() <= 100.0


def test_iq_learn_loss_modes_differ(env):
    losses = {}
    for mode in ("value", "v0"):
        agent = make_agent("iq_learn", env, config={**SMALL, "loss_mode": mode}, seed=0)
        learn(agent, env, 150)
        losses[mode] = agent.last_stats["value_term"]
        assert np.isfinite(agent.last_stats["critic_loss"]) and np.isfinite(agent.last_stats["chi2_term"])
    assert losses["value"] != losses["v0"]


@pytest.mark.parametrize("layer_norm", [False, True])
@pytest.mark.parametrize("backend", ["onednn", "torch"])
@pytest.mark.parametrize("activation", ["relu", "tanh"])
def test_actor_gradient_through_the_critics_matches_autograd(activation, backend, layer_norm):
    critic = TwinCritic(5, 3, (16, 8), activation, generator=torch.Generator().manual_seed(1), layer_norm=layer_norm)
    with torch.no_grad():
        critic.weights[-1].normal_()
    x, a, grad_q = torch.randn(7, 5), torch.randn(7, 3, requires_grad=True), torch.randn(2, 7)
    with gemm.backend(backend), torch.no_grad():
        _, hidden = critic(torch.cat([x, a.detach()], 1), keep=True)
        got = critic.action_gradient(hidden, grad_q)
    values, _ = critic(torch.cat([x, a], 1))
    (expected,) = torch.autograd.grad((values * grad_q).sum(), a)
    assert torch.allclose(got, expected, atol=1e-6)


@pytest.mark.parametrize("backend", ["onednn", "torch"])
@pytest.mark.parametrize("activation", ["relu", "tanh"])
@pytest.mark.parametrize(("loss_start", "n_loss", "n_actions"), [
    (0, 12, 6),  # every row in the loss, the actor's rows among them (IQ-Learn)
    (3, 9, 6),  # leading rows without loss (LS-IQ: the agent's Q(s, a))
    (0, 6, 6),  # the actor's rows outside the loss's (SQIL): each down its own critic
    (0, 12, 0)])
@pytest.mark.parametrize("layer_norm", [False, True])
def test_critic_backward_matches_autograd(activation, loss_start, n_loss, n_actions, backend, layer_norm):
    critic = TwinCritic(5, 3, (16, 8), activation, generator=torch.Generator().manual_seed(1), layer_norm=layer_norm)
    with torch.no_grad():
        critic.weights[-1].normal_()
        for bias in critic.biases:
            bias.normal_()
    x = torch.randn(12, 8)
    grad_values = torch.randn(2, n_loss)
    chosen = torch.randint(0, 2, (n_actions,), generator=torch.Generator().manual_seed(2)) if n_actions else None
    with gemm.backend(backend), torch.no_grad():
        _, hidden = critic(x, keep=True)
        grad_action = critic.backward(x, hidden, grad_values, loss_start, chosen, -0.25)
    manual = [p.grad for p in critic.parameters()]

    inputs = x.clone().requires_grad_()
    values, _ = critic(inputs)
    expected = torch.autograd.grad((values[:, loss_start:loss_start + n_loss] * grad_values).sum(),
                                   list(critic.parameters()), retain_graph=True)
    for got, want in zip(manual, expected, strict=True):
        assert got.shape == want.shape and got.is_contiguous()
        assert torch.allclose(got, want, rtol=1e-5, atol=1e-5), (got - want).abs().max()  # sums of terms ~10
    if n_actions:
        actor_values = values[:, 12 - n_actions:].gather(0, chosen.unsqueeze(0))
        (expected_action,) = torch.autograd.grad(-0.25 * actor_values.sum(), inputs)
        assert torch.allclose(grad_action, expected_action[12 - n_actions:, 5:], rtol=1e-5, atol=1e-6)
    else:
        assert grad_action is None


@pytest.mark.parametrize("backend", ["onednn", "torch"])
@pytest.mark.parametrize("activation", ["relu", "tanh"])
def test_actor_backward_matches_autograd(activation, backend):
    """forward_kept -> squash_t -> squash_backward -> backward_kept: the gradient of the actor's loss
    ``w sum log pi + sum(a * G)`` on the first rows, as autograd gives it through sample_t (clipped log-stds too)."""
    standardizer = RunningStandardizer(6)
    policy = TanhGaussianPolicy(np.ones(6, bool), 3, standardizer, (16, 8), activation,
                                generator=torch.Generator().manual_seed(0))
    g = torch.Generator().manual_seed(1)  # its own stream: the draws must not depend on which tests ran before
    with torch.no_grad():
        policy.net[-2].weight.normal_(std=2.0, generator=g)  # log-stds on both sides of [log_std_min, log_std_max]
    x, noise, grad_action = (torch.randn(shape, generator=g) for shape in ((10, 6), (10, 3), (6, 3)))
    with gemm.backend(backend):
        out, inputs = policy.forward_kept(x)
        raw_log_std = out[:, 3:]
        assert ((raw_log_std < policy.log_std_min) | (raw_log_std > policy.log_std_max)).any()
        action, log_prob = policy.squash_t(out, noise)
        policy.backward_kept(inputs, policy.squash_backward(out[:6], noise[:6], action[:6], 0.3, grad_action))
    manual = [p.grad.clone() for p in policy.parameters()]

    expected_action, expected_log_prob = policy.sample_t(x, noise)
    assert torch.allclose(action, expected_action, atol=1e-6) and torch.allclose(log_prob, expected_log_prob, atol=1e-5)
    loss = 0.3 * expected_log_prob[:6].sum() + (expected_action[:6] * grad_action).sum()
    for got, want in zip(manual, torch.autograd.grad(loss, list(policy.parameters())), strict=True):
        assert torch.allclose(got, want, rtol=1e-5, atol=1e-5), (got - want).abs().max()  # sums of terms ~10


def autograd_update(agent):
    """The update with autograd through actor and critics (the implementation the hand-written one replaced)."""
    x, action, x_next, absorbing = agent._sample()
    n = x.shape[0]
    noise = torch.randn((2, n, agent.policy.act_dim), generator=agent._generator)
    alpha = agent.log_alpha.detach().exp()
    with torch.no_grad():
        next_action, next_log_prob = agent.policy.sample_t(x_next, noise[1])
        next_q, _ = agent.target_critic(torch.cat([x_next, next_action], 1))
        next_v = next_q.amin(0) - alpha * next_log_prob
    new_action, log_prob = agent.policy.sample_t(x, noise[0])
    q, _ = agent.critic(torch.cat([x, action], 1))
    q_new, _ = agent.critic(torch.cat([x, new_action], 1))  # the actor's and the loss's values, one graph
    batch = CriticBatch(q=q, v=q_new - alpha * log_prob.detach(), next_v=next_v, absorbing=absorbing,
                        n_agent=agent.config.batch_size, gamma=agent.mdp_info.gamma)
    if not agent.uses_policy_values:
        batch.v = batch.v.detach()
    critic_loss, _ = agent.critic_loss(batch)
    critic_grads = torch.autograd.grad(critic_loss, list(agent.critic.parameters()), retain_graph=True)
    actor_loss = (alpha * log_prob - q_new.min(0).values).mean()
    actor_grads = torch.autograd.grad(actor_loss, list(agent.policy.parameters()))
    for params, grads, optimizer in ((agent.critic.parameters(), critic_grads, agent.critic_optimizer),
                                     (agent.policy.parameters(), actor_grads, agent.actor_optimizer)):
        for p, g in zip(params, grads, strict=True):
            p.grad = g
        optimizer.step()
    if agent.alpha_optimizer is not None:
        agent.log_alpha.grad = None
        (-(agent.log_alpha * (log_prob.detach() + agent.target_entropy).mean())).backward()
        agent.alpha_optimizer.step()
    agent.critic.soft_update(agent.target_critic, agent.config.tau)


@pytest.mark.parametrize(("algorithm", "extra"), [("sqil", {}), ("iq_learn", {}), ("lsiq", {"learn_alpha": True}),
                                                   ("iq_learn", {"loss_mode": "v0", "activation": "tanh"}),
                                                   ("iq_learn", {"n_critics": 1}), ("lsiq", {"n_critics": 1}),
                                                   ("sqil", {"critic_layer_norm": True, "clip_targets": True}),
                                                   ("iq_learn", {"critic_layer_norm": True}),
                                                   ("lsiq", {"loss_form": "chi2"})])
def test_update_matches_the_autograd_update(env, algorithm, extra):
    agent = make_agent(algorithm, env, config={**SMALL, **extra}, seed=0)
    learn(agent, env, 150)  # the optimisers' states exist
    reference = copy.deepcopy(agent)
    for _ in range(3):
        agent.update()
        autograd_update(reference)
    pairs = [(agent.critic, reference.critic), (agent.target_critic, reference.target_critic),
             (agent.policy.net, reference.policy.net)]
    for ours, theirs in pairs:
        for (name, got), want in zip(ours.named_parameters(), theirs.parameters(), strict=True):
            assert torch.allclose(got, want, rtol=1e-4, atol=1e-6 * float(want.detach().abs().max())), name
    assert torch.allclose(agent.log_alpha, reference.log_alpha)
    assert agent._rng.bit_generator.state == reference._rng.bit_generator.state
    assert torch.equal(agent._generator.get_state(), reference._generator.get_state())


def test_fused_adam_step_is_adam_step():
    params = [torch.nn.Parameter(torch.randn(2, 5, 4, generator=torch.Generator().manual_seed(i))) for i in range(2)]
    twins = [torch.nn.Parameter(p.detach().clone()) for p in params]
    adam = torch.optim.Adam(params, lr=1e-2, fused=True)
    ours = torch.optim.Adam(twins, lr=1e-2, fused=True)
    for step in range(4):
        for p, q in zip(params, twins, strict=True):
            p.grad = torch.randn(p.shape, generator=torch.Generator().manual_seed(10 + step))
            q.grad = p.grad.clone()
        adam.step()
        fused_adam_step(ours)  # the first step (no state yet) goes through Adam.step
    assert all(torch.equal(p, q) for p, q in zip(params, twins, strict=True))
    for p, q in zip(params, twins, strict=True):
        assert all(torch.equal(v, ours.state[q][k]) for k, v in adam.state[p].items())


def test_lsiq_from_observations_learns_an_inverse_model(env):
    data = env.create_dataset()
    expert = ExpertData({k: v for k, v in data.items() if k != "actions"}, np.ones(33, dtype=bool))
    with pytest.raises(ValueError, match="needs expert actions"):
        make_agent("lsiq", env, config=SMALL, expert=expert)
    agent = make_agent("lsiq", env, config={**SMALL, "from_observations": True}, seed=0, expert=expert)
    learn(agent, env, 300)
    first = agent.last_stats["inverse_model_loss"]
    learn(agent, env, 300)
    assert agent.updates == 501 and 0 < agent.last_stats["inverse_model_loss"] < first


def test_offpolicy_family_config():
    run = load_run_config("UnitreeH1.walk", "lsiq")
    assert run.train.n_steps_per_fit == 1 and run.train.expert_actions == "auto"
    assert run.agent.reg_mult == 0.5 and run.agent.batch_size == 256 and run.agent.actor_lr == 3e-5
    assert load_run_config("HumanoidMuscle.walk", "sqil").agent.from_observations
    # LS-IQ's humanoid temperature 0.1 and single critic (bounded targets); twin critics where Q is unbounded
    assert run.agent.alpha == 0.1 and run.agent.n_critics == 1
    iq = load_run_config("UnitreeH1.walk", "iq_learn").agent
    assert iq.n_critics == 2 and iq.alpha == 0.1 and iq.loss_mode == "v0"
    sqil = load_run_config("UnitreeH1.walk", "sqil").agent
    assert sqil.n_critics == 2 and sqil.alpha == 0.1 and sqil.clip_targets and sqil.critic_layer_norm


def test_one_critic_has_one_set_of_weights(env):
    agent = make_agent("iq_learn", env, config={**SMALL, "n_critics": 1}, seed=0)
    assert agent.critic.n == 1 and all(w.shape[0] == 1 for w in agent.critic.weights)
    learn(agent, env, 200)
    assert agent.updates == 101 and all(np.isfinite(v) for v in agent.last_stats.values())
    with pytest.raises(ValueError, match="n_critics must be >= 1"):
        make_agent("iq_learn", env, config={**SMALL, "n_critics": 0})


@pytest.mark.parametrize(("algorithm", "extra"), [("lsiq", {"learn_alpha": True}), ("iq_learn", {}), ("sqil", {}),
                                                   ("lsiq", {"from_observations": True})])
def test_resume_from_checkpoint_and_buffer_is_exact(env, algorithm, extra, tmp_path):
    config = {**SMALL, **extra}
    straight = make_agent(algorithm, env, config=config, seed=3)
    env.seed(0)
    core = Core(straight, env)
    core.learn(n_steps=200, n_steps_per_fit=1, quiet=True)  # two epochs of Core.learn, as the trainer runs them
    core.learn(n_steps=200, n_steps_per_fit=1, quiet=True)

    first = make_agent(algorithm, env, config=config, seed=3)
    env.seed(0)
    Core(first, env).learn(n_steps=200, n_steps_per_fit=1, quiet=True)
    torch.save(first.state_dict(), tmp_path / "checkpoint.pt")
    first.save_buffer(tmp_path / "replay.npz")
    env_rng = env._rng.bit_generator.state

    resumed = make_agent(algorithm, env, config=config, seed=99)  # everything must come from the files
    resumed.load_state_dict(torch.load(tmp_path / "checkpoint.pt", weights_only=True))
    resumed.load_buffer(tmp_path / "replay.npz")
    env.seed(12345)
    env._rng.bit_generator.state = env_rng
    Core(resumed, env).learn(n_steps=200, n_steps_per_fit=1, quiet=True)

    a, b = straight.state_dict(), resumed.state_dict()
    assert a["updates"] == b["updates"] == 301 and a["transitions"] == b["transitions"] == 400
    for key in ("critic", "target_critic"):
        for name, tensor in a[key].items():
            assert torch.equal(tensor, b[key][name]), (key, name)
    for name, tensor in a["policy"]["net"].items():
        assert torch.equal(tensor, b["policy"]["net"][name]), name
    assert torch.equal(a["log_alpha"], b["log_alpha"])
    assert (a["log_alpha"] != np.float32(np.log(1e-3))) == config.get("learn_alpha", False)
    keys = ["actor_optimizer", "critic_optimizer"] + ["alpha_optimizer"] * bool(a["alpha_optimizer"])
    if config.get("from_observations"):
        for name, tensor in a["inverse_model"]["net"].items():
            assert torch.equal(tensor, b["inverse_model"]["net"][name]), name
        keys.append("inverse_model")
    for key in keys:
        optimizer_a = a[key]["optimizer"] if key == "inverse_model" else a[key]
        optimizer_b = b[key]["optimizer"] if key == "inverse_model" else b[key]
        for i, state in optimizer_a["state"].items():
            assert all(torch.equal(v, optimizer_b["state"][i][k]) for k, v in state.items()), (key, i)
    assert a["rng"] == b["rng"] and a["policy"]["rng"] == b["policy"]["rng"]
    assert torch.equal(a["torch_rng"], b["torch_rng"]) and a["stats"] == b["stats"]
    for name in ("states", "actions", "next_states", "absorbing"):
        assert np.array_equal(getattr(straight.buffer, name), getattr(resumed.buffer, name)), name

    with pytest.raises(ValueError, match="not from the same moment"):
        resumed.load_buffer(tmp_path / "replay.npz")  # the buffer of 200 transitions, the agent after 400


def test_warm_start_without_buffer_refills_it_before_updating(env, tmp_path):
    source = make_agent("sqil", env, config=SMALL, seed=0)
    learn(source, env, 200)
    warm = make_agent("sqil", env, config=SMALL, seed=1)
    warm.load_state_dict(source.state_dict())  # a warm start: weights and counters, no replay buffer
    learn(warm, env, 150)
    assert warm.buffer.size == 150 and warm.updates == source.updates + 51  # updates resume at 100 transitions
    warm.save_buffer(tmp_path / "replay.npz")
    resumed = make_agent("sqil", env, config=SMALL, seed=2)
    resumed.load_state_dict(warm.state_dict())
    resumed.load_buffer(tmp_path / "replay.npz")
    assert resumed.buffer.size == 150 and resumed.transitions == 350


def test_entries_unknown_to_the_expert_are_hidden_from_the_networks(env):
    data = env.create_dataset()
    data = {**data, "states": data["states"].copy(), "next_states": data["next_states"].copy()}
    data["states"][:, 5] = data["next_states"][:, 5] = np.nan  # e.g. a carried load motion capture cannot know
    agent = make_agent("iq_learn", env, config=SMALL, seed=0, expert=ExpertData(data, np.ones(33, dtype=bool)))
    assert agent.policy.obs_dim == 32 and not agent.policy.obs_mask[5] and agent.buffer.obs_dim == 32
    obs = env.reset()
    action = agent.draw_action(obs)
    obs[5] = 1e6  # what the networks do not see cannot change the action
    with agent.policy.evaluation_mode(deterministic=True):
        assert np.array_equal(agent.draw_action(obs), agent.draw_action(np.where(np.arange(33) == 5, 0.0, obs)))
    learn(agent, env, 150)
    assert np.isfinite(agent.last_stats["critic_loss"]) and action.shape == (11,)


def test_trainer_resumes_an_offpolicy_run_exactly_and_says_when_it_cannot(tmp_path):
    """Through the Trainer: the buffer is saved beside the checkpoint; with it a resume is exact, without it the
    run goes on as a warm start and warns."""
    import shutil

    from baselines.training import REPLAY, Trainer, load_checkpoint

    def run(n_steps):
        return load_run_config("UnitreeH1.walk.perfect", "lsiq", overrides={
            "train": {"n_steps": n_steps, "epoch_steps": 300, "n_eval_episodes": 1}, "env": {"horizon": 50},
            "agent": {**SMALL, "initial_samples": 20, "n_threads": 1}})  # warm-up = batch size for both budgets

    threads = torch.get_num_threads()
    try:
        Trainer(run(600), tmp_path / "straight", progress=False).train()
        Trainer(run(300), tmp_path / "split", progress=False).train()
        shutil.copytree(tmp_path / "split", tmp_path / "nobuffer")
        (tmp_path / "nobuffer" / REPLAY).unlink()
        assert (tmp_path / "split" / REPLAY).exists() and not (tmp_path / "split" / "replay.next.npz").exists()
        Trainer(run(600), tmp_path / "split", resume=True, progress=False).train()
        with pytest.warns(UserWarning, match="continues as a warm start"):
            Trainer(run(600), tmp_path / "nobuffer", resume=True, progress=False)
    finally:
        torch.set_num_threads(threads)
    a, b = (load_checkpoint(tmp_path / d)["agent"] for d in ("straight", "split"))
    for name, tensor in a["critic"].items():
        assert torch.equal(tensor, b["critic"][name]), name
    assert a["updates"] == b["updates"] > 0 and a["rng"] == b["rng"]


def test_expert_action_labels_are_scored_against_the_true_actions(tmp_path):
    """mj_inverse explains most of the perfect data's action variance; a task without true actions is refused."""
    from experiments.compare_expert_actions import label_scores, main

    true = np.random.default_rng(0).normal(size=(100, 3))
    assert label_scores(true, true) == {"rmse": 0.0, "r2": 1.0, "rmse_per_dim_max": 0.0}
    assert label_scores(np.broadcast_to(true.mean(0), true.shape), true)["r2"] == pytest.approx(0.0, abs=1e-12)
    assert main(["--task", "UnitreeH1.walk", "--transitions", "10", "--updates", "1"]) == 2
    out = tmp_path / "labels.json"
    assert main(["--transitions", "300", "--updates", "20", "--json", str(out)]) == 0
    res = json.loads(out.read_text())
    assert res["mj_inverse"]["r2"] > 0.5 and res["mj_inverse"]["rmse"] < 0.3
    assert {"learned_on_random", "learned_on_demonstrator+N(0,0.1)"} <= set(res)
    assert main(["--transitions", "300", "--updates", "20", "--json", str(out)]) == 2  # never overwritten


@pytest.mark.parametrize("algorithm, from_observations", [("sqil", False), ("lsiq", True)])
def test_critic_probe_reads_values_around_the_expert_actions(env, algorithm, from_observations):
    """The probe's noise of 0 reproduces the value at the expert's action (the dataset's, or the inverse model's
    label), its figures are finite and the replay buffer's states are probed where it holds transitions."""
    from experiments.critic_probe import probe

    agent = make_agent(algorithm, env, config={**SMALL, "from_observations": from_observations}, seed=0)
    learn(agent, env, 300)
    x, action = agent.expert_rows(np.arange(5))
    assert x.shape == (5, agent.buffer.obs_dim) and action.shape == (5, agent.policy.act_dim)
    if not from_observations:
        assert torch.equal(action, torch.from_numpy(np.clip(agent.expert.actions[:5], -1, 1).astype(np.float32)))
    out = probe(agent, n=64, noise=(0.0, 0.1), seed=3)
    expert = out["expert_states"]
    assert expert["q_expert_action_plus_noise"]["0"] == pytest.approx(expert["q_expert_action"], rel=1e-6)
    assert set(expert["q_between"]) == {"0.25", "0.5", "0.75"}
    values = [expert["q_expert_action"], expert["q_policy_mean_action"], *expert["q_between"].values(),
              *out["agent_states"].values()]
    assert np.all(np.isfinite(values))
    assert 0 < expert["rms_expert_action"] <= 1 and expert["policy_std"] > 0
    assert probe(agent, n=64, noise=(0.1,), seed=3) == probe(agent, n=64, noise=(0.1,), seed=3)  # seeded
    with pytest.raises(ValueError, match="n must be at least 1"):
        probe(agent, n=0)


def test_critic_probe_command_reads_a_run_directory(tmp_path, capsys):
    from baselines.training import Trainer
    from experiments.critic_probe import main

    overrides = {"train": {"n_steps": 300, "epoch_steps": 300, "n_eval_episodes": 1}, "env": {"horizon": 50},
                 "agent": {**SMALL, "initial_samples": 20}}
    threads = torch.get_num_threads()
    try:
        Trainer(load_run_config("UnitreeH1.walk.perfect", "sqil", overrides=overrides), tmp_path / "run",
                progress=False).train()
        out = tmp_path / "probe.json"
        assert main([str(tmp_path / "run"), "--samples", "32", "--json", str(out)]) == 0
        result = json.loads(out.read_text())
        assert (result["algorithm"], result["steps"], result["bound"]) == ("sqil", 300, "100 (rewards in [0, 1])")
        assert "agent_states" in result  # the replay buffer beside the checkpoint was read
        assert main([str(tmp_path / "run"), "--json", str(out)]) == 2  # never overwritten
        assert "never overwritten" in capsys.readouterr().err
        assert main([str(tmp_path / "nowhere")]) == 2
        assert "no checkpoint at" in capsys.readouterr().err
    finally:
        torch.set_num_threads(threads)


def test_a_deadline_counts_an_offpolicy_epochs_updates_not_its_warm_up_steps(tmp_path, monkeypatch):
    """On a clock where each update takes 1 s and nothing else takes time, the first epoch (300 steps, 150 of them
    warm-up) takes 151 s and a full one 300 s: a deadline 401 s away stops after the first epoch instead of
    overrunning it by 50 s (a per-step estimate expected 151 s). Resumed with its buffer, the log's pace gives the
    same estimate; without the buffer the warm-up refills and the shorter epoch fits."""
    import shutil
    import types

    import baselines.training as training
    from baselines.training import REPLAY, EpochPace, Trainer

    def run():
        return load_run_config("UnitreeH1.walk.perfect", "sqil", overrides={
            "train": {"n_steps": 1500, "epoch_steps": 300, "n_eval_episodes": 1}, "env": {"horizon": 50},
            "agent": {**SMALL, "initial_samples": 150}})

    current: dict = {}

    def clock() -> float:
        agent = current.get("agent")
        return 1_000_000.0 + (agent.updates if agent is not None else 0)

    monkeypatch.setattr(training, "time", types.SimpleNamespace(time=clock, perf_counter=clock))
    threads = torch.get_num_threads()
    try:
        trainer = Trainer(run(), tmp_path / "run", progress=False)
        current["agent"] = trainer.agent
        assert trainer.agent.updates_in(300) == 151 and trainer.agent.updates_in(100) == 0
        trainer.train(deadline=clock() + 401.0)
        assert trainer.stopped_at_deadline and (trainer.steps, trainer.agent.updates) == (300, 151)
        assert trainer.agent.updates_in(300) == 300
        shutil.copytree(tmp_path / "run", tmp_path / "nobuffer")
        (tmp_path / "nobuffer" / REPLAY).unlink()

        resumed = Trainer(run(), tmp_path / "run", resume=True, progress=False)
        current["agent"] = resumed.agent
        resumed.train(deadline=clock() + 250.0)  # 300 updates expected from the log's 151 s for 151 updates
        assert resumed.stopped_at_deadline and resumed.steps == 300
        resumed.train(deadline=clock() + 350.0)
        assert resumed.stopped_at_deadline and (resumed.steps, resumed.agent.updates) == (600, 451)

        with pytest.warns(UserWarning, match="continues as a warm start"):
            refilled = Trainer(run(), tmp_path / "nobuffer", resume=True, progress=False)
        current["agent"] = refilled.agent
        assert refilled.agent.updates_in(300) == 151  # the buffer refills its warm-up first
        refilled.train(deadline=clock() + 250.0)
        assert refilled.stopped_at_deadline and refilled.steps == 600
    finally:
        torch.set_num_threads(threads)
    log = tmp_path / "nobuffer" / "progress.csv"  # the log's last epoch, as a resume reads it
    header = "step,train_steps_per_s,updates\n"
    for rows, expected in ((["300,2.0,151"], EpochPace(150.0, 300, 151)),  # the first epoch, from step 0
                           (["300,2.0,151", "600,1.0,451"], EpochPace(300.0, 300, 300)),
                           (["15300,2.0,9000"], EpochPace(150.0, 300)),  # a warm start's: counts continue another run
                           (["300,2.0,151", "450,1.0,301"], EpochPace(150.0, 150, 150))):  # a shorter last epoch
        log.write_text(header + "\n".join(rows) + "\n")
        assert refilled._logged_pace() == expected, rows
    pace = EpochPace(learn_s=151.0, steps=300, updates=151, other_s=2.0)
    assert pace.expected_s(300, 300) == 302.0 and pace.expected_s(300, 0) == 153.0  # the larger of the two
    assert EpochPace(learn_s=100.0, steps=400).expected_s(200) == 50.0  # agents without updates: per step
