"""Post-processing of trajectories (paper Sec. 3.5): linear interpolation and smoothing.

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sotmot.config import PostprocessConfig
from sotmot.types import Detections, Tracklet, Tracks


def interpolate(frames: np.ndarray, boxes: np.ndarray, scores: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fill every gap by linear interpolation of the box coordinates.

    Parameters
    ----------
    frames
        ``(L,)`` strictly increasing 1-based frames.
    boxes
        ``(L, 4)`` ``x, y, w, h`` pixels.
    scores
        ``(L,)`` scores; a filled box gets the lower score of the two boxes
        around its gap.

    Returns
    -------
    frames, boxes, scores, filled
        Over every frame from the first to the last; ``filled`` marks the new boxes.
    """
    full = np.arange(frames[0], frames[-1] + 1, dtype=np.int64)
    out = np.stack([np.interp(full, frames, boxes[:, k]) for k in range(4)], axis=1)
    right = np.clip(np.searchsorted(frames, full, side="left"), 0, len(frames) - 1)
    left = np.clip(np.searchsorted(frames, full, side="right") - 1, 0, len(frames) - 1)
    filled = ~np.isin(full, frames)
    full_scores = np.where(filled, np.minimum(scores[left], scores[right]), scores[left])
    return full, out, full_scores, filled


def smooth(frames: np.ndarray, boxes: np.ndarray, window: int) -> np.ndarray:
    """Each box replaced by the mean of the trajectory's boxes within ``+- window`` frames.

    Works on trajectories with or without gaps: only boxes that exist are
    averaged. ``window = 0`` returns a copy.
    """
    if window <= 0 or len(frames) < 2:
        return boxes.copy()
    lo = np.searchsorted(frames, frames - window, side="left")
    hi = np.searchsorted(frames, frames + window, side="right")
    csum = np.vstack([np.zeros((1, 4)), np.cumsum(boxes, axis=0)])
    return (csum[hi] - csum[lo]) / (hi - lo)[:, None]


def output_ids(trajectories: Sequence[Tracklet], config: PostprocessConfig = PostprocessConfig()) -> list[int | None]:
    """The track id each trajectory gets in the output (None if it is dropped as too short).

    Trajectories are numbered 1, 2, ... by first frame, then by first
    detection index; one shorter than ``config.min_length`` boxes after
    interpolation gets no id.
    """
    order = sorted(range(len(trajectories)), key=lambda k: (trajectories[k].start, int(trajectories[k].det_index[0])))
    ids: list[int | None] = [None] * len(trajectories)
    next_id = 1
    for k in order:
        t = trajectories[k]
        length = t.end - t.start + 1 if config.interpolate else len(t)
        if length >= config.min_length:
            ids[k] = next_id
            next_id += 1
    return ids


def to_tracks(trajectories: Sequence[Tracklet], detections: Detections,
              config: PostprocessConfig = PostprocessConfig()) -> Tracks:
    """Post-process trajectories into the final :class:`Tracks`.

    Each trajectory is interpolated (if enabled) and smoothed, and written
    under the id :func:`output_ids` gives it (or dropped).
    """
    parts = []
    for t, track_id in zip(trajectories, output_ids(trajectories, config)):
        if track_id is None:
            continue
        frames, boxes, scores = t.frames, t.boxes, t.scores
        sot = detections.from_sot[t.det_index]
        filled = np.zeros(len(frames), dtype=bool)
        if config.interpolate and len(frames) > 1:
            frames, boxes, scores, filled = interpolate(frames, boxes, scores)
            full_sot = np.zeros(len(frames), dtype=bool)
            full_sot[~filled] = sot
            sot = full_sot
        boxes = smooth(frames, boxes, config.smooth_window)
        parts.append((frames, np.full(len(frames), track_id), boxes, scores, filled, sot))
    if not parts:
        return Tracks.empty()
    parts.sort(key=lambda p: int(p[1][0]))
    cols = [np.concatenate(c) for c in zip(*parts)]
    return Tracks(*cols)
