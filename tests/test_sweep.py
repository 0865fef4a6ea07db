"""Sweeps on Ray: trials run to completion, a re-run changes no file, more steps resume, a folder holding another
run is refused, a failing trial is shown, and malformed sweep files fail naming the key."""

import csv
import hashlib
import io
import json
import shutil
import sys
from pathlib import Path

import pytest
import yaml

from baselines.training import load_checkpoint
from experiments import sweep
from experiments.land_run import PARKED_FILES
from experiments.sweep_plan import (
    DirState,
    RunDirConflict,
    Trial,
    adopt_parked,
    inspect_run_dir,
    make_trials,
    parked_source,
)
from experiments.sweep_spec import SweepSpecError, build_spec, read_sweep_file
from experiments.sweep_status import LiveTable, TrialStatus, render

# The cheapest trial the repo allows: BC on the perfect dataset, tiny network, 100 gradient steps per epoch,
# one 50-step evaluation episode.
TINY = ["--tasks", "UnitreeH1.walk.perfect", "--algos", "bc", "--set", "train.epoch_steps=100",
        "--set", "train.n_eval_episodes=1", "--set", "env.horizon=50", "--set", "agent.policy_hidden=[32]",
        "--set", "agent.batch_size=64"]


@pytest.fixture(scope="module")
def local_ray():
    ray = pytest.importorskip("ray", reason='the sweep extra: pip install -e ".[sweep]"')
    sweep._init_ray(ray, sweep.parse_args(["--num-cpus", "1"]))  # the sweep's own local start, on one CPU
    yield ray
    ray.shutdown()


def files(folder: Path) -> dict[str, tuple[str, int]]:
    """Every file under ``folder``: its sha256 and modification time."""
    return {p.relative_to(folder).as_posix(): (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
            for p in sorted(folder.rglob("*")) if p.is_file()}


def log_rows(run: Path) -> list[dict[str, str]]:
    with (run / "progress.csv").open(newline="") as f:
        return list(csv.DictReader(f))


# ---- running, re-running, extending ---------------------------------------------------------------------
def test_sweep_runs_skips_resumes_and_refuses(local_ray, tmp_path, capsys):
    out = tmp_path / "sweep"
    both = [*TINY, "--steps", "200", "--seeds", "0", "1", "--out", str(out)]
    assert sweep.main(both) == 0
    printed = capsys.readouterr().out
    assert "2 trials run: 2 finished, 0 failed; 0 had already finished" in printed
    assert "pending" in printed and "finished" in printed  # the live table's states
    runs = {seed: out / "UnitreeH1.walk.perfect" / "bc" / f"seed{seed}" for seed in (0, 1)}
    for run in runs.values():
        assert load_checkpoint(run)["steps"] == 200
        assert [r["step"] for r in log_rows(run)] == ["100", "200"]

    before = files(out)
    assert sweep.main(both) == 0  # a finished sweep: nothing runs, nothing is written
    printed = capsys.readouterr().out
    assert "0 trials run" in printed and "done before" in printed
    assert files(out) == before

    first_rows = log_rows(runs[0])
    assert sweep.main([*TINY, "--steps", "300", "--seeds", "0", "--out", str(out)]) == 0
    assert "1 trials run: 1 finished" in capsys.readouterr().out
    assert load_checkpoint(runs[0])["steps"] == 300
    rows = log_rows(runs[0])  # resumed, not restarted: the earlier epochs' rows are kept as they were
    assert rows[:2] == first_rows and [r["step"] for r in rows] == ["100", "200", "300"]
    after = files(out)
    assert {k: v for k, v in after.items() if k.startswith("UnitreeH1.walk.perfect/bc/seed1")} == \
           {k: v for k, v in before.items() if k.startswith("UnitreeH1.walk.perfect/bc/seed1")}

    assert sweep.main([*both, "--set", "agent.lr=0.01"]) == 2  # another configuration: refused, untouched
    err = capsys.readouterr().err
    assert "agent.lr: 0.001 in the folder, 0.01 in this sweep" in err and "nothing was started" in err
    assert files(out) == after


def test_a_failing_trial_is_shown_and_fails_the_sweep(local_ray, tmp_path, capsys):
    assert sweep.main(["--tasks", "UnitreeH1.run.perfect", "--algos", "bc", "--steps", "100",
                       "--out", str(tmp_path)]) == 1
    captured = capsys.readouterr()
    assert "1 trials run: 0 finished, 1 failed" in captured.out
    assert "failed" in captured.out and "ValueError: UnitreeH1.run.perfect has no data" in captured.out
    assert "Traceback" in captured.err


# ---- folders: what a trial finds there ------------------------------------------------------------------
def tiny_trial(tmp_path: Path, steps: int = 200, **overrides) -> Trial:
    spec = build_spec({}, {"tasks": ["UnitreeH1.walk.perfect"], "algos": ["bc"], "steps": steps, "out": str(tmp_path),
                           "set": [*TINY[5::2], *[f"{k}={v}" for k, v in overrides.items()]]})
    return make_trials(spec)[0]


def test_a_run_killed_before_its_first_checkpoint_is_started_again_unless_it_is_another(tmp_path):
    trial = tiny_trial(tmp_path)
    assert inspect_run_dir(trial).kind == "new"
    trial.out_dir.mkdir(parents=True)
    (trial.out_dir / "config.yaml").write_text(yaml.safe_dump({**trial.run.to_dict(), "dataset": {}}))
    (trial.out_dir / "progress.csv").write_text("")
    assert inspect_run_dir(trial).kind == "unstarted"
    with pytest.raises(RunDirConflict, match=r"agent.lr: 0.001 in the folder, 0.01 in this sweep"):
        inspect_run_dir(tiny_trial(tmp_path, **{"agent.lr": 0.01}))
    (trial.out_dir / "progress.csv").write_text("step,score\n100,1.0\n")  # a logged epoch without checkpoint
    with pytest.raises(RunDirConflict, match=r"holds another run's files \(progress.csv, config.yaml\)"):
        inspect_run_dir(trial)


def test_from_parked_continues_a_parked_run_and_refuses_another_configuration(local_ray, tmp_path, capsys):
    """A fresh clone continues the table's unfinished runs from the states land_run.py --park committed."""
    from baselines.training import Trainer

    trained = tiny_trial(tmp_path / "trained")
    Trainer(trained.run, trained.out_dir, progress=False).train()  # 200 of the 300 steps below
    parked_root = tmp_path / "results_runs"
    source = parked_root / "UnitreeH1.walk.perfect_bc"  # land_run.py's name: <task>_<algo>
    source.mkdir(parents=True)
    for name in PARKED_FILES:  # what land_run.py --park commits, where the run has it
        if (trained.out_dir / name).exists():
            shutil.copy2(trained.out_dir / name, source / name)
    assert sorted(p.name for p in source.iterdir()) == ["checkpoint.pt", "config.yaml", "machines.csv", "progress.csv"]
    (source / "snapshots" / "100").mkdir(parents=True)
    (source / "snapshots" / "100" / "card.json").write_text("{}")
    parked = files(parked_root)

    longer = tiny_trial(tmp_path / "unit", steps=300)
    assert parked_source(longer, tmp_path / "elsewhere") is None
    assert parked_source(longer, parked_root) == (source, 200)
    adopt_parked(longer, source)
    assert inspect_run_dir(longer) == DirState("resume", 200)
    assert (longer.out_dir / "snapshots" / "100" / "card.json").read_text() == "{}"
    assert parked_source(longer, parked_root) is None  # its folder holds a run now: left to the sweep's plan
    with pytest.raises(RunDirConflict, match=r"agent.lr: 0.001 in the folder, 0.01 in this sweep.*without --from"):
        parked_source(tiny_trial(tmp_path / "unit2", **{"agent.lr": 0.01}), parked_root)

    out = tmp_path / "sweep"
    assert sweep.main([*TINY, "--steps", "300", "--out", str(out), "--from-parked", str(tmp_path / "elsewhere")]) == 2
    assert "elsewhere: no such folder; give the folder land_run.py --park writes into" in capsys.readouterr().err
    assert sweep.main([*TINY, "--steps", "300", "--out", str(out), "--set", "agent.lr=0.01",
                       "--from-parked", str(parked_root)]) == 2
    assert "1 parked runs conflict with this sweep; nothing was copied" in capsys.readouterr().err
    assert not out.exists()

    # --plan says what the sweep would do, and copies, starts and writes nothing
    assert sweep.main([*TINY, "--steps", "300", "--out", str(out), "--from-parked", str(parked_root), "--plan"]) == 0
    printed = capsys.readouterr().out
    assert "to resume" in printed and "200 / 300" in printed and f"from the state parked in {source}" in printed
    assert "left to train: 0 environment steps and 100 gradient steps; nothing was started or written" in printed
    assert sweep.main([*TINY, "--steps", "300", "--out", str(out), "--set", "agent.lr=0.01",
                       "--from-parked", str(parked_root), "--plan"]) == 2
    printed = capsys.readouterr().out
    assert "conflict" in printed and "agent.lr: 0.001 in the folder" in printed and "1 in conflict" in printed
    assert sweep.main([*TINY, "--steps", "300", "--out", str(out), "--plan"]) == 0
    assert "to start" in capsys.readouterr().out
    assert sweep.main([*TINY, "--steps", "300", "--out", str(tmp_path / "unit"), "--plan"]) == 0  # adopted above
    printed = capsys.readouterr().out
    assert "to resume" in printed and "200 / 300" in printed and "resumes its checkpoint" in printed
    assert not out.exists() and files(parked_root) == parked
    assert sweep.main([*TINY, "--steps", "300", "--out", str(out), "--from-parked", str(parked_root)]) == 0
    captured = capsys.readouterr()
    assert f"continues the run parked in {source} at 200 steps" in captured.err
    assert "1 trials run: 1 finished" in captured.out
    run = out / "UnitreeH1.walk.perfect" / "bc" / "seed0"
    assert load_checkpoint(run)["steps"] == 300
    assert [r["step"] for r in log_rows(run)] == ["100", "200", "300"]
    assert log_rows(run)[:2] == log_rows(source)  # resumed from the parked state, not restarted
    assert files(parked_root) == parked  # the parked state itself is never written
    assert sweep.main([*TINY, "--steps", "300", "--out", str(out), "--from-parked", str(parked_root), "--plan"]) == 0
    printed = capsys.readouterr().out
    assert "done before" in printed and "300 / 300" in printed and "0 gradient steps" in printed


def write_export(trial: Trial, root: Path, steps: int, score: float = 1.5) -> Path:
    """What land_run.py exports of a run, as far as --skip-landed reads it: the card and the resolved config."""
    folder = root / trial.run.task / trial.run.algorithm / f"seed{trial.run.seed}"
    folder.mkdir(parents=True)
    (folder / "config.yaml").write_text(yaml.safe_dump({**trial.run.to_dict(), "dataset": {}}))
    (folder / "card.json").write_text(json.dumps({"steps": steps, "evaluation": {"score": {"mean": score}}}))
    return folder


def test_skip_landed_leaves_out_exported_runs_and_names_their_other_configuration(tmp_path, capsys):
    """sweep.py --skip-landed trains only what the table lacks: a run exported with at least the trial's steps is
    skipped (shown with the values its configuration differs in); a shorter export is trained again."""
    pytest.importorskip("ray", reason='the sweep extra: pip install -e ".[sweep]"')
    pretrained, out = tmp_path / "pretrained", tmp_path / "sweep"
    export = write_export(tiny_trial(tmp_path / "x"), pretrained, steps=200)
    exported = files(pretrained)
    landed = [*TINY, "--out", str(out), "--skip-landed", str(pretrained)]

    assert sweep.main([*landed, "--steps", "200", "--plan"]) == 0
    printed = capsys.readouterr().out
    assert "landed" in printed and "200 / 200" in printed and "1.5" in printed and str(export) in printed
    assert "1 landed (0 with another configuration); left to train: 0 environment steps and 0 gradient" in printed
    assert sweep.main([*landed, "--steps", "200", "--set", "agent.lr=0.01", "--plan"]) == 0
    printed = capsys.readouterr().out
    assert "with another configuration: agent.lr: 0.001 in the export, 0.01 in this sweep" in printed
    assert "1 landed (1 with another configuration)" in printed
    assert sweep.main([*landed, "--steps", "300", "--plan"]) == 0  # the export is short of 300 steps
    printed = capsys.readouterr().out
    assert "to start" in printed and "left to train: 0 environment steps and 300 gradient steps" in printed

    assert sweep.main([*landed, "--steps", "200"]) == 0  # nothing to train: Ray is not even started
    assert "0 trials run: all 1 trials had already finished (1 of them landed)" in capsys.readouterr().out
    assert not out.exists() and files(pretrained) == exported

    assert sweep.main([*TINY, "--out", str(out), "--skip-landed", str(tmp_path / "nowhere"), "--plan"]) == 2
    assert "nowhere: no such folder; give the folder land_run.py exports into" in capsys.readouterr().err
    (export / "config.yaml").unlink()
    assert sweep.main([*landed, "--steps", "200", "--plan"]) == 2
    err = capsys.readouterr().err
    assert f"{export / 'config.yaml'} cannot be read" in err and "or sweep without --skip-landed" in err
    (export / "card.json").write_text("{not json")
    assert sweep.main([*landed, "--steps", "200", "--plan"]) == 2
    assert f"{export / 'card.json'} cannot be read" in capsys.readouterr().err


# ---- sweep files and options ----------------------------------------------------------------------------
def test_sweep_file_and_command_line_merge(tmp_path):
    path = tmp_path / "sweep.yaml"
    path.write_text("tasks: UnitreeH1.walk\nalgos: [vail, bc, vail]\nseeds: [0, 1]\nsteps: 20000\n"
                    "set: {agent: {max_kl: 0.01}}\ncpus_per_trial: 0.5\n")
    spec = build_spec(read_sweep_file(path), {"seeds": [3], "out": "x", "set": ["agent.std_0=0.3"]})
    assert (spec.tasks, spec.algos, spec.seeds, spec.steps) == (["UnitreeH1.walk"], ["vail", "bc"], [3], 20000)
    assert (spec.out, spec.cpus_per_trial, spec.threads) == (Path("x"), 0.5, 1)
    assert spec.overrides["agent"] == {"max_kl": 0.01, "std_0": 0.3}


def test_a_sweep_file_plans_seeds_per_task_and_leaves_pairs_out(tmp_path):
    path = tmp_path / "grid.yaml"
    path.write_text("tasks: [UnitreeH1.walk, Talos.walk]\nalgos: [vail, bc]\nseeds: [0]\n"
                    "seeds_by_task: {UnitreeH1.walk: [0, 1, 2]}\nexclude: [Talos.walk/bc]\n")
    spec = build_spec(read_sweep_file(path), {})
    assert spec.seeds_of("UnitreeH1.walk") == [0, 1, 2] and spec.seeds_of("Talos.walk") == [0]
    assert spec.runs() == [("UnitreeH1.walk", "vail", 0), ("UnitreeH1.walk", "vail", 1), ("UnitreeH1.walk", "vail", 2),
                           ("UnitreeH1.walk", "bc", 0), ("UnitreeH1.walk", "bc", 1), ("UnitreeH1.walk", "bc", 2),
                           ("Talos.walk", "vail", 0)]
    assert [t.key for t in make_trials(spec)][-2:] == ["UnitreeH1.walk/bc/seed2", "Talos.walk/vail/seed0"]
    # --seeds replaces every task's seeds; --tasks keeps the file's per-task entries for the tasks it names
    assert build_spec(read_sweep_file(path), {"seeds": [5]}).runs() == [
        ("UnitreeH1.walk", "vail", 5), ("UnitreeH1.walk", "bc", 5), ("Talos.walk", "vail", 5)]
    assert build_spec(read_sweep_file(path), {"tasks": ["Talos.walk"]}).runs() == [("Talos.walk", "vail", 0)]
    for text, match in [("seeds_by_task: {Talos.wakl: [1]}", r"seeds_by_task: 'Talos.wakl' names 'Talos.wakl', "
                                                              r"which is not in the sweep; valid: UnitreeH1.walk"),
                        ("exclude: [Talos.walk/vial]", r"exclude: 'Talos.walk/vial' names 'vial'.*valid: vail, bc")]:
        path.write_text(f"tasks: [UnitreeH1.walk, Talos.walk]\nalgos: [vail, bc]\n{text}\n")
        with pytest.raises(SweepSpecError, match=match):
            build_spec(read_sweep_file(path), {})


def test_trials_start_resumed_first_then_each_rows_first_seed(tmp_path):
    path = tmp_path / "grid.yaml"
    path.write_text("tasks: [UnitreeH1.walk, Talos.walk]\nalgos: [vail, bc]\nseeds: [0]\n"
                    "seeds_by_task: {UnitreeH1.walk: [0, 1, 2]}\nexclude: [Talos.walk/bc]\n")
    spec = build_spec(read_sweep_file(path), {})
    trials = make_trials(spec)
    resumed = {"UnitreeH1.walk/bc/seed2": 40_000, "Talos.walk/vail/seed0": 100_000}
    todo = [(t, TrialStatus(t.key, t.run.train.n_steps, steps=resumed.get(t.key, 0))) for t in trials]
    order = [t.key for t, _ in sweep.start_order(todo, spec.seeds_of)]
    assert order == ["Talos.walk/vail/seed0", "UnitreeH1.walk/bc/seed2",  # resumed: first seeds first
                     "UnitreeH1.walk/vail/seed0", "UnitreeH1.walk/bc/seed0",  # every row's first seed
                     "UnitreeH1.walk/vail/seed1", "UnitreeH1.walk/bc/seed1", "UnitreeH1.walk/vail/seed2"]
    assert sorted(order) == sorted(t.key for t in trials)  # nothing lost or repeated


def test_the_table_grid_file_is_a_valid_sweep():
    spec = build_spec(read_sweep_file(Path(sweep.REPO) / "sweeps" / "table.yaml"), {})
    runs = spec.runs()
    assert len(runs) == len(set(runs)) == 40 + 2 * 7  # 6 x 7 cells less 2 n/a, with two more seeds on UnitreeH1.walk
    assert spec.threads == 1 and spec.cpus_per_trial == 1


@pytest.mark.parametrize("text, match", [
    ("seeds_by_task: [0, 1]\n", r"seeds_by_task must map task names to lists of seeds"),
    ("seeds_by_task: {UnitreeH1.walk: [a]}\n", r"seeds_by_task: UnitreeH1.walk must be a non-empty list of integers"),
    ("exclude: [UnitreeH1.walk]\n", r"exclude must be a list of TASK/ALGO pairs"),
    ("tasks: [UnitreeH1.walk]\nalgo: [vail]\n", r"unknown key 'algo' \(did you mean 'algos'\?\); valid keys: tasks"),
    ("tasks: [UnitreeH1.walk]\nseeds: [0, one]\n", r"seeds must be a non-empty list of integers.*got \[0, 'one'\]"),
    ("tasks: []\n", r"tasks must be a non-empty list of names"),
    ("steps: -5\n", r"steps must be a whole number of at least 1, got -5"),
    ("threads: 2.5\n", r"threads must be a whole number"),
    ("cpus_per_trial: 0\n", r"cpus_per_trial must be a positive number of CPUs"),
    ("set: [agent.max_kl]\n", r"set: override 'agent.max_kl' must look like SECTION.KEY=VALUE"),
    ("set: {agnet: {max_kl: 0.1}}\n", r"set: unknown sections \['agnet'\]; valid: env, train, agent"),
    ("set: 3\n", r"set must be a list of SECTION.KEY=VALUE strings"),
    ("- UnitreeH1.walk\n", r"must be a mapping of tasks, algos, seeds"),
    ("tasks: [UnitreeH1.walk\n", r"is not valid YAML"),
])
def test_malformed_sweep_files_name_the_key(tmp_path, text, match):
    path = tmp_path / "sweep.yaml"
    path.write_text(text)
    with pytest.raises(SweepSpecError, match=match):
        read_sweep_file(path)


def test_incomplete_or_unknown_sweeps_fail_before_anything_starts(tmp_path, capsys, monkeypatch):
    with pytest.raises(SweepSpecError, match=r"unknown algorithms \['vial'\]; valid: bc, gaifo"):
        build_spec({"tasks": ["UnitreeH1.walk"], "algos": ["vial"]}, {})
    with pytest.raises(SweepSpecError, match=r"the sweep needs algos: give --algos"):
        build_spec({"tasks": ["UnitreeH1.walk"]}, {})
    with pytest.raises(SweepSpecError, match=r"cannot read sweep file .*missing.yaml"):
        read_sweep_file(tmp_path / "missing.yaml")
    out = str(tmp_path / "out")
    assert sweep.main(["--tasks", "UnitreeH1.wakl", "--algos", "bc", "--out", out]) == 2
    assert "Did you mean 'UnitreeH1.walk'" in capsys.readouterr().err
    assert sweep.main(["--config", str(tmp_path / "missing.yaml")]) == 2
    assert "cannot read sweep file" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    monkeypatch.setitem(sys.modules, "ray", None)  # as if Ray were not installed
    assert sweep.main(["--tasks", "UnitreeH1.walk", "--algos", "bc", "--out", out]) == 2
    assert 'pip install -e ".[sweep]"' in capsys.readouterr().err


def test_live_table_redraws_on_a_terminal_and_prints_changes_otherwise():
    rows = [TrialStatus("UnitreeH1.walk/vail/seed0", 20000), TrialStatus("UnitreeH1.walk/bc/seed0", 20000)]
    log = io.StringIO()
    table = LiveTable(log, interactive=False)
    table.update(rows)
    rows[0].state, rows[0].steps = "running", 5000
    table.update(rows)
    rows[0].steps = 6000  # a step count alone is not worth a new table in a log
    table.update(rows)
    rows[1].state, rows[1].note = "failed", "ValueError: bad"
    table.update(rows)
    assert log.getvalue().count("sweep: 2 trials") == 3
    assert "1 running, 1 failed" in log.getvalue() and "6,000 / 20,000" in log.getvalue()
    screen = io.StringIO()
    live = LiveTable(screen, interactive=True)
    live.update(rows)
    live.update(rows)
    assert screen.getvalue().count("\x1b[4F\x1b[J") == 1  # back over the 4 lines drawn, then redrawn


def test_a_trial_stops_at_the_sweeps_time_limit_and_the_sweep_says_so(tmp_path, capsys):
    """run_trial as a Ray worker runs it: past its deadline a trial is not started (nothing written); with time
    left it trains; a far deadline finishes it. The sweep's summary and table name stopped trials."""
    import time

    from experiments.sweep_trial import TrialOutcome, run_trial

    trial = tiny_trial(tmp_path)
    outcome = run_trial(trial, None, deadline=time.time() - 1.0)
    assert (outcome.state, outcome.steps) == ("stopped", 0) and not trial.out_dir.exists()
    outcome = run_trial(trial, None, deadline=time.time() + 3600.0)
    assert (outcome.state, outcome.steps) == ("finished", 200)
    row = TrialStatus(trial.key, 200)
    sweep._apply(row, TrialOutcome(trial.key, "stopped", steps=100))
    assert (row.state, row.steps, row.note) == ("stopped", 100, "time limit: run again to resume")
    assert "1 stopped" in render([row], None)
    assert sweep._summary([TrialOutcome("a", "stopped"), TrialOutcome("b", "finished")], 3) == 0
    assert ("2 trials run: 1 finished, 1 stopped at the time limit (run the same command to resume them), 0 failed; "
            "3 had already finished") in capsys.readouterr().out
    assert sweep.main([*TINY, "--out", str(tmp_path), "--time-limit", "0"]) == 2
    assert "--time-limit must be a positive number of minutes, got 0.0" in capsys.readouterr().err
