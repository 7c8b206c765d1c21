"""Box geometry: the one place where IoU, IoM, NMS, the pixel bounds of crops, conversions and the motion of
boxes across a gap live.

All boxes are ``x, y, w, h`` in pixels (top-left corner, width, height), the
MOTChallenge convention, as float arrays of shape ``(N, 4)``. Every other
module calls these functions instead of writing its own overlap code.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

Overlap = Literal["iou", "iom"]


def as_boxes(boxes: np.ndarray) -> np.ndarray:
    """Return ``boxes`` as a float64 ``(N, 4)`` array (a single box becomes ``(1, 4)``)."""
    arr = np.asarray(boxes, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr.reshape(1, -1)
    if arr.ndim != 2 or arr.shape[1] != 4:
        raise ValueError(f"boxes must have shape (N, 4), got {arr.shape}")
    return arr


def xywh_to_xyxy(boxes: np.ndarray) -> np.ndarray:
    """Convert ``(N, 4)`` ``x, y, w, h`` boxes to ``x1, y1, x2, y2`` corners."""
    b = as_boxes(boxes)
    return np.concatenate([b[:, :2], b[:, :2] + b[:, 2:]], axis=1)


def xyxy_to_xywh(boxes: np.ndarray) -> np.ndarray:
    """Convert ``(N, 4)`` ``x1, y1, x2, y2`` corners to ``x, y, w, h`` boxes."""
    b = as_boxes(boxes)
    return np.concatenate([b[:, :2], b[:, 2:] - b[:, :2]], axis=1)


def xywh_to_cxcywh(boxes: np.ndarray) -> np.ndarray:
    """Convert ``(N, 4)`` ``x, y, w, h`` boxes to ``cx, cy, w, h`` (centre and size)."""
    b = as_boxes(boxes)
    return np.concatenate([centers(b), b[:, 2:]], axis=1)


def cxcywh_to_xywh(boxes: np.ndarray) -> np.ndarray:
    """Convert ``(N, 4)`` ``cx, cy, w, h`` (centre and size) to ``x, y, w, h`` boxes."""
    b = as_boxes(boxes)
    return np.concatenate([b[:, :2] - 0.5 * b[:, 2:], b[:, 2:]], axis=1)


def centers(boxes: np.ndarray) -> np.ndarray:
    """Centres ``(N, 2)`` of ``(N, 4)`` ``x, y, w, h`` boxes, in pixels."""
    b = as_boxes(boxes)
    return b[:, :2] + 0.5 * b[:, 2:]


def heights_moved(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(N,)`` how far the centre of each ``(N, 4)`` ``x, y, w, h`` box ``a`` lies from that of box ``b``, in the
    two boxes' mean height: a person's displacement in their own size, whatever their distance from the camera."""
    a, b = as_boxes(a), as_boxes(b)
    return np.linalg.norm(centers(b) - centers(a), axis=1) / (0.5 * (a[:, 3] + b[:, 3]))


def clip_xyxy(corners: np.ndarray, width: float, height: float) -> np.ndarray:
    """``(N, 4)`` corners ``x1, y1, x2, y2`` (pixels, floats) clipped to a ``width`` x ``height`` image."""
    c = np.asarray(corners, dtype=np.float64).reshape(-1, 4)
    return np.clip(c, 0.0, [width, height, width, height])


def inside_share(boxes: np.ndarray, width: float, height: float) -> np.ndarray:
    """``(N,)`` share of each ``x, y, w, h`` box's area inside a ``width`` x ``height`` image (0: wholly outside)."""
    b = as_boxes(boxes) if len(boxes) else np.zeros((0, 4))
    ix = np.maximum(0.0, np.minimum(b[:, 0] + b[:, 2], width) - np.maximum(b[:, 0], 0.0))
    iy = np.maximum(0.0, np.minimum(b[:, 1] + b[:, 3], height) - np.maximum(b[:, 1], 0.0))
    return ix * iy / np.maximum(b[:, 2] * b[:, 3], 1e-9)


def pixel_bounds(boxes: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Integer pixel bounds ``x1, y1, x2, y2`` (``(N,)`` each, ``x2``/``y2`` exclusive) of ``(N, 4)``
    ``x, y, w, h`` boxes clipped to a ``width`` x ``height`` image: the one rule every crop uses.

    The box is widened to whole pixels (floor of the corner, ceiling of the far
    edge) and clipped to the image; a box entirely outside becomes the nearest
    one-pixel strip of the border, so every crop has at least one pixel.
    """
    b = as_boxes(boxes) if len(boxes) else np.zeros((0, 4))
    x1 = np.clip(np.floor(b[:, 0]), 0, width - 1).astype(np.int64)
    y1 = np.clip(np.floor(b[:, 1]), 0, height - 1).astype(np.int64)
    x2 = np.clip(np.ceil(b[:, 0] + b[:, 2]), x1 + 1, width).astype(np.int64)
    y2 = np.clip(np.ceil(b[:, 1] + b[:, 3]), y1 + 1, height).astype(np.int64)
    return x1, y1, x2, y2


def _intersection(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection areas of broadcastable ``(..., 4)`` box arrays."""
    ix = np.minimum(a[..., 0] + a[..., 2], b[..., 0] + b[..., 2]) - np.maximum(a[..., 0], b[..., 0])
    iy = np.minimum(a[..., 1] + a[..., 3], b[..., 1] + b[..., 3]) - np.maximum(a[..., 1], b[..., 1])
    return np.clip(ix, 0.0, None) * np.clip(iy, 0.0, None)


def _overlap(a: np.ndarray, b: np.ndarray, kind: Overlap, aligned: bool) -> np.ndarray:
    a = as_boxes(a)
    b = as_boxes(b)
    if not aligned:
        a = a[:, None, :]
        b = b[None, :, :]
    elif a.shape != b.shape:
        raise ValueError(f"aligned overlap needs equal shapes, got {a.shape} and {b.shape}")
    inter = _intersection(a, b)
    area_a = a[..., 2] * a[..., 3]
    area_b = b[..., 2] * b[..., 3]
    if kind == "iou":
        denom = area_a + area_b - inter
    elif kind == "iom":
        denom = np.minimum(area_a, area_b)
    else:
        raise ValueError(f"unknown overlap kind {kind!r}; valid: 'iou', 'iom'")
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(denom > 0, inter / np.where(denom > 0, denom, 1.0), 0.0)
    return out


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection over union of every box in ``a`` (N, 4) with every box in ``b`` (M, 4).

    Returns an ``(N, M)`` array in [0, 1]; degenerate (zero-area) pairs give 0.
    """
    return _overlap(a, b, "iou", aligned=False)


def iom_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection over the *smaller* area (IoM, paper Sec. 6.1), ``(N, M)`` in [0, 1]."""
    return _overlap(a, b, "iom", aligned=False)


def intersection_aligned(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection area (pixels squared) of ``a[i]`` with ``b[i]`` for two ``(N, 4)`` arrays; returns ``(N,)``."""
    a, b = as_boxes(a), as_boxes(b)
    if a.shape != b.shape:
        raise ValueError(f"aligned overlap needs equal shapes, got {a.shape} and {b.shape}")
    return _intersection(a, b)


def iou_aligned(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of ``a[i]`` with ``b[i]`` for two ``(N, 4)`` arrays; returns ``(N,)``."""
    return _overlap(a, b, "iou", aligned=True)


#: Above this many boxes :func:`nms` computes overlaps row by row instead of as one matrix.
NMS_MATRIX_MAX = 1000


def nms(boxes: np.ndarray, scores: np.ndarray, threshold: float, overlap: Overlap = "iou") -> np.ndarray:
    """Greedy non-maximum suppression.

    Parameters
    ----------
    boxes
        ``(N, 4)`` ``x, y, w, h`` boxes in pixels.
    scores
        ``(N,)`` detection scores; higher is better. Any real range (DPM scores
        are not probabilities) is fine.
    threshold
        A box is suppressed when its overlap with a kept, higher-scoring box is
        strictly greater than this.
    overlap
        ``"iou"`` (intersection over union) or ``"iom"`` (intersection over the
        smaller box, which also removes a small box inside a large one).

    Returns
    -------
    numpy.ndarray
        Indices of the kept boxes, by descending score. Ties in score are broken
        by the lower index, so the result does not depend on sort stability.
    """
    b = as_boxes(boxes) if len(boxes) else np.zeros((0, 4))
    s = np.asarray(scores, dtype=np.float64)
    if len(s) != len(b):
        raise ValueError(f"{len(b)} boxes but {len(s)} scores")
    order = np.lexsort((np.arange(len(s)), -s))
    if len(order) == 0:
        return order.astype(np.intp)
    ranked = b[order]
    # the whole overlap matrix for a usual frame; for a frame with thousands of boxes one row per kept
    # box, so memory stays O(N) (12,000 boxes took 7 GB as a matrix)
    ov = _overlap(ranked, ranked, overlap, aligned=False) if len(order) <= NMS_MATRIX_MAX else None
    suppressed = np.zeros(len(order), dtype=bool)
    keep = []
    for i in range(len(order)):
        if suppressed[i]:
            continue
        keep.append(order[i])
        row = ov[i, i + 1:] if ov is not None else _overlap(ranked[i:i + 1], ranked[i + 1:], overlap, False)[0]
        suppressed[i + 1:] |= row > threshold
    return np.asarray(keep, dtype=np.intp)


#: The velocity at a trajectory's end is measured over at most this many of its last (or first) boxes.
VELOCITY_BOXES = 10


def end_velocity(frames: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Centre velocity (pixels per frame) from the first to the last of ``boxes`` at ``frames``; 0 for one box."""
    if len(frames) < 2:
        return np.zeros(2)
    c = centers(np.asarray(boxes).reshape(-1, 4))
    return (c[-1] - c[0]) / float(frames[-1] - frames[0])


def motion_agreement(end_box: np.ndarray, end_velocity: np.ndarray, start_box: np.ndarray,
                     start_velocity: np.ndarray, gap: np.ndarray) -> np.ndarray:
    """How well a gap of ``gap`` frames fits the motion around it, in [0, 1], vectorised over ``(K,)`` gaps.

    ``end_box`` ``(K, 4)`` is the last box before the gap, moving at ``end_velocity`` ``(K, 2)`` pixels per
    frame; ``start_box`` the first box after it, moving at ``start_velocity``. The first is carried forward
    ``gap`` frames, the second backward, and ``e`` is the mean distance of each prediction from the other box;
    its scale ``s = w + v gap`` is the boxes' mean width plus the path walked at their mean speed ``v``.
    Returns ``exp(-e / s)`` times the ratio of the two heights (smaller over larger).
    """
    gap = np.asarray(gap, dtype=np.float64).reshape(-1, 1)
    end_box, start_box = np.asarray(end_box).reshape(-1, 4), np.asarray(start_box).reshape(-1, 4)
    end_velocity, start_velocity = np.asarray(end_velocity).reshape(-1, 2), np.asarray(start_velocity).reshape(-1, 2)
    c_end, c_start = centers(end_box), centers(start_box)
    error = 0.5 * (np.linalg.norm(c_end + end_velocity * gap - c_start, axis=1)
                   + np.linalg.norm(c_start - start_velocity * gap - c_end, axis=1))
    speed = 0.5 * (np.linalg.norm(end_velocity, axis=1) + np.linalg.norm(start_velocity, axis=1))
    scale = 0.5 * (end_box[:, 2] + start_box[:, 2]) + speed * gap[:, 0]
    heights = np.stack([end_box[:, 3], start_box[:, 3]], axis=1)
    return np.exp(-error / scale) * heights.min(axis=1) / heights.max(axis=1)
