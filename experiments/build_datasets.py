"""Build every task's real and agent datasets into the cache, or list them with provenance and figures.

    python experiments/build_datasets.py            # build all (cached ones are loaded)
    python experiments/build_datasets.py --list     # sources, licence, seconds, speed, quality; agents, returns
    python experiments/build_datasets.py --task UnitreeH1.walk --rebuild
    python experiments/build_datasets.py --task HumanoidTorque4Ages.walk.2
    python experiments/build_datasets.py --export-minari UnitreeH1.walk.perfect [--minari-id ID] [--overwrite]
    python experiments/build_datasets.py --record UnitreeA1.simple.preference   # after changing a recipe
    python experiments/build_datasets.py --clip ../shared/mocap/cmu/07_02.bvh --robot UnitreeH1   # any clip

The quadruped tasks' permissive datasets are rollouts of our trotting controller (loco_mujoco/controllers);
every humanoid dataset is checked against the quality goals of loco_mujoco/datasets/quality.py.
"""

from __future__ import annotations

import argparse
import sys
import warnings

from loco_mujoco.controllers.datasets import load_real_dataset
from loco_mujoco.core.task_names import environment_class, list_tasks, parse_task_name
from loco_mujoco.datasets.quality import quality_violations
from loco_mujoco.datasets.registry import RECIPES, dataset_kind, retarget_file
from loco_mujoco.datasets.trajectory import TrajectoryDataset


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
            kind = dataset_kind(env_cls.dataset_subject())
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
    parser.add_argument("--clip", metavar="PATH", help="retarget one motion file (.bvh .mot .sto .trc .txt) and "
                        "print its quality figures; with --robot")
    parser.add_argument("--robot", metavar="NAME", help="the embodiment for --clip, e.g. UnitreeH1")
    parser.add_argument("--no-foot-lock", action="store_true", help="--clip: the joint mapping alone, no IK")
    parser.add_argument("--jobs", type=int, default=2, help="datasets built in parallel processes (default 2)")
    parser.add_argument("--record", metavar="NAME", help="rebuild shipped agent dataset NAME (e.g. "
                        "UnitreeA1.simple.preference) and write its build record: the file's sha256 and "
                        "its exports' (pretrained/<task>/datasets/<type>.sha256)")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error(f"--jobs must be at least 1, got {args.jobs}")
    if args.export_minari is None and (args.minari_id is not None or args.overwrite):
        parser.error("--minari-id and --overwrite go with --export-minari TASK")
    if args.record is not None:
        if args.list or args.task or args.rebuild or args.export_minari is not None:
            parser.error("--record NAME does not combine with --list, --task, --rebuild or --export-minari")
        return record_agent_dataset(args.record)
    if args.export_minari is not None:
        if args.list or args.task or args.rebuild:
            parser.error("--export-minari does not combine with --list, --task or --rebuild")
        return export_minari_dataset(args.export_minari, args.minari_id, args.overwrite)
    if args.clip is not None or args.robot is not None:
        if args.clip is None or args.robot is None:
            parser.error("--clip PATH and --robot NAME go together")
        return show_clip(args.clip, args.robot, args.task or "walk", not args.no_foot_lock)
    datasets = real_datasets(args.task)
    rebuild = args.rebuild
    if not args.list and args.jobs > 1 and len(datasets) > 1:
        build_in_parallel(datasets, args.jobs, rebuild)
        rebuild = False
    for env_cls, task, mode, variant in datasets:
        ds = load_real_dataset(env_cls.dataset_subject(), task, variant, mode, rebuild, progress=not args.list)
        meta = ds.metadata
        label = ".".join([env_cls.__name__, task] + ([mode] if mode else []))
        if not args.list:
            print(f"{label} [{variant}]: {ds.n_trajectories} trajectories, {ds.duration:.1f} s")
            continue
        q = meta["quality"]
        nc = "NON-COMMERCIAL" if meta["noncommercial"] else "commercial use ok"
        actions = f"actions: yes ({meta.get('env_settings', {}).get('control', '?')} control)" \
            if ds.actions is not None else "actions: no (inverse dynamics)"
        print(f"{label} [{variant}]  {meta['seconds']:.1f} s at {meta['frequency']:.0f} Hz, "
              f"{ds.n_trajectories} trajectories, mean speed {meta['mean_forward_speed']:.2f} m/s, {actions}")
        print(f"    licence: {', '.join(meta['licences'])} ({nc})")
        print(f"    sources: {', '.join(s.get('path') or s.get('module', '?') for s in meta['sources'])}")
        print(f"    quality: {quality_line(q)}")
        if dataset_kind(env_cls) == "human":
            problems = quality_violations(meta)
            print("    goals: " + ("met" if not problems else "MISSED: " + "; ".join(problems)))
    if not args.task:
        list_agent_datasets(args.list, args.rebuild)
    return 0


def _build_one(entry: tuple[str, str, str | None, str], rebuild: bool) -> None:
    env_name, task, mode, variant = entry
    load_real_dataset(environment_class(env_name).dataset_subject(), task, variant, mode, rebuild, progress=False)


def build_in_parallel(datasets: list[tuple[type, str, str | None, str]], jobs: int, rebuild: bool) -> None:
    """Build the datasets into the cache in ``jobs`` processes, longest first (walking and carrying clips are
    the longest); each process writes its own cache files."""
    from concurrent.futures import ProcessPoolExecutor

    from tqdm import tqdm

    order = sorted(datasets, key=lambda d: (d[1] not in ("walk", "carry"), d[0].__name__, d[1], str(d[2])))
    entries = [(cls.__name__, task, mode, variant) for cls, task, mode, variant in order]
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(_build_one, entry, rebuild) for entry in entries]
        for future in tqdm(futures, desc=f"building datasets ({jobs} processes)", unit="dataset"):
            future.result()


def quality_line(q: dict) -> str:
    """The quality figures of a dataset or clip on one line."""
    return (f"foot sliding {q['foot_sliding_mps']:.3f} m/s (p95 {q['foot_sliding_p95_mps']:.3f}), "
            f"penetration max {1000 * q['ground_penetration_max_m']:.1f} mm, "
            f"stance float {1000 * q['stance_float_mean_m']:.1f} mm, "
            f"joint-limit clipped {100 * q.get('joint_limit_clipped_fraction', 0.0):.2f}%, "
            f"flight {100 * q['flight_fraction']:.1f}%")


def show_clip(path: str, robot: str, task: str, foot_lock: bool) -> int:
    """Retarget one motion file onto ``robot`` and print its quality figures against the goals."""
    try:
        env_cls = environment_class(robot)
        subject = env_cls.dataset_subject()
        if task not in subject.tasks:
            raise ValueError(f"{robot} has no task {task!r}; tasks: {list(subject.tasks)}")
        out = retarget_file(path, subject.target(task, None), foot_lock=foot_lock)
    except (ValueError, FileNotFoundError, RuntimeError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    q = out.quality
    seconds = (len(out.qpos) - 1) / out.frequency
    kind = "walking (no flight)" if q.get("walking", 0.0) else "running (flight allowed)"
    print(f"{path} on {robot}: {len(out.qpos)} frames, {seconds:.1f} s, {kind}, "
          f"foot lock {'on' if foot_lock else 'off'}")
    print(f"    speed {q['mean_speed_mps']:.2f} m/s, forward {q['mean_travel_forward_mps']:.2f} m/s, "
          f"heading change {q['heading_change_deg']:.0f} deg, leg scale {q['leg_length_scale']:.2f}")
    print(f"    quality: {quality_line(q)}")
    meta = {"task": task if q.get("walking", 0.0) else "run", "quality": q,
            "trajectories": [{"name": out.name, "source": str(path), "quality": q}]}
    problems = quality_violations(meta)
    print("    goals: " + ("met" if not problems else "MISSED: " + "; ".join(problems)))
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


def record_agent_dataset(name: str) -> int:
    """Rebuild shipped agent dataset ``name`` and write its build record (for the recipe's author)."""
    from loco_mujoco.agent_datasets import AGENT_RECIPES, agent_dataset_path, record_build

    if name not in AGENT_RECIPES:
        raise SystemExit(f"error: no shipped agent dataset {name!r}; shipped: {', '.join(AGENT_RECIPES)}")
    with warnings.catch_warnings():  # the old record is being replaced: its mismatch is expected
        warnings.simplefilter("ignore")
        path = agent_dataset_path(name, rebuild=True)
    record = record_build(name, path)
    print(f"{name}: {path} -> {record}")
    print(record.read_text(), end="")
    return 0


def list_agent_datasets(details: bool, rebuild: bool) -> None:
    """Build (or load) every shipped perfect and preference dataset; with ``details`` print their agents,
    returns and sizes."""
    import numpy as np

    from loco_mujoco.agent_datasets import AGENT_RECIPES, agent_dataset_path, file_sha256

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
