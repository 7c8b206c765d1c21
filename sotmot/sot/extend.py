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

import heapq
import logging
from collections.abc import Callable, Iterator

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
             track_id: int, ahead: tuple[int, ...] = ()) -> tuple[np.ndarray | None, float, bool]:
        """The best candidate for ``track_id`` in ``frame`` around ``prior``, its re-ID affinity with ``identity``,
        and whether it is a detector's weak box. The frames ``ahead`` are decoded while it searches (once
        ``frame`` is read, so that asking for them cannot drop it; a folder of JPEGs).

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
        for later in ahead:
            self.prefetch(later)
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


class _End:
    """One end of a trajectory, walked frame by frame away from it: where it stands, the frames it may still
    search, and the boxes it found. ``order`` is its place among the ends (track ids ascending, each track's last
    end before its first): an earlier end searches a frame before a later one (:func:`_walk_in_frame_order`)."""

    def __init__(self, order: int, track_id: int, direction: int, start: int, box: np.ndarray, identity: np.ndarray,
                 confidence: float, velocity: np.ndarray, steps: int, n_frames: int) -> None:
        self.order, self.track_id, self.direction, self.start = order, track_id, direction, start
        self.box, self.identity, self.confidence, self.velocity = box, identity, confidence, velocity
        self.k, self.template = 0, None  # steps taken; the end box's template, cut at the first step
        self.last = min(n_frames, start + steps) if direction == 1 else max(1, start - steps)  # the farthest frame
        self.done = not 1 <= self.next <= n_frames  # at the sequence's first or last frame: nowhere to go
        self.found: list[dict] = []  # a trace record per box found (extend_ends' ``trace``), step after step

    @property
    def next(self) -> int:
        """The frame it searches next."""
        return self.start + self.direction * (self.k + 1)

    @property
    def key(self) -> int:
        """The frame its next step reads first: the end's own at the first step (the template is cut there)."""
        return self.start if self.k == 0 else self.next

    def frames(self) -> range:
        """Every frame it may search."""
        return range(self.start + 1, self.last + 1) if self.direction == 1 else range(self.last, self.start)

    def may_search(self, frame: int) -> bool:
        """Whether it has yet to search ``frame``: it has not stopped, and ``frame`` lies between its next frame
        and its farthest."""
        if self.done:
            return False
        return self.next <= frame <= self.last if self.direction == 1 else self.last <= frame <= self.next

    def step(self, finder: _Finder, motion: CameraMotion, then: int | None = None) -> None:
        """Search the next frame: the box found there is claimed and the end walks on; none, and it stops.
        While it searches, the frame it reads next if it grows is decoded ahead, and ``then``: the frame read
        next if it stops."""
        if self.k == 0:
            finder.prefetch(self.next)
            self.template = finder.template(self.start, self.box)
        g, direction = self.next, self.direction
        prior = motion.box_from_ref(g, motion.box_to_ref(g - direction, self.box) + np.r_[self.velocity, 0.0, 0.0])
        ahead = ((g + direction,) if g != self.last else ()) + ((then,) if then is not None else ())
        found, affinity, supported = finder.find(self.template, g, prior, self.identity, self.track_id, ahead)
        self.k += 1
        if found is None:
            self.done = True
            return
        finder.claim(g, self.track_id, found)
        self.found.append({"frame": g, "track": self.track_id, "direction": direction, "step": self.k, "box": found,
                           "affinity": affinity, "track_confidence": self.confidence, "supported": supported})
        self.box = found
        self.done = g == self.last  # as far as it may grow


def _track_rows(tracks: Tracks, track_id: int) -> np.ndarray:
    rows = np.flatnonzero(tracks.ids == track_id)
    return rows[np.argsort(tracks.frames[rows], kind="stable")]


def extend_ends(tracks: Tracks, features: dict[int, np.ndarray], read_frame: Callable[[int], np.ndarray],
                n_frames: int, frame_rate: float, embedder: Embedder, search: SotConfig, config: EndsConfig,
                progress: Callable | None = None, trace: list[dict] | None = None,
                support: DetectorSupport | None = None, motion: CameraMotion | None = None) -> Tracks:
    """``tracks`` with boxes added before the first and after the last box of each track.

    The ends are walked a step at a time in the order of the frames they
    read (:func:`_walk_in_frame_order`), so a video is read forward; the boxes
    are those of walking the ends one after another, track by track.

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
        ``(ends, total) -> ends``: wraps the ends, each given when it has stopped (a progress bar).
    trace
        If given, one dict per added box is appended: ``frame``, ``track``,
        ``direction`` (+1 after the last box, -1 before the first), ``step``
        (frames from the end), ``box``, ``affinity`` (re-ID, with the track's
        identity), ``track_confidence`` and ``supported`` (a detector's weak
        box); each end's boxes one step after another, the ends track by
        track. ``scripts/fit_sot.py`` fits the gates from it; it shows why an
        end grew as far as it did.
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
    ends: list[_End] = []
    ids = np.unique(tracks.ids).tolist()
    for track_id in ids:
        rows = _track_rows(tracks, track_id)
        frames, boxes = tracks.frames[rows], tracks.boxes[rows]
        identity, confidence = features.get(track_id), mean_confidence(tracks.confidence[rows])
        if identity is None or not passes_end_gates(config, track_confidence=confidence):
            continue
        for direction in (1, -1):
            start = int(frames[-1] if direction == 1 else frames[0])
            velocity = end_velocity(frames, motion.to_ref(frames, boxes), direction)
            ends.append(_End(len(ends), track_id, direction, start, boxes[-1 if direction == 1 else 0], identity,
                             confidence, velocity, steps, n_frames))
    walked = _walk_in_frame_order(ends, finder, motion)
    for _ in (progress(walked, len(ends)) if progress else walked):
        pass
    found = [record for end in ends for record in end.found]
    if trace is not None:
        trace.extend(found)
    log.info("end extension added %d boxes to %d tracks", len(found), len(ids))
    return with_added(tracks, [(r["frame"], r["track"], r["box"]) for r in found])


def _walk_in_frame_order(ends: list[_End], finder: _Finder, motion: CameraMotion) -> Iterator[_End]:
    """Walk every end a step at a time, the step that reads the lowest frame first; yield each end once stopped.

    Walked one after another, the ends read a video back and forth (each
    track's two ends lie wherever the track is), and a video goes back only by
    a seek, which decodes from the last key frame: 0.04 s in an MPEG-4 file,
    0.45 s in an H.264 one with a key frame every 250 frames (ffmpeg's
    default), where MOT16-09's 48 seeks took 21 s of its run's 43. In frame
    order the reader moves forward, and a walk back finds the frames before
    its end in the reader's cache (:meth:`FrameReader.__call__`).

    Ends meet only in a frame they both search: a box found there is claimed
    and stops the others. So a step waits while an end earlier in
    ``_End.order`` may still search its frame, and every frame is searched by
    its ends in that order, as walking them one after another does: the same
    boxes, whatever order the frames are read in.
    """
    touching: dict[int, list[_End]] = {}  # frame -> the ends that may search it, in their order
    for end in ends:
        for g in end.frames():
            touching.setdefault(g, []).append(end)
    waiting: dict[int, list[_End]] = {}  # an end's order -> the ends whose frame it may still search
    ready = [(end.key, end.order) for end in ends if not end.done]
    heapq.heapify(ready)
    yield from (end for end in ends if end.done)
    while ready:
        end = ends[heapq.heappop(ready)[1]]
        earlier = next((e for e in touching[end.next] if e.order < end.order and e.may_search(end.next)), None)
        if earlier is not None:
            waiting.setdefault(earlier.order, []).append(end)
            continue
        end.step(finder, motion, ends[ready[0][1]].key if ready else None)
        for other in waiting.pop(end.order, []):
            heapq.heappush(ready, (other.key, other.order))
        if end.done:
            yield end
        else:
            heapq.heappush(ready, (end.key, end.order))


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
