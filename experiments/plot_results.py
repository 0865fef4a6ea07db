"""Turn training runs into the committed results: ``results/<task>_<algo>.csv`` and ``.png``.

    python experiments/plot_results.py RUN_DIR [RUN_DIR ...] [--out results]

Each run directory's ``progress.csv`` (one row per epoch: deterministic evaluation over 10 episodes) is
copied, and the episode length L and the undiscounted task return R are plotted against environment steps,
with the uniformly random policy's figures (same evaluation seed) as dashed lines.
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from baselines.training import load_checkpoint, make_env, run_config_from_checkpoint  # noqa: E402
from experiments.evaluate import random_policy_statistics  # noqa: E402


def read_progress(path: Path) -> dict[str, list[float]]:
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    return {key: [float(r[key]) if r[key] not in ("", None) else float("nan") for r in rows] for key in rows[0]}


def plot_run(run_dir: Path, out_dir: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    state = load_checkpoint(run_dir)
    run = run_config_from_checkpoint(state)
    stem = f"{run.task}_{run.algorithm}"
    out_dir.mkdir(parents=True, exist_ok=True)
    shutil.copy(run_dir / "progress.csv", out_dir / f"{stem}.csv")
    progress = read_progress(run_dir / "progress.csv")
    env = make_env(run, seed=run.train.eval_seed)
    random = random_policy_statistics(env, run.train.n_eval_episodes, run.train.eval_seed)
    (out_dir / f"{stem}_random.json").write_text(json.dumps(random, indent=2))

    steps = [s / 1e6 for s in progress["step"]]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    for ax, key, label in zip(axes, ("L", "R", "disc_reward_mean"),
                              ("episode length L", "task return R", "discriminator reward / step"), strict=True):
        ax.plot(steps, progress[key], label=run.algorithm.upper() if run.algorithm != "gaifo" else "GAIfO")
        if key in random:
            ax.axhline(random[key], color="grey", linestyle="--", label="random policy")
        ax.set_xlabel("environment steps (millions)")
        ax.set_title(label)
        ax.grid(alpha=0.3)
    axes[0].legend()
    fig.suptitle(f"{run.algorithm} on {run.task} ({run.env.get('control', 'default')} control), seed {run.seed}: "
                 f"deterministic evaluation, {run.train.n_eval_episodes} episodes per point")
    fig.tight_layout()
    png = out_dir / f"{stem}.png"
    fig.savefig(png, dpi=90)
    plt.close(fig)
    return png


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, help="run directories")
    parser.add_argument("--out", type=Path, default=Path("results"))
    args = parser.parse_args(argv)
    for run_dir in args.runs:
        print(plot_run(run_dir, args.out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
