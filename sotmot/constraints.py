"""The long-term association constraint A(t1, t2) and trajectory merging (paper Sec. 3.4).

This module is the one place where the rules live. Every solver (the greedy
merge, the flow solvers) and every inspection tool calls :func:`check_pair`
and :func:`merge`, so all of them obey, and explain, the very same rules:

1. **IoU**: on every temporally overlapping segment (a maximal run of
   consecutive frames where both trajectories have a box) the mean IoU of
   their boxes must be ``> tau_iou`` (0.5). The merged trajectory keeps the
   higher-score box in each shared frame.
2. **Velocity**: in every gap of the merged trajectory, the speed of the box
   centre under linear motion, ``||c2 - c1|| / (f2 - f1)`` pixels per frame,
   must be ``<= w``, ``2/3 w`` or ``1/3 w`` for a frame difference of 1,
   2..5 or more than 5, with ``w`` the mean width of the two boxes at the
   gap's ends.
3. **Gap**: every gap (frame difference between consecutive boxes) is
   ``<= l_max`` (60).
4. **Affinity**: the appearance affinity of the two mean features is
   ``>= min_affinity`` (a gate below which a pair is never merged).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from sotmot.appearance import affinity as feature_affinity
from sotmot.boxes import centers, iou_aligned
from sotmot.config import AssociationConfig
from sotmot.types import Tracklet

Constraint = Literal["iou", "velocity", "gap", "affinity"]

#: The order in which a failed constraint is reported when several fail.
CONSTRAINTS: tuple[Constraint, ...] = ("iou", "gap", "velocity", "affinity")


@dataclass(frozen=True)
class PairCheck:
    """The outcome of A(t1, t2) for one pair, with the numbers that decided it.

    Attributes
    ----------
    allowed
        True when every constraint holds.
    failed
        The constraints that do not hold, in :data:`CONSTRAINTS` order (empty if allowed).
    affinity
        Appearance affinity of the two mean features, in [0, 1].
    overlap_frames
        Number of frames where both have a box.
    min_segment_iou
        Lowest mean IoU over the overlapping segments (NaN when they do not overlap).
    max_gap
        Largest frame difference between consecutive boxes of the merged trajectory.
    gap_at_max_velocity
        Frame difference of the gap with the highest velocity ratio (0 if there is no gap).
    velocity
        Centre speed (pixels per frame) in that gap (0 if there is no gap).
    velocity_bound
        The bound that applies to that gap, in pixels per frame (inf if no gap).
    """

    allowed: bool
    failed: tuple[Constraint, ...]
    affinity: float
    overlap_frames: int
    min_segment_iou: float
    max_gap: int
    gap_at_max_velocity: int
    velocity: float
    velocity_bound: float

    @property
    def first_failed(self) -> Constraint | None:
        """The constraint reported as the reason for rejection, or None."""
        return self.failed[0] if self.failed else None


def velocity_bound(gap: np.ndarray | int, width: np.ndarray | float,
                   config: AssociationConfig) -> np.ndarray:
    """Velocity bound in pixels per frame for a gap of ``gap`` frames between boxes of mean ``width``."""
    gap = np.asarray(gap)
    factor = np.where(gap <= 1, config.velocity_adjacent,
                      np.where(gap <= config.short_gap, config.velocity_short, config.velocity_long))
    return factor * np.asarray(width, dtype=np.float64)


def time_distance(a: Tracklet, b: Tracklet) -> int:
    """Frame difference across the gap between two time spans, 0 when the spans overlap.

    ``max(a.start, b.start) - min(a.end, b.end)`` clipped at 0; 1 for a
    trajectory that ends in the frame just before the other starts.
    """
    return max(0, max(a.start, b.start) - min(a.end, b.end))


def merge(a: Tracklet, b: Tracklet, new_id: int) -> Tracklet:
    """One trajectory from two: the union of their frames, the higher-score box in shared frames.

    Ties in score keep ``a``'s box. The mean feature is the mean over both
    trajectories' detections.
    """
    frames = np.concatenate([a.frames, b.frames])
    scores = np.concatenate([a.scores, b.scores])
    origin = np.r_[np.zeros(len(a), np.int64), np.ones(len(b), np.int64)]
    # Sort by frame, then best score first, then a before b; keep the first row of each frame.
    order = np.lexsort((origin, -scores, frames))
    frames = frames[order]
    first = np.r_[True, frames[1:] != frames[:-1]]
    take = order[first]
    n = a.n_features + b.n_features
    feature = (a.feature.astype(np.float64) * a.n_features + b.feature.astype(np.float64) * b.n_features) / n
    return Tracklet(id=new_id, frames=np.concatenate([a.frames, b.frames])[take],
                    boxes=np.concatenate([a.boxes, b.boxes])[take], scores=np.concatenate([a.scores, b.scores])[take],
                    det_index=np.concatenate([a.det_index, b.det_index])[take], feature=feature, n_features=n)


def _overlap_segments_iou(a: Tracklet, b: Tracklet) -> tuple[int, float]:
    """Number of shared frames and the lowest mean IoU over the shared segments."""
    common, ia, ib = np.intersect1d(a.frames, b.frames, assume_unique=True, return_indices=True)
    if len(common) == 0:
        return 0, math.nan
    ious = iou_aligned(a.boxes[ia], b.boxes[ib])
    breaks = np.flatnonzero(np.diff(common) != 1) + 1
    means = [seg.mean() for seg in np.split(ious, breaks)]
    return len(common), float(min(means))


def gap_velocity(f1: np.ndarray, b1: np.ndarray, f2: np.ndarray, b2: np.ndarray,
                 config: AssociationConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gap, speed and velocity bound between boxes ``b1`` at frames ``f1`` and ``b2`` at ``f2``.

    Vectorised over rows: ``f1, f2`` are ``(K,)`` frames with ``f2 > f1``,
    ``b1, b2`` are ``(K, 4)`` boxes. Returns the frame differences, the centre
    speeds in pixels per frame (linear motion) and their bounds.
    """
    gaps = np.asarray(f2) - np.asarray(f1)
    speed = np.linalg.norm(centers(b2) - centers(b1), axis=1) / gaps
    bound = velocity_bound(gaps, 0.5 * (np.asarray(b1)[:, 2] + np.asarray(b2)[:, 2]), config)
    return gaps, speed, bound


def _gap_checks(frames: np.ndarray, boxes: np.ndarray,
                config: AssociationConfig) -> tuple[int, int, float, float]:
    """Max gap, and the gap, speed and bound of the worst gap (highest speed/bound), over consecutive boxes."""
    if len(frames) < 2:
        return 0, 0, 0.0, math.inf
    gaps, speed, bound = gap_velocity(frames[:-1], boxes[:-1], frames[1:], boxes[1:], config)
    worst = int(np.argmax(speed / bound))
    return int(gaps.max()), int(gaps[worst]), float(speed[worst]), float(bound[worst])


def check_pair(a: Tracklet, b: Tracklet, config: AssociationConfig,
               pair_affinity: float | None = None) -> PairCheck:
    """Evaluate A(a, b): may ``a`` and ``b`` be merged into one trajectory?

    Parameters
    ----------
    a, b
        The two trajectories (either order; the result does not depend on it
        except for ties in box score, which keep ``a``'s box).
    config
        Thresholds of the constraints.
    pair_affinity
        Their appearance affinity, if the caller already computed it (it is
        computed from the mean features otherwise).

    Returns
    -------
    PairCheck
        Whether the pair is allowed, which constraints fail and the numbers.

    Notes
    -----
    When the two do not overlap in time, only the one new gap between them is
    checked (the gaps inside each were checked when they were made); when they
    overlap, every gap of the merged trajectory is checked.
    """
    aff = float(feature_affinity(a.feature, b.feature)[0, 0]) if pair_affinity is None else float(pair_affinity)
    overlap, min_iou = _overlap_segments_iou(a, b)
    if overlap == 0 and (a.end < b.start or b.end < a.start):
        first, second = (a, b) if a.end < b.start else (b, a)
        frames = np.array([first.end, second.start])
        boxes = np.stack([first.boxes[-1], second.boxes[0]])
        max_gap, worst_gap, speed, bound = _gap_checks(frames, boxes, config)
        max_gap = max(max_gap, a.max_gap, b.max_gap)
    else:
        merged = merge(a, b, new_id=-1)
        max_gap, worst_gap, speed, bound = _gap_checks(merged.frames, merged.boxes, config)
    failed = _failed(overlap, min_iou, max_gap, speed, bound, aff, config)
    return PairCheck(allowed=not failed, failed=failed, affinity=aff, overlap_frames=overlap,
                     min_segment_iou=min_iou, max_gap=max_gap, gap_at_max_velocity=worst_gap,
                     velocity=speed, velocity_bound=bound)


def _failed(overlap: int, min_iou: float, max_gap: int, speed: float, bound: float, aff: float,
            config: AssociationConfig) -> tuple[Constraint, ...]:
    """The rules that fail, in :data:`CONSTRAINTS` order: the one statement of each rule's test."""
    failed: list[Constraint] = []
    if overlap and not min_iou > config.tau_iou:
        failed.append("iou")
    if max_gap > config.l_max:
        failed.append("gap")
    if speed > bound:
        failed.append("velocity")
    if aff < config.min_affinity:
        failed.append("affinity")
    return tuple(failed)


def candidate_pairs(tracklets: list[Tracklet] | tuple[Tracklet, ...], l_max: int) -> list[tuple[int, int]]:
    """Index pairs ``(i, j)``, ``i < j``, of trajectories whose time spans are within ``l_max`` frames.

    Only these can pass the gap constraint; the rest are never checked.
    """
    if not tracklets:
        return []
    starts = np.array([t.start for t in tracklets])
    ends = np.array([t.end for t in tracklets])
    order = np.argsort(starts, kind="stable")
    sorted_starts = starts[order]
    pairs = []
    for pos, i in enumerate(order):
        stop = np.searchsorted(sorted_starts, ends[i] + l_max, side="right")
        for j in order[pos + 1:stop]:
            pairs.append((int(min(i, j)), int(max(i, j))))
    return sorted(pairs)


@dataclass(frozen=True)
class Screen:
    """Vectorised pre-check of many pairs (see :func:`screen_pairs`).

    Attributes
    ----------
    ok
        ``(K,)`` False where :func:`check_pair` must reject the pair.
    exact
        ``(K,)`` True for pairs that do not overlap in time: for them ``ok``
        is :func:`check_pair`'s final answer and ``checks`` holds its result.
    checks
        Pair index -> :class:`PairCheck` for the exact pairs that are ok.
    """

    ok: np.ndarray
    exact: np.ndarray
    checks: dict[int, PairCheck]


def screen_pairs(tracklets: list[Tracklet] | tuple[Tracklet, ...], pairs: np.ndarray,
                 affinities: np.ndarray, config: AssociationConfig) -> Screen:
    """Check many pairs at once, vectorised where possible.

    For pairs that do not overlap in time, the single new gap is evaluated
    with the same helpers and the same rule statement (:func:`_failed`) as
    :func:`check_pair`, so the answer is final. Pairs that overlap pass the
    screen when their affinity does, and need the full :func:`check_pair`.

    Parameters
    ----------
    pairs
        ``(K, 2)`` indices into ``tracklets``.
    affinities
        ``(K,)`` affinity of each pair.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    affinities = np.asarray(affinities, dtype=np.float64)
    if len(pairs) == 0:
        return Screen(np.zeros(0, bool), np.zeros(0, bool), {})
    involved = np.unique(pairs)  # only these are read: solvers call this with a few pairs at a time
    starts = np.zeros(len(tracklets), dtype=np.int64)
    ends = np.zeros(len(tracklets), dtype=np.int64)
    inner = np.zeros(len(tracklets), dtype=np.int64)
    for k in involved:
        starts[k], ends[k], inner[k] = tracklets[k].frames[0], tracklets[k].frames[-1], tracklets[k].max_gap
    i, j = pairs[:, 0], pairs[:, 1]
    i_first = ends[i] < starts[j]
    exact = i_first | (ends[j] < starts[i])
    ok = affinities >= config.min_affinity
    checks: dict[int, PairCheck] = {}
    rows = np.flatnonzero(exact & ok)
    if len(rows):
        first = np.where(i_first, i, j)[rows]
        second = np.where(i_first, j, i)[rows]
        last_box = np.stack([tracklets[k].boxes[-1] for k in first])
        first_box = np.stack([tracklets[k].boxes[0] for k in second])
        gaps, speed, bound = gap_velocity(ends[first], last_box, starts[second], first_box, config)
        max_gap = np.maximum(gaps, np.maximum(inner[first], inner[second]))
        for r, g, mg, v, b in zip(rows, gaps.tolist(), max_gap.tolist(), speed.tolist(), bound.tolist()):
            failed = _failed(0, math.nan, mg, v, b, float(affinities[r]), config)
            if failed:
                ok[r] = False
            else:
                checks[int(r)] = PairCheck(allowed=True, failed=(), affinity=float(affinities[r]), overlap_frames=0,
                                           min_segment_iou=math.nan, max_gap=mg, gap_at_max_velocity=g,
                                           velocity=v, velocity_bound=b)
    return Screen(ok, exact, checks)


def allowed_checks(tracklets: list[Tracklet] | tuple[Tracklet, ...], pairs: np.ndarray,
                   affinities: np.ndarray, config: AssociationConfig) -> list[tuple[int, PairCheck]]:
    """``(pair index, PairCheck)`` of every allowed pair: :func:`screen_pairs`, then
    :func:`check_pair` on the overlapping pairs that pass the screen."""
    screen = screen_pairs(tracklets, pairs, affinities, config)
    out = []
    for r in np.flatnonzero(screen.ok):
        if screen.exact[r]:
            out.append((int(r), screen.checks[int(r)]))
        else:
            check = check_pair(tracklets[pairs[r, 0]], tracklets[pairs[r, 1]], config, pair_affinity=affinities[r])
            if check.allowed:
                out.append((int(r), check))
    return out


def merge_group(tracklets: list[Tracklet] | tuple[Tracklet, ...], new_id: int) -> Tracklet:
    """One trajectory from several tracklets, merged pairwise with :func:`merge` in the given order."""
    if not tracklets:
        raise ValueError("cannot merge an empty group")
    out = dataclasses.replace(tracklets[0], id=new_id)
    for t in tracklets[1:]:
        out = merge(out, t, new_id)
    return out
