"""How long the musculoskeletal human stays up under constant excitations: is half excitation a bad start?

A Gaussian policy starts with its mean near action 0, which HumanoidMuscle maps to half excitation of every muscle.
Before muscle runs are given another initial mean, this measures episode length and return under the evaluation
protocol's start states (random dataset states) for constant excitations with and without the policies' initial
exploration noise (Gaussian, std in action units), plus the stretch-reflex hold reference, and for zero action
and the hold reference from the home pose.

    .venv/bin/python bench/muscle_start_excitation.py [--episodes 10] [--task HumanoidMuscle.walk]
"""

from __future__ import annotations

import argparse

import numpy as np

from loco_mujoco import LocoEnv
from loco_mujoco.evaluation.protocol import SEED, Policy, evaluation_env, run_episodes
from loco_mujoco.evaluation.references import hold_pose_policy, zero_policy

EXCITATIONS = (0.0, 0.05, 0.1, 0.2, 0.3, 0.5)
NOISE_STDS = (0.0, 0.5)  # 0.5: std_0 of the adversarial policies (configs/defaults.yaml)


def constant_excitation(n_actions: int, excitation: float, noise_std: float, seed: int) -> Policy:
    """Every muscle at ``excitation`` in [0, 1], plus Gaussian noise of ``noise_std`` in action units, clipped."""
    rng = np.random.default_rng(seed)
    mean = np.full(n_actions, 2.0 * excitation - 1.0)
    return lambda obs: np.clip(mean + noise_std * rng.standard_normal(n_actions), -1.0, 1.0)


def summary(env: LocoEnv, policy: Policy, episodes: int) -> str:
    """Mean episode length and return of ``policy`` over the protocol's first ``episodes`` start states."""
    evaluation = run_episodes(env, policy, n_episodes=episodes, seed=SEED)
    lengths, returns = evaluation.lengths, evaluation.returns
    return f"L {lengths.mean():6.1f} (min {lengths.min():4.0f}, max {lengths.max():4.0f})  R {returns.mean():6.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="HumanoidMuscle.walk")
    parser.add_argument("--episodes", type=int, default=10)
    args = parser.parse_args()
    env = evaluation_env(args.task)
    if env.control != "muscle":
        raise SystemExit(f"{args.task} is driven by '{env.control}', not muscles; pass a HumanoidMuscle task")
    n = env.info.action_space.shape[0]
    print(f"{args.task}: protocol start states, {args.episodes} episodes each, horizon {env.info.horizon}")
    for excitation in EXCITATIONS:
        for noise in NOISE_STDS:
            policy = constant_excitation(n, excitation, noise, seed=SEED)
            print(f"  excitation {excitation:4.2f}, noise std {noise:3.1f}: {summary(env, policy, args.episodes)}")
    print(f"  stretch-reflex hold:             {summary(env, hold_pose_policy(env), args.episodes)}")
    home = LocoEnv.make(args.task, random_start=False, seed=SEED)
    print(f"from the home pose: zero action (half excitation): {summary(home, zero_policy(home), 1)}")
    print(f"                    stretch-reflex hold:           {summary(home, hold_pose_policy(home), 1)}")


if __name__ == "__main__":
    main()
