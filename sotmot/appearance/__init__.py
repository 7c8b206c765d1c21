"""Appearance: embedders behind one protocol, and the affinity between features.

An embedder turns the boxes of one frame into L2-normalised feature vectors::

    embedder.embed(frame, boxes) -> (N, D) float32, rows of unit length

where ``frame`` is a BGR ``uint8`` image ``(H, W, 3)`` and ``boxes`` are
``(N, 4)`` ``x, y, w, h`` pixels. Two features are compared with
:func:`affinity`, a similarity in [0, 1] where 1 means the same object.

Backends are registered in :data:`BACKENDS` and imported only when used, so
``import sotmot`` does not load onnxruntime.
"""

from __future__ import annotations

import dataclasses
import importlib
import logging
import os
from typing import Callable, Protocol

import numpy as np

from sotmot.config import AppearanceConfig
from sotmot.errors import ConfigError, ModelError
from sotmot.plugins import BACKENDS, EXTRAS

log = logging.getLogger(__name__)


class Embedder(Protocol):
    """What the tracker needs from an appearance model."""

    dim: int

    def embed(self, frame: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Features ``(N, dim)`` float32, L2-normalised, of ``(N, 4)`` ``x, y, w, h`` boxes."""
        ...


def normalize(features: np.ndarray) -> np.ndarray:
    """Rows scaled to unit L2 length (zero rows stay zero), as float32."""
    f = np.asarray(features, dtype=np.float32)
    norm = np.linalg.norm(f, axis=-1, keepdims=True)
    return f / np.maximum(norm, 1e-12)


def flip_average(features: np.ndarray, mirrored: np.ndarray | None, source: object) -> np.ndarray:
    """Unit features from a network's raw outputs: ``features`` ``(N, D)`` of the crops and, with the
    flip of paper eq. 1, ``mirrored`` ``(N, D)`` of their mirror images (each normalised, averaged,
    normalised again). Every backend ends here.

    Raises
    ------
    ModelError
        An output is NaN or infinite (named after ``source``, the model file): a feature that
        cannot be compared must not enter tracking.
    """
    features = np.asarray(features, dtype=np.float32)
    if not np.isfinite(features).all() or (mirrored is not None and not np.isfinite(mirrored).all()):
        raise ModelError(f"{source}: the model gave NaN or infinite features; is it a re-ID model taking BGR "
                         f"0-255 crops?")
    if mirrored is None:
        return normalize(features)
    return normalize(normalize(features) + normalize(mirrored))


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


def embedder_for(config: AppearanceConfig, embedder: Embedder | None = None) -> Embedder:
    """``embedder`` when the caller has one, else a new one built from ``config`` (:func:`make_embedder`)."""
    return embedder if embedder is not None else make_embedder(config)


def make_embedder(config: AppearanceConfig) -> Embedder:
    """Build the embedder that ``config.backend`` names."""
    target = BACKENDS.get(config.backend)
    if target is None:
        raise ConfigError(f"unknown appearance backend {config.backend!r}; valid: {', '.join(BACKENDS)}")
    cpus = os.cpu_count() or 1
    if config.threads > cpus:
        log.warning("appearance threads = %d but this machine has %d CPUs; using %d", config.threads, cpus, cpus)
        config = dataclasses.replace(config, threads=cpus)
    module, name = target.split(":")
    try:
        importlib.import_module(module)
    except ImportError as exc:
        raise ConfigError(f"appearance backend {config.backend!r} needs {exc.name!r}: pip install "
                          f"{EXTRAS.get(config.backend, repr(exc.name))}") from exc
    factory: Callable[[AppearanceConfig], Embedder] = getattr(importlib.import_module(module), name)
    return factory(config)


__all__ = ["BACKENDS", "Embedder", "affinity", "affinity_rows", "embedder_for", "flip_average", "make_embedder",
           "normalize", "roc_auc"]
