"""Aggregates over tasks, as ``rliable`` reports them: the interquartile mean (IQM) of run scores and the
performance profile (fraction of runs scoring above tau), each with a 95% stratified-bootstrap interval.

Why written here: ``rliable`` 1.2.0 pins ``arch<8``, and the repository needs ``arch`` 8 for its own intervals
(:mod:`loco_mujoco.evaluation.intervals`), so the two aggregates are re-implemented with numpy, reusing that
module's :func:`~loco_mujoco.evaluation.intervals.iqm`, confidence level and number of bootstrap replicates.
``arch`` offers no stratified bootstrap; rliable's ``StratifiedBootstrap`` only changes how indices are drawn,
which is what :func:`stratified_run_scores` does.

Input: per task, per run (training seed), that run's per-episode normalised scores. A run's score is the mean
over its episodes. The bootstrap is stratified by task (every replicate keeps every task, as rliable does) and
two-level: within a task it resamples runs with replacement, and within each drawn run its episodes. With one
run per task (most cells today) the first level is constant and the interval still says how much the 50
evaluation episodes leave open; rliable resamples runs only and would give a zero-width interval there.
Intervals are the percentile intervals of the replicates, rliable's default for these aggregates.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from loco_mujoco.evaluation.intervals import BOOTSTRAP_REPS, CONFIDENCE, iqm

TaskRuns = Sequence[Sequence[np.ndarray]]  # [task][run] -> per-episode normalised scores


def _check(scores: TaskRuns) -> list[list[np.ndarray]]:
    if len(scores) == 0:
        raise ValueError("no tasks to aggregate")
    out = []
    for t, runs in enumerate(scores):
        if len(runs) == 0:
            raise ValueError(f"task {t} has no runs; leave tasks without runs out of the aggregate")
        task = []
        for r, episodes in enumerate(runs):
            x = np.asarray(episodes, dtype=float).ravel()
            if x.size == 0 or not np.all(np.isfinite(x)):
                raise ValueError(f"task {t}, run {r}: per-episode scores must be finite and non-empty")
            task.append(x)
        out.append(task)
    return out


def run_scores(scores: TaskRuns) -> np.ndarray:
    """Every run's score (the mean over its episodes), tasks one after another."""
    return np.array([x.mean() for runs in _check(scores) for x in runs])


def stratified_run_scores(scores: TaskRuns, reps: int = BOOTSTRAP_REPS, seed: int = 0) -> list[np.ndarray]:
    """Per task, a ``(reps, n_runs)`` array of bootstrapped run scores: runs drawn with replacement within the
    task, and each drawn run's episodes drawn with replacement within that run."""
    rng = np.random.default_rng(seed)
    out = []
    for runs in _check(scores):
        means = np.stack([x[rng.integers(0, x.size, (reps, x.size))].mean(axis=1) for x in runs], axis=1)
        drawn = rng.integers(0, len(runs), (reps, len(runs)))
        out.append(np.take_along_axis(means, drawn, axis=1))
    return out


def _percentile_interval(replicates: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    tail = 100.0 * (1.0 - confidence) / 2.0
    return np.percentile(replicates, tail, axis=0), np.percentile(replicates, 100.0 - tail, axis=0)


def aggregate_iqm(scores: TaskRuns, reps: int = BOOTSTRAP_REPS, seed: int = 0,
                  confidence: float = CONFIDENCE) -> dict[str, float | list[float] | int]:
    """IQM of all run scores over all tasks, with its stratified-bootstrap percentile interval."""
    point = iqm(run_scores(scores))
    boot = np.concatenate(stratified_run_scores(scores, reps, seed), axis=1)
    lo, hi = _percentile_interval(np.array([iqm(row) for row in boot]), confidence)
    return {"iqm": point, "ci95": [float(lo), float(hi)], "tasks": len(scores),
            "runs": int(sum(len(runs) for runs in scores))}


def _profile(task_scores: Sequence[np.ndarray], taus: np.ndarray) -> np.ndarray:
    """Mean over tasks of the fraction of the task's runs above each tau (``task_scores[t]``: ``(..., n_runs)``)."""
    return np.mean([np.mean(s[..., None] > taus, axis=-2) for s in task_scores], axis=0)


def performance_profile(scores: TaskRuns, taus: np.ndarray, reps: int = BOOTSTRAP_REPS, seed: int = 0,
                        confidence: float = CONFIDENCE) -> dict[str, np.ndarray]:
    """Fraction of runs with score > tau for each tau (each task weighted equally, as rliable does), with a
    stratified-bootstrap percentile band."""
    taus = np.asarray(taus, dtype=float)
    checked = _check(scores)
    point = _profile([np.array([x.mean() for x in runs]) for runs in checked], taus)
    lo, hi = _percentile_interval(_profile(stratified_run_scores(checked, reps, seed), taus), confidence)
    return {"tau": taus, "fraction": point, "lo": lo, "hi": hi}
