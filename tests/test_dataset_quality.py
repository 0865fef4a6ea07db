"""Every humanoid dataset meets the contact-quality goals; foot locking is what gets it there."""

import numpy as np
import pytest

from experiments.build_datasets import real_datasets
from loco_mujoco.datasets import registry
from loco_mujoco.datasets.foot_lock import FootLockSettings, stance_phases
from loco_mujoco.datasets.quality import GOALS, quality_violations
from loco_mujoco.datasets.sources.fetch import default_sources_root

needs_sources = pytest.mark.skipif(default_sources_root() is None,
                                   reason="needs ../shared/mocap or LOCO_MUJOCO_SOURCES")


def _humanoid_datasets():
    if default_sources_root() is None:
        return []
    return [(cls, task, mode, variant) for cls, task, mode, variant in real_datasets()
            if registry.dataset_kind(cls) == "human"]


def _label(entry) -> str:
    cls, task, mode, variant = entry
    return ".".join([cls.__name__, task] + ([mode] if mode else []) + [variant])


@needs_sources
@pytest.mark.parametrize("entry", _humanoid_datasets(), ids=_label)
def test_humanoid_dataset_meets_the_quality_goals(entry):
    cls, task, mode, variant = entry
    meta = registry.load_dataset(cls, task, variant, progress=False, mode=mode).metadata
    assert quality_violations(meta) == []
    assert meta["quality"]["foot_sliding_mps"] <= GOALS.sliding_mean_mps


def test_quality_violations_name_each_missed_goal():
    meta = {"task": "walk", "quality": {"foot_sliding_mps": 0.05, "foot_sliding_p95_mps": 0.3,
                                        "ground_penetration_max_m": 0.01, "flight_fraction": 0.02},
            "trajectories": [{"name": "clip", "source": "x.bvh", "quality": {
                "heading_change_deg": 5.0, "mean_travel_forward_mps": 0.3, "mean_speed_mps": 1.0}}]}
    problems = quality_violations(meta)
    assert len(problems) == 5
    assert any("flight 2.0%" in p for p in problems) and any("x.bvh" in p for p in problems)
    meta["task"] = "run"  # running may fly; a turning clip is not held to the straight-clip rule
    meta["trajectories"][0]["quality"]["heading_change_deg"] = 90.0
    assert len(quality_violations(meta)) == 3


def test_walking_stance_phases_leave_no_flight_and_use_hysteresis():
    t = np.arange(200) / 100.0
    # two feet alternating, with a few frames at each change where both are in the air
    height = np.stack([0.05 * (np.sin(2 * np.pi * t) > -0.1), 0.05 * (np.sin(2 * np.pi * t) < 0.1)], axis=1)
    speed = np.where(height > 0, 2.0, 0.0)
    walking = stance_phases(height, speed, 100.0, True, FootLockSettings())
    running = stance_phases(height, speed, 100.0, False, FootLockSettings())
    assert walking.any(axis=1).all()
    assert not running.any(axis=1).all()
    # a foot that dips below the landing height for one frame while fast does not land
    h = np.zeros((50, 2))
    h[:, 0] = 0.05
    h[20, 0] = 0.0
    s = np.zeros((50, 2))
    s[:, 0] = 2.0
    phases = stance_phases(h, s, 100.0, False, FootLockSettings())
    assert not phases[:, 0].any() and phases[:, 1].all()
