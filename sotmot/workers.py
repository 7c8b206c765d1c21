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


def models_share(config: TrackerConfig, share: int) -> TrackerConfig:
    """``config`` with the threads of the re-ID model and the detector, where the config leaves them to the runtime
    (0), set to ``share``: processes side by side on one machine must not each run a model on every core.
    Threads change no result."""
    if config.appearance.threads == 0:
        config = config.replace("appearance", threads=share)
    if config.detection.threads == 0:
        config = config.replace("detection", threads=share)
    return config


def process_threads(config: TrackerConfig, workers: int) -> TrackerConfig:
    """``config`` with the models' threads (:func:`models_share`) set to this machine's share of one of
    ``workers`` processes (``cpu_count // workers``)."""
    return models_share(config, max(1, (os.cpu_count() or 1) // workers))


def dask_worker_threads(config: TrackerConfig) -> TrackerConfig:
    """``config`` with the models' threads (:func:`models_share`) set to this Dask worker's thread count: a worker
    started with ``--nthreads 1`` beside others on one machine must not run a model on every core, as
    ``--workers N`` gives each process ``cpu_count // N``. Unchanged outside a Dask worker."""
    try:
        from distributed import get_worker

        share = max(1, int(get_worker().state.nthreads))
    except (ImportError, ValueError, AttributeError):
        return config
    return models_share(config, share)
