"""The reported results table, generated from evaluation files, pretrained cards and training logs.

    python experiments/results_table.py [--results results] [--runs results/runs] [--out results] [--force]

Writes ``table.md``, ``table.csv`` and ``performance_profile.png`` into ``--out``; an existing one is replaced
only with ``--force``. Same inputs give byte-identical files (every bootstrap seeded, no dates, no absolute paths).

One row per task and algorithm of the planned grid (``sweeps/table.yaml``: 6 tasks x 7 algorithms and
each task's seeds), its seeds pooled episode by episode (:mod:`experiments.table_cells` says how rows are filled
and when a row is "not run", "in progress", "not evaluated" or "n/a"; the inputs are read by
:mod:`experiments.table_sources`). Below the table, per algorithm over the tasks it has: the IQM of run scores with
a 95% stratified-bootstrap interval, and the performance profile (fraction of runs with score > tau) with its band,
from :mod:`loco_mujoco.evaluation.aggregate` (numpy, because rliable 1.2.0 pins ``arch<8``).
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import math
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from tqdm import tqdm  # noqa: E402

from baselines import is_offline  # noqa: E402
from experiments.table_cells import (  # noqa: E402
    ALGORITHMS,
    NAMES,
    OK,
    TASKS,
    Cell,
    Inputs,
    aggregates,
    build_cells,
    collect,
    committed_config,
    in_grid,
)
from experiments.table_references import references_file  # noqa: E402
from experiments.table_sources import format_steps  # noqa: E402
from loco_mujoco.evaluation.intervals import BOOTSTRAP_REPS  # noqa: E402

OUTPUTS = ("table.md", "table.csv", "performance_profile.png")


def _num(x: float | None, digits: int) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{digits}f}"


def _range(values: list[Any], fmt: Callable[[Any], str]) -> str:
    """One value, or the lowest-highest over seeds; ' (some -)' where some seeds have none."""
    known = sorted({v for v in values if v is not None})
    if not known:
        return "-"
    text = fmt(known[0]) if len(known) == 1 else f"{fmt(known[0])}-{fmt(known[-1])}"
    return text + (" (some -)" if None in values else "")


def budget_text(cell: Cell) -> tuple[str, str]:
    """Steps per seed (env or gradient) and training hours per seed, '-' where unknown."""
    if not cell.budgets:
        return "-", "-"
    unit = "grad" if is_offline(cell.algorithm) else "env"
    return (f"{_range([b.steps for b in cell.budgets], format_steps)} {unit}",
            _range([b.hours for b in cell.budgets], _hours))


def _hours(h: float) -> str:
    return f"{h:.1f}" if h >= 1.0 else f"{h:.2g}"


def score_text(cell: Cell) -> str:
    if cell.status != OK:
        return cell.status
    lo, hi = cell.figures["score_ci"]
    return f"**{cell.figures['score']:.1f}** [{_num(lo, 1)}, {_num(hi, 1)}]"


def _machines(cell: Cell) -> str:
    return "; ".join(sorted({b.machine for b in cell.budgets if b.machine}))


def plot_profile(agg: dict[str, dict[str, Any]], path: Path) -> None:
    """Fraction of runs with score > tau against tau, one line and 95% band per algorithm."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    colors = dict(zip(ALGORITHMS, plt.get_cmap("tab10").colors, strict=False))
    for algo, a in agg.items():
        p = a["profile"]
        perfect = sum("(perfect data)" in t for t in a["task_names"])
        label = (f"{NAMES[algo]} ({a['tasks']} task{'s' * (a['tasks'] != 1)}, {a['runs']} run{'s' * (a['runs'] != 1)}"
                 + (f"; {perfect} on perfect data" if perfect else "") + ")")
        ax.plot(p["tau"], p["fraction"], color=colors[algo], label=label, drawstyle="steps-post")
        ax.fill_between(p["tau"], p["lo"], p["hi"], color=colors[algo], alpha=0.2, step="post", linewidth=0)
    ax.set_xlabel(r"normalised score $\tau$ (random 0, expert 100)")
    ax.set_ylabel(r"fraction of runs with score > $\tau$")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Performance profile over the tasks each algorithm has (95% stratified-bootstrap bands)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120, metadata={"Software": None})
    plt.close(fig)


# ---- outputs -----------------------------------------------------------------------------------------------------

CSV_COLUMNS = ("task", "algorithm", "status", "data", "control", "score_mean", "score_ci_low", "score_ci_high",
               "score_iqm", "seeds", "seeds_planned", "episodes", "R_mean", "R_ci_low", "R_ci_high", "L_mean",
               "L_ci_low", "L_ci_high", "gait_deviation", "dtw_joints_rad", "dtw_sites_m", "classifier_auc",
               "steps_per_seed", "step_unit", "train_hours_per_seed", "machine", "random_R", "hold_pose_R",
               "zero_action_R", "expert_R", "random_R_se", "random_episodes", "references_dataset",
               "score_mean_own_references", "sources", "notes")


def _csv_number(x: float | None) -> str:
    return "" if x is None or not math.isfinite(x) else f"{x:.6g}"


def render_csv(cells: list[Cell]) -> str:
    """One line per row, numbers to 6 significant digits, empty where there is none."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for c in cells:
        f, refs = c.figures, c.references or {}
        ci = {k: f.get(f"{k}_ci", (None, None)) for k in ("score", "R", "L")}
        w.writerow([c.task, c.algorithm, c.status, c.data or "", c.control, _csv_number(f.get("score")),
                    _csv_number(ci["score"][0]), _csv_number(ci["score"][1]), _csv_number(f.get("score_iqm")),
                    len(c.results) or "", len(c.planned_seeds), f.get("episodes", ""), _csv_number(f.get("R")),
                    _csv_number(ci["R"][0]), _csv_number(ci["R"][1]), _csv_number(f.get("L")),
                    _csv_number(ci["L"][0]), _csv_number(ci["L"][1]),
                    _csv_number(f.get("gait_deviation")), _csv_number(f.get("dtw_joints")),
                    _csv_number(f.get("dtw_sites")), _csv_number(f.get("classifier_auc")),
                    ";".join(str(b.steps) for b in c.budgets),
                    ("gradient" if is_offline(c.algorithm) else "environment") if c.budgets else "",
                    ";".join(_csv_number(b.hours) for b in c.budgets), _machines(c),
                    _csv_number(refs.get("random_return")), _csv_number(refs.get("hold_return")),
                    _csv_number(refs.get("zero_return")), _csv_number(refs.get("expert_return")),
                    _csv_number(refs.get("random_return_se")), refs.get("random_episodes") or "",
                    refs.get("dataset_digest", ""), _csv_number(f.get("score_own")),
                    ";".join(r.source for r in c.results), "; ".join(c.notes)])
    return buf.getvalue()


FAMILY_NAMES = {"adversarial": "on-policy (GAIL, VAIL, GAIfO)", "offpolicy": "off-policy (IQ-Learn, LS-IQ, SQIL)",
                "offline": "offline (BC)"}


def compute_cost(cells: list[Cell]) -> dict[str, dict[str, Any]]:
    """Per algorithm family, what training the rows' seeds cost: runs, steps and logged hours (learning time, one
    CPU core and one torch thread each); ``unlogged`` counts the runs whose log gives no hours."""
    from baselines import ALGORITHMS as CLASSES

    cost: dict[str, dict[str, Any]] = {}
    for c in cells:
        family = CLASSES[c.algorithm].family
        for b in c.budgets:
            f = cost.setdefault(family, {"runs": 0, "steps": 0, "hours": 0.0, "unlogged": 0})
            f["runs"] += 1
            f["steps"] += int(b.steps)
            if b.hours is None or not math.isfinite(b.hours):
                f["unlogged"] += 1
            else:
                f["hours"] += float(b.hours)
    return {k: cost[k] for k in FAMILY_NAMES if k in cost}


def compute_lines(cells: list[Cell]) -> list[str]:
    """The table's "Compute" section: its cost per algorithm family and in all."""
    cost = compute_cost(cells)
    lines = ["## Compute", "",
             "What the runs behind the rows above (evaluated or not) cost to train, from their logs: learning time on "
             "one CPU core with one torch thread each, without the per-epoch evaluations; the machines were shared, "
             "so hours are upper bounds for an idle core.", "",
             "| family | runs | steps | hours | runs without logged hours |", "|---|---|---|---|---|"]
    for family, f in cost.items():
        unit = "grad" if family == "offline" else "env"
        lines.append(f"| {FAMILY_NAMES[family]} | {f['runs']} | {format_steps(f['steps'])} {unit} | {f['hours']:.1f} | "
                     f"{f['unlogged']} |")
    total = sum(f["hours"] for f in cost.values())
    lines += ["", f"In all: {sum(f['runs'] for f in cost.values())} runs, {total:.1f} core-hours of learning.", ""]
    return lines


def family_budgets() -> str:
    """The table's budget per algorithm family, as the committed configs of the grid's first task set them."""
    families = (("on-policy", "vail"), ("off-policy", "sqil"), ("BC", "bc"))
    return ", ".join(f"{name} {format_steps(committed_config(TASKS[0], algo).train.n_steps)} "
                     f"{'gradient' if is_offline(algo) else 'env'} steps" for name, algo in families)


def render_markdown(cells: list[Cell], agg: dict[str, dict[str, Any]], inputs: Inputs) -> str:
    """The table, the aggregate and where every figure came from."""
    filled = sum(c.status == OK for c in cells)
    lines = [
        "# Results table",
        "",
        "Generated by `python experiments/results_table.py --force` from the evaluation files `results/*_eval.json`, "
        "the pretrained cards and the training logs under `results/runs/`; do not edit by hand. "
        f"{len(cells)} rows ({len(TASKS)} tasks x {len(ALGORITHMS)} algorithms), {filled} with an evaluation.",
        "",
        "- **control**: what the agent's actions command: `pd` joint-position targets through the embodiment's PD "
        "gains, `torque` motor torques, `muscle` muscle excitations; for a row not run yet, what its committed "
        "config asks for (`launch.py --print-config`). The random and hold references are measured in the row's "
        "mode, so rows of one task in different modes compare by normalised score only.",
        "- **score**: normalised (0 = uniformly random policy, 100 = expert), deterministic policy, mean with a 95% "
        "studentized-bootstrap interval over the per-episode scores of all seeds pooled (50 episodes per seed); "
        "BCa where 60% or more of the values tie, as episode lengths at the horizon do. A row is evaluated on its "
        "exported policy, the pretrained agent (`evaluate.py --pretrained TASK ALGO [SEED]` repeats its figures and "
        "its card carries them), except rows without an export, which evaluated their training checkpoint "
        "(the same policy up to float rounding).",
        "- **seeds**: the training seeds pooled; \"k of n\" where k of the n seeds the grid plans have an evaluation "
        "(`sweeps/table.yaml`, the sweep file that trains every row: `python experiments/sweep.py --config "
        "sweeps/table.yaml`), \"+ m\" for m pooled seeds it does not plan.",
        "- **R**, **L**: mean return and episode length over the same episodes.",
        "- **gait dev.**: the mean relative deviation of eight gait metrics from the expert's over the same frames "
        "(each capped at 1; 0 = the expert's gait); **DTW joints** (rad) and **DTW sites** (m, pelvis height and "
        "feet relative to the pelvis): distances to the dataset frames that follow each episode's start (0 = the "
        "expert); all three per-episode means pooled over seeds. **AUC**: a linear classifier's cross-validated "
        "AUC between the agent's and the dataset's kinematic states (0.5 = indistinguishable; the dataset against "
        "itself gives about 0.55), averaged over seeds.",
        "- **budget**: training steps per seed, environment steps (env) or, for BC, gradient steps (grad); "
        "**hours**: per seed, the sum over logged epochs of the epoch's steps over its logged `train_steps_per_s` "
        "(learning only: without the per-epoch evaluation and checkpoint; the runs shared their CPUs with others), "
        "'-' where no complete log is found; **machine**: the processor model, its widest vector instructions "
        "(recorded since 2026-11-28: virtual machines show one model name for processors 3.5-4x apart, AVX-512 "
        "against AVX2; and since 2026-12-02 the x86 family and model, which separate Zen 4 (family 25) from Zen 5 "
        "(family 26), 2.4x apart in matrix products) and CPU count that trained each stretch of the run, from the "
        "run's `machines.csv` (written "
        "at every start and resume since 2026-11-27; '-' for older runs).",
        "- **random / hold / expert R**: the returns of the task's references (uniformly random actions, a "
        "controller holding the home pose, the expert's dataset frames) that the row's scores are normalised by: one "
        "set per task, `results/references/<task>.json`, measured under the task's committed env settings with "
        "1,000 random-action episodes (random R's standard error 0.2-0.7; `python experiments/results_table.py "
        "--measure-references`). Each evaluation is rescored with them from its per-episode returns where its own "
        "references were measured on the same data and settings (expert and stand-still R equal within 1e-6): "
        "evaluation files before 2026-11-30 used 50 random episodes (random R within +-2-3 of its mean), and a "
        "machine whose BLAS kernels round otherwise builds the same dataset with other last bits (another digest). "
        "The CSV keeps each row's score under its files' own references (`score_mean_own_references`); a row "
        "whose references differ otherwise keeps them and its notes say so.",
        "- **notes**: a row whose score interval reaches 0 (not shown to beat uniformly random actions) begins with "
        "\"did not learn\", its figures kept; an off-policy row whose critics' values passed 1.25x the range its "
        "rewards allow says \"critic diverged\", and one whose training ended with the critic valuing the agent's own "
        "states within 5% of the lowest value its targets allow (0 for SQIL, -200 for LS-IQ) says \"critic "
        "saturated\" (experiments/critic_values.py); one whose run was continued on a fresh machine from its "
        "committed state, which keeps no replay buffer, says \"resumed without its replay buffer\" and where (the "
        "updates after it drew on a refilled buffer of the latest policy's transitions: not the run an uninterrupted "
        f"seed gives); a seed trained for fewer steps than its family's budget ({family_budgets()}: the committed "
        "`train.n_steps` the sweep trains) says \"trained N of the table's M\" (the row does not meet the table's "
        "budget yet); a row whose run was configured "
        "otherwise than the committed config now is (trained before a default changed) says \"trained with\" and "
        "each such value beside today's (budget, threads and control mode aside: they have their own columns); then "
        "which data, evaluations and runs the row rests on.",
        "",
        "| task | algorithm | control | score [95% CI] | seeds | R | L | gait dev. | DTW joints | DTW sites | AUC | "
        "budget | hours | machine | random R | hold R | expert R | notes |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cells:
        f, refs = c.figures, c.references or {}
        steps, hours = budget_text(c)
        lines.append("| " + " | ".join([
            c.task, NAMES[c.algorithm], c.control, score_text(c), c.seeds_text,
            _num(f.get("R"), 1), _num(f.get("L"), 0), _num(f.get("gait_deviation"), 2), _num(f.get("dtw_joints"), 2),
            _num(f.get("dtw_sites"), 2), _num(f.get("classifier_auc"), 3), steps, hours, _machines(c) or "-",
            _num(refs.get("random_return"), 1), _num(refs.get("hold_return"), 1), _num(refs.get("expert_return"), 1),
            "; ".join(c.notes)]) + " |")
    lines += ["", "## Aggregate over tasks", "",
              "Per algorithm, over the rows it has: the interquartile mean (IQM) of run scores (a run: one seed's "
              "mean normalised score on one task) with a 95% percentile interval from a stratified bootstrap "
              f"({BOOTSTRAP_REPS} replicates: every task kept, its seeds and each seed's episodes "
              "resampled). Most rows are not run yet, so each algorithm's figure covers only the tasks listed; "
              "figures over different task sets do not compare.", "",
              "| algorithm | tasks | runs | IQM [95% CI] | tasks covered |", "|---|---|---|---|---|"]
    for algo, a in agg.items():
        lo, hi = a["ci95"]
        lines.append(f"| {NAMES[algo]} | {a['tasks']} | {a['runs']} | **{a['iqm']:.1f}** [{lo:.1f}, {hi:.1f}] | "
                     f"{', '.join(a['task_names'])} |")
    none = [NAMES[a] for a in ALGORITHMS if a not in agg]
    lines += ["", f"No evaluated row: {', '.join(none) or 'none'}.", "",
              "![performance profile](performance_profile.png)", "",
              "Performance profile: the fraction of runs (each task weighted equally) whose score exceeds tau, with "
              "its 95% stratified-bootstrap band; rliable's figure, drawn with numpy "
              "(`loco_mujoco/evaluation/aggregate.py`) because rliable 1.2.0 pins `arch<8`.", "",
              *compute_lines(cells), "## Sources", ""]
    for c in cells:
        if c.results:
            logs = ", ".join(b.log or "no training log" for b in c.budgets)
            lines.append(f"- {c.task} {NAMES[c.algorithm]}: " + ", ".join(
                f"seed {r.seed} {r.source} ({format_steps(r.steps)})" for r in c.results) + f"; budget from {logs}")
    outside = sorted(f"{r.source} ({r.task}, {r.algorithm})" for r in inputs.results if not in_grid(r))
    if outside:
        lines += ["", "Read but outside the grid: " + ", ".join(outside) + "."]
    return "\n".join(lines) + "\n"


def task_env_settings(task: str) -> dict[str, Any]:
    """The env settings that the committed configs of all grid algorithms give ``task`` (one set per embodiment:
    ``configs/defaults.yaml`` embodiments), under which its references are measured."""
    found = {json.dumps(committed_config(task, a).env, sort_keys=True) for a in ALGORITHMS}
    if len(found) != 1:
        raise ValueError(f"the committed configs of {task} give {len(found)} sets of env settings ({sorted(found)}): "
                         "one set of references cannot serve its rows")
    return json.loads(found.pop())


def measure_references(results_dir: Path, force: bool) -> int:
    """Measure each grid task's references under its committed settings (the protocol's random episodes; cached
    per machine) and write ``<results>/references/<task>.json``; a file with other content is replaced only with
    ``force``."""
    from dataclasses import asdict

    from loco_mujoco.evaluation.references import references

    written = []
    for task in tqdm(TASKS, desc="references", unit="task"):
        text = json.dumps(asdict(references(task, task_env_settings(task), progress=True)), indent=1,
                          sort_keys=True) + "\n"
        path = references_file(results_dir, task)
        if path.exists() and path.read_text() != text and not force:
            print(f"error: {path} holds other references; pass --force to replace it", file=sys.stderr)
            return 2
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
        written.append(str(path))
    print(f"wrote {', '.join(written)}")
    return 0


def main(argv: list[str] | None = None) -> int:
    from loco_mujoco.agent_datasets import pretrained_root

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--results", default="results", help="folder of the evaluation files *_eval.json")
    parser.add_argument("--runs", default="results/runs", help="folder of run directories (config.yaml, progress.csv)")
    parser.add_argument("--pretrained", default=None,
                        help="folder of pretrained agents whose cards fill seeds without an evaluation file "
                             "(default: the repository's pretrained/; 'none' to leave cards out)")
    parser.add_argument("--out", default="results", help="folder of table.md, table.csv and performance_profile.png")
    parser.add_argument("--force", action="store_true", help="replace existing outputs")
    parser.add_argument("--measure-references", action="store_true",
                        help="measure every task's references under its committed settings into "
                             "<results>/references/<task>.json (the table's normalisation), then stop")
    args = parser.parse_args(argv)
    results_dir, runs_dir, out = Path(args.results), Path(args.runs), Path(args.out)
    if not results_dir.is_dir():
        print(f"error: --results {results_dir} is not a folder", file=sys.stderr)
        return 2
    if args.measure_references:
        return measure_references(results_dir, args.force)
    existing = [str(out / name) for name in OUTPUTS if (out / name).exists()]
    if existing and not args.force:
        print(f"error: {', '.join(existing)} exist; pass --force to replace them, or --out another folder",
              file=sys.stderr)
        return 2
    pretrained = None if args.pretrained == "none" else Path(args.pretrained or pretrained_root())
    try:
        inputs = collect(results_dir, runs_dir, pretrained)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    cells = build_cells(inputs, results_dir, runs_dir)
    agg = aggregates(cells)
    out.mkdir(parents=True, exist_ok=True)
    (out / "table.md").write_text(render_markdown(cells, agg, inputs))
    (out / "table.csv").write_text(render_csv(cells))
    plot_profile(agg, out / "performance_profile.png")
    filled = sum(c.status == OK for c in cells)
    print(f"{len(cells)} rows, {filled} evaluated; wrote {', '.join(str(out / n) for n in OUTPUTS)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
