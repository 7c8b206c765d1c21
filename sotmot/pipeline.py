"""The tracker's stages wired together; each stage is also callable on its own.

    detect (a model) or read (a det.txt) -> preprocess (score threshold, NMS) -> embed -> tracklets
         -> long-term association (a solver from ``solvers.SOLVERS``)
         -> post-processing -> confirmation (``sotmot.confidence``) -> results

Boxes are ``x, y, w, h`` pixels, frames 1-based throughout.
"""

from __future__ import annotations

import logging
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypeVar

import numpy as np

from solvers import Association, get_solver
from sotmot.appearance import Embedder, embedder_for
from sotmot.boxes import nms
from sotmot.confidence import (
    BoxModel,
    box_features,
    confidence_knots,
    detection_confidence,
    load_calibration,
    model_kind,
    scores_are_probabilities,
)
from sotmot.config import PreprocessConfig, TrackerConfig
from sotmot.constraints import merge_group
from sotmot.detection import Detector, detection_source, known_family, make_detector
from sotmot.io import FrameReader, SeqInfo, read_detections, read_seqinfo
from sotmot.postprocess import BoxScorer, Expanded, output_ids, to_tracks
from sotmot.tracklets import build_tracklets
from sotmot.types import Detections, Tracklet, Tracks

log = logging.getLogger(__name__)
T = TypeVar("T")

#: How a stage shows progress: ``(items, description, total) -> items`` (an iterator over the same items).
Progress = Callable[[Iterable, str, "int | None"], Iterable]


def progress_bar(items: Iterable[T], desc: str, enabled: bool, total: int | None = None,
                 position: int | None = None) -> Iterator[T]:
    """Wrap ``items`` in a tqdm progress bar on stderr when ``enabled`` (on terminal line ``position``)."""
    if not enabled:
        yield from items
        return
    from tqdm import tqdm

    yield from tqdm(items, desc=desc, total=total, leave=False, dynamic_ncols=True, unit="frame", position=position)


def bars(position: int | None = None) -> Progress:
    """A :data:`Progress` that draws tqdm bars (on terminal line ``position``: ``track --workers`` gives
    each worker its own line under the overall bar)."""
    return lambda items, desc, total=None: progress_bar(items, desc, True, total, position)


def as_progress(progress: "bool | Progress") -> Progress:
    """``progress`` as the stages use it: a :data:`Progress`; True draws bars, False shows nothing."""
    if callable(progress):
        return progress
    return bars() if progress else (lambda items, desc, total=None: items)


def resolve_nms(config: PreprocessConfig, detections: Detections) -> str:
    """The NMS overlap to use: ``config.nms`` with ``"auto"`` decided from the scores.

    ``auto`` means IoM when any score lies outside [0, 1] (scores that are not
    probabilities, as with the public DPM detections, where the paper uses
    NMS-IoM), IoU otherwise.
    """
    if config.nms != "auto":
        return config.nms
    return "iou" if scores_are_probabilities(detections.scores) else "iom"


def nms_per_frame(detections: Detections, kind: str, threshold: float) -> np.ndarray:
    """Indices (ascending) of the boxes that survive NMS of kind ``"iou"``/``"iom"``/``"none"`` in their frame."""
    if kind == "none" or len(detections) == 0:
        return np.arange(len(detections))
    kept = [idx[nms(detections.boxes[idx], detections.scores[idx], threshold, kind)]
            for idx in detections.by_frame().values()]
    return np.sort(np.concatenate(kept))


def preprocess(detections: Detections, config: PreprocessConfig) -> Detections:
    """Score threshold, then per-frame NMS (paper Sec. 6.1). Keeps the canonical order."""
    return detections.subset(preprocess_indices(detections, config))


def preprocess_indices(detections: Detections, config: PreprocessConfig) -> np.ndarray:
    """Indices (ascending) into ``detections`` of the boxes :func:`preprocess` keeps."""
    kept = np.flatnonzero(detections.scores >= config.score_threshold) if config.score_threshold is not None \
        else np.arange(len(detections))
    return kept[nms_per_frame(detections.subset(kept), resolve_nms(config, detections), config.nms_threshold)]


def run_sot(info: SeqInfo, detections: Detections, features: np.ndarray | None, embedder: Embedder,
            config: TrackerConfig, progress: "bool | Progress" = False,
            confidence: np.ndarray | None = None,
            timings: dict[str, float] | None = None) -> tuple[Detections, np.ndarray, np.ndarray, int]:
    """The SOT step, then NMS on the enlarged set (paper Sec. 3.3 and 6.1).

    ``features`` of ``detections``, or None: the SOT step computes them from
    the frames it decodes, window by window, so each frame is decoded once
    for appearance, SOT and the added boxes' features. ``confidence``
    (``(N,)`` of ``detections``) chooses the seeds with ``[sot]
    seed_min_confidence``. ``timings``, when given, receives ``"appearance"``
    (the seconds of re-ID inside the step: detections, candidates, added
    boxes) and ``"decode"`` (frame reading).

    Returns the enlarged detections (added boxes flagged ``from_sot``), their
    features, the SOT links ``(K, 2)`` as indices into them (links whose ends
    NMS removed are dropped) and the number of extension steps.
    """
    from sotmot.sot import SotTracker

    spent = {"appearance": 0.0, "decode": 0.0}

    def timed(stage: str, work: Callable) -> Callable:
        def run(*args):
            start = time.perf_counter()
            out = work(*args)
            spent[stage] += time.perf_counter() - start
            return out
        return run

    tracker = SotTracker(config.sot, timed("decode", FrameReader(info, cache_size=1)), info.length,
                         embed=timed("appearance", embedder.embed), det_features=features)
    seeds = None if confidence is None else confidence >= config.sot.seed_min_confidence
    show = as_progress(progress)
    result = tracker.run(detections, progress=lambda items: show(items, f"{info.name}: SOT ({config.sot.variant})"),
                         seeds=seeds)
    if timings is not None:
        for stage, seconds in spent.items():
            timings[stage] = timings.get(stage, 0.0) + seconds
    enlarged = result.detections
    features = result.det_features if features is None else features
    all_features = np.concatenate([features, result.features.astype(features.dtype)])
    keep = nms_per_frame(enlarged, resolve_nms(config.preprocess, detections), config.preprocess.nms_threshold)
    remap = np.full(len(enlarged), -1)
    remap[keep] = np.arange(len(keep))
    links = remap[result.links]
    links = links[(links >= 0).all(axis=1)] if len(links) else links.reshape(0, 2)
    return enlarged.subset(keep), all_features[keep], links, result.steps


#: Frames the appearance stage decodes (and crops) ahead of the one the model embeds.
PREFETCH_FRAMES = 8


def embed_detections(info: SeqInfo, detections: Detections, embedder: Embedder,
                     progress: "bool | Progress" = False, timings: dict[str, float] | None = None) -> np.ndarray:
    """Appearance features ``(N, D)`` of every detection (see :func:`frame_pass` for how frames are read)."""
    features = np.zeros((len(detections), embedder.dim), dtype=np.float32)
    per_frame = detections.by_frame()
    passed = frame_pass(info, sorted(per_frame), lambda frame, image: detections.boxes[per_frame[frame]],
                        embedder, f"{info.name}: appearance", progress, timings)
    for frame, _, feats in passed:
        features[per_frame[frame]] = feats
    return features


def frame_pass(info: SeqInfo, frames: list[int], boxes_of: Callable[[int, np.ndarray], object],
               embedder: Embedder | None, desc: str, progress: "bool | Progress" = False,
               timings: dict[str, float] | None = None) -> list[tuple[int, object, np.ndarray]]:
    """Read each of ``frames`` once, find its boxes and embed them: ``[(frame, found, features), ...]``.

    ``boxes_of(frame, image)`` gives the frame's boxes: an ``(N, 4)`` array,
    or ``(boxes, scores)`` from a detector (whose call is timed as
    ``"detect"``); ``embedder`` None skips the embedding (features
    ``(N, 0)``). The next frames (:data:`PREFETCH_FRAMES`) are decoded,
    searched and (for the crop-based backends, onnx and openvino) cropped in a
    background thread while the re-ID model embeds earlier ones (each
    releases the GIL), so reading overlaps inference. The crop-based backends
    get the crops of several frames in one call that fills about one forward
    pass (``batch_size`` rows; with the flip a crop is two rows): a frame
    holds a few boxes, and small batches waste the runtime's time
    (docs/benchmarks.md); other embedders are called once per frame.
    ``timings``, when given, receives ``"decode"``: the seconds spent reading
    (and cropping) frames, overlapped with the embedding, so part of, not
    added to, the stage's wall time.
    """
    from concurrent.futures import ThreadPoolExecutor

    from sotmot.appearance.onnx_reid import CropEmbedder, crop_boxes

    frame_reader = FrameReader(info, cache_size=1)  # called from the one decoding thread only
    spent = {"decode": 0.0, "detect": 0.0}
    batched = isinstance(embedder, CropEmbedder)
    per_call = max(1, embedder.batch_size // (2 if embedder.flip else 1)) if batched else 1  # crops: one forward pass
    out: list[tuple[int, object, np.ndarray]] = []

    def reader(frame: int) -> tuple[np.ndarray, object, np.ndarray]:
        start = time.perf_counter()
        image = frame_reader(frame)
        spent["decode"] += time.perf_counter() - start
        start = time.perf_counter()
        found = boxes_of(frame, image)
        boxes = found[0] if isinstance(found, tuple) else found
        spent["detect" if isinstance(found, tuple) else "decode"] += time.perf_counter() - start
        start = time.perf_counter()
        if batched:
            image = crop_boxes(image, boxes)
        spent["decode"] += time.perf_counter() - start
        return boxes, found, image

    pending: list[tuple[int, np.ndarray]] = []  # (index into out, crops) not embedded yet

    def flush() -> None:
        sizes = [len(c) for _, c in pending]
        if sum(sizes):
            feats = embedder.embed_crops(np.concatenate([c for _, c in pending]))
            for (k, _), part in zip(pending, np.split(feats, np.cumsum(sizes)[:-1])):
                out[k] = (out[k][0], out[k][1], part)
        pending.clear()

    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="sotmot-decode") as pool:
        # a few frames ahead: one call of the model consumes several frames' crops at once
        upcoming = deque(pool.submit(reader, f) for f in frames[:PREFETCH_FRAMES])
        for k, frame in enumerate(as_progress(progress)(frames, desc, len(frames))):
            boxes, found, item = upcoming.popleft().result()
            if k + PREFETCH_FRAMES < len(frames):
                upcoming.append(pool.submit(reader, frames[k + PREFETCH_FRAMES]))
            out.append((frame, found, np.zeros((len(boxes), embedder.dim if embedder else 0), np.float32)))
            if embedder is None:
                continue
            if not batched:
                out[-1] = (frame, found, embedder.embed(item, boxes))
                continue
            pending.append((len(out) - 1, item))
            if sum(len(c) for _, c in pending) >= per_call or k + 1 == len(frames):
                flush()
    if timings is not None:
        for stage, seconds in spent.items():
            if seconds:
                timings[stage] = timings.get(stage, 0.0) + seconds
    return out


def detect_sequence(info: SeqInfo, detector, embedder: Embedder | None = None, progress: "bool | Progress" = False,
                    timings: dict[str, float] | None = None) -> tuple[Detections, np.ndarray]:
    """Run ``detector`` on every frame: the detections in canonical order and, with ``embedder``, their features
    from the same decoded frames (``(N, D)``; ``(N, 0)`` without)."""
    passed = frame_pass(info, list(range(1, info.length + 1)), lambda frame, image: detector.detect(image),
                        embedder, f"{info.name}: detection", progress, timings)
    dim = embedder.dim if embedder is not None else 0
    frames = np.concatenate([np.full(len(found[0]), frame, np.int64) for frame, found, _ in passed] or [[]])
    raw = Detections(frames, np.concatenate([found[0] for _, found, _ in passed] or [np.zeros((0, 4))]),
                     np.concatenate([found[1] for _, found, _ in passed] or [[]]))
    features = np.concatenate([f for *_, f in passed] or [np.zeros((0, dim), np.float32)]).reshape(len(raw), dim)
    order = raw.canonical_order()
    return raw.subset(order), features[order]


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
        The final output (the confirmed boxes).
    timings
        Seconds spent per stage.
    confidence
        ``(N,)`` confidence in [0, 1] of each of ``detections`` (``[preprocess] confidence``).
    dropped
        The boxes the confirmation stage dropped (same ids as ``tracks``).
    detected
        The detector's boxes before preprocessing when the detections came
        from the model (``[detection] source``), else None.
    """

    info: SeqInfo
    detections: Detections
    features: np.ndarray
    tracklets: list[Tracklet]
    association: Association
    trajectories: list[Tracklet]
    tracks: Tracks
    timings: dict[str, float] = field(default_factory=dict)
    confidence: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dropped: Tracks = field(default_factory=Tracks.empty)
    detected: Detections | None = None


def associate(tracklets: list[Tracklet], merger: str | None, config: TrackerConfig
              ) -> tuple[Association, list[Tracklet]]:
    """Run the solver named ``merger`` (None: ``[association] solver``) and merge each group into one trajectory."""
    solver = get_solver(merger or config.association.solver)
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
    sot_links: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))
    sot_steps: int = 0
    confidence: np.ndarray = field(default_factory=lambda: np.zeros(0))
    confidence_method: str = "raw"
    detected: Detections | None = None


class _Clock:
    def __init__(self, timings: dict[str, float]) -> None:
        self.timings = timings
        self.last = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.timings[stage] = self.timings.get(stage, 0.0) + now - self.last
        self.last = now


def prepare_sequence(seq_dir: str | Path, config: TrackerConfig = TrackerConfig(),
                     embedder: Embedder | None = None, progress: "bool | Progress" = False,
                     features: np.ndarray | None = None, detector: Detector | None = None) -> Prepared:
    """Detect or read, preprocess, embed and build tracklets: the stages no solver choice can change.

    Parameters are those of :func:`track_sequence`.
    """
    timings: dict[str, float] = {}
    clock = _Clock(timings)
    info = read_seqinfo(seq_dir)
    sot = config.sot.variant != "none"
    source, det_file = detection_source(config.detection, info)
    detected = raw_features = None
    if source == "model":  # one pass over the frames: detection, and re-ID of what it found
        embed_now = features is None and not sot
        if embed_now:
            embedder = embedder_for(config.appearance, embedder)
        detector = detector if detector is not None else make_detector(config.detection)
        # embedding too, the pass is the appearance stage with detection inside it (timed as "detect", like
        # "decode"); detection alone, the pass is the "detect" stage
        raw, raw_features = detect_sequence(info, detector, embedder if embed_now else None, progress,
                                            timings if embed_now else None)
        detected = raw
        log.info("%s: the detector found %d boxes", info.name, len(raw))
        clock.lap("appearance" if embed_now else "detect")
    else:
        raw = read_detections(det_file, info.length, (info.width, info.height))
        clock.lap("read")
    kept = preprocess_indices(raw, config.preprocess)
    dets = raw.subset(kept)
    log.info("%s: %d detections, %d after preprocessing", info.name, len(raw), len(dets))
    clock.lap("preprocess")
    if features is None and not sot and raw_features is not None:
        features = raw_features[kept]
    elif features is None and not sot:  # with SOT, the SOT step computes them from the frames it decodes
        embedder = embedder_for(config.appearance, embedder)
        features = embed_detections(info, dets, embedder, progress, timings)
    elif features is not None and len(features) != len(dets):
        raise ValueError(f"{len(features)} precomputed features for {len(dets)} detections")
    clock.lap("appearance")
    links, steps = np.zeros((0, 2), np.int64), 0
    method, knots = confidence_knots(config.preprocess.confidence, raw.scores,
                                     load_calibration(config.confirm.calibration),
                                     known_family(config.detection, info))
    log.info("%s: detection confidence by %r", info.name, method)
    if sot:
        embedder = embedder_for(config.appearance, embedder)
        inside: dict[str, float] = {}
        dets, features, links, steps = run_sot(info, dets, features, embedder, config, progress,
                                               detection_confidence(dets.scores, knots), inside)
        log.info("%s: SOT added %d boxes (after NMS)", info.name, int(dets.from_sot.sum()))
        clock.lap("sot")
        # the re-ID inside the SOT step (the detections' features too, when it computed them) counts as appearance;
        # "decode" is reported beside the stages, as part of the one that read the frames (here: sot)
        timings["sot"] -= inside["appearance"]
        timings["appearance"] += inside["appearance"]
        timings["decode"] = timings.get("decode", 0.0) + inside["decode"]
    tracklets = build_tracklets(dets, features, info.frame_rate, config.tracklets,
                                must_link=links if config.sot.must_link else None)
    clock.lap("tracklets")
    confidence = detection_confidence(dets.scores, knots)  # the SOT step's boxes too
    return Prepared(info, dets, features, tracklets, timings, links, steps, confidence, method, detected)


def box_scorer(prepared: Prepared, model: BoxModel, confidence: np.ndarray | None = None) -> BoxScorer:
    """``model`` as a :data:`~sotmot.postprocess.BoxScorer` for one prepared sequence.

    ``confidence`` overrides ``prepared.confidence`` (the calibration fit tries
    other detection confidences on the same sequence).
    """
    confidence = prepared.confidence if confidence is None else confidence
    dets, rate = prepared.detections, prepared.info.frame_rate

    def score(trajectory: Tracklet, expanded: Expanded) -> np.ndarray:
        return model.predict(box_features(trajectory, expanded, confidence, dets.from_sot, prepared.features, rate))

    return score


def confirm(tracks: Tracks, config: TrackerConfig, method: str = "raw") -> tuple[Tracks, Tracks]:
    """Split scored ``tracks`` into the confirmed boxes and the dropped ones.

    The threshold is ``[confirm] threshold``, or the calibration's for the
    model kind of the confidence ``method`` the sequence used.
    """
    threshold = config.confirm.threshold
    if threshold is None:
        threshold = load_calibration(config.confirm.calibration).thresholds[model_kind(method)]
    keep = ~(tracks.confidence < threshold)  # NaN (not scored) is kept
    return tracks.subset(np.flatnonzero(keep)), tracks.subset(np.flatnonzero(~keep))


def finish_sequence(prepared: Prepared, config: TrackerConfig = TrackerConfig(),
                    merger: str | None = None, embedder: Embedder | None = None,
                    progress: "bool | Progress" = False) -> TrackResult:
    """Long-term association with the solver ``merger`` (None: the config's), then post-processing, confirmation and
    (with ``[sot] extend_seconds``) the extension of trajectory ends; ``embedder`` serves the latter
    (built from ``config.appearance`` when needed and omitted)."""
    timings = dict(prepared.timings)
    clock = _Clock(timings)
    association, trajectories = associate(prepared.tracklets, merger, config)
    clock.lap("association")
    scorer = None
    if config.confirm.enabled:
        model = load_calibration(config.confirm.calibration).box_models[model_kind(prepared.confidence_method)]
        scorer = box_scorer(prepared, model)
    tracks = to_tracks(trajectories, prepared.detections, config.postprocess, scorer, prepared.info.frame_rate)
    clock.lap("postprocess")
    tracks, dropped = (confirm(tracks, config, prepared.confidence_method) if config.confirm.enabled
                       else (tracks, Tracks.empty()))
    clock.lap("confirm")
    if (config.sot.extend_seconds > 0 or config.sot.refine_gaps) and len(tracks):
        tracks = extend_trajectories(prepared, trajectories, tracks, config, embedder, progress)
        clock.lap("extend")
    log.info("%s: %d tracklets -> %d trajectories -> %d tracks, %d boxes kept, %d dropped as unconfirmed (%s)",
             prepared.info.name, len(prepared.tracklets), len(trajectories), tracks.n_tracks, len(tracks),
             len(dropped), merger or config.association.solver)
    return TrackResult(prepared.info, prepared.detections, prepared.features, prepared.tracklets,
                       association, trajectories, tracks, timings, prepared.confidence, dropped, prepared.detected)


def extend_trajectories(prepared: Prepared, trajectories: list[Tracklet], tracks: Tracks, config: TrackerConfig,
                        embedder: Embedder | None = None, progress: "bool | Progress" = False) -> Tracks:
    """SOT after association (:mod:`sotmot.extend`) on the output ``tracks``: interpolated boxes replaced by
    boxes found in the frames (``[sot] refine_gaps``), then the ends extended (``[sot] extend_seconds``)."""
    from sotmot.extend import extend_ends, refine_gaps

    info = prepared.info
    ids = output_ids(trajectories, config.postprocess, info.frame_rate)
    identity = {i: t.feature for t, i in zip(trajectories, ids) if i is not None}
    reader, embedder = FrameReader(info, cache_size=8), embedder_for(config.appearance, embedder)
    if config.sot.refine_gaps:
        tracks = refine_gaps(tracks, identity, reader, embedder, config.sot,
                             progress=lambda items: as_progress(progress)(items, f"{info.name}: refine gaps"))
    if config.sot.extend_seconds > 0:
        before = len(tracks)
        tracks = extend_ends(tracks, identity, reader, info.length, info.frame_rate, embedder, config.sot,
                             progress=lambda items: as_progress(progress)(items, f"{info.name}: extend ends"))
        log.info("%s: end extension added %d boxes", info.name, len(tracks) - before)
    return tracks


def track_sequence(seq_dir: str | Path, config: TrackerConfig = TrackerConfig(), merger: str | None = None,
                   embedder: Embedder | None = None, progress: "bool | Progress" = False,
                   features: np.ndarray | None = None, detector: Detector | None = None) -> TrackResult:
    """Track one MOTChallenge sequence folder.

    Parameters
    ----------
    seq_dir
        Folder with ``seqinfo.ini``, ``det/det.txt`` and ``img1/``.
    config
        Tracker configuration.
    merger
        Name of the long-term association solver (a key of ``solvers.SOLVERS``);
        None: ``[association] solver`` of ``config``.
    embedder
        Appearance model; built from ``config.appearance`` when omitted.
    progress
        Show progress bars on stderr (True), nothing (False), or any
        :data:`Progress`.
    features
        Precomputed features of the preprocessed detections (skips embedding;
        used by benchmarks that try several settings on the same detections).
    detector
        Person detector, when the detections come from the model (``[detection]
        source``); built from ``config.detection`` when needed and omitted.
    """
    get_solver(merger or config.association.solver)  # an unknown name fails before any work is done
    return finish_sequence(prepare_sequence(seq_dir, config, embedder, progress, features, detector), config,
                           merger, embedder, progress)
