"""SOT after association: extend confirmed trajectories past their first and last detections.

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
  added) at IoU above ``extend_stop_iou``: someone else is there;
* less than half the candidate lies inside the image (the person leaves);
* it has grown ``extend_seconds``, or reached the sequence's first or last frame.

Added boxes are flagged ``from_sot`` in the output. Boxes are ``x, y, w, h``
pixels, frames 1-based.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

import numpy as np

from sotmot.appearance import Embedder, affinity_rows
from sotmot.boxes import centers, iou_matrix
from sotmot.config import SotConfig
from sotmot.sot import TemplateSearch
from sotmot.types import Tracks

log = logging.getLogger(__name__)

#: How many of a trajectory's last boxes (frames) give its velocity.
VELOCITY_FRAMES = 5


def inside_fraction(box: np.ndarray, width: int, height: int) -> float:
    """Share of the ``x, y, w, h`` box's area inside a ``width`` x ``height`` image."""
    x, y, w, h = box
    ix = max(0.0, min(x + w, width) - max(x, 0.0))
    iy = max(0.0, min(y + h, height) - max(y, 0.0))
    return ix * iy / max(w * h, 1e-9)


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


def extend_ends(tracks: Tracks, features: dict[int, np.ndarray], read_frame: Callable[[int], np.ndarray],
                n_frames: int, frame_rate: float, embedder: Embedder, config: SotConfig,
                progress: Callable | None = None) -> Tracks:
    """``tracks`` with boxes added before the first and after the last box of each track.

    Parameters
    ----------
    tracks
        Confirmed output tracks.
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
        ``tau``, ``rerank``, ``search_radius``, ``scales`` and the ``extend_*`` fields.
    """
    import cv2

    steps = max(1, int(round(config.extend_seconds * frame_rate)))
    search = TemplateSearch(config)
    occupied: dict[int, list[np.ndarray]] = {}
    owner: dict[int, list[int]] = {}
    for f, i, b in zip(tracks.frames.tolist(), tracks.ids.tolist(), tracks.boxes):
        occupied.setdefault(f, []).append(b)
        owner.setdefault(f, []).append(i)
    added: list[tuple[int, int, np.ndarray]] = []
    ids = np.unique(tracks.ids).tolist()
    greys: dict[int, np.ndarray] = {}

    def grey(f: int) -> np.ndarray:
        if f not in greys:
            if len(greys) > 64:
                greys.clear()
            bgr = read_frame(f)
            greys[f] = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr
        return greys[f]

    for track_id in (progress(ids) if progress else ids):
        rows = np.flatnonzero(tracks.ids == track_id)
        rows = rows[np.argsort(tracks.frames[rows])]
        frames, boxes = tracks.frames[rows], tracks.boxes[rows]
        identity = features.get(track_id)
        if identity is None:
            continue
        for direction in (1, -1):
            start = int(frames[-1] if direction == 1 else frames[0])
            box = boxes[-1 if direction == 1 else 0]
            template = TemplateSearch.template(read_frame(start), box)
            velocity = end_velocity(frames, boxes, direction)
            for k in range(1, steps + 1):
                g = start + direction * k
                if not 1 <= g <= n_frames:
                    break
                prior = box + np.r_[velocity, 0.0, 0.0]
                image = read_frame(g)
                candidates, ncc = search.search(template, grey(g), prior, top=config.rerank)
                keep = ncc > config.tau
                if not keep.any():
                    break
                candidates, ncc = candidates[keep], ncc[keep]
                aff = affinity_rows(np.repeat(identity[None], len(candidates), 0), embedder.embed(image, candidates))
                best = int(np.argmax(aff))
                found = candidates[best]
                if aff[best] < config.extend_min_affinity:
                    break
                if inside_fraction(found, image.shape[1], image.shape[0]) < 0.5:
                    break
                others = [b for b, o in zip(occupied.get(g, []), owner.get(g, [])) if o != track_id]
                if others and iou_matrix(found, np.stack(others))[0].max() > config.extend_stop_iou:
                    break
                occupied.setdefault(g, []).append(found)
                owner.setdefault(g, []).append(track_id)
                added.append((g, track_id, found))
                box = found
    log.info("end extension added %d boxes to %d tracks", len(added), len(ids))
    if not added:
        return tracks
    n = len(added)
    extra = Tracks(np.array([a[0] for a in added]), np.array([a[1] for a in added]),
                   np.stack([a[2] for a in added]), np.full(n, float(tracks.scores.min())),
                   np.zeros(n, bool), np.ones(n, bool), np.full(n, np.nan))
    both = [np.concatenate([getattr(tracks, c), getattr(extra, c)])
            for c in ("frames", "ids", "boxes", "scores", "interpolated", "from_sot", "confidence")]
    order = np.lexsort((both[0], both[1]))
    return Tracks(*both).subset(order)
