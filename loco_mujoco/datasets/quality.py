"""Quality goals of humanoid datasets, checked from the figures retargeting records in their metadata."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class QualityGoals:
    """What a humanoid dataset must meet: feet that do not skate or sink, walking without flight, straight clips
    that travel along their heading."""

    sliding_mean_mps: float = 0.02
    sliding_p95_mps: float = 0.10
    penetration_m: float = 0.005
    walking_flight_fraction: float = 0.01  # walk and carry tasks
    straight_heading_deg: float = 20.0  # a clip turning less than this is straight ...
    straight_forward_tolerance: float = 0.10  # ... and its forward speed is within this fraction of its speed


GOALS = QualityGoals()
WALKING_TASKS = ("walk", "carry")


def quality_violations(metadata: dict, goals: QualityGoals = GOALS) -> list[str]:
    """Each goal a dataset misses, as a sentence with the measured figure; empty when it meets them all."""
    q = metadata["quality"]
    out = []
    if q["foot_sliding_mps"] > goals.sliding_mean_mps:
        out.append(f"foot sliding {q['foot_sliding_mps']:.3f} m/s > {goals.sliding_mean_mps} m/s")
    if q["foot_sliding_p95_mps"] > goals.sliding_p95_mps:
        out.append(f"foot sliding p95 {q['foot_sliding_p95_mps']:.3f} m/s > {goals.sliding_p95_mps} m/s")
    if q["ground_penetration_max_m"] > goals.penetration_m:
        out.append(f"ground penetration {1000 * q['ground_penetration_max_m']:.1f} mm > "
                   f"{1000 * goals.penetration_m:.0f} mm")
    if metadata.get("task") in WALKING_TASKS and q["flight_fraction"] >= goals.walking_flight_fraction:
        out.append(f"flight {100 * q['flight_fraction']:.1f}% of frames >= "
                   f"{100 * goals.walking_flight_fraction:.0f}% in a {metadata['task']} dataset")
    for traj in metadata.get("trajectories", []):
        tq = traj["quality"]
        if tq.get("heading_change_deg", float("inf")) >= goals.straight_heading_deg or tq["mean_speed_mps"] <= 0:
            continue
        off = abs(tq["mean_travel_forward_mps"] - tq["mean_speed_mps"]) / tq["mean_speed_mps"]
        if off > goals.straight_forward_tolerance:
            out.append(f"{traj['name']} ({traj['source']}): forward speed {tq['mean_travel_forward_mps']:.2f} m/s "
                       f"is {100 * off:.0f}% off its speed {tq['mean_speed_mps']:.2f} m/s on a straight clip")
    return out
