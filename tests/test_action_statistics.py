"""experiments/action_statistics.py: action figures of a pretrained agent beside uniformly random actions."""

import json

import numpy as np
import pytest

from experiments.action_statistics import main, statistics


def test_statistics_pool_episodes_and_measure_saturation_and_change():
    bang = np.array([[1.0, -1.0], [1.0, -1.0], [-1.0, 1.0]])  # at the bounds; one switch of size 2 per component
    still = np.array([[0.0, 0.5]])  # a one-step episode adds no step change
    figures = statistics([bang, still])
    assert figures["L"] == 2.0
    assert figures["at_bound"] == pytest.approx(6 / 8)
    assert figures["step_change"] == pytest.approx(4 / 4)  # |diffs| 0, 0, 2, 2
    assert figures["mean_action"] == pytest.approx(0.5 / 8)
    uniform = np.random.default_rng(0).uniform(-1, 1, (20_000, 3))
    figures = statistics([uniform])
    assert figures["at_bound"] == pytest.approx(0.01, abs=0.003) and figures["step_change"] == pytest.approx(2 / 3,
                                                                                                             abs=0.02)
    with pytest.raises(ValueError, match="at least one action"):
        statistics([bang, np.empty((0, 2))])


def test_the_command_compares_a_pretrained_agent_with_random_actions(tmp_path, capsys):
    out = tmp_path / "actions.json"
    assert main(["UnitreeH1.walk", "bc", "--episodes", "2", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.startswith("bc on UnitreeH1.walk, seed 0: actions over the protocol's first 2 start states")
    result = json.loads(out.read_text())
    agent, random = result["pretrained (deterministic)"], result["uniformly random"]
    assert 1 <= agent["L"] <= 1000 and 0 <= agent["at_bound"] <= 1 and -1 <= agent["mean_action"] <= 1
    assert random["step_change"] == pytest.approx(2 / 3, abs=0.05)
    assert main(["UnitreeH1.walk", "bc", "--episodes", "2", "--json", str(out)]) == 2  # never overwritten
    assert "never overwritten" in capsys.readouterr().err
    assert main(["UnitreeH1.walk", "bc", "--episodes", "0"]) == 2
    assert "--episodes must be at least 1" in capsys.readouterr().err
    assert main(["UnitreeH1.walk", "nosuchalgo"]) == 2
    assert "error:" in capsys.readouterr().err
