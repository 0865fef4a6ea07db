"""Which references (random, stand-still and expert returns) each task's rows are normalised by.

A task's rows share one set: the task's committed references, ``<results>/references/<task>.json`` (measured under
the task's committed env settings with the protocol's 1,000 random-action episodes: ``results_table.py
--measure-references``), else the set most of its evaluations were scored against. An evaluation scored against
another set measured on the same data is rescored with the task's from its per-episode returns: its file's random R
came from fewer episodes (50 before references version 2: +-2.2-2.5 R) or from another build of the dataset. One
recipe built where BLAS picks other kernels differs in its last bits (Talos.walk under OpenBLAS's Haswell, Prescott
and Sandybridge kernels: at most 2.7e-8 rad in qpos and 1.3e-6 rad/s in qvel, results/README.md), so its digest
differs while the deterministic references (expert R from the frames, the two stand-still rollouts) agree to
~1e-9 relative. References that differ in anything else (settings, horizon, changed data) keep their own, and the
row's notes say so.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from experiments.table_sources import SeedResult, normalized_scores

SAME_DATA_RTOL = 1e-6  # deterministic references of two builds of one dataset agree to ~1e-9 relative (measured)
DETERMINISTIC = ("expert_return", "zero_return", "hold_return")


def references_key(refs: dict[str, Any]) -> str:
    """A hashable, order-independent form of one set of references."""
    return json.dumps(refs, sort_keys=True)


def references_file(results_dir: Path, task: str) -> Path:
    """Where a task's committed references live."""
    return results_dir / "references" / f"{task}.json"


def committed_references(results_dir: Path) -> dict[str, dict[str, Any]]:
    """The committed references per task (``<results>/references/<task>.json``; none where the folder is missing)."""
    out = {}
    for path in sorted((results_dir / "references").glob("*.json")):
        refs = json.loads(path.read_text())
        if refs.get("task") != path.stem:
            raise ValueError(f"{path} holds the references of {refs.get('task')!r}, not of {path.stem!r}")
        out[path.stem] = refs
    return out


def task_references(results: list[SeedResult], committed: dict[str, dict[str, Any]] | None = None
                    ) -> dict[str, dict[str, Any]]:
    """Per task, its committed references, else those most of its evaluations were scored against (ties: the first
    in sort order)."""
    counts: dict[str, Counter] = {}
    for r in results:
        if r.references is not None:
            counts.setdefault(r.base_task, Counter())[references_key(r.references)] += 1
    majority = {task: json.loads(sorted(c.items(), key=lambda kv: (-kv[1], kv[0]))[0][0]) for task, c in counts.items()}
    return {**majority, **(committed or {})}


def same_data(own: dict[str, Any], task_refs: dict[str, Any]) -> bool:
    """Whether two sets of references were measured on the same data and settings (the dataset possibly another
    build of it): same settings and horizon, deterministic returns equal within ``SAME_DATA_RTOL``."""
    if own["env_settings"] != task_refs["env_settings"] or own["horizon"] != task_refs["horizon"]:
        return False
    return all(math.isclose(float(own[k]), float(task_refs[k]), rel_tol=SAME_DATA_RTOL, abs_tol=SAME_DATA_RTOL)
               for k in DETERMINISTIC)


def on_task_references(result: SeedResult, task_refs: dict[str, Any] | None) -> SeedResult:
    """``result`` rescored with its task's references where its own are another measurement on the same data (a
    copy; the file's references kept in ``own_references``); else ``result`` itself."""
    own = result.references
    if (own is None or task_refs is None or result.returns is None or own == task_refs
            or not same_data(own, task_refs)):
        return result
    return replace(result, references=task_refs, scores=normalized_scores(result.returns, task_refs),
                   own_references=own)


def own_scores(result: SeedResult) -> np.ndarray | None:
    """The per-episode scores under the references its evaluation file gave (None for a card)."""
    if result.returns is None or result.references is None:
        return None
    return normalized_scores(result.returns, result.own_references or result.references)
