"""SOT after association: extend confirmed trajectories past their ends, and check their interpolated boxes.

Interpolation fills gaps inside a trajectory but cannot reach before its
first or after its last box, where a person is often still visible and only
the detector lost them (entering, leaving, partly occluded). Each end of every
confirmed trajectory is tracked frame by frame away from the trajectory, with
the paper's machinery (Sec. 3.3): the template of the end box proposes
candidates around a constant-velocity prior (the trajectory's own last
motion), and the re-ID model re-ranks them against the trajectory's mean
appearance feature, its identity (compared with the end detection's own
feature, the paper's seed, the mean was right more often: on MOT17-09-FRCNN
71 of 73 added boxes against 102 of 150). An end stops at the first frame where

* no candidate has a template correlation above ``[sot] tau`` and an
  affinity with the trajectory of at least ``extend_min_affinity``;
* the best candidate overlaps a box of another trajectory (or one already
  added) at IoU above ``stop_iou``: someone else is there (a box a detector
  box supports, a detection of its own, above ``extend_supported_stop_iou``);
* less than half the candidate lies inside the image (the person leaves);
* it has grown ``extend_seconds``, or reached the sequence's first or last frame.

Only trajectories the confirmation stage trusts (mean confidence at least
``extend_min_confidence``) are extended. :func:`refine_gaps` uses the same
search inside a trajectory's gaps, where it replaces an interpolated box by
the box found around it when the evidence passes the same gates.

Added boxes are flagged ``from_sot`` in the output. Boxes are ``x, y, w, h``
pixels, frames 1-based.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable

import numpy as np

from sotmot.appearance import Embedder, affinity_rows
from sotmot.boxes import centers, inside_share, iou_matrix
from sotmot.config import DetectionConfig, SotConfig
from sotmot.motion import CameraMotion
from sotmot.sot.search import TemplateSearch
from sotmot.types import Tracks

log = logging.getLogger(__name__)

#: How many of a trajectory's last boxes (frames) give its velocity.
VELOCITY_FRAMES = 5


def end_velocity(frames: np.ndarray, boxes: np.ndarray, direction: int) -> np.ndarray:
    """Centre velocity ``(2,)`` in pixels per frame at one end, pointing away from the trajectory.

    ``frames`` ascending; ``direction`` +1 for the last end, -1 for the first.
    Uses the end box and the box up to :data:`VELOCITY_FRAMES` frames inside.
    """
    if len(frames) < 2:
        return np.zeros(2)
    if direction == 1:
        a, b = max(0, len(frames) - 1 - VELOCITY_FRAMES), len(frames) - 1
    else:
        a, b = min(len(frames) - 1, VELOCITY_FRAMES), 0
    c = centers(boxes[[a, b]])
    return (c[1] - c[0]) / abs(int(frames[b]) - int(frames[a]))


def end_steps(seconds: float, frame_rate: float) -> int:
    """How many frames an end may grow: ``extend_seconds`` at the sequence's frame rate, at least one."""
    return max(1, int(round(seconds * frame_rate)))


def mean_confidence(confidence: np.ndarray) -> float:
    """Mean of a track's confirmation confidences (:mod:`sotmot.confidence`); 1 when none was computed."""
    scored = confidence[np.isfinite(confidence)]
    return float(scored.mean()) if len(scored) else 1.0


def passes_end_gates(config: SotConfig, track_confidence: float = 1.0, affinity: float = 1.0, step: int = 1,
                     steps: int | None = None, supported: bool = False) -> bool:
    """The end extension's gates, stated once: the track's mean confirmation confidence is at least
    ``extend_min_confidence``, the found box's re-ID affinity with the track at least ``extend_min_affinity``
    (``extend_supported_affinity`` for a box a detector box ``supported``, ``[sot] verify``), and the box at
    most ``steps`` frames from the end (None: no limit). :func:`extend_ends` checks each where it knows the
    number; :func:`gated` applies all of them to a trace (``scripts/fit_sot.py``)."""
    needed = config.extend_supported_affinity if supported else config.extend_min_affinity
    return (not track_confidence < config.extend_min_confidence and not affinity < needed
            and (steps is None or step <= steps))


def gated(trace: list[dict], frame_rate: float, config: SotConfig) -> list[dict]:
    """The boxes of a :func:`extend_ends` trace (run with looser gates) that ``config``'s gates keep.

    An end stops at its first box that fails a gate, as :func:`extend_ends`
    does, so this reproduces the stricter run, except that a box cut from one
    end no longer blocks another track's end.
    """
    steps = end_steps(config.extend_seconds, frame_rate)
    stopped, kept = set(), []
    for box in trace:  # in the order they were added: each end's boxes one step after another
        end = (box["track"], box["direction"])
        if end in stopped or not passes_end_gates(config, box["track_confidence"], box["affinity"], box["step"], steps,
                                                  box.get("supported", False)):
            stopped.add(end)
            continue
        kept.append(box)
    return kept


class DetectorSupport:
    """The person detector as a verifier of SOT boxes (``[sot] verify = "detector"``): its boxes scoring at least
    ``verify_min_score`` in a frame, detected once per frame the search visits."""

    def __init__(self, detector, min_score: float) -> None:
        self.detector = detector
        self.min_score = min_score
        self._boxes: dict[int, np.ndarray] = {}
        self.frames_detected = 0

    @classmethod
    def from_pass(cls, found: dict[int, tuple[np.ndarray, np.ndarray]], min_score: float) -> DetectorSupport:
        """The boxes one detection pass already found (frame -> (boxes, scores), run at a threshold no higher
        than ``min_score``: :func:`sotmot.passes.detect_sequence`'s ``weak``); a frame the pass did not see has
        none (the detector is not run again)."""
        support = cls(None, min_score)
        for frame, (boxes, scores) in found.items():
            support._boxes[frame] = boxes[scores >= min_score]
        return support

    @classmethod
    def from_config(cls, detection: DetectionConfig, min_score: float, detector=None) -> DetectorSupport:
        """The detector ``detection`` names, run at the verifier's own low threshold ``min_score`` (its tracking
        threshold, ``[detection] min_score``, would hide the weak boxes); ``detector``, one already loaded, is
        used instead when it runs at ``min_score`` or lower."""
        if detector is not None and getattr(detector, "min_score", 1.0) <= min_score:
            return cls(detector, min_score)
        from sotmot.detection import make_detector

        return cls(make_detector(dataclasses.replace(detection, min_score=min_score)), min_score)

    def __call__(self, frame: int, image: np.ndarray) -> np.ndarray:
        """``(K, 4)`` ``x, y, w, h`` boxes of ``frame`` (its ``image``)."""
        if frame not in self._boxes:
            if self.detector is None:
                return np.zeros((0, 4))
            boxes, scores = self.detector.detect(image)
            keep = np.asarray(scores) >= self.min_score
            self._boxes[frame] = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)[keep]
            self.frames_detected += 1
        return self._boxes[frame]


class _Finder:
    """The search both uses share: template proposals around a prior, re-ranked by re-ID against an identity."""

    def __init__(self, tracks: Tracks, read_frame: Callable[[int], np.ndarray], embedder: Embedder,
                 config: SotConfig, support: DetectorSupport | None = None) -> None:
        if config.extend_by == "auto":  # as [sot] extend_by = "auto" resolves: weak boxes where a detector is at hand
            config = dataclasses.replace(config, extend_by="detections" if support is not None else "sot")
        self.read_frame, self.embedder, self.config, self.support = read_frame, embedder, config, support
        if config.extend_by == "detections" and support is None:
            raise ValueError("[sot] extend_by = 'detections' needs the detector's boxes (a DetectorSupport)")
        self.search = TemplateSearch(config)
        self.occupied: dict[int, list[tuple[int, np.ndarray]]] = {}  # frame -> (track id, box) of every box there
        for f, i, b in zip(tracks.frames.tolist(), tracks.ids.tolist(), tracks.boxes):
            self.occupied.setdefault(f, []).append((i, b))
        self._greys: dict[int, np.ndarray] = {}

    def grey(self, f: int) -> np.ndarray:
        import cv2

        if f not in self._greys:
            if len(self._greys) > 64:
                self._greys.clear()
            bgr = self.read_frame(f)
            self._greys[f] = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr
        return self._greys[f]

    def template(self, frame: int, box: np.ndarray) -> np.ndarray | None:
        """The template of ``box`` in ``frame``; None for the weak-box search, which uses none (so the frame is
        not decoded for it)."""
        return None if self.config.extend_by == "detections" else TemplateSearch.template(self.read_frame(frame), box)

    def find(self, template: np.ndarray | None, frame: int, prior: np.ndarray, identity: np.ndarray,
             track_id: int) -> tuple[np.ndarray | None, float, bool]:
        """The best candidate for ``track_id`` in ``frame`` around ``prior``, its re-ID affinity with ``identity``,
        and whether a detector box supports it.

        With a :class:`DetectorSupport`, a candidate that overlaps a detector
        box at IoU ``verify_iou`` or more is replaced by that box (supported).
        The box is None when the evidence is not there: no proposal
        correlates above ``tau``, or the best re-ranked one has affinity under
        the gate (:func:`passes_end_gates`), lies less than half inside the
        image, or overlaps a box of another track at IoU above ``stop_iou``
        (``extend_supported_stop_iou`` for a supported box).
        """
        cfg = self.config
        image = self.read_frame(frame)
        if cfg.extend_by == "detections":  # the weak-box baseline: the detector's boxes near the prior, no SOT
            candidates = self.support(frame, image)
            candidates = candidates[iou_matrix(prior, candidates)[0] >= cfg.verify_iou] if len(candidates) \
                else candidates
        else:
            candidates, ncc = self.search.search(template, self.grey(frame), prior, top=cfg.rerank)
            candidates = candidates[ncc > cfg.tau]
        if len(candidates) == 0:
            return None, 0.0, False
        aff = affinity_rows(np.repeat(identity[None], len(candidates), 0), self.embedder.embed(image, candidates))
        best = int(np.argmax(aff))
        found, affinity, supported = candidates[best], float(aff[best]), cfg.extend_by == "detections"
        if self.support is not None and not supported:
            boxes = self.support(frame, image)
            if len(boxes):
                overlap = iou_matrix(found, boxes)[0]
                k = int(np.argmax(overlap))
                if overlap[k] >= cfg.verify_iou:
                    found, supported = boxes[k], True  # the paper's box regression on a SOT result
        if not passes_end_gates(cfg, affinity=affinity, supported=supported) \
                or inside_share(found[None], image.shape[1], image.shape[0])[0] < 0.5:
            return None, affinity, supported
        others = [b for o, b in self.occupied.get(frame, []) if o != track_id]
        stop = cfg.extend_supported_stop_iou if supported else cfg.stop_iou  # a detector box is someone of its own
        if others and iou_matrix(found, np.stack(others))[0].max() > stop:
            return None, affinity, supported
        return found, affinity, supported

    def claim(self, frame: int, track_id: int, box: np.ndarray) -> None:
        """``box`` of ``track_id`` now stands in ``frame``: later searches of other tracks avoid it."""
        self.occupied.setdefault(frame, []).append((track_id, box))


def _track_rows(tracks: Tracks, track_id: int) -> np.ndarray:
    rows = np.flatnonzero(tracks.ids == track_id)
    return rows[np.argsort(tracks.frames[rows], kind="stable")]


def extend_ends(tracks: Tracks, features: dict[int, np.ndarray], read_frame: Callable[[int], np.ndarray],
                n_frames: int, frame_rate: float, embedder: Embedder, config: SotConfig,
                progress: Callable | None = None, trace: list[dict] | None = None,
                support: DetectorSupport | None = None, motion: CameraMotion | None = None) -> Tracks:
    """``tracks`` with boxes added before the first and after the last box of each track.

    Parameters
    ----------
    tracks
        Confirmed output tracks; only those whose mean confirmation confidence is at least
        ``extend_min_confidence`` are extended.
    features
        Track id -> mean appearance feature of its detections (its identity).
    read_frame
        ``frame -> BGR image``.
    n_frames
        Sequence length.
    frame_rate
        Frames per second (``extend_seconds`` becomes frames with it).
    embedder
        The re-ID model that re-ranks candidates.
    config
        ``tau``, ``rerank``, ``search_radius``, ``scales``, ``stop_iou`` and the ``extend_*`` fields.
    progress
        Wraps the list of track ids (a progress bar).
    trace
        If given, one dict per added box is appended: ``frame``, ``track``,
        ``direction`` (+1 after the last box, -1 before the first), ``step``
        (frames from the end), ``box``, ``affinity`` (re-ID, with the track's
        identity), ``track_confidence`` and ``supported`` (a detector box took
        its place). ``scripts/fit_sot.py`` fits the gates from it; it shows why
        an end grew as far as it did.
    support
        The detector that checks each found box (``[sot] verify``), or None.
    motion
        The camera's motion: when it moved, the constant-velocity prior is
        carried in the reference frame (the track's own motion, not the
        camera's) and mapped into the frame searched.
    """
    steps = end_steps(config.extend_seconds, frame_rate)
    motion = motion if motion is not None else CameraMotion.still(n_frames)
    finder = _Finder(tracks, read_frame, embedder, config, support)
    added: list[tuple[int, int, np.ndarray]] = []
    ids = np.unique(tracks.ids).tolist()
    for track_id in (progress(ids) if progress else ids):
        rows = _track_rows(tracks, track_id)
        frames, boxes = tracks.frames[rows], tracks.boxes[rows]
        identity, confidence = features.get(track_id), mean_confidence(tracks.confidence[rows])
        if identity is None or not passes_end_gates(config, track_confidence=confidence):
            continue
        for direction in (1, -1):
            start = int(frames[-1] if direction == 1 else frames[0])
            box = boxes[-1 if direction == 1 else 0]
            template = finder.template(start, box)
            velocity = end_velocity(frames, motion.to_ref(frames, boxes), direction)
            for k in range(1, steps + 1):
                g = start + direction * k
                if not 1 <= g <= n_frames:
                    break
                prior = motion.box_from_ref(g, motion.box_to_ref(g - direction, box) + np.r_[velocity, 0.0, 0.0])
                found, affinity, supported = finder.find(template, g, prior, identity, track_id)
                if found is None:
                    break
                finder.claim(g, track_id, found)
                added.append((g, track_id, found))
                if trace is not None:
                    trace.append({"frame": g, "track": track_id, "direction": direction, "step": k, "box": found,
                                  "affinity": affinity, "track_confidence": confidence, "supported": supported})
                box = found
    log.info("end extension added %d boxes to %d tracks", len(added), len(ids))
    return with_added(tracks, added)


def with_added(tracks: Tracks, added: list[tuple[int, int, np.ndarray]]) -> Tracks:
    """``tracks`` plus SOT boxes ``(frame, track id, box)`` (flagged ``from_sot``, the lowest score, no
    confidence), rows in track, frame order."""
    if not added:
        return tracks
    n = len(added)
    extra = Tracks(np.array([a[0] for a in added]), np.array([a[1] for a in added]),
                   np.stack([a[2] for a in added]), np.full(n, float(tracks.scores.min())),
                   np.zeros(n, bool), np.ones(n, bool), np.full(n, np.nan))
    both = Tracks.concatenate([tracks, extra])
    return both.subset(np.lexsort((both.frames, both.ids)))


def refine_gaps(tracks: Tracks, features: dict[int, np.ndarray], read_frame: Callable[[int], np.ndarray],
                embedder: Embedder, config: SotConfig, progress: Callable | None = None,
                support: DetectorSupport | None = None) -> Tracks:
    """``tracks`` with interpolated boxes replaced by boxes found in the frames where the evidence supports them.

    Interpolation puts a box on the straight line between the two detector
    boxes around a gap; a person who turned, stopped or sped up is elsewhere.
    Each interpolated box is searched for around itself (the interpolation is
    the motion prior, known from both sides), with the template of the
    nearer real box of the track, and re-ranked by re-ID against the track's
    identity (``features``); it is replaced (flagged ``from_sot``, no longer
    ``interpolated``) only when :meth:`_Finder.find` accepts a candidate, else
    the interpolated box stays. Boxes are ``x, y, w, h`` pixels, frames 1-based.
    """
    finder = _Finder(tracks, read_frame, embedder, config, support)
    boxes = tracks.boxes.copy()
    interpolated, from_sot = tracks.interpolated.copy(), tracks.from_sot.copy()
    ids = np.unique(tracks.ids[tracks.interpolated]).tolist()
    templates: dict[int, np.ndarray] = {}
    for track_id in (progress(ids) if progress else ids):
        identity = features.get(track_id)
        if identity is None:
            continue
        rows = _track_rows(tracks, track_id)
        real = rows[~tracks.interpolated[rows]]
        for r in rows[tracks.interpolated[rows]]:
            f = int(tracks.frames[r])
            nearest = int(real[np.argmin(np.abs(tracks.frames[real] - f))])
            if nearest not in templates:
                templates[nearest] = finder.template(int(tracks.frames[nearest]), tracks.boxes[nearest])
            found, _, _ = finder.find(templates[nearest], f, tracks.boxes[r], identity, track_id)
            if found is not None:
                boxes[r], interpolated[r], from_sot[r] = found, False, True
    log.info("gap refinement replaced %d of %d interpolated boxes", int((from_sot & tracks.interpolated).sum()),
             int(tracks.interpolated.sum()))
    return Tracks(tracks.frames, tracks.ids, boxes, tracks.scores, interpolated, from_sot, tracks.confidence)
