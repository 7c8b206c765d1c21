"""Appearance: embedders behind one protocol, and the affinity between features.

An embedder turns the boxes of one frame into L2-normalised feature vectors::

    embedder.embed(frame, boxes) -> (N, D) float32, rows of unit length

where ``frame`` is a BGR ``uint8`` image ``(H, W, 3)`` and ``boxes`` are
``(N, 4)`` ``x, y, w, h`` pixels. Two features are compared with
:func:`affinity`, a similarity in [0, 1] where 1 means the same object.

Backends are registered in :data:`BACKENDS` and imported only when used, so
``import sotmot`` does not load onnxruntime. Modules: ``base`` (what every
backend shares: crops, the flip average, batching, the model-input checks),
``affinity`` (comparing features), one module per backend (``onnx``,
``openvino``, ``torch``).
"""

from __future__ import annotations

import dataclasses
import importlib
import logging
import os
from typing import Callable, Protocol

import numpy as np

from sotmot.appearance.affinity import (affinity, affinity_rows, motion_only, normalize, pair_affinities, roc_auc,
                                       unit, unit_affinity_rows)
from sotmot.appearance.base import flip_average
from sotmot.config import AppearanceConfig
from sotmot.errors import ConfigError
from sotmot.plugins import BACKENDS, EXTRAS

log = logging.getLogger(__name__)


class Embedder(Protocol):
    """What the tracker needs from an appearance model."""

    dim: int

    def embed(self, frame: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Features ``(N, dim)`` float32, L2-normalised, of ``(N, 4)`` ``x, y, w, h`` boxes."""
        ...


def embedder_for(config: AppearanceConfig, embedder: Embedder | None = None) -> Embedder:
    """``embedder`` when the caller has one, else a new one built from ``config`` (:func:`make_embedder`)."""
    return embedder if embedder is not None else make_embedder(config)


def resolve_backend(config: AppearanceConfig) -> AppearanceConfig:
    """``config`` as a run uses it: ``backend = "auto"`` made concrete (``"openvino"`` where the OpenVINO runtime is
    installed and the device is the CPU: the same network as onnxruntime runs, about twice as fast; else
    ``"onnx"``), and ``threads`` no more than the machine's CPUs. ``config`` itself when nothing changes."""
    import importlib.util

    changes: dict[str, object] = {}
    if config.backend == "auto":
        fast = config.device == "cpu" and importlib.util.find_spec("openvino") is not None
        changes["backend"] = "openvino" if fast else "onnx"
    cpus = os.cpu_count() or 1
    if config.threads > cpus:
        log.warning("appearance threads = %d but this machine has %d CPUs; using %d", config.threads, cpus, cpus)
        changes["threads"] = cpus
    return dataclasses.replace(config, **changes) if changes else config


def make_embedder(config: AppearanceConfig) -> Embedder:
    """Build the embedder that ``config.backend`` names (``config`` as :func:`resolve_backend` makes it)."""
    config = resolve_backend(config)
    target = BACKENDS.get(config.backend)
    if target is None:
        raise ConfigError(f"unknown appearance backend {config.backend!r}; valid: {', '.join(BACKENDS)}")
    module, name = target.split(":")
    try:
        importlib.import_module(module)
    except ImportError as exc:
        raise ConfigError(f"appearance backend {config.backend!r} needs {exc.name!r}: pip install "
                          f"{EXTRAS.get(config.backend, repr(exc.name))}") from exc
    factory: Callable[[AppearanceConfig], Embedder] = getattr(importlib.import_module(module), name)
    return factory(config)


__all__ = ["BACKENDS", "Embedder", "affinity", "affinity_rows", "embedder_for", "flip_average", "make_embedder",
           "motion_only", "normalize", "pair_affinities", "resolve_backend", "roc_auc", "unit", "unit_affinity_rows"]
