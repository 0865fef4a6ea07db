"""Distances between two sets of states x (N, D) and y (M, D), e.g. agent and expert state visitations.

Rows containing NaN or inf are dropped first; each set is then subsampled to ``max_samples`` rows without
replacement by its own generator seeded with ``seed`` (so identical sets stay identical), making every result
deterministic for a seed.
"""

from __future__ import annotations

import warnings

import numpy as np
import ot
from scipy.spatial.distance import cdist
from sklearn.exceptions import ConvergenceWarning
from sklearn.linear_model import LogisticRegression
from sklearn.metrics import roc_auc_score
from sklearn.model_selection import cross_val_predict
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler


def _sets(x: np.ndarray, y: np.ndarray, max_samples: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Both sets as finite float64 (n, D) arrays, subsampled to at most ``max_samples`` rows each."""
    if max_samples < 1:
        raise ValueError(f"max_samples must be at least 1, got {max_samples}")
    out = []
    for name, s in (("x", x), ("y", y)):
        s = np.asarray(s, dtype=np.float64)
        if s.ndim == 1:
            s = s[:, None]
        if s.ndim != 2:
            raise ValueError(f"state set {name} must be (N, D), got shape {s.shape}")
        s = s[np.isfinite(s).all(axis=1)]
        if len(s) == 0:
            raise ValueError(f"state set {name} is empty (after dropping rows with NaN or inf)")
        if len(s) > max_samples:
            s = s[np.sort(np.random.default_rng(seed).choice(len(s), max_samples, replace=False))]
        out.append(s)
    if out[0].shape[1] != out[1].shape[1]:
        raise ValueError(f"state sets differ in feature dimension: x has {out[0].shape[1]}, y has {out[1].shape[1]}")
    return out[0], out[1]


def _standardise(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both sets in units of the pooled standard deviation around the pooled mean (constant features kept at 0)."""
    pooled = np.concatenate([x, y])
    mean, std = pooled.mean(axis=0), pooled.std(axis=0)
    std = np.where(std > 0, std, 1.0)
    return (x - mean) / std, (y - mean) / std


def mmd_rbf(x: np.ndarray, y: np.ndarray, bandwidth: float | None = None, max_samples: int = 2000,
            seed: int = 0) -> float:
    """Maximum mean discrepancy with an RBF kernel, sqrt(max(MMD^2, 0)); unitless, 0 for identical sets.

    Biased V-statistic MMD^2 = mean k(x, x') + mean k(y, y') - 2 mean k(x, y) with
    k(u, v) = exp(-|u - v|^2 / (2 bandwidth^2)); ``bandwidth`` (in the states' unit) defaults to the median
    pairwise distance of the pooled sets (median heuristic).
    """
    x, y = _sets(x, y, max_samples, seed)
    if bandwidth is not None and (not np.isfinite(bandwidth) or bandwidth <= 0):
        raise ValueError(f"bandwidth must be positive, got {bandwidth}")
    dxx, dyy, dxy = cdist(x, x, "sqeuclidean"), cdist(y, y, "sqeuclidean"), cdist(x, y, "sqeuclidean")
    if bandwidth is None:
        pairs = np.concatenate([dxx[np.triu_indices(len(x), 1)], dyy[np.triu_indices(len(y), 1)], dxy.ravel()])
        bandwidth = float(np.sqrt(np.median(pairs))) if pairs.size else 1.0
        bandwidth = bandwidth if bandwidth > 0 else 1.0  # all points equal: any bandwidth gives the same MMD
    gamma = -0.5 / bandwidth**2
    mmd2 = np.exp(gamma * dxx).mean() + np.exp(gamma * dyy).mean() - 2.0 * np.exp(gamma * dxy).mean()
    return float(np.sqrt(max(mmd2, 0.0)))


def sliced_wasserstein(x: np.ndarray, y: np.ndarray, n_projections: int = 128, max_samples: int = 2000,
                       seed: int = 0) -> float:
    """Sliced 2-Wasserstein distance (POT) after standardising by the pooled mean/std; unit: pooled std devs."""
    x, y = _sets(x, y, max_samples, seed)
    xs, ys = _standardise(x, y)
    return float(ot.sliced_wasserstein_distance(xs, ys, n_projections=n_projections, seed=seed))


def _group_folds(features: np.ndarray, labels: np.ndarray, max_folds: int,
                 seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Stratified (train, test) index pairs that keep identical states in one fold.

    A state present in both sets (e.g. an agent reset onto expert states) would otherwise be scored while its
    twin with the other label is in the training folds, biasing the AUC below 0.5.
    """
    _, group = np.unique(features, axis=0, return_inverse=True)
    group = group.ravel()
    in_x = np.bincount(group, weights=labels == 0) > 0
    in_y = np.bincount(group, weights=labels == 1) > 0
    folds = min(max_folds, int(in_x.sum()), int(in_y.sum()))
    if folds < 2:
        raise ValueError(f"classifier_auc needs at least 2 distinct states per set, got {in_x.sum()} and {in_y.sum()}")
    # Deal the distinct states round-robin into folds, x-only then shared then y-only (each shuffled): every
    # fold gets its share of each stratum, and each set's states span at least two folds.
    rng = np.random.default_rng(seed)
    order = np.concatenate([rng.permutation(np.flatnonzero(m)) for m in (in_x & ~in_y, in_x & in_y, in_y & ~in_x)])
    fold_of_group = np.empty(len(in_x), dtype=int)
    fold_of_group[order] = np.arange(len(order)) % folds
    fold = fold_of_group[group]
    return [(np.flatnonzero(fold != k), np.flatnonzero(fold == k)) for k in range(folds)]


def classifier_auc(x: np.ndarray, y: np.ndarray, max_samples: int = 2000, seed: int = 0) -> float:
    """Classifier two-sample test: cross-validated ROC AUC (unitless) of a linear classifier telling x from y.

    0.5 = indistinguishable, 1.0 = perfectly separable. Logistic regression on standardised features: an MLP
    separated any two walking clips (AUC 0.99 between halves of one dataset), so it could not rank agents.
    AUC of out-of-fold probabilities from 5-fold cross-validation stratified by set
    (fewer folds for tiny sets), with identical states kept in the same fold.
    """
    x, y = _sets(x, y, max_samples, seed)
    features = np.concatenate([x, y])
    labels = np.concatenate([np.zeros(len(x), dtype=int), np.ones(len(y), dtype=int)])
    model = make_pipeline(StandardScaler(), LogisticRegression(max_iter=300, random_state=seed))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        proba = cross_val_predict(model, features, labels, method="predict_proba",
                                  cv=_group_folds(features, labels, 5, seed))
    return float(roc_auc_score(labels, proba[:, 1]))
