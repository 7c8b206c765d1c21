"""What a worker process (a local pool's or a Dask worker) keeps and how many threads its models get: shared by
the runs of many sequences (:mod:`sotmot.runs`) and of one sequence's windows (:mod:`sotmot.windows`)."""

from __future__ import annotations

import os
import threading

from sotmot.config import AppearanceConfig, TrackerConfig

_EMBEDDERS: dict[AppearanceConfig, object] = {}  # per worker process (pool or Dask), shared by its threads
_EMBEDDERS_LOCK = threading.Lock()


def worker_embedder(appearance: AppearanceConfig):
    """This process's appearance model for ``appearance``, loaded on first use."""
    with _EMBEDDERS_LOCK:
        if appearance not in _EMBEDDERS:
            from sotmot.appearance import make_embedder

            _EMBEDDERS[appearance] = make_embedder(appearance)
        return _EMBEDDERS[appearance]


def process_threads(config: TrackerConfig, workers: int) -> TrackerConfig:
    """``config`` with the re-ID model's threads, where the config leaves them to the runtime (0), set to this
    machine's share of one of ``workers`` processes (``cpu_count // workers``), so they do not oversubscribe it."""
    if config.appearance.threads == 0:
        config = config.replace("appearance", threads=max(1, (os.cpu_count() or 1) // workers))
    return config


def dask_worker_threads(config: TrackerConfig) -> TrackerConfig:
    """``config`` with the models' threads (where the config leaves them to the runtime, 0) set to this Dask
    worker's thread count: a worker started with ``--nthreads 1`` beside others on one machine must not run
    a model on every core, as ``--workers N`` gives each process ``cpu_count // N``. Threads change no result.
    Unchanged outside a Dask worker."""
    try:
        from distributed import get_worker

        share = max(1, int(get_worker().state.nthreads))
    except (ImportError, ValueError, AttributeError):
        return config
    if config.appearance.threads == 0:
        config = config.replace("appearance", threads=share)
    if config.detection.threads == 0:
        config = config.replace("detection", threads=share)
    return config
