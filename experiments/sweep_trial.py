"""One sweep trial, as a Ray task runs it on a worker: launch.py's run through the existing Trainer.

The trial looks at its folder again when it starts (it may have changed since the sweep was planned, e.g. when
Ray retries it), resumes a checkpoint or starts afresh, reports its step count to the sweep's progress board
at most once a second, and returns a :class:`TrialOutcome` instead of raising, so that the sweep can show the
error's last line and go on with the other trials.
"""

from __future__ import annotations

import time
import traceback
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from experiments.sweep_plan import Trial, clear_unstarted, inspect_run_dir

REPORT_EVERY_S = 1.0


@dataclass
class TrialOutcome:
    """How a trial ended: ``finished`` (with its last evaluation's score), ``stopped`` (at the sweep's time limit,
    after a checkpoint) or ``failed`` (with the error)."""

    key: str
    state: str
    steps: int = 0
    score: float | None = None
    seconds: float = 0.0
    error: str = ""  # the error's last line
    details: str = ""  # its traceback
    warnings: list[str] = field(default_factory=list)


def run_trial(trial: Trial, board: Any = None, deadline: float | None = None) -> TrialOutcome:
    """Train ``trial`` to its steps (resuming its checkpoint if there is one), or until ``deadline`` (a
    ``time.time()`` value: ``Trainer.train``'s); ``board`` is the sweep's progress actor (``report.remote(key,
    steps)``) or None."""
    from baselines.training import Trainer

    start, steps, trainer = time.perf_counter(), 0, None
    report = _throttled(lambda n: board.report.remote(trial.key, n)) if board is not None else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        try:
            state = inspect_run_dir(trial)
            steps = state.steps
            if state.kind == "finished":
                return TrialOutcome(trial.key, "finished", steps=steps)
            if deadline is not None and time.time() >= deadline:  # not worth building its environments
                return TrialOutcome(trial.key, "stopped", steps=steps)
            if state.kind == "unstarted":
                clear_unstarted(trial)
            if report is not None:
                report(steps, force=True)
            trainer = Trainer(trial.run, trial.out_dir, resume=state.kind == "resume", progress=False,
                              n_threads=trial.threads, on_progress=report)
            result = trainer.train(deadline=deadline)
            steps = trainer.steps
            outcome = TrialOutcome(trial.key, "stopped" if trainer.stopped_at_deadline else "finished", steps=steps,
                                   score=result.get("score"))
        except Exception as err:  # noqa: BLE001  (any error of the run is the trial's result, shown by the sweep)
            lines = [line for line in traceback.format_exception_only(type(err), err) if line.strip()]
            steps = trainer.steps if trainer is not None else steps
            outcome = TrialOutcome(trial.key, "failed", steps=steps, error=lines[-1].strip(),
                                   details=traceback.format_exc())
    outcome.seconds = time.perf_counter() - start
    outcome.warnings = list(dict.fromkeys(f"{w.category.__name__}: {w.message}" for w in caught))
    return outcome


def _throttled(send: Callable[[int], Any]) -> Callable[..., None]:
    """``send(steps)`` at most every ``REPORT_EVERY_S`` seconds (off-policy runs advance after every step)."""
    last = [float("-inf")]

    def report(steps: int, force: bool = False) -> None:
        now = time.monotonic()
        if force or now - last[0] >= REPORT_EVERY_S:
            last[0] = now
            send(steps)

    return report
