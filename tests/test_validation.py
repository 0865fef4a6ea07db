"""No silent mistakes: every entry point rejects wrong input with our own error naming it, before any work."""

import json
import os
import shutil
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import loco_mujoco as lm
from baselines.config import CONFIG_DIR, ConfigError, load_run_config, parse_overrides
from baselines.training import load_checkpoint
from loco_mujoco.core.parameters import ENV_PARAMETERS, ParameterError
from loco_mujoco.datasets.loco_format import load_any_dataset
from loco_mujoco.policy_export import ExportError, PolicyExport

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))
VAIL_RUN = REPO / "results/runs/UnitreeH1.walk_vail_from15.3M"  # finished: its log and config; the agent is exported
VAIL_PRETRAINED = ["--pretrained", "UnitreeH1.walk", "vail"]


# ---- arguments ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("make", [lambda **kw: lm.LocoEnv.make("UnitreeH1.walk", **kw),
                                  lambda **kw: gym.make("LocoMujoco", env_name="UnitreeH1.walk", **kw)])
def test_misspelt_keyword_raises_with_a_suggestion(make):
    with pytest.raises(ParameterError, match=r"\['contrl'\] \(did you mean 'control'\?\); valid: .*horizon"):
        make(contrl="pd")


@pytest.mark.parametrize("kwargs, match", [
    ({"horizon": 0}, r"horizon must be an int >= 1.*got 0"), ({"horizon": -5}, "horizon must be"),
    ({"horizon": "1000"}, r"horizon must be.*'1000' \(str\)"), ({"horizon": True}, "horizon must be"),
    ({"gamma": 2.0}, r"gamma must be a number in \(0, 1\]"), ({"gamma": 0}, "gamma must be"),
    ({"random_start": "no"}, "random_start must be True or False"), ({"control": 3}, "control must be"),
    ({"control": "pdd"}, "invalid control.*valid: torque, pd"), ({"timestep": -0.01}, "timestep must be"),
    ({"n_substeps": 2.5}, "n_substeps must be"), ({"seed": -1}, "seed must be"),
    ({"init_step_no": -3}, "init_step_no must be"), ({"weight_mass": float("nan")}, "weight_mass must be"),
])
def test_wrong_types_and_ranges_raise_naming_the_parameter(kwargs, match):
    with pytest.raises(ValueError, match=match):
        lm.LocoEnv.make("UnitreeH1.walk", **kwargs)


# ---- YAML and the command line ---------------------------------------------------------------------------
def _config(tmp_path, task_yaml: str):
    shutil.copy(CONFIG_DIR / "defaults.yaml", tmp_path / "defaults.yaml")
    (tmp_path / "vail").mkdir(exist_ok=True)
    (tmp_path / "vail" / "UnitreeH1.walk.yaml").write_text(task_yaml)
    return lambda: load_run_config("UnitreeH1.walk", "vail", config_dir=tmp_path)


@pytest.mark.parametrize("text, match", [
    ('env: {random_start: "no"}', r"UnitreeH1.walk.yaml: env.random_start must be True or False, got 'no'"),
    ('env: {gamma: "0.99"}', r"env.gamma must be a number in \(0, 1\], got '0.99'"),
    ('env: {horizon: "1000"}', r"env.horizon must be an int >= 1.*'1000'"),
    ('agent: {max_kl: "0.01"}', r"max_kl must be float, got '0.01'"),
    ("agent: {std_0: 0.3, std_0: 0.5}", r"duplicate key 'std_0' at line 1"),
    ("agent:\n  max_kl: 0.01\nagent:\n  std_0: 0.3\n", r"duplicate key 'agent' at line 3 \(first at line 1\)"),
])
def test_yaml_is_strict_and_errors_name_the_file_and_key(tmp_path, text, match):
    with pytest.raises(ConfigError, match=match):
        _config(tmp_path, text)()


def test_command_line_value_fails_before_anything_is_created(tmp_path):
    from experiments.launch import main

    out = tmp_path / "run"
    assert main(["--env", "UnitreeH1.walk", "--algo", "vail", "--set", 'env.horizon="1000"', "--out", str(out)]) == 2
    assert not out.exists()
    with pytest.raises(ConfigError, match=r"command line.*env.horizon must be"):
        load_run_config("UnitreeH1.walk", "vail", overrides=parse_overrides(['env.horizon="1000"']))
    for bad in (["--threads", "0"], ["--steps", "-5"]):
        assert main(["--env", "UnitreeH1.walk", "--algo", "vail", "--out", str(out), *bad]) == 2
    assert not out.exists()


# ---- files -------------------------------------------------------------------------------------------------
def test_dataset_files_that_cannot_be_read_name_the_file(tmp_path):
    garbage, truncated = tmp_path / "garbage.npz", tmp_path / "truncated.npz"
    garbage.write_bytes(b"\x80\x04not a dataset")
    real = lm.LocoEnv.make("UnitreeH1.walk").dataset.source_file
    truncated.write_bytes(Path(real).read_bytes()[:3000])
    for path in (garbage, truncated):
        with pytest.raises(ValueError, match=f"{path}: not a dataset file"):
            lm.LocoEnv.make("UnitreeH1.walk", dataset_path=path)
    with pytest.raises(FileNotFoundError, match=f"dataset_path {tmp_path / 'missing.npz'} does not exist"):
        lm.LocoEnv.make("UnitreeH1.walk", dataset_path=tmp_path / "missing.npz")


def test_a_cache_variable_pointing_nowhere_is_named(tmp_path, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    monkeypatch.setenv("LOCO_MUJOCO_CACHE", str(blocker / "cache"))
    with pytest.raises(OSError, match=f"LOCO_MUJOCO_CACHE='{blocker / 'cache'}' is not usable"):
        lm.LocoEnv.make("Talos.walk")


def test_outputs_that_cannot_be_written_fail_before_the_work(tmp_path):
    from experiments.evaluate import main as evaluate

    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    start = time.perf_counter()
    assert evaluate([*VAIL_PRETRAINED, "--episodes", "1", "--json", str(blocker / "out.json")]) == 2
    assert time.perf_counter() - start < 5  # refused before building the agent or running an episode
    existing = tmp_path / "eval.json"
    existing.write_text("{}")
    assert evaluate([*VAIL_PRETRAINED, "--episodes", "1", "--json", str(existing)]) == 2
    assert existing.read_text() == "{}"  # never overwritten unasked


# ---- run folders and results ----------------------------------------------------------------------------------
TINY = ["--set", "env.horizon=50", "--set", "train.n_eval_episodes=1", "--set", "train.epoch_steps=1000",
        "--set", "agent.policy_hidden=[16]", "--set", "agent.critic_hidden=[16]", "--set", "agent.disc_hidden=[16]",
        "--set", "agent.n_threads=1", "--quiet"]


def test_run_folders_steps_and_the_final_message(tmp_path, capsys):
    from experiments.launch import main

    out = tmp_path / "run"
    assert main(["--env", "UnitreeH1.walk", "--algo", "gaifo", "--steps", "1500", "--out", str(out), *TINY]) == 0
    captured = capsys.readouterr()
    assert "not a multiple of train.n_steps_per_fit (1,000); training 2,000 steps" in captured.err
    assert f"checkpoint: {out / 'checkpoint.pt'}" in captured.out
    assert load_checkpoint(out)["steps"] == 2000
    other = tmp_path / "other"
    other.mkdir()
    (other / "progress.csv").write_text("step,R\n5,1\n")  # another run's log, no checkpoint
    assert main(["--env", "UnitreeH1.walk", "--algo", "gaifo", "--steps", "1000", "--out", str(other), *TINY]) == 2
    assert "holds another run's files (progress.csv)" in capsys.readouterr().err
    assert (other / "progress.csv").read_text() == "step,R\n5,1\n"
    failed = tmp_path / "failed"  # GAIL on real data without inverse dynamics fails while building the agent
    assert main(["--env", "UnitreeH1.walk", "--algo", "gail", "--steps", "1000", "--out", str(failed),
                 "--set", "train.expert_actions=dataset", *TINY]) == 2
    assert not failed.exists()  # a failed start leaves nothing behind


def test_plot_results_never_replaces_files_it_did_not_write(tmp_path):
    from experiments.plot_results import main as plot

    run = tmp_path / "run"
    shutil.copytree(VAIL_RUN, run)
    assert not (run / "checkpoint.pt").exists()  # plotted from its config.yaml
    assert plot([str(run)]) == 0  # beside the run by default
    assert (run / "UnitreeH1.walk_vail_from15.3M.png").exists()
    results = tmp_path / "results"
    results.mkdir()
    committed = results / "UnitreeH1.walk_vail_from15.3M.csv"
    committed.write_text("step\n1\n")
    assert plot([str(run), "--out", str(results)]) == 2
    assert committed.read_text() == "step\n1\n"
    assert plot([str(run), "--out", str(results), "--force"]) == 0
    assert committed.read_text() != "step\n1\n"
    assert plot([str(results)]) == 2  # neither a checkpoint nor a config.yaml
    from baselines.training import run_config_from_directory

    with pytest.raises(FileNotFoundError, match="neither checkpoint.pt nor config.yaml: not a run directory"):
        run_config_from_directory(results)
    assert run_config_from_directory(run).init_from["steps"] == 15_300_000


# ---- fuzz -----------------------------------------------------------------------------------------------------
POOL = [None, True, False, 0, -1, 7, 1.5, -2.5, float("nan"), float("inf"), "", "x", "1000", "0.99", [], [1, 2],
        {}, {"a": 1}, b"\x00\xff", 10**12, np.int64(3), np.float32(0.5), object()]


def _allowed(name, value):
    rule = ENV_PARAMETERS[name]
    return (value is None and rule.optional) or (value is not None and rule.accepts(value))


def test_fuzz_entry_points_fail_with_our_errors_naming_the_input(tmp_path):
    """Random keyword arguments, YAML values and bytes, fixed seed: every failure is a ValueError or OSError of
    ours naming the input, never a bare traceback from numpy, zipfile, torch, yaml or Mushroom-RL."""
    rng = np.random.default_rng(2026)
    deadline = time.perf_counter() + 50
    names = [n for n in ENV_PARAMETERS if n not in ("task", "mode", "dataset_type", "disable_back_joint")]
    n_cases = 0
    for _ in range(150):  # keyword arguments: each case holds at least one value its rule rejects
        name = names[rng.integers(len(names))]
        bad = [v for v in POOL if not _allowed(name, v)]
        kwargs = {name: bad[rng.integers(len(bad))]}
        if rng.random() < 0.3:
            kwargs["".join(rng.choice(list("abcdefgh_"), size=6))] = 1  # an unknown name too
        with pytest.raises((ValueError, OSError)) as info:
            lm.LocoEnv.make("UnitreeH1.walk", **kwargs)
        assert any(k in str(info.value) for k in kwargs), (kwargs, info.value)
        n_cases += 1
    defaults = (CONFIG_DIR / "defaults.yaml").read_text()
    for i in range(60):  # YAML values in every section
        section = ("env", "train", "agent")[rng.integers(3)]
        key = {"env": ["horizon", "gamma", "random_start", "control"],
               "train": ["n_steps", "epoch_steps", "eval_seed", "expert_actions"],
               "agent": ["std_0", "max_kl", "policy_hidden", "n_threads"]}[section][rng.integers(4)]
        value = POOL[rng.integers(len(POOL) - 1)]  # all but object(), which YAML cannot write
        config = tmp_path / f"c{i}"
        (config / "vail").mkdir(parents=True)
        (config / "defaults.yaml").write_text(defaults)
        text = yaml.safe_dump({section: {key: value.item() if isinstance(value, np.generic) else value}})
        (config / "vail" / "UnitreeH1.walk.yaml").write_text(text)
        try:
            load_run_config("UnitreeH1.walk", "vail", config_dir=config)
        except ConfigError as err:
            assert key in str(err) and "UnitreeH1.walk.yaml" in str(err), (section, key, value, err)
        n_cases += 1
    for i in range(40):  # random bytes as every kind of file
        blob = rng.bytes(int(rng.integers(0, 4000)))
        path = tmp_path / f"blob{i}"
        path.write_bytes(blob if i % 4 else b"PK\x03\x04" + blob)  # some look like zip archives
        for read in (lambda p: load_any_dataset(lm.UnitreeH1.dataset_subject(), p), load_checkpoint):
            with pytest.raises(ValueError) as info:
                read(path)
            assert str(path) in str(info.value)
        config = tmp_path / f"y{i}"
        (config / "vail").mkdir(parents=True)
        (config / "defaults.yaml").write_text(defaults)
        (config / "vail" / "UnitreeH1.walk.yaml").write_bytes(blob)
        with pytest.raises(ConfigError) as info:
            load_run_config("UnitreeH1.walk", "vail", config_dir=config)
        assert "UnitreeH1.walk.yaml" in str(info.value)
        export = tmp_path / f"e{i}"
        export.mkdir()
        for name in ("policy.safetensors", "card.json", "config.yaml"):
            (export / name).write_bytes(blob)
        with pytest.raises(ExportError, match=str(export)):
            PolicyExport.load(export)
        n_cases += 1
    assert time.perf_counter() < deadline and n_cases == 250
    assert json.dumps(n_cases) and os.getpid()  # the loop ran to the end
