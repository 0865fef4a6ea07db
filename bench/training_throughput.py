"""Training-loop throughput: VAIL on UnitreeH1.walk with our FastTRPO against Mushroom-RL's unmodified TRPO.

Both learners run inside the same VAIL agent (same discriminator, expert data, standardizers, networks and
hyperparameters: policy / critic MLPs [512, 256], 1000 env steps per fit, 25 CG iterations, max KL 5e-3,
critic 5 epochs of minibatches of 256, discriminator trained every 3rd fit) on the same environment, in the
same process, alternating runs. "fast" is baselines.common.fast_trpo.FastTRPO with the numpy-sampled
GaussianPolicy; "mushroom" is mushroom_rl's TRPO with its GaussianTorchPolicy, unmodified.

Protocol per run: a fresh agent (seed 0), --warmup env steps (3 fits: torch warm-up and the first
discriminator step), then --steps env steps timed end to end with ``Core.learn`` (environment, action
sampling, discriminator, TRPO, critic: everything). Variants are ``learner:torch_threads``; by default the
fast learner with its default thread count (2 on 2 cores) and with 1 thread, and Mushroom's with the same
default count. Runs alternate between variants; best of --repeats per variant, because other processes may
share the cores and the best run is the one least disturbed. Then, with --profile, one more run per variant
under cProfile, broken down by component (cProfile slows Python-heavy parts, so shares matter more than
absolute times there; the fast learner's critic runs in a background thread, which cProfile does not see:
its time is measured with a timer and reported as overlapped with the rollout).

    .venv/bin/python bench/training_throughput.py [--steps 20000] [--warmup 3000] [--repeats 3]
                                                  [--variants fast:2 fast:1 mushroom:2] [--profile]
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
from mushroom_rl.core import Core  # noqa: E402

from baselines import make_agent  # noqa: E402
from baselines.common.fast_trpo import default_num_threads  # noqa: E402

ENV = "UnitreeH1.walk"
STEPS_PER_FIT = 1000  # environment steps per fit: train.n_steps_per_fit of configs/defaults.yaml (adversarial)
LABELS = {"fast": "fast (FastTRPO)", "mushroom": "mushroom (unmodified TRPO)"}

# Components shown in the profile: (label, file name, function name); cumulative time of that function.
PROFILE_ROWS = {
    "fast": [
        ("env.step", "loco_env.py", "step"),
        ("policy.draw_action (numpy)", "policy.py", "draw_action"),
        ("agent.fit (all of it)", "adversarial.py", "fit"),
        ("  discriminator training", "adversarial.py", "train_discriminator"),
        ("  discriminator reward", "adversarial.py", "reward"),
        ("  GAE (critic values)", "fast_trpo.py", "_gae"),
        ("  Fisher operator setup", "fast_trpo.py", "_fisher_operator"),
        ("  conjugate gradient (25 FVPs)", "fast_trpo.py", "_conjugate_gradient_t"),
        ("  line search (1 FVP + trials)", "fast_trpo.py", "_line_search_t"),
        ("  waiting for the critic thread", "fast_trpo.py", "synchronize"),
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


def build(env: lm.LocoEnv, learner: str, threads: int, warmup: int) -> Core:
    """A fresh seeded VAIL agent with ``learner``, warmed up for ``warmup`` env steps."""
    agent = make_agent("vail", env, {"learner": learner, "n_threads": threads}, seed=0)
    torch.set_num_threads(threads)
    core = Core(agent, env)
    if warmup:
        core.learn(n_steps=warmup, n_steps_per_fit=STEPS_PER_FIT, quiet=True)
    return core


def timed_run(core: Core, steps: int) -> float:
    """Env steps per second of ``Core.learn`` over ``steps`` steps (includes waiting for background work)."""
    t0 = time.perf_counter()
    core.learn(n_steps=steps, n_steps_per_fit=STEPS_PER_FIT, quiet=True)
    return steps / (time.perf_counter() - t0)


def label(variant: tuple[str, int]) -> str:
    learner, threads = variant
    return f"{LABELS[learner]}, {threads} thread{'s' if threads > 1 else ''}"


def parse_variant(text: str) -> tuple[str, int]:
    learner, _, threads = text.partition(":")
    if learner not in LABELS or not threads.isdigit() or int(threads) < 1:
        raise argparse.ArgumentTypeError(f"variant must be fast:N or mushroom:N, got {text!r}")
    return learner, int(threads)


def profile_run(env: lm.LocoEnv, variant: tuple[str, int], warmup: int, steps: int) -> None:
    learner, threads = variant
    core = build(env, learner, threads, warmup)
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
    core.learn(n_steps=steps, n_steps_per_fit=STEPS_PER_FIT, quiet=True)
    profiler.disable()
    wall = time.perf_counter() - t0
    stats = pstats.Stats(profiler).stats  # {(file, line, function): (cc, nc, tottime, cumtime, callers)}

    def cumulative(file_name: str, function: str) -> float:
        return sum(v[3] for k, v in stats.items() if k[2] == function and os.path.basename(k[0]) == file_name)

    per_k = 1000.0 / steps
    print(f"\n{label(variant)}: cProfile over {steps} env steps, {wall:.2f} s wall "
          f"({steps / wall:,.0f} steps/s under the profiler)")
    print(f"  {'component':36s} {'ms / 1000 steps':>16s} {'% of wall':>10s}")
    rows = PROFILE_ROWS[learner]
    times = {name: cumulative(f, fn) for name, f, fn in rows}
    for name, _, _ in rows:
        print(f"  {name:36s} {times[name] * 1e3 * per_k:16.1f} {100 * times[name] / wall:9.1f}%")
    top_level = times["env.step"] + times[rows[1][0]] + times["agent.fit (all of it)"]
    rest = wall - top_level
    print(f"  {'Core loop + dataset bookkeeping':36s} {rest * 1e3 * per_k:16.1f} {100 * rest / wall:9.1f}%")
    if learner == "fast":
        print(f"  {'critic fit (background thread)':36s} {critic_time[0] * 1e3 * per_k:16.1f} "
              f"{'overlapped':>10s}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--steps", type=int, default=20_000, help="timed env steps per run")
    parser.add_argument("--warmup", type=int, default=3_000, help="untimed env steps before each run")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--variants", nargs="+", type=parse_variant, default=None,
                        help="learner:threads, e.g. fast:2 fast:1 mushroom:2 (the default on 2 cores)")
    parser.add_argument("--profile", action="store_true", help="also profile one run per variant")
    parser.add_argument("--profile-steps", type=int, default=10_000)
    args = parser.parse_args()
    default = default_num_threads()
    variants = args.variants or list(dict.fromkeys([("fast", default), ("fast", 1), ("mushroom", default)]))

    env = lm.LocoEnv.make(ENV)
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"VAIL on {ENV}: {args.steps} timed env steps per run after {args.warmup} warm-up steps, "
          f"best of {args.repeats}; torch {torch.__version__}, {cores} cores, "
          f"{platform.processor() or platform.machine()}, load average {os.getloadavg()[0]:.2f} at start")
    results: dict[tuple[str, int], list[float]] = {v: [] for v in variants}
    for _ in range(args.repeats):  # alternate, so that a disturbance hits every variant alike
        for learner, threads in variants:
            results[(learner, threads)].append(timed_run(build(env, learner, threads, args.warmup), args.steps))
    print(f"\n  {'variant':42s} {'env steps/s of each run':28s} {'best':>8s}")
    for variant, runs in results.items():
        print(f"  {label(variant):42s} {', '.join(f'{r:,.0f}' for r in runs):28s} {max(runs):8,.0f}")
    best = {learner: max((max(r) for (name, _), r in results.items() if name == learner), default=None)
            for learner in LABELS}
    if best["fast"] and best["mushroom"]:
        print(f"\n  speed-up, best fast / best mushroom: {best['fast'] / best['mushroom']:.2f}x")
    if best["fast"]:
        print(f"  goal: fast >= 4,000 env steps/s on 2 cores -> {'met' if best['fast'] >= 4000 else 'NOT met'}")
    if args.profile:
        for variant in variants:
            profile_run(env, variant, args.warmup, args.profile_steps)


if __name__ == "__main__":
    main()
