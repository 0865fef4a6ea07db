"""Pretrained cards carry the evaluation of their export: ``refresh_cards.py`` writes it (weights untouched),
``--check`` finds a card that disagrees without writing, and ``evaluate.py --pretrained FOLDER`` repeats it."""

import hashlib
import json
import math
import shutil
from pathlib import Path

import pytest

from baselines.card_evaluation import evaluate_export
from experiments import evaluate, refresh_cards
from loco_mujoco.agent_datasets import pretrained_root

REPO = Path(__file__).resolve().parent.parent
BC = "UnitreeH1.walk/bc/seed0"  # episodes of ~36 steps: the cheapest committed export to evaluate


@pytest.fixture
def export(tmp_path):
    folder = tmp_path / "pretrained" / BC
    shutil.copytree(pretrained_root() / BC, folder)
    card = json.loads((folder / "card.json").read_text())
    (folder / "card.json").write_text(json.dumps({**card, "evaluation": {}}))  # as a snapshot's card starts
    return folder


def sha256(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_refresh_writes_the_exports_own_evaluation_and_check_writes_nothing(export, capsys):
    weights = sha256(export / "policy.safetensors")
    assert refresh_cards.main([str(export)]) == 0
    assert "1 cards: 1 changed, 0 unchanged" in capsys.readouterr().out
    card = json.loads((export / "card.json").read_text())
    ev = card["evaluation"]
    assert ev["protocol"] == {"episodes": 50, "seed": 12345, "deterministic": True}
    assert ev["R"]["n"] == ev["L"]["n"] == ev["score"]["n"] == 50
    refs = ev["references"]
    assert refs["version"] == 2 and refs["random_episodes"] >= 20 and refs["random_return_se"] > 0
    # the score is the returns' affine image: mean and interval bounds alike (one bootstrap, one seed)
    span = refs["expert_return"] - refs["random_return"]
    for key in ("mean", "iqm"):
        assert math.isclose(ev["score"][key], 100 * (ev["R"][key] - refs["random_return"]) / span, abs_tol=1e-9)
    assert sha256(export / "policy.safetensors") == weights
    assert card["task"] == "UnitreeH1.walk" and card["steps"] == 100_000  # the rest of the card as it was

    before = (export / "card.json").read_bytes()
    assert refresh_cards.main([str(export), "--check"]) == 0  # evaluated again: the same figures to the bit
    assert "1 cards: 0 would change, 1 unchanged" in capsys.readouterr().out
    assert evaluate.main(["--pretrained", str(export)]) == 0
    assert "its card's figures repeated exactly" in capsys.readouterr().out

    tampered = {**card, "evaluation": {**ev, "R": {**ev["R"], "mean": ev["R"]["mean"] + 1.0}}}
    (export / "card.json").write_text(json.dumps(tampered))
    before = (export / "card.json").read_bytes()
    assert refresh_cards.main([str(export), "--check"]) == 1
    assert "1 cards: 1 would change" in capsys.readouterr().out
    assert (export / "card.json").read_bytes() == before  # --check wrote nothing
    assert evaluate.main(["--pretrained", str(export)]) == 0
    assert "its card's figures differ: R" in capsys.readouterr().out


def test_refresh_leaves_an_agreeing_card_byte_for_byte(export):
    refresh_cards.main([str(export)])
    before, stat = (export / "card.json").read_bytes(), (export / "card.json").stat().st_mtime_ns
    assert evaluate_export(export) == json.loads(before)["evaluation"]
    assert refresh_cards.main([str(export)]) == 0
    assert (export / "card.json").read_bytes() == before and (export / "card.json").stat().st_mtime_ns == stat


def test_refresh_and_evaluate_name_what_is_not_an_export(tmp_path, capsys):
    assert refresh_cards.main([str(tmp_path)]) == 2
    assert "not policy exports (a folder with policy.safetensors and card.json)" in capsys.readouterr().err
    assert refresh_cards.main(["--root", str(tmp_path)]) == 2
    assert f"no policy exports under {tmp_path}" in capsys.readouterr().err
    assert evaluate.main(["--pretrained", str(tmp_path / "missing")]) == 2
    assert "takes TASK ALGO [SEED] or an export folder" in capsys.readouterr().err
    assert evaluate.main(["--pretrained", str(tmp_path)]) == 2
    assert "is not a policy export: missing" in capsys.readouterr().err


def test_evaluation_files_are_re_evaluated_from_the_export(export, tmp_path, capsys):
    results = tmp_path / "results"
    results.mkdir()
    shutil.copy(REPO / "results" / "UnitreeH1.walk_bc_eval.json", results)
    (results / "other_eval.json").write_text(json.dumps({"task": "UnitreeH1.walk", "algorithm": "bc", "seed": 0,
                                                          "steps": 1}))  # another run: left alone
    before_other = (results / "other_eval.json").read_bytes()
    assert refresh_cards.main([str(export), "--evaluation-files", str(results)]) == 0
    assert "re-evaluated UnitreeH1.walk_bc_eval.json" in capsys.readouterr().out
    evaluation = json.loads((results / "UnitreeH1.walk_bc_eval.json").read_text())
    card = json.loads((export / "card.json").read_text())["evaluation"]
    assert evaluation["pretrained"] == str(export.resolve()) and {"stochastic", "metrics"} <= set(evaluation)
    assert card["R"] == evaluation["deterministic"]["R"] and card["score"] == evaluation["deterministic"]["score"]
    assert (results / "other_eval.json").read_bytes() == before_other

    shutil.copy(results / "UnitreeH1.walk_bc_eval.json", results / "UnitreeH1.walk_bc_copy_eval.json")
    assert refresh_cards.main([str(export), "--evaluation-files", str(results)]) == 2  # which one? nothing done
    assert "several evaluation files hold ('UnitreeH1.walk', 'bc', 0, 100000)" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        refresh_cards.main([str(export), "--check", "--evaluation-files", str(results)])
