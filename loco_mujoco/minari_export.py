"""Export an agent dataset (perfect or preference) as a local Minari dataset, where offline-RL libraries look.

One Minari episode per trajectory: observations (all its frames, float64), actions (float64, as passed to
``env.step``), the task reward of each transition (recomputed: our files store no rewards), ``terminations``
True on the last step when the final frame is absorbing (a fall), ``truncations`` True on it otherwise.
Data are float64 under float64 Box spaces with the env's bounds: nothing is rounded. The env spec is the
Gymnasium ``LocoMujoco`` env the rollouts ran in, so ``dataset.recover_environment()`` works (it emits float32).

    from loco_mujoco.minari_export import export_minari
    dataset_id = export_minari("UnitreeH1.walk.perfect")   # loco-mujoco/UnitreeH1-walk-perfect-v0
    minari.load_dataset(dataset_id)
"""

from __future__ import annotations

import re
import shutil
import warnings
from pathlib import Path
from typing import Any

import numpy as np

NAMESPACE = "loco-mujoco"
LICENSE = "MIT"
AUTHOR = "loco_mujoco"
_ID_RE = re.compile(r"^(?:[-_\w][-_\w/]*[-_\w]+/)?[-_\w]+?-v\d+$")  # Minari's id grammar, version required
# Minari nags when optional provenance is missing; we have no contact address or permalink to give.
_QUIET = ("`author_email` is set to None", "`code_permalink` is set to None")


def default_dataset_id(task: str) -> str:
    """``loco-mujoco/<task with dots as dashes>-v0``: Minari ids allow no dots."""
    return f"{NAMESPACE}/{task.replace('.', '-')}-v0"


def datasets_with_actions() -> list[str]:
    """Task names whose dataset holds actions (our agents' rollouts): the ones that can be exported."""
    from loco_mujoco.agent_datasets import AGENT_DATASET_TYPES
    from loco_mujoco.core.task_names import list_tasks

    return [t for t in list_tasks(with_data=True) if t.split(".")[-1] in AGENT_DATASET_TYPES]


def export_minari(task: str, dataset_id: str | None = None, overwrite: bool = False) -> str:
    """Write the dataset of ``task`` (e.g. ``UnitreeH1.walk.perfect``) as local Minari dataset ``dataset_id``
    under ``$MINARI_DATASETS_PATH`` (Minari's default when unset) and return its id.

    An existing dataset with that id is replaced only with ``overwrite=True`` (it is deleted first)."""
    minari = _import_minari()
    from minari.storage import get_dataset_path

    name = _exportable_name(task)
    dataset_id = default_dataset_id(name) if dataset_id is None else _check_id(dataset_id)
    path = get_dataset_path(dataset_id)
    if path.exists() and not overwrite:
        raise FileExistsError(f"a Minari dataset {dataset_id!r} already exists at {path}; pass overwrite=True "
                              "(build_datasets.py --overwrite) to replace it, or choose another id")
    if path.exists() and not (path / "data" / "metadata.json").is_file():
        raise FileExistsError(f"{path} exists but is not a Minari dataset; not replacing it. Choose another id")

    import gymnasium as gym

    from loco_mujoco import LocoEnv

    env = LocoEnv.make(name)
    gym_env = None
    try:
        ds, meta = env.dataset, env.dataset.metadata
        if ds.actions is None:
            raise ValueError(f"{name} has no actions, so it cannot be exported to Minari; datasets with actions: "
                             f"{', '.join(datasets_with_actions())}")
        buffers = _episode_buffers(env)
        spaces = {key: _float64_box(getattr(env.info, key)) for key in ("observation_space", "action_space")}
        spec_kwargs = {"env_name": meta["task"], **meta.get("env_settings", {}), "random_start": True}
        gym_env = gym.make("LocoMujoco", **spec_kwargs)  # the env the rollouts ran in: starts from real data states
        if path.exists():  # overwrite=True, checked above; everything that can fail early has run
            shutil.rmtree(path)
        if path.exists():  # appeared meanwhile (another process): not ours to replace or clean up
            raise FileExistsError(f"a Minari dataset {dataset_id!r} appeared at {path} during the export")
        try:
            with warnings.catch_warnings():
                for message in _QUIET:
                    warnings.filterwarnings("ignore", message=re.escape(message), category=UserWarning)
                dataset = minari.create_dataset_from_buffers(
                    dataset_id, buffers, env=gym_env, eval_env=gym_env.spec, algorithm_name=_algorithms(meta),
                    author=AUTHOR, description=_description(name, ds, spec_kwargs), data_format="hdf5",
                    requirements=_requirements(), jpeg_encoding=False, **spaces)
            dataset.storage.update_metadata({"license": LICENSE, "loco_mujoco_task": name,
                                             "loco_mujoco_metadata": meta, "loco_mujoco_file_sha256": _sha(ds)})
            dataset.storage.update_episode_metadata(_episode_metadata(ds))
        except BaseException:
            shutil.rmtree(path, ignore_errors=True)  # ours: it did not exist, or overwrite=True removed it
            raise
    finally:
        if gym_env is not None:
            gym_env.close()
        env.stop()
    return dataset_id


def _import_minari() -> Any:
    try:
        import h5py  # noqa: F401  (Minari's hdf5 storage, imported lazily by it)
        import minari
    except ImportError as err:
        raise ImportError(f"exporting to Minari needs minari and h5py ({err}); install them with "
                          "pip install 'loco_mujoco[minari]'") from err
    return minari


def _exportable_name(task: str) -> str:
    """The canonical name of ``task``; raises unless its dataset has actions."""
    from loco_mujoco.core.task_names import parse_task_name

    name = str(parse_task_name(task))  # raises naming the valid task names
    have = datasets_with_actions()
    if name not in have:
        raise ValueError(f"{task!r} ({name}) has no dataset with actions (motion capture holds states only), so it "
                         f"cannot be exported to Minari; datasets with actions: {', '.join(have) or 'none'}")
    return name


def _check_id(dataset_id: str) -> str:
    if not isinstance(dataset_id, str) or not _ID_RE.fullmatch(dataset_id):
        raise ValueError(f"invalid Minari dataset id {dataset_id!r}: it must read [namespace/]name-v<version> with "
                         "letters, digits, '-' and '_' only (no dots), e.g. 'loco-mujoco/UnitreeH1-walk-perfect-v0'")
    return dataset_id


def _episode_buffers(env: Any) -> list[Any]:
    """One Minari EpisodeBuffer per trajectory; observations and actions are views of the dataset's arrays."""
    from minari.data_collector import EpisodeBuffer

    ds = env.dataset
    obs = ds.observations if ds.observations is not None else env.dataset_observations()
    rewards = env.dataset_task_rewards()  # one per transition (every frame but each trajectory's last)
    absorbing = ds.absorbing if ds.absorbing is not None else np.zeros(ds.n_frames, dtype=bool)
    _check_returns(ds, rewards)
    buffers = []
    for i in range(ds.n_trajectories):
        start, stop = int(ds.split_points[i]), int(ds.split_points[i + 1])
        actions = ds.actions[start:stop - 1]
        if not np.all(np.isfinite(actions)):
            raise ValueError(f"trajectory {i} of {ds.source_file or 'the dataset'} has non-finite actions "
                             f"before its last frame; the file is corrupt: rebuild it")
        steps = stop - 1 - start
        fell = bool(absorbing[stop - 1])
        terminations = np.zeros(steps, dtype=bool)
        truncations = np.zeros(steps, dtype=bool)
        (terminations if fell else truncations)[-1] = True
        buffers.append(EpisodeBuffer(observations=obs[start:stop], actions=actions,
                                     rewards=rewards[start - i:stop - 1 - i], terminations=terminations,
                                     truncations=truncations))
    return buffers


def _check_returns(ds: Any, rewards: np.ndarray) -> None:
    """Warn when the recomputed rewards do not add up to the returns recorded at rollout time."""
    recorded = [t.get("return") for t in ds.metadata.get("trajectories", [])]
    if len(recorded) != ds.n_trajectories or None in recorded:
        return
    starts = ds.split_points[:-1] - np.arange(ds.n_trajectories)  # transition index of each trajectory's first
    sums = np.add.reduceat(rewards, starts)
    worst = float(np.max(np.abs(sums - np.asarray(recorded))))
    if worst > 1e-6 * max(1.0, float(np.max(np.abs(recorded)))):
        warnings.warn(f"recomputed task rewards differ from the returns recorded when the dataset was rolled out "
                      f"(by up to {worst:.3g} per trajectory); the exported rewards are the recomputed ones",
                      stacklevel=3)


def _float64_box(space: Any) -> Any:
    from gymnasium import spaces

    return spaces.Box(np.asarray(space.low, np.float64), np.asarray(space.high, np.float64), dtype=np.float64)


def _episode_metadata(ds: Any) -> list[dict[str, Any]]:
    """Each episode's trajectory index, first frame and the scalars recorded for it (return, set, rank)."""
    trajectories = ds.metadata.get("trajectories", [])
    out = []
    for i in range(ds.n_trajectories):
        extra = trajectories[i] if i < len(trajectories) else {}
        scalars = {k: v for k, v in extra.items() if isinstance(v, (int, float, str, bool))}
        out.append({"trajectory": i, "first_frame": int(ds.split_points[i]), **scalars})
    return out


def _algorithms(meta: dict[str, Any]) -> str:
    names = [str(a.get("algorithm")) for a in meta.get("agents", [])]
    return "+".join(dict.fromkeys(names)) or "unknown"


def _description(name: str, ds: Any, spec_kwargs: dict[str, Any]) -> str:
    meta = ds.metadata
    kind = meta.get("type", name.rsplit(".", 1)[-1])
    what = {"perfect": "expert rollouts, each cut 1 s before any fall",
            "preference": "ranked sets of sub-optimal rollouts (falls included), one set per agent; each episode's "
                          "set, rank and return are in its episode metadata"}.get(kind, "agent rollouts")
    agents = ", ".join(f"{a.get('algorithm')} ({a.get('export')})" for a in meta.get("agents", []))
    return (f"loco_mujoco {name}: {what}. {ds.n_trajectories} episodes of {meta.get('task')} with env settings "
            f"{meta.get('env_settings', {})} at {ds.frequency:g} Hz, policies {agents}, seed {meta.get('seed')}. "
            f"Observations and actions (in [-1, 1]) are float64; rewards are the task reward recomputed from the "
            f"observations; terminated = fall (absorbing), truncated = cut or horizon. Environment: "
            f"gymnasium.make('LocoMujoco', **{spec_kwargs}). Full provenance in 'loco_mujoco_metadata'.")


def _requirements() -> list[str]:
    import mujoco

    from loco_mujoco import __version__

    return [f"loco_mujoco=={__version__}", f"mujoco=={mujoco.__version__}"]


def _sha(ds: Any) -> str | None:
    from loco_mujoco.agent_datasets import file_sha256

    source = ds.source_file
    return file_sha256(source) if source is not None and Path(source).is_file() else None
