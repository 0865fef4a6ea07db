"""Whether an off-policy run's critic diverged or saturated, read from its training log (``q_expert`` and
``q_agent``, the critics' mean values of expert and of replay transitions, logged every epoch).

A row whose critic left the range its rewards allow measures a broken value function more than the algorithm, so the
results table says so. Bounds on ``|Q|``: SQIL's rewards of 0 and 1 allow ``1 / (1 - gamma)``; LS-IQ clips its
targets to ``1 / (c (1 - gamma))``; IQ-Learn's implicit rewards have no fixed bound, so ten times SQIL's stands in
(a unit reward per step could not produce it). A run is flagged when its logged value passes ``SLACK`` times the
bound (the entropy term of soft values adds up to ``alpha |log pi| / (1 - gamma)``, ~5-10 at the table's settings).

A critic *saturates* when it values the agent's own states at the floor its targets allow (0 for SQIL, ``-bound``
for LS-IQ; IQ-Learn has none): it then separates expert from agent states as a saturated discriminator does and
gives the actor nothing to climb. The table's runs that ended so learned little or nothing (results/README.md,
"Critic probes"); a run is flagged when its last logged ``q_agent`` lies within ``FLOOR_SHARE`` of the range above
the floor.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from baselines.lsiq.lsiq import value_floor as lsiq_value_floor
from experiments.table_sources import format_steps, read_progress

SLACK = 1.25
FLOOR_SHARE = 0.05  # of the range [floor, bound]: LS-IQ below -180 of [-200, 200], SQIL below 5 of [0, 100]


def _gamma(config: dict[str, Any]) -> float:
    return float((config.get("env") or {}).get("gamma", 0.99))


def _lsiq_setting(config: dict[str, Any], key: str, default: Any) -> Any:
    return (config.get("agent") or {}).get(key, default)


def value_bound(algorithm: str, config: dict[str, Any]) -> tuple[float, str] | None:
    """``(bound on |Q|, where it comes from)`` for an off-policy algorithm and its run config; None for the others."""
    horizon = 1.0 / (1.0 - _gamma(config))
    if algorithm == "sqil":
        return horizon, "rewards in [0, 1]"
    if algorithm == "lsiq":
        c = float(_lsiq_setting(config, "reg_mult", 0.5))
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


def value_floor(algorithm: str, config: dict[str, Any]) -> float | None:
    """The lowest value the critic's targets allow: 0 for SQIL (rewards 0 and 1), LS-IQ's ``V_min`` (``-bound``, or
    ``-bound / 2`` for its chi2 form); None for IQ-Learn (no fixed floor) and the algorithms without a critic."""
    bound = value_bound(algorithm, config)
    if algorithm == "sqil":
        return 0.0
    if algorithm == "lsiq" and bound is not None:
        return lsiq_value_floor(float(_lsiq_setting(config, "reg_mult", 0.5)), _gamma(config),
                                _lsiq_setting(config, "loss_form", "least_squares"))
    return None


def saturation_threshold(algorithm: str, config: dict[str, Any]) -> tuple[float, float] | None:
    """``(floor, threshold)``: ``q_agent`` below the threshold counts as at the floor; None where there is no floor."""
    floor, bound = value_floor(algorithm, config), value_bound(algorithm, config)
    if floor is None or bound is None:
        return None
    return floor, floor + FLOOR_SHARE * (bound[0] - floor)


def saturated_since(algorithm: str, config: dict[str, Any], log: Path) -> tuple[int, int, float] | None:
    """``(first step, last step, last q_agent)`` of the unbroken stretch of epochs that ends the log with ``q_agent``
    at the floor; None where the log's last ``q_agent`` is above it (or there is no floor or no ``q_agent``)."""
    threshold = saturation_threshold(algorithm, config)
    if threshold is None or not log.exists():
        return None
    rows = [r for r in read_progress(log) if math.isfinite(r.get("q_agent", math.nan))]
    if not rows or not rows[-1]["q_agent"] < threshold[1]:
        return None
    first = len(rows) - 1
    while first > 0 and rows[first - 1]["q_agent"] < threshold[1]:
        first -= 1
    return int(rows[first]["step"]), int(rows[-1]["step"]), rows[-1]["q_agent"]


def saturation_note(algorithm: str, config: dict[str, Any], log: Path) -> str | None:
    """"critic saturated: ..." where the log ends with ``q_agent`` at the floor, else None."""
    stretch = saturated_since(algorithm, config, log)
    if stretch is None:
        return None
    floor, threshold = saturation_threshold(algorithm, config)
    return (f"critic saturated from {format_steps(stretch[0])} to {format_steps(stretch[1])}: q_agent "
            f"{stretch[2]:.3g} at the end, within {FLOOR_SHARE:.0%} of its floor {floor:g} (below {threshold:g}), "
            f"every agent state valued as never reaching the expert's")


def saturation_warning(algorithm: str, config: dict[str, Any], q_agent: float | None) -> str | None:
    """A warning line for a training run whose latest ``q_agent`` lies at the floor, else None."""
    threshold = saturation_threshold(algorithm, config)
    if threshold is None or q_agent is None or not math.isfinite(q_agent) or not q_agent < threshold[1]:
        return None
    return (f"warning: q_agent is {q_agent:.3g}, within {FLOOR_SHARE:.0%} of its floor {threshold[0]:g} (below "
            f"{threshold[1]:g}): the critic values every agent state as never reaching the expert's; the table's "
            f"runs whose critics ended so learned little or nothing (results/README.md)")
