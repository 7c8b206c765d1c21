"""The single-object-tracking (SOT) step: recover boxes the detector missed (paper Sec. 3.3, Algorithm 1).

Every detection puts a forward and a backward *tracklet end* into a max
priority queue keyed by score. The best end is popped and extended by one
frame in its direction:

* it stops when it has grown to ``L`` boxes;
* if the adjacent frame already holds a box with an end of the opposite
  direction whose affinity with the seed is ``> tau_a`` and whose IoU with the
  current box is ``> tau_I``, the two ends meet: they are linked and both stop;
* otherwise :meth:`SotTracker.next` looks for the object in the adjacent frame
  around the current box, scoring candidates against the *seed* detection
  ``d_b`` (never against the last box: the paper's guard against drift);
  the end stops if nothing scores above ``tau``, if the best candidate's
  affinity with the seed is below ``tau_a``, or if it overlaps a box already
  in that frame with IoU ``> tau_I``; else the candidate is added (flagged as
  found by SOT), linked to the end, and pushed with score ``s * e``.

Two appearance variants score candidates:

* ``template``: OpenCV normalised cross-correlation (``cv2.matchTemplate``,
  ``TM_CCOEFF_NORMED``) of the seed's crop over a search window, at a few
  scales; one call scores every offset. Affinity is the correlation, clipped
  to [0, 1].
* ``deep``: the same template search proposes the best few boxes, which are
  re-ranked by the re-ID model's affinity with the seed's feature, all
  candidates of a step in one batched forward pass.

With the detector's weak boxes (``[detection] weak_boxes``, on by default
with the built-in detector) each found box is replaced by the weak box it
overlaps (the paper's box regression on SOT results, Sec. 6.1), and an
extension ends where none supports it.

The step runs over windows of frames (``window`` frames, default ``2 L + 1``)
so only a window's frames are kept in memory; an end never leaves its window.
Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import heapq
import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from sotmot.appearance import affinity_rows
from sotmot.boxes import iou_matrix
from sotmot.config import SotConfig
from sotmot.motion import CameraMotion
from sotmot.sot.search import TemplateSearch
from sotmot.sot.support import SUPPORT_IOU
from sotmot.types import Detections

log = logging.getLogger(__name__)


@dataclass
class SotResult:
    """What the SOT step produced.

    Attributes
    ----------
    detections
        The original detections followed by the added ones (``from_sot`` True),
        before the final NMS.
    links
        ``(K, 2)`` detection indices ``(earlier, later)`` that SOT linked in
        adjacent frames: an extension step or two ends that met.
    features
        Deep features of the added boxes, row ``i`` for added box ``i``, when
        the tracker has an embedder (else None).
    steps
        Number of extension attempts.
    det_features
        Features of the input detections: those given, or those computed
        window by window from the frames SOT decoded anyway (else None).
    """

    detections: Detections
    links: np.ndarray
    features: np.ndarray | None = None
    steps: int = 0
    det_features: np.ndarray | None = None


@dataclass(order=True)
class _End:
    priority: float
    order: int
    box_id: int = field(compare=False)
    seed_id: int = field(compare=False)
    score: float = field(compare=False)
    length: int = field(compare=False)
    direction: int = field(compare=False)


class SotTracker:
    """Algorithm 1 over one sequence.

    Parameters
    ----------
    config
        The SOT thresholds and variant.
    read_frame
        ``frame number -> BGR image``; one with a ``prefetch(frame)`` (a
        :class:`~sotmot.io.FrameReader`) decodes each next frame whose
        detections are embedded while this one's are.
    n_frames
        Sequence length (frames are ``1..n_frames``).
    embed
        ``(frame, boxes) -> (N, D)`` unit features; the ``deep`` variant needs
        it. With it, the added boxes get features from the frames of their
        window (no second decoding of those frames), whatever the variant.
    det_features
        Features of the input detections. None with ``embed``: they are
        computed window by window from the frames SOT decodes anyway, so a
        run with SOT decodes each frame once (``SotResult.det_features``).
    motion
        The camera's motion (None: a still camera): a box is carried into the
        next frame by the camera's motion, where the search is centred and the
        overlap checks are made.
    support
        ``(frame, image) -> (K, 4)`` the person detector's weak boxes in a
        frame (:class:`sotmot.sot.support.DetectorSupport`, ``[detection]
        weak_boxes``), or None. With it, a candidate is replaced by the weak
        box it overlaps at IoU :data:`~sotmot.sot.support.SUPPORT_IOU` or more
        (the paper's box regression on SOT results, Sec. 6.1), and an
        extension ends where no weak box supports its candidate.
    """

    def __init__(self, config: SotConfig, read_frame: Callable[[int], np.ndarray], n_frames: int,
                 embed: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                 det_features: np.ndarray | None = None, motion: CameraMotion | None = None,
                 support: Callable[[int, np.ndarray], np.ndarray] | None = None) -> None:
        if config.variant == "deep" and embed is None:
            raise ValueError("the deep SOT variant needs an embedder")
        self.config = config
        self.read_frame = read_frame
        self._prefetch: Callable[[int], None] = getattr(read_frame, "prefetch", lambda frame: None)
        self.n_frames = n_frames
        self.embed = embed
        self.det_features = det_features
        self.search = TemplateSearch(config)
        self.steps = 0
        self.motion = motion if motion is not None else CameraMotion.still(n_frames)
        self.support = support
        self.regressed = self.unsupported = 0

    # -- affinity of a candidate with the seed -------------------------------------------------
    def _seed_affinity(self, seed: int, frame: np.ndarray, box_ids: list[int]) -> np.ndarray:
        """Affinity of the seed with boxes already in a frame (template NCC or deep features)."""
        if self.config.variant == "template":
            t = self._templates[seed]
            return np.array([self.search.score_box(t, frame, self._boxes[b]) for b in box_ids])
        feats = np.stack([self._features[b] for b in box_ids])
        return affinity_rows(np.repeat(self._features[seed][None], len(box_ids), 0), feats)

    def next(self, prior: np.ndarray, seed: int, frame: np.ndarray,
             grey: np.ndarray | None = None) -> tuple[np.ndarray, float, np.ndarray | None]:
        """Paper's ``next(B, d_b, I)``: the best candidate around ``prior`` scored against the seed.

        ``grey`` is the frame in grey levels, if the caller has it. Returns
        ``(box, affinity, feature)``; ``box`` is empty when nothing scores
        above ``tau``.
        """
        self.steps += 1
        search_in = frame if grey is None else grey
        if self.config.variant == "template":
            boxes, scores = self.search.search(self._templates[seed], search_in, prior, top=1)
            if len(boxes) == 0 or scores[0] <= self.config.tau:
                return np.zeros(0), 0.0, None
            return boxes[0], float(scores[0]), None
        boxes, _ = self.search.search(self._templates[seed], search_in, prior, top=self.config.rerank)
        if len(boxes) == 0:
            return np.zeros(0), 0.0, None
        feats = self.embed(frame, boxes)
        aff = affinity_rows(np.repeat(self._features[seed][None], len(boxes), 0), feats)
        best = int(np.argmax(aff))
        if aff[best] <= self.config.tau:
            return np.zeros(0), 0.0, None
        return boxes[best], float(aff[best]), feats[best]

    # -- Algorithm 1 ---------------------------------------------------------------------------
    def run(self, detections: Detections, progress: Callable | None = None) -> SotResult:
        """Run Algorithm 1 window by window over all ``detections``, every one a seed."""
        cfg = self.config
        n = len(detections)
        self._boxes: list[np.ndarray] = [b for b in detections.boxes]
        self._frames: list[int] = detections.frames.tolist()
        self._features: list[np.ndarray | None] = (list(self.det_features) if self.det_features is not None
                                                   else [None] * n)
        self._templates: dict[int, np.ndarray] = {}
        links: list[tuple[int, int]] = []
        window = cfg.window or 2 * cfg.L + 1
        ranks = _score_ranks(detections.scores)
        per_frame = detections.by_frame()
        starts = range(1, self.n_frames + 1, window)
        for w0 in (progress(starts) if progress else starts):
            w1 = min(self.n_frames, w0 + window - 1)
            # every extension in this window starts from a seed in it: earlier seeds' templates are done with
            self._templates.clear()
            frames_cache: dict[int, tuple[np.ndarray, np.ndarray]] = {}

            def cached(f: int) -> tuple[np.ndarray, np.ndarray]:
                if f not in frames_cache:
                    import cv2

                    bgr = self.read_frame(f)
                    frames_cache[f] = (bgr, cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr)
                return frames_cache[f]

            def image(f: int) -> np.ndarray:
                return cached(f)[0]

            in_frame: dict[int, list[int]] = {f: list(per_frame.get(f, [])) for f in range(w0, w1 + 1)}
            if self.det_features is None and self.embed is not None:  # the detections' features, from these frames
                wanted = [f for f, idx in in_frame.items() if idx]
                for k, f in enumerate(wanted):
                    bgr = image(f)
                    if k + 1 < len(wanted):  # the next one decodes while this one's boxes are embedded
                        self._prefetch(wanted[k + 1])
                    for d, feature in zip(in_frame[f], self.embed(bgr, detections.boxes[in_frame[f]])):
                        self._features[d] = feature
            first_added = len(self._boxes)
            ends: dict[int, set[int]] = {}
            heap: list[_End] = []
            counter = 0
            for f in range(w0, w1 + 1):
                for d in in_frame[f]:
                    ends[d] = {1, -1}
                    for direction in (1, -1):
                        heapq.heappush(heap, _End(-ranks[d], counter, d, d, ranks[d], 1, direction))
                        counter += 1
            while heap:
                end = heapq.heappop(heap)
                if end.direction not in ends.get(end.box_id, set()):
                    continue  # this end already met another one
                ends[end.box_id].discard(end.direction)
                f = self._frames[end.box_id]
                g = f + end.direction
                if end.length >= cfg.L or not (w0 <= g <= w1):
                    continue
                seed = end.seed_id
                if seed not in self._templates:  # both variants propose with the template
                    self._templates[seed] = TemplateSearch.template(image(self._frames[seed]), self._boxes[seed])
                box = self._boxes[end.box_id]
                carried = self.motion.box_from_ref(g, self.motion.box_to_ref(f, box))  # the camera alone moved it
                others = in_frame[g]
                if others:
                    ious = iou_matrix(carried, np.stack([self._boxes[b] for b in others]))[0]
                    facing = [b for b, iou in zip(others, ious)
                              if iou > cfg.tau_I and -end.direction in ends.get(b, ())]
                    if facing:
                        aff = self._seed_affinity(seed, image(g), facing)
                        best = int(np.argmax(aff))
                        if aff[best] > cfg.tau_a:
                            meet = facing[best]
                            ends[meet].discard(-end.direction)
                            links.append((end.box_id, meet) if end.direction == 1 else (meet, end.box_id))
                            continue
                found, aff, feature = self.next(carried, seed, *cached(g))
                if len(found) == 0 or aff < cfg.tau_a:
                    continue

                def runs_into(candidate: np.ndarray) -> bool:
                    """A box already in the frame is the same object (IoU above ``tau_I``): someone is there."""
                    return bool(others) and iou_matrix(candidate, np.stack([self._boxes[b] for b in others]))[0].max() \
                        > cfg.tau_I

                if runs_into(found):
                    continue
                if self.support is not None:  # box regression on the SOT result: a detector box takes its place
                    weak = self.support(g, image(g))
                    ious = iou_matrix(found, weak)[0] if len(weak) else np.zeros(1)
                    if ious.max() < SUPPORT_IOU:
                        self.unsupported += 1
                        continue  # no detector box supports it: the extension ends here
                    found = weak[int(np.argmax(ious))]
                    self.regressed += 1
                    if runs_into(found):
                        continue
                    # deep: the regressed box's own feature (another end may meet it); template: embedded later
                    feature = self.embed(image(g), found[None])[0] if cfg.variant == "deep" else None
                new = len(self._boxes)
                self._boxes.append(found)
                self._frames.append(g)
                self._features.append(feature)
                in_frame[g].append(new)
                ends[new] = {end.direction}
                links.append((end.box_id, new) if end.direction == 1 else (new, end.box_id))
                heapq.heappush(heap, _End(-end.score * cfg.e, counter, new, seed, end.score * cfg.e,
                                          end.length + 1, end.direction))
                counter += 1
            if self.embed is not None:  # added boxes the variant did not embed (template): their frames are here
                todo: dict[int, list[int]] = {}
                for b in range(first_added, len(self._boxes)):
                    if self._features[b] is None:
                        todo.setdefault(self._frames[b], []).append(b)
                for f, idx in todo.items():
                    for b, feature in zip(idx, self.embed(image(f), np.stack([self._boxes[b] for b in idx]))):
                        self._features[b] = feature
        added = len(self._boxes) - n
        scores = np.concatenate([detections.scores, np.full(added, _added_score(detections.scores))])
        enlarged = Detections(np.asarray(self._frames), np.asarray(self._boxes).reshape(-1, 4), scores,
                              np.r_[detections.from_sot, np.ones(added, bool)])
        feats = det_feats = None
        if self.embed is not None:
            dim = next((len(f) for f in self._features if f is not None), 0)
            feats = np.stack(self._features[n:]) if added else np.zeros((0, dim), np.float32)
            det_feats = np.stack(self._features[:n]) if n else np.zeros((0, dim), np.float32)
        log.info("SOT (%s) added %d boxes to %d detections in %d steps", cfg.variant, added, n, self.steps)
        if self.support is not None:
            log.info("SOT: %d candidates regressed onto a detector box, %d ended unsupported", self.regressed,
                     self.unsupported)
        return SotResult(enlarged, np.asarray(links, dtype=np.int64).reshape(-1, 2), feats, self.steps, det_feats)


def _score_ranks(scores: np.ndarray) -> np.ndarray:
    """Scores mapped to (0, 1] by rank, so any score range (DPM's are negative too) orders the queue."""
    if len(scores) == 0:
        return np.zeros(0)
    order = np.argsort(np.argsort(scores, kind="stable"), kind="stable")
    return (order + 1) / len(scores)


def _added_score(scores: np.ndarray) -> float:
    """Score given to SOT boxes: the lowest detection score, so NMS prefers the detector's boxes."""
    return float(scores.min()) if len(scores) else 0.0
