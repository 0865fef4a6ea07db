"""Perfect and preference datasets: rollouts of our own agents (policy exports) in their task environment.

- **perfect**: expert states *with* the actions that produced them, in the agent's own embodiment and env
  settings. Only motion that does not lead into a fall is kept: an episode that falls is cut
  ``FALL_MARGIN_S`` before the fall.
- **preference**: ranked sets of sub-optimal episodes (falls included, flagged absorbing), one set per agent,
  with every episode's return; rank 0 is the set with the highest mean return.

Each trajectory holds the simulator states (qpos, qvel) of every frame, so an env can reset to any of them,
the observations, the actions exactly as passed to ``env.step`` (clipped to [-1, 1]; NaN at a trajectory's
last frame) and absorbing flags. The same exports and seed give a byte-identical file on one machine.

Shipped datasets are built from committed exports (``pretrained/``) into the cache on first use; the sha256
of the file as built on the machine that made the recipe is committed beside the exports with the weights
sha256 of each export it used, and a build that differs (another CPU, or an export replaced since) says so in a
warning naming the cause; a test keeps every recipe's exports equal to the recorded ones. This module sits
above the environments: the datasets layer (``loco_mujoco/datasets``) never imports it.
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from loco_mujoco.datasets.trajectory import TrajectoryDataset
from loco_mujoco.policy_export import PolicyExport

VERSION = 1  # bump when rollouts or the stored layout change
FALL_MARGIN_S = 1.0
AGENT_DATASET_TYPES = ("perfect", "preference")
# Env settings that shape the motion and so travel with the data; the rest (horizon, gamma, starts) do not.
MOTION_SETTINGS = ("control", "disable_arms", "timestep", "n_substeps", "domain_randomization_config",
                   "weight_mass", "use_foot_forces")


class DatasetBuildMismatchWarning(UserWarning):
    """A dataset built here differs from the one the recipe's author built (another CPU or library version)."""


@dataclass(frozen=True)
class AgentRecipe:
    """How a shipped agent dataset is made: its exports (folders under ``pretrained/``), seed and size."""

    exports: tuple[str, ...]
    seed: int = 0
    deterministic: bool = True
    min_transitions: int = 0  # perfect: roll out until this many transitions are kept
    episodes_per_set: int = 0  # preference: episodes per agent


AGENT_RECIPES: dict[str, AgentRecipe] = {
    "UnitreeH1.walk.perfect": AgentRecipe(exports=("UnitreeH1.walk/vail/seed0",), min_transitions=50_000),
    "UnitreeH1.walk.preference": AgentRecipe(
        exports=("UnitreeH1.walk/vail/seed0", "UnitreeH1.walk/preference/vail_seed0_21.7M",
                 "UnitreeH1.walk/preference/vail_seed0_4.4M", "UnitreeH1.walk/preference/gaifo_seed0_4.1M"),
        episodes_per_set=100),  # GAIfO's 4.1M export (the table's row went on to 20M)
    "Atlas.walk.preference": AgentRecipe(  # GAIL 20M and 5.0M, GAIfO's 5M snapshot, LS-IQ, BC (all PD)
        exports=("Atlas.walk/gail/seed0", "Atlas.walk/preference/gaifo_seed0_5M",
                 "Atlas.walk/preference/gail_seed0_5.0M", "Atlas.walk/lsiq/seed0", "Atlas.walk/bc/seed0"),
        episodes_per_set=100),
    "HumanoidTorque.walk.preference": AgentRecipe(  # VAIL 20M, GAIL 20M and its 5M snapshot, BC (all PD)
        exports=("HumanoidTorque.walk/vail/seed0", "HumanoidTorque.walk/gail/seed0",
                 "HumanoidTorque.walk/preference/gail_seed0_5M", "HumanoidTorque.walk/bc/seed0"), episodes_per_set=100),
    "UnitreeA1.simple.preference": AgentRecipe(  # GAIL 20M and its 10M snapshot, VAIL 20M, BC (all PD); 40 episodes
        exports=("UnitreeA1.simple/gail/seed0", "UnitreeA1.simple/preference/gail_seed0_10M",  # of up to 1,000 steps
                 "UnitreeA1.simple/vail/seed0", "UnitreeA1.simple/bc/seed0"), episodes_per_set=40),
    "Talos.walk.preference": AgentRecipe(  # VAIL, GAIL and its 15M snapshot, LS-IQ, BC (all PD)
        exports=("Talos.walk/vail/seed0", "Talos.walk/gail/seed0", "Talos.walk/preference/gail_seed0_15M",
                 "Talos.walk/lsiq/seed0", "Talos.walk/bc/seed0"), episodes_per_set=100),
    "HumanoidMuscle.walk.preference": AgentRecipe(  # VAIL 20M and its 5M, 10M, 15M snapshots (muscle excitations;
        exports=("HumanoidMuscle.walk/vail/seed0", "HumanoidMuscle.walk/preference/vail_seed0_5M",  # the only row run)
                 "HumanoidMuscle.walk/preference/vail_seed0_10M", "HumanoidMuscle.walk/preference/vail_seed0_15M"),
        episodes_per_set=100),
}


def pretrained_root() -> Path:
    """Folder of the committed policy exports: ``$LOCO_MUJOCO_PRETRAINED`` or the repository's ``pretrained/``."""
    env = os.environ.get("LOCO_MUJOCO_PRETRAINED")
    return Path(env).expanduser() if env else Path(__file__).resolve().parent.parent / "pretrained"


def agent_recipe(name: str) -> AgentRecipe | None:
    """The recipe of dataset ``<Env>.<task>[.<mode>].<type>``, or None if none is shipped."""
    return AGENT_RECIPES.get(name)


def motion_settings(env_kwargs: dict[str, Any]) -> dict[str, Any]:
    """The env settings of ``env_kwargs`` that travel with a dataset."""
    return {k: v for k, v in env_kwargs.items() if k in MOTION_SETTINGS}


def recipe_settings(name: str) -> dict[str, Any]:
    """The env settings a shipped dataset was made with (from its first export's card)."""
    recipe = AGENT_RECIPES[name]
    return motion_settings(PolicyExport.load(pretrained_root() / recipe.exports[0]).env_kwargs)


# ---- rollouts -------------------------------------------------------------------------------------------
@dataclass
class _Episode:
    qpos: np.ndarray
    qvel: np.ndarray
    observations: np.ndarray
    actions: np.ndarray  # (frames - 1, act)
    rewards: np.ndarray
    fell: bool


def _rollout(env, export: PolicyExport, rng: np.random.Generator | None) -> _Episode:
    obs = env.reset()
    qpos, qvel, observations, actions, rewards = [env.data.qpos.copy()], [env.data.qvel.copy()], [obs.copy()], [], []
    fell = False
    for _ in range(int(env.info.horizon)):
        action = np.clip(export.draw_action(obs, rng), -1.0, 1.0)
        obs, reward, fell, _ = env.step(action)
        actions.append(action)
        rewards.append(reward)
        qpos.append(env.data.qpos.copy())
        qvel.append(env.data.qvel.copy())
        observations.append(obs.copy())
        if fell:
            break
    return _Episode(np.array(qpos), np.array(qvel), np.array(observations), np.array(actions), np.array(rewards),
                    bool(fell))


def _env_for(export: PolicyExport, seed: int):
    from loco_mujoco import LocoEnv

    kwargs = {k: v for k, v in export.env_kwargs.items() if k not in ("random_start", "init_step_no")}
    return LocoEnv.make(_real_name(export.task), **kwargs, random_start=True, seed=seed)


def _real_name(task: str) -> str:
    parts = task.split(".")
    return ".".join(parts[:-1]) if parts[-1] in ("real", *AGENT_DATASET_TYPES) else task


def _stack(episodes: list[_Episode], env, metadata: dict[str, Any]) -> TrajectoryDataset:
    """One TrajectoryDataset of ``episodes`` (each a trajectory), actions NaN at every last frame."""
    actions, absorbing = [], []
    for ep in episodes:
        a = np.full((len(ep.qpos), ep.actions.shape[1]), np.nan)
        a[:len(ep.actions)] = ep.actions
        actions.append(a)
        flags = np.zeros(len(ep.qpos), dtype=bool)
        flags[-1] = ep.fell
        absorbing.append(flags)
    m = env.model
    split = np.concatenate([[0], np.cumsum([len(ep.qpos) for ep in episodes])])
    return TrajectoryDataset(qpos=np.concatenate([ep.qpos for ep in episodes]),
                             qvel=np.concatenate([ep.qvel for ep in episodes]), split_points=split,
                             frequency=round(1.0 / env.dt, 9),
                             joint_names=tuple(m.joint(j).name for j in range(m.njnt)),
                             metadata=metadata, actions=np.concatenate(actions),
                             observations=np.concatenate([ep.observations for ep in episodes]),
                             absorbing=np.concatenate(absorbing))


def _base_metadata(kind: str, exports: list[PolicyExport], seed: int, deterministic: bool, env) -> dict[str, Any]:
    return {"type": kind, "task": _real_name(exports[0].task), "env_settings": motion_settings(exports[0].env_kwargs),
            "seed": int(seed), "deterministic": bool(deterministic), "version": VERSION,
            "mean_forward_speed": float(env.target_velocity), "mean_speed": float(env.target_velocity),
            "licences": ["MIT (rollouts of this project's agents)"], "noncommercial": False,
            "agents": [{"algorithm": e.card.get("algorithm"), "steps": e.card.get("steps"), "sha256": e.sha256,
                        "export": _relative(e.path)} for e in exports]}


def _relative(path: Path) -> str:
    try:
        return path.resolve().relative_to(pretrained_root().resolve()).as_posix()
    except ValueError:
        return path.as_posix()


def perfect_dataset(export: PolicyExport, seed: int = 0, min_transitions: int = 50_000,
                    deterministic: bool = True, progress: bool = True) -> TrajectoryDataset:
    """Roll ``export`` out from dataset start states until ``min_transitions`` transitions are kept; episodes
    that fall are cut ``FALL_MARGIN_S`` before the fall (dropped when nothing is left)."""
    env = _env_for(export, seed)
    margin = int(round(FALL_MARGIN_S / env.dt))
    rng = None if deterministic else np.random.default_rng(seed)
    kept, n_kept, returns, lengths, cut = [], 0, [], [], 0
    bar = tqdm(total=min_transitions, desc=f"perfect {export.task}", unit="transition", disable=not progress)
    while n_kept < min_transitions:
        ep = _rollout(env, export, rng)
        returns.append(float(ep.rewards.sum()))
        lengths.append(len(ep.rewards))
        if ep.fell:
            keep = len(ep.qpos) - 1 - margin  # frames before the margin; the fall is frame len - 1
            cut += 1
            if keep < 2:
                continue
            ep = _Episode(ep.qpos[:keep], ep.qvel[:keep], ep.observations[:keep], ep.actions[:keep - 1],
                          ep.rewards[:keep - 1], False)
        kept.append(ep)
        n_kept += len(ep.actions)
        bar.update(len(ep.actions))
    bar.close()
    meta = _base_metadata("perfect", [export], seed, deterministic, env)
    meta.update({"episodes": {"returns": returns, "lengths": lengths, "fell": cut, "rolled_out": len(returns)},
                 "trajectories": [{"return": float(ep.rewards.sum()), "length": len(ep.actions)} for ep in kept],
                 "fall_margin_s": FALL_MARGIN_S, "transitions": int(n_kept)})
    dataset = _stack(kept, env, meta)
    env.stop()
    return dataset


def preference_dataset(exports: list[PolicyExport], seed: int = 0, episodes_per_set: int = 40,
                       deterministic: bool = True, progress: bool = True) -> TrajectoryDataset:
    """``episodes_per_set`` episodes of each export (the same start states for every set), ranked by mean return."""
    tasks = {_real_name(e.task) for e in exports}
    if len(tasks) != 1:
        raise ValueError(f"preference sets must come from agents of one task, got {sorted(tasks)}")
    sets, episodes, env = [], [], None
    for k, export in enumerate(exports):
        env = _env_for(export, seed)
        env.seed(seed)
        rng = None if deterministic else np.random.default_rng(seed)
        eps = [_rollout(env, export, rng) for _ in tqdm(range(episodes_per_set), desc=f"set {k}", unit="episode",
                                                         disable=not progress)]
        returns = [float(ep.rewards.sum()) for ep in eps]
        sets.append({"agent": k, "returns": returns, "lengths": [len(ep.rewards) for ep in eps],
                     "mean_return": float(np.mean(returns))})
        episodes.extend(eps)
        env.stop()
    order = sorted(range(len(sets)), key=lambda k: -sets[k]["mean_return"])
    for rank, k in enumerate(order):
        sets[k]["rank"] = rank
    meta = _base_metadata("preference", exports, seed, deterministic, env)
    meta.update({"sets": sets, "trajectories": [{"set": k, "rank": sets[k]["rank"], "return": r}
                                                for k in range(len(sets)) for r in sets[k]["returns"]]})
    return _stack(episodes, env, meta)


# ---- shipped datasets: built on first use ------------------------------------------------------------------
def _real_dataset_key(name: str) -> str:
    """The cache name of the real dataset the rollouts start from: when it changes, so do the rollouts."""
    from loco_mujoco.core.task_names import environment_class, parse_task_name
    from loco_mujoco.datasets.registry import cache_path, resolve_variant

    parsed = parse_task_name(_real_name(name))
    subject = environment_class(parsed.env).dataset_subject()
    return cache_path(subject, parsed.task, resolve_variant(subject, parsed.task, None), parsed.mode).name


def _export_sha256s(recipe: AgentRecipe) -> dict[str, str]:
    """{export folder: weights sha256} of the recipe's exports, in recipe order."""
    return {e: PolicyExport.load(pretrained_root() / e).sha256 for e in recipe.exports}


def _recipe_key(name: str, recipe: AgentRecipe) -> str:
    shas = list(_export_sha256s(recipe).values())
    key = json.dumps({"version": VERSION, "name": name, "recipe": asdict(recipe), "exports": shas,
                      "starts": _real_dataset_key(name)}, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:12]


def sha256_file(name: str) -> Path:
    """Where the build record of shipped dataset ``name`` is committed: the file's sha256 as its author built it
    (first line), then the weights sha256 of every export it was built from (``<sha256>  export <folder>``)."""
    task, kind = name.rsplit(".", 1)
    return pretrained_root() / task / "datasets" / f"{kind}.sha256"


def recorded_build(name: str) -> tuple[str | None, dict[str, str]]:
    """The committed build record of ``name``: the dataset's sha256 and {export folder: weights sha256} (None and
    {} without a record; an older record holds no exports)."""
    path = sha256_file(name)
    if not path.exists():
        return None, {}
    lines = [line.split() for line in path.read_text().splitlines() if line.strip()]
    exports = {parts[2]: parts[0] for parts in lines[1:] if len(parts) == 3 and parts[1] == "export"}
    return lines[0][0], exports


def changed_exports(name: str) -> list[str]:
    """The recipe's exports whose weights differ from (or are missing in) the committed build record: a
    replaced export silently changes the dataset, so tests and the build check this."""
    _, recorded = recorded_build(name)
    return [e for e, sha in _export_sha256s(AGENT_RECIPES[name]).items() if recorded.get(e) != sha]


def record_build(name: str, path: str | Path) -> Path:
    """Write the build record of shipped dataset ``name`` from the file at ``path`` (its author, after building)."""
    record = sha256_file(name)
    record.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"{file_sha256(path)}  {name}"]
    lines += [f"{sha}  export {e}" for e, sha in _export_sha256s(AGENT_RECIPES[name]).items()]
    record.write_text("\n".join(lines) + "\n")
    return record


def build_agent_dataset(name: str, progress: bool = True) -> TrajectoryDataset:
    """Roll out shipped dataset ``name`` from its recipe (no cache)."""
    recipe = AGENT_RECIPES[name]
    exports = [PolicyExport.load(pretrained_root() / e) for e in recipe.exports]
    if name.endswith(".perfect"):
        return perfect_dataset(exports[0], recipe.seed, recipe.min_transitions, recipe.deterministic, progress)
    return preference_dataset(exports, recipe.seed, recipe.episodes_per_set, recipe.deterministic, progress)


def agent_dataset_path(name: str, rebuild: bool = False, progress: bool = True) -> Path:
    """The cached file of shipped dataset ``name``, built on first use; warns if it differs from the author's."""
    from loco_mujoco.datasets.sources.fetch import cache_dir

    recipe = AGENT_RECIPES.get(name)
    if recipe is None:
        raise KeyError(f"no shipped agent dataset {name!r}; shipped: {', '.join(AGENT_RECIPES)}")
    path = cache_dir() / "datasets" / f"{name}.{_recipe_key(name, recipe)}.npz"
    if path.exists() and not rebuild:
        return path
    build_agent_dataset(name, progress).save(path)
    expected, _ = recorded_build(name)
    actual = file_sha256(path)
    if expected is not None and expected != actual:
        changed = changed_exports(name)
        cause = (f"its exports {', '.join(changed)} are not the ones recorded in {sha256_file(name)}" if changed
                 else "as on another CPU")
        warnings.warn(f"{name}: the dataset built here (sha256 {actual[:16]}...) differs from the one its recipe's "
                      f"author built ({expected[:16]}...), {cause}; results on it name this file's sha256",
                      DatasetBuildMismatchWarning, stacklevel=2)
    return path


def file_sha256(path: str | Path) -> str:
    """sha256 of a dataset file: every run records the one it trained on."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()
