"""SOT after association: extend confirmed trajectories past their ends.

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
  affinity with the trajectory of at least ``[ends] min_affinity``;
* the best candidate overlaps a box of another trajectory (or one already
  added) at IoU above ``[ends] stop_iou``: someone else is there;
* less than half the candidate lies inside the image (the person leaves;
  :data:`MIN_INSIDE`): the template search looks past the image's edge
  (:class:`~sotmot.sot.search.TemplateSearch` with ``beyond_edge``), so an
  end follows a person out of the image until half of them is gone, as
  MOTChallenge annotates them;
* it has grown ``[ends] seconds``, or reached the sequence's first or last frame.

With the detector's weak boxes (``[detection] weak_boxes``) the candidates
are the weak boxes near the prior instead of template proposals (no SOT),
judged by the values of :mod:`sotmot.sot.support`. Only trajectories the
confirmation stage trusts (mean confidence at least ``[ends]
min_confidence``) are extended.

Added boxes are flagged ``from_sot`` in the output. Boxes are ``x, y, w, h``
pixels, frames 1-based.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from sotmot.appearance import Embedder, affinity_rows
from sotmot.boxes import centers, inside_share, iou_matrix
from sotmot.config import EndsConfig, SotConfig
from sotmot.motion import CameraMotion
from sotmot.sot.search import TemplateSearch
from sotmot.sot.support import SUPPORT_IOU, SUPPORTED_AFFINITY, SUPPORTED_STOP_IOU, DetectorSupport
from sotmot.types import Tracks

log = logging.getLogger(__name__)

#: How many of a trajectory's last boxes (frames) give its velocity.
VELOCITY_FRAMES = 5
#: An end stops where less of the box it found than this share lies inside the image (the person leaves).
MIN_INSIDE = 0.5


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
    """How many frames an end may grow: ``[ends] seconds`` at the sequence's frame rate, at least one."""
    return max(1, int(round(seconds * frame_rate)))


def mean_confidence(confidence: np.ndarray) -> float:
    """Mean of a track's confirmation confidences (:mod:`sotmot.confidence`); 1 when none was computed."""
    scored = confidence[np.isfinite(confidence)]
    return float(scored.mean()) if len(scored) else 1.0


def passes_end_gates(config: EndsConfig, track_confidence: float = 1.0, affinity: float = 1.0, step: int = 1,
                     steps: int | None = None, supported: bool = False) -> bool:
    """The end extension's gates, stated once: the track's mean confirmation confidence is at least
    ``min_confidence``, the found box's re-ID affinity with the track at least ``min_affinity``
    (:data:`~sotmot.sot.support.SUPPORTED_AFFINITY` for a detector's weak box, ``supported``), and the box at
    most ``steps`` frames from the end (None: no limit). :func:`extend_ends` checks each where it knows the
    number; :func:`gated` applies all of them to a trace (``scripts/fit_sot.py``)."""
    needed = SUPPORTED_AFFINITY if supported else config.min_affinity
    return (not track_confidence < config.min_confidence and not affinity < needed
            and (steps is None or step <= steps))


def gated(trace: list[dict], frame_rate: float, config: EndsConfig) -> list[dict]:
    """The boxes of a :func:`extend_ends` trace (run with looser gates) that ``config``'s gates keep.

    An end stops at its first box that fails a gate, as :func:`extend_ends`
    does, so this reproduces the stricter run, except that a box cut from one
    end no longer blocks another track's end.
    """
    steps = end_steps(config.seconds, frame_rate)
    stopped, kept = set(), []
    for box in trace:  # in the order they were added: each end's boxes one step after another
        end = (box["track"], box["direction"])
        if end in stopped or not passes_end_gates(config, box["track_confidence"], box["affinity"], box["step"], steps,
                                                  box.get("supported", False)):
            stopped.add(end)
            continue
        kept.append(box)
    return kept


class _Finder:
    """The search both uses share: candidates around a prior (the detector's weak boxes when ``support`` is given,
    else template proposals), re-ranked by re-ID against an identity."""

    def __init__(self, tracks: Tracks, read_frame: Callable[[int], np.ndarray], embedder: Embedder,
                 search: SotConfig, ends: EndsConfig, support: DetectorSupport | None = None) -> None:
        self.read_frame, self.embedder, self.support = read_frame, embedder, support
        # the frame an end will search next decodes while this one is searched (a FrameReader of JPEGs)
        self.prefetch: Callable[[int], None] = getattr(read_frame, "prefetch", lambda frame: None)
        self.search_config, self.ends = search, ends
        self.search = TemplateSearch(search, beyond_edge=True)  # MIN_INSIDE says how far out
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
        return None if self.support is not None else TemplateSearch.template(self.read_frame(frame), box)

    def find(self, template: np.ndarray | None, frame: int, prior: np.ndarray, identity: np.ndarray,
             track_id: int) -> tuple[np.ndarray | None, float, bool]:
        """The best candidate for ``track_id`` in ``frame`` around ``prior``, its re-ID affinity with ``identity``,
        and whether it is a detector's weak box.

        The candidates are the weak boxes overlapping the prior at IoU
        :data:`~sotmot.sot.support.SUPPORT_IOU` or more when the finder has
        them, else the template proposals correlating above ``[sot] tau``.
        The box is None when the evidence is not there: no candidate, or the
        best re-ranked one has affinity under the gate
        (:func:`passes_end_gates`), lies less than half inside the image, or
        overlaps a box of another track at IoU above ``[ends] stop_iou``
        (:data:`~sotmot.sot.support.SUPPORTED_STOP_IOU` for a weak box).
        """
        image = self.read_frame(frame)
        supported = self.support is not None
        if supported:  # the detector's boxes near the prior, no SOT
            candidates = self.support(frame, image)
            candidates = candidates[iou_matrix(prior, candidates)[0] >= SUPPORT_IOU] if len(candidates) \
                else candidates
        else:
            candidates, ncc = self.search.search(template, self.grey(frame), prior, top=self.search_config.rerank)
            candidates = candidates[ncc > self.search_config.tau]
        if len(candidates) == 0:
            return None, 0.0, False
        aff = affinity_rows(np.repeat(identity[None], len(candidates), 0), self.embedder.embed(image, candidates))
        best = int(np.argmax(aff))
        found, affinity = candidates[best], float(aff[best])
        if not passes_end_gates(self.ends, affinity=affinity, supported=supported) \
                or inside_share(found[None], image.shape[1], image.shape[0])[0] < MIN_INSIDE:
            return None, affinity, supported
        others = [b for o, b in self.occupied.get(frame, []) if o != track_id]
        stop = SUPPORTED_STOP_IOU if supported else self.ends.stop_iou  # a detector box is someone of its own
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
                n_frames: int, frame_rate: float, embedder: Embedder, search: SotConfig, config: EndsConfig,
                progress: Callable | None = None, trace: list[dict] | None = None,
                support: DetectorSupport | None = None, motion: CameraMotion | None = None) -> Tracks:
    """``tracks`` with boxes added before the first and after the last box of each track.

    Parameters
    ----------
    tracks
        Confirmed output tracks; only those whose mean confirmation confidence is at least
        ``[ends] min_confidence`` are extended.
    features
        Track id -> mean appearance feature of its detections (its identity).
    read_frame
        ``frame -> BGR image``.
    n_frames
        Sequence length.
    frame_rate
        Frames per second (``[ends] seconds`` becomes frames with it).
    embedder
        The re-ID model that re-ranks candidates.
    search
        The template search of ``[sot]``: ``tau``, ``rerank``, ``search_radius``, ``scales``.
    config
        ``[ends]``: how far, and the gates.
    progress
        Wraps the list of track ids (a progress bar).
    trace
        If given, one dict per added box is appended: ``frame``, ``track``,
        ``direction`` (+1 after the last box, -1 before the first), ``step``
        (frames from the end), ``box``, ``affinity`` (re-ID, with the track's
        identity), ``track_confidence`` and ``supported`` (a detector's weak
        box). ``scripts/fit_sot.py`` fits the gates from it; it shows why
        an end grew as far as it did.
    support
        The detector's weak boxes (``[detection] weak_boxes``): the ends grow by them instead of SOT; or None.
    motion
        The camera's motion: when it moved, the constant-velocity prior is
        carried in the reference frame (the track's own motion, not the
        camera's) and mapped into the frame searched.
    """
    steps = end_steps(config.seconds, frame_rate)
    motion = motion if motion is not None else CameraMotion.still(n_frames)
    finder = _Finder(tracks, read_frame, embedder, search, config, support)
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
            finder.prefetch(start + direction)
            template = finder.template(start, box)
            velocity = end_velocity(frames, motion.to_ref(frames, boxes), direction)
            for k in range(1, steps + 1):
                g = start + direction * k
                if not 1 <= g <= n_frames:
                    break
                prior = motion.box_from_ref(g, motion.box_to_ref(g - direction, box) + np.r_[velocity, 0.0, 0.0])
                if k < steps:
                    finder.prefetch(g + direction)  # decoded while this frame is searched, used if the end grows
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
