"""The layers only look down (models -> datasets -> core -> environments): datasets never see an environment."""

from __future__ import annotations

import ast
from pathlib import Path

import mujoco
import numpy as np
import pytest

import loco_mujoco as lm
from loco_mujoco.core.task_names import environment_class
from loco_mujoco.datasets import registry

DATASETS = Path(lm.__file__).parent / "datasets"
ABOVE_DATASETS = ("loco_mujoco.core", "loco_mujoco.environments")


def _is_above(module: str) -> bool:
    return any(module == m or module.startswith(m + ".") for m in ABOVE_DATASETS)


def _imports_from_above(source: str, package: str) -> list[str]:
    """The imports in ``source`` of a module in ``package`` (at run time or under TYPE_CHECKING alike) that reach
    core or the environments."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if _is_above(a.name)]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: resolve against the module's package
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([node.module] if node.module else []))
            if _is_above(base):
                found.append(base)
            elif base == "loco_mujoco":  # from loco_mujoco import core / LocoEnv / UnitreeH1 ...
                found += [f"{base}.{a.name}" for a in node.names if _is_above(f"{base}.{a.name}")
                          or _is_above(getattr(getattr(lm, a.name, None), "__module__", None) or "")]
    return found


def test_datasets_never_import_core_or_environments():
    files = sorted(DATASETS.rglob("*.py"))
    assert len(files) > 5
    root = DATASETS.parent.parent
    bad = {}
    for path in files:
        package = ".".join(path.relative_to(root).parts[:-1])
        if imports := _imports_from_above(path.read_text(), package):
            bad[str(path.relative_to(root))] = imports
    assert not bad, f"modules under loco_mujoco/datasets import layers above them: {bad}"


@pytest.mark.parametrize("source", [
    "import loco_mujoco.core.loco_env", "from loco_mujoco.environments import UnitreeH1",
    "from loco_mujoco import core", "from loco_mujoco import LocoEnv", "from .. import environments",
    "from ..core.loco_env import LocoEnv", "if TYPE_CHECKING:\n    from loco_mujoco.core.loco_env import LocoEnv",
    "def f():\n    from loco_mujoco.core import loco_env"])
def test_the_layer_check_sees_every_import_form(source):
    assert _imports_from_above(source, "loco_mujoco.datasets")


def test_the_layer_check_allows_lower_layers():
    source = "import loco_mujoco\nfrom loco_mujoco.models import spec_edit\nfrom . import motion\nfrom .. import models"
    assert not _imports_from_above(source, "loco_mujoco.datasets")


@pytest.fixture
def no_environments(monkeypatch):
    """Constructing any environment fails the test."""
    def refuse(self, *args, **kwargs):
        raise AssertionError(f"{type(self).__name__} was constructed while building a dataset")

    monkeypatch.setattr(lm.LocoEnv, "__init__", refuse)


def test_building_a_dataset_constructs_no_environment(no_environments):
    subject = lm.UnitreeA1.dataset_subject()
    target = subject.target("simple", None)
    assert target.label == "UnitreeA1.simple" and target.model.nq == len(target.home_qpos)
    ds = registry.build_dataset(subject, "simple", "noncommercial", progress=False)
    assert ds.n_frames > 100 and ds.metadata["env"] == "UnitreeA1"
    # the default (permissive) variant is simulated above the datasets layer, which refuses to build it
    with pytest.raises(registry.GeneratedDatasetError, match="controller"):
        registry.build_dataset(subject, "simple", progress=False)
    with pytest.raises(AssertionError, match="constructed"):
        lm.UnitreeA1()


def _model_arrays(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    names = ("body_pos", "body_quat", "body_mass", "body_inertia", "jnt_qposadr", "jnt_range", "qpos0",
             "geom_size", "geom_pos", "actuator_ctrlrange", "actuator_gainprm")
    return {n: getattr(model, n) for n in names}


@pytest.mark.parametrize("name, task, mode", [("UnitreeH1", "carry", None), ("UnitreeA1", "simple", None),
                                              ("Atlas", "walk", None), ("HumanoidMuscle", "walk", None),
                                              ("HumanoidTorque4Ages", "walk", "2")])
def test_retarget_target_is_the_model_the_environment_simulates(name, task, mode):
    env_cls = environment_class(name)
    target = env_cls.dataset_subject().target(task, mode)
    env = env_cls(task=task, mode=mode, disable_arms=False, reward_type="none")
    try:
        assert target.spec is env_cls.RETARGET
        assert [target.model.body(b).name for b in range(target.model.nbody)] == \
               [env.model.body(b).name for b in range(env.model.nbody)]
        np.testing.assert_array_equal(target.home_qpos, env.home_qpos(env.model))
        for field, value in _model_arrays(env.model).items():
            np.testing.assert_array_equal(getattr(target.model, field), value, err_msg=field)
    finally:
        env.stop()


def test_subject_describes_the_environment_class():
    subject = environment_class("HumanoidTorque4Ages").dataset_subject()
    assert subject.name == "HumanoidTorque4Ages" and subject.sizes == ("1", "2", "3", "4")
    assert subject.tasks == ("walk", "run")
    assert lm.UnitreeH1.dataset_subject().old_format_joints["knee_angle_l"] == "left_knee"
    with pytest.raises(ValueError, match="invalid task 'fly'; valid: walk, run, carry"):
        lm.UnitreeH1.dataset_subject().target("fly", None)
    with pytest.raises(registry.DatasetUnavailableError, match="UnitreeH1.fly has no real dataset"):
        registry.variants(lm.UnitreeH1.dataset_subject(), "fly")
