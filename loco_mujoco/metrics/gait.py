"""Gait metrics of a legged trajectory: speed, cadence, stride, duty factor, support, clearance, sliding, symmetry."""

from __future__ import annotations

import numpy as np

from loco_mujoco.metrics.contacts import foot_contacts, stance_sliding


def _edges(c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Touchdown and lift-off frames of one foot's contact flags (T,): where contact starts and ends."""
    step = np.diff(c.astype(np.int8))
    return np.flatnonzero(step == 1) + 1, np.flatnonzero(step == -1) + 1


MIN_PHASE_S = 0.05  # s: contact or swing phases shorter than this are flicker at the contact height, not steps


def _runs(c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Run-length encoding of a bool sequence: start, length and value of each run."""
    change = np.flatnonzero(np.diff(c.astype(np.int8))) + 1
    starts = np.concatenate([[0], change])
    lengths = np.diff(np.concatenate([starts, [len(c)]]))
    return starts, lengths, c[starts]


def debounce(c: np.ndarray, min_frames: int) -> np.ndarray:
    """One foot's contact flags (T,) with swings, then stances, shorter than ``min_frames`` removed (interior runs
    only: the first and last run may be cut by the episode)."""
    c = np.asarray(c, dtype=bool).copy()
    for value in (False, True):  # fill short gaps in stance first, then drop short touches
        starts, lengths, values = _runs(c)
        interior = (starts > 0) & (starts + lengths < len(c))
        for s, n in zip(starts[interior & (values == value) & (lengths < min_frames)],
                        lengths[interior & (values == value) & (lengths < min_frames)], strict=True):
            c[s:s + n] = not value
    return c


def _swing_peaks(height: np.ndarray, touchdowns: np.ndarray, liftoffs: np.ndarray) -> np.ndarray:
    """Maximum sole height (m) of each complete swing (lift-off to the next touchdown) of one foot."""
    td = touchdowns[touchdowns > liftoffs[0]] if len(liftoffs) else touchdowns[:0]
    n = min(len(liftoffs), len(td))  # edges alternate, so the k-th lift-off pairs with the k-th later touchdown
    if n == 0:
        return np.empty(0)
    bounds = np.column_stack([liftoffs[:n], td[:n]]).ravel()
    return np.maximum.reduceat(height, bounds)[::2]


def _nan_mean(x: np.ndarray) -> float:
    """Mean of x, NaN when x is empty."""
    return float(x.mean()) if x.size else float("nan")


def gait_metrics(sole_height: np.ndarray, foot_xy: np.ndarray, root_xy: np.ndarray, heading_xy: np.ndarray,
                 dt: float, contact_height: float) -> dict[str, float]:
    """Gait metrics of one episode; a metric the episode cannot define (e.g. no touchdown) is NaN.

    Inputs: ``sole_height`` (T, feet) height of each foot's lowest sole point above the floor (m), ``foot_xy``
    (T, feet, 2) world xy of that point (m), ``root_xy`` (T, 2) root xy (m), ``heading_xy`` (T, 2) root heading
    (normalised here), ``dt`` seconds per step, ``contact_height`` (m) as in :func:`foot_contacts`.

    Keys:
      - ``forward_speed`` (m/s): mean root velocity along the heading.
      Steps (touchdowns, lift-offs) come from contacts debounced by ``MIN_PHASE_S``; fractions and sliding
      from the raw contacts.
      - ``cadence`` (steps/min): touchdowns of all feet per minute; each foot's rate is one over its mean interval
        between touchdowns (touchdowns / duration for a foot with fewer than two), summed over feet.
      - ``stride_length`` (m): mean distance a foot travels between its consecutive touchdowns.
      - ``duty_factor`` (fraction): fraction of time a foot is in contact, mean over feet.
      - ``double_support`` (fraction): fraction of frames with at least two feet in contact (for bipeds).
      - ``foot_clearance`` (m): mean over complete swing phases of each swing's maximum sole height.
      - ``foot_sliding`` (m/s): mean horizontal speed of feet in contact (np.gradient of ``foot_xy``).
      - ``symmetry`` (fraction, 0 = symmetric): gait symmetry index |d0 - d1| / mean(d0, d1) of the duty
        factors of the first two feet.
    """
    h = np.asarray(sole_height, dtype=np.float64)
    feet_xy = np.asarray(foot_xy, dtype=np.float64)
    root = np.asarray(root_xy, dtype=np.float64)
    heading = np.asarray(heading_xy, dtype=np.float64)
    if h.ndim != 2 or h.shape[0] == 0 or h.shape[1] == 0:
        raise ValueError(f"sole_height must be (T, feet) with T, feet >= 1, got shape {h.shape}")
    t, n_feet = h.shape
    for name, x, shape in (("foot_xy", feet_xy, (t, n_feet, 2)), ("root_xy", root, (t, 2)),
                           ("heading_xy", heading, (t, 2))):
        if x.shape != shape:
            raise ValueError(f"{name} must have shape {shape} to match sole_height {h.shape}, got {x.shape}")
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"dt must be a positive number of seconds, got {dt}")
    contacts = foot_contacts(h, contact_height)
    nan = float("nan")

    forward_speed = foot_sliding = nan
    if t >= 2:  # velocities need two frames
        norm = np.linalg.norm(heading, axis=1)
        valid = norm > 0  # frames with a defined heading
        along = np.sum(np.gradient(root, dt, axis=0)[valid] * heading[valid], axis=1) / norm[valid]
        forward_speed = _nan_mean(along)
        foot_sliding = _nan_mean(stance_sliding(np.gradient(feet_xy, dt, axis=0), contacts))

    rates, strides, peaks = [], [], []
    min_frames = max(1, int(round(MIN_PHASE_S / dt)))
    for f in range(n_feet):
        td, lo = _edges(debounce(contacts[:, f], min_frames))
        rates.append((len(td) - 1) / ((td[-1] - td[0]) * dt) if len(td) >= 2 else len(td) / (t * dt))
        strides.append(np.linalg.norm(np.diff(feet_xy[td, f], axis=0), axis=1))
        peaks.append(_swing_peaks(h[:, f], td, lo))
    cadence = 60.0 * sum(rates) if sum(rates) > 0 else nan

    duty = contacts.mean(axis=0)
    mean_duty01 = duty[:2].mean()
    return {
        "forward_speed": forward_speed,
        "cadence": cadence,
        "stride_length": _nan_mean(np.concatenate(strides)),
        "duty_factor": float(duty.mean()),
        "double_support": float((contacts.sum(axis=1) >= 2).mean()) if n_feet >= 2 else nan,
        "foot_clearance": _nan_mean(np.concatenate(peaks)),
        "foot_sliding": foot_sliding,
        "symmetry": float(abs(duty[0] - duty[1]) / mean_duty01) if n_feet >= 2 and mean_duty01 > 0 else nan,
    }


def gait_deviation(agent: dict[str, float], expert: dict[str, float]) -> float:
    """Mean relative deviation (fraction, 0 = the expert's gait) of ``agent``'s gait metrics from ``expert``'s:
    the mean over the metrics the expert defines of ``|a - e| / max(|e|, 0.05)``, each capped at 1, where a
    metric the agent cannot define (no step taken) counts as 1."""
    deviations = []
    for key, e in expert.items():
        if not np.isfinite(e):
            continue
        a = agent.get(key, float("nan"))
        deviations.append(1.0 if not np.isfinite(a) else min(abs(a - e) / max(abs(e), 0.05), 1.0))
    return float(np.mean(deviations)) if deviations else float("nan")
