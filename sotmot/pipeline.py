"""The tracker's stages wired together; each stage is also callable on its own.

    plan (``sotmot.plan.resolve``: every "auto" decided once)
         -> detect (a model) or read (a det.txt) -> preprocess (score threshold, NMS, scores as confidences)
         -> embed -> camera motion (``sotmot.motion``) -> [Algorithm 1, ``sotmot.sot``] -> tracklets
         -> long-term association (a solver named in ``sotmot.plugins.SOLVERS``)
         -> post-processing -> confirmation (``sotmot.confirm``) -> trajectory ends (``[ends]``) -> results

Boxes are ``x, y, w, h`` pixels, frames 1-based throughout. With a moving
camera (``[motion]``), tracklets, association and post-processing see the
boxes in the reference frame's pixels (frame 1), and the results are mapped
back into each frame's own.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import time
from collections.abc import Callable
from contextlib import closing
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sotmot.appearance import Embedder, embedder_for, motion_only
from sotmot.boxes import inside_share
from sotmot.association import Association, get_solver
from sotmot.association.merge import merge_group
from sotmot.confidence.calibration import load_calibration, model_kind
from sotmot.confidence.maps import confidence_knots, detection_confidence, self_map
from sotmot.config import PostprocessConfig, TrackerConfig
from sotmot.confirm import box_scorer, confirm
from sotmot.detection import Detector, make_detector
from sotmot.errors import ConfigError
from sotmot.io import FrameReader, SeqInfo, read_detections, read_seqinfo
from sotmot.motion import CameraMotion, PassMotion, estimate_motion
from sotmot.passes import detect_sequence, embed_detections
from sotmot.plan import Plan, resolve
from sotmot.postprocess import BoxScorer, Occluders, line_checked, output_ids, to_tracks
from sotmot.preprocess import frame_preprocessor, nms_per_frame, preprocess_indices, resolve_nms
from sotmot.progress import Progress, as_progress
from sotmot.sot.support import WEAK_MIN_SCORE, DetectorSupport
from sotmot.tracklets import build_tracklets
from sotmot.types import Detections, Tracklet, Tracks

log = logging.getLogger(__name__)

def run_sot(info: SeqInfo, detections: Detections, features: np.ndarray | None, embedder: Embedder,
            config: TrackerConfig, progress: "bool | Progress" = False,
            timings: dict[str, float] | None = None,
            motion: CameraMotion | None = None,
            support: DetectorSupport | None = None) -> tuple[Detections, np.ndarray, np.ndarray, int]:
    """The SOT step, then NMS on the enlarged set (paper Sec. 3.3 and 6.1).

    ``features`` of ``detections``, or None: the SOT step computes them from
    the frames it decodes, window by window, so each frame is decoded once
    for appearance, SOT and the added boxes' features. ``timings``, when given, receives ``"appearance"``
    (the seconds of re-ID inside the step: detections, candidates, added
    boxes) and ``"decode"`` (frame reading, in a thread of its own one frame
    ahead).

    ``support`` (the detector's weak boxes, ``[detection] weak_boxes``), when
    given, regresses each found box onto a detector box and ends extensions no
    detector box supports.

    Returns the enlarged detections (added boxes flagged ``from_sot``), their
    features, the SOT links ``(K, 2)`` as indices into them (links whose ends
    NMS removed are dropped) and the number of extension steps.
    """
    from sotmot.sot.algorithm1 import SotTracker

    spent = {"appearance": 0.0, "decode": 0.0}

    def timed(stage: str, work: Callable) -> Callable:
        def run(*args):
            start = time.perf_counter()
            out = work(*args)
            spent[stage] += time.perf_counter() - start
            return out
        return run

    reader = FrameReader(info, cache_size=1, ahead=True)  # decodes ahead in its thread, a video too
    tracker = SotTracker(config.sot, reader, info.length, embed=timed("appearance", embedder.embed),
                         det_features=features, motion=motion, support=support)
    show = as_progress(progress)
    with closing(reader):
        result = tracker.run(detections,
                             progress=lambda items: show(items, f"{info.name}: SOT ({config.sot.variant})"))
    spent["decode"] = reader.decode_seconds
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
        Seconds spent per stage; ``"decode"``, ``"detect"`` and
        ``"motion_in_pass"`` are the shares of the pass over the frames
        (:func:`sotmot.passes.frame_pass`) that read them, found the boxes and
        measured the camera, inside its stage's time, not added to it.
    confidence
        ``(N,)`` confidence in [0, 1] of each of ``detections`` (``[preprocess] confidence``).
    dropped
        The boxes the confirmation stage dropped (same ids as ``tracks``).
    detected
        The detector's boxes before preprocessing when the detections came
        from the model (``[detection] source``), else None.
    track_ids
        The output track id of each of ``trajectories`` (None: dropped as too
        short), as :func:`~sotmot.postprocess.output_ids` numbers them.
    motion
        The camera's motion (``[motion]``). When ``motion.moving``, the boxes of
        ``tracklets`` and ``trajectories`` are in the reference frame's pixels
        (frame 1), where association judged them; ``detections`` and ``tracks``
        are in each frame's own.
    confidence_method
        How detection scores became confidences (``[preprocess] confidence`` as
        ``"auto"`` resolved it: a detector family, ``"self"``, ``"quantile"``, ...).
    occluders
        The detections as post-processing's occlusion check saw them (what could
        hide a person in a long gap; :func:`sotmot.postprocess.gaps_of`).
    postprocess
        ``[postprocess]`` as post-processing applied it to ``trajectories``: the
        interpolation bound lowered where the line check found the straight line
        does not hold (:func:`sotmot.postprocess.line_checked`); None when not
        post-processed.
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
    track_ids: list[int | None] = field(default_factory=list)
    motion: CameraMotion | None = None
    confidence_method: str = ""
    occluders: Occluders | None = None
    postprocess: PostprocessConfig | None = None

    def identities(self) -> dict[int, np.ndarray]:
        """Output track id -> the mean appearance feature of its trajectory (its identity)."""
        return {i: t.feature for t, i in zip(self.trajectories, self.track_ids) if i is not None}


def associate(tracklets: list[Tracklet], plan: Plan) -> tuple[Association, list[Tracklet]]:
    """Run the solver ``[association] solver`` names (with the plan's gap limit in frames) and merge each group
    into one trajectory."""
    solver = get_solver(plan.association.solver)
    association = solver(tuple(tracklets), plan.association)
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
    plan: Plan
    # the detections in the reference frame's pixels (the trajectories' coordinates), as the tracklets hold them
    in_ref: Detections
    sot_links: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), np.int64))
    sot_steps: int = 0
    confidence: np.ndarray = field(default_factory=lambda: np.zeros(0))
    confidence_method: str = "raw"
    detected: Detections | None = None
    motion: CameraMotion | None = None
    # the detector's weak boxes (the plan's weak_boxes): they checked Algorithm 1 and serve the trajectory ends
    support: DetectorSupport | None = None

    @functools.cached_property
    def occluders(self) -> Occluders:
        """The detections as what could hide a person in a long gap, in the trajectories' coordinates (the
        reference frame when the camera moves); built once per prepared sequence."""
        return Occluders(self.in_ref)

    def finishing(self, config: TrackerConfig) -> Plan:
        """The plan that finishes this sequence with ``config`` (:func:`finish_sequence`): the preparation's own
        when ``config`` is the one it was prepared with; else its decisions on the detections kept (where they
        came from, whether the weak boxes are at hand) with ``config``'s association and trajectory ends."""
        return self.plan if config is self.plan.config else self.plan.finishing(config)

    def written(self, trajectories: list[Tracklet], post: PostprocessConfig, scorer: BoxScorer | None = None,
                ids: list[int | None] | None = None) -> Tracks:
        """``trajectories`` as the tracker writes them, before confirmation: post-processed by ``post``
        (:func:`~sotmot.postprocess.to_tracks`, in the trajectories' coordinates), then, when the camera moves, each
        box in its own frame's pixels, a box wholly outside the image left out (a person the camera turned away from
        is still filled in where the world says they were). :func:`finish_sequence` writes these; the confidence
        fits (:mod:`sotmot.fitting.confidence`) label the very same boxes."""
        info = self.info
        tracks = to_tracks(trajectories, self.detections, post, scorer, info.frame_rate, ids, self.occluders)
        if self.motion is not None and self.motion.moving:
            tracks = tracks.with_boxes(self.motion.from_ref(tracks.frames, tracks.boxes))
            tracks = tracks.subset(inside_share(tracks.boxes, info.width, info.height) > 0)
        return tracks


class _Clock:
    def __init__(self, timings: dict[str, float]) -> None:
        self.timings = timings
        self.last = time.perf_counter()

    def lap(self, stage: str) -> None:
        now = time.perf_counter()
        self.timings[stage] = self.timings.get(stage, 0.0) + now - self.last
        self.last = now


def pass_detector(plan: Plan) -> Detector:
    """The detector of a run on the detector's own boxes, as the plan runs it: with the weak boxes at the lower
    of ``[detection] min_score`` and :data:`~sotmot.sot.support.WEAK_MIN_SCORE`, so one pass gives the boxes
    tracked and the weak boxes that check the SOT step (:func:`prepare_sequence` splits them)."""
    if plan.detector is None:
        raise ValueError(f"{plan.info.name}: this run has no detector (detections from {plan.source})")
    return make_detector(plan.detector)


def prepare_sequence(seq_dir: "str | Path | SeqInfo", config: TrackerConfig = TrackerConfig(),
                     embedder: Embedder | None = None, progress: "bool | Progress" = False,
                     features: np.ndarray | None = None, detector: Detector | None = None,
                     detections: Detections | None = None) -> Prepared:
    """Detect or read, preprocess, embed and build tracklets: the stages no solver choice can change.

    Parameters are those of :func:`track_sequence`.
    """
    return prepare(plan_for(seq_dir, config, detections), embedder, progress, features, detector, detections)


def plan_for(seq_dir: "str | Path | SeqInfo", config: TrackerConfig, detections: Detections | None = None) -> Plan:
    """The plan (:func:`sotmot.plan.resolve`) of tracking ``seq_dir`` with ``config``; ``detections``: handed over."""
    info = seq_dir if isinstance(seq_dir, SeqInfo) else read_seqinfo(seq_dir, config.input.fps)
    return resolve(config, info, given=detections is not None)


def prepare(plan: Plan, embedder: Embedder | None = None, progress: "bool | Progress" = False,
            features: np.ndarray | None = None, detector: Detector | None = None,
            detections: Detections | None = None) -> Prepared:
    """:func:`prepare_sequence` of a plan already made.

    Raises
    ------
    ConfigError
        ``[input] step`` above 1: the stages track every frame of the sequence they are given, and only ``sotmot
        track`` (:mod:`sotmot.stepping`) gives them every k-th.
    """
    if plan.config.input.step != 1:
        raise ConfigError(f"[input] step = {plan.config.input.step} is for sotmot track, sotmot.track and "
                          f"sotmot.stream (they track every k-th frame and fill the frames between); this run "
                          f"tracks every frame of {plan.info.name}: set step = 1")
    timings: dict[str, float] = {}
    clock = _Clock(timings)
    info, config, sot = plan.info, plan.config, plan.sot
    detected = raw_features = support = None
    seen = None  # the camera's motion, measured by the pass over a video
    if plan.source == "model":  # one pass over the frames: detection, and re-ID of what it found
        embed_now = features is None and not sot
        if embed_now:
            embedder = embedder_for(plan.appearance, embedder)
        if detector is None:
            detector = pass_detector(plan)
        low = getattr(detector, "min_score", None)  # a detector without one: every box it gives is tracked
        split = config.detection.min_score if low is not None and low < config.detection.min_score else None
        weak = {} if plan.weak_boxes and low is not None and low <= WEAK_MIN_SCORE else None
        # embedding too, the pass is the appearance stage with detection inside it (timed as "detect", like
        # "decode"); detection alone, the pass is the "detect" stage
        if plan.motion_in_pass:  # the estimate leaves out the boxes preprocessing will keep
            seen = PassMotion(info, config.motion, frame_preprocessor(config.preprocess, plan.mask))
        raw, raw_features = detect_sequence(info, detector, embedder if embed_now else None, progress,
                                            timings if embed_now else None, weak=weak, min_score=split,
                                            tap=seen.see if seen is not None else None)
        if weak is not None:
            support = DetectorSupport.from_pass(weak, plan.mask)
        detected = raw
        log.info("%s: the detector found %d boxes", info.name, len(raw))
        clock.lap("appearance" if embed_now else "detect")
    else:
        raw = detections if detections is not None else read_detections(plan.det_file, info.length,
                                                                         (info.width, info.height))
        clock.lap("read")
    kept = preprocess_indices(raw, config.preprocess, plan.mask)
    dets = raw.subset(kept)
    log.info("%s: %d detections, %d after preprocessing", info.name, len(raw), len(dets))
    if plan.mask is not None:
        log.info("%s: the mask %s ignores %.0f %% of the image, where %d detections stood", info.name,
                 plan.mask.path, 100 * plan.mask.ignored_share, int(plan.mask.ignores(raw.boxes).sum()))
    # the detector's scores as confidences: the map fitted for its family, the ranks, or (after association) the
    # sequence's own trajectories ("self")
    method, knots = confidence_knots(config.preprocess.confidence, raw.scores,
                                     load_calibration(config.confirm.calibration), plan.family, info.name)
    confidence = detection_confidence(dets.scores, knots)
    log.info("%s: detection confidence by %r", info.name, method)
    clock.lap("preprocess")
    if features is None and not sot and raw_features is not None:
        features = raw_features[kept]
    elif features is None and not sot:  # with SOT, the SOT step computes them from the frames it decodes
        embedder = embedder_for(plan.appearance, embedder)
        if plan.motion_in_pass:
            seen = PassMotion(info, config.motion)
        features = embed_detections(info, dets, embedder, progress, timings, seen.see if seen is not None else None)
    elif features is not None and len(features) != len(dets):
        raise ValueError(f"{len(features)} precomputed features for {len(dets)} detections")
    clock.lap("appearance")
    links, steps = np.zeros((0, 2), np.int64), 0
    motion = estimate_motion(info, dets, config.motion, progress, seen=seen)
    seen = None
    if config.motion.compensation != "off":
        clock.lap("motion")
    if plan.weak_boxes and support is None:  # public, refined: the detector runs on the frames the search visits
        support = DetectorSupport.from_config(plan.weak_detector, detector, plan.mask)
    if sot:
        embedder = embedder_for(plan.appearance, embedder)
        inside: dict[str, float] = {}
        dets, features, links, steps = run_sot(info, dets, features, embedder, config, progress, inside, motion,
                                               support)
        confidence = detection_confidence(dets.scores, knots)  # the SOT step's boxes too
        log.info("%s: SOT added %d boxes (after NMS)", info.name, int(dets.from_sot.sum()))
        clock.lap("sot")
        # the re-ID inside the SOT step (the detections' features too, when it computed them) counts as appearance;
        # "decode" is reported beside the stages, as part of the one that read the frames (here: sot)
        timings["sot"] -= inside["appearance"]
        timings["appearance"] += inside["appearance"]
        timings["decode"] = timings.get("decode", 0.0) + inside["decode"]
    # association, post-processing and the occlusion check see the boxes in the reference frame when the camera
    # moved (the same detections otherwise)
    in_ref = motion.to_ref_detections(dets)
    tracklets = build_tracklets(in_ref, features, info.frame_rate, config.tracklets)
    clock.lap("tracklets")
    return Prepared(info, dets, features, tracklets, timings, plan, in_ref, links, steps, confidence, method, detected,
                    motion, support)


def with_self_confidence(prepared: Prepared, trajectories: list[Tracklet]) -> Prepared:
    """``prepared`` with the ``"self"`` confidence (:func:`~sotmot.confidence.maps.self_map`) of its detections from
    ``trajectories``; the ranks stay (with the quantile model) when the sequence teaches too little."""
    dets = prepared.detections
    knots = self_map(dets, trajectories, prepared.info.frame_rate)
    if knots is None:
        log.info("%s: too few long trajectories or lone boxes for a self-fitted confidence; ranks kept",
                 prepared.info.name)
        return dataclasses.replace(prepared, confidence_method="quantile")
    return dataclasses.replace(prepared, confidence=detection_confidence(dets.scores, knots))


def finish_sequence(prepared: Prepared, config: TrackerConfig = TrackerConfig(),
                    embedder: Embedder | None = None,
                    progress: "bool | Progress" = False) -> TrackResult:
    """Long-term association with the solver ``[association] solver``, then post-processing, confirmation and
    (with ``[ends] seconds``) the extension of trajectory ends; ``embedder`` serves the latter
    (built from ``config.appearance`` when needed and omitted)."""
    plan = prepared.finishing(config)
    timings = dict(prepared.timings)
    clock = _Clock(timings)
    association, trajectories = associate(prepared.tracklets, plan)
    clock.lap("association")
    if prepared.confidence_method == "self":  # the map from what association made of this very sequence
        prepared = with_self_confidence(prepared, trajectories)
    scorer = None
    if config.confirm.enabled:
        model = load_calibration(config.confirm.calibration).box_models[model_kind(prepared.confidence_method)]
        scorer = box_scorer(model, prepared.detections, prepared.features, prepared.confidence,
                            prepared.info.frame_rate)
    occluders = prepared.occluders
    post = line_checked(config.postprocess, trajectories, prepared.info.frame_rate)
    if post != config.postprocess:
        log.info("%s: the straight line does not hold over %g s on this sequence's trajectories ([postprocess] "
                 "line_check_seconds): gaps are filled up to %g s", prepared.info.name,
                 config.postprocess.line_check_seconds, post.interpolate_max_seconds)
    ids = output_ids(trajectories, post, prepared.info.frame_rate, occluders)
    tracks = prepared.written(trajectories, post, scorer, ids)
    clock.lap("postprocess")
    tracks, dropped = (confirm(tracks, config, prepared.confidence_method) if config.confirm.enabled
                       else (tracks, Tracks.empty()))
    clock.lap("confirm")
    if motion_only(prepared.features) and config.ends.enabled:
        log.info("%s: no re-ID (motion only): trajectory ends are not extended", prepared.info.name)
    elif config.ends.enabled and len(tracks):
        identity = {i: t.feature for t, i in zip(trajectories, ids) if i is not None}
        tracks = extend_trajectories(prepared, plan, identity, tracks, embedder, progress)
        clock.lap("extend")
    log.info("%s: %d tracklets -> %d trajectories -> %d tracks, %d boxes kept, %d dropped as unconfirmed (%s)",
             prepared.info.name, len(prepared.tracklets), len(trajectories), tracks.n_tracks, len(tracks),
             len(dropped), config.association.solver)
    return TrackResult(prepared.info, prepared.detections, prepared.features, prepared.tracklets,
                       association, trajectories, tracks, timings, prepared.confidence, dropped, prepared.detected,
                       ids, prepared.motion, prepared.confidence_method, occluders, post)


def extend_trajectories(prepared: Prepared, plan: Plan, identity: dict[int, np.ndarray], tracks: Tracks,
                        embedder: Embedder | None = None, progress: "bool | Progress" = False) -> Tracks:
    """SOT after association (:mod:`sotmot.sot.extend`) on the output ``tracks`` (``identity``: track id -> mean
    feature): the ends extended (``[ends] seconds``), by the detector's weak boxes when the plan has them, else by
    SOT."""
    from sotmot.sot.extend import extend_ends

    info, config = prepared.info, plan.config
    reader, embedder = FrameReader.walking(info), embedder_for(plan.appearance, embedder)
    support = None
    if plan.weak_boxes:  # the preparation's, or the detector at the weak boxes' threshold on the frames searched
        support = prepared.support if prepared.support is not None else DetectorSupport.from_config(
            plan.weak_detector, mask=plan.mask)
    if config.ends.seconds > 0:
        before = len(tracks)
        tracks = extend_ends(tracks, identity, reader, info.length, info.frame_rate, embedder, config.sot,
                             config.ends, support=support, motion=prepared.motion,
                             progress=lambda ends, n: as_progress(progress)(ends, f"{info.name}: extend ends", n))
        log.info("%s: end extension added %d boxes", info.name, len(tracks) - before)
    if support is not None:
        log.info("%s: the detector's boxes checked the SOT boxes (%d frames detected for it alone)", info.name,
                 support.frames_detected)
    return tracks


def track_sequence(seq_dir: "str | Path | SeqInfo", config: TrackerConfig = TrackerConfig(),
                   embedder: Embedder | None = None, progress: "bool | Progress" = False,
                   features: np.ndarray | None = None, detector: Detector | None = None,
                   detections: Detections | None = None) -> TrackResult:
    """Track one sequence: a MOTChallenge folder, a video file, or a :class:`~sotmot.io.SeqInfo` (frames in
    memory: :func:`sotmot.track`).

    Parameters
    ----------
    seq_dir
        Folder with ``seqinfo.ini``, ``det/det.txt`` and ``img1/``; a video file; or the sequence itself.
    config
        Tracker configuration; ``[association] solver`` names the long-term
        association solver (a key of :data:`sotmot.plugins.SOLVERS`).
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
        source``), or whose weak boxes check SOT boxes (``[detection]
        weak_boxes``; used when its ``min_score`` is at most
        :data:`~sotmot.sot.support.WEAK_MIN_SCORE`); built from
        ``config.detection`` when needed and omitted.
    detections
        The detections, already read and checked (:func:`sotmot.io.detections_from_array`), instead of a file
        or the detector; tracked as a detections file is (``[detection] source = "file"``).
    """
    get_solver(config.association.solver)  # an unknown name fails before any work is done
    return track_plan(plan_for(seq_dir, config, detections), embedder, progress, features, detector, detections)


def track_plan(plan: Plan, embedder: Embedder | None = None, progress: "bool | Progress" = False,
               features: np.ndarray | None = None, detector: Detector | None = None,
               detections: Detections | None = None) -> TrackResult:
    """Every stage of :func:`track_sequence`, of a plan already made."""
    return finish_sequence(prepare(plan, embedder, progress, features, detector, detections), plan.config,
                           embedder, progress)
