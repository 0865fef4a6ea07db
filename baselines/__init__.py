"""Imitation-learning baselines for loco_mujoco: GAIL, VAIL, GAIfO (adversarial, on Mushroom-RL's ``Core``),
IQ-Learn, LS-IQ, SQIL (off-policy actor-critic, on ``Core``) and behaviour cloning (offline).

Each algorithm lives in one module and is a Mushroom-RL ``Agent``; ``make_agent`` builds one by name from a
plain config dict (what a launcher reads from YAML)::

    import loco_mujoco as lm
    from baselines import make_agent
    from mushroom_rl.core import Core

    env = lm.LocoEnv.make("UnitreeH1.walk")
    agent = make_agent("vail", env, config={"std_0": 0.8}, seed=0)
    Core(agent, env).learn(n_steps=10_000, n_steps_per_fit=1000, quiet=True)
    torch.save(agent.state_dict(), "ckpt.pt")      # everything needed to resume exactly
"""

from __future__ import annotations

from typing import Any

from loco_mujoco import _compat  # noqa: F401  (patches mushroom-rl for our torch / numpy before first use)

# isort: split
from baselines.bc.bc import BC, BCConfig
from baselines.gaifo.gaifo import GAIfO, GAIfOConfig
from baselines.gail.gail import GAIL, GAILConfig
from baselines.iq_learn.iq_learn import IQLearn, IQLearnConfig
from baselines.lsiq.lsiq import LSIQ, LSIQConfig
from baselines.sqil.sqil import SQIL, SQILConfig
from baselines.vail.vail import VAIL, VAILConfig

ALGORITHMS = {"gail": GAIL, "vail": VAIL, "gaifo": GAIfO, "bc": BC, "iq_learn": IQLearn, "lsiq": LSIQ, "sqil": SQIL}


def is_offline(algorithm: str) -> bool:
    """Whether ``algorithm`` (a key of ``ALGORITHMS``) trains on gradient steps without environment steps (BC)."""
    return bool(getattr(ALGORITHMS[algorithm], "offline", False))


def make_agent(algorithm: str, env: Any, config: dict[str, Any] | None = None, seed: int = 0, **kwargs: Any):
    """Build the agent ``algorithm`` (a key of ``ALGORITHMS``) for ``env``; unknown config keys raise."""
    try:
        cls = ALGORITHMS[algorithm.lower()]
    except KeyError:
        raise ValueError(f"unknown algorithm {algorithm!r}; valid: {', '.join(ALGORITHMS)}") from None
    return cls.from_env(env, config=config, seed=seed, **kwargs)


__all__ = ["ALGORITHMS", "BC", "BCConfig", "GAIL", "GAILConfig", "GAIfO", "GAIfOConfig", "IQLearn", "IQLearnConfig",
           "LSIQ", "LSIQConfig", "SQIL", "SQILConfig", "VAIL", "VAILConfig", "is_offline", "make_agent"]
