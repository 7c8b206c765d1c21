"""Builders for hand-made tracklets."""

from __future__ import annotations

import numpy as np

from sotmot.types import Tracklet


def tk(tid: int, frames, boxes, feature=(1.0, 0.0), scores=None, det_start: int | None = None) -> Tracklet:
    """A tracklet with given frames and boxes (one box repeated if a single box is given)."""
    frames = np.asarray(frames)
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    if len(boxes) == 1 and len(frames) > 1:
        boxes = np.repeat(boxes, len(frames), axis=0)
    scores = np.ones(len(frames)) if scores is None else np.asarray(scores, dtype=float)
    start = 1000 * tid if det_start is None else det_start
    return Tracklet(id=tid, frames=frames, boxes=boxes, scores=scores,
                    det_index=np.arange(start, start + len(frames)), feature=np.asarray(feature), n_features=len(frames))
