"""Evaluate a trained agent: ``python experiments/evaluate.py runs/UnitreeH1.walk/vail/seed0/checkpoint.pt``.

Rebuilds the environment and agent from the checkpoint's own configuration, runs ``--episodes`` deterministic
episodes (and as many with a uniform random policy, for comparison) and prints R (undiscounted return), J
(discounted), L (episode length) and the mean task reward per step. ``--record`` writes an mp4 of the first
episode (needs offscreen rendering, e.g. ``MUJOCO_GL=egl``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

import numpy as np  # noqa: E402

from baselines.common.evaluation import episode_statistics, evaluate  # noqa: E402
from baselines.training import build, load_checkpoint, make_env, run_config_from_checkpoint  # noqa: E402


def random_policy_statistics(env, n_episodes: int, seed: int) -> dict[str, float]:
    """R, J, L and task reward of uniformly random actions on ``env`` (re-seeded with ``seed``)."""
    env.seed(seed)
    rng = np.random.default_rng(seed)
    low, high = env.info.action_space.low, env.info.action_space.high
    dataset = []
    for _ in range(n_episodes):
        env.reset()
        for t in range(env.info.horizon):
            obs, reward, absorbing, _ = env.step(rng.uniform(low, high))
            last = absorbing or t == env.info.horizon - 1
            dataset.append((None, None, reward, obs, absorbing, last))
            if last:
                break
    return episode_statistics(dataset, env.info.gamma)


def record_episode(agent, env, path: Path, seed: int, max_steps: int = 1000) -> int:
    """Write an mp4 of one deterministic episode; returns the number of frames."""
    from loco_mujoco.demo import write_video

    env.seed(seed)
    obs = env.reset()
    frames = [env.render_rgb()]
    with agent.policy.evaluation_mode(deterministic=True, seed=seed):
        for _ in range(max_steps):
            obs, _, absorbing, _ = env.step(agent.policy.draw_action(obs))
            frames.append(env.render_rgb())
            if absorbing:
                break
    write_video(frames, path, fps=round(1.0 / env.dt))
    return len(frames)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("checkpoint", help="checkpoint.pt (or its run directory)")
    parser.add_argument("--episodes", type=int, default=10)
    parser.add_argument("--seed", type=int, default=None, help="evaluation seed (default: the run's eval_seed)")
    parser.add_argument("--stochastic", action="store_true", help="also evaluate the stochastic policy")
    parser.add_argument("--no-random", action="store_true", help="skip the random-policy comparison")
    parser.add_argument("--record", nargs="?", const="", default=None,
                        help="write an mp4 of one episode (default path: beside the checkpoint)")
    parser.add_argument("--json", help="also write the results to this JSON file")
    args = parser.parse_args(argv)
    try:
        state = load_checkpoint(args.checkpoint)
    except (FileNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    run = run_config_from_checkpoint(state)
    seed = run.train.eval_seed if args.seed is None else args.seed
    _, agent = build(run)
    agent.load_state_dict(state["agent"])
    env = make_env(run, seed=seed)
    print(f"{run.algorithm} on {run.task}, seed {run.seed}: epoch {state['epoch']}, {state['steps']:,} training steps")

    results = {}
    env.seed(seed)
    results["deterministic"] = evaluate(agent, env, n_episodes=args.episodes, deterministic=True, seed=seed)
    if args.stochastic:
        env.seed(seed)
        results["stochastic"] = evaluate(agent, env, n_episodes=args.episodes, deterministic=False, seed=seed)
    if not args.no_random:
        results["random"] = random_policy_statistics(env, args.episodes, seed)
    for name, r in results.items():
        print(f"{name:>13}: R={r['R']:9.2f}  J={r['J']:8.2f}  L={r['L']:7.1f}  task_reward={r['task_reward']:.4f}  "
              f"({r['episodes']} episodes)")
    if "random" in results and results["random"]["R"] > 0:
        print(f"task return vs random policy: {results['deterministic']['R'] / results['random']['R']:.2f}x")
    if args.record is not None:
        path = Path(args.record or Path(args.checkpoint).with_suffix("").as_posix() + ".mp4")
        try:
            n = record_episode(agent, env, path, seed)
            print(f"video: {path} ({n} frames)")
        except Exception as err:  # noqa: BLE001  (no OpenGL context on this machine)
            print(f"no video: offscreen rendering unavailable ({type(err).__name__}: {err}); try MUJOCO_GL=egl",
                  file=sys.stderr)
    if args.json:
        Path(args.json).write_text(json.dumps({"task": run.task, "algorithm": run.algorithm, "steps": state["steps"],
                                               **results}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
