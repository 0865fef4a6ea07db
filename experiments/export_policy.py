"""Export a checkpoint's policy as plain arrays: ``python experiments/export_policy.py CHECKPOINT OUT_DIR``.

The export (``policy.safetensors``, ``config.yaml``, ``card.json``; see loco_mujoco/policy_export.py) runs
with numpy alone. Its card carries the evaluation under the protocol (normalised score with its interval,
R, L) unless ``--no-eval``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("checkpoint")
    parser.add_argument("out_dir")
    parser.add_argument("--no-eval", action="store_true", help="skip the evaluation on the card")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing export in OUT_DIR")
    args = parser.parse_args(argv)

    from baselines.export import export_checkpoint

    evaluation = None
    if not args.no_eval:
        from baselines.common.evaluation import evaluate_agent
        from baselines.training import build, load_checkpoint, run_config_from_checkpoint
        from loco_mujoco.evaluation import protocol
        from loco_mujoco.evaluation.references import references

        state = load_checkpoint(args.checkpoint)
        run = run_config_from_checkpoint(state)
        _, agent = build(run)
        agent.load_state_dict(state["agent"])
        ev = evaluate_agent(agent, protocol.evaluation_env(run.task, run.env), protocol.EPISODES, True,
                            protocol.SEED, progress=True)
        refs = references(run.task, run.env)
        from loco_mujoco.evaluation.intervals import summarize

        evaluation = {"protocol": {"episodes": protocol.EPISODES, "seed": protocol.SEED, "deterministic": True},
                      "score": summarize(refs.normalized_score(ev.returns)), **ev.summary()}
    try:
        path = export_checkpoint(args.checkpoint, args.out_dir, evaluation, overwrite=args.overwrite)
    except (FileExistsError, ValueError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    size = sum(f.stat().st_size for f in Path(path).iterdir())
    print(f"export: {path} ({size:,} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
