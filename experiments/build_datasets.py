"""Build every task's real and agent datasets into the cache, or list them with provenance and figures.

    python experiments/build_datasets.py            # build all (cached ones are loaded)
    python experiments/build_datasets.py --list     # sources, licence, seconds, speed, quality; agents, returns
    python experiments/build_datasets.py --task UnitreeH1.walk --rebuild
    python experiments/build_datasets.py --task HumanoidTorque4Ages.walk.2
    python experiments/build_datasets.py --export-minari UnitreeH1.walk.perfect [--minari-id ID] [--overwrite]
"""

from __future__ import annotations

import argparse
import sys

from loco_mujoco.core.task_names import environment_class, list_tasks, parse_task_name
from loco_mujoco.datasets.registry import RECIPES, dataset_kind, load_dataset


def real_datasets(only: str | None = None) -> list[tuple[type, str, str | None, str]]:
    """(env class, task, mode, variant) of every real dataset, or of one ``Env.task[.mode]``.

    Body-size environments have one dataset per size; mode ``all`` joins them and is not listed.
    """
    out = []
    names = [only] if only else sorted({".".join(t.split(".")[:2]) for t in list_tasks()})
    for name in names:
        env_cls = environment_class(name.split(".")[0])
        parts = name.split(".")
        if len(parts) < 2 or parts[1] not in env_cls.TASKS:
            parse_task_name(name)  # raises with the valid choices
        task = parts[1]
        modes = [parts[2]] if len(parts) > 2 else [m for m in env_cls.MODES if m != "all"] or [None]
        for mode in modes:
            if mode is not None:
                parse_task_name(f"{env_cls.__name__}.{task}.{mode}")
        try:
            kind = dataset_kind(env_cls)
        except Exception:  # noqa: BLE001 - environments without datasets are listed as such
            continue
        for variant in RECIPES[kind].get(task, {}):
            out.extend((env_cls, task, mode, variant) for mode in modes)
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--list", action="store_true", help="print each dataset's provenance and quality")
    parser.add_argument("--task", help="only this Env.task")
    parser.add_argument("--rebuild", action="store_true", help="rebuild even if cached")
    parser.add_argument("--export-minari", metavar="TASK",
                        help="write TASK's agent dataset (e.g. UnitreeH1.walk.perfect) as a local Minari dataset")
    parser.add_argument("--minari-id", metavar="ID", help="Minari id (default loco-mujoco/<TASK with dashes>-v0)")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing Minari dataset with that id")
    args = parser.parse_args(argv)
    if args.export_minari is None and (args.minari_id is not None or args.overwrite):
        parser.error("--minari-id and --overwrite go with --export-minari TASK")
    if args.export_minari is not None:
        if args.list or args.task or args.rebuild:
            parser.error("--export-minari does not combine with --list, --task or --rebuild")
        return export_minari_dataset(args.export_minari, args.minari_id, args.overwrite)
    for env_cls, task, mode, variant in real_datasets(args.task):
        ds = load_dataset(env_cls, task, variant, rebuild=args.rebuild, progress=not args.list, mode=mode)
        meta = ds.metadata
        label = ".".join([env_cls.__name__, task] + ([mode] if mode else []))
        if not args.list:
            print(f"{label} [{variant}]: {ds.n_trajectories} trajectories, {ds.duration:.1f} s")
            continue
        q = meta["quality"]
        nc = "NON-COMMERCIAL" if meta["noncommercial"] else "commercial use ok"
        print(f"{label} [{variant}]  {meta['seconds']:.1f} s at {meta['frequency']:.0f} Hz, "
              f"{ds.n_trajectories} trajectories, mean speed {meta['mean_forward_speed']:.2f} m/s")
        print(f"    licence: {', '.join(meta['licences'])} ({nc})")
        print(f"    sources: {', '.join(s['path'] for s in meta['sources'])}")
        print(f"    quality: foot sliding {q['foot_sliding_mps']:.3f} m/s (p95 {q['foot_sliding_p95_mps']:.2f}), "
              f"penetration max {1000 * q['ground_penetration_max_m']:.1f} mm, "
              f"stance float {1000 * q['stance_float_mean_m']:.1f} mm, "
              f"joint-limit clipped {100 * q['joint_limit_clipped_fraction']:.2f}%, "
              f"flight {100 * q['flight_fraction']:.0f}%")
    if not args.task:
        list_agent_datasets(args.list, args.rebuild)
    return 0


def export_minari_dataset(task: str, dataset_id: str | None, overwrite: bool) -> int:
    """Export ``task``'s agent dataset to Minari and print its id, size and path; 1 with the reason on failure."""
    from loco_mujoco.minari_export import export_minari

    try:
        dataset_id = export_minari(task, dataset_id, overwrite)
    except (ValueError, FileExistsError, ImportError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 1
    import minari
    from minari.storage import get_dataset_path

    dataset = minari.load_dataset(dataset_id)
    print(f"{dataset_id}: {dataset.total_episodes} episodes, {dataset.total_steps:,} transitions, "
          f"at {get_dataset_path(dataset_id)}")
    return 0


def list_agent_datasets(details: bool, rebuild: bool) -> None:
    """Build (or load) every shipped perfect and preference dataset; with ``details`` print their agents,
    returns and sizes."""
    import numpy as np

    from loco_mujoco.agent_datasets import AGENT_RECIPES, agent_dataset_path, file_sha256
    from loco_mujoco.datasets.trajectory import TrajectoryDataset

    for name in AGENT_RECIPES:
        path = agent_dataset_path(name, rebuild=rebuild, progress=not details)
        ds = TrajectoryDataset.load(path)
        meta = ds.metadata
        n_transitions = int(np.sum(~np.isnan(ds.actions[:, 0])))
        print(f"{name}  {n_transitions:,} transitions with actions in {ds.n_trajectories} trajectories, "
              f"{path.stat().st_size / 1e6:.1f} MB, sha256 {file_sha256(path)[:16]}")
        if not details:
            continue
        print(f"    env settings: {meta['env_settings']}; seed {meta['seed']}, "
              f"{'deterministic' if meta['deterministic'] else 'stochastic'} policy; licence {meta['licences'][0]}")
        for i, agent in enumerate(meta["agents"]):
            line = f"    agent {i}: {agent['algorithm']} at {agent['steps'] / 1e6:.1f}M steps ({agent['export']})"
            if meta["type"] == "preference":
                s = meta["sets"][i]
                line += (f": rank {s['rank']}, mean return {s['mean_return']:.1f} over {len(s['returns'])} episodes, "
                         f"mean length {np.mean(s['lengths']):.0f}")
            else:
                ep = meta["episodes"]
                line += (f": {ep['rolled_out']} episodes (mean return {np.mean(ep['returns']):.1f}, mean length "
                         f"{np.mean(ep['lengths']):.0f}); {ep['fell']} fell and were cut {meta['fall_margin_s']} s "
                         "before the fall")
            print(line)


if __name__ == "__main__":
    sys.exit(main())
