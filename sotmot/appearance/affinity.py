"""Comparing appearance features: the affinity in [0, 1] the whole tracker uses, and its batched forms."""

from __future__ import annotations

import numpy as np


def motion_only(features: np.ndarray) -> bool:
    """Whether ``(N, D)`` ``features`` are the motion-only mode's (``[appearance] backend = "none"``): ``D == 0``,
    no re-ID, so affinities and gates are what geometry alone says."""
    features = np.asarray(features)
    return features.ndim == 2 and features.shape[1] == 0


def normalize(features: np.ndarray) -> np.ndarray:
    """Rows scaled to unit L2 length (zero rows stay zero), as float32."""
    f = np.asarray(features, dtype=np.float32)
    norm = np.linalg.norm(f, axis=-1, keepdims=True)
    return f / np.maximum(norm, 1e-12)


def affinity(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Appearance affinity of every row of ``a`` (N, D) with every row of ``b`` (M, D).

    Defined as ``1 - ||a_n - b_n|| / 2`` on the unit-normalised features
    ``a_n``, ``b_n``: 1 for identical directions, 0.5 for orthogonal ones, 0 for
    opposite ones. The paper writes an L2 distance but thresholds it as a
    similarity ("affinity > tau"); this is the similarity that distance gives.
    Inputs need not be normalised (mean features are not): they are normalised
    here. Returns ``(N, M)`` float64 in [0, 1].
    """
    return _affinity_from_cosine(unit(a) @ unit(b).T)


def affinity_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Affinity of ``a[i]`` with ``b[i]`` for two ``(N, D)`` arrays; returns ``(N,)``.

    The same quantity as :func:`affinity`, without the ``(N, M)`` matrix.
    """
    return unit_affinity_rows(unit(a), unit(b))


def unit(features: np.ndarray) -> np.ndarray:
    """Rows of ``features`` as :func:`affinity` compares them: unit length, float64, ``(N, D)``."""
    return normalize(np.atleast_2d(features)).astype(np.float64)


def unit_affinity_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`affinity_rows` of rows already passed through :func:`unit` (saves normalising them again)."""
    return _affinity_from_cosine(np.einsum("nd,nd->n", a, b))


def pair_affinities(units: np.ndarray, pairs: np.ndarray, chunk: int = 8192) -> np.ndarray:
    """Affinity of ``units[i]`` with ``units[j]`` for each row ``(i, j)`` of ``pairs``; ``units`` from :func:`unit`.

    Works through the pairs ``chunk`` at a time, so that a million pairs of
    256-D features never gather gigabytes of rows at once. Returns ``(K,)``.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    out = np.empty(len(pairs))
    for a in range(0, len(pairs), chunk):
        p = pairs[a:a + chunk]
        out[a:a + chunk] = unit_affinity_rows(units[p[:, 0]], units[p[:, 1]])
    return out


def roc_auc(positive: np.ndarray, negative: np.ndarray) -> float:
    """ROC AUC of scores: the probability that a positive outscores a negative (ties count half).

    Used to judge an appearance model on same-person (``positive``) and
    different-person (``negative``) pair affinities; NaN if either is empty.
    """
    from scipy.stats import rankdata

    pos, neg = np.asarray(positive, float), np.asarray(negative, float)
    if len(pos) == 0 or len(neg) == 0:
        return float("nan")
    ranks = rankdata(np.concatenate([pos, neg]))
    return float((ranks[:len(pos)].sum() - len(pos) * (len(pos) + 1) / 2) / (len(pos) * len(neg)))


def _affinity_from_cosine(cos: np.ndarray) -> np.ndarray:
    """``1 - ||a - b|| / 2`` for unit vectors, from their cosine: ``||a - b||^2 = 2 - 2 cos``."""
    cos = np.clip(cos, -1.0, 1.0)
    return 1.0 - np.sqrt(np.maximum(2.0 - 2.0 * cos, 0.0)) / 2.0
