"""The person detector's weak boxes as evidence for what SOT finds (``[detection] weak_boxes``).

The detector runs at a low threshold (:data:`WEAK_MIN_SCORE`); its boxes
below ``[detection] min_score`` never enter tracking, but they *support* a box
SOT found (Algorithm 1, the trajectory ends, gap refinement): a found box that
overlaps one at IoU :data:`SUPPORT_IOU` or more is replaced by it (the paper's
box regression on SOT results, Sec. 6.1). The values below were fitted once
(issue #25, docs/benchmarks.md) and are not settings. Boxes are ``x, y, w, h``
pixels, frames 1-based.
"""

from __future__ import annotations

import numpy as np

from sotmot.config import DetectionConfig
from sotmot.io.mask import Mask

#: The lowest score at which a detector box counts as support (a weak box).
WEAK_MIN_SCORE = 0.1
#: A found box and a weak box overlapping at least this much are the same object: the weak box takes its place.
SUPPORT_IOU = 0.5
#: The re-ID affinity with the trajectory a weak box needs to extend it (``[ends] min_affinity`` for an SOT box).
SUPPORTED_AFFINITY = 0.5
#: A weak box is a detection of its own: it stops an end only where it overlaps another trajectory's box more than
#: this (``[ends] stop_iou`` for an SOT box). A person walking behind another overlaps them at 0.3-0.7; at 0.7 the
#: weak-box ends found 416 boxes (80 % right) on the public sequences where 0.3 found 275 (72 %) (issue #25).
SUPPORTED_STOP_IOU = 0.7


class DetectorSupport:
    """The person detector as a verifier of SOT boxes: its boxes scoring at least :data:`WEAK_MIN_SCORE` in a
    frame, detected once per frame the search visits; none whose foot point ``mask`` ignores
    (``[preprocess] mask``)."""

    def __init__(self, detector, mask: Mask | None = None) -> None:
        self.detector = detector
        self.mask = mask
        self._boxes: dict[int, np.ndarray] = {}
        self.frames_detected = 0

    def _weak(self, boxes: np.ndarray, scores: np.ndarray) -> np.ndarray:
        """The ``(K, 4)`` boxes among ``boxes`` that count as support."""
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        keep = np.asarray(scores) >= WEAK_MIN_SCORE
        if self.mask is not None:
            keep &= ~self.mask.ignores(boxes)
        return boxes[keep]

    @classmethod
    def from_pass(cls, found: dict[int, tuple[np.ndarray, np.ndarray]], mask: Mask | None = None) -> DetectorSupport:
        """The boxes one detection pass already found (frame -> (boxes, scores), run at a threshold no higher
        than :data:`WEAK_MIN_SCORE`: :func:`sotmot.passes.detect_sequence`'s ``weak``); a frame the pass did not
        see has none (the detector is not run again)."""
        support = cls(None, mask)
        for frame, (boxes, scores) in found.items():
            support._boxes[frame] = support._weak(boxes, scores)
        return support

    @classmethod
    def from_config(cls, detection: DetectionConfig, detector=None, mask: Mask | None = None) -> DetectorSupport:
        """The detector ``detection`` names (a plan's ``weak_detector``: at :data:`WEAK_MIN_SCORE`, since the
        tracking threshold, ``[detection] min_score``, would hide the weak boxes); ``detector``, one already
        loaded, is used instead when it runs that low or lower."""
        if detector is not None and getattr(detector, "min_score", 1.0) <= WEAK_MIN_SCORE:
            return cls(detector, mask)
        from sotmot.detection import make_detector

        return cls(make_detector(detection), mask)

    def __call__(self, frame: int, image: np.ndarray) -> np.ndarray:
        """``(K, 4)`` ``x, y, w, h`` boxes of ``frame`` (its ``image``)."""
        if frame not in self._boxes:
            if self.detector is None:
                return np.zeros((0, 4))
            self._boxes[frame] = self._weak(*self.detector.detect(image))
            self.frames_detected += 1
        return self._boxes[frame]
