"""The rows of the results table: the planned grid, which results fill each row, and the aggregates over tasks.

The grid (tasks, algorithms and each task's planned seeds) is the sweep file ``sweeps/table.yaml``, the one
that trains it, so rows and runs have one definition; a row with fewer seeds than planned says which are missing.

A row pools the per-episode normalised scores of all its training seeds (deterministic policy) and gives their
mean with the repository's studentized-bootstrap 95% interval (BCa where most values tie;
:func:`loco_mujoco.evaluation.intervals.mean_interval`, seeded as ``evaluate.py`` seeds it, so a one-seed row repeats
its evaluation file's intervals). One evaluation per
seed: where a seed has several (a run and its warm-started continuation), the one with the most training steps,
the others named in the notes. An agent trained on ``<task>.perfect`` data (evaluated on the real task) fills its
base task's row, marked "(perfect data)", unless the row has an agent trained on the real data. A row without any
says "not run", "in progress" where its run directories stop short of their planned steps (a run training, or
parked to continue), "not evaluated" where a run directory finished it, or "n/a: no expert actions" where its
committed config asks for derived expert actions (``train.expert_actions`` inverse_dynamics or auto, without
``agent.from_observations``), the task ships no ``.perfect`` dataset with actions, and inverse dynamics refuses the
model's actuators (muscles): read from the configs and the code, not listed here. A filled row whose score
interval reaches 0 (not shown to beat uniformly random actions) leads its notes with "did not learn", its figures kept.
"""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from baselines import is_offline
from experiments.critic_values import divergence_note, saturation_note
from experiments.sweep_spec import build_spec, read_sweep_file
from experiments.table_references import (
    committed_references,
    on_task_references,
    own_scores,
    references_key,
    task_references,
)
from experiments.table_sources import (
    Budget,
    SeedResult,
    TrainingRun,
    control_mode,
    find_budget,
    format_steps,
    read_card,
    read_config,
    read_evaluation,
    read_progress,
    replay_refills,
    training_runs,
)
from loco_mujoco.evaluation.aggregate import aggregate_iqm, performance_profile
from loco_mujoco.evaluation.intervals import iqm, mean_interval
from loco_mujoco.evaluation.protocol import SEED

if TYPE_CHECKING:
    from baselines.config import RunConfig

GRID_FILE = Path(__file__).resolve().parent.parent / "sweeps" / "table.yaml"
GRID = build_spec(read_sweep_file(GRID_FILE), {})
TASKS, ALGORITHMS = tuple(GRID.tasks), tuple(GRID.algos)
OK, NOT_RUN, NOT_EVALUATED, NO_ACTIONS = "ok", "not run", "not evaluated", "n/a: no expert actions"
IN_PROGRESS = "in progress"  # its runs stop short of their planned steps
DID_NOT_LEARN = "did not learn: its score's 95% interval reaches 0 (uniformly random actions)"
NAMES = {"gail": "GAIL", "vail": "VAIL", "gaifo": "GAIfO", "iq_learn": "IQ-Learn", "lsiq": "LS-IQ", "sqil": "SQIL",
         "bc": "BC"}


@functools.cache
def committed_config(task: str, algorithm: str, seed: int = 0) -> RunConfig:
    """The committed run config of ``task`` and ``algorithm`` (``launch.py --print-config``), read once per table:
    several columns and notes of a row compare against it. Read-only: the cached object is shared."""
    from baselines.config import load_run_config

    return load_run_config(task, algorithm, seed=seed)


def expert_actions_unavailable(task: str, algorithm: str) -> bool:
    """Whether ``algorithm`` on ``task`` cannot get the expert actions its committed config asks for: it asks for
    derived ones, the task has no ``.perfect`` dataset (which carries actions), and inverse dynamics refuses the
    model's actuators. Real motion capture never has actions (baselines.common.expert_data)."""
    from loco_mujoco.core.task_names import environment_class, parse_task_name

    run = committed_config(task, algorithm)
    if run.train.expert_actions == "dataset" or getattr(run.agent, "from_observations", False):
        return False
    parsed = parse_task_name(task)
    if "perfect" in environment_class(parsed.env).dataset_types_with_data(parsed.task, parsed.mode):
        return False
    return inverse_dynamics_refuses(task, run.env.get("control"), bool(run.env.get("disable_arms")))


@functools.cache
def inverse_dynamics_refuses(task: str, control: str | None, disable_arms: bool) -> bool:
    """Whether ``baselines.common.inverse_dynamics`` refuses the actuators of ``task``'s model in ``control`` mode
    (muscles: force not affine in the control); the model is compiled, no environment built."""
    from baselines.common.inverse_dynamics import _affine_actuators
    from loco_mujoco.core.embodiment_model import ModelChoice
    from loco_mujoco.core.task_names import environment_class, parse_task_name

    parsed = parse_task_name(task)
    cls = environment_class(parsed.env)
    model, _ = cls.compile_model(ModelChoice(parsed.task, parsed.mode, control or cls.DEFAULT_CONTROL, disable_arms))
    try:
        _affine_actuators(model)
    except ValueError:
        return True
    return False


@dataclass
class Inputs:
    """Every result read (evaluation files and cards), every run directory and the committed references."""

    results: list[SeedResult]
    runs: list[TrainingRun]
    references: dict[str, dict[str, Any]] = field(default_factory=dict)  # per task, results/references/<task>.json


def in_grid(result: SeedResult) -> bool:
    """Whether ``result`` belongs to a row: a grid task (real or perfect data) and a grid algorithm."""
    return result.base_task in TASKS and result.algorithm in ALGORITHMS and result.data in ("real", "perfect")


@dataclass
class Cell:
    """One row of the table."""

    task: str
    algorithm: str
    status: str
    control: str = "-"  # the control mode(s) its agents act in (or, not run, its committed config names)
    results: list[SeedResult] = field(default_factory=list)  # one per seed, pooled
    budgets: list[Budget] = field(default_factory=list)
    references: dict[str, Any] | None = None
    notes: list[str] = field(default_factory=list)
    figures: dict[str, Any] = field(default_factory=dict)
    planned_seeds: list[int] = field(default_factory=lambda: [0])  # the grid file's seeds for this task

    @property
    def seeds_text(self) -> str:
        """How many planned seeds the row pools, "k of n" where that is fewer than planned, then "+ m" for the
        pooled seeds the grid does not plan: "1 of 3", "3", "0 of 3 + 1"."""
        if not self.results:
            return "-"
        seeds = {r.seed for r in self.results}
        planned = len(self.planned_seeds)
        found = len(seeds & set(self.planned_seeds))
        text = f"{found} of {planned}" if found < planned else str(found)
        extra = len(seeds) - found
        return f"{text} + {extra}" if extra else text

    @property
    def data(self) -> str | None:
        return self.results[0].data if self.results else None


def collect(results_dir: Path, runs_dir: Path, pretrained_dir: Path | None) -> Inputs:
    """Evaluation files ``<results>/*_eval.json``, cards ``<pretrained>/*/*/seed*/card.json`` whose seed no evaluation
    file covers, run directories under ``runs_dir`` and the committed references ``<results>/references/``."""
    results = [read_evaluation(p) for p in sorted(results_dir.glob("*_eval.json"))]
    covered = {(r.task, r.algorithm, r.seed) for r in results}
    if pretrained_dir is not None:
        for path in sorted(pretrained_dir.glob("*/*/seed*/card.json")):
            if "evaluation" in json.loads(path.read_text()):
                card = read_card(path)
                if (card.task, card.algorithm, card.seed) not in covered:
                    results.append(card)
    return Inputs(results, training_runs(runs_dir), committed_references(results_dir))


def _one_per_seed(results: list[SeedResult], notes: list[str]) -> list[SeedResult]:
    """The result with the most training steps of each seed (episodes preferred to a card), sorted by seed."""
    chosen = []
    for seed in sorted({r.seed for r in results}):
        same = sorted((r for r in results if r.seed == seed), key=lambda r: (r.scores is None, -r.steps, r.source))
        chosen.append(same[0])
        for other in same[1:]:
            notes.append(f"seed {seed}: {other.source} ({format_steps(other.steps)}) superseded by {same[0].source} "
                         f"({format_steps(same[0].steps)})")
    return chosen


def build_cells(inputs: Inputs, results_dir: Path, runs_dir: Path) -> list[Cell]:
    """The 42 rows, their seeds pooled, budgets found and notes written."""
    refs_of_task = task_references(inputs.results, inputs.references)
    by_cell: dict[tuple[str, str], list[SeedResult]] = {}
    for r in filter(in_grid, inputs.results):
        r = on_task_references(r, refs_of_task.get(r.base_task))
        by_cell.setdefault((r.base_task, r.algorithm), []).append(r)
    cells = []
    for task in TASKS:
        for algo in ALGORITHMS:
            cell = Cell(task, algo, NOT_RUN, references=refs_of_task.get(task), planned_seeds=GRID.seeds_of(task))
            found = by_cell.get((task, algo), [])
            real = [r for r in found if r.data == "real"]
            chosen = real or found
            if real and len(real) < len(found):
                cell.notes.append("perfect-data evaluations not pooled: "
                                  + ", ".join(r.source for r in found if r.data != "real"))
            if chosen:
                _fill(cell, _one_per_seed(chosen, cell.notes), results_dir, runs_dir, refs_of_task.get(task))
                if did_not_learn(cell):
                    cell.notes.insert(0, DID_NOT_LEARN)
                _note_seeds(cell)
            else:
                _empty(cell, inputs.runs)
            cells.append(cell)
    return cells


def _note_seeds(cell: Cell) -> None:
    """Name the planned seeds the row has no evaluation of, and the pooled seeds the grid does not plan."""
    found, planned = [r.seed for r in cell.results], cell.planned_seeds
    listed = ", ".join(map(str, planned))
    missing = [s for s in planned if s not in found]
    extra = [s for s in found if s not in planned]
    if missing:
        cell.notes.append(f"seed{'s' * (len(missing) > 1)} {', '.join(map(str, missing))} of the planned {listed} "
                          f"not evaluated yet")
    if extra:
        cell.notes.append(f"seed{'s' * (len(extra) > 1)} {', '.join(map(str, extra))} outside the planned {listed}")


def did_not_learn(cell: Cell) -> bool:
    """Whether a filled row is not shown to beat uniformly random actions: its score interval's lower end <= 0."""
    lo = cell.figures.get("score_ci", (math.nan,))[0]
    return cell.status == OK and (lo is None or not math.isfinite(lo) or lo <= 0.0)


def _empty(cell: Cell, runs: list[TrainingRun]) -> None:
    """A row without an evaluation: a run in progress, n/a or not run."""
    mine = [r for r in runs if r.algorithm == cell.algorithm and r.task in (cell.task, f"{cell.task}.perfect")]
    cell.control = _modes([(r.task, r.control) for r in mine] or [(cell.task, committed_control(cell))])
    if mine:
        cell.status = IN_PROGRESS if all(r.unfinished for r in mine) else NOT_EVALUATED
        cell.budgets = [r.budget for r in mine]
        for r in mine:
            data = " (perfect data)" if r.task.endswith(".perfect") else ""
            where = (f"at {format_steps(r.budget.steps)} of {format_steps(r.planned_steps)}" if r.unfinished
                     else f"at {format_steps(r.budget.steps)}")
            cell.notes.append(f"seed {r.seed}{data}: {r.directory} {where}, no evaluation file")
        _note_critic(cell, [r.budget for r in mine])
    elif expert_actions_unavailable(cell.task, cell.algorithm):
        cell.status = NO_ACTIONS


def _note_critic(cell: Cell, budgets: list[Budget]) -> None:
    """A "critic diverged" note per seed whose training log passed its critic's bound, a "critic saturated" note
    per seed whose log ends with the agent's states at the critic's floor (:mod:`experiments.critic_values`), and a
    "resumed without its replay buffer" note per seed whose log shows a refilled buffer; the config beside the log
    (a run directory's), else the committed one."""
    for budget in budgets:
        if budget.log_path is None:
            continue
        config = read_config(budget.log_path.parent)
        if config is None:
            committed = committed_config(cell.task, cell.algorithm)
            config = {"env": committed.env, "agent": committed.agent.to_dict()}
        for note in (divergence_note(cell.algorithm, config, budget.log_path),
                     saturation_note(cell.algorithm, config, budget.log_path), _refill_note(budget.log_path)):
            if note:
                cell.notes.append(f"{note}; {budget.log}" if len(budgets) > 1 else note)


def _refill_note(log: Path) -> str | None:
    """"resumed without its replay buffer at ..." where an off-policy log shows the buffer refilled after a resume
    (:func:`~experiments.table_sources.replay_refills`): those updates drew on the policy's latest transitions only,
    so the run is not the uninterrupted one its seed would give."""
    refills = replay_refills(read_progress(log)) if log.exists() else []
    if not refills:
        return None
    where = ", ".join(f"{format_steps(step)} ({size:,} transitions at the next row, not {before + size:,})"
                      for step, size, before in refills)
    return f"resumed without its replay buffer at {where}"


# Values a row's runs may differ in from the committed config without the note below: the budget (its own column),
# threads, paths, a continued run's origin, and the control mode (its own column and note).
UNREPORTED = ("seed", "sources", "init_from", "env.control", "train.n_steps", "train.snapshot_every",
              "train.env_threads", "agent.n_threads")


def config_changes(result: SeedResult, run_dir: Path) -> list[str]:
    """``key value (committed: value)`` for each value the run in ``run_dir`` was trained with that the committed
    config of its task and algorithm no longer asks for."""
    from baselines.config import flat_config
    from baselines.training import run_config_from_directory

    trained = flat_config(run_config_from_directory(run_dir).to_dict(), UNREPORTED)
    committed = flat_config(committed_config(result.task, result.algorithm, seed=result.seed).to_dict(), UNREPORTED)
    return [f"{key} {trained.get(key, '(unset)')} (committed: {committed.get(key, '(unset)')})"
            for key in sorted(set(trained) | set(committed)) if trained.get(key) != committed.get(key)]


def _note_config_changes(cell: Cell, results: list[SeedResult], budgets: list[Budget]) -> None:
    """A note per seed whose run (the folder of its training log) was configured otherwise than the committed
    config now is, e.g. trained before a default changed."""
    for result, budget in zip(results, budgets, strict=True):
        if budget.log_path is None:
            continue
        changes = config_changes(result, budget.log_path.parent)
        if changes:
            seed = f"seed {result.seed} " if len(results) > 1 else ""
            cell.notes.append(f"{seed}trained with {'; '.join(changes)}")


def _note_short_budgets(cell: Cell, results: list[SeedResult], budgets: list[Budget]) -> None:
    """A note per seed trained for fewer steps than the table's budget for its family (the committed config's
    ``train.n_steps``, which the sweep trains each trial for): such a row does not yet meet the table's budget."""
    budget = committed_config(cell.task, cell.algorithm).train.n_steps
    unit = "gradient" if is_offline(cell.algorithm) else "env"
    for result, used in zip(results, budgets, strict=True):
        if used.steps < budget:
            seed = f"seed {result.seed} " if len(results) > 1 else ""
            cell.notes.append(f"{seed}trained {format_steps(used.steps)} of the table's {format_steps(budget)} "
                              f"{unit} steps")


def committed_control(cell: Cell) -> str | None:
    """The control that the committed config of the row's task and algorithm names (None: the task's default)."""
    return committed_config(cell.task, cell.algorithm).env.get("control")


def _modes(named: list[tuple[str, str | None]]) -> str:
    """The distinct control modes of (task, control as named) pairs, sorted and joined by '/'."""
    return "/".join(sorted({control_mode(task, control) for task, control in named}))


def _pooled_mean(values: list[np.ndarray]) -> float | None:
    x = np.concatenate(values) if values else np.array([])
    x = x[np.isfinite(x)]
    return float(x.mean()) if x.size else None


def _fill(cell: Cell, results: list[SeedResult], results_dir: Path, runs_dir: Path,
          task_refs: dict[str, Any] | None) -> None:
    """Pool the seeds of a row: score, R, L, metrics, budget, references."""
    cell.status = OK
    episodes = [r for r in results if r.scores is not None]
    if len(episodes) < len(results) and (episodes or len(results) > 1):
        kept = episodes or results[:1]
        cell.notes.append("cards hold no episodes to pool; left out: "
                          + ", ".join(r.source for r in results if r not in kept))
        results = kept
    cell.results = results
    cell.control = _modes([(r.task, r.control) for r in results])
    committed = _modes([(cell.task, committed_control(cell))])
    if cell.control != committed:
        cell.notes.append(f"trained in {cell.control} control; the committed config now asks for {committed}")
    cell.budgets = [find_budget(r, runs_dir, results_dir) for r in results]
    _note_short_budgets(cell, results, cell.budgets)
    _note_config_changes(cell, results, cell.budgets)
    _note_critic(cell, cell.budgets)
    if results[0].data == "perfect":
        cell.notes.insert(0, "(perfect data)")
    refs = {references_key(r.references) for r in results if r.references is not None}
    if refs:
        cell.references = json.loads(sorted(refs)[0])
        if len(refs) > 1:
            cell.notes.append("seeds scored against different references (each its own)")
        if task_refs is not None and cell.references != task_refs:
            own, other = cell.references, task_refs
            what = ("settings {env_settings} (expert R {expert_return:.1f})" if own["env_settings"] !=
                    other["env_settings"] else "dataset {dataset_digest} (expert R {expert_return:.1f})")
            cell.notes.append(f"references of {what.format(**own)}; the task's: {what.format(**other)}")
    f = cell.figures
    if not episodes:  # one card: its summaries as they are
        card = results[0].card_summary
        f.update(score=card["score"]["mean"], score_ci=tuple(card["score"]["ci95"]), score_iqm=card["score"]["iqm"],
                 R=card["R"]["mean"], R_ci=tuple(card["R"]["ci95"]), L=card["L"]["mean"], L_ci=tuple(card["L"]["ci95"]),
                 episodes=int(card["score"]["n"]))
        cell.notes.append(f"card summary only ({results[0].source})")
        return
    scores = np.concatenate([r.scores for r in results])
    returns = np.concatenate([r.returns for r in results])
    lengths = np.concatenate([r.lengths for r in results])
    # the seeds evaluate.py uses (score: the protocol's, R and L: 0), so a one-seed row scored against its file's
    # references repeats the file's intervals
    f.update(score=float(scores.mean()), score_ci=mean_interval(scores, seed=SEED), score_iqm=iqm(scores),
             R=float(returns.mean()), R_ci=mean_interval(returns), L=float(lengths.mean()), L_ci=mean_interval(lengths),
             episodes=int(scores.size), score_own=float(np.concatenate([own_scores(r) for r in results]).mean()))
    for name in ("gait_deviation", "dtw_joints", "dtw_sites"):
        f[name] = _pooled_mean([r.episode_metrics[name] for r in results if name in r.episode_metrics])
    auc = [r.evaluation_metrics["classifier_auc"] for r in results if "classifier_auc" in r.evaluation_metrics]
    f["classifier_auc"] = float(np.mean(auc)) if auc else None


def aggregates(cells: list[Cell]) -> dict[str, dict[str, Any]]:
    """Per algorithm with at least one row of per-episode scores: the IQM over its tasks and its profile."""
    rows = {a: [c for c in cells if c.algorithm == a and c.status == OK
                and all(r.scores is not None for r in c.results)] for a in ALGORITHMS}
    scores = {a: [[r.scores for r in c.results] for c in rows[a]] for a in ALGORITHMS if rows[a]}
    if not scores:
        return {}
    run_means = [x.mean() for s in scores.values() for task in s for x in task]
    lo = min(0.0, 10.0 * math.floor(min(run_means) / 10.0))
    hi = max(10.0, 10.0 * math.ceil(max(run_means) / 10.0 + 0.5))
    taus = np.linspace(lo, hi, int(round((hi - lo) * 4)) + 1)
    out = {}
    for algo, s in scores.items():
        out[algo] = {**aggregate_iqm(s, seed=SEED), "profile": performance_profile(s, taus, seed=SEED),
                     "task_names": [c.task + (" (perfect data)" if c.data == "perfect" else "") for c in rows[algo]]}
    return out
