"""The tracker's stages wired together; each stage is also callable on its own.

    read -> preprocess (score threshold, NMS) -> embed -> tracklets
         -> long-term association (a solver from ``solvers.SOLVERS``)
         -> post-processing -> results

Boxes are ``x, y, w, h`` pixels, frames 1-based throughout.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import numpy as np

from solvers import Association, get_solver
from sotmot.appearance import Embedder, make_embedder
from sotmot.boxes import nms
from sotmot.config import PreprocessConfig, TrackerConfig
from sotmot.constraints import merge_group
from sotmot.io import FrameReader, SeqInfo, read_detections, read_seqinfo
from sotmot.postprocess import to_tracks
from sotmot.tracklets import build_tracklets
from sotmot.types import Detections, Tracklet, Tracks

log = logging.getLogger(__name__)
T = TypeVar("T")


def progress_bar(items: Iterable[T], desc: str, enabled: bool, total: int | None = None) -> Iterator[T]:
    """Wrap ``items`` in a tqdm progress bar on stderr when ``enabled``."""
    if not enabled:
        yield from items
        return
    from tqdm import tqdm

    yield from tqdm(items, desc=desc, total=total, leave=False, dynamic_ncols=True, unit="frame")


def resolve_nms(config: PreprocessConfig, detections: Detections) -> str:
    """The NMS overlap to use: ``config.nms`` with ``"auto"`` decided from the scores.

    ``auto`` means IoM when any score lies outside [0, 1] (scores that are not
    probabilities, as with the public DPM detections, where the paper uses
    NMS-IoM), IoU otherwise.
    """
    if config.nms != "auto":
        return config.nms
    s = detections.scores
    return "iom" if len(s) and (s.min() < 0.0 or s.max() > 1.0) else "iou"


def preprocess(detections: Detections, config: PreprocessConfig) -> Detections:
    """Score threshold, then per-frame NMS (paper Sec. 6.1). Keeps the canonical order."""
    keep = np.ones(len(detections), dtype=bool)
    if config.score_threshold is not None:
        keep &= detections.scores >= config.score_threshold
    dets = detections.subset(np.flatnonzero(keep))
    kind = resolve_nms(config, detections)
    if kind == "none" or len(dets) == 0:
        return dets
    kept = [idx[nms(dets.boxes[idx], dets.scores[idx], config.nms_threshold, kind)]
            for idx in dets.by_frame().values()]
    return dets.subset(np.sort(np.concatenate(kept)))


def embed_detections(info: SeqInfo, detections: Detections, embedder: Embedder,
                     progress: bool = False) -> np.ndarray:
    """Appearance features ``(N, D)`` of every detection, one batched call per frame."""
    features = np.zeros((len(detections), embedder.dim), dtype=np.float32)
    reader = FrameReader(info, cache_size=1)
    per_frame = detections.by_frame()
    for frame in progress_bar(sorted(per_frame), f"{info.name}: appearance", progress, len(per_frame)):
        idx = per_frame[frame]
        features[idx] = embedder.embed(reader(frame), detections.boxes[idx])
    return features


@dataclass
class TrackResult:
    """Everything one run produced, for inspection and comparison.

    Attributes
    ----------
    info
        The sequence.
    detections
        Detections after preprocessing (the indices in tracklets refer to these).
    features
        ``(N, D)`` appearance features of ``detections``.
    tracklets
        Output of the tracklet stage.
    association
        The solver's grouping of the tracklets.
    trajectories
        One merged trajectory per group (before post-processing).
    tracks
        The final output.
    timings
        Seconds spent per stage.
    """

    info: SeqInfo
    detections: Detections
    features: np.ndarray
    tracklets: list[Tracklet]
    association: Association
    trajectories: list[Tracklet]
    tracks: Tracks
    timings: dict[str, float] = field(default_factory=dict)


def associate(tracklets: list[Tracklet], merger: str, config: TrackerConfig) -> tuple[Association, list[Tracklet]]:
    """Run the solver named ``merger`` and merge each of its groups into one trajectory."""
    solver = get_solver(merger)
    association = solver(tuple(tracklets), config.association)
    by_id = {t.id: t for t in tracklets}
    trajectories = [merge_group([by_id[i] for i in group], new_id=k)
                    for k, group in enumerate(association.groups, 1)]
    return association, trajectories


@dataclass
class Prepared:
    """A sequence taken up to the tracklets: everything before long-term association."""

    info: SeqInfo
    detections: Detections
    features: np.ndarray
    tracklets: list[Tracklet]
    timings: dict[str, float]


class _Clock:
    def __init__(self, timings: dict[str, float]) -> None:
        self.timings = timings
        self.last = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.timings[stage] = self.timings.get(stage, 0.0) + now - self.last
        self.last = now


def prepare_sequence(seq_dir: str | Path, config: TrackerConfig = TrackerConfig(),
                     embedder: Embedder | None = None, progress: bool = False,
                     features: np.ndarray | None = None) -> Prepared:
    """Read, preprocess, embed and build tracklets: the stages no solver choice can change.

    Parameters are those of :func:`track_sequence`.
    """
    timings: dict[str, float] = {}
    clock = _Clock(timings)
    info = read_seqinfo(seq_dir)
    raw = read_detections(info.det_path, info.length)
    clock.lap("read")
    dets = preprocess(raw, config.preprocess)
    log.info("%s: %d detections, %d after preprocessing", info.name, len(raw), len(dets))
    clock.lap("preprocess")
    if features is None:
        if embedder is None:
            embedder = make_embedder(config.appearance)
        features = embed_detections(info, dets, embedder, progress)
    elif len(features) != len(dets):
        raise ValueError(f"{len(features)} precomputed features for {len(dets)} detections")
    clock.lap("appearance")
    tracklets = build_tracklets(dets, features, info.frame_rate, config.tracklets)
    clock.lap("tracklets")
    return Prepared(info, dets, features, tracklets, timings)


def finish_sequence(prepared: Prepared, config: TrackerConfig = TrackerConfig(),
                    merger: str = "greedy") -> TrackResult:
    """Long-term association with the solver ``merger``, then post-processing."""
    timings = dict(prepared.timings)
    clock = _Clock(timings)
    association, trajectories = associate(prepared.tracklets, merger, config)
    clock.lap("association")
    tracks = to_tracks(trajectories, prepared.detections, config.postprocess)
    clock.lap("postprocess")
    log.info("%s: %d tracklets -> %d trajectories -> %d tracks (%s)", prepared.info.name,
             len(prepared.tracklets), len(trajectories), tracks.n_tracks, merger)
    return TrackResult(prepared.info, prepared.detections, prepared.features, prepared.tracklets,
                       association, trajectories, tracks, timings)


def track_sequence(seq_dir: str | Path, config: TrackerConfig = TrackerConfig(), merger: str = "greedy",
                   embedder: Embedder | None = None, progress: bool = False,
                   features: np.ndarray | None = None) -> TrackResult:
    """Track one MOTChallenge sequence folder.

    Parameters
    ----------
    seq_dir
        Folder with ``seqinfo.ini``, ``det/det.txt`` and ``img1/``.
    config
        Tracker configuration.
    merger
        Name of the long-term association solver (a key of ``solvers.SOLVERS``).
    embedder
        Appearance model; built from ``config.appearance`` when omitted.
    progress
        Show progress bars on stderr.
    features
        Precomputed features of the preprocessed detections (skips embedding;
        used by benchmarks that try several settings on the same detections).
    """
    get_solver(merger)  # an unknown name fails before any work is done
    return finish_sequence(prepare_sequence(seq_dir, config, embedder, progress, features), config, merger)
