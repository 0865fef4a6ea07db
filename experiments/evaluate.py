"""Evaluate a trained agent under the evaluation protocol, or list every task's reference returns.

    python experiments/evaluate.py runs/UnitreeH1.walk_vail/checkpoint.pt [--metrics] [--record] [--json F]
    python experiments/evaluate.py --references [TASK ...]

The protocol (loco_mujoco.evaluation.protocol): 50 episodes from dataset start states drawn with seed 12345,
the deterministic policy (``--stochastic`` adds the stochastic one). Every figure is a mean with a 95%
bootstrap interval and an interquartile mean (IQM). The normalised score puts a uniformly random policy at 0
and the expert (the task reward its dataset frames earn, over the horizon) at 100, under the run's own env
settings. ``--metrics`` adds trajectory distances, gait and state-distribution metrics beside the expert's;
``--record`` writes an H.264 mp4 of the first episode beside a translucent replay of the reference motion.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

import numpy as np  # noqa: E402

from loco_mujoco.evaluation import protocol  # noqa: E402
from loco_mujoco.evaluation.intervals import format_summary, summarize  # noqa: E402
from loco_mujoco.evaluation.references import references, stand_still_scores  # noqa: E402

METRIC_UNITS = {"euclidean": "mean per-step distance", "dtw": "RMS per-step distance along the DTW path",
                "frechet": "discrete Frechet distance", "joints": "rad", "sites": "m"}
GAIT_UNITS = {"forward_speed": "m/s", "cadence": "steps/min", "stride_length": "m", "duty_factor": "fraction",
              "double_support": "fraction", "foot_clearance": "m", "foot_sliding": "m/s",
              "symmetry": "index, 0 = symmetric"}
DISTRIBUTION_UNITS = {"mmd": "RBF MMD, 0 = same", "sliced_wasserstein": "pooled std units, 0 = same",
                      "classifier_auc": "0.5 = indistinguishable"}


def tasks_with_data() -> list[str]:
    """Every bare task name (real dataset) whose dataset has a recipe."""
    from loco_mujoco import list_tasks
    from loco_mujoco.core.task_names import DATASET_TYPES, environment_class, parse_task_name
    from loco_mujoco.datasets.registry import variants

    names = []
    for name in list_tasks():
        if name.split(".")[-1] in DATASET_TYPES:
            continue
        parsed = parse_task_name(name)
        try:
            if variants(environment_class(parsed.env), parsed.task):
                names.append(name)
        except Exception:  # noqa: BLE001  (no recipe for this task)
            continue
    return names


def print_references(tasks: list[str], refresh: bool) -> list[dict]:
    """One line per task: expert, random, zero-action and hold-pose returns and the stand-still scores."""
    from tqdm import tqdm

    rows = []
    print(f"{'task':<34}{'expert R':>10}{'random R':>10}{'random L':>10}{'zero R':>9}{'zero L':>8}"
          f"{'hold R':>9}{'hold L':>8}{'zero score':>12}{'hold score':>12}")
    for task in tqdm(tasks, desc="references", unit="task", leave=False):
        refs = references(task, refresh=refresh)
        s = stand_still_scores(refs)
        tqdm.write(f"{task:<34}{refs.expert_return:10.1f}{refs.random_return:10.1f}{refs.random_length:10.1f}"
                   f"{refs.zero_return:9.1f}{refs.zero_length:8.0f}{refs.hold_return:9.1f}{refs.hold_length:8.0f}"
                   f"{s['zero']:12.2f}{s['hold']:12.2f}")
        rows.append({"task": task, **refs.__dict__, "stand_still_scores": s})
    return rows


def print_metrics(m: dict) -> None:
    print("imitation metrics (agent vs. expert reference; mean [95% CI] over episodes):")
    for name, values in m["trajectory"].items():
        kind, part = name.rsplit("_", 1)
        vals = np.asarray(values, dtype=float)
        s = summarize(vals[np.isfinite(vals)], seed=0) if np.any(np.isfinite(vals)) else None
        text = format_summary(s, 3) if s else "n/a"
        print(f"  {name:<22}{text:<40} expert 0 by definition  ({METRIC_UNITS[kind]}, {METRIC_UNITS[part]})")
    dev = np.asarray(m["gait"]["deviation"], dtype=float)
    dev_text = format_summary(summarize(dev[np.isfinite(dev)]), 3) if np.any(np.isfinite(dev)) else "n/a"
    print(f"  {'gait_deviation':<22}{dev_text:<40} expert 0 by definition  (mean relative deviation of the gait "
          "metrics below, each capped at 1)")
    print(f"  {'gait':<22}{'agent':>12}{'expert':>12}")
    for key, value in m["gait"]["agent"].items():
        print(f"  {key:<22}{value:12.3f}{m['gait']['expert'][key]:12.3f}  ({GAIT_UNITS[key]})")
    print(f"  {'state distribution':<22}{'agent':>12}{'expert':>12}  "
          "(expert: alternate 1 s chunks of the dataset vs. the rest)")
    for key, value in m["distribution"]["agent"].items():
        expert = m["distribution"]["expert"].get(key, math.nan)
        print(f"  {key:<22}{value:12.3f}{expert:12.3f}  ({DISTRIBUTION_UNITS[key]})")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("checkpoint", nargs="?", help="checkpoint.pt (or its run directory)")
    parser.add_argument("--episodes", type=int, default=protocol.EPISODES)
    parser.add_argument("--seed", type=int, default=protocol.SEED, help=f"evaluation seed (default {protocol.SEED})")
    parser.add_argument("--stochastic", action="store_true", help="also evaluate the stochastic policy")
    parser.add_argument("--metrics", action="store_true", help="trajectory, gait and distribution metrics")
    parser.add_argument("--record", nargs="?", const="", default=None,
                        help="write an H.264 mp4 of the first episode beside the reference motion "
                             "(default: <run dir>/<task>_<algo>_seed<N>_episode0.mp4)")
    parser.add_argument("--json", help="also write the results to this JSON file")
    parser.add_argument("--force", action="store_true", help="replace an existing --json file or video")
    parser.add_argument("--references", nargs="*", metavar="TASK",
                        help="list the reference returns of these tasks (default: every task with data)")
    parser.add_argument("--refresh", action="store_true", help="recompute cached references")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be at least 1, got {args.episodes}")
    if args.references is not None:
        rows = print_references(args.references or tasks_with_data(), args.refresh)
        if args.json:
            Path(args.json).write_text(json.dumps(rows, indent=1))
        return 0
    if not args.checkpoint:
        parser.error("give a checkpoint to evaluate, or --references")

    from baselines.common.evaluation import evaluate_agent
    from baselines.training import build, load_checkpoint, run_config_from_checkpoint, writable_dir

    try:
        state = load_checkpoint(args.checkpoint)
    except (FileNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    run = run_config_from_checkpoint(state)
    run_dir = Path(args.checkpoint) if Path(args.checkpoint).is_dir() else Path(args.checkpoint).parent
    video = None
    if args.record is not None:
        default = run_dir / f"{run.task}_{run.algorithm}_seed{run.seed}_episode0.mp4"
        video = Path(args.record) if args.record else default
    try:  # every output checked before the work: nothing is overwritten unasked, nothing fails at the end
        for out in [p for p in (Path(args.json) if args.json else None, video) if p is not None]:
            if out.exists() and not args.force:
                raise FileExistsError(f"{out} exists; pass --force to replace it")
            writable_dir(out.parent)
    except OSError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    _, agent = build(run)
    agent.load_state_dict(state["agent"])
    env = protocol.evaluation_env(run.task, run.env, seed=args.seed)  # the real task, whatever data it trained on
    print(f"{run.algorithm} on {run.task}, seed {run.seed}: epoch {state['epoch']}, {state['steps']:,} training steps")
    refs = references(run.task, run.env, progress=True)
    eval_task, eval_kwargs = protocol.evaluation_task(run.task, run.env)
    print(f"references ({eval_task}, {', '.join(f'{k}={v}' for k, v in eval_kwargs.items())}): expert R "
          f"{refs.expert_return:.1f}, random R {refs.random_return:.1f} (L {refs.random_length:.1f}), "
          f"zero action R {refs.zero_return:.1f}, hold pose R {refs.hold_return:.1f}")

    results: dict = {"task": run.task, "algorithm": run.algorithm, "seed": run.seed, "steps": state["steps"],
                     "protocol": {"episodes": args.episodes, "seed": args.seed}, "references": refs.__dict__}
    evaluations = {"deterministic": evaluate_agent(agent, env, args.episodes, True, args.seed,
                                                   record=args.metrics or args.record is not None, progress=True)}
    if args.stochastic:
        evaluations["stochastic"] = evaluate_agent(agent, env, args.episodes, False, args.seed, progress=True)
    for name, ev in evaluations.items():
        summary = ev.summary()
        score = summarize(refs.normalized_score(ev.returns), seed=args.seed)
        results[name] = {"score": score, **summary, "statistics": ev.statistics(),
                         "returns": ev.returns.tolist(), "lengths": ev.lengths.tolist()}
        print(f"{name:>13}: score {format_summary(score)}  ({args.episodes} episodes, 95% CI)")
        print(f"{'':>15}R {format_summary(summary['R'])}  L {format_summary(summary['L'])}  "
              f"J {format_summary(summary['J'])}")
    if args.metrics:
        from loco_mujoco.evaluation.imitation import imitation_metrics

        results["metrics"] = imitation_metrics(env, evaluations["deterministic"])
        print_metrics(results["metrics"])
    if video is not None:
        path = video
        try:
            from loco_mujoco.evaluation.imitation import reference_qpos
            from loco_mujoco.evaluation.video import render_with_reference

            episode = evaluations["deterministic"].episodes[0]
            ref = reference_qpos(env, episode.start_frame, len(episode.qpos)) if episode.start_frame is not None \
                else None
            # every second step (50 fps) at 480x360 without shadows: ~4 frames/s in software rendering
            n = render_with_reference(env.model, episode.qpos[::2], None if ref is None else ref[::2], path,
                                      fps=round(0.5 / env.dt), width=480, height=360)
            print(f"video: {path} ({n} frames; the translucent figure is the reference motion)")
            results["video"] = str(path)
        except Exception as err:  # noqa: BLE001  (no OpenGL context, or an unwritable folder)
            print(f"no video: {type(err).__name__}: {err} (offscreen rendering needs e.g. MUJOCO_GL=egl)",
                  file=sys.stderr)
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1, default=float))
        print(f"results: {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
