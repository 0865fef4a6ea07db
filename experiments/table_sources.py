"""What the results table is made of: evaluation files, pretrained cards and training logs, read as they are.

- An evaluation file (``experiments/evaluate.py --json``) gives one training seed's per-episode returns, lengths
  and imitation metrics under the protocol, with the references it was scored against. Its per-episode
  normalised scores are recomputed from those returns and references, so seeds can be pooled episode by episode.
- A pretrained card (``pretrained/<task>/<algo>/seed<N>/card.json``) holds only the summary of its evaluation
  (no episodes): it is used for a seed that no evaluation file covers.
- A training log (``progress.csv`` in a run directory, or its copy ``<results>/<stem>.csv`` written by
  ``plot_results.py``) gives the budget. Hours are the sum over epochs of the epoch's steps divided by its
  logged ``train_steps_per_s``: the time the trainer measured around learning (environment steps and fits, or
  gradient steps), without the per-epoch evaluation and checkpoint, on whatever else the machine ran beside
  it. A warm-started run adds its source's log (``init_from_progress.csv``); a log that does not cover every
  epoch from the first gives no hours.
"""

from __future__ import annotations

import ast
import csv
import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from baselines.common.machine import read_machines
from loco_mujoco.core.task_names import parse_task_name

# Per-episode imitation metrics pooled over seeds (key in the evaluation file's "metrics"), and per-evaluation ones
# averaged over seeds. Chosen small and readable: one gait figure, DTW on joints and on body sites, the classifier.
EPISODE_METRICS = {"gait_deviation": ("gait", "deviation"), "dtw_joints": ("trajectory", "dtw_joints"),
                   "dtw_sites": ("trajectory", "dtw_sites")}
EVALUATION_METRICS = {"classifier_auc": ("distribution", "agent", "classifier_auc")}


@dataclass(frozen=True)
class Budget:
    """Training budget of one seed: steps (environment or gradient), hours if the log allows, machine if recorded."""

    steps: int
    hours: float | None = None
    machine: str | None = None
    log_path: Path | None = None  # the training log the hours come from

    @property
    def log(self) -> str | None:
        """The training log as the table names it, below the results folder: ``runs/<run>/progress.csv`` for a run
        directory's log, the file name for a log copied beside its evaluation."""
        if self.log_path is None:
            return None
        return "/".join(self.log_path.parts[-3:]) if self.log_path.name == "progress.csv" else self.log_path.name


@dataclass
class SeedResult:
    """One training seed of one algorithm on one task, as an evaluation file or a card reports it."""

    task: str  # as trained, e.g. UnitreeH1.walk.perfect
    algorithm: str
    seed: int
    steps: int
    references: dict[str, Any] | None
    source: str  # the file it was read from (relative to its folder's parent)
    scores: np.ndarray | None = None  # per-episode normalised scores (None: a card's summary only)
    returns: np.ndarray | None = None
    lengths: np.ndarray | None = None
    card_summary: dict[str, dict] | None = None  # a card's score, R and L summaries
    episode_metrics: dict[str, np.ndarray] = field(default_factory=dict)
    evaluation_metrics: dict[str, float] = field(default_factory=dict)
    machine: str | None = None
    stem: str | None = None  # <task>_<algo>[...] of the run, to find its training log
    control: str | None = None  # as its settings name it (None: not named, the task's default)
    own_references: dict[str, Any] | None = None  # where the table rescored it: the references its file gave

    @property
    def base_task(self) -> str:
        """The real task the agent is evaluated on (a dataset type such as ``.perfect`` removed)."""
        p = parse_task_name(self.task)
        return ".".join([p.env, p.task] + ([p.mode] if p.mode else []))

    @property
    def data(self) -> str:
        """The dataset type it was trained on: ``real``, ``perfect`` or ``preference``."""
        return parse_task_name(self.task).dataset_type


def format_steps(n: int) -> str:
    """``38.2M``, ``400k`` or the number itself."""
    return f"{n / 1e6:.1f}M" if n >= 1_000_000 else f"{n / 1e3:.0f}k" if n >= 1000 else str(n)


def _dig(d: dict, keys: tuple[str, ...]) -> Any:
    for k in keys:
        if not isinstance(d, dict) or k not in d:
            return None
        d = d[k]
    return d


def normalized_scores(returns: np.ndarray, refs: dict[str, Any]) -> np.ndarray:
    """100 (R - random) / (expert - random), as ``References.normalized_score``."""
    span = float(refs["expert_return"]) - float(refs["random_return"])
    return 100.0 * (np.asarray(returns, dtype=float) - float(refs["random_return"])) / span


def control_mode(task: str, control: str | None = None) -> str:
    """The control mode an agent of ``task`` acts in where its settings name ``control`` (None: not named): that,
    else for a ``.perfect`` or ``.preference`` task its dataset's (PD), else the embodiment's default."""
    from loco_mujoco.core.task_names import environment_class
    from loco_mujoco.evaluation.protocol import evaluation_task

    base, kwargs = evaluation_task(task, {"control": control})
    return kwargs.get("control") or environment_class(parse_task_name(base).env).DEFAULT_CONTROL


def _settings_control(refs: dict[str, Any]) -> str | None:
    """The control an evaluation's references name (their settings are ``repr``-ed values), or None."""
    value = (refs.get("env_settings") or {}).get("control")
    return None if value is None else ast.literal_eval(value)


def read_evaluation(path: Path) -> SeedResult:
    """One ``evaluate.py --json`` file; its deterministic evaluation (the protocol's headline)."""
    try:
        d = json.loads(path.read_text())
        det, refs = d["deterministic"], d["references"]
        returns = np.asarray(det["returns"], dtype=float)
        result = SeedResult(task=d["task"], algorithm=d["algorithm"], seed=int(d["seed"]), steps=int(d["steps"]),
                            references=refs, source=f"{path.parent.name}/{path.name}",
                            scores=normalized_scores(returns, refs), returns=returns,
                            lengths=np.asarray(det["lengths"], dtype=float), machine=d.get("machine"),
                            stem=path.name.removesuffix("_eval.json"), control=_settings_control(refs))
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{path} is not an evaluation file of experiments/evaluate.py --json "
                         f"({type(err).__name__}: {err})") from None
    for name, keys in EPISODE_METRICS.items():
        values = _dig(d.get("metrics", {}), keys)
        if values is not None:
            result.episode_metrics[name] = np.asarray(values, dtype=float)
    for name, keys in EVALUATION_METRICS.items():
        value = _dig(d.get("metrics", {}), keys)
        if value is not None:
            result.evaluation_metrics[name] = float(value)
    return result


def read_card(path: Path) -> SeedResult:
    """A pretrained card with an evaluation (its summaries only)."""
    try:
        d = json.loads(path.read_text())
        ev = d["evaluation"]
        result = SeedResult(task=d["task"], algorithm=d["algorithm"], seed=int(d["seed"]), steps=int(d["steps"]),
                            references=None, source="/".join(path.parts[-4:]),
                            card_summary={k: ev[k] for k in ("score", "R", "L")}, machine=d.get("machine"))
    except (KeyError, TypeError, ValueError) as err:
        raise ValueError(f"{path} is not a pretrained card with an evaluation ({type(err).__name__}: {err})") from None
    source = d.get("source_checkpoint", "")
    if source.endswith("checkpoint.pt") and " " not in source:
        result.stem = Path(source).parent.name
    config = read_config(path.parent)  # an export keeps its run's config beside the card
    result.control = ((config or {}).get("env") or {}).get("control")
    return result


def read_progress(path: Path) -> list[dict[str, float]]:
    """Rows of a training log, every value a float (NaN where empty)."""
    with path.open(newline="") as f:
        return [{k: float(v) if v not in ("", None) else math.nan for k, v in row.items()} for row in csv.DictReader(f)]


def replay_refills(rows: list[dict[str, float]]) -> list[tuple[int, int, int]]:
    """``(step resumed at, replay_size logged next, replay_size before)`` for each resume that found no replay
    buffer (a warm start from a committed state): the logged ``replay_size`` fell from one row to the next, which
    a buffer never does otherwise (full, it stays at its capacity). Empty for logs without the column."""
    sizes = [(int(r["step"]), r.get("replay_size", math.nan)) for r in rows]
    return [(step, int(size), int(before)) for (step, before), (_, size) in itertools.pairwise(sizes)
            if size < before]


def read_config(run_dir: Path) -> dict[str, Any] | None:
    """A run directory's ``config.yaml``, or None where there is none."""
    path = run_dir / "config.yaml"
    return yaml.safe_load(path.read_text()) if path.exists() else None


def training_hours(rows: list[dict[str, float]], steps: int, start: int = 0) -> float | None:
    """Hours of training up to ``steps`` from a log whose first row is the first epoch after ``start``: the sum of
    each epoch's steps over its ``train_steps_per_s``. None where the log skips epochs, lacks the rate or does not
    reach exactly ``steps``."""
    rows = [r for r in rows if r["step"] <= steps]
    if not rows or rows[-1]["step"] != steps or "train_steps_per_s" not in rows[0]:
        return None
    epochs = [r.get("epoch", math.nan) for r in rows]
    first = epochs[0]
    if not all(e == first + i for i, e in enumerate(epochs)):
        return None
    seconds, previous = 0.0, start
    for r in rows:
        rate = r["train_steps_per_s"]
        if not rate > 0 or r["step"] <= previous:
            return None
        seconds += (r["step"] - previous) / rate
        previous = r["step"]
    return seconds / 3600.0


def _run_hours(run_dir: Path, config: dict[str, Any], steps: int) -> float | None:
    """Hours of a run directory's log up to ``steps``, its warm start's source log included."""
    rows = read_progress(run_dir / "progress.csv")
    init = config.get("init_from") or {}
    if not init:
        return training_hours(rows, steps) if rows and rows[0].get("epoch") == 1 else None
    source = run_dir / "init_from_progress.csv"
    init_steps = int(init["steps"])
    if not source.exists():
        return None
    before = training_hours(read_progress(source), init_steps)
    after = training_hours(rows, steps, start=init_steps)
    return None if before is None or after is None else before + after


def machine_summary(rows: list[dict[str, str]], end_step: int) -> str | None:
    """The machines of ``machines.csv`` ``rows`` that trained the run up to ``end_step``: one name, or each with
    its steps when several did (``Intel Xeon (16 CPUs) 0-1.0M + AMD EPYC (2 CPUs) 1.0M-20.0M``); None without rows."""
    rows = [r for r in rows if int(r["step"]) < end_step] or rows[:1]
    if not rows:
        return None
    stretches: list[tuple[str, int]] = []  # (machine, first step); consecutive rows on one machine are one stretch
    for r in rows:
        if not stretches or stretches[-1][0] != r["machine"]:
            stretches.append((r["machine"], int(r["step"])))
    if len(stretches) == 1:
        return stretches[0][0]
    ends = [start for _, start in stretches[1:]] + [end_step]
    return " + ".join(f"{m} {format_steps(start)}-{format_steps(end)}"
                      for (m, start), end in zip(stretches, ends, strict=True))


def _machine(run_dir: Path, config: dict[str, Any], steps: int) -> str | None:
    """The machine kind(s) that trained ``run_dir`` up to ``steps``: its ``machines.csv`` (written by the Trainer
    since 2026-11-27), else a ``machine`` key of its config, else None."""
    return machine_summary(read_machines(run_dir), steps) or config.get("machine")


def _matches(config: dict[str, Any] | None, result: SeedResult) -> bool:
    return (config is not None and config.get("task") == result.task and config.get("algorithm") == result.algorithm
            and int(config.get("seed", -1)) == result.seed)


def find_budget(result: SeedResult, runs_dir: Path, results_dir: Path) -> Budget:
    """The budget of ``result``: from its run directory ``<runs>/<stem>`` (its config naming the same task, algorithm
    and seed), else from the log copy ``<results>/<stem>.csv``, else from the one run directory whose config matches
    and whose log reaches its steps (none or several: steps only)."""
    own = runs_dir / result.stem if result.stem else None
    if own is not None and _matches(read_config(own), result) and (own / "progress.csv").exists():
        config = read_config(own)
        return Budget(result.steps, _run_hours(own, config, result.steps),
                      result.machine or _machine(own, config, result.steps), own / "progress.csv")
    copy = results_dir / f"{result.stem}.csv" if result.stem else None
    if copy is not None and copy.exists():
        rows = read_progress(copy)
        hours = training_hours(rows, result.steps) if rows and rows[0].get("epoch") == 1 else None
        return Budget(result.steps, hours, result.machine, copy)
    found = []
    for run_dir in sorted(p for p in runs_dir.glob("*") if p.is_dir()) if runs_dir.is_dir() else []:
        config = read_config(run_dir)
        if _matches(config, result) and (run_dir / "progress.csv").exists():
            hours = _run_hours(run_dir, config, result.steps)
            if hours is not None:
                found.append(Budget(result.steps, hours, result.machine or _machine(run_dir, config, result.steps),
                                    run_dir / "progress.csv"))
    return found[0] if len(found) == 1 else Budget(result.steps, None, result.machine)


@dataclass(frozen=True)
class TrainingRun:
    """A run directory: what it trains and how far its log goes (for cells trained but not yet evaluated)."""

    task: str
    algorithm: str
    seed: int
    budget: Budget
    directory: str
    control: str | None = None  # as its config names it (None: the task's default)
    planned_steps: int | None = None  # its config's train.n_steps (None where the config does not say)

    @property
    def unfinished(self) -> bool:
        """Whether the log stops short of the run's planned steps (a run in progress, or parked to continue)."""
        return self.planned_steps is not None and self.budget.steps < self.planned_steps


def training_runs(runs_dir: Path) -> list[TrainingRun]:
    """Every run directory under ``runs_dir`` with a config and a non-empty log, sorted by name."""
    out = []
    for run_dir in sorted(p for p in runs_dir.glob("*") if p.is_dir()) if runs_dir.is_dir() else []:
        config = read_config(run_dir)
        if config is None or not (run_dir / "progress.csv").exists():
            continue
        rows = read_progress(run_dir / "progress.csv")
        if not rows:
            continue
        steps = int(rows[-1]["step"])
        budget = Budget(steps, _run_hours(run_dir, config, steps), _machine(run_dir, config, steps),
                        run_dir / "progress.csv")
        planned = (config.get("train") or {}).get("n_steps")
        out.append(TrainingRun(config["task"], config["algorithm"], int(config["seed"]), budget, run_dir.name,
                               (config.get("env") or {}).get("control"), int(planned) if planned else None))
    return out
