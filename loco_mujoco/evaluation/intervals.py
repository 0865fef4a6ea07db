"""Interval estimates for evaluation figures: the mean with a studentized bootstrap 95% interval, and the
interquartile mean (IQM) with a BCa interval, both from ``arch``'s bootstrap.

Why these: episode returns are skewed (a few falls, many full episodes). On 50 draws from skewed
distributions the percentile bootstrap covers the true mean only ~91% of the time and BCa ~92-94%; the
studentized bootstrap covers it 94-95% (tests/test_evaluation.py repeats this 1,000 times). Where most values
tie (episode lengths of an agent that mostly reaches the horizon), the studentized pivot breaks down: a
resample holding only the tied value and one or two near it has a tiny standard error and a huge t, so the
interval grows without bound (A1 VAIL's lengths: [541, 989] around a mean of 951, BCa [883, 985]). From a
modal share of ``TIED_SHARE`` on, the mean's interval is BCa: on 500 samples of 50 draws with 60-90% of them at
the horizon it covered 93-96%, where the studentized interval covered 97-99.5% with widths up to 10^13. ``rliable`` is
built on the same ``arch`` bootstrap but pins ``arch<8``, whose last release does not import with pandas 3.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.stats import trim_mean

CONFIDENCE = 0.95
BOOTSTRAP_REPS = 2000
TIED_SHARE = 0.6  # the share of values equal to the most common one from which the mean's interval is BCa


def iqm(values: np.ndarray) -> float:
    """Interquartile mean: the mean of the middle 50% of the values (robust to a few outliers)."""
    return float(trim_mean(np.asarray(values, dtype=float), 0.25))


def _mean(x: np.ndarray) -> np.ndarray:
    return np.array([x.mean()])


def _standard_error(params: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.array([x.std(ddof=1) / math.sqrt(len(x))])


def _iqm(x: np.ndarray) -> np.ndarray:
    return np.array([trim_mean(x, 0.25)])


def _check(values: np.ndarray) -> np.ndarray:
    x = np.asarray(values, dtype=float).ravel()
    if x.size == 0:
        raise ValueError("no values to summarise")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"values must be finite; got {int(np.sum(~np.isfinite(x)))} NaN/inf among {x.size}")
    return x


def _interval(values: np.ndarray, func, method: str, min_size: int, confidence: float, reps: int, seed: int,
              **kwargs) -> tuple[float, float]:
    """``method``'s bootstrap interval of ``func(values)``: NaN bounds below ``min_size`` values, the value itself
    for constant values, and the percentile interval where ``method`` is undefined (a small sample whose
    resamples are often constant: zero standard errors, or BCa's bias at 0 or 1, as when most episodes of an
    agent that stands reach the horizon and nearly every resample's IQM equals the sample's)."""
    from arch.bootstrap import IIDBootstrap

    x = _check(values)
    if x.size < min_size:
        return math.nan, math.nan
    if np.ptp(x) == 0.0:
        return float(x[0]), float(x[0])
    with warnings.catch_warnings(), np.errstate(divide="ignore", invalid="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)
        try:
            ci = IIDBootstrap(x, seed=np.random.default_rng(seed)).conf_int(func, reps=reps, method=method,
                                                                            size=confidence, **kwargs)
        except (RuntimeError, ValueError):  # ValueError: arch's BCa percentiles NaN (bias at 0 or 1)
            ci = np.full((2, 1), np.nan)
        if not np.all(np.isfinite(ci)):
            ci = IIDBootstrap(x, seed=np.random.default_rng(seed)).conf_int(func, reps=reps, method="percentile",
                                                                            size=confidence)
    return float(ci[0, 0]), float(ci[1, 0])


def modal_share(values: np.ndarray) -> float:
    """The share of ``values`` equal to their most common value (1/n when all differ)."""
    _, counts = np.unique(_check(values), return_counts=True)
    return float(counts.max() / counts.sum())


def mean_interval(values: np.ndarray, confidence: float = CONFIDENCE, reps: int = BOOTSTRAP_REPS,
                  seed: int = 0) -> tuple[float, float]:
    """Studentized-bootstrap interval of the mean of ``values`` (NaN bounds for fewer than 2 values); BCa where
    at least ``TIED_SHARE`` of the values tie (the studentized pivot is unstable there, see the module doc)."""
    if modal_share(values) >= TIED_SHARE:
        return _interval(values, _mean, "bca", 2, confidence, reps, seed)
    return _interval(values, _mean, "studentized", 2, confidence, reps, seed, std_err_func=_standard_error)


def iqm_interval(values: np.ndarray, confidence: float = CONFIDENCE, reps: int = BOOTSTRAP_REPS,
                 seed: int = 0) -> tuple[float, float]:
    """BCa-bootstrap interval of the interquartile mean of ``values`` (NaN bounds for fewer than 4 values)."""
    return _interval(values, _iqm, "bca", 4, confidence, reps, seed)


def summarize(values: np.ndarray, seed: int = 0) -> dict[str, float | list[float]]:
    """Mean with its 95% interval, IQM with its 95% interval, and the number of values."""
    x = _check(values)
    return {"mean": float(x.mean()), "ci95": list(mean_interval(x, seed=seed)), "iqm": iqm(x),
            "iqm_ci95": list(iqm_interval(x, seed=seed)), "n": int(x.size)}


def format_summary(s: dict, digits: int = 1) -> str:
    """``mean [lo, hi] (IQM x)`` for printing."""
    lo, hi = s["ci95"]
    return f"{s['mean']:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}] (IQM {s['iqm']:.{digits}f})"
