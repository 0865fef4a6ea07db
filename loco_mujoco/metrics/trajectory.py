"""Distances between an agent trajectory ``a`` (T1, D) and a reference trajectory ``b`` (T2, D).

All three are in the unit of the inputs (rad for joint angles, m for site positions); 1-D inputs are (T, 1).
"""

from __future__ import annotations

import numpy as np
from dtaidistance import dtw_ndim
from dtaidistance.exceptions import CythonException


def _pair(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both trajectories as float64 C-contiguous (T, D) arrays with the same D and at least one step."""
    out = []
    for name, x in (("a", a), ("b", b)):
        x = np.asarray(x, dtype=np.float64)
        if x.ndim == 1:
            x = x[:, None]
        if x.ndim != 2:
            raise ValueError(f"trajectory {name} must be (T, D) or (T,), got shape {x.shape}")
        if len(x) == 0:
            raise ValueError(f"trajectory {name} is empty")
        out.append(np.ascontiguousarray(x))
    if out[0].shape[1] != out[1].shape[1]:
        raise ValueError(f"trajectories differ in dimension: a {out[0].shape} vs b {out[1].shape}")
    return out[0], out[1]


def euclidean_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Mean per-step L2 distance over the first min(T1, T2) steps, in the inputs' unit."""
    a, b = _pair(a, b)
    n = min(len(a), len(b))
    return float(np.linalg.norm(a[:n] - b[:n], axis=1).mean())


def dtw_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Dynamic-time-warping distance as an RMS per-step L2 distance, in the inputs' unit.

    dtaidistance returns sqrt(sum of squared step distances along the optimal warping path); dividing by
    sqrt(max(T1, T2)) makes it an RMS per-step distance, comparable with :func:`euclidean_distance` (on
    equal-length inputs it is at most the RMS of the per-step distances) and across episode lengths.
    """
    a, b = _pair(a, b)
    try:
        d = dtw_ndim.distance_fast(a, b)
    except CythonException:  # compiled library unavailable: same result, pure Python
        d = dtw_ndim.distance(a, b)
    return float(d / np.sqrt(max(len(a), len(b))))


def frechet_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Discrete Fréchet distance (Eiter & Mannila 1994) with per-step L2 distances, in the inputs' unit.

    The coupling table is filled one anti-diagonal at a time (cells i + j = k depend only on diagonals k - 1
    and k - 2), so memory is O(T1 + T2) and each diagonal is one vectorised numpy step.
    """
    a, b = _pair(a, b)
    n, m = len(a), len(b)
    # diag[i + 1] holds the coupling cost of cell (i, k - i); index 0 and invalid cells are +inf.
    prev2 = np.full(n + 1, np.inf)
    prev1 = np.full(n + 1, np.inf)
    prev1[1] = np.linalg.norm(a[0] - b[0])
    for k in range(1, n + m - 1):
        i = np.arange(max(0, k - m + 1), min(k, n - 1) + 1)
        d = np.linalg.norm(a[i] - b[k - i], axis=1)
        best = np.minimum(np.minimum(prev1[i], prev1[i + 1]), prev2[i])  # from (i-1, j), (i, j-1), (i-1, j-1)
        cur = np.full(n + 1, np.inf)
        cur[i + 1] = np.maximum(d, best)
        prev2, prev1 = prev1, cur
    return float(prev1[n])
