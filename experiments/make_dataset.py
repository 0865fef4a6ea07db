"""Roll policy exports out into a perfect or preference dataset file.

    python experiments/make_dataset.py --type perfect pretrained/UnitreeH1.walk/vail/seed0 --out out/perfect.npz
    python experiments/make_dataset.py --type preference EXPORT1 EXPORT2 ... --episodes 100 --out out/pref.npz

perfect: the export's rollouts from dataset start states until ``--transitions`` transitions are kept, each
fall cut 1 s before it; preference: ``--episodes`` episodes per export, sets ranked by mean return. Use the
file with ``LocoEnv.make(task, dataset_path=FILE)``; the shipped ``<task>.perfect`` / ``.preference`` datasets
are built the same way from the exports under ``pretrained/`` (see loco_mujoco/agent_datasets.py).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("exports", nargs="+", help="policy export folders (see experiments/export_policy.py)")
    parser.add_argument("--type", required=True, choices=("perfect", "preference"))
    parser.add_argument("--out", required=True, help="dataset file to write (.npz)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the start states (and of stochastic actions)")
    parser.add_argument("--transitions", type=int, default=50_000, help="perfect: transitions to keep")
    parser.add_argument("--episodes", type=int, default=100, help="preference: episodes per export")
    parser.add_argument("--stochastic", action="store_true", help="sample actions instead of the mean action")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing --out file")
    args = parser.parse_args(argv)
    if args.type == "perfect" and len(args.exports) != 1:
        parser.error(f"--type perfect takes one export, got {len(args.exports)}")
    if args.type == "preference" and len(args.exports) < 2:
        parser.error("--type preference takes two or more exports (one ranked set each)")
    if args.transitions < 1 or args.episodes < 1:
        parser.error("--transitions and --episodes must be at least 1")
    out = Path(args.out)
    if out.exists() and not args.overwrite:
        parser.error(f"{out} exists; pass --overwrite to replace it")

    from loco_mujoco.agent_datasets import file_sha256, perfect_dataset, preference_dataset
    from loco_mujoco.policy_export import ExportError, PolicyExport

    try:
        exports = [PolicyExport.load(p) for p in args.exports]
    except ExportError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.type == "perfect":
        dataset = perfect_dataset(exports[0], args.seed, args.transitions, not args.stochastic)
    else:
        dataset = preference_dataset(exports, args.seed, args.episodes, not args.stochastic)
    dataset.save(out)
    print(f"{out}: {dataset.n_trajectories} trajectories, {dataset.n_frames - dataset.n_trajectories:,} transitions, "
          f"sha256 {file_sha256(out)}")
    if args.type == "preference":
        for s in sorted(dataset.metadata["sets"], key=lambda s: s["rank"]):
            print(f"  rank {s['rank']}: {args.exports[s['agent']]}  mean return {s['mean_return']:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
