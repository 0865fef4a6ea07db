"""Evaluate a trained agent under the evaluation protocol, or list every task's reference returns.

    python experiments/evaluate.py runs/UnitreeH1.walk_vail/checkpoint.pt [--metrics] [--record] [--json F]
    python experiments/evaluate.py --pretrained UnitreeH1.walk vail [SEED] [--metrics] [--record] [--json F]
    python experiments/evaluate.py --references [TASK ...] [--env control=pd ...]

The protocol (loco_mujoco.evaluation.protocol): 50 episodes from dataset start states drawn with seed 12345,
the deterministic policy (``--stochastic`` adds the stochastic one). Every figure is a mean with a 95%
bootstrap interval and an interquartile mean (IQM). The normalised score puts a uniformly random policy at 0
and the expert (the task reward its dataset frames earn, over the horizon) at 100, under the run's own env
settings. ``--pretrained TASK ALGO [SEED]`` evaluates a pretrained agent (``pretrained/``, training seed 0
unless given; ``--seed`` stays the evaluation seed; or ``--pretrained FOLDER`` for any policy export) the same way, and
prints the score on its card beside: the card's own figures come from this evaluation of the export
(``baselines.card_evaluation``), so with the default protocol they repeat exactly on the machine that wrote them.
``--metrics`` adds trajectory distances, gait and state-distribution metrics beside the expert's;
``--record`` writes an H.264 mp4 of the first episode beside a translucent replay of the reference motion.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

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


def parse_env_settings(items: list[str]) -> dict[str, Any]:
    """``["control=pd", "horizon=500"]`` -> ``{"control": "pd", "horizon": 500}`` (values read as YAML)."""
    import yaml

    settings = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"--env takes KEY=VALUE settings (e.g. control=pd), got {item!r}")
        settings[key] = yaml.safe_load(value)
    return settings


def print_references(tasks: list[str], refresh: bool, env_kwargs: dict[str, Any] | None = None) -> list[dict]:
    """One line per task: expert, random, zero-action and hold-pose returns and the stand-still scores, under
    ``env_kwargs`` (default: each task's own defaults); the settings each was measured under follow the table."""
    from tqdm import tqdm

    rows = []
    print(f"{'task':<34}{'expert R':>10}{'random R':>10}{'+- (se)':>9}{'random L':>10}{'zero R':>9}{'zero L':>8}"
          f"{'hold R':>9}{'hold L':>8}{'zero score':>12}{'hold score':>12}")
    for task in tqdm(tasks, desc="references", unit="task", leave=False):
        refs = references(task, env_kwargs, refresh=refresh)
        s = stand_still_scores(refs)
        tqdm.write(f"{task:<34}{refs.expert_return:10.1f}{refs.random_return:10.1f}{refs.random_return_se:9.2f}"
                   f"{refs.random_length:10.1f}"
                   f"{refs.zero_return:9.1f}{refs.zero_length:8.0f}{refs.hold_return:9.1f}{refs.hold_length:8.0f}"
                   f"{s['zero']:12.2f}{s['hold']:12.2f}")
        rows.append({"task": task, **refs.__dict__, "stand_still_scores": s})
    for row in rows:
        print(f"{row['task']}: measured under {', '.join(f'{k}={v}' for k, v in row['env_settings'].items())}")
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


def compare_with_card(card: dict, deterministic: dict) -> str:
    """Whether this deterministic evaluation repeated the card's (same protocol) figures exactly."""
    now = json.loads(json.dumps({k: deterministic[k] for k in ("R", "L")}, default=float))
    if all(card.get(k) == now[k] for k in ("R", "L")):
        return "its card's figures repeated exactly"
    return (f"its card's figures differ: R {card['R']['mean']:.2f} on the card, {now['R']['mean']:.2f} here (another "
            "machine's rounding, or a card written before cards evaluated their export: "
            "python experiments/refresh_cards.py re-evaluates it)")


@dataclass
class Subject:
    """What is evaluated: a checkpoint's agent or a pretrained agent, built only once the outputs are checked."""

    task: str
    algorithm: str
    seed: int
    steps: int
    env: dict[str, Any]
    out_dir: Path  # default folder of the video
    header: str
    build: Callable[[], Any]  # -> an agent (or policy) that evaluate_agent takes
    extra: dict[str, Any]  # more for the results file


def checkpoint_subject(checkpoint: str) -> Subject:
    """The agent of a training checkpoint (or its run directory)."""
    from baselines.training import build, load_checkpoint, run_config_from_checkpoint

    state = load_checkpoint(checkpoint)
    run = run_config_from_checkpoint(state)

    def make_agent() -> Any:
        _, agent = build(run)
        agent.load_state_dict(state["agent"])
        return agent

    return Subject(run.task, run.algorithm, run.seed, int(state["steps"]), dict(run.env),
                   Path(checkpoint) if Path(checkpoint).is_dir() else Path(checkpoint).parent,
                   f"{run.algorithm} on {run.task}, seed {run.seed}: epoch {state['epoch']}, "
                   f"{state['steps']:,} training steps", make_agent, {})


def pretrained_subject(values: list[str]) -> Subject:
    """A pretrained agent from ``[TASK, ALGO]``, ``[TASK, ALGO, SEED]`` or ``[EXPORT_FOLDER]`` (any policy export,
    such as a run's snapshot)."""
    from baselines.pretrained import PretrainedPolicy, load
    from loco_mujoco.policy_export import PolicyExport

    if len(values) == 1:
        if not Path(values[0]).is_dir():
            raise ValueError(f"--pretrained takes TASK ALGO [SEED] or an export folder; {values[0]!r} is no folder")
        policy = PretrainedPolicy(PolicyExport.load(values[0]))
    elif len(values) in (2, 3):
        try:
            seed = int(values[2]) if len(values) == 3 else 0
        except ValueError:
            raise ValueError(f"--pretrained SEED must be an integer, got {values[2]!r}") from None
        policy = load(values[0], values[1], seed)
    else:
        raise ValueError(f"--pretrained takes TASK ALGO [SEED] or an export folder, got {len(values)} values: "
                         f"{' '.join(values)}")
    card = policy.card
    score = card.get("evaluation", {}).get("score")
    on_card = (f"; its card: score {format_summary(score)} ({card['evaluation']['protocol']['episodes']} episodes)"
               if score else "; its card has no evaluation")
    return Subject(policy.task, policy.algorithm, policy.seed, int(card.get("steps", 0)), policy.env_kwargs, Path("."),
                   f"pretrained {policy.algorithm} on {policy.task}, seed {policy.seed} ({policy.export.path}): "
                   f"{card.get('steps', 0):,} training steps{on_card}", lambda: policy,
                   {"pretrained": str(policy.export.path), "card_evaluation": card.get("evaluation", {})})


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("checkpoint", nargs="?", help="checkpoint.pt (or its run directory)")
    parser.add_argument("--pretrained", nargs="+", metavar="TASK ALGO [SEED]",
                        help="evaluate the pretrained agent of TASK and ALGO (training seed SEED, default 0), or "
                             "the policy export in a folder")
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
    parser.add_argument("--env", nargs="+", default=[], metavar="KEY=VALUE",
                        help="with --references: env settings to measure under (e.g. control=pd; default: each "
                             "task's own; the results table's are in results/references/<task>.json)")
    args = parser.parse_args(argv)
    if args.episodes < 1:
        parser.error(f"--episodes must be at least 1, got {args.episodes}")
    if args.references is not None:
        try:
            rows = print_references(args.references or tasks_with_data(), args.refresh, parse_env_settings(args.env))
        except (ValueError, TypeError) as err:
            print(f"error: {err}", file=sys.stderr)
            return 2
        if args.json:
            Path(args.json).write_text(json.dumps(rows, indent=1))
        return 0
    if args.env:
        parser.error("--env applies to --references (an agent is evaluated under the settings it trained with)")
    if not args.checkpoint and not args.pretrained:
        parser.error("give a checkpoint to evaluate, --pretrained TASK ALGO [SEED] (or an export folder), or "
                     "--references")
    if args.checkpoint and args.pretrained:
        parser.error("give either a checkpoint or --pretrained, not both")

    from baselines.common.evaluation import evaluate_agent
    from baselines.training import writable_dir

    try:
        subject = pretrained_subject(args.pretrained) if args.pretrained else checkpoint_subject(args.checkpoint)
    except (FileNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    video = None
    if args.record is not None:
        default = subject.out_dir / f"{subject.task}_{subject.algorithm}_seed{subject.seed}_episode0.mp4"
        video = Path(args.record) if args.record else default
    try:  # every output checked before the work: nothing is overwritten unasked, nothing fails at the end
        for out in [p for p in (Path(args.json) if args.json else None, video) if p is not None]:
            if out.exists() and not args.force:
                raise FileExistsError(f"{out} exists; pass --force to replace it")
            writable_dir(out.parent)
    except OSError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    agent = subject.build()
    env = protocol.evaluation_env(subject.task, subject.env, seed=args.seed)  # the real task, whatever its data
    print(subject.header)
    refs = references(subject.task, subject.env, progress=True)
    eval_task, eval_kwargs = protocol.evaluation_task(subject.task, subject.env)
    print(f"references ({eval_task}, {', '.join(f'{k}={v}' for k, v in eval_kwargs.items())}): expert R "
          f"{refs.expert_return:.1f}, random R {refs.random_return:.1f} +- {refs.random_return_se:.1f} "
          f"({refs.random_episodes} episodes, L {refs.random_length:.1f}), "
          f"zero action R {refs.zero_return:.1f}, hold pose R {refs.hold_return:.1f}")

    results: dict = {"task": subject.task, "algorithm": subject.algorithm, "seed": subject.seed,
                     "steps": subject.steps, **subject.extra,
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
    card = subject.extra.get("card_evaluation")
    if card and card.get("protocol", {}).get("episodes") == args.episodes and card["protocol"].get("seed") == args.seed:
        print(compare_with_card(card, results["deterministic"]))
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
