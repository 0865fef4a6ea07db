"""How a pretrained agent acts, beside uniformly random actions: ``python experiments/action_statistics.py
HumanoidMuscle.walk vail``.

Over the protocol's first ``--episodes`` start states (deterministic policy, as the table evaluates it) and as many
episodes of uniformly random actions in [-1, 1], prints the episode length, the fraction of action components at
a bound (|a| >= 0.99; uniform actions: 0.01), the mean step-to-step change |a_t - a_(t-1)| (uniform: 2/3) and the
mean action. A policy with many actions on its bounds acts bang-bang; the step change says whether it switches
them as often as random actions do or holds them (for muscle excitations: -1 relaxed, +1 fully excited).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from loco_mujoco.evaluation import protocol  # noqa: E402
from loco_mujoco.evaluation.references import random_policy  # noqa: E402

AT_BOUND = 0.99  # |a| at or above this counts as saturated


def recorded(policy: Callable[[np.ndarray], np.ndarray], actions: list[np.ndarray]) -> Callable:
    """``policy`` that also appends each action it returns (clipped to the box the env applies) to ``actions``."""
    def act(obs: np.ndarray) -> np.ndarray:
        action = np.clip(np.asarray(policy(obs), dtype=np.float64).ravel(), -1.0, 1.0)
        actions.append(action)
        return action
    return act


def statistics(episodes: list[np.ndarray]) -> dict[str, float]:
    """Figures of the actions of each episode (``(length, act_dim)`` arrays), pooled over the episodes."""
    if not episodes or any(len(e) == 0 for e in episodes):
        raise ValueError("every episode needs at least one action")
    pooled = np.concatenate(episodes)
    changes = [np.abs(np.diff(e, axis=0)) for e in episodes if len(e) > 1]
    return {"L": float(np.mean([len(e) for e in episodes])),
            "at_bound": float(np.mean(np.abs(pooled) >= AT_BOUND)),
            "step_change": float(np.concatenate(changes).mean()) if changes else float("nan"),
            "mean_action": float(pooled.mean())}


def act_statistics(env, policy: Callable[[np.ndarray], np.ndarray], n_episodes: int,
                   seed: int = protocol.SEED) -> dict[str, float]:
    """Run ``n_episodes`` protocol episodes of ``policy`` on ``env`` and return :func:`statistics` of its actions."""
    actions: list[np.ndarray] = []
    evaluation = protocol.run_episodes(env, recorded(policy, actions), n_episodes=n_episodes, seed=seed)
    ends = np.cumsum(evaluation.lengths).astype(int)
    if ends[-1] != len(actions):
        raise RuntimeError(f"{len(actions)} actions recorded for episodes of {ends[-1]} steps in all")
    return statistics(np.split(np.array(actions), ends[:-1]))


def render(task: str, algo: str, seed: int, rows: dict[str, dict[str, float]], n_episodes: int) -> str:
    lines = [f"{algo} on {task}, seed {seed}: actions over the protocol's first {n_episodes} start states",
             f"{'policy':<28}{'L':>8}{'at a bound':>12}{'step change':>13}{'mean action':>13}"]
    for name, r in rows.items():
        lines.append(f"{name:<28}{r['L']:8.1f}{r['at_bound']:12.3f}{r['step_change']:13.3f}{r['mean_action']:13.3f}")
    lines.append(f"(at a bound: share of action components with |a| >= {AT_BOUND}; step change: mean |a_t - a_(t-1)|)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from baselines.pretrained import PretrainedNotFoundError, load

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("task", help="e.g. HumanoidMuscle.walk")
    parser.add_argument("algo", help="e.g. vail")
    parser.add_argument("--seed", type=int, default=0, help="the pretrained agent's training seed (default 0)")
    parser.add_argument("--episodes", type=int, default=10, help="episodes of each policy (default 10)")
    parser.add_argument("--json", help="also write the figures to this file (never overwritten)")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        print(f"error: --episodes must be at least 1, got {args.episodes}", file=sys.stderr)
        return 2
    if args.json and Path(args.json).exists():
        print(f"error: {args.json} exists; give another --json path (results are never overwritten)", file=sys.stderr)
        return 2
    try:
        policy = load(args.task, args.algo, args.seed)
    except (PretrainedNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    env = protocol.evaluation_env(policy.task, policy.env_kwargs)
    rows = {"pretrained (deterministic)": act_statistics(env, policy.draw_action, args.episodes),
            "uniformly random": act_statistics(env, random_policy(env, protocol.SEED), args.episodes)}
    print(render(policy.task, policy.algorithm, policy.seed, rows, args.episodes))
    if args.json:
        Path(args.json).write_text(json.dumps({"task": policy.task, "algorithm": policy.algorithm,
                                               "seed": policy.seed, "episodes": args.episodes, **rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
