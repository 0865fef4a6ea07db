"""Whether an off-policy run's critic diverged, read from its training log (``q_expert``, the critics' mean value of
expert transitions, logged every epoch).

A row whose critic left the range its rewards allow measures a broken value function more than the algorithm, so the
results table says so. Bounds on ``|Q|``: SQIL's rewards of 0 and 1 allow ``1 / (1 - gamma)``; LS-IQ clips its
targets to ``1 / (c (1 - gamma))``; IQ-Learn's implicit rewards have no fixed bound, so ten times SQIL's stands in
(a unit reward per step could not produce it). A run is flagged when its logged value passes ``SLACK`` times the
bound (the entropy term of soft values adds up to ``alpha |log pi| / (1 - gamma)``, ~5-10 at the table's settings).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from experiments.table_sources import format_steps, read_progress

SLACK = 1.25


def value_bound(algorithm: str, config: dict[str, Any]) -> tuple[float, str] | None:
    """``(bound on |Q|, where it comes from)`` for an off-policy algorithm and its run config; None for the others."""
    gamma = float((config.get("env") or {}).get("gamma", 0.99))
    horizon = 1.0 / (1.0 - gamma)
    if algorithm == "sqil":
        return horizon, "rewards in [0, 1]"
    if algorithm == "lsiq":
        c = float((config.get("agent") or {}).get("reg_mult", 0.5))
        return horizon / c, f"LS-IQ's clipped targets, c = {c:g}"
    if algorithm == "iq_learn":
        return 10.0 * horizon, "10 / (1 - gamma), no fixed bound"
    return None


def value_peak(log: Path) -> tuple[float, int] | None:
    """The largest ``|q_expert|`` a training log records and the step it was logged at; None where it logs none."""
    if not log.exists():
        return None
    rows = [r for r in read_progress(log) if math.isfinite(r.get("q_expert", math.nan))]
    if not rows:
        return None
    peak = max(rows, key=lambda r: abs(r["q_expert"]))
    return abs(peak["q_expert"]), int(peak["step"])


def bound_passed(algorithm: str, config: dict[str, Any], value: float | None) -> tuple[float, str] | None:
    """:func:`value_bound` where ``|value|`` passed ``SLACK`` times it, else None."""
    bound = value_bound(algorithm, config)
    if bound is None or value is None or not abs(value) > SLACK * bound[0]:
        return None
    return bound


def divergence_warning(algorithm: str, config: dict[str, Any], q_expert: float | None) -> str | None:
    """A warning line for a training run whose latest ``q_expert`` passed ``SLACK`` times its bound, else None."""
    bound = bound_passed(algorithm, config, q_expert)
    if bound is None:
        return None
    return (f"warning: the critics' value of expert transitions is {q_expert:.3g}, above {SLACK:g} x its bound "
            f"{bound[0]:g} ({bound[1]}): the critic is diverging")


def divergence_note(algorithm: str, config: dict[str, Any], log: Path) -> str | None:
    """"critic diverged: ..." where the log's values passed ``SLACK`` times the algorithm's bound, else None."""
    bound = value_bound(algorithm, config)
    if bound is None:  # no critic: the log is not read
        return None
    peak = value_peak(log)
    if peak is None or not peak[0] > SLACK * bound[0]:
        return None
    return (f"critic diverged: q_expert reached {peak[0]:.3g} in size (at {format_steps(peak[1])}), above "
            f"{SLACK:g} x its bound {bound[0]:g} ({bound[1]})")
