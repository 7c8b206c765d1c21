"""The affinity of a candidate link: appearance when the tracklets carry features, motion when they do not.

Every solver ranks and gates links by :func:`link_affinities`, so the greedy
merge, the flow network, the lifted objective, ``explain`` and ``graph`` see
the same number. Tracklets from a re-ID model carry a mean feature and the
affinity is :func:`sotmot.appearance.affinity` of the two means (unchanged).
Tracklets of the motion-only mode (``[appearance] backend = "none"``) carry
zero-width features; their affinity is :func:`motion_affinities`, in the same
[0, 1] range, gated by the same ``[association] min_affinity`` (and 0 for a
join over more than 1 s at more than ``[association] motion_gap_speed``).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sotmot.appearance import motion_only, pair_affinities
from sotmot.boxes import VELOCITY_BOXES, end_velocity, heights_moved, iou_aligned, motion_agreement
from sotmot.config import AssociationConfig
from sotmot.types import Tracklet

#: A join of the motion-only mode across a gap longer than this (seconds) must also keep to
#: ``[association] motion_gap_speed``.
WALK_GAP_SECONDS = 1.0


def link_affinities(tracklets: Sequence[Tracklet], pairs: np.ndarray, units: np.ndarray,
                    config: AssociationConfig | None = None) -> np.ndarray:
    """Affinity in [0, 1] of each pair ``(i, j)`` of ``pairs`` (``(K, 2)`` indices into ``tracklets``).

    ``units`` are the tracklets' mean features through :func:`sotmot.appearance.unit`, ``(N, D)``: with
    ``D > 0`` the appearance affinity of rows ``i`` and ``j``; with ``D == 0`` (no re-ID) the motion
    affinity of the two tracklets under ``config`` (the association as a run resolved it, its
    ``frame_rate`` set). Returns ``(K,)`` float64.
    """
    if motion_only(units):
        return motion_affinities(tracklets, pairs, config)
    return pair_affinities(units, pairs)


def _end_velocity(t: Tracklet, last: bool) -> np.ndarray:
    """Centre velocity (pixels per frame) over the last (or first) :data:`VELOCITY_BOXES` boxes; 0 for one box."""
    sl = slice(-VELOCITY_BOXES, None) if last else slice(0, VELOCITY_BOXES)
    return end_velocity(t.frames[sl], t.boxes[sl])


def motion_affinities(tracklets: Sequence[Tracklet], pairs: np.ndarray,
                      config: AssociationConfig | None = None) -> np.ndarray:
    """How well two trajectories' motion agrees, in [0, 1], for each pair of ``pairs`` (the motion-only affinity).

    For a pair one after the other (the earlier ends at ``f1``, the later
    starts at ``f2 = f1 + g``): the earlier one's last centre is carried
    forward ``g`` frames at its end velocity, the later one's first centre
    backward at its start velocity (each over at most :data:`VELOCITY_BOXES`
    boxes), and ``e`` is the mean distance between each prediction and the box
    it should meet. Its scale ``s = w + v g`` is the boxes' mean width ``w``
    plus the distance the two walk in the gap at their mean speed ``v``: a
    prediction is as uncertain as the path it extrapolates. The affinity is
    ``exp(-e / s) * min(h1, h2) / max(h1, h2)`` (heights: the same person keeps
    their size across a gap); the gate ``min_affinity = 0.45`` passes errors
    up to about 0.8 ``s``. For a pair whose spans meet, the affinity is the
    IoU of the later one's first box with the earlier one's box in that frame
    (the IoU rule judges the rest); where the earlier one has no box there
    because the later one lies wholly inside one of its gaps, the later one
    would fill that gap, and the affinity is the lower agreement of the two
    joins it makes, as for a pair one after the other (a merged trajectory
    whose gap another tracklet walks through could otherwise never take it
    in, and both would be written there: on the label-only validation
    sequences most false boxes were such pairs). A later one that starts in a
    gap and runs past it scores 0. So does a pair one after the other across
    a gap of more than :data:`WALK_GAP_SECONDS` whose centres lie more than
    ``config.motion_gap_speed`` of their mean height per second of the gap
    apart (with ``config`` resolved for a frame rate, :meth:`AssociationConfig.at`):
    without appearance, a walk extrapolated over seconds meets someone else,
    and the joins that stay right are mostly of people who stood still.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    out = np.zeros(len(pairs))
    if not len(pairs):
        return out
    nodes, local = np.unique(pairs, return_inverse=True)
    local = local.reshape(-1, 2)
    chosen = [tracklets[n] for n in nodes.tolist()]
    starts = np.array([t.start for t in chosen])
    ends = np.array([t.end for t in chosen])
    first = np.array([t.boxes[0] for t in chosen]).reshape(-1, 4)
    last = np.array([t.boxes[-1] for t in chosen]).reshape(-1, 4)
    v_first = np.array([_end_velocity(t, last=False) for t in chosen]).reshape(-1, 2)
    v_last = np.array([_end_velocity(t, last=True) for t in chosen]).reshape(-1, 2)
    a_leads = (starts[local[:, 0]] < starts[local[:, 1]]) | (
        (starts[local[:, 0]] == starts[local[:, 1]]) & (ends[local[:, 0]] <= ends[local[:, 1]]))
    early = np.where(a_leads, local[:, 0], local[:, 1])
    late = np.where(a_leads, local[:, 1], local[:, 0])
    apart = ends[early] < starts[late]
    e_, l_ = early[apart], late[apart]
    out[apart] = motion_agreement(last[e_], v_last[e_], first[l_], v_first[l_], starts[l_] - ends[e_])
    if config is not None and config.motion_gap_speed is not None and config.frame_rate:
        seconds = (starts[l_] - ends[e_]) / config.frame_rate
        moved = heights_moved(last[e_], first[l_])
        out[apart] = np.where((seconds > WALK_GAP_SECONDS) & (moved > config.motion_gap_speed * seconds), 0.0,
                              out[apart])
    for k in np.flatnonzero(~apart).tolist():
        a, b = chosen[early[k]], chosen[late[k]]
        row = int(np.searchsorted(a.frames, b.start))  # b starts at or before a's end: row < len(a)
        if a.frames[row] == b.start:
            out[k] = float(iou_aligned(a.boxes[row:row + 1], b.boxes[:1])[0])
        elif b.end < a.frames[row]:  # b lies wholly inside a's gap between rows row - 1 and row
            out[k] = float(np.min(_gap_fill_agreement(a, row, b, v_first[late[k]], v_last[late[k]])))
    return out


def _gap_fill_agreement(a: Tracklet, row: int, b: Tracklet, b_start_velocity: np.ndarray,
                        b_end_velocity: np.ndarray) -> np.ndarray:
    """The motion agreement of the two joins ``b`` makes when it fills ``a``'s gap before row ``row``: ``a``'s
    boxes up to the gap into ``b``'s start, ``b``'s end into ``a``'s boxes after it (``b``'s velocities at its two
    ends as :func:`_end_velocity` gives them)."""
    before = slice(max(0, row - VELOCITY_BOXES), row)
    after = slice(row, row + VELOCITY_BOXES)
    return motion_agreement(
        np.stack([a.boxes[row - 1], b.boxes[-1]]),
        np.stack([end_velocity(a.frames[before], a.boxes[before]), b_end_velocity]),
        np.stack([b.boxes[0], a.boxes[row]]),
        np.stack([b_start_velocity, end_velocity(a.frames[after], a.boxes[after])]),
        np.array([b.start - a.frames[row - 1], a.frames[row] - b.end]))
