"""Bring a trained run into the repository: ``python experiments/land_run.py RUN_DIR [--park]``.

A finished run (its checkpoint reached ``train.n_steps``) lands as what the table and users read:

- ``results/runs/<name>/``: its config, log and machines (a parked checkpoint of the same run there is removed);
- ``results/<name>_eval.json``: the evaluation of its export under the protocol (deterministic and stochastic
  policy, imitation metrics), as ``evaluate.py --pretrained EXPORT --metrics --stochastic --json`` writes it;
- ``results/<name>.csv``, ``.png``, ``_references.json``: its learning curve (``plot_results.py``);
- ``pretrained/<task>/<algo>/seed<N>/``: its policy export, whose card carries that same evaluation;
- ``results/table.md``, ``table.csv``, ``performance_profile.png``: regenerated.

An unfinished run is parked with ``--park``: its resumable state (checkpoint, config, log, machines; never a
replay buffer; its policy snapshots with ``--snapshots``) goes into ``results/runs/<name>/``, so that a fresh
machine continues it with ``sweep.py --tasks TASK --algos ALGO --seeds N --from-parked`` (a copy in the sweep's folder)
or ``launch.py --env TASK --algo ALGO --threads 1 --resume --out results/runs/<name>`` (in place).
Parking again replaces an earlier state of the same run only; a later one, another run's or a landed run's folder
is refused.

``<name>`` is ``<task>_<algo>`` (``_seed<N>`` for seeds other than 0). Every target is checked before any work:
an existing evaluation, curve or export is replaced only with ``--replace``, and an export that a shipped agent
dataset is built from only with ``--allow-dataset-change`` as well (that dataset must then be rebuilt and recorded:
``build_datasets.py --record NAME``).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from baselines.common.machine import MACHINES  # noqa: E402
from baselines.training import CHECKPOINT, INIT_FROM_PROGRESS, SNAPSHOTS  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
# What a run folder in git holds: its log, config and machines (and a warm start's copy of its source's log); a
# parked one also its checkpoint, never a replay buffer or TensorBoard files.
LANDED_FILES = ("config.yaml", "progress.csv", MACHINES, INIT_FROM_PROGRESS)
PARKED_FILES = (CHECKPOINT, *LANDED_FILES)
CURVE_SUFFIXES = (".csv", ".png", "_references.json")


class LandingRefused(ValueError):
    """A target holds something the landing would overwrite or contradict; nothing was changed."""


@dataclass
class Run:
    """The run to land: where it is, its configuration and how far it trained."""

    path: Path
    config: Any  # baselines.config.RunConfig
    steps: int

    @property
    def finished(self) -> bool:
        return self.steps >= self.config.train.n_steps

    @property
    def name(self) -> str:
        from experiments.plot_results import output_stem

        return output_stem(self.config)

    @property
    def export_folder(self) -> str:
        """The export's folder relative to the pretrained root, as agent-dataset recipes name it."""
        return f"{self.config.task}/{self.config.algorithm}/seed{self.config.seed}"


def read_run(run_dir: Path) -> Run:
    """The run in ``run_dir`` (a folder with ``checkpoint.pt``, or the checkpoint itself)."""
    from baselines.training import load_checkpoint, run_config_from_checkpoint

    path = Path(run_dir)
    path = path.parent if path.name == CHECKPOINT else path
    if not (path / CHECKPOINT).exists():
        raise FileNotFoundError(f"{path} holds no {CHECKPOINT}: give a run folder (e.g. a sweep trial's "
                                "<out>/<task>/<algo>/seed<N>)")
    state = load_checkpoint(path / CHECKPOINT)
    return Run(path, run_config_from_checkpoint(state), int(state["steps"]))


def parked_steps(folder: Path, run: Run) -> int | None:
    """Steps of the parked state of ``run`` in ``folder`` (None if it holds none); raises
    :class:`LandingRefused` if the folder holds another run's checkpoint."""
    from experiments.sweep_plan import config_differences

    if not (folder / CHECKPOINT).exists():
        return None
    other = read_run(folder)
    diffs = config_differences(other.config.to_dict(), run.config.to_dict())
    if diffs:
        raise LandingRefused(f"{folder} holds another run ({'; '.join(diffs[:3])}); move it away first")
    return other.steps


def plan_park(run: Run, results: Path) -> Path:
    """Check that ``run`` can be parked in ``results/runs/<name>``; returns that folder."""
    if run.finished:
        raise LandingRefused(f"{run.path} finished ({run.steps:,} of {run.config.train.n_steps:,} steps): land it "
                             "without --park")
    folder = results / "runs" / run.name
    earlier = parked_steps(folder, run)
    if earlier is None and any((folder / f).exists() for f in LANDED_FILES):
        raise LandingRefused(f"{folder} holds a landed run (a log without checkpoint): park under another name by "
                             "moving that folder away first")
    if earlier is not None and earlier > run.steps:
        raise LandingRefused(f"{folder} holds a later state of this run ({earlier:,} steps > {run.steps:,})")
    return folder


def park(run: Run, results: Path, snapshots: bool = False) -> Path:
    """Copy ``run``'s resumable state into ``results/runs/<name>``, with its policy snapshots if ``snapshots`` (the
    agents of preference datasets, ~0.3-0.6 MB each)."""
    folder = plan_park(run, results)
    folder.mkdir(parents=True, exist_ok=True)
    _copy_run_files(run.path, folder, PARKED_FILES)
    if snapshots and (run.path / SNAPSHOTS).is_dir() and run.path.resolve() != folder.resolve():
        shutil.copytree(run.path / SNAPSHOTS, folder / SNAPSHOTS, dirs_exist_ok=True)
    return folder


def _copy_run_files(source: Path, folder: Path, names: tuple[str, ...], drop_missing: bool = False) -> None:
    """Copy ``names`` from ``source`` into ``folder`` (a run landing in its own folder copies nothing); with
    ``drop_missing``, remove those of ``folder`` that ``source`` lacks."""
    for name in names:
        if (source / name).exists():
            if (source / name).resolve() != (folder / name).resolve():
                shutil.copy2(source / name, folder / name)
        elif drop_missing and (folder / name).exists():
            (folder / name).unlink()


@dataclass
class Targets:
    """Where a landing writes."""

    run_folder: Path
    evaluation: Path
    curves: list[Path]
    export: Path


def plan_landing(run: Run, results: Path, pretrained: Path, replace: bool = False,
                 allow_dataset_change: bool = False) -> Targets:
    """Check every target of landing ``run``; raises :class:`LandingRefused` naming the first conflict."""
    if not run.finished:
        raise LandingRefused(f"{run.path} is unfinished ({run.steps:,} of {run.config.train.n_steps:,} steps): "
                             "train it on, or --park its resumable state")
    name = run.name
    targets = Targets(results / "runs" / name, results / f"{name}_eval.json",
                      [results / f"{name}{s}" for s in CURVE_SUFFIXES], pretrained / run.export_folder)
    if parked_steps(targets.run_folder, run) is None and any((targets.run_folder / f).exists()
                                                              for f in LANDED_FILES) and not replace:
        raise LandingRefused(f"{targets.run_folder} holds a landed run; pass --replace to land this one over it")
    existing = [str(p) for p in (targets.evaluation, *targets.curves, targets.export) if p.exists()]
    if existing and not replace:
        raise LandingRefused(f"would replace {', '.join(existing)}; pass --replace to land this run over them")
    if targets.export.exists():
        datasets = datasets_built_from(run.export_folder)
        if datasets and not allow_dataset_change:
            raise LandingRefused(
                f"{targets.export} is an export of the shipped datasets {', '.join(datasets)}: replacing it changes "
                "them. Either copy it to <task>/preference/<algo>_seed<N>_<steps> and point the recipes there "
                "(loco_mujoco/agent_datasets.py), or pass --allow-dataset-change and rebuild and record them "
                "(experiments/build_datasets.py --record NAME)")
    return targets


def datasets_built_from(export_folder: str) -> list[str]:
    """The shipped agent datasets whose recipe uses the export ``<task>/<algo>/seed<N>``."""
    from loco_mujoco.agent_datasets import AGENT_RECIPES

    return sorted(name for name, recipe in AGENT_RECIPES.items() if export_folder in recipe.exports)


def card_evaluation(results: dict[str, Any]) -> dict[str, Any]:
    """The card's evaluation, taken from the evaluation file (of the export) so the two never disagree."""
    from baselines.card_evaluation import summary_figures
    from loco_mujoco.evaluation.references import References

    det = results["deterministic"]
    return summary_figures(det["returns"], det, References(**results["references"]), results["protocol"]["episodes"],
                           results["protocol"]["seed"])


def evaluate_export_into(export: Path, evaluation_file: Path, shown_as: Path | None = None) -> dict[str, Any]:
    """Evaluate the export in ``export`` under the protocol (deterministic and stochastic, imitation metrics) into
    ``evaluation_file`` (replaced) and put the same figures on its card; the file names the export as ``shown_as``
    (default: ``export``), relative to the repository where inside it. Returns the evaluation."""
    from experiments import evaluate
    from loco_mujoco.policy_export import CARD, write_card

    args = ["--pretrained", str(export), "--metrics", "--stochastic", "--json", str(evaluation_file), "--force"]
    if shown_as is not None and Path(shown_as).resolve() != Path(export).resolve():  # the header names the folder
        print(f"evaluating the export staged in {export}; it moves to {shown_as} once its evaluation is written")
    if evaluate.main(args) != 0:
        raise RuntimeError(f"the evaluation of the export {export} failed (see above)")
    evaluation = json.loads(evaluation_file.read_text())
    evaluation.pop("card_evaluation", None)  # the card's figures before: replaced below
    shown = Path(shown_as or export).resolve()
    evaluation["pretrained"] = str(shown.relative_to(REPO)) if shown.is_relative_to(REPO) else str(shown)
    evaluation_file.write_text(json.dumps(evaluation, indent=1, default=float))
    card = json.loads((export / CARD).read_text())
    write_card(export, {**card, "evaluation": card_evaluation(evaluation)})
    return evaluation


def land(run: Run, results: Path, pretrained: Path, replace: bool = False, allow_dataset_change: bool = False,
         table: bool = True) -> Targets:
    """Land the finished ``run``: log, evaluation, curve, export and the regenerated table (see the module doc).

    The evaluation is of the export, the policy users load (``evaluate.py --pretrained`` repeats it), made in a
    hidden folder beside its target that replaces the target only once everything it needs was written."""
    from baselines.export import export_checkpoint
    from experiments import plot_results, results_table

    targets = plan_landing(run, results, pretrained, replace, allow_dataset_change)
    checkpoint = run.path / CHECKPOINT
    staging = targets.export.parent / f".{targets.export.name}.landing"
    shutil.rmtree(staging, ignore_errors=True)  # a landing that died before it moved its export into place
    try:
        export_checkpoint(checkpoint, staging, None, overwrite=True)
        evaluate_export_into(staging, targets.evaluation, shown_as=targets.export)
        if targets.export.exists():  # checked by plan_landing: replace was given
            shutil.rmtree(targets.export)
        staging.rename(targets.export)
    finally:
        shutil.rmtree(staging, ignore_errors=True)

    folder = targets.run_folder
    folder.mkdir(parents=True, exist_ok=True)
    _copy_run_files(run.path, folder, LANDED_FILES, drop_missing=True)  # a replaced run's extra files go too
    plot_results.plot_run(folder, results, force=True)
    if (folder / CHECKPOINT).exists() and folder.resolve() != run.path.resolve():
        (folder / CHECKPOINT).unlink()  # the parked state of this run: its export supersedes it
    if table:
        results_table.main(["--results", str(results), "--runs", str(results / "runs"), "--pretrained",
                            str(pretrained), "--out", str(results), "--force"])
    return targets


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir", type=Path, help="the run's folder (or its checkpoint.pt)")
    parser.add_argument("--park", action="store_true", help="copy an unfinished run's resumable state")
    parser.add_argument("--snapshots", action="store_true", help="with --park: also copy the policy snapshots")
    parser.add_argument("--replace", action="store_true", help="replace an existing evaluation, curve and export")
    parser.add_argument("--allow-dataset-change", action="store_true",
                        help="with --replace: replace an export that shipped agent datasets are built from")
    parser.add_argument("--no-table", action="store_true", help="do not regenerate the results table")
    parser.add_argument("--results", type=Path, default=REPO / "results", help="results folder (default: results/)")
    parser.add_argument("--pretrained", type=Path, default=None,
                        help="pretrained folder (default: $LOCO_MUJOCO_PRETRAINED or pretrained/)")
    args = parser.parse_args(argv)
    from loco_mujoco.agent_datasets import pretrained_root

    try:
        run = read_run(args.run_dir)
        if args.park:
            folder = park(run, args.results, args.snapshots)
            relative = os.path.relpath(folder)
            shown = folder if relative.startswith("..") else relative
            size = sum(f.stat().st_size for f in folder.rglob("*") if f.is_file())
            print(f"parked: {run.config.task} {run.config.algorithm} seed {run.config.seed} at {run.steps:,} of "
                  f"{run.config.train.n_steps:,} steps in {shown} ({size:,} bytes); continue with\n"
                  f"  python experiments/sweep.py --tasks {run.config.task} --algos {run.config.algorithm} "
                  f"--seeds {run.config.seed} --threads 1 --from-parked {Path(shown).parent} --out runs/table\n"
                  f"or in place with\n"
                  f"  python experiments/launch.py --env {run.config.task} --algo {run.config.algorithm} "
                  f"--threads 1 --resume --out {shown}")
            return 0
        targets = land(run, args.results, args.pretrained or pretrained_root(), args.replace,
                       args.allow_dataset_change, table=not args.no_table)
    except (FileNotFoundError, LandingRefused) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    size = sum(f.stat().st_size for f in targets.export.iterdir())
    print(f"landed: {targets.run_folder}, {targets.evaluation}, export {targets.export} ({size:,} bytes)")
    if (targets.run_folder / CHECKPOINT).exists():  # trained in place: the run's own files stay untouched
        print(f"note: {targets.run_folder} was the run's own folder and keeps its checkpoint.pt; a finished run keeps "
              "only its export in git: `git rm --cached` it, or move it out of the tree")
    return 0


if __name__ == "__main__":
    sys.exit(main())
