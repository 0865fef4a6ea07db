"""Re-evaluate pretrained cards: ``python experiments/refresh_cards.py [EXPORT ...] [--check]``.

Each export (default: every one under ``pretrained/``, snapshots of preference datasets included) is evaluated
under the protocol as ``evaluate.py --pretrained`` does (``baselines.card_evaluation``: 50 episodes of its
deterministic policy, today's references) and its card's evaluation is replaced where the figures differ; the
weights, and so every dataset built from them, stay as they are. Cards written before 2026-11-30 carried the
evaluation of the training checkpoint (equal up to rounding) under references from 50 random-action episodes.
``--check`` writes nothing and exits 1 if a card would change.

``--evaluation-files`` also re-evaluates, for each export, the evaluation file of the results table that holds the
same training run (``results/*_eval.json`` with its task, algorithm, seed and steps) from the export, with the
stochastic policy and the imitation metrics, as ``land_run.py`` has done since 2026-11-30: table row, card and
``evaluate.py --pretrained`` then give one set of figures.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run from a checkout without installing

from loco_mujoco.policy_export import CARD, WEIGHTS  # noqa: E402

REPO = Path(__file__).resolve().parent.parent


def exports_under(root: Path) -> list[Path]:
    """Every export folder below ``root`` (a folder holding weights and a card), sorted."""
    return sorted(p.parent for p in root.rglob(WEIGHTS) if (p.parent / CARD).is_file())


RUN_KEY = ("task", "algorithm", "seed", "steps")  # what names one training run in a card and an evaluation file


def evaluation_files_by_run(results: Path) -> dict[tuple, list[Path]]:
    """The evaluation files in ``results`` grouped by training run (each file read once)."""
    index: dict[tuple, list[Path]] = {}
    for path in sorted(results.glob("*_eval.json")):
        data = json.loads(path.read_text())
        index.setdefault(tuple(data.get(k) for k in RUN_KEY), []).append(path)
    return index


def evaluation_file_of(card: dict, index: dict[tuple, list[Path]]) -> Path | None:
    """The evaluation file (of ``evaluation_files_by_run``) of the training run whose export carries ``card``;
    None if there is none; ``ValueError`` if several match."""
    key = tuple(card.get(k) for k in RUN_KEY)
    found = index.get(key, [])
    if len(found) > 1:
        raise ValueError(f"several evaluation files hold {key}: {', '.join(map(str, found))}")
    return found[0] if found else None


def score_text(evaluation: dict) -> str:
    """``mean [low, high]`` of a card evaluation's score, or ``-`` where it has none."""
    score = evaluation.get("score")
    if not score:
        return "-"
    low, high = score["ci95"]
    return f"{score['mean']:.2f} [{low:.2f}, {high:.2f}]"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("exports", nargs="*", type=Path, help="export folders (default: every one under --root)")
    parser.add_argument("--root", type=Path, default=None,
                        help="pretrained folder (default: $LOCO_MUJOCO_PRETRAINED or pretrained/)")
    parser.add_argument("--check", action="store_true", help="write nothing; exit 1 if a card would change")
    parser.add_argument("--evaluation-files", nargs="?", type=Path, const=REPO / "results", default=None,
                        metavar="RESULTS", help="also re-evaluate each export's evaluation file in RESULTS "
                                                "(default: results/) from the export")
    args = parser.parse_args(argv)
    if args.check and args.evaluation_files:
        parser.error("--check compares cards only; leave out --evaluation-files")
    from tqdm import tqdm

    from baselines.card_evaluation import evaluate_export, refresh_card
    from experiments.land_run import evaluate_export_into
    from loco_mujoco.agent_datasets import pretrained_root

    root = args.root or pretrained_root()
    exports = args.exports or exports_under(root)
    missing = [str(p) for p in exports if not (p / WEIGHTS).is_file() or not (p / CARD).is_file()]
    if missing:
        print(f"error: not policy exports (a folder with {WEIGHTS} and {CARD}): {', '.join(missing)}", file=sys.stderr)
        return 2
    if not exports:
        print(f"error: no policy exports under {root}", file=sys.stderr)
        return 2

    try:  # which evaluation file each export's run has, settled before any work
        index = evaluation_files_by_run(args.evaluation_files) if args.evaluation_files else {}
        files = {p: evaluation_file_of(json.loads((p / CARD).read_text()), index)
                 for p in exports} if args.evaluation_files else {}
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    changed = 0
    print(f"{'export':<48}{'card score before':>26}{'after':>26}{'R before -> after':>22}")
    for path in tqdm(exports, desc="cards", unit="export", leave=False):
        old = json.loads((path / CARD).read_text()).get("evaluation", {})
        evaluation_file = files.get(path)
        if evaluation_file is not None:
            evaluate_export_into(path, evaluation_file)
            new = json.loads((path / CARD).read_text())["evaluation"]
            tqdm.write(f"{'':<48}re-evaluated {evaluation_file.name}")
        elif args.check:
            new = evaluate_export(path)
        else:
            old, new = refresh_card(path)
        changed += old != new
        r_old = old.get("R", {}).get("mean", math.nan)
        name = str(path.relative_to(root)) if path.is_relative_to(root) else str(path)
        tqdm.write(f"{name:<48}{score_text(old):>26}{score_text(new):>26}"
                   f"{r_old:>10.2f} -> {new['R']['mean']:<9.2f}{'' if old != new else ' (unchanged)'}")
    verb = "would change" if args.check else "changed"
    print(f"{len(exports)} cards: {changed} {verb}, {len(exports) - changed} unchanged")
    return 1 if args.check and changed else 0


if __name__ == "__main__":
    sys.exit(main())
