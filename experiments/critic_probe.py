"""Where an off-policy run's critics put value around the expert's actions, read from its checkpoint.

The training log's ``q_expert`` (:mod:`experiments.critic_values`) says whether the critics stayed in the range
their rewards allow, not whether they can guide the actor. This probe evaluates ``min_j Q_j`` on expert states at
the expert's action, at the policy's mean action, at the expert's action plus Gaussian noise of a few scales
(clipped to [-1, 1]) and at points between the two actions; on the replay buffer's states (where the buffer lies
beside the checkpoint) at the stored and at the mean actions. A critic whose value drops from the expert's action
to the bottom of its range within noise smaller than the distance between expert and policy actions is a narrow
ridge: it rewards the actions it saw and no neighbourhood, and gives the actor little to climb::

    python experiments/critic_probe.py results/runs/Atlas.walk_sqil --json probe.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from experiments.critic_values import value_bound  # noqa: E402

NOISE = (0.05, 0.1, 0.2, 0.5)  # standard deviations added to the expert's actions (actions span [-1, 1])
BLEND = (0.25, 0.5, 0.75)  # shares of the expert's action in points between it and the policy's mean action


def _values(agent: Any, x: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
    """``min_j Q_j(x, action)`` per row (standardized ``x``), as the actor and the targets use them."""
    values, _ = agent.critic(torch.cat([x, action], 1))
    return values.amin(0)


def _mean_action(agent: Any, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """The policy's deterministic action ``tanh(mu)`` and its standard deviation (before the squashing)."""
    mean, log_std = agent.policy.mean_log_std_t(x)
    return torch.tanh(mean), log_std.exp()


def probe(agent: Any, n: int = 2048, noise: tuple[float, ...] = NOISE, seed: int = 0) -> dict[str, Any]:
    """The critics' mean values (module docstring) over ``n`` expert transitions and ``n`` replay transitions
    drawn with ``seed``; distances are root mean squares per action dimension."""
    if n < 1:
        raise ValueError(f"n must be at least 1, got {n}")
    rng = np.random.default_rng(seed)
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        x, expert_action = agent.expert_rows(rng.integers(len(agent.expert), size=n))
        mean_action, std = _mean_action(agent, x)
        at_expert = _values(agent, x, expert_action)
        out = {"expert_states": {
            "q_expert_action": float(at_expert.mean()),
            "q_policy_mean_action": float(_values(agent, x, mean_action).mean()),
            "q_expert_action_plus_noise": {
                f"{s:g}": float(_values(agent, x, (expert_action + s * torch.randn(expert_action.shape,
                                                                                   generator=generator)).clamp(-1, 1)
                                        ).mean()) for s in noise},
            "q_between": {f"{t:g}": float(_values(agent, x, t * expert_action + (1 - t) * mean_action).mean())
                          for t in BLEND},
            "rms_policy_minus_expert_action": float((mean_action - expert_action).square().mean().sqrt()),
            "rms_expert_action": float(expert_action.square().mean().sqrt()),
            "policy_std": float(std.mean()),
        }}
        buffer = agent.buffer
        if buffer.size:
            rows = rng.integers(buffer.size, size=n)
            xa = torch.from_numpy(agent.obs_standardizer.normalize(buffer.states[rows]))
            own_mean, own_std = _mean_action(agent, xa)
            out["agent_states"] = {"q_stored_action": float(_values(agent, xa, torch.from_numpy(buffer.actions[rows]))
                                                            .mean()),
                                   "q_policy_mean_action": float(_values(agent, xa, own_mean).mean()),
                                   "policy_std": float(own_std.mean())}
    return out


def load_agent(path: Path) -> tuple[Any, dict[str, Any], int]:
    """The agent of the checkpoint at ``path`` (a run directory or its ``checkpoint.pt``) with the replay buffer
    beside it where there is one, its run config as a dict, and its training steps."""
    from baselines import ALGORITHMS
    from baselines.common.offpolicy import OffPolicyImitation
    from baselines.training import REPLAY, build, load_checkpoint, run_config_from_checkpoint

    state = load_checkpoint(path)
    run = run_config_from_checkpoint(state)
    if not issubclass(ALGORITHMS[run.algorithm], OffPolicyImitation):
        raise ValueError(f"{path} is a {run.algorithm} run; the probe reads the critics of off-policy runs "
                         "(iq_learn, lsiq, sqil)")
    _, agent = build(run)
    agent.load_state_dict(state["agent"])
    replay = (path if path.is_dir() else path.parent) / REPLAY
    if replay.exists():
        agent.load_buffer(replay)
    return agent, run.to_dict(), int(state["steps"])


def render(result: dict[str, Any]) -> str:
    """The probe as lines of text."""
    e = result["expert_states"]
    lines = [f"{result['run']}: {result['algorithm']} at {result['steps']:,} steps; "
             f"value bound {result['bound']}",
             f"expert states: Q at the expert's action {e['q_expert_action']:.2f}, at the policy's mean action "
             f"{e['q_policy_mean_action']:.2f} (rms distance {e['rms_policy_minus_expert_action']:.3f} per dimension, "
             f"expert actions rms {e['rms_expert_action']:.3f}; policy std {e['policy_std']:.4f})",
             "  expert's action + N(0, s): " + ", ".join(f"s {s}: {v:.2f}"
                                                        for s, v in e["q_expert_action_plus_noise"].items()),
             "  t expert's + (1 - t) policy's: " + ", ".join(f"t {t}: {v:.2f}" for t, v in e["q_between"].items())]
    a = result.get("agent_states")
    lines.append("agent states: no replay buffer beside the checkpoint" if a is None else
                 f"agent states: Q at the stored action {a['q_stored_action']:.2f}, at the policy's mean action "
                 f"{a['q_policy_mean_action']:.2f} (policy std {a['policy_std']:.4f})")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", help="a run directory holding checkpoint.pt (and replay.npz), or the checkpoint")
    parser.add_argument("--samples", type=int, default=2048, help="expert and replay transitions drawn (each)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draws and the noise")
    parser.add_argument("--json", help="also write the figures to this file (never overwritten)")
    args = parser.parse_args(argv)
    if args.json and Path(args.json).exists():
        print(f"error: {args.json} exists; give another --json path (results are never overwritten)",
              file=sys.stderr)
        return 2
    torch.set_num_threads(1)
    path = Path(args.run)
    try:
        agent, config, steps = load_agent(path)
        result = probe(agent, args.samples, seed=args.seed)
    except (FileNotFoundError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    bound = value_bound(config["algorithm"], config)
    result = {"run": path.as_posix(), "algorithm": config["algorithm"], "steps": steps,
              "bound": None if bound is None else f"{bound[0]:g} ({bound[1]})", **result}
    print(render(result))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
