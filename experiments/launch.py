"""Train a baseline on a task: ``python experiments/launch.py --env UnitreeH1.walk --algo vail``.

The configuration comes from ``configs/defaults.yaml`` (shared, per algorithm family, per algorithm) and
``configs/<algo>/<task>.yaml``; ``--print-config`` shows the result and where each value came from. The run directory
(``--out``, default ``runs/<task>/<algo>/seed<N>``) receives the resolved config, ``progress.csv``,
TensorBoard logs and ``checkpoint.pt`` after every epoch. Ctrl-C (or a kill) loses at most the epoch in
progress; ``--time-limit MINUTES`` loses nothing: the run stops at its last checkpoint that fits (a session's or a
cluster job's end). ``--resume`` continues bit for bit from the last checkpoint, and ``--steps`` may extend the run.
"""

from __future__ import annotations

import argparse
import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from baselines import ALGORITHMS  # noqa: E402
from baselines.config import (  # noqa: E402
    CONFIG_DIR,
    ConfigError,
    RunConfig,
    format_config,
    load_run_config,
    parse_overrides,
)
from baselines.training import Trainer  # noqa: E402
from experiments.critic_values import divergence_warning, saturation_warning  # noqa: E402
from experiments.reported_curves import comparison_line, reported_curve  # noqa: E402


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", required=True, help="task name, e.g. UnitreeH1.walk")
    parser.add_argument("--algo", required=True, choices=sorted(ALGORITHMS), help="algorithm")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--steps", type=int, help="total training steps: environment steps, or gradient steps for "
                                                     "offline algorithms such as bc (default: train.n_steps)")
    parser.add_argument("--epoch-steps", type=int, help="steps between evaluations / checkpoints (default: config)")
    parser.add_argument("--threads", type=int, help="torch threads of the learner (default: the config's)")
    parser.add_argument("--out", help="run directory (default: runs/<task>/<algo>/seed<N>)")
    parser.add_argument("--resume", action="store_true", help="continue the run in --out from its checkpoint")
    parser.add_argument("--time-limit", type=float, metavar="MINUTES",
                        help="stop after the last checkpoint whose next epoch would end later than MINUTES from "
                             "now (estimated from the last epoch's duration); --resume continues the run")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override one config value (repeatable), e.g. --set train.n_steps_per_fit=5000")
    parser.add_argument("--init-from", metavar="CHECKPOINT",
                        help="warm start: a new run in --out that loads this checkpoint's agent (same task and "
                             "algorithm) and continues its step count under the current configuration")
    parser.add_argument("--config-dir", default=str(CONFIG_DIR), help="directory of the YAML configs")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--print-config", action="store_true",
                        help="print the resolved configuration and where each value came from, then exit")
    return parser.parse_args(argv)


def _stop_on_sigterm(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def run_dir(root: str | Path, task: str, algorithm: str, seed: int) -> Path:
    """Where a run lives under ``root``: ``<root>/<task>/<algorithm>/seed<N>`` (launch.py's default, and sweep.py's)."""
    return Path(root) / task / algorithm / f"seed{seed}"


def resolve_run(task: str, algorithm: str, seed: int = 0, steps: int | None = None, epoch_steps: int | None = None,
                threads: int | None = None, overrides: dict[str, dict[str, Any]] | None = None,
                config_dir: str | Path = CONFIG_DIR, note: Callable[[str], None] | None = None) -> RunConfig:
    """The run configuration the command line asks for: the YAML layers, then ``overrides`` (``--set``), then
    ``steps``, ``epoch_steps`` and ``threads``; ``train.n_steps`` rounded up to a multiple of
    ``train.n_steps_per_fit`` (every epoch ends on a fit), which ``note`` is told. Shared by launch.py and
    sweep.py so that a sweep trial is exactly the run launch.py would start. Raises ``ConfigError`` or
    ``ValueError`` naming what is wrong."""
    for name, value in (("steps", steps), ("epoch_steps", epoch_steps), ("threads", threads)):
        if value is not None and value < 1:
            raise ValueError(f"--{name.replace('_', '-')} must be at least 1, got {value}")
    merged = {section: dict(values) for section, values in (overrides or {}).items()}
    for section, key, value in (("train", "n_steps", steps), ("train", "epoch_steps", epoch_steps),
                                ("agent", "n_threads", threads)):
        if value is not None:
            merged.setdefault(section, {})[key] = value
    run = load_run_config(task, algorithm, seed=seed, config_dir=config_dir, overrides=merged)
    per_fit = run.train.n_steps_per_fit
    if run.train.n_steps % per_fit:
        rounded = -(-run.train.n_steps // per_fit) * per_fit
        if note is not None:
            note(f"{run.train.n_steps:,} steps is not a multiple of train.n_steps_per_fit ({per_fit:,}); "
                 f"training {rounded:,} steps")
        run.train.n_steps = rounded
    return run


def _note(text: str) -> None:
    print(f"note: {text}", file=sys.stderr)


def _compare_with_reported(run: Any) -> Callable[[int, dict[str, float]], str]:
    """At every evaluation: this run's score and L beside our reported run's at the same step count
    (``results/runs``, :mod:`reported_curves`)."""
    config = run.to_dict()
    curve = reported_curve(run.task, run.algorithm, config=config)

    def line(steps: int, figures: dict[str, float]) -> str:
        text = comparison_line(run.task, run.algorithm, steps, figures, curve)
        warnings = [divergence_warning(run.algorithm, config, figures.get("q_expert")),
                    saturation_warning(run.algorithm, config, figures.get("q_agent"))]
        return "\n".join([text, *[w for w in warnings if w]])

    return line


def main(argv: list[str] | None = None) -> int:
    started = time.time()  # --time-limit counts from here
    args = parse_args(argv)
    if args.resume and (args.set or args.epoch_steps is not None):
        print("error: --resume continues with the checkpoint's own configuration (only --steps may extend it); "
              "to change settings, start a new run from it with --init-from CHECKPOINT --set ...", file=sys.stderr)
        return 2
    try:
        run = resolve_run(args.env, args.algo, seed=args.seed, steps=args.steps, epoch_steps=args.epoch_steps,
                          threads=args.threads, overrides=parse_overrides(args.set), config_dir=args.config_dir,
                          note=_note)
    except (ConfigError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.print_config:
        print(format_config(run))
        return 0
    if args.time_limit is not None and not args.time_limit > 0:
        print(f"error: --time-limit must be a positive number of minutes, got {args.time_limit}", file=sys.stderr)
        return 2
    deadline = None if args.time_limit is None else started + 60.0 * args.time_limit
    out = Path(args.out) if args.out else run_dir("runs", args.env, args.algo, args.seed)
    try:
        trainer = Trainer(run, out, resume=args.resume, progress=not args.quiet, init_from=args.init_from,
                          n_threads=args.threads, on_evaluation=_compare_with_reported(run))
    except (OSError, ValueError) as err:  # our errors name the file or value; nothing was created
        print(f"error: {err}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, _stop_on_sigterm)
    print(f"{run.algorithm} on {run.task}, seed {run.seed}: {trainer.steps:,} of {trainer.run.train.n_steps:,} steps "
          f"done, run directory {out}", flush=True)
    try:
        result = trainer.train(deadline=deadline)
    except KeyboardInterrupt:
        print(f"\ninterrupted; checkpoint at epoch {trainer.epoch} ({trainer.steps:,} steps) in {out}. "
              f"Continue with: --resume --out {out}", file=sys.stderr)
        return 130
    if trainer.stopped_at_deadline:
        print(f"stopped at the time limit ({args.time_limit:g} min) after epoch {trainer.epoch} "
              f"({trainer.steps:,} of {trainer.run.train.n_steps:,} steps). Continue with: --resume --out {out}")
    if result:
        print(f"epoch {trainer.epoch}, {trainer.steps:,} steps: R={result['R']:.2f} J={result['J']:.2f} "
              f"L={result['L']:.1f} task_reward={result['task_reward']:.4f} (deterministic, "
              f"{run.train.n_eval_episodes} episodes)")
    if trainer.checkpoint_path.exists():
        print(f"checkpoint: {trainer.checkpoint_path}")
    else:
        print(f"no checkpoint written: no epoch completed in {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
