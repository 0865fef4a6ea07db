"""Configs, the training loop with checkpoints, the launcher and evaluation scripts, inverse-dynamics actions."""

import csv
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import mujoco
import numpy as np
import pytest
import torch
import yaml

import loco_mujoco as lm
from loco_mujoco.policy_export import PolicyExport

# isort: split
from conftest import TINY_TRAINING  # noqa: E402

from baselines import ALGORITHMS  # noqa: E402
from baselines.common.inverse_dynamics import (  # noqa: E402
    controls_from_inverse,
    inverse_dynamics_actions,
    inverse_dynamics_report,
)
from baselines.common.machine import (  # noqa: E402
    cpu_generation,
    cpu_model,
    describe,
    read_machines,
    record_machine,
    usable_cpus,
    vector_isa,
)
from baselines.config import CONFIG_DIR, ConfigError, flat_config, load_run_config, parse_overrides  # noqa: E402
from baselines.export import export_checkpoint  # noqa: E402
from baselines.training import Trainer, load_checkpoint  # noqa: E402
from experiments.plot_results import config_changes  # noqa: E402
from loco_mujoco.core.task_names import DATASET_TYPES, list_tasks  # noqa: E402

REPO = Path(__file__).resolve().parent.parent
BASE_TASKS = [t for t in list_tasks() if t.split(".")[-1] not in DATASET_TYPES]


@pytest.fixture(scope="module", autouse=True)
def restore_torch_threads():
    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


# ---- configs -------------------------------------------------------------------------------------------
def test_every_task_has_a_valid_config_for_every_algorithm():
    assert len(BASE_TASKS) == 33
    for algorithm in ALGORITHMS:
        files = {p.stem for p in (CONFIG_DIR / algorithm).glob("*.yaml")}
        assert files == set(BASE_TASKS), (algorithm, set(BASE_TASKS) ^ files)
        for task in BASE_TASKS:
            run = load_run_config(task, algorithm)
            assert run.train.n_steps_per_fit >= 1 and run.train.epoch_steps % run.train.n_steps_per_fit == 0
            assert run.provenance["train.n_steps"].startswith(("configs/defaults.yaml", "configs/" + algorithm))


def test_flat_config_names_each_value_by_section_and_leaves_out_the_keys_asked():
    config = load_run_config("UnitreeH1.walk", "sqil").to_dict()
    flat = flat_config(config, leave_out=("sources", "agent.n_threads"))
    assert flat["task"] == "UnitreeH1.walk" and flat["agent.batch_size"] == config["agent"]["batch_size"]
    assert flat["env.control"] == config["env"]["control"] and flat["train.n_steps"] == config["train"]["n_steps"]
    assert "sources" not in flat and "agent.n_threads" not in flat and "agent" not in flat
    assert len(flat) == sum(len(config[s]) for s in ("env", "train", "agent")) - 1 + len(config) - 3 - 1


def test_config_layers_merge_in_order(tmp_path):
    (tmp_path / "vail").mkdir()
    (tmp_path / "defaults.yaml").write_text(yaml.safe_dump({
        "env": {"horizon": 500}, "train": {"n_steps": 1000, "epoch_steps": 500},
        "families": {"adversarial": {"train": {"n_steps_per_fit": 250}, "agent": {"std_0": 0.9, "max_kl": 0.01}},
                     "offline": {"train": {"epoch_steps": 100, "n_steps_per_fit": 1}}},
        "algorithms": {"vail": {"std_0": 0.7, "latent_dim": 16}}}))
    (tmp_path / "vail" / "UnitreeH1.walk.yaml").write_text(yaml.safe_dump({"agent": {"latent_dim": 8}}))
    run = load_run_config("UnitreeH1.walk", "vail", seed=3, config_dir=tmp_path,
                          overrides={"train": {"n_steps": 2000}})
    assert (run.env, run.train.n_steps, run.train.n_steps_per_fit, run.seed) == ({"horizon": 500}, 2000, 250, 3)
    assert (run.agent.std_0, run.agent.max_kl, run.agent.latent_dim) == (0.7, 0.01, 8)
    where = run.provenance
    assert where["env.horizon"].endswith("defaults.yaml") and where["train.n_steps"].startswith("command line")
    assert where["train.n_steps_per_fit"].endswith("[families.adversarial]")
    assert where["agent.std_0"].endswith("[algorithms.vail]")
    assert where["agent.latent_dim"].endswith("UnitreeH1.walk.yaml")
    assert where["agent.critic_lr"] == "VAILConfig default (baselines)"
    # a dataset type reuses its base task's file unless it has its own
    assert load_run_config("UnitreeH1.walk.perfect", "vail", config_dir=tmp_path).agent.latent_dim == 8
    (tmp_path / "vail" / "UnitreeH1.walk.perfect.yaml").write_text(yaml.safe_dump({"agent": {"latent_dim": 4}}))
    assert load_run_config("UnitreeH1.walk.perfect", "vail", config_dir=tmp_path).agent.latent_dim == 4
    (tmp_path / "bc").mkdir()
    (tmp_path / "bc" / "UnitreeH1.walk.yaml").write_text("# nothing particular\n")
    bc = load_run_config("UnitreeH1.walk", "bc", config_dir=tmp_path)  # its own family: no TRPO keys
    assert bc.train.epoch_steps == 100 and not hasattr(bc.agent, "max_kl")


def test_embodiment_layer_sits_between_the_algorithm_and_the_task_file(tmp_path):
    (tmp_path / "vail").mkdir()
    (tmp_path / "defaults.yaml").write_text(yaml.safe_dump({
        "train": {"n_steps": 1000, "epoch_steps": 500},
        "families": {"adversarial": {"train": {"n_steps_per_fit": 250}}},
        "algorithms": {"vail": {"latent_dim": 16}},
        "embodiments": {"Talos": {"env": {"control": "pd"}, "agent": {"latent_dim": 12}}}}))
    for task in ("Talos.walk", "Talos.carry", "Atlas.walk"):
        (tmp_path / "vail" / f"{task}.yaml").write_text("# nothing particular\n")
    walk = load_run_config("Talos.walk", "vail", config_dir=tmp_path)
    assert (walk.env, walk.agent.latent_dim) == ({"control": "pd"}, 12)  # over the algorithm's defaults
    assert walk.provenance["env.control"].endswith("[embodiments.Talos]")
    assert load_run_config("Talos.carry", "vail", config_dir=tmp_path).env == {"control": "pd"}  # every task of it
    assert load_run_config("Atlas.walk", "vail", config_dir=tmp_path).env == {}  # other embodiments untouched
    (tmp_path / "vail" / "Talos.walk.yaml").write_text(yaml.safe_dump({"env": {"control": "torque"}}))
    assert load_run_config("Talos.walk", "vail", config_dir=tmp_path).env == {"control": "torque"}  # the task wins
    for bad, match in [({"Tallos": {}}, r"embodiments.Tallos: .*Talos"),
                       ({"Talos": {"agnet": {}}}, r"unknown sections \['agnet'\] under embodiments.Talos")]:
        (tmp_path / "defaults.yaml").write_text(yaml.safe_dump({"train": {"n_steps": 1000},
                                                                 "families": {"adversarial": {}},
                                                                 "embodiments": bad}))
        with pytest.raises(ConfigError, match=match):
            load_run_config("Talos.walk", "vail", config_dir=tmp_path)


def test_a_tasks_committed_configs_share_one_control_mode():
    """Rows of one task in results/table.md differ by algorithm only: PD on every motor-driven humanoid."""
    for task, control in [("UnitreeH1.walk", "pd"), ("Talos.walk", "pd"), ("Atlas.walk", "pd"),
                          ("HumanoidTorque.walk", "pd"), ("HumanoidTorque4Ages.walk.all", "pd"),
                          ("UnitreeA1.simple", None), ("HumanoidMuscle.walk", None)]:  # None: their default
        assert {load_run_config(task, algo).env.get("control") for algo in ALGORITHMS} == {control}, task


@pytest.mark.parametrize("layer, match", [
    ({"agent": {"max_kll": 0.01}}, r"unknown VAILConfig keys \['max_kll'\]"),
    ({"agent": {"std_0": "wide"}}, r"std_0 must be float"),
    ({"env": {"random_strat": True}}, r"unknown env keys \['random_strat'\].*did you mean 'random_start'"),
    ({"train": {"n_step": 10}}, r"unknown train keys \['n_step'\].*did you mean 'n_steps'"),
    ({"train": {"epoch_steps": 1500}}, r"multiple of train.n_steps_per_fit"),
    ({"train": {"expert_actions": "guess"}}, r"one of dataset, inverse_dynamics, auto"),
    ({"agent": {"n_steps_per_fit": 500}}, r"unknown VAILConfig keys \['n_steps_per_fit'\]"),
    ({"trian": {}}, r"unknown sections \['trian'\]"),
    ({"agent": [1, 2]}, r"agent must be a mapping"),
])
def test_malformed_config_raises_naming_the_key(tmp_path, layer, match):
    shutil.copy(CONFIG_DIR / "defaults.yaml", tmp_path / "defaults.yaml")
    (tmp_path / "vail").mkdir()
    (tmp_path / "vail" / "UnitreeH1.walk.yaml").write_text(yaml.safe_dump(layer))
    with pytest.raises(ConfigError, match=match):
        load_run_config("UnitreeH1.walk", "vail", config_dir=tmp_path)


def test_bad_yaml_missing_file_and_unknown_names_raise(tmp_path):
    shutil.copy(CONFIG_DIR / "defaults.yaml", tmp_path / "defaults.yaml")
    (tmp_path / "vail").mkdir()
    (tmp_path / "vail" / "UnitreeH1.walk.yaml").write_text("agent: {std_0: [0.5\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_run_config("UnitreeH1.walk", "vail", config_dir=tmp_path)
    with pytest.raises(ConfigError, match="no config for vail on UnitreeH1.run"):
        load_run_config("UnitreeH1.run", "vail", config_dir=tmp_path)
    with pytest.raises(ConfigError, match="unknown algorithm 'vial'"):
        load_run_config("UnitreeH1.walk", "vial")
    with pytest.raises(ValueError, match="Did you mean 'UnitreeH1.walk'"):
        load_run_config("UnitreeH1.wakl", "vail")


def test_command_line_overrides_are_parsed_and_validated():
    overrides = parse_overrides(["train.n_steps_per_fit=5000", "agent.policy_hidden=[64, 32]", "env.horizon=500"])
    run = load_run_config("UnitreeH1.walk", "vail", overrides=overrides)
    assert run.train.n_steps_per_fit == 5000 and run.agent.policy_hidden == (64, 32) and run.env["horizon"] == 500
    for bad, match in [("agent.max_kl", "SECTION.KEY=VALUE"), ("max_kl=0.1", "SECTION.KEY=VALUE"),
                       ("policy.max_kl=0.1", "unknown section 'policy'"), ("agent.max_kl=[0.1", "not valid YAML")]:
        with pytest.raises(ConfigError, match=match):
            parse_overrides([bad])
    with pytest.raises(ConfigError, match="max_kll"):
        load_run_config("UnitreeH1.walk", "vail", overrides=parse_overrides(["agent.max_kll=0.1"]))


# ---- the training loop ---------------------------------------------------------------------------------
def tiny_run(algorithm="vail", n_steps=1200):
    overrides = {k: dict(v) for k, v in TINY_TRAINING.items()}
    overrides["train"]["n_steps"] = n_steps
    return load_run_config("UnitreeH1.walk", algorithm, seed=7, overrides=overrides)


def logged_rows(directory: Path) -> list[dict[str, str]]:
    with (directory / "progress.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def progress_rows(directory: Path) -> list[dict[str, str]]:
    """The log without its timing column (which differs between runs that compute the same)."""
    return [{k: v for k, v in row.items() if k != "train_steps_per_s"} for row in logged_rows(directory)]


def assert_identical(a, b, path="state"):
    """Bit-identical nested checkpoint contents (tensors, arrays, dicts, lists, scalars)."""
    assert type(a) is type(b), path
    if isinstance(a, torch.Tensor):
        assert torch.equal(a, b), path
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for key in a:
            assert_identical(a[key], b[key], f"{path}.{key}")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_identical(x, y, f"{path}[{i}]")
    else:
        assert a == b, path


def test_resumed_run_reproduces_the_uninterrupted_one_exactly(tmp_path):
    Trainer(tiny_run(), tmp_path / "straight", progress=False).train()
    Trainer(tiny_run(n_steps=400), tmp_path / "split", progress=False).train()  # "killed" after one epoch
    resumed = Trainer(tiny_run(n_steps=1200), tmp_path / "split", resume=True, progress=False)
    assert (resumed.epoch, resumed.steps) == (1, 400)
    resumed.train()
    a, b = load_checkpoint(tmp_path / "straight"), load_checkpoint(tmp_path / "split")
    assert a["steps"] == b["steps"] == 1200 and a["epoch"] == b["epoch"] == 3
    assert_identical(a["agent"], b["agent"])  # networks, optimisers, standardizers, generators, counters
    assert_identical(a["env_rng"], b["env_rng"])
    assert_identical(a["torch_rng"], b["torch_rng"])
    assert progress_rows(tmp_path / "straight") == progress_rows(tmp_path / "split")
    assert len(progress_rows(tmp_path / "split")) == 3
    here = describe()
    assert [(r["step"], r["machine"]) for r in read_machines(tmp_path / "straight")] == [("0", here)]
    assert [(r["step"], r["machine"]) for r in read_machines(tmp_path / "split")] == [("0", here), ("400", here)]


def test_snapshots_export_the_policy_at_each_multiple_and_a_resume_may_turn_them_on(tmp_path):
    run = tiny_run(n_steps=800)
    run.train.snapshot_every = 0
    Trainer(run, tmp_path, progress=False).train()
    assert not (tmp_path / "snapshots").exists()
    longer = tiny_run(n_steps=2000)
    longer.train.snapshot_every = 600  # epochs end at 1200, 1600, 2000: the first at or past 1200 and 1800
    resumed = Trainer(longer, tmp_path, resume=True, progress=False)
    assert resumed.run.train.snapshot_every == 600
    resumed.train()
    assert sorted(int(p.name) for p in (tmp_path / "snapshots").iterdir()) == [1200, 2000]
    snap = PolicyExport.load(tmp_path / "snapshots" / "2000")
    assert snap.card["steps"] == 2000 and snap.card["task"] == "UnitreeH1.walk" and snap.card["evaluation"] == {}
    assert set(snap.card["training_evaluation"]) >= {"R", "L", "score"}
    final = PolicyExport.load(export_checkpoint(tmp_path / "checkpoint.pt", tmp_path / "final"))
    obs = np.random.default_rng(0).normal(size=(5, resumed.env.info.observation_space.shape[0]))
    np.testing.assert_array_equal(snap.mean_action(obs), final.mean_action(obs))  # the checkpoint's policy
    assert not np.array_equal(PolicyExport.load(tmp_path / "snapshots" / "1200").mean_action(obs),
                              snap.mean_action(obs))
    with pytest.raises(ConfigError, match="snapshot_every must be >= 0"):
        load_run_config("UnitreeH1.walk", "vail", overrides={"train": {"snapshot_every": -1}})


def test_machine_log_drops_unsaved_stretches(tmp_path):
    record_machine(tmp_path, 0, 1)
    record_machine(tmp_path, 400, 2)
    record_machine(tmp_path, 400, 1)  # a resume from the same checkpoint replaces the stretch that saved nothing
    rows = read_machines(tmp_path)
    assert [(r["step"], r["torch_threads"], r["machine"]) for r in rows] == [("0", "1", describe()),
                                                                             ("400", "1", describe())]
    assert describe(16).endswith("(16 CPUs)") and describe(16).startswith(cpu_model()) and cpu_model()
    if platform.machine() == "x86_64":  # the vector instructions name the machine kind beside the model
        assert vector_isa() in ("AVX-512", "AVX2", "AVX") and f", {vector_isa()}, " in describe()
        family, model = cpu_generation().removeprefix("family ").split(" model ")  # e.g. Zen 4 against Zen 5
        assert family.isdigit() and model.isdigit()
        assert describe().endswith(f", {vector_isa()}, {cpu_generation()} ({usable_cpus()} CPUs)")


def test_resume_drops_log_rows_of_an_unsaved_epoch_and_refuses_mismatches(tmp_path):
    Trainer(tiny_run(n_steps=400), tmp_path, progress=False).train()
    with (tmp_path / "progress.csv").open("a") as f:  # an epoch logged, then killed before its checkpoint
        f.write("800,2" + "," * (len(progress_rows(tmp_path)[0]) - 2) + "\n")
    resumed = Trainer(tiny_run(n_steps=400), tmp_path, resume=True, progress=False, n_threads=2)
    assert [r["step"] for r in progress_rows(tmp_path)] == ["400"]
    assert resumed.run.agent.n_threads == 2 and resumed.run.train.n_steps == 400  # the two things a resume sets
    with pytest.raises(FileExistsError, match="--resume"):
        Trainer(tiny_run(), tmp_path, progress=False)
    with pytest.raises(ValueError, match="gaifo on UnitreeH1.walk"):
        Trainer(tiny_run("gaifo"), tmp_path, resume=True, progress=False)
    with pytest.raises(FileNotFoundError):
        Trainer(tiny_run(), tmp_path / "nothing", resume=True, progress=False)
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "checkpoint.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="not a readable checkpoint"):
        load_checkpoint(tmp_path / "bad")


def test_warm_start_loads_the_agent_continues_the_step_count_and_records_its_source(tmp_path):
    Trainer(tiny_run(n_steps=400), tmp_path / "source", progress=False).train()
    source = load_checkpoint(tmp_path / "source")
    run = tiny_run(n_steps=800)
    run.train.n_steps_per_fit = 400  # the kind of change a warm start is for: a larger batch per fit
    warm = Trainer(run, tmp_path / "warm", progress=False, init_from=tmp_path / "source")
    assert (warm.epoch, warm.steps) == (1, 400)
    loaded = {k: v for k, v in warm.agent.state_dict().items() if k != "config"}
    assert_identical(loaded, {k: v for k, v in source["agent"].items() if k != "config"})  # every tensor, loaded
    assert warm.run.init_from["steps"] == 400 and warm.run.init_from["run_config"]["train"]["n_steps_per_fit"] == 200
    warm.train()
    rows = progress_rows(tmp_path / "warm")
    assert [r["step"] for r in rows] == ["800"]  # only its own epochs, on the continued step count
    with (tmp_path / "warm" / "init_from_progress.csv").open(newline="") as f:  # the source's log, kept beside
        assert [r["step"] for r in csv.DictReader(f)] == ["400"]
    assert [r["step"] for r in read_machines(tmp_path / "warm")] == ["0", "400"]  # the source's machine, then its own
    assert config_changes(warm.run.init_from["run_config"], warm.run.to_dict()) == {
        "train.n_steps_per_fit": (200, 400)}
    saved = load_checkpoint(tmp_path / "warm")
    assert saved["run_config"]["init_from"]["checkpoint"] == str((tmp_path / "source" / "checkpoint.pt").resolve())
    assert saved["run_config"]["train"]["n_steps_per_fit"] == 400
    assert "init_from" in yaml.safe_load((tmp_path / "warm" / "config.yaml").read_text())
    with pytest.raises(ValueError, match="vail on UnitreeH1.walk; it cannot warm-start gaifo"):
        Trainer(tiny_run("gaifo", n_steps=800), tmp_path / "other", progress=False, init_from=tmp_path / "source")
    with pytest.raises(ValueError, match="must be larger"):
        Trainer(tiny_run(n_steps=400), tmp_path / "short", progress=False, init_from=tmp_path / "source")
    with pytest.raises(ValueError, match="give one of them"):
        Trainer(tiny_run(n_steps=800), tmp_path / "warm", resume=True, progress=False, init_from=tmp_path / "source")
    bigger = tiny_run(n_steps=800)
    bigger.agent.policy_hidden = (64,)
    with pytest.raises(ValueError, match="networks do not match"):
        Trainer(bigger, tmp_path / "bigger", progress=False, init_from=tmp_path / "source")


def test_launch_and_evaluate_scripts(tmp_path):
    config_dir = tmp_path / "configs"
    (config_dir / "gaifo").mkdir(parents=True)
    shutil.copy(CONFIG_DIR / "defaults.yaml", config_dir / "defaults.yaml")
    (config_dir / "gaifo" / "UnitreeH1.walk.yaml").write_text(yaml.safe_dump(TINY_TRAINING))
    out = tmp_path / "run"
    launch = [sys.executable, str(REPO / "experiments" / "launch.py"), "--env", "UnitreeH1.walk", "--algo", "gaifo",
              "--steps", "400", "--out", str(out), "--config-dir", str(config_dir), "--quiet"]
    done = subprocess.run(launch, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    assert (out / "checkpoint.pt").exists() and "L=" in done.stdout
    again = subprocess.run(launch, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert again.returncode == 2 and "--resume" in again.stderr
    changed = subprocess.run([*launch, "--resume", "--set", "agent.max_kl=0.1"], capture_output=True, text=True,
                             cwd=tmp_path, timeout=300)
    assert changed.returncode == 2 and "--init-from" in changed.stderr
    evaluate = [sys.executable, str(REPO / "experiments" / "evaluate.py"), str(out / "checkpoint.pt"),
                "--episodes", "2", "--json", str(tmp_path / "eval.json")]
    done = subprocess.run(evaluate, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "deterministic: score" in done.stdout and "random R" in done.stdout
    result = yaml.safe_load((tmp_path / "eval.json").read_text())
    assert result["steps"] == 400 and result["deterministic"]["statistics"]["episodes"] == 2
    assert 1 <= result["deterministic"]["statistics"]["L"] <= 100
    assert result["deterministic"]["score"]["n"] == 2
    written = yaml.safe_load((out / "config.yaml").read_text())
    assert written["dataset"]["file"].startswith("UnitreeH1.walk.real.") and len(written["dataset"]["sha256"]) == 64
    progress = (out / "progress.csv").read_text().splitlines()
    assert "score" in progress[0].split(",")  # every epoch logs the normalised score


# ---- inverse-dynamics expert actions ---------------------------------------------------------------------
@pytest.mark.parametrize("control", ["torque", "pd"])
def test_inverse_dynamics_recovers_the_controls_of_forward_dynamics(control):
    env = lm.LocoEnv.make("UnitreeH1.walk", control=control)
    model, data = env._model, mujoco.MjData(env._model)
    qpos, qvel = env.dataset_states(np.array([50]))
    rng = np.random.default_rng(0)
    data.qpos[:], data.qvel[:] = qpos[0], qvel[0]
    data.qpos[2] -= 0.003  # feet in contact
    if control == "torque":
        data.ctrl[:] = env.action_to_ctrl(rng.uniform(-0.5, 0.5, model.nu))
    else:  # targets near the joints, so that the servos stay inside their force limits (clipping is lossy)
        data.ctrl[:] = data.qpos[model.jnt_qposadr[model.actuator_trnid[:, 0]]] + rng.uniform(-0.02, 0.02, model.nu)
    mujoco.mj_forward(model, data)
    assert data.ncon > 0
    limited = model.actuator_forcelimited.astype(bool)
    assert np.all(np.abs(data.actuator_force[limited]) < model.actuator_forcerange[limited, 1])
    expected = data.ctrl.copy()
    data.ctrl[:] = 0
    mujoco.mj_inverse(model, data)
    np.testing.assert_allclose(controls_from_inverse(model, data), expected, rtol=1e-6, atol=1e-6)


def test_inverse_dynamics_actions_fit_the_dataset_and_refuse_muscles():
    env = lm.LocoEnv.make("UnitreeH1.walk")
    actions = inverse_dynamics_actions(env)
    assert actions.shape == (len(env.create_dataset()["states"]), env.info.action_space.shape[0])
    assert actions.dtype == np.float32 and np.all(np.abs(actions) <= 1.0)
    report = inverse_dynamics_report(env)
    assert 0.0 < report["sink_m"] < 0.01  # the floor carries the weight after a few millimetres
    assert abs(report["root_vertical_over_weight_median"]) < 0.1
    assert report["clipped_fraction"] < 0.2
    with pytest.raises(ValueError, match="affine"):
        inverse_dynamics_actions(lm.LocoEnv.make("HumanoidMuscle.walk"))


def test_logger_mirrors_scalars_to_tensorboard(tmp_path):
    pytest.importorskip("tensorboard")
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    from baselines.common import CSVLogger

    logger = CSVLogger(tmp_path)
    logger.log(1000, R=1.5, L=20)
    logger.log(2000, R=2.5, L=30)
    logger.close()
    events = EventAccumulator(str(tmp_path / "tensorboard"))
    events.Reload()
    assert [(e.step, e.value) for e in events.Scalars("R")] == [(1000, 1.5), (2000, 2.5)]
    assert [e.value for e in events.Scalars("L")] == [20, 30]


def test_a_deadline_stops_the_run_after_the_last_checkpoint_that_fits(tmp_path, monkeypatch):
    """With a fake clock on which each epoch takes 200 s, a deadline 350 s away stops after epoch 1 and 550 s after
    epoch 2; a deadline already past trains nothing; resumed, a run expects its next epoch to take as long as its
    log's last rate says, and a far deadline lets it finish."""
    import types

    import baselines.training as training

    clock = {"now": 1_000_000.0}

    def perf_counter() -> float:  # every reading moves the clock: three readings per epoch, 100 s apart
        clock["now"] += 100.0
        return clock["now"]

    monkeypatch.setattr(training, "time", types.SimpleNamespace(time=lambda: clock["now"], perf_counter=perf_counter))
    for allowed, epochs in ((350.0, 1), (550.0, 2)):
        trainer = Trainer(tiny_run(), tmp_path / f"limit{allowed:.0f}", progress=False)
        trainer.train(deadline=clock["now"] + allowed)
        assert trainer.stopped_at_deadline and (trainer.epoch, trainer.steps) == (epochs, 400 * epochs)
        assert load_checkpoint(tmp_path / f"limit{allowed:.0f}")["steps"] == 400 * epochs
        assert len(progress_rows(tmp_path / f"limit{allowed:.0f}")) == epochs
    late = Trainer(tiny_run(), tmp_path / "late", progress=False)
    assert late.train(deadline=clock["now"] - 1.0) == {} and late.stopped_at_deadline and late.steps == 0
    assert not (tmp_path / "late" / "checkpoint.pt").exists()

    monkeypatch.undo()  # real time: the log's rate (steps per second of learning) sizes the first epoch
    before = load_checkpoint(tmp_path / "limit350")
    resumed = Trainer(tiny_run(), tmp_path / "limit350", resume=True, progress=False)
    logged = float(logged_rows(tmp_path / "limit350")[-1]["train_steps_per_s"])
    assert logged == pytest.approx(400 / 100.0)  # learning took 100 fake seconds
    resumed.train(deadline=time.time() + 0.5 * 400 / logged)  # half the expected epoch left
    assert resumed.stopped_at_deadline and resumed.steps == 400
    assert_identical(load_checkpoint(tmp_path / "limit350")["agent"], before["agent"])
    resumed = Trainer(tiny_run(), tmp_path / "limit350", resume=True, progress=False)
    resumed.train(deadline=time.time() + 3600.0)
    assert not resumed.stopped_at_deadline and resumed.steps == 1200
