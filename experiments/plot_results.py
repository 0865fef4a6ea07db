"""Plot training runs: ``<task>_<algo>[_seed<N>].csv``, ``.png`` and ``_references.json`` per run.

    python experiments/plot_results.py RUN_DIR [RUN_DIR ...]                 # beside each run
    python experiments/plot_results.py results/runs/* --out results --force   # regenerate the committed ones

By default the files go into each run's own folder. A file that exists and was not written by this same call
is never replaced unless ``--force`` is given (the committed results in ``results/`` stay as they are).

Each run directory's ``progress.csv`` (one row per epoch: deterministic evaluation over 10 episodes) is
copied, and the episode length L and the undiscounted task return R are plotted against environment steps,
with the uniformly random policy's figures (same evaluation seed) as dashed lines. A run warm-started with
``launch.py --init-from`` is named ``<task>_<algo>_from<N>M`` and drawn after its source's curve.
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from baselines.config import SECTIONS  # noqa: E402
from baselines.training import (  # noqa: E402
    INIT_FROM_PROGRESS,
    run_config_from_directory,
)
from loco_mujoco.evaluation.references import references  # noqa: E402


def read_progress(path: Path) -> dict[str, list[float]]:
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    return {key: [float(r[key]) if r[key] not in ("", None) else float("nan") for r in rows] for key in rows[0]}


def config_changes(before: dict, after: dict) -> dict[str, tuple]:
    """``{"section.key": (old, new)}`` for the env / train / agent settings that differ (threads and length aside)."""
    ignored = {"agent.n_threads", "train.n_steps"}
    changes = {}
    for section in SECTIONS:
        old, new = before.get(section, {}), after.get(section, {})
        for key in sorted(set(old) | set(new)):
            name = f"{section}.{key}"
            if name not in ignored and old.get(key) != new.get(key):
                changes[name] = (old.get(key), new.get(key))
    return changes


def output_stem(run) -> str:
    """``<task>_<algo>`` (``_seed<N>`` for seeds other than 0, ``_from<N>M`` for warm starts)."""
    stem = f"{run.task}_{run.algorithm}" + (f"_seed{run.seed}" if run.seed != 0 else "")
    if run.init_from is not None:
        stem += f"_from{run.init_from['steps'] / 1e6:g}M"
    return stem


def _default_control(task: str) -> str:
    """The control the task's environment uses when the run's config names none."""
    import loco_mujoco as lm

    return lm.LocoEnv.make(task).control


def plot_run(run_dir: Path, out_dir: Path | None = None, force: bool = False,
             written: set[Path] | None = None) -> Path:
    """Write ``run_dir``'s csv, png and references into ``out_dir`` (default: ``run_dir``); an existing file not in
    ``written`` (the files this call already wrote) raises ``FileExistsError`` unless ``force``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    run_dir = Path(run_dir)
    out_dir = Path(out_dir) if out_dir is not None else run_dir
    written = set() if written is None else written
    run = run_config_from_directory(run_dir)
    stem = output_stem(run)
    targets = [out_dir / f"{stem}{suffix}" for suffix in (".csv", ".png", "_references.json")]
    existing = [str(t) for t in targets if t.exists() and t.resolve() not in written]
    if existing and not force:
        raise FileExistsError(f"would replace {', '.join(existing)}; pass --force to regenerate them, or --out "
                              "another folder")
    written.update(t.resolve() for t in targets)
    source = None
    if run.init_from is not None and (run_dir / INIT_FROM_PROGRESS).exists():  # the source's curve drawn first
        source = read_progress(run_dir / INIT_FROM_PROGRESS)
    out_dir.mkdir(parents=True, exist_ok=True)
    if (out_dir / f"{stem}.csv").resolve() != (run_dir / "progress.csv").resolve():
        shutil.copy(run_dir / "progress.csv", out_dir / f"{stem}.csv")
    progress = read_progress(run_dir / "progress.csv")
    refs = references(run.task, run.env)  # random, stand-still and expert returns under the evaluation protocol
    (out_dir / f"{stem}_references.json").write_text(json.dumps(refs.__dict__, indent=2))
    # Runs logged since the evaluation protocol carry the normalised score (random policy at 0); older runs only
    # their task return R, under the reward of their time, so no reference line is drawn for it.
    random = {"L": refs.random_length, "score": 0.0}
    middle = (("score", "normalised score (random 0, expert 100)") if "score" in progress
              else ("R", "task return R (reward of its time)"))

    steps = [s / 1e6 for s in progress["step"]]
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    third = next(((k, t) for k, t in (("disc_reward_mean", "discriminator reward / step"),
                                      ("critic_loss", "critic loss"), ("bc_nll", "BC negative log-likelihood"))
                  if k in progress), ("R", "task return R"))  # what each algorithm family logs about its learning
    for ax, key, label in zip(axes, ("L", middle[0], third[0]), ("episode length L", middle[1], third[1]),
                              strict=True):
        if source is not None and key in source:
            ax.plot([s / 1e6 for s in source["step"]], source[key], color="tab:grey", alpha=0.7,
                    label="before the warm start")
            ax.axvline(run.init_from["steps"] / 1e6, color="black", linewidth=0.8, linestyle=":")
        ax.plot(steps, progress[key], label=run.algorithm.upper() if run.algorithm != "gaifo" else "GAIfO")
        if key in random:
            ax.axhline(random[key], color="grey", linestyle="--", label="random policy")
        ax.set_xlabel("environment steps (millions)")
        ax.set_title(label)
        ax.grid(alpha=0.3)
    axes[0].legend()
    control = run.env.get("control") or _default_control(run.task)  # a .perfect dataset brings its agent's control
    title = (f"{run.algorithm} on {run.task} ({control} control), seed {run.seed}: "
             f"deterministic evaluation, {run.train.n_eval_episodes} episodes per point")
    if run.init_from is not None:
        changes = ", ".join(f"{k} {a}\u2192{b}" for k, (a, b) in config_changes(run.init_from["run_config"],
                                                                              run.to_dict()).items())
        title += f"\nwarm start at {run.init_from['steps'] / 1e6:g}M steps: {changes or 'same configuration'}"
    fig.suptitle(title)
    fig.tight_layout()
    png = out_dir / f"{stem}.png"
    fig.savefig(png, dpi=90)
    plt.close(fig)
    return png


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, help="run directories")
    parser.add_argument("--out", type=Path, default=None, help="output folder (default: each run's own folder)")
    parser.add_argument("--force", action="store_true", help="replace existing files (e.g. the committed results)")
    args = parser.parse_args(argv)
    written: set[Path] = set()
    for run_dir in args.runs:
        try:
            print(plot_run(run_dir, args.out, args.force, written))
        except (OSError, ValueError) as err:
            print(f"error: {err}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
