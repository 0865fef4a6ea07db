"""The results table (experiments/results_table.py) and the aggregates over tasks (loco_mujoco.evaluation.aggregate):
the 42-row grid, not-run / n/a / not-evaluated rows, synthetic evaluation files landing in their rows, pooling of
seeds, budgets from training logs, byte-identical regeneration and the refusal to overwrite."""

import json

import numpy as np
import pytest
import yaml

from experiments.results_table import OUTPUTS, main, render_csv
from experiments.table_cells import (
    ALGORITHMS,
    DID_NOT_LEARN,
    GRID,
    IN_PROGRESS,
    NO_ACTIONS,
    NOT_EVALUATED,
    NOT_RUN,
    TASKS,
    build_cells,
    collect,
)
from experiments.table_sources import training_hours
from loco_mujoco.evaluation.aggregate import aggregate_iqm, performance_profile
from loco_mujoco.evaluation.intervals import iqm

REFS = {"task": "UnitreeH1.walk", "horizon": 1000, "expert_reward_per_step": 0.5, "expert_return": 500.0,
        "random_return": 20.0, "random_length": 50.0, "zero_return": 1.0, "zero_length": 67.0, "hold_return": 0.0,
        "hold_length": 146.0, "dataset_digest": "abc", "env_settings": {}}


def write_eval(folder, task, algo, seed, returns, steps=1_000_000, refs=None, stem=None):
    """An evaluation file as ``evaluate.py --json`` writes it (the parts the table reads)."""
    returns = [float(r) for r in returns]
    d = {"task": task, "algorithm": algo, "seed": seed, "steps": steps, "protocol": {"episodes": len(returns)},
         "references": {**REFS, "task": task.removesuffix(".perfect"), **(refs or {})},
         "deterministic": {"returns": returns, "lengths": [200.0 + r for r in returns]},
         "metrics": {"gait": {"deviation": [0.5] * len(returns)},
                     "trajectory": {"dtw_joints": [1.0] * (len(returns) - 1) + [float("nan")],
                                    "dtw_sites": [0.25] * len(returns)},
                     "distribution": {"agent": {"classifier_auc": 0.8 + 0.1 * seed}}}}
    path = folder / f"{stem or f'{task}_{algo}_seed{seed}'}_eval.json"
    path.write_text(json.dumps(d))
    return path


def table(results, runs):
    cells = build_cells(collect(results, runs, None), results, runs)
    return {(c.task, c.algorithm): c for c in cells}, cells


@pytest.fixture
def dirs(tmp_path):
    results, runs = tmp_path / "results", tmp_path / "runs"
    results.mkdir()
    runs.mkdir()
    return results, runs


def test_grid_has_42_rows_with_not_run_and_na(dirs):
    rows, cells = table(*dirs)
    assert len(cells) == 42 == len(TASKS) * len(ALGORITHMS)
    assert [(c.task, c.algorithm) for c in cells] == [(t, a) for t in TASKS for a in ALGORITHMS]
    # muscles: inverse dynamics refuses them and no .perfect dataset exists; GAIL and BC ask for derived actions
    assert rows["HumanoidMuscle.walk", "gail"].status == NO_ACTIONS
    assert rows["HumanoidMuscle.walk", "bc"].status == NO_ACTIONS
    # state-only algorithms, and the off-policy ones that learn an inverse model online there (from_observations)
    for algo in ("vail", "gaifo", "iq_learn", "lsiq", "sqil"):
        assert rows["HumanoidMuscle.walk", algo].status == NOT_RUN
    assert rows["HumanoidTorque.walk", "gail"].status == NOT_RUN  # torque motors: inverse dynamics works
    assert rows["UnitreeH1.walk", "bc"].status == NOT_RUN
    assert all(not c.results and not c.figures for c in cells)


def test_the_grid_file_leaves_out_exactly_the_rows_without_expert_actions(dirs):
    """sweeps/table.yaml trains the rows: the pairs it excludes are the rows the table finds n/a."""
    _, cells = table(*dirs)
    assert GRID.exclude == {(c.task, c.algorithm) for c in cells if c.status == NO_ACTIONS}
    assert {c.task: c.planned_seeds for c in cells}["UnitreeH1.walk"] == [0, 1, 2]
    assert {c.task: c.planned_seeds for c in cells}["Talos.walk"] == [0]


def test_a_row_short_of_its_planned_seeds_says_which_are_missing(dirs):
    results, runs = dirs
    write_eval(results, "UnitreeH1.walk", "gail", 0, np.full(50, 68.0))
    write_eval(results, "UnitreeH1.walk", "gail", 2, np.full(50, 68.0))
    write_eval(results, "Talos.walk", "gail", 0, np.full(50, 68.0))
    write_eval(results, "Atlas.walk", "vail", 0, np.full(50, 68.0))
    write_eval(results, "Atlas.walk", "vail", 5, np.full(50, 68.0))
    rows, _ = table(results, runs)
    h1, talos, atlas = rows["UnitreeH1.walk", "gail"], rows["Talos.walk", "gail"], rows["Atlas.walk", "vail"]
    assert h1.seeds_text == "2 of 3" and "seed 1 of the planned 0, 1, 2 not evaluated yet" in h1.notes
    assert talos.seeds_text == "1" and not any("planned" in n for n in talos.notes)
    assert atlas.seeds_text == "1 + 1" and "seed 5 outside the planned 0" in atlas.notes  # pooled, not planned
    assert rows["Atlas.walk", "gail"].seeds_text == "-"


def test_an_evaluation_lands_in_its_row(dirs):
    results, runs = dirs
    returns = np.random.default_rng(0).uniform(20.0, 300.0, 50)
    write_eval(results, "Atlas.walk", "vail", 0, returns)
    rows, cells = table(results, runs)
    cell = rows["Atlas.walk", "vail"]
    assert cell.status == "ok" and len(cell.results) == 1 and cell.data == "real"
    expected = 100.0 * (returns.mean() - 20.0) / (500.0 - 20.0)
    f = cell.figures
    assert f["score"] == pytest.approx(expected)
    lo, hi = f["score_ci"]
    assert lo < expected < hi and hi - lo < 30.0
    assert f["R"] == pytest.approx(returns.mean()) and f["L"] == pytest.approx(200.0 + returns.mean())
    assert f["gait_deviation"] == 0.5 and f["dtw_joints"] == 1.0 and f["dtw_sites"] == 0.25  # NaN episode left out
    assert f["classifier_auc"] == pytest.approx(0.8)
    assert sum(c.status == "ok" for c in cells) == 1
    assert rows["Atlas.walk", "gail"].references["expert_return"] == 500.0  # the task's references on its other rows


def test_two_seeds_are_pooled_episode_by_episode(dirs):
    results, runs = dirs
    a, b = np.full(50, 68.0), np.full(30, 260.0)  # scores 10 and 50
    write_eval(results, "UnitreeA1.simple", "gaifo", 0, a)
    write_eval(results, "UnitreeA1.simple", "gaifo", 1, b)
    rows, _ = table(results, runs)
    cell = rows["UnitreeA1.simple", "gaifo"]
    assert [r.seed for r in cell.results] == [0, 1]
    f = cell.figures
    assert f["episodes"] == 80
    assert f["score"] == pytest.approx((50 * 10.0 + 30 * 50.0) / 80)
    assert f["score_ci"][0] < f["score"] < f["score_ci"][1]
    assert f["classifier_auc"] == pytest.approx(0.85)  # per-evaluation metric: the mean over seeds


def test_a_row_not_beating_random_actions_says_did_not_learn(dirs):
    results, runs = dirs
    rng = np.random.default_rng(1)
    write_eval(results, "Talos.walk", "lsiq", 0, rng.normal(21.0, 5.0, 50))  # score ~0.2: interval reaches 0
    write_eval(results, "Talos.walk", "bc", 0, np.full(50, 10.0))  # below random: score -2.1
    write_eval(results, "Talos.walk", "vail", 0, rng.normal(68.0, 5.0, 50))  # score ~10
    rows, _ = table(results, runs)
    for algo in ("lsiq", "bc"):
        cell = rows["Talos.walk", algo]
        assert cell.figures["score_ci"][0] <= 0.0 and cell.notes[0] == DID_NOT_LEARN
    assert rows["Talos.walk", "bc"].figures["score"] == pytest.approx(-100.0 * 10.0 / 480.0)  # figures kept
    assert rows["Talos.walk", "vail"].figures["score_ci"][0] > 0.0
    assert DID_NOT_LEARN not in rows["Talos.walk", "vail"].notes
    assert all(DID_NOT_LEARN not in c.notes for c in rows.values() if c.status != "ok")


def test_a_seed_trained_short_of_its_familys_budget_says_so(dirs):
    """The committed budgets (20M env steps on-policy, 500k off-policy, 100k gradient steps for BC): a seed below
    its family's is named with its steps; one at or above it is not."""
    results, runs = dirs
    write_eval(results, "UnitreeH1.walk", "lsiq", 0, np.full(10, 68.0), steps=300_000)
    write_eval(results, "UnitreeH1.walk", "lsiq", 1, np.full(10, 68.0), steps=500_000)
    write_eval(results, "Atlas.walk", "vail", 0, np.full(10, 68.0), steps=38_200_000)
    write_eval(results, "Atlas.walk", "bc", 0, np.full(10, 68.0), steps=20_000)
    rows, _ = table(results, runs)
    lsiq = rows["UnitreeH1.walk", "lsiq"].notes
    assert "seed 0 trained 300k of the table's 500k env steps" in lsiq
    assert not any("seed 1 trained" in n for n in lsiq)
    assert not any("of the table's" in n for n in rows["Atlas.walk", "vail"].notes)
    assert "trained 20k of the table's 100k gradient steps" in rows["Atlas.walk", "bc"].notes


def test_perfect_data_superseded_seeds_and_runs_without_evaluation(dirs):
    results, runs = dirs
    write_eval(results, "UnitreeH1.walk.perfect", "bc", 0, np.full(10, 116.0), steps=20_000)
    write_eval(results, "UnitreeH1.walk", "vail", 0, np.full(10, 68.0), steps=2_000_000, stem="UnitreeH1.walk_vail")
    write_eval(results, "UnitreeH1.walk", "vail", 0, np.full(10, 116.0), steps=5_000_000, stem="late")
    run = runs / "UnitreeH1.walk.perfect_sqil"
    run.mkdir()
    (run / "config.yaml").write_text(yaml.safe_dump({"task": "UnitreeH1.walk.perfect", "algorithm": "sqil",
                                                     "seed": 0}))
    (run / "progress.csv").write_text("step,epoch,train_steps_per_s\n20000,1,100\n40000,2,50\n")
    (run / "machines.csv").write_text("step,machine,cpus,torch_threads,started\n0,Xeon (16 CPUs),16,1,-\n"
                                      "20000,EPYC (2 CPUs),2,1,-\n")
    rows, _ = table(results, runs)
    bc = rows["UnitreeH1.walk", "bc"]
    assert bc.data == "perfect" and bc.notes[0] == "(perfect data)" and bc.figures["score"] == pytest.approx(20.0)
    vail = rows["UnitreeH1.walk", "vail"]
    assert len(vail.results) == 1 and vail.results[0].steps == 5_000_000  # the latest evaluation of seed 0
    assert vail.figures["score"] == pytest.approx(20.0) and "superseded" in vail.notes[0]
    sqil = rows["UnitreeH1.walk", "sqil"]
    assert sqil.status == NOT_EVALUATED and sqil.budgets[0].steps == 40_000
    parked = runs / "Talos.walk_gaifo"  # a run stopped short of its planned steps (parked to continue)
    parked.mkdir()
    (parked / "config.yaml").write_text(yaml.safe_dump({"task": "Talos.walk", "algorithm": "gaifo", "seed": 0,
                                                        "train": {"n_steps": 20_000_000}}))
    (parked / "progress.csv").write_text("step,epoch,train_steps_per_s\n100000,1,1000\n6700000,67,950\n")
    gaifo = table(results, runs)[0]["Talos.walk", "gaifo"]
    assert gaifo.status == IN_PROGRESS and gaifo.budgets[0].steps == 6_700_000
    assert gaifo.notes == ["seed 0: Talos.walk_gaifo at 6.7M of 20.0M, no evaluation file"]
    (parked / "progress.csv").write_text("step,epoch,train_steps_per_s\n20000000,200,950\n")  # finished
    assert table(results, runs)[0]["Talos.walk", "gaifo"].status == NOT_EVALUATED
    assert sqil.budgets[0].machine == "Xeon (16 CPUs) 0-20k + EPYC (2 CPUs) 20k-40k"  # from the run's machines.csv
    assert sqil.budgets[0].hours == pytest.approx((20_000 / 100 + 20_000 / 50) / 3600)
    from experiments.results_table import compute_cost, compute_lines

    cost = compute_cost(list(rows.values()))
    assert list(cost) == ["adversarial", "offpolicy", "offline"]  # the superseded VAIL evaluation is not counted
    assert cost["adversarial"] == {"runs": 1, "steps": 5_000_000, "hours": 0.0, "unlogged": 1}
    assert cost["offpolicy"] == {"runs": 1, "steps": 40_000, "hours": pytest.approx(600 / 3600), "unlogged": 0}
    assert cost["offline"]["steps"] == 20_000 and cost["offline"]["unlogged"] == 1
    assert "In all: 3 runs, 0.2 core-hours of learning." in compute_lines(list(rows.values()))


def _offpolicy_run(runs, name, task, algo, column, values, agent=None):
    """A run directory of an off-policy run whose log has ``column`` at ``values`` (one per 20k epoch)."""
    folder = runs / name
    folder.mkdir()
    (folder / "config.yaml").write_text(yaml.safe_dump({"task": task, "algorithm": algo, "seed": 0,
                                                        "env": {"gamma": 0.99}, "agent": agent or {},
                                                        "train": {"n_steps": 500_000}}))
    lines = [f"{20_000 * (i + 1)},{i + 1},30,{v}" for i, v in enumerate(values)]
    (folder / "progress.csv").write_text(f"step,epoch,train_steps_per_s,{column}\n" + "\n".join(lines) + "\n")


def test_a_row_whose_critic_passed_its_bound_says_critic_diverged(dirs):
    results, runs = dirs

    def run(name, task, algo, q_expert, agent=None):
        _offpolicy_run(runs, name, task, algo, "q_expert", q_expert, agent)

    run("Talos.walk_sqil", "Talos.walk", "sqil", [30.0, 326.0, 718_000.0])  # bound 100: diverged
    run("Atlas.walk_sqil", "Atlas.walk", "sqil", [30.0, 95.0, 120.0])  # within 1.25 x 100
    run("Atlas.walk_lsiq", "Atlas.walk", "lsiq", [190.0, 240.0], agent={"reg_mult": 0.5})  # bound 200: within
    run("Talos.walk_lsiq", "Talos.walk", "lsiq", [190.0, 600.0], agent={"reg_mult": 1.0})  # bound 100: diverged
    run("Atlas.walk_gaifo", "Atlas.walk", "gaifo", [1e9])  # on-policy: no critic bound
    write_eval(results, "Talos.walk", "lsiq", 0, np.full(10, 116.0), steps=40_000, stem="Talos.walk_lsiq")
    rows, _ = table(results, runs)
    sqil = rows["Talos.walk", "sqil"]
    assert sqil.status == IN_PROGRESS
    assert sqil.notes[-1] == ("critic diverged: q_expert reached 7.18e+05 in size (at 60k), above 1.25 x its bound "
                              "100 (rewards in [0, 1])")
    lsiq = rows["Talos.walk", "lsiq"]  # an evaluated row: the note beside its figures
    assert lsiq.status == "ok" and any(n.startswith("critic diverged: q_expert reached 600") for n in lsiq.notes)
    for key in (("Atlas.walk", "sqil"), ("Atlas.walk", "lsiq"), ("Atlas.walk", "gaifo")):
        assert not any("critic diverged" in n for n in rows[key].notes), key


def test_a_row_whose_critic_ends_at_its_floor_says_critic_saturated(dirs):
    results, runs = dirs

    def run(name, task, algo, q_agent, agent=None):
        _offpolicy_run(runs, name, task, algo, "q_agent", q_agent, agent)

    # LS-IQ, c = 0.5: floor -200, threshold -200 + 0.05 x 400 = -180; the stretch that ends the log counts
    run("Talos.walk_lsiq", "Talos.walk", "lsiq", [-10.0, -185.0, -150.0, -181.0, -194.0], agent={"reg_mult": 0.5})
    run("Atlas.walk_lsiq", "Atlas.walk", "lsiq", [-190.0, -185.0, -179.0], agent={"reg_mult": 0.5})  # climbed out
    run("Talos.walk_sqil", "Talos.walk", "sqil", [9.0, 0.3])  # floor 0, threshold 5
    run("Atlas.walk_sqil", "Atlas.walk", "sqil", [0.5, 5.5])
    run("Talos.walk_iq_learn", "Talos.walk", "iq_learn", [-500.0])  # no floor
    rows, _ = table(results, runs)
    assert rows["Talos.walk", "lsiq"].notes[-1] == (
        "critic saturated from 80k to 100k: q_agent -194 at the end, within 5% of its floor -200 (below -180), every "
        "agent state valued as never reaching the expert's")
    assert rows["Talos.walk", "sqil"].notes[-1].startswith("critic saturated from 40k to 40k: q_agent 0.3 at the "
                                                           "end, within 5% of its floor 0 (below 5), ")
    for key in (("Atlas.walk", "lsiq"), ("Atlas.walk", "sqil"), ("Talos.walk", "iq_learn")):
        assert not any("critic saturated" in n for n in rows[key].notes), key


def test_a_row_resumed_without_its_replay_buffer_says_where(dirs):
    """A resume from a committed state (no buffer) shows in the log as replay_size falling; the row names it."""
    from experiments.table_sources import replay_refills

    results, runs = dirs
    _offpolicy_run(runs, "Talos.walk_sqil", "Talos.walk", "sqil", "replay_size",
                   [20_000, 40_000, 20_000, 40_000, 60_000, 20_000])  # resumed without it at 40k and at 100k
    _offpolicy_run(runs, "Atlas.walk_sqil", "Atlas.walk", "sqil", "replay_size", [20_000, 40_000, 60_000])
    _offpolicy_run(runs, "Talos.walk_lsiq", "Talos.walk", "lsiq", "replay_size", [500_000, 500_000])  # full: stays
    rows, _ = table(results, runs)
    assert rows["Talos.walk", "sqil"].notes[-1] == (
        "resumed without its replay buffer at 40k (20,000 transitions at the next row, not 60,000), 100k (20,000 "
        "transitions at the next row, not 80,000)")
    for key in (("Atlas.walk", "sqil"), ("Talos.walk", "lsiq")):
        assert not any("replay buffer" in n for n in rows[key].notes), key
    assert replay_refills([{"step": 1000.0}, {"step": 2000.0}]) == []  # on-policy logs have no replay_size


def test_saturation_warning_while_training():
    from experiments.critic_values import saturation_warning

    config = {"env": {"gamma": 0.99}, "agent": {"reg_mult": 0.5}}
    warning = saturation_warning("lsiq", config, -190.0)
    assert warning.startswith("warning: q_agent is -190, within 5% of its floor -200 (below -180)")
    assert saturation_warning("lsiq", config, -170.0) is None
    assert saturation_warning("sqil", config, 1.0) and saturation_warning("sqil", config, 13.5) is None
    assert saturation_warning("iq_learn", config, -1e6) is None and saturation_warning("gail", config, -1e6) is None
    assert saturation_warning("lsiq", config, None) is None and saturation_warning("lsiq", config, float("nan")) is None
    chi2 = {"env": {"gamma": 0.99}, "agent": {"reg_mult": 0.5, "loss_form": "chi2"}}  # floor -Q_max / 2
    assert saturation_warning("lsiq", chi2, -95.0).startswith("warning: q_agent is -95, within 5% of its floor -100")
    assert saturation_warning("lsiq", chi2, -80.0) is None


def test_each_row_names_the_control_its_agents_act_in(dirs):
    results, runs = dirs
    write_eval(results, "Atlas.walk", "vail", 0, np.full(10, 68.0), refs={"env_settings": {"control": "'pd'"}})
    write_eval(results, "Atlas.walk", "gail", 0, np.full(10, 68.0))  # no control named: the embodiment's default
    write_eval(results, "UnitreeH1.walk.perfect", "sqil", 0, np.full(10, 68.0))  # the perfect data's: PD
    run = runs / "Talos.walk_vail"
    run.mkdir()
    (run / "config.yaml").write_text(yaml.safe_dump({"task": "Talos.walk", "algorithm": "vail", "seed": 0,
                                                     "env": {"control": "torque"}}))
    (run / "progress.csv").write_text("step,epoch,train_steps_per_s\n1000,1,100\n")
    rows, _ = table(results, runs)
    got = {key: rows[key].control for key in [("Atlas.walk", "vail"), ("Atlas.walk", "gail"),
                                              ("UnitreeH1.walk", "sqil"), ("Talos.walk", "vail"),
                                              ("Talos.walk", "gaifo"), ("HumanoidMuscle.walk", "gail")]}
    # evaluated: as evaluated; not evaluated: the run's config; not run (or n/a): the committed config (PD: the
    # embodiments section of configs/defaults.yaml; muscles: their only mode)
    assert got == {("Atlas.walk", "vail"): "pd", ("Atlas.walk", "gail"): "torque", ("UnitreeH1.walk", "sqil"): "pd",
                   ("Talos.walk", "vail"): "torque", ("Talos.walk", "gaifo"): "pd",
                   ("HumanoidMuscle.walk", "gail"): "muscle"}
    assert "trained in torque control; the committed config now asks for pd" in rows["Atlas.walk", "gail"].notes
    assert not any("committed config" in n for n in rows["Atlas.walk", "vail"].notes)


def test_a_row_trained_otherwise_than_the_committed_config_names_the_values(dirs):
    """A row trained before a default changed says so: each value its run's config differs in from today's."""
    from baselines.config import load_run_config

    results, runs = dirs
    for task, agent in (("Atlas.walk", {"critic_layer_norm": False, "n_threads": 4}), ("Talos.walk", {})):
        config = load_run_config(task, "sqil").to_dict()
        config["agent"].update(agent)  # n_threads: not reported (a resume may change it)
        config["train"]["n_steps"] = 40_000  # the budget has its own column
        folder = runs / f"{task}_sqil"
        folder.mkdir()
        (folder / "config.yaml").write_text(yaml.safe_dump(config))
        (folder / "progress.csv").write_text("step,epoch,train_steps_per_s\n20000,1,30\n40000,2,30\n")
        write_eval(results, task, "sqil", 0, np.full(10, 68.0), steps=40_000, stem=f"{task}_sqil")
    rows, _ = table(results, runs)
    assert "trained with agent.critic_layer_norm False (committed: True)" in rows["Atlas.walk", "sqil"].notes
    assert not any(n.startswith("trained with") for n in rows["Talos.walk", "sqil"].notes)


def test_machine_summary_names_each_machines_stretch():
    from experiments.table_sources import machine_summary

    one = [{"step": "0", "machine": "EPYC (2 CPUs)"}, {"step": "400", "machine": "EPYC (2 CPUs)"}]
    assert machine_summary(one, 800) == "EPYC (2 CPUs)" and machine_summary([], 800) is None
    lent = [{"step": "0", "machine": "Xeon (16 CPUs)"}, {"step": "1000000", "machine": "Xeon (16 CPUs)"},
            {"step": "5000000", "machine": "EPYC (2 CPUs)"}, {"step": "19000000", "machine": "EPYC (2 CPUs)"}]
    assert machine_summary(lent, 20_000_000) == "Xeon (16 CPUs) 0-5.0M + EPYC (2 CPUs) 5.0M-20.0M"
    assert machine_summary(lent, 5_000_000) == "Xeon (16 CPUs)"  # the stretch from 5M on trained none of it


def test_training_hours_need_a_complete_log():
    rows = [{"step": 100.0, "epoch": 1.0, "train_steps_per_s": 10.0},
            {"step": 200.0, "epoch": 2.0, "train_steps_per_s": 20.0}]
    assert training_hours(rows, 200) == pytest.approx(15.0 / 3600)
    assert training_hours(rows, 100) == pytest.approx(10.0 / 3600)
    assert training_hours(rows, 150) is None  # no epoch ends there
    assert training_hours([rows[0], {**rows[1], "epoch": 3.0}], 200) is None  # an epoch missing


def test_aggregate_iqm_and_profile():
    rng = np.random.default_rng(1)
    scores = [[rng.normal(10.0, 5.0, 50), rng.normal(12.0, 5.0, 50)], [rng.normal(40.0, 5.0, 50)]]
    means = [x.mean() for task in scores for x in task]
    agg = aggregate_iqm(scores, reps=500)
    assert agg["iqm"] == pytest.approx(iqm(np.array(means))) and agg["tasks"] == 2 and agg["runs"] == 3
    assert agg["ci95"][0] < agg["iqm"] < agg["ci95"][1]
    p = performance_profile(scores, np.array([0.0, 11.0, 30.0, 50.0]), reps=500)
    # task 1: both runs > 0, one of two > 11 (~10 and ~12), none > 30; task 2: its run > 30; averaged over tasks
    assert p["fraction"] == pytest.approx([1.0, 0.75, 0.5, 0.0])
    assert np.all(p["lo"] <= p["fraction"]) and np.all(p["fraction"] <= p["hi"])
    assert aggregate_iqm(scores, reps=500) == agg  # seeded
    with pytest.raises(ValueError, match="no runs"):
        aggregate_iqm([[]])


def test_regeneration_is_byte_identical_and_never_overwrites_unasked(dirs, tmp_path, capsys):
    results, runs = dirs
    rng = np.random.default_rng(2)
    write_eval(results, "UnitreeH1.walk", "gail", 0, rng.uniform(20, 200, 20))
    write_eval(results, "UnitreeH1.walk", "gail", 1, rng.uniform(20, 200, 20))
    write_eval(results, "Talos.walk", "gail", 0, rng.uniform(20, 200, 20))
    args = ["--results", str(results), "--runs", str(runs), "--pretrained", "none"]
    out = tmp_path / "out"
    assert main([*args, "--out", str(out)]) == 0
    first = {name: (out / name).read_bytes() for name in OUTPUTS}
    md = first["table.md"].decode()
    assert md.count("\n| ") == 1 + 42 + 1 + 1 + 1 + 1  # header, 42 rows, aggregate header and row, compute
    assert "| on-policy (GAIL, VAIL, GAIfO) | 3 | 3.0M env | 0.0 | 3 |" in md  # three GAIL runs, no logs
    assert "| Talos.walk | GAIL | torque | **" in md and "| GAIL | 2 | 3 |" in md  # control: the settings name none
    # refused without --force, nothing touched
    (out / "table.csv").write_text("mine")
    assert main([*args, "--out", str(out)]) == 2
    assert "pass --force" in capsys.readouterr().err
    assert (out / "table.csv").read_text() == "mine" and (out / "table.md").read_bytes() == first["table.md"]
    assert main([*args, "--out", str(out), "--force"]) == 0
    assert {name: (out / name).read_bytes() for name in OUTPUTS} == first


def test_a_card_fills_a_seed_without_an_evaluation_file(dirs, tmp_path):
    results, runs = dirs
    summary = {"mean": 7.0, "ci95": [5.0, 9.0], "iqm": 6.5, "iqm_ci95": [5.0, 8.0], "n": 50}
    for algo in ("vail", "gaifo"):
        card = tmp_path / "pretrained" / "Talos.walk" / algo / "seed0" / "card.json"
        card.parent.mkdir(parents=True)
        card.write_text(json.dumps({"task": "Talos.walk", "algorithm": algo, "seed": 0, "steps": 3_000_000,
                                    "evaluation": {"score": summary, "R": summary, "L": summary}}))
    write_eval(results, "Talos.walk", "gaifo", 0, np.full(10, 68.0))  # an evaluation file wins over the card
    cells = build_cells(collect(results, runs, tmp_path / "pretrained"), results, runs)
    rows = {(c.task, c.algorithm): c for c in cells}
    vail = rows["Talos.walk", "vail"]
    assert vail.figures["score"] == 7.0 and vail.figures["score_ci"] == (5.0, 9.0)
    assert "card summary only" in vail.notes[-1] and vail.budgets[0].steps == 3_000_000
    gaifo = rows["Talos.walk", "gaifo"]
    assert gaifo.figures["score"] == pytest.approx(10.0) and gaifo.results[0].card_summary is None


def test_divergence_warning_while_training():
    from experiments.critic_values import divergence_warning

    config = {"env": {"gamma": 0.99}, "agent": {"reg_mult": 0.5}}
    warning = divergence_warning("sqil", config, 326.0)
    assert warning.startswith("warning: the critics' value of expert transitions is 326")
    assert divergence_warning("sqil", config, 110.0) is None  # within 1.25 x 100 (soft values' entropy term)
    assert divergence_warning("lsiq", config, 240.0) is None and divergence_warning("lsiq", config, 260.0)
    assert divergence_warning("iq_learn", config, -2e3) and divergence_warning("iq_learn", config, 900.0) is None
    assert divergence_warning("vail", config, 1e9) is None and divergence_warning("sqil", config, None) is None


def test_another_build_of_the_dataset_is_rescored_with_the_tasks_references(dirs):
    """Two builds of one recipe differ in their last bits (digest) and in random R (chaotic rollouts) only: the row
    is scored against the task's references, its own score kept in the CSV; other differences keep the row's own
    references and say so."""
    results, runs = dirs
    write_eval(results, "Talos.walk", "gail", 0, np.full(50, 68.0))  # score 10 under REFS
    write_eval(results, "Talos.walk", "vail", 0, np.full(50, 116.0))  # score 20 under REFS
    other_build = {"dataset_digest": "def", "random_return": 21.8, "expert_return": 500.0 * (1 + 2e-10)}
    write_eval(results, "Talos.walk", "sqil", 0, np.full(50, 68.0), refs=other_build)
    write_eval(results, "Talos.walk", "bc", 0, np.full(50, 68.0), refs={**other_build, "hold_return": 5.0})
    rows, cells = table(results, runs)
    sqil, bc = rows["Talos.walk", "sqil"], rows["Talos.walk", "bc"]
    assert sqil.figures["score"] == pytest.approx(10.0)  # the task's references: random R 20
    assert sqil.figures["score_own"] == pytest.approx(100 * (68 - 21.8) / (500 * (1 + 2e-10) - 21.8))
    assert sqil.references["dataset_digest"] == "abc" and not any("references" in n for n in sqil.notes)
    assert [r.scores.mean() for r in sqil.results] == pytest.approx([10.0])  # what the aggregate reads
    # the stand-still return differs: not the same data, its own references and the note naming both datasets
    assert bc.figures["score"] == pytest.approx(100 * (68 - 21.8) / (500 * (1 + 2e-10) - 21.8))
    assert bc.references["dataset_digest"] == "def"
    assert any("references of dataset def" in n and "the task's: dataset abc" in n for n in bc.notes)
    csv_row = next(line for line in render_csv(cells).splitlines() if line.startswith("Talos.walk,sqil,"))
    assert f"{100 * (68 - 21.8) / (500 * (1 + 2e-10) - 21.8):.6g}" in csv_row


def test_committed_references_normalise_their_tasks_rows(dirs):
    """<results>/references/<task>.json (1,000 random episodes) replaces the evaluations' own 50-episode random R on
    the same data; a row measured under other settings keeps its own; a file naming another task is refused."""
    results, runs = dirs
    write_eval(results, "Atlas.walk", "gail", 0, np.full(50, 68.0))
    write_eval(results, "Atlas.walk", "vail", 0, np.full(50, 68.0), refs={"env_settings": {"control": "'torque'"}})
    committed = {**REFS, "task": "Atlas.walk", "random_return": 24.0, "random_return_se": 0.4, "random_episodes": 1000,
                 "dataset_digest": "xyz"}
    (results / "references").mkdir()
    (results / "references" / "Atlas.walk.json").write_text(json.dumps(committed))
    rows, cells = table(results, runs)
    gail, vail = rows["Atlas.walk", "gail"], rows["Atlas.walk", "vail"]
    assert gail.figures["score"] == pytest.approx(100 * (68 - 24) / (500 - 24))
    assert gail.figures["score_own"] == pytest.approx(10.0) and gail.references == committed
    assert rows["Atlas.walk", "bc"].references == committed  # rows without an evaluation show the task's
    assert vail.figures["score"] == pytest.approx(10.0) and vail.references["dataset_digest"] == "abc"
    assert any("references of settings" in n for n in vail.notes)
    csv_row = next(line for line in render_csv(cells).splitlines() if line.startswith("Atlas.walk,gail,"))
    assert ",0.4,1000,xyz," in csv_row
    (results / "references" / "Talos.walk.json").write_text(json.dumps(committed))
    with pytest.raises(ValueError, match="Talos.walk.json holds the references of 'Atlas.walk'"):
        table(results, runs)


def test_measure_references_writes_each_task_once_and_never_replaces_unasked(dirs, monkeypatch, capsys):
    import loco_mujoco.evaluation.references as module

    results, _ = dirs
    calls = []

    def fake(task, env_kwargs, progress=False):
        calls.append((task, env_kwargs))
        return module.References(**{**REFS, "task": task, "random_return": 1.0 + len(calls)})

    monkeypatch.setattr(module, "references", fake)
    assert main(["--results", str(results), "--measure-references"]) == 0
    assert [t for t, _ in calls] == list(TASKS)
    assert dict(calls)["Talos.walk"]["control"] == "pd" and "control" not in dict(calls)["HumanoidMuscle.walk"]
    first = json.loads((results / "references" / "Talos.walk.json").read_text())
    assert first["task"] == "Talos.walk" and first["random_return"] == 3.0
    assert main(["--results", str(results), "--measure-references"]) == 2  # other values: refused
    assert "pass --force" in capsys.readouterr().err
    assert json.loads((results / "references" / "Talos.walk.json").read_text()) == first
    assert main(["--results", str(results), "--measure-references", "--force"]) == 0
    assert json.loads((results / "references" / "Talos.walk.json").read_text())["random_return"] > 3.0
