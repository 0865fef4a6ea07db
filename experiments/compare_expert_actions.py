"""How well each way of labelling state-only expert data recovers the actions that produced it.

Imitation from observation (LS-IQ's state-only variant, GAIL on motion capture) needs actions for expert
transitions ``(s, s')`` that have none. Two ways exist here: ``mj_inverse`` (``train.expert_actions:
inverse_dynamics``, :mod:`baselines.common.inverse_dynamics`) and an inverse-dynamics model ``f(s, s')`` learned
on the agent's own transitions (``agent.from_observations``, :mod:`baselines.common.inverse_model`). On a dataset
whose true actions are known (a ``.perfect`` one) both are compared with them::

    python experiments/compare_expert_actions.py --task UnitreeH1.walk.perfect --json results/expert_action_labels.json

The learned model is trained exactly as online (same network, learning rate, batch and standardization of the
observations by the expert data), once on transitions of a uniformly random policy (what the agent's buffer holds
at the start) and once on the demonstrator's own with Gaussian action noise (what it holds once the agent
imitates well: the model's best case). Each label set is scored against the true actions by the RMSE and the
share of their variance it explains (R^2, 1 = exact, 0 = no better than the mean action).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from baselines.common.inverse_model import InverseDynamicsModel  # noqa: E402
from baselines.common.standardizer import RunningStandardizer  # noqa: E402


def label_scores(labels: np.ndarray, true: np.ndarray) -> dict[str, float]:
    """RMSE and explained variance (R^2 over all action entries, each dimension centred on its own mean)."""
    err = labels - true
    var = np.mean((true - true.mean(axis=0)) ** 2)
    return {"rmse": float(np.sqrt(np.mean(err ** 2))), "r2": float(1.0 - np.mean(err ** 2) / var),
            "rmse_per_dim_max": float(np.sqrt(np.mean(err ** 2, axis=0)).max())}


def rollout_transitions(env: Any, act: Any, n: int, rng: np.random.Generator, desc: str) -> tuple[np.ndarray, ...]:
    """``n`` transitions ``(s, a, s')`` of ``act(obs, rng)`` on ``env`` (absorbing ones included: they are real)."""
    obs_dim, act_dim = env.info.observation_space.shape[0], env.info.action_space.shape[0]
    s, a, s2 = np.empty((n, obs_dim)), np.empty((n, act_dim)), np.empty((n, obs_dim))
    obs, t = env.reset(), 0
    for i in tqdm(range(n), desc=desc, unit="step", leave=False):
        action = np.clip(act(obs, rng), -1.0, 1.0)
        nxt, _, absorbing, _ = env.step(action)
        s[i], a[i], s2[i] = obs, action, nxt
        t += 1
        if absorbing or t >= env.info.horizon:
            obs, t = env.reset(), 0
        else:
            obs = nxt
    return s, a, s2


def fit_inverse_model(s: np.ndarray, a: np.ndarray, s2: np.ndarray, standardizer: RunningStandardizer,
                      updates: int, batch: int, seed: int) -> InverseDynamicsModel:
    """The online model's network and optimiser, fitted for ``updates`` minibatches of ``batch`` transitions."""
    gen = torch.Generator().manual_seed(seed)
    model = InverseDynamicsModel(s.shape[1], a.shape[1], generator=gen)
    x, x2 = torch.from_numpy(standardizer.normalize(s)), torch.from_numpy(standardizer.normalize(s2))
    act = torch.from_numpy(a.astype(np.float32))
    for _ in tqdm(range(updates), desc="fitting f(s, s')", unit="update", leave=False):
        idx = torch.randint(len(x), (batch,), generator=gen)
        model.fit(x[idx], x2[idx], act[idx])
    return model


def compare(task: str, n_transitions: int, updates: int, batch: int, noise: float, seed: int) -> dict[str, Any]:
    from baselines.common.inverse_dynamics import inverse_dynamics_actions
    from loco_mujoco import LocoEnv
    from loco_mujoco.agent_datasets import agent_recipe, pretrained_root
    from loco_mujoco.policy_export import PolicyExport

    recipe = agent_recipe(task)
    if recipe is None or not task.endswith(".perfect"):
        raise ValueError(f"{task!r} has no true actions to compare with: give a .perfect task (one with a recipe)")
    env = LocoEnv.make(task, seed=seed)
    data = env.create_dataset()
    true = data["actions"].astype(np.float64)
    standardizer = RunningStandardizer(data["states"].shape[1])  # the agent's: fitted once on the expert's states
    standardizer.update(data["states"])
    results: dict[str, Any] = {"task": task, "transitions": int(len(true)), "seed": seed,
                               "mj_inverse": label_scores(inverse_dynamics_actions(env), true)}
    export = PolicyExport.load(pretrained_root() / recipe.exports[0])
    behaviours = {"random": lambda obs, rng: rng.uniform(-1.0, 1.0, true.shape[1]),
                  f"demonstrator+N(0,{noise:g})": lambda obs, rng: export.mean_action(obs[None])[0]
                  + noise * rng.standard_normal(true.shape[1])}
    x = torch.from_numpy(standardizer.normalize(data["states"]))
    x2 = torch.from_numpy(standardizer.normalize(data["next_states"]))
    for name, act in behaviours.items():
        s, a, s2 = rollout_transitions(env, act, n_transitions, np.random.default_rng(seed), name)
        model = fit_inverse_model(s, a, s2, standardizer, updates, batch, seed)
        results[f"learned_on_{name}"] = {**label_scores(model.predict(x, x2).numpy().astype(np.float64), true),
                                         "train_transitions": n_transitions, "updates": updates, "batch": batch}
    env.stop()
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="UnitreeH1.walk.perfect", help="a .perfect task (true actions known)")
    parser.add_argument("--transitions", type=int, default=50_000, help="behaviour transitions to fit f on")
    parser.add_argument("--updates", type=int, default=50_000, help="minibatch updates of f (one per env step online)")
    parser.add_argument("--batch", type=int, default=256, help="the off-policy family's agent batch")
    parser.add_argument("--noise", type=float, default=0.1, help="std of the demonstrator's action noise")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", help="also write the results here (an existing file is refused)")
    args = parser.parse_args(argv)
    if args.json and Path(args.json).exists():
        print(f"error: {args.json} exists; remove it or choose another --json", file=sys.stderr)
        return 2
    torch.set_num_threads(1)
    try:
        res = compare(args.task, args.transitions, args.updates, args.batch, args.noise, args.seed)
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print(f"{res['task']}: {res['transitions']:,} expert transitions with true actions")
    print(f"{'labels':<40} {'RMSE':>7} {'R^2':>7} {'worst dim RMSE':>15}")
    for name, r in res.items():
        if isinstance(r, dict):
            print(f"{name:<40} {r['rmse']:7.3f} {r['r2']:7.3f} {r['rmse_per_dim_max']:15.3f}")
    if args.json:
        Path(args.json).write_text(json.dumps(res, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
