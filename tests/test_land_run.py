"""Landing a run in the repository: a finished run becomes log, evaluation, curve, export and table row; an
unfinished one is parked as its resumable state; nothing is overwritten unasked."""

import dataclasses
import json
import shutil

import pytest
import torch
from conftest import TINY_TRAINING

from experiments import evaluate
from experiments.land_run import (
    LandingRefused,
    card_evaluation,
    datasets_built_from,
    land,
    main,
    park,
    plan_landing,
    read_run,
)

TINY = {**TINY_TRAINING, "train": {**TINY_TRAINING["train"], "n_steps": 200, "epoch_steps": 200,
                                   "n_eval_episodes": 1}}


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A tiny GAIfO run on UnitreeH1.walk, seed 3, trained to its 200 steps."""
    from baselines.config import load_run_config
    from baselines.training import Trainer

    out = tmp_path_factory.mktemp("land") / "run"
    Trainer(load_run_config("UnitreeH1.walk", "gaifo", seed=3, overrides=TINY), out, progress=False).train()
    return out


def unfinished_copy(finished, folder):
    """The same run as if it had been stopped at 200 of 400 steps."""
    shutil.copytree(finished, folder)
    state = torch.load(folder / "checkpoint.pt", weights_only=False)
    state["run_config"]["train"]["n_steps"] = 400
    torch.save(state, folder / "checkpoint.pt")
    return folder


def test_park_copies_the_resumable_state_and_refuses_what_it_would_overwrite(finished, tmp_path, capsys):
    half = unfinished_copy(finished, tmp_path / "half")
    results = tmp_path / "results"
    assert main([str(half), "--park", "--results", str(results)]) == 0
    parked = results / "runs" / "UnitreeH1.walk_gaifo_seed3"
    expected = ["checkpoint.pt", "config.yaml", "machines.csv", "progress.csv"]  # no TensorBoard, no replay buffer
    assert sorted(p.name for p in parked.iterdir()) == expected
    assert (parked / "checkpoint.pt").read_bytes() == (half / "checkpoint.pt").read_bytes()
    printed = capsys.readouterr().out
    assert "at 200 of 400 steps" in printed
    assert f"--algos gaifo --seeds 3 --threads 1 --from-parked {results / 'runs'} --out" in printed
    (half / "snapshots" / "100").mkdir(parents=True)
    (half / "snapshots" / "100" / "card.json").write_text("{}")
    park(read_run(half), results, snapshots=True)  # the same state again: allowed; with its snapshots when asked
    assert (parked / "snapshots" / "100" / "card.json").read_text() == "{}"

    with pytest.raises(LandingRefused, match="finished .*land it without --park"):
        park(read_run(finished), results)
    with pytest.raises(LandingRefused, match="is unfinished .*--park"):
        plan_landing(read_run(half), results, tmp_path / "pretrained")
    later = read_run(half)
    with pytest.raises(LandingRefused, match=r"later state of this run \(200 steps > 100\)"):
        park(dataclasses.replace(later, steps=100), results)
    agent = dataclasses.replace(later.config.agent, max_kl=0.5)
    other = dataclasses.replace(later, config=dataclasses.replace(later.config, agent=agent))
    with pytest.raises(LandingRefused, match="holds another run .*max_kl"):
        park(other, results)
    assert main([str(tmp_path / "nothing"), "--park", "--results", str(results)]) == 2
    assert "holds no checkpoint.pt" in capsys.readouterr().err


def test_landing_writes_everything_from_one_evaluation_and_never_overwrites(finished, tmp_path, capsys):
    results, pretrained = tmp_path / "results", tmp_path / "pretrained"
    park(read_run(unfinished_copy(finished, tmp_path / "half")), results)  # an earlier state, superseded
    run = read_run(finished)
    targets = land(run, results, pretrained)
    staged = targets.export.parent / f".{targets.export.name}.landing"
    assert f"evaluating the export staged in {staged}; it moves to {targets.export}" in capsys.readouterr().out

    assert sorted(p.name for p in targets.run_folder.iterdir()) == ["config.yaml", "machines.csv", "progress.csv"]
    evaluation = json.loads(targets.evaluation.read_text())
    assert {"deterministic", "stochastic", "metrics"} <= set(evaluation) and evaluation["steps"] == 200
    assert len(evaluation["deterministic"]["returns"]) == 50
    assert all(p.exists() for p in targets.curves)
    card = json.loads((targets.export / "card.json").read_text())
    assert card["evaluation"] == json.loads(json.dumps(card_evaluation(evaluation)))  # the same numbers, once
    assert evaluation["pretrained"] == str(targets.export.resolve()) and "card_evaluation" not in evaluation
    assert card["evaluation"]["references"]["random_return"] == evaluation["references"]["random_return"]
    assert not any(p.name.endswith(".landing") for p in targets.export.parent.iterdir())  # no staging folder left
    assert evaluate.main(["--pretrained", str(targets.export)]) == 0  # what was landed is what users evaluate
    assert "its card's figures repeated exactly" in capsys.readouterr().out
    assert card["steps"] == 200 and card["seed"] == 3 and targets.export == pretrained / "UnitreeH1.walk/gaifo/seed3"
    table = (results / "table.md").read_text()
    score = evaluation["deterministic"]["score"]["mean"]
    row = next(line for line in table.splitlines() if line.startswith("| UnitreeH1.walk | GAIfO |"))
    assert f"{score:.1f}" in row and "| 0 of 3 + 1 |" in row and "seed 3 outside the planned 0, 1, 2" in row, row

    before = {p: p.read_bytes() for p in results.rglob("*") if p.is_file()}
    with pytest.raises(LandingRefused, match="holds a landed run; pass --replace"):
        plan_landing(run, results, pretrained)
    assert main([str(finished), "--results", str(results), "--pretrained", str(pretrained)]) == 2
    assert "pass --replace" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in results.rglob("*") if p.is_file()} == before


def test_replacing_an_export_that_datasets_are_built_from_needs_consent(finished, tmp_path):
    assert "UnitreeH1.walk.perfect" in datasets_built_from("UnitreeH1.walk/vail/seed0")
    assert datasets_built_from("UnitreeH1.walk/vail/seed7") == []
    run = read_run(finished)
    vail = dataclasses.replace(run, config=dataclasses.replace(run.config, algorithm="vail", seed=0))
    (tmp_path / "pretrained" / "UnitreeH1.walk/vail/seed0").mkdir(parents=True)
    with pytest.raises(LandingRefused, match="shipped datasets .*UnitreeH1.walk.perfect.*--allow-dataset-change"):
        plan_landing(vail, tmp_path / "results", tmp_path / "pretrained", replace=True)
    targets = plan_landing(vail, tmp_path / "results", tmp_path / "pretrained", replace=True,
                           allow_dataset_change=True)
    assert targets.evaluation.name == "UnitreeH1.walk_vail_eval.json"
