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
