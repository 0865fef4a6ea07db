"""Compare as you train: the reported curve of a task and algorithm, read from run directories."""

from pathlib import Path

import yaml

from experiments.reported_curves import at_step, comparison_line, differences, reported_curve, reported_logs


def _run(folder: Path, task: str, algo: str, rows: list[dict], init_rows: list[dict] | None = None,
         agent: dict | None = None) -> None:
    folder.mkdir(parents=True)
    config = {"task": task, "algorithm": algo, "env": {"control": "pd"}, "agent": agent or {"alpha": 0.1}}
    (folder / "config.yaml").write_text(yaml.safe_dump(config))
    for name, table in (("progress.csv", rows), ("init_from_progress.csv", init_rows)):
        if table:
            keys = list(table[0])
            lines = [",".join(keys)] + [",".join(str(r.get(k, "")) for k in keys) for r in table]
            (folder / name).write_text("\n".join(lines) + "\n")


def test_curves_merge_warm_started_logs_and_compare_at_the_same_step(tmp_path):
    _run(tmp_path / "T.walk_vail", "T.walk", "vail", [{"step": 100, "L": 50}, {"step": 200, "L": 60}])
    _run(tmp_path / "T.walk_vail_from0.2M", "T.walk", "vail", [{"step": 300, "L": 90, "score": 4.0}],
         init_rows=[{"step": 100, "L": 50}, {"step": 200, "L": 61}])
    _run(tmp_path / "T.walk_gaifo", "T.walk", "gaifo", [{"step": 100, "L": 10}])  # not vail's
    _run(tmp_path / "T.walk_vailx", "T.walk", "vail", [{"step": 100, "L": 999}])  # another name: skipped
    assert len(reported_logs("T.walk", "vail", tmp_path)) == 3
    curve = reported_curve("T.walk", "vail", tmp_path)
    assert [row["step"] for row in curve] == [100, 200, 300]
    assert curve[2] == {"step": 300.0, "L": 90.0, "score": 4.0}
    assert at_step(curve, 99) is None and at_step(curve, 250)["step"] == 200
    line = comparison_line("T.walk", "vail", 350, {"score": 5.5, "L": 120.0}, curve)
    assert "at 300 steps" in line and "score 5.5 vs 4.0 (+1.5)" in line and "L 120.0 vs 90.0 (+30.0)" in line
    assert "no evaluation at or before 50 steps" in comparison_line("T.walk", "vail", 50, {"L": 1.0}, curve)
    assert "no reported gail run on T.walk" in comparison_line("T.walk", "gail", 50, {"L": 1.0}, [])


def test_only_runs_with_the_same_settings_are_compared(tmp_path):
    _run(tmp_path / "T.walk_lsiq", "T.walk", "lsiq", [{"step": 100, "L": 50}], agent={"alpha": 1e-3})
    _run(tmp_path / "T.walk_lsiq_a0.1", "T.walk", "lsiq", [{"step": 100, "L": 70}], agent={"alpha": 0.1})
    config = {"env": {"control": "pd", "horizon": 1000}, "agent": {"alpha": 0.1, "n_critics": 2, "n_threads": 1}}
    assert [row["L"] for row in reported_curve("T.walk", "lsiq", tmp_path, config)] == [70.0]
    assert reported_curve("T.walk", "lsiq", tmp_path, {**config, "env": {"control": "torque"}}) == []
    assert differences({"agent": {"alpha": 1e-3, "n_threads": 2}}, config) == ["agent.alpha"]


def test_a_folder_whose_config_names_another_task_is_not_reported(tmp_path):
    _run(tmp_path / "T.walk_vail", "T.run", "vail", [{"step": 100, "L": 50}])
    assert reported_logs("T.walk", "vail", tmp_path) == [] and reported_curve("T.walk", "vail", tmp_path) == []
