"""Training-loop throughput: on-policy (VAIL with our FastTRPO against Mushroom-RL's unmodified TRPO) and
off-policy (IQ-Learn / LS-IQ / SQIL on our actor-critic loop against Mushroom-RL's own SAC).

**On-policy** (``--section onpolicy``): VAIL on UnitreeH1.walk, by default with its committed configuration
(``--setup committed``: configs/defaults.yaml and configs/vail/UnitreeH1.walk.yaml: PD control, random starts,
std_0 0.3, max_kl 0.01); ``--setup plain`` is LocoEnv's and AdversarialConfig's defaults (torque control, home
starts, std_0 1.0, max_kl 5e-3), the setup of the figures measured before ``train.n_envs`` existed.

Both learners run inside the same VAIL agent (same discriminator, expert data, standardizers, networks and
hyperparameters: policy / critic MLPs [512, 256], 1000 env steps per fit, 25 CG iterations, max KL 5e-3,
critic 5 epochs of minibatches of 256, discriminator trained every 3rd fit) on the same environment, in the
same process, alternating runs. "fast" is baselines.common.fast_trpo.FastTRPO with the numpy-sampled
GaussianPolicy; "mushroom" is mushroom_rl's TRPO with its GaussianTorchPolicy, unmodified.

Protocol per run: a fresh agent (seed 0), --warmup env steps (3 fits: torch warm-up and the first
discriminator step), then --steps env steps timed end to end with ``Core.learn`` (environment, action
sampling, discriminator, TRPO, critic: everything). Variants are ``learner:torch_threads``; by default the
fast learner with its default thread count (2 on 2 cores) and with 1 thread, and Mushroom's with the same
default count. ``learner:torch_threads:nN`` collects with N environments instead
(:class:`~baselines.common.batched.BatchedCollector`, ``train.n_envs``: one batched policy forward per control
step, each env contributing 1000 / N consecutive steps to a fit) and ``...:nN:tP`` steps them in P threads
(default: one per core, at most 2; ``t1`` is the plain sequential batched loop); ``--collect-only`` times the
collection alone (fits do nothing, the initial policy acts throughout). Each run reports env steps per
second of wall time and per second of the process's CPU time (all its threads; what other processes on shared
cores take does not count). Runs alternate between variants; best of --repeats per variant, because other
processes may share the cores and the best run is the one least disturbed. Then, with --profile, one more run
per variant under cProfile, broken down by component (cProfile slows Python-heavy parts, so shares matter more
than absolute times there; the fast learner's critic runs in a background thread, which cProfile does not see:
its time is measured with a timer and reported as overlapped with the rollout; batched variants are profiled
with their envs stepped in the main thread).

**Off-policy** (``--section offpolicy``): on UnitreeH1.walk.perfect (it has expert actions), our
baselines.common.offpolicy loop (sqil, iq_learn, lsiq) against ``mushroom_rl.algorithms.actor_critic.SAC``
at identical settings: actor and twin critics [256, 256] (Mushroom's SAC has separate mean and log-std
networks, as it is written), 512 transitions per update (ours: 256 agent + 256 expert; SAC: 512 from its
replay memory), lr 3e-4 / 3e-5, tau 0.005, one update per environment step (``n_steps_per_fit=1``), all in
one process on one torch thread (``--off-threads``). SQIL is SAC's computation with a constant reward, so
sqil / sac is the like-for-like ratio; IQ-Learn and LS-IQ also regress the value of the policy's actions
(one more critic pass with gradients). Per run: a fresh agent (seed 0), ``--off-warmup`` steps filling the
replay memory without updates (timed: collection alone), then ``--off-steps`` steps with one update each
(timed: env steps/s = updates/s, and the process's CPU time per step, which other processes on shared cores do
not inflate). Runs alternate, best of ``--repeats``. Each variant's floating-point operations per step (matrix
products, counted once by torch's ``FlopCounterMode``) and the core's matrix-product ceilings (``torch.mm``, which
Mushroom-RL's networks use, and oneDNN, which our loop uses: :mod:`baselines.common.gemm`) say how far from the
hardware each loop is, and how large a speed-up over SAC its FLOPs allow at most.

    .venv/bin/python bench/training_throughput.py [--section all|onpolicy|offpolicy] [--steps 20000]
        [--warmup 3000] [--repeats 3] [--variants fast:2 fast:1 mushroom:2 fast:2:n4 fast:2:n8:t1] [--profile]
        [--off-steps 1000] [--off-warmup 2000] [--off-threads 1] [--off-variants sqil iq_learn lsiq sac]
"""

from __future__ import annotations

import argparse
import cProfile
import os
import platform
import pstats
import time

import loco_mujoco as lm  # noqa: E402  (first: it patches mushroom-rl before mushroom-rl is imported)

# isort: split
import torch  # noqa: E402
import torch.nn.functional as F  # noqa: E402
from mushroom_rl.algorithms.actor_critic import SAC  # noqa: E402
from mushroom_rl.core import Core  # noqa: E402
from torch import nn  # noqa: E402

from baselines import make_agent  # noqa: E402
from baselines.common import gemm  # noqa: E402
from baselines.common.batched import BatchedCollector, default_env_threads, env_seeds  # noqa: E402
from baselines.common.fast_trpo import default_num_threads  # noqa: E402
from baselines.common.networks import MushroomMLP, build_mlp  # noqa: E402
from baselines.config import load_run_config  # noqa: E402

ENV = "UnitreeH1.walk"
STEPS_PER_FIT = 1000  # environment steps per fit: train.n_steps_per_fit of configs/defaults.yaml (adversarial)
LABELS = {"fast": "fast (FastTRPO)", "mushroom": "mushroom (unmodified TRPO)"}

# Components shown in the profile: (label, file name, function name); cumulative time of that function.
FAST_FIT_ROWS = [  # inside the fit of FastTRPO's VAIL, with one env or several
    ("  discriminator training", "adversarial.py", "train_discriminator"),
    ("  discriminator reward", "adversarial.py", "reward"),
    ("  GAE (critic values)", "fast_trpo.py", "_gae"),
    ("  Fisher operator setup", "fast_trpo.py", "_fisher_operator"),
    ("  conjugate gradient (25 FVPs)", "fast_trpo.py", "_conjugate_gradient_t"),
    ("  line search (1 FVP + trials)", "fast_trpo.py", "_line_search_t"),
    ("  waiting for the critic thread", "fast_trpo.py", "synchronize"),
]
PROFILE_ROWS = {
    "fast": [
        ("env.step", "loco_env.py", "step"),
        ("policy.draw_action (numpy)", "policy.py", "draw_action"),
        ("agent.fit (all of it)", "adversarial.py", "fit"),
        *FAST_FIT_ROWS,
    ],
    "batched": [
        ("envs: apply + physics + finish", "batched.py", "_step_env"),
        ("policy.draw_actions (numpy, batch)", "policy.py", "draw_actions"),
        ("agent.fit (all of it)", "adversarial.py", "fit_arrays"),
        *FAST_FIT_ROWS,
        ("  batch to arrays (env by env)", "batched.py", "_batch"),
    ],
    "mushroom": [
        ("env.step", "loco_env.py", "step"),
        ("policy.draw_action (torch)", "torch_policy.py", "draw_action"),
        ("agent.fit (all of it)", "adversarial.py", "fit"),
        ("  discriminator training", "adversarial.py", "train_discriminator"),
        ("  discriminator reward", "adversarial.py", "reward"),
        ("  TRPO.fit", "trpo.py", "fit"),
        ("    compute_gae", "value_functions.py", "compute_gae"),
        ("    conjugate gradient", "trpo.py", "_conjugate_gradient"),
        ("    line search", "trpo.py", "_line_search"),
        ("    all Fisher-vector products", "trpo.py", "_fisher_vector_product"),
        ("    critic fit", "torch_approximator.py", "fit"),
    ],
}


Variant = tuple[str, int, int, int]  # learner, torch threads, environments (1: Core), env threads (0: default)
_EXTRA_ENVS: list[lm.LocoEnv] = []  # the batched variants' environments beyond the first, built once


class Collector:
    """``learn(n_steps)`` through ``Core`` (one env) or a ``BatchedCollector`` (``n_envs`` envs)."""

    def __init__(self, env: lm.LocoEnv, agent, n_envs: int, env_threads: int):
        self.agent = agent
        if n_envs == 1:
            self.core, self.batched = Core(agent, env), None
            return
        while len(_EXTRA_ENVS) < n_envs - 1:
            _EXTRA_ENVS.append(lm.LocoEnv.make(ENV, **ENV_KWARGS))
        envs = [env, *_EXTRA_ENVS[:n_envs - 1]]
        for e, seed in zip(envs, env_seeds(0, n_envs), strict=True):  # as train.n_envs seeds them (run seed 0)
            e.seed(seed)
        self.core, self.batched = None, BatchedCollector(agent, envs, n_threads=env_threads or None)

    def learn(self, n_steps: int) -> None:
        if self.batched is None:
            self.core.learn(n_steps=n_steps, n_steps_per_fit=STEPS_PER_FIT, quiet=True)
        else:
            self.batched.learn(n_steps=n_steps, n_steps_per_fit=STEPS_PER_FIT)

    def close(self) -> None:
        if self.batched is not None:
            self.batched.close()


ENV_KWARGS: dict = {}  # --setup committed: the environment settings of configs/vail/UnitreeH1.walk.yaml
AGENT_CONFIG: dict = {}  # and its agent settings (--setup plain: LocoEnv's and AdversarialConfig's defaults)


def build(env: lm.LocoEnv, variant: Variant, warmup: int, collect_only: bool = False) -> Collector:
    """A fresh seeded VAIL agent with the variant's learner and collection, warmed up for ``warmup`` env steps;
    ``collect_only``: its fits do nothing (the initial policy collects throughout)."""
    learner, threads, n_envs, env_threads = variant
    agent = make_agent("vail", env, {**AGENT_CONFIG, "learner": learner, "n_threads": threads}, seed=0)
    if collect_only:
        agent.fit = agent.fit_arrays = lambda *args, **kwargs: None
    torch.set_num_threads(threads)
    collector = Collector(env, agent, n_envs, env_threads)
    if warmup:
        collector.learn(warmup)
    return collector


def timed_run(collector: Collector, steps: int) -> tuple[float, float]:
    """Env steps per second of wall time and of this process's CPU time (all threads) over ``steps`` steps of
    ``learn`` (includes waiting for background work)."""
    t0, c0 = time.perf_counter(), time.process_time()
    collector.learn(steps)
    rate, cpu_rate = steps / (time.perf_counter() - t0), steps / (time.process_time() - c0)
    collector.close()
    return rate, cpu_rate


def label(variant: Variant) -> str:
    learner, threads, n_envs, env_threads = variant
    text = f"{LABELS[learner]}, {threads} thread{'s' if threads > 1 else ''}"
    if n_envs > 1:
        p = env_threads or default_env_threads(n_envs)
        text += f", {n_envs} envs in {p} thread{'s' if p > 1 else ''}"
    return text


def parse_variant(text: str) -> Variant:
    parts = text.split(":")
    learner, threads = parts[0], parts[1] if len(parts) > 1 else ""
    n_envs = parts[2][1:] if len(parts) > 2 and parts[2].startswith("n") else "1"
    env_threads = parts[3][1:] if len(parts) > 3 and parts[3].startswith("t") else "0"
    if (learner not in LABELS or not (threads.isdigit() and n_envs.isdigit() and env_threads.isdigit())
            or int(threads) < 1 or int(n_envs) < 1 or len(parts) > 4 or (len(parts) > 2 and parts[2][0] != "n")
            or (len(parts) > 3 and parts[3][0] != "t") or STEPS_PER_FIT % int(n_envs)
            or (learner == "mushroom" and int(n_envs) > 1)):
        raise argparse.ArgumentTypeError(f"variant must be fast:T or mushroom:T, or fast:T:nN[:tP] (N environments "
                                         f"dividing {STEPS_PER_FIT}, stepped in P threads), got {text!r}")
    return learner, int(threads), int(n_envs), int(env_threads)


def profile_run(env: lm.LocoEnv, variant: Variant, warmup: int, steps: int) -> None:
    learner, threads, n_envs, _ = variant
    if n_envs > 1:  # cProfile sees the main thread only: step the envs there
        variant = (learner, threads, n_envs, 1)
    collector = build(env, variant, warmup)
    core = collector.batched or collector.core
    critic_time = [0.0]
    if learner == "fast":  # the critic thread is invisible to cProfile: time it directly
        fit_critic = core.agent.learner._fit_critic

        def timed_fit_critic(*args, **kwargs):
            t0 = time.perf_counter()
            out = fit_critic(*args, **kwargs)
            critic_time[0] += time.perf_counter() - t0
            return out

        core.agent.learner._fit_critic = timed_fit_critic
    profiler = cProfile.Profile()
    t0 = time.perf_counter()
    profiler.enable()
    collector.learn(steps)
    profiler.disable()
    wall = time.perf_counter() - t0
    collector.close()
    stats = pstats.Stats(profiler).stats  # {(file, line, function): (cc, nc, tottime, cumtime, callers)}

    def cumulative(file_name: str, function: str) -> float:
        return sum(v[3] for k, v in stats.items() if k[2] == function and os.path.basename(k[0]) == file_name)

    per_k = 1000.0 / steps
    print(f"\n{label(variant)}: cProfile over {steps} env steps, {wall:.2f} s wall "
          f"({steps / wall:,.0f} steps/s under the profiler)")
    print(f"  {'component':36s} {'ms / 1000 steps':>16s} {'% of wall':>10s}")
    rows = PROFILE_ROWS["batched" if n_envs > 1 else learner]
    times = {name: cumulative(f, fn) for name, f, fn in rows}
    for name, _, _ in rows:
        print(f"  {name:36s} {times[name] * 1e3 * per_k:16.1f} {100 * times[name] / wall:9.1f}%")
    top_level = times[rows[0][0]] + times[rows[1][0]] + times["agent.fit (all of it)"]
    rest = wall - top_level
    name = "collector loop + batch" if n_envs > 1 else "Core loop + dataset bookkeeping"
    print(f"  {name:36s} {rest * 1e3 * per_k:16.1f} {100 * rest / wall:9.1f}%")
    if learner == "fast":
        print(f"  {'critic fit (background thread)':36s} {critic_time[0] * 1e3 * per_k:16.1f} "
              f"{'overlapped':>10s}")


# ---- off-policy ------------------------------------------------------------------------------------------
OFF_ENV = "UnitreeH1.walk.perfect"
OFF_VARIANTS = ("sqil", "iq_learn", "lsiq", "sac", "iq_learn:1", "lsiq:1", "sqil:1", "sqil:ln", "iq_learn:ln")
# "<algo>:1": one critic instead of SAC's two, as the IQ-Learn and LS-IQ reference implementations have it;
# "<algo>:ln": twin critics with LayerNorm in their hidden layers (agent.critic_layer_norm)
OFF_LABELS = {"sqil": "ours, SQIL", "iq_learn": "ours, IQ-Learn", "lsiq": "ours, LS-IQ",
              "sac": "Mushroom-RL SAC (unmodified)", "iq_learn:1": "ours, IQ-Learn, 1 critic",
              "lsiq:1": "ours, LS-IQ, 1 critic", "sqil:1": "ours, SQIL, 1 critic",
              "sqil:ln": "ours, SQIL, critic LayerNorm", "iq_learn:ln": "ours, IQ-Learn, critic LayerNorm"}
HIDDEN, BATCH, ACTOR_LR, CRITIC_LR, TAU = (256, 256), 256, 3e-5, 3e-4, 0.005


class SACCritic(nn.Module):
    """Mushroom's critic interface ``forward(state, action)``: an MLP on ``[s, a]`` (same init as ours)."""

    def __init__(self, input_shape: tuple[int, ...], output_shape: tuple[int, ...], seed: int = 0, **_: object):
        super().__init__()
        self.net = build_mlp(input_shape[0], output_shape[0], HIDDEN, "relu", output_std=1e-3,
                             generator=torch.Generator().manual_seed(seed), onednn=False)  # SAC as written

    def forward(self, state: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        return torch.squeeze(self.net(torch.cat([state.float(), action.float()], dim=1)), 1)


def build_offpolicy(env: lm.LocoEnv, variant: str, warmup: int) -> tuple[Core, float]:
    """A fresh agent whose updates start after ``warmup`` steps, and the collection rate of that warm-up."""
    if variant == "sac":
        obs, act = env.info.observation_space.shape, env.info.action_space.shape
        actor = dict(network=MushroomMLP, input_shape=obs, output_shape=act, hidden=HIDDEN, output_std=1e-3,
                     onednn=False)
        critic = dict(network=SACCritic, input_shape=(obs[0] + act[0],), output_shape=(1,), loss=F.mse_loss,
                      optimizer={"class": torch.optim.Adam, "params": {"lr": CRITIC_LR}})
        agent = SAC(env.info, actor, dict(actor), {"class": torch.optim.Adam, "params": {"lr": ACTOR_LR}}, critic,
                    batch_size=2 * BATCH, initial_replay_size=warmup, max_replay_size=1_000_000,
                    warmup_transitions=warmup, tau=TAU, lr_alpha=3e-4, log_std_min=-5, log_std_max=2)
    else:
        algo, _, critics = variant.partition(":")
        agent = make_agent(algo, env, {"actor_hidden": HIDDEN, "critic_hidden": HIDDEN, "batch_size": BATCH,
                                       "actor_lr": ACTOR_LR, "critic_lr": CRITIC_LR, "tau": TAU,
                                       "initial_samples": warmup + 1, "n_threads": torch.get_num_threads(),
                                       "n_critics": 1 if critics == "1" else 2,
                                       "critic_layer_norm": critics == "ln"},
                           seed=0)
    env.seed(0)
    core = Core(agent, env)
    t0 = time.perf_counter()
    core.learn(n_steps=warmup, n_steps_per_fit=1, quiet=True)
    return core, warmup / (time.perf_counter() - t0)


def timed_offpolicy_run(core: Core, steps: int) -> tuple[float, float]:
    """Env steps per second of ``Core.learn`` with one update per step: per wall-clock second and per second of
    this process's CPU time (what other processes on shared cores take from the wall clock does not count)."""
    before = getattr(core.agent, "updates", None)
    t0, c0 = time.perf_counter(), time.process_time()
    core.learn(n_steps=steps, n_steps_per_fit=1, quiet=True)
    rate, cpu_rate = steps / (time.perf_counter() - t0), steps / (time.process_time() - c0)
    if before is not None and core.agent.updates - before != steps:
        raise RuntimeError(f"expected {steps} updates, got {core.agent.updates - before}")
    return rate, cpu_rate


def flops_per_step(core: Core, steps: int = 5) -> float:
    """Floating-point operations of one env step with its update, counted by torch's ``FlopCounterMode`` (matrix
    products forward and backward, ours written out and Mushroom's through autograd alike; elementwise work is not
    counted). The same for every run of a variant: a property of the computation, not of the machine."""
    from torch.utils.flop_counter import FlopCounterMode

    # The counter sees aten's products only, so ours run on torch's path while it counts (same FLOPs as oneDNN's).
    with FlopCounterMode(display=False) as counter, gemm.backend("torch"):
        core.learn(n_steps=steps, n_steps_per_fit=1, quiet=True)
    return counter.get_total_flops() / steps


def gemm_ceiling(backend: str = "torch", repeats: int = 5) -> float:
    """FLOP/s of one ``[1024, 256] @ [256, 256]`` product per second of CPU time (the updates' largest shape), best
    of ``repeats`` runs on the current torch threads, with ``torch.mm`` (``backend="torch"``: MKL, what Mushroom-RL's
    networks use) or oneDNN (``"onednn"``: what our loop uses, :mod:`baselines.common.gemm`): what the updates could
    reach if they were nothing but it."""
    a, b = torch.randn(1024, 256), torch.randn(256, 256)
    with gemm.backend(backend):
        for _ in range(20):
            gemm.mm(a, b)
        best = float("inf")
        for _ in range(repeats):
            t0 = time.process_time()
            for _ in range(200):
                gemm.mm(a, b)
            best = min(best, time.process_time() - t0)
    return 2 * 1024 * 256 * 256 * 200 / best


def print_products(products: str) -> None:
    """Say where the runs' matrix products went (``--products``) and what ``auto`` picks on this processor."""
    print(f"  products: --products {products} (oneDNN preferred on this processor: {gemm.ONEDNN_PREFERRED})")


def offpolicy_section(args: argparse.Namespace) -> None:
    torch.set_num_threads(args.off_threads)
    env = lm.LocoEnv.make(OFF_ENV)
    print(f"\nOff-policy on {OFF_ENV}: {args.off_steps} timed steps (one update each) per run after "
          f"{args.off_warmup} collection steps, best of {args.repeats}; {args.off_threads} torch thread(s), "
          f"updates of {BATCH} + {BATCH} transitions, MLPs {list(HIDDEN)}; load average {os.getloadavg()[0]:.2f}")
    loop: dict[str, list[float]] = {v: [] for v in args.off_variants}
    cpu: dict[str, list[float]] = {v: [] for v in args.off_variants}
    collect: dict[str, list[float]] = {v: [] for v in args.off_variants}
    flops: dict[str, float] = {}
    for _ in range(args.repeats):
        for variant in args.off_variants:
            with gemm.backend(args.products):
                core, collection_rate = build_offpolicy(env, variant, args.off_warmup)
                collect[variant].append(collection_rate)
                rate, cpu_rate = timed_offpolicy_run(core, args.off_steps)
            loop[variant].append(rate)
            cpu[variant].append(cpu_rate)
            if variant not in flops:
                flops[variant] = flops_per_step(core)
    ceiling, onednn_ceiling = gemm_ceiling("torch"), gemm_ceiling("onednn")
    print_products(args.products)
    print(f"\n  {'variant':30s} {'steps/s = updates/s, each run':30s} {'best':>7s} {'ms/step':>8s} "
          f"{'CPU ms/step':>12s} {'collection only, steps/s':>25s} {'GFLOP/step':>11s} {'GFLOP/s (CPU)':>14s}")
    for variant in args.off_variants:
        best = max(loop[variant])
        print(f"  {OFF_LABELS[variant]:30s} {', '.join(f'{r:.1f}' for r in loop[variant]):30s} {best:7.1f} "
              f"{1e3 / best:8.2f} {1e3 / max(cpu[variant]):12.2f} {max(collect[variant]):25,.0f} "
              f"{flops[variant] / 1e9:11.3f} {flops[variant] * max(cpu[variant]) / 1e9:14.1f}")
    ours = "oneDNN" if gemm.ONEDNN_PREFERRED else "torch.mm"
    print(f"  matrix-product ceiling of this core ([1024, 256] @ [256, 256], per CPU second): torch.mm (Mushroom's) "
          f"{ceiling / 1e9:.1f} GFLOP/s, oneDNN {onednn_ceiling / 1e9:.1f} GFLOP/s; ours with auto: {ours}")
    if "sac" in loop:
        sac, sac_cpu = max(loop["sac"]), max(cpu["sac"])
        for variant in (v for v in args.off_variants if v != "sac"):
            ratio, cpu_ratio = max(loop[variant]) / sac, max(cpu[variant]) / sac_cpu
            top = onednn_ceiling if gemm.ONEDNN_PREFERRED else ceiling  # our products' library
            bound = top / flops[variant] / sac_cpu  # ours at that ceiling, against SAC per CPU second
            print(f"  speed-up {OFF_LABELS[variant]} / Mushroom SAC: {ratio:.2f}x (per CPU second {cpu_ratio:.2f}x; "
                  f"goal >= 2x: {'met' if ratio >= 2 else 'NOT met'}; at most {bound:.2f}x with its "
                  f"{flops[variant] / flops['sac']:.2f}x of SAC's FLOPs at {ours}'s ceiling)")


def onpolicy_section(args: argparse.Namespace) -> None:
    default = default_num_threads()
    variants = args.variants or list(dict.fromkeys([("fast", default, 1, 0), ("fast", 1, 1, 0),
                                                    ("mushroom", default, 1, 0), ("fast", default, 8, 0)]))

    if args.setup == "committed":
        run = load_run_config(ENV, "vail")
        if run.train.n_steps_per_fit != STEPS_PER_FIT:
            raise SystemExit(f"configs give {run.train.n_steps_per_fit} steps per fit; the bench uses {STEPS_PER_FIT}")
        ENV_KWARGS.update(run.env)
        AGENT_CONFIG.update(run.agent.to_dict())
    env = lm.LocoEnv.make(ENV, **ENV_KWARGS)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"{'Collection only (no fits), ' if args.collect_only else ''}VAIL on {ENV} ({args.setup} setup: env "
          f"{ENV_KWARGS or 'defaults'}, agent "
          f"{ {k: AGENT_CONFIG[k] for k in ('std_0', 'max_kl')} if AGENT_CONFIG else 'defaults'}): "
          f"{args.steps} timed env steps per run after {args.warmup} warm-up steps, "
          f"best of {args.repeats}; torch {torch.__version__}, {cores} cores, "
          f"{platform.processor() or platform.machine()}, load average {os.getloadavg()[0]:.2f} at start")
    results: dict[Variant, list[tuple[float, float]]] = {v: [] for v in variants}
    for _ in range(args.repeats):  # alternate, so that a disturbance hits every variant alike
        for variant in variants:
            with gemm.backend(args.products):
                results[variant].append(timed_run(build(env, variant, args.warmup, args.collect_only), args.steps))
    print_products(args.products)
    print(f"\n  {'variant':58s} {'env steps/s of each run':26s} {'best':>7s} {'per CPU-s, best':>16s}")
    for variant, runs in results.items():
        print(f"  {label(variant):58s} {', '.join(f'{r:,.0f}' for r, _ in runs):26s} {max(r for r, _ in runs):7,.0f} "
              f"{max(c for _, c in runs):16,.0f}")
    best = {learner: max((max(r for r, _ in runs) for v, runs in results.items() if v[0] == learner and v[2] == 1),
                         default=None) for learner in LABELS}
    if args.collect_only:
        return
    if best["fast"] and best["mushroom"]:
        print(f"\n  speed-up, best fast / best mushroom: {best['fast'] / best['mushroom']:.2f}x")
    if best["fast"]:
        print(f"  goal: fast >= 4,000 env steps/s on 2 cores -> {'met' if best['fast'] >= 4000 else 'NOT met'}")
    batched = [max(r for r, _ in runs) for v, runs in results.items() if v[0] == "fast" and v[2] > 1]
    if batched:
        top = max(batched)
        print(f"  goal: batched (train.n_envs > 1) >= 12,000 env steps/s on 2 cores -> "
              f"{'met' if top >= 12000 else 'NOT met'} (best {top:,.0f}"
              + (f", {top / best['fast']:.2f}x the best single-env fast run)" if best["fast"] else ")"))
    if args.profile:
        for variant in variants:
            profile_run(env, variant, args.warmup, args.profile_steps)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=20_000, help="timed env steps per run")
    parser.add_argument("--warmup", type=int, default=3_000, help="untimed env steps before each run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--variants", nargs="+", type=parse_variant, default=None,
                        help="learner:threads, e.g. fast:2 fast:1 mushroom:2 (the default on 2 cores)")
    parser.add_argument("--setup", choices=("committed", "plain"), default="committed",
                        help="on-policy: the committed config of VAIL on UnitreeH1.walk (PD control, random starts, "
                             "std_0 0.3, max_kl 0.01), or LocoEnv's and AdversarialConfig's defaults (the setup of "
                             "the figures before train.n_envs)")
    parser.add_argument("--collect-only", action="store_true",
                        help="on-policy: time the collection alone (fits do nothing: the initial policy acts)")
    parser.add_argument("--profile", action="store_true", help="also profile one run per variant")
    parser.add_argument("--profile-steps", type=int, default=10_000)
    parser.add_argument("--section", choices=("all", "onpolicy", "offpolicy"), default="all")
    parser.add_argument("--off-steps", type=int, default=1_000, help="timed steps (= updates) per off-policy run")
    parser.add_argument("--off-warmup", type=int, default=2_000, help="collection steps before the updates start")
    parser.add_argument("--off-threads", type=int, default=1, help="torch threads of the off-policy runs")
    parser.add_argument("--off-variants", nargs="+", choices=OFF_VARIANTS, default=list(OFF_VARIANTS[:4]))
    parser.add_argument("--products", choices=gemm.BACKENDS, default="auto",
                        help="where our learners' matrix products run (baselines.common.gemm.backend): auto (this "
                             "processor's faster library), onednn-large (oneDNN for large ones, the rule before "
                             "2026-11-29), onednn or torch")
    args = parser.parse_args()
    if args.section in ("all", "onpolicy"):
        onpolicy_section(args)
    if args.section in ("all", "offpolicy"):
        offpolicy_section(args)


if __name__ == "__main__":
    main()
