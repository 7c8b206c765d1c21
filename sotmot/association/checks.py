"""The constraint A(t1, t2) of :mod:`sotmot.association.rules` evaluated, vectorised over many pairs.

Every solver calls :func:`check_pairs` (or :func:`check_pair` for one pair,
with every number measured, as the explanations need), and
:func:`candidate_pairs` to find the pairs worth checking. Boxes are ``x, y, w,
h`` pixels, frames 1-based.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sotmot.appearance import unit
from sotmot.association.affinity import link_affinities
from sotmot.association.rules import CONSTRAINTS, Constraint, gap_velocity, rule_failures
from sotmot.boxes import iou_aligned
from sotmot.config import AssociationConfig
from sotmot.types import Tracklet

#: Frames one :func:`check_pairs` call walks through at once (about 250 bytes each); larger
#: checks are split into pieces of about this size, so memory stays bounded on long sequences.
CHECK_FRAMES = 400_000


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
    velocity_gap
        Frame difference of the checked gap with the highest speed/bound
        ratio (0 if the merge creates or changes no gap).
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
    velocity_gap: int
    velocity: float
    velocity_bound: float


class _Ends:
    """First and last frame and box, and largest inner gap, of several trajectories."""

    def __init__(self, tracklets: Sequence[Tracklet], nodes: np.ndarray) -> None:
        chosen = [tracklets[n] for n in nodes.tolist()]
        self.starts = np.array([t.frames[0] for t in chosen], dtype=np.int64)
        self.ends = np.array([t.frames[-1] for t in chosen], dtype=np.int64)
        self.first_box = np.array([t.boxes[0] for t in chosen], dtype=np.float64).reshape(-1, 4)
        self.last_box = np.array([t.boxes[-1] for t in chosen], dtype=np.float64).reshape(-1, 4)
        self.inner = np.array([t.max_gap for t in chosen], dtype=np.int64)


class _FrameIndex(_Ends):
    """Boxes and scores of several trajectories, looked up by (trajectory, frame) in one search."""

    def __init__(self, tracklets: Sequence[Tracklet], nodes: np.ndarray) -> None:
        super().__init__(tracklets, nodes)
        frames = [tracklets[n].frames for n in nodes.tolist()]
        self.span = int(self.ends.max()) + 2 if frames else 1
        self.keys = np.concatenate([code * self.span + f for code, f in enumerate(frames)]) if frames \
            else np.zeros(0, np.int64)
        self.boxes = np.concatenate([tracklets[n].boxes for n in nodes.tolist()]) if frames else np.zeros((0, 4))
        self.scores = np.concatenate([tracklets[n].scores for n in nodes.tolist()]) if frames else np.zeros(0)

    def lookup(self, codes: np.ndarray, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Whether trajectory ``codes[i]`` has a box in ``frames[i]``, and its row."""
        q = codes * self.span + frames
        pos = np.minimum(np.searchsorted(self.keys, q), max(len(self.keys) - 1, 0))
        return self.keys[pos] == q, pos


def _expand(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pair index and frame of every frame in ``[lo[k], hi[k]]``, pair by pair (empty if hi < lo)."""
    length = np.clip(hi - lo + 1, 0, None)
    which = np.repeat(np.arange(len(lo)), length)
    offset = np.arange(len(which)) - np.repeat(np.cumsum(length) - length, length)
    return which, lo[which] + offset


def _segment_ious(index: _FrameIndex, local: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Shared frames and lowest segment mean IoU (NaN if none) of pairs of index codes."""
    k = len(local)
    overlap = np.zeros(k, dtype=np.int64)
    min_iou = np.full(k, np.nan)
    lo = index.starts[local].max(axis=1)
    hi = index.ends[local].min(axis=1)
    which, frame = _expand(lo, hi)
    found_a, pos_a = index.lookup(local[which, 0], frame)
    found_b, pos_b = index.lookup(local[which, 1], frame)
    both = found_a & found_b
    which, frame = which[both], frame[both]
    if len(which) == 0:
        return overlap, min_iou
    ious = iou_aligned(index.boxes[pos_a[both]], index.boxes[pos_b[both]])
    new_segment = np.r_[True, (which[1:] != which[:-1]) | (np.diff(frame) != 1)]
    segment = np.cumsum(new_segment) - 1
    means = np.bincount(segment, weights=ious) / np.bincount(segment)
    overlap[:] = np.bincount(which, minlength=k)
    lowest = np.full(k, np.inf)
    np.minimum.at(lowest, which[new_segment], means)
    min_iou[overlap > 0] = lowest[overlap > 0]
    return overlap, min_iou


def _junction_gaps(ends: _Ends, early: np.ndarray, late: np.ndarray,
                   config: AssociationConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gap numbers of merging disjoint trajectories, ``early`` ending before ``late`` starts.

    The merge creates one gap, joining the last box of ``early`` to the first
    box of ``late``; it is the only checked gap. Returns the largest gap of
    the merged trajectory (inner gaps included) and that gap, its speed and bound.
    """
    gaps, speed, bound = gap_velocity(ends.ends[early], ends.last_box[early], ends.starts[late],
                                      ends.first_box[late], config)
    return np.maximum(np.maximum(ends.inner[early], ends.inner[late]), gaps), gaps, speed, bound


def _overlap_gaps(index: _FrameIndex, local: np.ndarray,
                  config: AssociationConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Gap numbers of merging pairs whose spans meet: max gap, and gap, speed, bound of the worst checked gap.

    With ``lo`` the later start and ``hi`` the earlier end, the merge can only
    change gaps that touch the common span ``[lo, hi]``: checked gaps
    ``(f1, f2)`` are those with ``f2 >= lo`` and ``f1 <= hi``. The merged
    trajectory (higher-score box per shared frame, ties to the first of the
    pair) is built only over the span widened by ``l_max + 1`` frames, enough
    to see every such gap whole (a longer one is an inner gap of an input,
    counted through ``Tracklet.max_gap``).
    """
    k = len(local)
    lo = index.starts[local].max(axis=1)
    hi = index.ends[local].min(axis=1)
    max_gap = np.maximum(index.inner[local[:, 0]], index.inner[local[:, 1]])
    velocity_gap, speed, bound = np.zeros(k, np.int64), np.zeros(k), np.full(k, np.inf)
    if k == 0:
        return max_gap, velocity_gap, speed, bound
    first = np.maximum(index.starts[local].min(axis=1), lo - config.l_max - 1)
    last = np.minimum(index.ends[local].max(axis=1), hi + config.l_max + 1)
    which, frame = _expand(first, last)
    found_a, pos_a = index.lookup(local[which, 0], frame)
    found_b, pos_b = index.lookup(local[which, 1], frame)
    take_a = found_a & (~found_b | (index.scores[pos_a] >= index.scores[pos_b]))
    present = found_a | found_b
    which, frame = which[present], frame[present]
    boxes = np.where(take_a[present][:, None], index.boxes[pos_a[present]], index.boxes[pos_b[present]])
    step = np.flatnonzero((which[1:] == which[:-1]) & (frame[1:] >= lo[which[1:]]) & (frame[:-1] <= hi[which[:-1]]))
    if len(step) == 0:
        return max_gap, velocity_gap, speed, bound
    pair = which[step]
    gaps, spd, bnd = gap_velocity(frame[step], boxes[step], frame[step + 1], boxes[step + 1], config)
    np.maximum.at(max_gap, pair, gaps)
    order = np.lexsort((-(spd / bnd), pair))  # by pair, worst ratio first
    head = order[np.r_[True, pair[order][1:] != pair[order][:-1]]]
    velocity_gap[pair[head]], speed[pair[head]], bound[pair[head]] = gaps[head], spd[head], bnd[head]
    return max_gap, velocity_gap, speed, bound


@dataclass(frozen=True)
class PairChecks:
    """A(t1, t2) evaluated for many pairs at once (see :func:`check_pairs`); arrays of shape ``(K,)``.

    Attributes
    ----------
    allowed
        True where every constraint holds.
    failures
        Constraint name -> True where it fails. Pairs rejected by the IoU or
        affinity rule are not checked further: their gap numbers stay at
        0 / 0 / 0 / inf and their gap and velocity entries False.
    affinity, overlap, min_iou
        Affinity, shared frames, lowest segment mean IoU (NaN if none).
    max_gap, velocity_gap, speed, bound
        Largest gap of the merged trajectory; gap, speed and bound of the
        checked gap with the highest speed/bound ratio.
    """

    allowed: np.ndarray
    failures: dict[Constraint, np.ndarray]
    affinity: np.ndarray
    overlap: np.ndarray
    min_iou: np.ndarray
    max_gap: np.ndarray
    velocity_gap: np.ndarray
    speed: np.ndarray
    bound: np.ndarray

    @staticmethod
    def concat(parts: Sequence[PairChecks]) -> PairChecks:
        """One screen of the pairs of ``parts``, in order."""
        fields = [f.name for f in dataclasses.fields(PairChecks) if f.name != "failures"]
        return PairChecks(**{name: np.concatenate([getattr(p, name) for p in parts]) for name in fields},
                      failures={c: np.concatenate([p.failures[c] for p in parts]) for c in CONSTRAINTS})

    def take(self, rows: np.ndarray) -> PairChecks:
        """The screen of the pairs ``rows`` only."""
        return dataclasses.replace(self, **{f.name: getattr(self, f.name)[rows] for f in dataclasses.fields(self)
                                            if f.name != "failures"},
                                   failures={c: v[rows] for c, v in self.failures.items()})

    def check(self, row: int) -> PairCheck:
        """The :class:`PairCheck` of one pair."""
        overlap = int(self.overlap[row])
        return PairCheck(allowed=bool(self.allowed[row]),
                         failed=tuple(c for c in CONSTRAINTS if self.failures[c][row]),
                         affinity=float(self.affinity[row]), overlap_frames=overlap,
                         min_segment_iou=float(self.min_iou[row]) if overlap else math.nan,
                         max_gap=int(self.max_gap[row]), velocity_gap=int(self.velocity_gap[row]),
                         velocity=float(self.speed[row]), velocity_bound=float(self.bound[row]))


def check_pairs(tracklets: Sequence[Tracklet], pairs: np.ndarray, affinities: np.ndarray,
                config: AssociationConfig, complete: bool = False) -> PairChecks:
    """Evaluate A(t1, t2) for many pairs at once, vectorised: the implementation of the rules.

    Parameters
    ----------
    tracklets
        The trajectories.
    pairs
        ``(K, 2)`` indices into ``tracklets``; in each pair the first one's box
        wins ties in score when the two share a frame.
    affinities
        ``(K,)`` appearance affinity of each pair.
    config
        The thresholds.
    complete
        Also measure gaps and velocity for pairs already rejected by the IoU
        or affinity rule (for explanations); solvers leave this off.
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    affinities = np.asarray(affinities, dtype=np.float64).reshape(-1)
    if not complete:
        # pairs below the affinity gate are rejected whatever their boxes: measure only the rest
        keep = np.flatnonzero(~rule_failures(0, np.nan, 0, 0.0, np.inf, affinities, config)["affinity"])
        if len(keep) < len(pairs):
            return _scatter(check_pairs(tracklets, pairs[keep], affinities[keep], config), keep, affinities, config)
    k = len(pairs)
    nodes, local = np.unique(pairs, return_inverse=True)
    local = local.reshape(-1, 2)
    ends = _Ends(tracklets, nodes)
    meet = ends.starts[local].max(axis=1) <= ends.ends[local].min(axis=1)
    met, apart = np.flatnonzero(meet), np.flatnonzero(~meet)
    if k > 1:
        # frames a pair's check walks through (its span widened by l_max + 1 on both sides, if they meet)
        work = np.where(meet, ends.ends[local].max(axis=1) - ends.starts[local].min(axis=1) + 2 * config.l_max + 3, 1)
        if work.sum() > CHECK_FRAMES:
            cut = np.flatnonzero(np.diff(np.cumsum(work) // CHECK_FRAMES)) + 1
            parts = [check_pairs(tracklets, pairs[a:b], affinities[a:b], config, complete)
                     for a, b in zip(np.r_[0, cut], np.r_[cut, k])]
            return PairChecks.concat(parts)
    # only the trajectories of pairs whose spans meet are needed frame by frame
    sub, met_local = np.unique(local[met], return_inverse=True)
    index = _FrameIndex(tracklets, nodes[sub])
    met_local = met_local.reshape(-1, 2)
    overlap, min_iou = np.zeros(k, np.int64), np.full(k, np.nan)
    overlap[met], min_iou[met] = _segment_ious(index, met_local)
    failures = rule_failures(overlap, min_iou, 0, 0.0, np.inf, affinities, config)
    max_gap, velocity_gap, speed, bound = np.zeros(k, np.int64), np.zeros(k, np.int64), np.zeros(k), np.full(k, np.inf)
    measure = np.ones(k, bool) if complete else ~(failures["iou"] | failures["affinity"])
    rows = apart[measure[apart]]
    a_first = ends.ends[local[rows, 0]] < ends.starts[local[rows, 1]]
    early, late = np.where(a_first, local[rows, 0], local[rows, 1]), np.where(a_first, local[rows, 1], local[rows, 0])
    max_gap[rows], velocity_gap[rows], speed[rows], bound[rows] = _junction_gaps(ends, early, late, config)
    sel = np.flatnonzero(measure[met])
    max_gap[met[sel]], velocity_gap[met[sel]], speed[met[sel]], bound[met[sel]] = _overlap_gaps(
        index, met_local[sel], config)
    failures = rule_failures(overlap, min_iou, max_gap, speed, bound, affinities, config, velocity_gap)
    allowed = ~np.any(np.stack([failures[c] for c in CONSTRAINTS]), axis=0) if k else np.zeros(0, bool)
    return PairChecks(allowed=allowed, failures=failures, affinity=affinities, overlap=overlap, min_iou=min_iou,
                  max_gap=max_gap, velocity_gap=velocity_gap, speed=speed, bound=bound)


def _scatter(part: PairChecks, rows: np.ndarray, affinities: np.ndarray, config: AssociationConfig) -> PairChecks:
    """A screen over all pairs from the screen of ``rows``; the other pairs failed only the affinity gate."""
    k = len(affinities)

    def fill(values: np.ndarray, default: float | int | bool) -> np.ndarray:
        out = np.full(k, default, dtype=values.dtype)
        out[rows] = values
        return out

    overlap, min_iou = fill(part.overlap, 0), fill(part.min_iou, np.nan)
    max_gap, velocity_gap = fill(part.max_gap, 0), fill(part.velocity_gap, 0)
    speed, bound = fill(part.speed, 0.0), fill(part.bound, np.inf)
    failures = rule_failures(overlap, min_iou, max_gap, speed, bound, affinities, config, velocity_gap)
    return PairChecks(allowed=fill(part.allowed, False), failures=failures, affinity=affinities, overlap=overlap,
                  min_iou=min_iou, max_gap=max_gap, velocity_gap=velocity_gap, speed=speed, bound=bound)


def check_pair(a: Tracklet, b: Tracklet, config: AssociationConfig,
               pair_affinity: float | None = None) -> PairCheck:
    """Evaluate A(a, b): may ``a`` and ``b`` be merged into one trajectory?

    Every number is computed, also for a pair that an early rule rejects (it
    is the explanation). Solvers use :func:`check_pairs` on many pairs.

    Parameters
    ----------
    a, b
        The two trajectories; ``a``'s box wins ties in score in shared frames.
    config
        Thresholds of the constraints.
    pair_affinity
        Their appearance affinity, if the caller already computed it (it is
        computed from the mean features otherwise).
    """
    if pair_affinity is None:
        pair_affinity = link_affinities((a, b), np.array([[0, 1]]), unit(np.stack([a.feature, b.feature])),
                                        config)[0]
    aff = float(pair_affinity)
    return check_pairs((a, b), np.array([[0, 1]]), np.array([aff]), config, complete=True).check(0)


def candidate_pairs(tracklets: Sequence[Tracklet], l_max: int) -> np.ndarray:
    """Index pairs ``(i, j)``, ``i < j``, of trajectories whose time spans are within ``l_max`` frames.

    Only these can pass the gap constraint; the rest are never checked.
    Returned as a sorted ``(K, 2)`` int64 array.
    """
    if not tracklets:
        return np.zeros((0, 2), np.int64)
    starts = np.array([t.start for t in tracklets])
    ends = np.array([t.end for t in tracklets])
    order = np.argsort(starts, kind="stable")
    stop = np.searchsorted(starts[order], ends[order] + l_max, side="right")
    which, pos = _expand(np.arange(len(order)) + 1, stop - 1)
    i, j = order[which], order[pos]
    pairs = np.stack([np.minimum(i, j), np.maximum(i, j)], axis=1).astype(np.int64)
    return pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
