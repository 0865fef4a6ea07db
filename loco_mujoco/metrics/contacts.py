"""Foot contact detection and stance sliding: the one contact definition shared by the whole project."""

from __future__ import annotations

import numpy as np


def foot_contacts(sole_height: np.ndarray, contact_height: float) -> np.ndarray:
    """Contact flags (T, feet), bool: a foot touches when its lowest sole point is below ``contact_height`` (m).

    ``sole_height`` (T, feet) is each foot's lowest sole point above the floor in m; there is no speed term.
    """
    h = np.asarray(sole_height, dtype=np.float64)
    if h.ndim != 2:
        raise ValueError(f"sole_height must be (T, feet), got shape {h.shape}")
    if not np.isfinite(contact_height) or contact_height <= 0:
        raise ValueError(f"contact_height must be a positive number of metres, got {contact_height}")
    return h < contact_height


def stance_sliding(contact_point_velocity_xy: np.ndarray, contacts: np.ndarray) -> np.ndarray:
    """Horizontal speed (m/s) of each foot's contact point at the frames it is in contact, as a flat array."""
    v = np.asarray(contact_point_velocity_xy, dtype=np.float64)
    c = np.asarray(contacts)
    if c.dtype != bool:
        raise ValueError(f"contacts must be a bool array, got dtype {c.dtype}")
    if c.ndim != 2 or v.shape != (*c.shape, 2):
        raise ValueError(f"contact_point_velocity_xy shape {v.shape} does not match contacts shape {c.shape}: "
                         "expected (T, feet, 2) and (T, feet)")
    return np.linalg.norm(v, axis=2)[c]


def contact_figures(sole_height: np.ndarray, contact_point_velocity_xy: np.ndarray,
                    contact_height: float) -> dict[str, float]:
    """A trajectory's contact quality from each foot's lowest sole height (T, feet) and that point's horizontal
    velocity (T, feet, 2): sliding in contact (mean, 95th percentile), deepest penetration, mean height of the
    lowest foot while one touches, and the fraction of frames with no foot down."""
    h = np.asarray(sole_height, dtype=np.float64)
    contact = foot_contacts(h, contact_height)
    sliding = stance_sliding(contact_point_velocity_xy, contact)
    has_contact = contact.any(axis=1)
    return {
        "foot_sliding_mps": float(sliding.mean()) if sliding.size else 0.0,
        "foot_sliding_p95_mps": float(np.quantile(sliding, 0.95)) if sliding.size else 0.0,
        "ground_penetration_max_m": float(max(0.0, -h.min())),
        "stance_float_mean_m": float(h.min(axis=1)[has_contact].mean()) if has_contact.any() else 0.0,
        "flight_fraction": float(1.0 - has_contact.mean()),
    }
