"""Tracklet generation: frame-by-frame Hungarian matching inside 1-second batches (paper Sec. 3.4).

Inside a batch, for every frame a bipartite graph joins the open tracklets
and the frame's detections; the weight of an edge is the appearance affinity
between the detection and the mean feature of the tracklet's last ``tail``
detections. The assignment that maximises the total affinity is found with
the Hungarian algorithm; matches below the affinity gate (or the IoU gate) are
not linked. A tracklet that gets no detection in a frame is closed, so a
tracklet covers consecutive frames. Unmatched detections start new
tracklets. At the end of a batch every tracklet is closed; tracklets with
``<= l_min`` detector boxes (boxes added by the SOT step do not count) are
dropped. Long-term association joins the rest. With ``yield_weaker`` (off by
default), of two open tracklets whose last boxes overlap, the one whose last
detections scored lower yields a detection both may take.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

import numpy as np
from scipy.optimize import linear_sum_assignment

from sotmot.appearance import affinity, motion_only
from sotmot.boxes import iou_matrix
from sotmot.config import TrackletConfig
from sotmot.errors import ConfigError
from sotmot.types import Detections, Tracklet

_FORBIDDEN = 1e6
#: IoU of two open tracklets' last boxes from which ``[tracklets] yield_weaker`` judges them as overlapping.
YIELD_OVERLAP = 0.3
#: How many of a tracklet's last detections score it for ``[tracklets] yield_weaker``.
YIELD_TAIL = 3


def batch_length(frame_rate: float, batch_seconds: float) -> int:
    """Frames per batch: ``round(batch_seconds * frame_rate)``, at least 1."""
    return max(1, int(round(batch_seconds * frame_rate)))


def checked_batch_length(frame_rate: float, config: TrackletConfig, step: int = 1) -> int:
    """:func:`batch_length` of ``config`` at ``frame_rate`` (the rate tracked: the sequence's divided by
    ``step``), checked before any work (:func:`sotmot.plan.resolve`) and again by :func:`build_tracklets`.

    Raises
    ------
    ConfigError
        Batches so short that ``l_min`` drops every tracklet (a frame rate too low for ``batch_seconds``).
    """
    batch_frames = batch_length(frame_rate, config.batch_seconds)
    if batch_frames <= config.l_min:
        raise ConfigError(f"[tracklets] batch_seconds = {config.batch_seconds:g} at {frame_rate:g} frames/s gives "
                          f"batches of {batch_frames} frame(s), so every tracklet has at most {batch_frames} box(es) "
                          f"and l_min = {config.l_min} drops them all; use batch_seconds >= "
                          f"{(config.l_min + 1) / frame_rate:.3g} "
                          f"(or check frameRate in seqinfo.ini"
                          + (f", or a smaller [input] step than {step})" if step > 1 else ")"))
    return batch_frames


def build_tracklets(detections: Detections, features: np.ndarray, frame_rate: float,
                    config: TrackletConfig = TrackletConfig(),
                    progress: Callable[[Iterable[int]], Iterable[int]] | None = None) -> list[Tracklet]:
    """Build tracklets from detections and their appearance features.

    Parameters
    ----------
    detections
        Boxes of the whole sequence (``x, y, w, h`` pixels, 1-based frames).
    features
        ``(N, D)`` appearance features, row ``i`` for detection ``i``; ``D = 0``
        (the motion-only mode, ``[appearance] backend = "none"``): matches are
        weighted by IoU with the tracklet's last box, ``min_affinity`` unused.
    frame_rate
        Frames per second of the sequence (``frameRate`` of seqinfo.ini).
    config
        Gates, tail length, batch length and ``l_min``.
    progress
        Optional wrapper over the iterable of frames (e.g. a progress bar).

    Returns
    -------
    list of Tracklet
        Ordered by first frame, then by the index of their first detection;
        ids run from 1 in that order.
    """
    features = np.asarray(features, dtype=np.float32)
    if len(features) != len(detections):
        raise ValueError(f"{len(detections)} detections but {len(features)} features")
    no_reid = motion_only(features)
    per_frame = detections.by_frame()
    frames = sorted(per_frame)
    batch_frames = checked_batch_length(frame_rate, config)
    finished: list[list[int]] = []
    active: list[list[int]] = []
    current_batch = None
    for frame in (progress(frames) if progress else frames):
        batch = (frame - 1) // batch_frames
        if batch != current_batch or (active and detections.frames[active[0][-1]] != frame - 1):
            # New batch, or the previous frame had no detections: every open tracklet closes.
            finished.extend(active)
            active = []
            current_batch = batch
        idx = per_frame[frame]
        matched_tracks: set[int] = set()
        matched_dets: set[int] = set()
        if active:
            last_boxes = detections.boxes[[t[-1] for t in active]]
            last = last_boxes
            if config.predict:  # each tracklet's last box moved on one frame at its velocity over its tail
                last = last + np.array([_step(detections, t[-config.tail:]) for t in active])
            ious = iou_matrix(last, detections.boxes[idx])
            if no_reid:  # no re-ID: the IoU with the tracklet's last box is the affinity, its gate the only one
                aff, allowed = ious, ious >= config.min_iou
            else:
                tails = np.stack([features[t[-config.tail:]].mean(axis=0) for t in active])
                aff = affinity(tails, features[idx])
                allowed = (aff >= config.min_affinity) & (ious >= config.min_iou)
            cost = np.where(allowed, -aff, _FORBIDDEN)
            if config.yield_weaker:
                cost += config.yield_weaker * _weaker(detections, active, last_boxes, allowed)
            rows, cols = linear_sum_assignment(cost)
            for r, c in zip(rows, cols):
                if allowed[r, c]:
                    active[r].append(int(idx[c]))
                    matched_tracks.add(r)
                    matched_dets.add(c)
        finished.extend(t for r, t in enumerate(active) if r not in matched_tracks)
        active = [t for r, t in enumerate(active) if r in matched_tracks]
        active.extend([int(idx[c])] for c in range(len(idx)) if c not in matched_dets)
    finished.extend(active)
    # l_min counts detector boxes: a lone false detection that SOT extended is still a lone detection
    real = ~detections.from_sot
    kept = [t for t in finished if int(real[t].sum()) > config.l_min]
    kept.sort(key=lambda t: (detections.frames[t[0]], t[0]))
    return [make_tracklet(k, np.asarray(t), detections, features) for k, t in enumerate(kept, 1)]


def _weaker(detections: Detections, active: list[list[int]], last_boxes: np.ndarray, allowed: np.ndarray
            ) -> np.ndarray:
    """``(tracklets, detections)``: 1 where a tracklet must yield the detection (``[tracklets] yield_weaker``):
    another open tracklet whose last box (``last_boxes``, as detected) overlaps its own at IoU >=
    :data:`YIELD_OVERLAP`, and whose last :data:`YIELD_TAIL` detections scored higher on average, may take it
    too; 0 elsewhere."""
    out = np.zeros(allowed.shape)
    if len(active) < 2:
        return out
    overlap = iou_matrix(last_boxes, last_boxes)
    strength = np.array([detections.scores[t[-YIELD_TAIL:]].mean() for t in active])
    stronger = (overlap >= YIELD_OVERLAP) & (strength[None, :] > strength[:, None])  # [r, s]: s overlaps r, scores more
    for r in np.flatnonzero(stronger.any(axis=1)):
        out[r] = allowed[r] & allowed[stronger[r]].any(axis=0)
    return out


def _step(detections: Detections, rows: list[int]) -> np.ndarray:
    """The per-frame change ``(dx, dy, 0, 0)`` of boxes ``rows`` (consecutive frames), first to last; 0 for one."""
    if len(rows) < 2:
        return np.zeros(4)
    first, last = detections.boxes[rows[0]], detections.boxes[rows[-1]]
    return np.r_[(last[:2] - first[:2]) / (len(rows) - 1), 0.0, 0.0]


def make_tracklet(tracklet_id: int, det_index: np.ndarray, detections: Detections,
                  features: np.ndarray) -> Tracklet:
    """A :class:`Tracklet` over the detections ``det_index`` (one per frame, in frame order)."""
    return Tracklet(id=tracklet_id, frames=detections.frames[det_index], boxes=detections.boxes[det_index],
                    scores=detections.scores[det_index], det_index=det_index,
                    feature=features[det_index].mean(axis=0), n_features=len(det_index))
