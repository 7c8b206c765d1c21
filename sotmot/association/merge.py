"""Joining tracklets into trajectories, and the order in which links run (paper Sec. 3.4).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from sotmot.types import Tracklet


def link_order_key(t: Tracklet) -> tuple[int, int, int]:
    """The orientation of links: the tracklet that starts first (ties: ends first, then smaller id) leads."""
    return (t.start, t.end, t.id)


def merge(a: Tracklet, b: Tracklet, new_id: int) -> Tracklet:
    """One trajectory from two: the union of their frames, the higher-score box in shared frames.

    Ties in score keep ``a``'s box. The mean feature is the mean over both
    trajectories' detections.
    """
    n = a.n_features + b.n_features
    feature = (a.feature.astype(np.float64) * a.n_features + b.feature.astype(np.float64) * b.n_features) / n
    if a.end < b.start or b.end < a.start:  # disjoint spans: one after the other
        early, late = (a, b) if a.end < b.start else (b, a)
        return Tracklet(id=new_id, frames=np.concatenate([early.frames, late.frames]),
                        boxes=np.concatenate([early.boxes, late.boxes]),
                        scores=np.concatenate([early.scores, late.scores]),
                        det_index=np.concatenate([early.det_index, late.det_index]), feature=feature, n_features=n)
    frames = np.concatenate([a.frames, b.frames])
    scores = np.concatenate([a.scores, b.scores])
    origin = np.r_[np.zeros(len(a), np.int64), np.ones(len(b), np.int64)]
    # Sort by frame, then best score first, then a before b; keep the first row of each frame.
    order = np.lexsort((origin, -scores, frames))
    frames = frames[order]
    first = np.r_[True, frames[1:] != frames[:-1]]
    take = order[first]
    return Tracklet(id=new_id, frames=np.concatenate([a.frames, b.frames])[take],
                    boxes=np.concatenate([a.boxes, b.boxes])[take], scores=np.concatenate([a.scores, b.scores])[take],
                    det_index=np.concatenate([a.det_index, b.det_index])[take], feature=feature, n_features=n)


def merge_group(tracklets: Sequence[Tracklet], new_id: int) -> Tracklet:
    """One trajectory from several tracklets, merged pairwise with :func:`merge` in the given order."""
    if not tracklets:
        raise ValueError("cannot merge an empty group")
    out = dataclasses.replace(tracklets[0], id=new_id)
    for t in tracklets[1:]:
        out = merge(out, t, new_id)
    return out
