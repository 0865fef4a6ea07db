"""Compare as you train: where a run stands against our reported run of the same task and algorithm.

The reported runs are the run directories under ``results/runs/<task>_<algo>[_suffix]/`` (their ``progress.csv``,
plus ``init_from_progress.csv`` for a run warm-started from another). Their logs are merged into one curve, the
longest log winning where two cover the same step, and a run in training is compared, at each evaluation, with
the curve's last evaluation at or before its own step count: same evaluation (the Trainer's), same step scale.
Only reported runs whose ``env`` and ``agent`` settings agree with the run's (where both name a value; the torch
thread count aside) are compared: a run with other hyperparameters is another experiment.
Older logs predate the normalised score (and their R used the earlier reward), so only the figures both logs
hold are compared, and L (episode length, the same termination throughout) always is. Scores logged before
2026-11-30 were normalised by 50 random-action episodes, today's by 1,000 (references version 2): up to 1 point
apart on the same returns (HumanoidMuscle.walk; results/README.md).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import yaml

REPORTED_RUNS = Path(__file__).resolve().parents[1] / "results" / "runs"
COMPARED = ("score", "L")  # in this order; R is left out: its reward changed (results/README.md)


IGNORED = {("agent", "n_threads")}  # settings that do not change what a run computes


def differences(saved: dict, current: dict) -> list[str]:
    """``section.key`` of the ``env`` and ``agent`` values that both configs name and that differ."""
    out = []
    for section in ("env", "agent"):
        a, b = saved.get(section) or {}, current.get(section) or {}
        out += [f"{section}.{k}" for k in sorted(set(a) & set(b))
                if (section, k) not in IGNORED and _plain(a[k]) != _plain(b[k])]
    return out


def _plain(value: object) -> object:
    return list(value) if isinstance(value, tuple) else value


def reported_logs(task: str, algo: str, runs_dir: str | Path = REPORTED_RUNS,
                  config: dict | None = None) -> list[Path]:
    """The training logs of the reported runs of ``task`` and ``algo`` (empty if there are none); with ``config``
    (a run's resolved config as a dict) only those of runs whose settings agree with it."""
    runs_dir = Path(runs_dir)
    logs = []
    for folder in sorted(runs_dir.glob(f"{task}_{algo}*")):
        rest = folder.name[len(f"{task}_{algo}"):]
        if rest and not rest.startswith("_"):  # e.g. "<task>_gail" must not take "<task>_gaifo"
            continue
        saved = _run_config(folder)
        if saved.get("task") != task or saved.get("algorithm") != algo:  # a folder name alone could mislead
            continue
        if config is not None and differences(saved, config):
            continue
        logs += [p for p in (folder / "init_from_progress.csv", folder / "progress.csv") if p.is_file()]
    return logs


def _run_config(folder: Path) -> dict:
    """The run directory's ``config.yaml`` (empty if it has none)."""
    path = folder / "config.yaml"
    if not path.is_file():
        return {}
    with path.open() as f:
        return yaml.safe_load(f) or {}


def reported_curve(task: str, algo: str, runs_dir: str | Path = REPORTED_RUNS,
                   config: dict | None = None) -> list[dict[str, float]]:
    """The merged reported curve (of the runs that agree with ``config``, if given): one row per evaluated step
    count, sorted, holding the figures of :data:`COMPARED` that its log has."""
    by_step: dict[int, tuple[int, dict[str, float]]] = {}
    for log in reported_logs(task, algo, runs_dir, config):
        with log.open(newline="") as f:
            rows = list(csv.DictReader(f))
        for row in rows:
            step = int(float(row["step"]))
            figures = {k: float(row[k]) for k in COMPARED if row.get(k) not in (None, "")}
            figures = {k: v for k, v in figures.items() if math.isfinite(v)}
            if step not in by_step or len(rows) > by_step[step][0]:
                by_step[step] = (len(rows), {"step": float(step), **figures})
    return [by_step[s][1] for s in sorted(by_step)]


def at_step(curve: list[dict[str, float]], step: int) -> dict[str, float] | None:
    """The curve's last row at or before ``step`` (None if the curve starts later or is empty)."""
    before = [row for row in curve if row["step"] <= step]
    return before[-1] if before else None


def comparison_line(task: str, algo: str, step: int, evaluation: dict[str, float],
                    curve: list[dict[str, float]]) -> str:
    """One line: this run's figures at ``step`` beside the reported curve's at the same step count."""
    if not curve:
        return f"no reported {algo} run on {task} with these settings to compare with"
    row = at_step(curve, step)
    if row is None:
        return (f"the reported {algo} on {task} has no evaluation at or before {step:,} steps (its first: "
                f"{int(curve[0]['step']):,})")
    parts = []
    for key in COMPARED:
        if key in row and key in evaluation:
            diff = evaluation[key] - row[key]
            parts.append(f"{key} {evaluation[key]:.1f} vs {row[key]:.1f} ({diff:+.1f})")
    figures = ", ".join(parts) or "no figure in common"
    return f"against the reported {algo} on {task} at {int(row['step']):,} steps: {figures}"
