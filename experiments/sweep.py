"""Train tasks x algorithms x seeds on Ray: ``python experiments/sweep.py --tasks UnitreeH1.walk --algos vail bc``.

Each trial is the run ``launch.py`` would start (same configuration layers, same Trainer) in
``<out>/<task>/<algo>/seed<N>``, with ``--cpus-per-trial`` Ray CPUs and ``--threads`` torch threads (1 and 1 by
default). The same keys can come from a YAML file (``--config sweep.yaml``; the command line wins).

Running the same sweep again skips finished trials (their checkpoint reached the requested steps), resumes the
interrupted ones from their checkpoints, and for a finished sweep reports "0 trials run" and changes no file;
``--steps`` larger than before extends every trial. A folder holding a run with another configuration is
refused, never overwritten. With ``--from-parked`` an empty trial folder first takes the state
``land_run.py --park`` committed of the same run (``results/runs/<task>_<algo>[_seed<N>]``), so that a fresh clone
continues the table's unfinished runs; with ``--skip-landed`` a trial whose run ``land_run.py`` already exported
(``pretrained/<task>/<algo>/seed<N>``, at least the trial's steps) is skipped and shown as landed, with the
configuration values its export differs in. So ``sweep.py --config sweeps/table.yaml --from-parked --skip-landed``
trains what the results table still lacks. A live table shows each trial (pending, running with its step count,
finished, stopped, failed with the error's last line); the exit status is 1 if any trial failed. With
``--time-limit MINUTES`` every trial stops after its last checkpoint that fits in that time (a session's or a
cluster job's end) and the same command later resumes it. Trials start as CPUs free
up: those resuming a checkpoint first, then each (task, algorithm)'s first seed before any one's second
(:func:`start_order`).

Ray starts locally with ``--num-cpus`` CPUs (default: all) and nothing to set up; ``--address HOST:PORT`` joins a
cluster started with ``ray start`` (see the README's "Sweeps": the out folder must be on storage every machine
sees at the same path). Ray is an optional dependency: ``pip install -e ".[sweep]"``.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import TypeVar

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))  # run from a checkout without installing

from baselines.config import ConfigError, shown_path  # noqa: E402
from experiments.sweep_plan import (  # noqa: E402
    DirState,
    Landed,
    RunDirConflict,
    Trial,
    adopt_parked,
    first_differences,
    inspect_run_dir,
    landed_export,
    last_score,
    make_trials,
    parked_source,
)
from experiments.sweep_spec import SweepSpecError, build_spec, read_sweep_file  # noqa: E402
from experiments.sweep_status import LiveTable, ProgressBoard, TrialStatus, render  # noqa: E402
from experiments.sweep_trial import TrialOutcome, run_trial  # noqa: E402

REFRESH_S = 2.0  # how often the live table asks the trials for their step counts
PARKED = REPO / "results" / "runs"  # where land_run.py --park commits unfinished runs
T = TypeVar("T")


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--config", metavar="SWEEP.yaml", help="a YAML file with the keys below (tasks, algos, "
                                                               "seeds, steps, out, set, cpus_per_trial, threads)")
    parser.add_argument("--tasks", nargs="+", help="task names, e.g. UnitreeH1.walk UnitreeH1.run")
    parser.add_argument("--algos", nargs="+", help="algorithms, e.g. vail bc")
    parser.add_argument("--seeds", nargs="+", type=int, help="seeds (default: 0)")
    parser.add_argument("--steps", type=int, help="training steps of every trial (default: each config's "
                                                  "train.n_steps); more than before extends finished trials")
    parser.add_argument("--out", help="root folder of the trials (default: runs)")
    parser.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE",
                        help="override one config value in every trial (repeatable), e.g. --set agent.max_kl=0.01")
    parser.add_argument("--cpus-per-trial", type=float, help="Ray CPUs each trial holds (default: 1)")
    parser.add_argument("--threads", type=int, help="torch threads per trial (default: 1)")
    parser.add_argument("--num-cpus", type=int, help="CPUs of the local Ray instance (default: all of this machine)")
    parser.add_argument("--address", help="join this Ray cluster (HOST:PORT of `ray start --head`, or auto) "
                                          "instead of starting a local one")
    parser.add_argument("--from-parked", nargs="?", const=str(PARKED), metavar="DIR",
                        help="start each trial whose folder is empty from the same run's parked state in "
                             f"DIR/<task>_<algo>[_seed<N>] (default DIR: {PARKED.relative_to(REPO)})")
    parser.add_argument("--skip-landed", nargs="?", const="", metavar="DIR",
                        help="skip each trial whose run land_run.py exported to DIR/<task>/<algo>/seed<N> with at "
                             "least the trial's steps, listing the configuration values the export differs in "
                             "(default DIR: $LOCO_MUJOCO_PRETRAINED or pretrained/)")
    parser.add_argument("--time-limit", type=float, metavar="MINUTES",
                        help="each trial stops after its last checkpoint whose next epoch would end later than "
                             "MINUTES after the sweep's start (trials not started by then are not started); "
                             "the same command later resumes them")
    parser.add_argument("--plan", action="store_true",
                        help="print what each trial would do (start, resume from its checkpoint or a parked state, "
                             "or nothing: finished) and the steps left, then exit: nothing is started or written "
                             "and Ray is not needed")
    return parser.parse_args(argv)


def require_ray() -> ModuleType:
    """The ``ray`` module, or ``ImportError`` saying how to install it."""
    try:
        import ray
    except ImportError:
        raise ImportError('experiments/sweep.py runs its trials on Ray, which is not installed: '
                          'pip install -e ".[sweep]" (or pip install "ray>=2.60")') from None
    return ray


def main(argv: list[str] | None = None) -> int:
    started = time.time()  # --time-limit counts from here
    args = parse_args(argv)
    try:
        if args.address and args.num_cpus is not None:
            raise SweepSpecError("--num-cpus sizes a local Ray instance; a cluster joined with --address has the "
                                 "CPUs its `ray start` commands gave it")
        if args.num_cpus is not None and args.num_cpus < 1:
            raise SweepSpecError(f"--num-cpus must be at least 1, got {args.num_cpus}")
        if args.time_limit is not None and not args.time_limit > 0:
            raise SweepSpecError(f"--time-limit must be a positive number of minutes, got {args.time_limit}")
        spec = build_spec(read_sweep_file(args.config) if args.config else {},
                          {"tasks": args.tasks, "algos": args.algos, "seeds": args.seeds, "steps": args.steps,
                           "out": args.out, "set": args.set, "cpus_per_trial": args.cpus_per_trial,
                           "threads": args.threads})
        spec.out = spec.out.resolve()  # the same folder for workers on other machines (shared storage)
        notes: dict[str, None] = {}
        trials = make_trials(spec, note=lambda text: notes.setdefault(text))
    except (ImportError, SweepSpecError, ConfigError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    for text in notes:
        print(f"note: {text}", file=sys.stderr)
    landed = {} if args.skip_landed is None else _landed(trials, _pretrained_root(args.skip_landed))
    if landed is None:
        return 2
    if args.plan:
        return _print_plan(trials, None if args.from_parked is None else Path(args.from_parked), spec.out, landed)
    parked = {} if args.from_parked is None else _parked_sources([t for t in trials if t.key not in landed],
                                                                 Path(args.from_parked))
    if parked is None:
        return 2
    try:
        ray = require_ray()
    except ImportError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    for trial in trials:
        if parked.get(trial.key) is not None:
            source, steps = parked[trial.key]
            adopt_parked(trial, source)
            print(f"note: {trial.key} continues the run parked in {source} at {steps:,} steps", file=sys.stderr)

    rows, todo, conflicts = _plan(trials, landed)
    if conflicts:
        for text in conflicts:
            print(f"error: {text}", file=sys.stderr)
        print(f"error: {len(conflicts)} of {len(trials)} trials conflict with existing runs; nothing was started",
              file=sys.stderr)
        return 2
    done = len(trials) - len(todo)
    resumed = sum(row.steps > 0 for _, row in todo)
    skipped = f" ({len(landed)} of them landed)" if landed else ""
    print(f"sweep of {len(trials)} trials in {spec.out}: {len(todo)} to run ({resumed} resumed), "
          f"{done} already finished{skipped}", flush=True)
    if not todo:
        LiveTable(interactive=False).close(rows)
        print(f"0 trials run: all {done} trials had already finished{skipped}")
        return 0

    previous_handler = signal.signal(signal.SIGTERM, _stop_on_sigterm)
    started_ray = not ray.is_initialized()  # a caller's Ray instance (e.g. the tests') is used and left running
    try:
        if started_ray:
            try:
                _init_ray(ray, args)
            except ConnectionError as err:
                print(f"error: {err}: check the address that `ray start --head` printed; Ray's clusters require "
                      "their token by default: RAY_AUTH_MODE=token here, with the head's ~/.ray/auth_token copied "
                      "to this machine (or RAY_AUTH_TOKEN set)", file=sys.stderr)
                return 2
        deadline = None if args.time_limit is None else started + 60.0 * args.time_limit
        outcomes = _run(ray, spec.cpus_per_trial, start_order(todo, spec.seeds_of), rows, deadline)
    except KeyboardInterrupt:
        print("\ninterrupted: every trial keeps its last checkpoint; run the same command again to resume",
              file=sys.stderr)
        return 130
    finally:
        if started_ray and ray.is_initialized():
            ray.shutdown()
        signal.signal(signal.SIGTERM, previous_handler)
    return _summary(outcomes, done)


def _per_trial(trials: list[Trial], lookup: Callable[[Trial], T]) -> tuple[dict[str, T], dict[str, str]]:
    """``lookup`` of every trial by key, and per trial key the error of those it refused (``RunDirConflict``)."""
    found, errors = {}, {}
    for trial in trials:
        try:
            found[trial.key] = lookup(trial)
        except RunDirConflict as err:
            errors[trial.key] = str(err)
    return found, errors


def _parked_sources(trials: list[Trial], parked_root: Path) -> dict[str, tuple[Path, int] | None] | None:
    """Per trial key, the parked state (folder, steps) its empty folder would start from; None, the errors printed,
    when ``parked_root`` is missing or one of those states has another configuration (then nothing is copied)."""
    if _missing(parked_root):
        return None
    sources, conflicts = _per_trial(trials, lambda trial: parked_source(trial, parked_root))
    for text in conflicts.values():
        print(f"error: {text}", file=sys.stderr)
    if conflicts:
        print(f"error: {len(conflicts)} parked runs conflict with this sweep; nothing was copied or started",
              file=sys.stderr)
        return None
    return sources


def _pretrained_root(value: str) -> Path:
    """``--skip-landed``'s folder: the one given, else the pretrained folder land_run.py exports into."""
    if value:
        return Path(value)
    from loco_mujoco.agent_datasets import pretrained_root

    return pretrained_root()


def _landed(trials: list[Trial], pretrained: Path) -> dict[str, Landed] | None:
    """Per trial key, its landed export (``--skip-landed``); None, the errors printed, when ``pretrained`` is
    missing or an export there cannot be read."""
    if not pretrained.is_dir():
        print(f"error: --skip-landed {pretrained}: no such folder; give the folder land_run.py exports into "
              "(default: $LOCO_MUJOCO_PRETRAINED or pretrained/)", file=sys.stderr)
        return None
    exports, errors = _per_trial(trials, lambda trial: landed_export(trial, pretrained))
    for text in errors.values():
        print(f"error: {text}", file=sys.stderr)
    return None if errors else {key: export for key, export in exports.items() if export is not None}


def _landed_row(trial: Trial, export: Landed) -> TrialStatus:
    """The table row of a trial skipped for its landed export, naming the configuration values that differ."""
    note = f"exported in {shown_path(export.folder)}"
    if export.differences:
        note += f", with another configuration: {first_differences([_clipped(d) for d in export.differences], 3)}"
    return TrialStatus(trial.key, trial.run.train.n_steps, state="landed", steps=export.steps, score=export.score,
                       note=note)


def _clipped(text: str, width: int = 160) -> str:
    """``text`` cut to ``width`` characters (a nested value such as ``init_from`` can run to thousands)."""
    return text if len(text) <= width else text[:width - 3] + "..."


def _print_plan(trials: list[Trial], parked_root: Path | None, out: Path, landed: dict[str, Landed]) -> int:
    """``--plan``: the table of what each trial would do and the steps left; a trial whose folder or parked state
    holds another configuration is listed as a conflict (exit 2), as the sweep itself would refuse it."""
    if parked_root is not None and _missing(parked_root):
        return 2
    rows, todo, conflicts = _plan(trials, landed)
    parked, parked_conflicts = ({}, {}) if parked_root is None else _per_trial(
        [trial for trial, _ in todo], lambda trial: parked_source(trial, parked_root))
    for trial, row in todo:
        if trial.key in parked_conflicts:
            conflicts.append(parked_conflicts[trial.key])
            _mark_conflict(row, trial, parked_conflicts[trial.key])
            continue
        source = parked.get(trial.key)
        row.state = "to resume" if source is not None or row.steps else "to start"
        if source is not None:
            row.steps, row.note = source[1], f"from the state parked in {source[0]}"
    print(render(rows, None))
    from baselines import is_offline

    left = {True: 0, False: 0}  # offline (gradient steps) or not (environment steps)
    for trial, row in zip(trials, rows, strict=True):
        if row.state not in ("conflict", "landed"):
            left[is_offline(trial.run.algorithm)] += max(row.total - row.steps, 0)
    other = sum(bool(e.differences) for e in landed.values())
    skipped = f"; {len(landed)} landed ({other} with another configuration)" if landed else ""
    print(f"plan for {out}: {len(trials)} trials{skipped}; left to train: {left[False]:,} environment steps and "
          f"{left[True]:,} gradient steps{f'; {len(conflicts)} in conflict' if conflicts else ''}; nothing was "
          "started or written")
    return 2 if conflicts else 0


def _plan(trials: list[Trial], landed: dict[str, Landed]
          ) -> tuple[list[TrialStatus], list[tuple[Trial, TrialStatus]], list[str]]:
    """Every trial's row (one per trial, in order; a folder holding another run is a "conflict" row), the trials
    still to run (new or resumed: not landed) and the conflicts' texts."""
    rows, todo, conflicts = [], [], []
    for trial in trials:
        if trial.key in landed:
            rows.append(_landed_row(trial, landed[trial.key]))
            continue
        try:
            row = _row(trial, inspect_run_dir(trial))
        except RunDirConflict as err:
            conflicts.append(str(err))
            row = TrialStatus(trial.key, trial.run.train.n_steps)
            _mark_conflict(row, trial, str(err))
        rows.append(row)
        if row.state not in ("done before", "conflict"):
            todo.append((trial, row))
    return rows, todo, conflicts


def _mark_conflict(row: TrialStatus, trial: Trial, text: str) -> None:
    """Show ``row`` as refused, with the conflict's text less the trial's key (the row names it)."""
    row.state, row.note = "conflict", text.removeprefix(f"{trial.key}: ")


def _row(trial: Trial, state: DirState) -> TrialStatus:
    """The table row of a trial whose folder holds ``state``: done before (with its last score) or pending."""
    row = TrialStatus(trial.key, trial.run.train.n_steps, steps=state.steps)
    if state.kind == "finished":
        row.state, row.score = "done before", last_score(trial.out_dir)
    elif state.kind == "resume":
        row.note = "resumes its checkpoint"
    return row


def _missing(parked_root: Path) -> bool:
    """Whether the ``--from-parked`` folder is missing (said on stderr)."""
    if parked_root.is_dir():
        return False
    print(f"error: --from-parked {parked_root}: no such folder; give the folder land_run.py --park writes into "
          f"(default {PARKED.relative_to(REPO)})", file=sys.stderr)
    return True


def _init_ray(ray: ModuleType, args: argparse.Namespace) -> None:
    """A quiet local Ray instance (no dashboard, worker output kept in Ray's log files), or the cluster at
    ``--address``; workers import this checkout first (PYTHONPATH), as the driver does."""
    path = os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)
    options = {"logging_level": logging.ERROR, "log_to_driver": False,
               "runtime_env": {"env_vars": {"PYTHONPATH": path}}}
    if args.address:
        _check_reachable(args.address)
        ray.init(address=args.address, **options)
    else:
        ray.init(num_cpus=args.num_cpus or os.cpu_count(), include_dashboard=False, **options)


def _check_reachable(address: str) -> None:
    """Raise ``ConnectionError`` at once when nothing listens at ``HOST:PORT`` (Ray itself retries for minutes)."""
    host, sep, port = address.rpartition(":")
    if not sep or not port.isdigit() or "://" in address:
        return  # "auto", or a ray:// client address: left to Ray
    try:
        socket.create_connection((host, int(port)), timeout=10).close()
    except OSError as err:
        raise ConnectionError(f"nothing answers at {address} ({err.strerror or err})") from None


def start_order(todo: list[tuple[Trial, TrialStatus]], seeds_of: Callable[[str], list[int]]
                ) -> list[tuple[Trial, TrialStatus]]:
    """``todo`` in the order the trials are handed to Ray: those resuming a checkpoint (their steps are spent) before
    the new ones, and within each group every (task, algorithm)'s first seed before any one's second, and so on, in
    grid order. So a grid larger than the CPUs gives every row of a table a result before it adds seeds to any."""
    def key(item: tuple[Trial, TrialStatus]) -> tuple[bool, int]:
        trial, row = item
        return row.steps == 0, seeds_of(trial.run.task).index(trial.run.seed)

    return sorted(todo, key=key)  # stable: grid order within equal keys


def _run(ray: ModuleType, cpus_per_trial: float, todo: list[tuple[Trial, TrialStatus]],
         rows: list[TrialStatus], deadline: float | None = None) -> list[TrialOutcome]:
    """Every trial of ``todo`` as a Ray task (stopping by ``deadline``, a ``time.time()`` value); the table is
    redrawn until the last one ends."""
    board = ray.remote(num_cpus=0)(ProgressBoard).remote()
    task = ray.remote(run_trial).options(num_cpus=cpus_per_trial, max_retries=0)
    pending = {task.remote(trial, board, deadline): row for trial, row in todo}
    table, outcomes = LiveTable(), []
    try:
        table.update(rows)
        while pending:
            ray.wait(list(pending), num_returns=1, timeout=REFRESH_S)
            ready, _ = ray.wait(list(pending), num_returns=len(pending), timeout=0)
            for ref in ready:
                row = pending.pop(ref)
                outcomes.append(_outcome(ray, ref, row.key))
                _apply(row, outcomes[-1])
            for key, steps in ray.get(board.snapshot.remote()).items():
                for row in rows:
                    if row.key == key and row.state in ("pending", "running"):
                        row.state, row.steps, row.note = "running", steps, ""
            if pending:  # the last table is close()'s
                table.update(rows)
    except KeyboardInterrupt:
        for ref in pending:
            ray.cancel(ref)
        raise
    finally:
        table.close(rows)
    return outcomes


def _outcome(ray: ModuleType, ref: object, key: str) -> TrialOutcome:
    """The trial's own outcome, or a failure when Ray lost it (a worker killed, a node gone)."""
    try:
        return ray.get(ref)
    except ray.exceptions.RayError as err:
        lines = [line.strip() for line in str(err).splitlines() if line.strip()]
        return TrialOutcome(key, "failed", error=lines[-1] if lines else type(err).__name__, details=str(err))


def _apply(row: TrialStatus, outcome: TrialOutcome) -> None:
    row.state, row.steps = outcome.state, max(row.steps, outcome.steps)
    if outcome.state == "finished":
        row.score, row.note = outcome.score, f"{outcome.seconds:.0f} s"
    elif outcome.state == "stopped":
        row.note = "time limit: run again to resume"
    else:
        row.note = outcome.error


def _summary(outcomes: list[TrialOutcome], done_before: int) -> int:
    """Failed trials' tracebacks and the trials' warnings on stderr, then the counts; 1 if any trial failed."""
    failed = [o for o in outcomes if o.state == "failed"]
    for o in failed:
        print(f"\n{o.key} failed:\n{o.details.rstrip()}", file=sys.stderr)
    for o in outcomes:
        for text in o.warnings:
            print(f"warning ({o.key}): {text}", file=sys.stderr)
    stopped = sum(o.state == "stopped" for o in outcomes)
    print(f"{len(outcomes)} trials run: {len(outcomes) - len(failed) - stopped} finished, "
          + (f"{stopped} stopped at the time limit (run the same command to resume them), " if stopped else "")
          + f"{len(failed)} failed; {done_before} had already finished")
    return 1 if failed else 0


def _stop_on_sigterm(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main())
