"""A sweep's trials and what each one's folder already holds: nothing, an interrupted run, or a finished one.

A trial is the run launch.py would start for one (task, algorithm, seed), in ``<out>/<task>/<algo>/seed<N>``.
Its folder decides what happens: a checkpoint that reached the requested steps is finished (skipped, nothing
is read but the checkpoint), one short of them is resumed with the Trainer's ``resume``, and an empty or
missing folder starts a new run. A folder whose run has another configuration (any value except
``train.n_steps`` and the torch threads, which a resume may change) is never touched: the trial is refused
with the keys that differ.

A run parked in git (``land_run.py --park``: ``results/runs/<task>_<algo>[_seed<N>]``) can seed an empty trial
folder, so that a fresh clone continues it (``sweep.py --from-parked``). A run already landed
(``land_run.py``: its export in ``pretrained/<task>/<algo>/seed<N>``) can be skipped (``sweep.py --skip-landed``).
"""

from __future__ import annotations

import csv
import json
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from baselines.config import RunConfig, flat_config
from baselines.training import CHECKPOINT, RUN_FILES, SNAPSHOTS, load_checkpoint, run_config_from_checkpoint
from experiments.land_run import PARKED_FILES
from experiments.launch import resolve_run, run_dir
from experiments.plot_results import output_stem
from experiments.sweep_spec import SweepSpec

# What a resume may change, so what a sweep re-run may differ in; ``sources`` are paths, not values.
NOT_COMPARED = ("train.n_steps", "train.snapshot_every", "agent.n_threads", "sources")
# A run killed before its first checkpoint leaves only these behind; it is started again from scratch.
UNSTARTED_FILES = ("config.yaml", "progress.csv", "tensorboard")


class RunDirConflict(ValueError):
    """A trial's folder holds a run that is not this trial's; it is left alone."""


@dataclass
class Trial:
    """One run of the sweep; ``run`` is launch.py's resolved configuration for it."""

    run: RunConfig
    out_dir: Path
    threads: int

    @property
    def key(self) -> str:
        return f"{self.run.task}/{self.run.algorithm}/seed{self.run.seed}"


@dataclass
class DirState:
    """What a trial's folder holds: ``new`` (nothing), ``unstarted`` (a run killed before its first
    checkpoint), ``resume`` (a checkpoint short of the steps) or ``finished``; ``steps`` already trained."""

    kind: str
    steps: int = 0


@dataclass
class Landed:
    """A trial's run as ``land_run.py`` exported it: the export folder, its card's steps and score, and the
    configuration values it differs in from the trial (empty: the same run)."""

    folder: Path
    steps: int
    score: float | None
    differences: list[str]


def make_trials(spec: SweepSpec, note: Any = None) -> list[Trial]:
    """Every (task, algorithm, seed) of ``spec.runs()`` with its resolved configuration; raises ``ConfigError`` or
    ``ValueError`` on the first that cannot be configured (nothing has started yet)."""
    trials = []
    for task, algo, seed in spec.runs():
        run = resolve_run(task, algo, seed=seed, steps=spec.steps, threads=spec.threads, overrides=spec.overrides,
                          note=note)
        trials.append(Trial(run=run, out_dir=run_dir(spec.out, task, algo, seed), threads=spec.threads))
    return trials


def inspect_run_dir(trial: Trial) -> DirState:
    """What ``trial``'s folder holds; raises :class:`RunDirConflict` if it holds another run (never changed)."""
    out = trial.out_dir
    if out.exists() and not out.is_dir():
        raise RunDirConflict(f"{out} is a file, not a run folder; move it away to run {trial.key}")
    checkpoint = out / CHECKPOINT
    if checkpoint.exists():
        try:
            state = load_checkpoint(checkpoint)
            saved = run_config_from_checkpoint(state)
        except (ValueError, KeyError, TypeError) as err:
            raise RunDirConflict(f"{trial.key}: {checkpoint} cannot be read ({err}); the sweep leaves it alone: "
                                 "move the folder away or choose another --out") from None
        _refuse_other_config(trial, saved.to_dict(), checkpoint)
        steps = int(state["steps"])
        return DirState("finished" if steps >= trial.run.train.n_steps else "resume", steps)
    found = _held_files(out)
    if not found:
        return DirState("new")
    if set(found) <= set(UNSTARTED_FILES) and (out / "config.yaml").exists() and not _has_rows(out / "progress.csv"):
        saved = _config_yaml(out / "config.yaml", trial)
        _refuse_other_config(trial, saved, out / "config.yaml")
        return DirState("unstarted")
    raise RunDirConflict(f"{trial.key}: {out} holds another run's files ({', '.join(found)}) but no checkpoint; "
                         "the sweep never overwrites a run: move the folder away or choose another --out")


def parked_source(trial: Trial, parked_root: Path) -> tuple[Path, int] | None:
    """The parked state of ``trial``'s run in ``parked_root/<task>_<algo>[_seed<N>]`` and its steps, where the
    trial's folder is still empty; None where it is not or nothing is parked. A parked run with another
    configuration raises :class:`RunDirConflict` (it is neither used nor changed)."""
    source = parked_root / output_stem(trial.run)
    if trial.out_dir.is_file() or _held_files(trial.out_dir) or not (source / CHECKPOINT).exists():
        return None  # a folder holding something is the sweep's plan to judge (its checkpoint is not read twice)
    try:
        state = load_checkpoint(source / CHECKPOINT)
        saved = run_config_from_checkpoint(state)
    except (ValueError, KeyError, TypeError) as err:
        raise RunDirConflict(f"{trial.key}: the parked {source / CHECKPOINT} cannot be read ({err})") from None
    diffs = config_differences(saved.to_dict(), trial.run.to_dict())
    if diffs:
        raise RunDirConflict(f"{trial.key}: the run parked in {source} has another configuration "
                             f"({first_differences(diffs)}); sweep without --from-parked to start this trial afresh")
    return source, int(state["steps"])


def landed_export(trial: Trial, pretrained_root: Path) -> Landed | None:
    """The export of ``trial``'s run in ``pretrained_root/<task>/<algo>/seed<N>`` where its card's steps reached the
    trial's, whatever its configuration (the differences are returned, for the sweep to show); None where there is
    none or it is shorter. An export whose card or config cannot be read raises :class:`RunDirConflict`."""
    folder = run_dir(pretrained_root, trial.run.task, trial.run.algorithm, trial.run.seed)  # exports share the layout
    if not (folder / "card.json").exists():
        return None
    try:
        card = json.loads((folder / "card.json").read_text())
        steps = int(card["steps"])
        score = (card.get("evaluation") or {}).get("score", {}).get("mean")
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as err:
        raise RunDirConflict(f"{trial.key}: {folder / 'card.json'} cannot be read ({err!r})") from None
    if steps < trial.run.train.n_steps:
        return None
    saved = _config_yaml(folder / "config.yaml", trial, advice="fix or remove that export, or sweep without "
                                                               "--skip-landed")
    return Landed(folder, steps, None if score is None else float(score),
                  config_differences(saved, trial.run.to_dict(), where="the export"))


def adopt_parked(trial: Trial, source: Path) -> None:
    """Copy the parked run in ``source`` (checkpoint, config, log, machines, snapshots) into ``trial``'s empty
    folder, which the sweep then resumes (an off-policy run's replay buffer is never parked: the Trainer collects
    a fresh warm-up)."""
    trial.out_dir.mkdir(parents=True, exist_ok=True)
    for name in PARKED_FILES:
        if (source / name).exists():
            shutil.copy2(source / name, trial.out_dir / name)
    if (source / SNAPSHOTS).is_dir():
        shutil.copytree(source / SNAPSHOTS, trial.out_dir / SNAPSHOTS)


def clear_unstarted(trial: Trial) -> None:
    """Remove what a run killed before its first checkpoint left (its config, empty log, TensorBoard folder)."""
    for name in UNSTARTED_FILES:
        path = trial.out_dir / name
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()


def config_differences(saved: dict[str, Any], wanted: dict[str, Any], where: str = "the folder") -> list[str]:
    """``key: saved in <where>, wanted in this sweep`` for every compared value where two ``RunConfig.to_dict()``
    differ."""
    a, b = flat_config(saved, NOT_COMPARED), flat_config(wanted, NOT_COMPARED)
    return [f"{key}: {a.get(key, '(unset)')!r} in {where}, {b.get(key, '(unset)')!r} in this sweep"
            for key in sorted(set(a) | set(b)) if a.get(key) != b.get(key)]


def last_score(out_dir: Path) -> float | None:
    """The normalised score of the last evaluation in ``out_dir/progress.csv`` (None without one)."""
    rows = _rows(out_dir / "progress.csv")
    try:
        return float(rows[-1]["score"]) if rows else None
    except (KeyError, ValueError):
        return None


def _refuse_other_config(trial: Trial, saved: dict[str, Any], where: Path) -> None:
    diffs = config_differences(saved, trial.run.to_dict())
    if diffs:
        raise RunDirConflict(f"{trial.key}: {where} is a run with another configuration ({first_differences(diffs)}). "
                             "The sweep never overwrites a run: choose another --out, or move that folder away to "
                             "rerun it")


def _held_files(out: Path) -> list[str]:
    """The run files (``RUN_FILES``) that folder ``out`` holds; none: a new trial's folder."""
    return [name for name in RUN_FILES if (out / name).exists()]


def first_differences(diffs: list[str], shown: int = 5) -> str:
    """The first ``shown`` of ``diffs`` joined by "; ", then how many more there are."""
    return "; ".join(diffs[:shown]) + (f"; and {len(diffs) - shown} more" if len(diffs) > shown else "")


def _config_yaml(path: Path, trial: Trial, advice: str = "the sweep leaves it alone: move the folder away or choose "
                                                           "another --out") -> dict[str, Any]:
    """A run folder's (or an export's) ``config.yaml`` as ``RunConfig.to_dict()`` (normalised like a checkpoint's);
    :class:`RunDirConflict` with ``advice`` where it cannot be read."""
    try:
        data = yaml.safe_load(path.read_text())
        data.pop("dataset", None)
        return run_config_from_checkpoint({"run_config": data}).to_dict()
    except (OSError, yaml.YAMLError, AttributeError, KeyError, TypeError, ValueError) as err:
        raise RunDirConflict(f"{trial.key}: {path} cannot be read ({err}); {advice}") from None


def _rows(path: Path) -> list[dict[str, str]]:
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _has_rows(path: Path) -> bool:
    return bool(_rows(path))
