"""Which references (random, stand-still and expert returns) each task's rows are normalised by.

A task's rows share one set: the references most of its evaluations were scored against. An evaluation scored
against another machine's build of the same dataset is rescored with the task's set from its per-episode returns:
one recipe built where BLAS picks other kernels differs in its last bits (Talos.walk under OpenBLAS's Haswell,
Prescott and Sandybridge kernels: at most 2.7e-8 rad in qpos and 1.3e-6 rad/s in qvel, results/README.md), so its
digest differs; the deterministic references (expert R from the frames, the two stand-still rollouts) then agree
to ~1e-9 relative, while the random-action rollouts, chaotic, give random R 4-9% apart. References that differ in
anything else (settings, horizon, a changed dataset) keep their own, and the row's notes say so.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import replace
from typing import Any

from experiments.table_sources import SeedResult, normalized_scores

SAME_DATA_RTOL = 1e-6  # deterministic references of two builds of one dataset agree to ~1e-9 relative (measured)
DETERMINISTIC = ("expert_return", "zero_return", "hold_return")


def references_key(refs: dict[str, Any]) -> str:
    """A hashable, order-independent form of one set of references."""
    return json.dumps(refs, sort_keys=True)


def task_references(results: list[SeedResult]) -> dict[str, dict[str, Any]]:
    """Per task, the references most of its evaluations were scored against (ties: the first in sort order)."""
    counts: dict[str, Counter] = {}
    for r in results:
        if r.references is not None:
            counts.setdefault(r.base_task, Counter())[references_key(r.references)] += 1
    return {task: json.loads(sorted(c.items(), key=lambda kv: (-kv[1], kv[0]))[0][0]) for task, c in counts.items()}


def another_build(own: dict[str, Any], task_refs: dict[str, Any]) -> bool:
    """Whether ``own`` are references of another build of the dataset ``task_refs`` were measured on: other
    digest, same settings and horizon, deterministic returns equal within ``SAME_DATA_RTOL``."""
    if own["dataset_digest"] == task_refs["dataset_digest"]:
        return False
    if own["env_settings"] != task_refs["env_settings"] or own["horizon"] != task_refs["horizon"]:
        return False
    return all(math.isclose(float(own[k]), float(task_refs[k]), rel_tol=SAME_DATA_RTOL, abs_tol=SAME_DATA_RTOL)
               for k in DETERMINISTIC)


def on_task_references(result: SeedResult, task_refs: dict[str, Any] | None) -> SeedResult:
    """``result`` rescored with its task's references where its own are another build's (a copy; the file's
    references kept in ``own_references``); else ``result`` itself."""
    own = result.references
    if own is None or task_refs is None or result.returns is None or not another_build(own, task_refs):
        return result
    return replace(result, references=task_refs, scores=normalized_scores(result.returns, task_refs),
                   own_references=own)


def rescored_note(result: SeedResult) -> str:
    """What the table did to a rescored result, with both random returns and the score its own references gave."""
    own, task = result.own_references, result.references
    own_score = float(normalized_scores(result.returns, own).mean())
    worst = max(abs(float(own[k]) - float(task[k])) / max(abs(float(task[k])), 1e-12) for k in DETERMINISTIC)
    equal = f"equal within {worst:.0e} relative" if worst > 0 else "equal"
    return (f"{result.source} rescored with the task's references: its own are of another build of the same "
            f"dataset ({own['dataset_digest']}; expert and stand-still R {equal}, random R "
            f"{float(own['random_return']):.1f} against {float(task['random_return']):.1f}), under which it scored "
            f"{own_score:.1f}")
