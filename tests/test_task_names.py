import pytest
from mushroom_rl.core import Environment

import loco_mujoco as lm
from loco_mujoco.core.task_names import parse_task_name

EXPECTED = ["UnitreeH1.walk", "UnitreeH1.run", "UnitreeH1.carry", "Talos.walk", "Talos.carry",
            "UnitreeA1.simple", "UnitreeA1.hard", "Atlas.walk", "Atlas.carry", "HumanoidTorque.walk",
            "HumanoidTorque.run", "HumanoidMuscle.walk", "HumanoidMuscle.run"]
EXPECTED += [f"{env}4Ages.{task}.{mode}" for env in ("HumanoidTorque", "HumanoidMuscle") for task in ("walk", "run")
             for mode in ("all", "1", "2", "3", "4")]


def test_list_tasks_has_every_task_and_dataset_type():
    tasks = lm.list_tasks()
    for base in EXPECTED:
        assert base in tasks
        for dataset_type in ("real", "perfect", "preference"):
            assert f"{base}.{dataset_type}" in tasks
    assert len(tasks) == len(set(tasks)) == 4 * len(EXPECTED)


@pytest.mark.parametrize("name", ["UnitreeH1.walk", "UnitreeH1.walk.perfect", "UnitreeA1.hard.preference"])
def test_every_listed_name_parses_back(name):
    parsed = parse_task_name(name)
    assert name.startswith(f"{parsed.env}.{parsed.task}")
    assert parsed.dataset_type == (name.split(".")[2] if name.count(".") == 2 else "real")


@pytest.mark.parametrize("bad, suggestion", [
    ("UnitreeH1.wlak", "UnitreeH1.walk"),
    ("UnitreH1.walk", "UnitreeH1.walk"),
    ("Talos.run", "Talos.carry"),
    ("UnitreeH1.walk.realistic", "UnitreeH1.walk.real"),
])
def test_unknown_names_raise_with_suggestion(bad, suggestion):
    with pytest.raises(ValueError) as err:
        lm.LocoEnv.make(bad)
    msg = str(err.value)
    assert f"'{suggestion}'" in msg and "Did you mean" in msg
    assert bad in msg


@pytest.mark.parametrize("bad", ["", "UnitreeH1", "UnitreeH1.walk.real.extra", "UnitreeH1.walk.adult"])
def test_malformed_names_raise_value_error(bad):
    with pytest.raises(ValueError, match="Unknown|non-empty"):
        parse_task_name(bad)


def test_unknown_keyword_choices_name_the_valid_ones():
    with pytest.raises(ValueError, match="torque, pd"):
        lm.UnitreeH1(control="velocity")
    with pytest.raises(ValueError, match="none"):
        lm.UnitreeH1(reward_type="distance")
    with pytest.raises(ValueError, match="has no modes"):
        lm.UnitreeH1(mode="adult")


def test_mushroom_environment_make_builds_the_same_env():
    env = Environment.make("UnitreeA1.hard.real")
    assert isinstance(env, lm.UnitreeA1)
    assert (env.task_name, env.dataset_type) == ("hard", "real")
    with pytest.raises(ValueError, match="UnitreeA1.hard.perfect has no data"):
        Environment.make("UnitreeA1.hard.perfect")


def test_list_tasks_with_data_keeps_only_buildable_names():
    names = lm.list_tasks(with_data=True)
    assert "UnitreeH1.walk.perfect" in names and "UnitreeH1.walk.preference" in names
    assert "UnitreeA1.hard.perfect" not in names and "UnitreeH1.run.preference" not in names
    assert "UnitreeH1.run" in names and "UnitreeH1.run.real" in names
    assert set(names) < set(lm.list_tasks())
