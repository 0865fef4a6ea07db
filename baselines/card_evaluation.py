"""The evaluation a pretrained card carries: of the exported policy itself, under the protocol.

A card's figures come from its export (float32 numpy), not from the training checkpoint it was cut from: the two
act alike up to rounding, but an episode that passes near a fall can part after a rounding difference (Talos.walk
VAIL: 26 of 50 returns equal, the mean 0.1 R apart), so only the export's own evaluation is what
``evaluate.py --pretrained`` reproduces, to the last bit on the machine that wrote it. The card also records the
references it was normalised by (1,000 random-action episodes since references version 2).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from loco_mujoco.evaluation import protocol
from loco_mujoco.evaluation.intervals import summarize
from loco_mujoco.evaluation.references import VERSION, References, references
from loco_mujoco.policy_export import CARD, PolicyExport, write_card

# What a card keeps of its references: enough to renormalise its returns and to judge the random R's noise.
CARD_REFERENCES = ("expert_return", "random_return", "random_return_se", "random_episodes", "zero_return",
                   "hold_return", "dataset_digest")


def summary_figures(returns: Any, summary: dict[str, Any], refs: References, episodes: int, seed: int
                    ) -> dict[str, Any]:
    """A card's evaluation from one deterministic evaluation: its protocol, score, R, J and L, and references."""
    return {"protocol": {"episodes": episodes, "seed": seed, "deterministic": True},
            "score": summarize(refs.normalized_score(returns), seed=seed),
            **{k: summary[k] for k in ("R", "J", "L")},
            "references": {"version": VERSION, **{k: getattr(refs, k) for k in CARD_REFERENCES}}}


def evaluate_export(path: str | Path, episodes: int = protocol.EPISODES, seed: int = protocol.SEED,
                    progress: bool = False) -> dict[str, Any]:
    """The card evaluation of the export in ``path``: its deterministic policy over ``episodes`` episodes of its
    task under its card's env settings, normalised by that task's references (measured once and cached)."""
    from baselines.common.evaluation import evaluate_agent
    from baselines.pretrained import PretrainedPolicy

    export = PolicyExport.load(path)
    refs = references(export.task, export.env_kwargs, progress=progress)
    env = protocol.evaluation_env(export.task, export.env_kwargs, seed=seed)
    ev = evaluate_agent(PretrainedPolicy(export), env, episodes, True, seed, progress=progress)
    env.stop()
    return json.loads(json.dumps(summary_figures(ev.returns, ev.summary(), refs, episodes, seed), default=float))


def refresh_card(path: str | Path, progress: bool = False) -> tuple[dict[str, Any], dict[str, Any]]:
    """Evaluate the export in ``path`` and put the result on its card where it differs; (old, new) evaluation."""
    path = Path(path)
    new = evaluate_export(path, progress=progress)
    card = json.loads((path / CARD).read_text())
    old = card.get("evaluation", {})
    if old != new:
        write_card(path, {**card, "evaluation": new})
    return old, new
