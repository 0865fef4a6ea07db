"""Train a baseline on a task: ``python experiments/launch.py --env UnitreeH1.walk --algo vail``.

The configuration comes from ``configs/defaults.yaml`` (shared, per algorithm family, per algorithm) and
``configs/<algo>/<task>.yaml``; ``--print-config`` shows the result and where each value came from. The run directory
(``--out``, default ``runs/<task>/<algo>/seed<N>``) receives the resolved config, ``progress.csv``,
TensorBoard logs and ``checkpoint.pt`` after every epoch. Ctrl-C (or a kill) loses at most the epoch in
progress; ``--resume`` continues bit for bit from the last checkpoint, and ``--steps`` may extend the run.
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from baselines import ALGORITHMS  # noqa: E402
from baselines.config import CONFIG_DIR, ConfigError, format_config, load_run_config, parse_overrides  # noqa: E402
from baselines.training import Trainer  # noqa: E402


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


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    for name in ("steps", "epoch_steps", "threads"):
        value = getattr(args, name)
        if value is not None and value < 1:
            print(f"error: --{name.replace('_', '-')} must be at least 1, got {value}", file=sys.stderr)
            return 2
    if args.resume and (args.set or args.epoch_steps is not None):
        print("error: --resume continues with the checkpoint's own configuration (only --steps may extend it); "
              "to change settings, start a new run from it with --init-from CHECKPOINT --set ...", file=sys.stderr)
        return 2
    try:
        overrides = parse_overrides(args.set)
        if args.steps is not None:
            overrides["train"]["n_steps"] = args.steps
        if args.epoch_steps is not None:
            overrides["train"]["epoch_steps"] = args.epoch_steps
        if args.threads is not None:
            overrides["agent"]["n_threads"] = args.threads
        run = load_run_config(args.env, args.algo, seed=args.seed, config_dir=args.config_dir, overrides=overrides)
    except (ConfigError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    per_fit = run.train.n_steps_per_fit
    if run.train.n_steps % per_fit:  # every epoch ends on a fit: round up, and say so
        rounded = -(-run.train.n_steps // per_fit) * per_fit
        print(f"note: {run.train.n_steps:,} steps is not a multiple of train.n_steps_per_fit ({per_fit:,}); "
              f"training {rounded:,} steps", file=sys.stderr)
        run.train.n_steps = rounded
    if args.print_config:
        print(format_config(run))
        return 0
    out = Path(args.out or Path("runs") / args.env / args.algo / f"seed{args.seed}")
    try:
        trainer = Trainer(run, out, resume=args.resume, progress=not args.quiet, init_from=args.init_from,
                          n_threads=args.threads)
    except (OSError, ValueError) as err:  # our errors name the file or value; nothing was created
        print(f"error: {err}", file=sys.stderr)
        return 2
    signal.signal(signal.SIGTERM, _stop_on_sigterm)
    print(f"{run.algorithm} on {run.task}, seed {run.seed}: {trainer.steps:,} of {trainer.run.train.n_steps:,} steps "
          f"done, run directory {out}", flush=True)
    try:
        result = trainer.train()
    except KeyboardInterrupt:
        print(f"\ninterrupted; checkpoint at epoch {trainer.epoch} ({trainer.steps:,} steps) in {out}. "
              f"Continue with: --resume --out {out}", file=sys.stderr)
        return 130
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
