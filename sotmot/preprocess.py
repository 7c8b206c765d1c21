"""Cleaning the detections before tracking: the mask's ignored pixels, a score threshold, then NMS per frame
(paper Sec. 6.1).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from sotmot.boxes import nms
from sotmot.confidence.maps import scores_are_probabilities
from sotmot.config import PreprocessConfig
from sotmot.io.mask import Mask
from sotmot.types import Detections


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


def preprocess(detections: Detections, config: PreprocessConfig, mask: Mask | None = None) -> Detections:
    """The boxes outside ``mask``'s ignored pixels (``[preprocess] mask`` as a plan reads it), score threshold,
    then per-frame NMS (paper Sec. 6.1). Keeps the canonical order."""
    return detections.subset(preprocess_indices(detections, config, mask))


def preprocess_indices(detections: Detections, config: PreprocessConfig, mask: Mask | None = None) -> np.ndarray:
    """Indices (ascending) into ``detections`` of the boxes :func:`preprocess` keeps."""
    keep = np.ones(len(detections), bool)
    if config.score_threshold is not None:
        keep &= detections.scores >= config.score_threshold
    if mask is not None:
        keep &= ~mask.ignores(detections.boxes)
    kept = np.flatnonzero(keep)
    return kept[nms_per_frame(detections.subset(kept), resolve_nms(config, detections), config.nms_threshold)]


def frame_preprocessor(config: PreprocessConfig, mask: Mask | None = None
                       ) -> Callable[[int, tuple[np.ndarray, np.ndarray]], np.ndarray]:
    """For a pass that finds the boxes frame by frame: ``(frame, (boxes, scores))`` -> the boxes of that frame that
    :func:`preprocess` keeps, in canonical order; the same as it keeps of the whole sequence when ``nms = "auto"``
    decides on one frame's scores as on all of them (:func:`resolve_nms`; a detector's probabilities do)."""
    def kept(frame: int, found: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        boxes, scores = found
        one = Detections(np.full(len(scores), frame, np.int64), boxes, scores)
        one = one.subset(one.canonical_order())
        return one.boxes[preprocess_indices(one, config, mask)]
    return kept

