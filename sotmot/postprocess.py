"""Post-processing of trajectories (paper Sec. 3.5): linear interpolation and smoothing.

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from sotmot.boxes import (VELOCITY_BOXES, cxcywh_to_xywh, end_velocity, heights_moved, intersection_aligned,
                          iou_aligned, motion_agreement, xywh_to_cxcywh)
from sotmot.config import PostprocessConfig
from sotmot.types import Detections, Tracklet, Tracks

#: A detection stands in front of a box when its bottom edge is no higher than the box's by more than this share
#: of the box's height (nearer the camera, so it can hide the person).
FRONT_MARGIN = 0.05
_NONE = np.zeros(0, dtype=np.int64)
#: The windows (frames either side) ``[postprocess] smooth_window = "auto"`` chooses from, for each trajectory and
#: coordinate (:func:`smoothing_windows`).
AUTO_WINDOWS = (3, 4, 6, 8, 12)
#: :func:`smoothing_windows` predicts a box from the others leaving out the boxes within this many frames of it
#: too: a detector errs alike on a person in consecutive frames (the same pose, the same partial occlusion), and a
#: neighbour sharing the box's error would make little smoothing look best (with every box left out alone, windows
#: of 1 to 24 frames, the choice lost up to 0.85 HOTA on the validation set; docs/benchmarks.md). A line needs 3
#: others, so the shortest window is 3 frames, the paper's.
CV_BLOCK = 1
#: The window of a trajectory with too few observed boxes to choose one (the paper's 3).
SHORT_WINDOW = 3
#: The line check (``[postprocess] line_check_seconds``, :func:`line_checked`): one sample is the straight line
#: between two boxes of a trajectory a span apart, evaluated at its box halfway between them; it lands when its IoU
#: with that box is at least this (0.5 failed lines that follow a person under a detector's loose boxes:
#: docs/benchmarks.md, "Interpolation that checks its line").
LINE_IOU = 0.3
#: The line holds over a span when at least this share of the span's samples land (most of them).
LINE_HOLDS = 0.5
#: A span with fewer samples than this says nothing (it counts as holding): short clips keep the configured bound.
LINE_MIN_SAMPLES = 30
#: Where the line does not hold over ``line_check_seconds``, the spans tried are this long and longer by
#: :data:`LINE_STEP_SECONDS`; the bound never falls below the first (the occlusion check's default span).
LINE_FLOOR_SECONDS = PostprocessConfig.occlusion_seconds
LINE_STEP_SECONDS = 0.5


def interpolate(frames: np.ndarray, boxes: np.ndarray, scores: np.ndarray, max_gap: int | None = None
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Fill every gap of at most ``max_gap`` frames (None: every gap) by linear interpolation of the boxes.

    Parameters
    ----------
    frames
        ``(L,)`` strictly increasing 1-based frames.
    boxes
        ``(L, 4)`` ``x, y, w, h`` pixels.
    scores
        ``(L,)`` scores, or ``(L, K)``: K kinds of score, each column alike;
        a filled box gets the lower score of the two boxes around its gap.
    max_gap
        Longest gap filled, as the frame difference of the boxes around it.

    Returns
    -------
    frames, boxes, scores, filled
        Over every frame from the first to the last except those of longer
        gaps; ``filled`` marks the new boxes.
    """
    full = np.arange(frames[0], frames[-1] + 1, dtype=np.int64)
    if max_gap is not None:
        gaps = np.diff(frames)
        fill = gaps <= max_gap
        after = np.searchsorted(frames, full, side="right")  # index of the box after each frame
        inside = np.clip(after, 1, len(gaps)) - 1
        full = full[np.isin(full, frames) | fill[inside]]
    out = np.stack([np.interp(full, frames, boxes[:, k]) for k in range(4)], axis=1)
    right = np.clip(np.searchsorted(frames, full, side="left"), 0, len(frames) - 1)
    left = np.clip(np.searchsorted(frames, full, side="right") - 1, 0, len(frames) - 1)
    filled = ~np.isin(full, frames)
    where = filled.reshape((-1,) + (1,) * (np.ndim(scores) - 1))  # a row of every kind of score at once
    full_scores = np.where(where, np.minimum(scores[left], scores[right]), scores[left])
    return full, out, full_scores, filled


def smooth(frames: np.ndarray, boxes: np.ndarray, window: int | str, observed: np.ndarray | None = None) -> np.ndarray:
    """The boxes of one trajectory smoothed as ``[postprocess] smooth_window`` asks.

    ``window`` frames (an integer, the paper's smoothing): each box replaced by
    the mean of the trajectory's boxes within ``+- window`` frames; 0 returns a
    copy. ``"auto"``: each coordinate (centre x, centre y, width, height)
    replaced by a straight line fitted through its values within ``+- w``
    frames, evaluated at the box's frame, ``w`` chosen for the trajectory and
    the coordinate by :func:`smoothing_windows` from its ``observed`` boxes
    (``(L,)`` True for the boxes not interpolated; None: all). Works on
    trajectories with or without gaps: only boxes that exist enter a mean or a
    line. ``frames`` ``(L,)`` increasing 1-based, ``boxes`` ``(L, 4)`` ``x, y, w, h`` pixels.
    """
    if window == "auto":
        if len(frames) < 2:
            return boxes.copy()
        observed = np.ones(len(frames), dtype=bool) if observed is None else observed
        values = xywh_to_cxcywh(boxes)
        windows = smoothing_windows(frames[observed], values[observed])
        out = np.column_stack([local_lines(frames, values[:, k:k + 1], int(w))[0][:, 0]
                               for k, w in enumerate(windows)])
        return cxcywh_to_xywh(out)
    if window <= 0 or len(frames) < 2:
        return boxes.copy()
    lo = np.searchsorted(frames, frames - window, side="left")
    hi = np.searchsorted(frames, frames + window, side="right")
    csum = np.vstack([np.zeros((1, 4)), np.cumsum(boxes, axis=0)])
    return (csum[hi] - csum[lo]) / (hi - lo)[:, None]


def local_lines(frames: np.ndarray, values: np.ndarray, window: int, block: int = -1
                ) -> tuple[np.ndarray, np.ndarray]:
    """Each row of ``values`` ``(L, K)`` at 1-based ``frames`` ``(L,)`` (increasing) replaced by the least-squares
    line through the rows within ``+- window`` frames of it, evaluated at its frame (one line per column).

    The rows within ``+- block`` frames of a row are left out of its own line (-1: none; 0: the row itself), as
    :func:`smoothing_windows` predicts a row from the others. A line through rows of one frame only is their mean.
    Returns the fitted ``(L, K)`` and the number of rows each line went through ``(L,)`` (where it is 0 the
    fitted row is 0).
    """
    t = (frames - frames[0]).astype(np.float64)  # offsets: sums of squares stay small for long trajectories
    values = np.asarray(values, dtype=np.float64)

    running = [np.vstack([np.zeros((1, a.shape[1])), np.cumsum(a, axis=0)])
               for a in (np.ones((len(t), 1)), t[:, None], (t * t)[:, None], values, t[:, None] * values)]

    def sums(window_: int) -> list[np.ndarray]:
        lo = np.searchsorted(frames, frames - window_, side="left")
        hi = np.searchsorted(frames, frames + window_, side="right")
        return [r[hi] - r[lo] for r in running]

    n, st, stt, sy, sty = sums(window)
    if block >= 0:
        n, st, stt, sy, sty = (a - b for a, b in zip((n, st, stt, sy, sty), sums(block)))
    n, st, stt = n[:, 0], st[:, 0], stt[:, 0]
    safe = np.maximum(n, 1.0)
    mean_t, mean_y = st / safe, sy / safe[:, None]
    var_t = stt / safe - mean_t ** 2
    sloped = var_t > 1e-9
    slope = np.zeros_like(mean_y)
    slope[sloped] = (sty[sloped] / safe[sloped, None] - mean_t[sloped, None] * mean_y[sloped]) / var_t[sloped, None]
    return mean_y + slope * (t - mean_t)[:, None], n.astype(np.int64)


def smoothing_windows(frames: np.ndarray, values: np.ndarray, windows: Sequence[int] = AUTO_WINDOWS,
                      block: int = CV_BLOCK) -> np.ndarray:
    """For each column of ``values`` ``(L, K)`` (one trajectory's observed boxes at 1-based ``frames``, e.g. centre
    x, centre y, width, height), the window of ``windows`` whose local lines (:func:`local_lines`) predict each row
    best from the others: cross-validation, each row left out with those within ``+- block`` frames of it, the
    rows whose line has at least 3 others scored. Returns ``(K,)`` windows; :data:`SHORT_WINDOW` where no window
    scores a row (fewer than 4 rows, or rows too far apart)."""
    values = np.asarray(values, dtype=np.float64)
    if len(frames) < 4:
        return np.full(values.shape[1], SHORT_WINDOW)
    errors = []
    for w in windows:
        fitted, n = local_lines(frames, values, w, block)
        scored = n >= 3
        errors.append(((values[scored] - fitted[scored]) ** 2).mean(axis=0) if scored.any()
                      else np.full(values.shape[1], np.inf))
    errors = np.asarray(errors)
    best = np.asarray(windows)[np.argmin(errors, axis=0)]
    return np.where(np.isfinite(errors.min(axis=0)), best, SHORT_WINDOW)


def output_ids(trajectories: Sequence[Tracklet], config: PostprocessConfig = PostprocessConfig(),
               frame_rate: float | None = None, occluders: "Occluders | None" = None) -> list[int | None]:
    """The track id each trajectory gets in the output (None if it is dropped as too short).

    Trajectories are numbered 1, 2, ... by first frame, then by first
    detection index; one shorter than ``config.min_length`` boxes after
    interpolation (as :func:`expand` does it at ``frame_rate`` with ``occluders``) gets no id.
    """
    order = sorted(range(len(trajectories)), key=lambda k: (trajectories[k].start, int(trajectories[k].det_index[0])))
    ids: list[int | None] = [None] * len(trajectories)
    next_id = 1
    for k in order:
        t = trajectories[k]
        length = len(expand(t, config, frame_rate, occluders).frames) if config.min_length > 1 else len(t)
        if length >= config.min_length:
            ids[k] = next_id
            next_id += 1
    return ids


@dataclass(frozen=True)
class Expanded:
    """One trajectory as it will be written: every frame from first to last when interpolating.

    Attributes
    ----------
    frames, boxes, scores
        ``(L,)`` 1-based frames, ``(L, 4)`` ``x, y, w, h`` pixels (not yet
        smoothed), ``(L,)`` scores.
    filled
        ``(L,)`` bool, True for interpolated boxes.
    det_index
        ``(L,)`` index into the sequence's detections, -1 for interpolated boxes.
    """

    frames: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    filled: np.ndarray
    det_index: np.ndarray


def max_interpolated_gap(config: PostprocessConfig, frame_rate: float | None) -> int | None:
    """``[postprocess] interpolate_max_seconds`` in frames (None: no bound, or no frame rate given)."""
    if config.interpolate_max_seconds is None or frame_rate is None:
        return None
    return max(1, int(round(config.interpolate_max_seconds * frame_rate)))


def line_samples(trajectories: Sequence[Tracklet], span: int) -> tuple[int, int]:
    """How many straight lines over ``span`` frames land on their trajectory's box halfway, and how many were tried.

    A sample is two boxes of one trajectory ``span`` frames apart with a box at the frame halfway between them
    (``span // 2`` after the first; starts every ``span // 4`` frames, so that samples overlap little); it lands
    when the line from the first box to the second, at that frame, overlaps the box there by IoU >=
    :data:`LINE_IOU`. Boxes are ``x, y, w, h`` pixels, in the trajectories' coordinates.
    """
    landed = tried = 0
    for t in trajectories:
        f, b = t.frames, t.boxes
        starts = np.flatnonzero(np.isin(f + span, f) & np.isin(f + span // 2, f))[::max(1, span // 4)]
        if not len(starts):
            continue
        end, mid = np.searchsorted(f, f[starts] + span), np.searchsorted(f, f[starts] + span // 2)
        share = ((f[mid] - f[starts]) / span)[:, None]
        line = b[starts] * (1.0 - share) + b[end] * share
        landed += int((iou_aligned(line, b[mid]) >= LINE_IOU).sum())
        tried += len(starts)
    return landed, tried


def line_holds(trajectories: Sequence[Tracklet], seconds: float, frame_rate: float) -> bool:
    """Whether the straight line holds over ``seconds`` on these trajectories (:func:`line_samples`): at least
    :data:`LINE_HOLDS` of the samples land, or fewer than :data:`LINE_MIN_SAMPLES` were found."""
    landed, tried = line_samples(trajectories, max(2, int(round(seconds * frame_rate))))
    return tried < LINE_MIN_SAMPLES or landed >= LINE_HOLDS * tried


def line_checked(config: PostprocessConfig, trajectories: Sequence[Tracklet], frame_rate: float | None
                 ) -> PostprocessConfig:
    """``config`` as it applies to one sequence's ``trajectories``: ``interpolate_max_seconds`` lowered where the
    straight line does not hold (``[postprocess] line_check_seconds``).

    Interpolation writes a person where the straight line between two of their boxes says; whether that line is
    where people go is checked on the sequence's own trajectories, over spans where they were seen
    (:func:`line_holds`). Where it holds over ``line_check_seconds``, ``config`` stands; where it does not (a camera
    that moves with nothing to compensate it), gaps are filled only up to
    the longest span from :data:`LINE_FLOOR_SECONDS` up, in steps of :data:`LINE_STEP_SECONDS`, over which it
    holds (at least the first). Unchanged without a frame rate, with interpolation off or the check off.
    """
    horizon, bound = config.line_check_seconds, config.interpolate_max_seconds
    if horizon is None or not frame_rate or not config.interpolate or line_holds(trajectories, horizon, frame_rate):
        return config
    chosen = LINE_FLOOR_SECONDS
    while chosen + LINE_STEP_SECONDS < horizon and line_holds(trajectories, chosen + LINE_STEP_SECONDS, frame_rate):
        chosen += LINE_STEP_SECONDS
    if bound is not None and bound <= chosen:
        return config
    return dataclasses.replace(config, interpolate_max_seconds=chosen)


def off_the_line(frames: np.ndarray, boxes: np.ndarray, gaps: np.ndarray, config: PostprocessConfig,
                 frame_rate: float) -> np.ndarray:
    """``(K,)`` True for the long gaps after boxes ``gaps`` of one trajectory (1-based ``frames``, ``x, y, w, h``
    ``boxes``) that are not filled on trust (:func:`judge_gaps`)."""
    return judge_gaps(frames, boxes, gaps, config, frame_rate)[2]


def judge_gaps(frames: np.ndarray, boxes: np.ndarray, gaps: np.ndarray, config: PostprocessConfig,
               frame_rate: float) -> tuple[np.ndarray, np.ndarray | None, np.ndarray]:
    """What decides whether the long gaps after boxes ``gaps`` of one trajectory are filled on trust: their ``(K,)``
    motion agreement (:func:`gap_agreement`), their ``(K,)`` speed (:func:`gap_speed`; None, and not computed,
    without ``still_speed``) and ``(K,)`` True where not: the walk around the gap does not lead along its line
    (agreement below ``min_agreement``), or the box stood still across it (speed below ``still_speed``)."""
    agreement = gap_agreement(frames, boxes, gaps)
    off = agreement < config.min_agreement
    speed = None
    if config.still_speed is not None:
        speed = gap_speed(frames, boxes, gaps, frame_rate)
        off |= speed < config.still_speed
    return agreement, speed, off


def gap_speed(frames: np.ndarray, boxes: np.ndarray, gaps: np.ndarray, frame_rate: float) -> np.ndarray:
    """``(K,)`` how far the box's centre moved across each gap after boxes ``gaps`` of one trajectory (1-based
    ``frames``, ``x, y, w, h`` ``boxes``), in its heights (:func:`~sotmot.boxes.heights_moved`) per second."""
    gaps = np.asarray(gaps, dtype=np.int64)
    seconds = (frames[gaps + 1] - frames[gaps]) / frame_rate
    return heights_moved(boxes[gaps], boxes[gaps + 1]) / seconds


def gap_agreement(frames: np.ndarray, boxes: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """``(K,)`` motion agreement (:func:`~sotmot.boxes.motion_agreement`, up to :data:`~sotmot.boxes.VELOCITY_BOXES`
    boxes each side) of the gaps after boxes ``gaps`` ``(K,)`` of one trajectory's ``(L,)`` 1-based ``frames`` and
    ``(L, 4)`` ``x, y, w, h`` ``boxes``: how well the straight line through each gap fits the walk around it."""
    gaps = np.asarray(gaps, dtype=np.int64)
    before = [slice(max(0, k + 1 - VELOCITY_BOXES), k + 1) for k in gaps.tolist()]
    after = [slice(k + 1, k + 1 + VELOCITY_BOXES) for k in gaps.tolist()]
    v_before = np.array([end_velocity(frames[s], boxes[s]) for s in before]).reshape(-1, 2)
    v_after = np.array([end_velocity(frames[s], boxes[s]) for s in after]).reshape(-1, 2)
    return motion_agreement(boxes[gaps], v_before, boxes[gaps + 1], v_after, frames[gaps + 1] - frames[gaps])


class Occluders:
    """What could hide a person the detector missed: one sequence's detections by frame, in the coordinates of the
    trajectories they are checked against (the reference frame when the camera moves).

    Boxes are ``x, y, w, h`` pixels, frames 1-based.
    """

    def __init__(self, detections: Detections) -> None:
        self.boxes = detections.boxes
        self._by_frame = detections.by_frame()

    def hide(self, frames: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """``(K,)`` True where a detection of the same 1-based frame overlaps the ``(K, 4)`` box and stands in front
        of it (its bottom edge as low as the box's, within :data:`FRONT_MARGIN` of the box's height)."""
        boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        near = [self._by_frame.get(int(f), _NONE) for f in np.asarray(frames).tolist()]
        owner = np.repeat(np.arange(len(near)), [len(n) for n in near])
        if not len(owner):
            return np.zeros(len(near), dtype=bool)
        box, other = boxes[owner], self.boxes[np.concatenate(near)]
        front = other[:, 1] + other[:, 3] >= box[:, 1] + box[:, 3] * (1.0 - FRONT_MARGIN)
        hit = front & (intersection_aligned(box, other) > 0)
        return np.bincount(owner[hit], minlength=len(near)) > 0


def occlusion_checked(config: PostprocessConfig, frame_rate: float | None, occluders: Occluders | None) -> bool:
    """Whether ``[postprocess] occlusion_seconds`` judges gaps: it is set, and there are a frame rate and
    ``occluders``."""
    return config.occlusion_seconds is not None and frame_rate is not None and occluders is not None


def judged_gaps(trajectory: Tracklet, config: PostprocessConfig, frame_rate: float | None,
                occluders: Occluders | None) -> np.ndarray:
    """Indices ``k`` of the gaps (after box ``k``) of ``trajectory`` that ``[postprocess] occlusion_seconds`` judges:
    those longer than it; none when there is no check, no frame rate or no ``occluders``."""
    if not occlusion_checked(config, frame_rate, occluders):
        return _NONE
    return np.flatnonzero(np.diff(trajectory.frames) > long_gap_frames(config.occlusion_seconds, frame_rate))


def long_gap_frames(seconds: float, frame_rate: float) -> int:
    """The frame difference a gap must exceed to be longer than ``seconds`` at ``frame_rate`` (at least 1): the
    gaps ``[postprocess] occlusion_seconds`` judges (:func:`judged_gaps`)."""
    return max(1, int(round(seconds * frame_rate)))


def seen_share(trajectory: Tracklet) -> float:
    """The share of the frames from ``trajectory``'s first to its last in which it has a box."""
    return len(trajectory) / float(trajectory.end - trajectory.start + 1)


def too_sparse(trajectory: Tracklet, config: PostprocessConfig) -> bool:
    """Whether ``trajectory`` has boxes in fewer than ``[postprocess] min_seen_share`` of its frames (then its gaps
    stay empty: :func:`unhidden`)."""
    return config.min_seen_share is not None and seen_share(trajectory) < config.min_seen_share


def unhidden(trajectory: Tracklet, frames: np.ndarray, boxes: np.ndarray, filled: np.ndarray,
             config: PostprocessConfig, frame_rate: float | None, occluders: Occluders | None) -> np.ndarray:
    """``(L,)`` True for each interpolated box of ``trajectory`` (expanded to ``frames``, ``boxes``, ``filled``) that
    ``[postprocess] occlusion_seconds`` takes out: in a gap longer than it whose straight line the walk around it
    does not lead along, or across which the box stood still (:func:`off_the_line`), with nothing in front that
    could hide the person (:meth:`Occluders.hide`); in every gap, short or long, when the trajectory is too sparse
    (:func:`too_sparse`). All False when there is no check, no frame rate or no ``occluders``."""
    out = np.zeros(len(frames), dtype=bool)
    if not occlusion_checked(config, frame_rate, occluders):
        return out
    if too_sparse(trajectory, config):
        return filled.copy()
    long = judged_gaps(trajectory, config, frame_rate, occluders) if filled.any() else _NONE
    if not len(long):
        return out
    t = trajectory
    gap = np.searchsorted(t.frames, frames) - 1  # the gap each interpolated box lies in (after box ``gap``)
    off_line = long[off_the_line(t.frames, t.boxes, long, config, frame_rate)]
    candidates = np.flatnonzero(filled & np.isin(gap, off_line))
    out[candidates] = ~occluders.hide(frames[candidates], boxes[candidates])
    return out


def expand(trajectory: Tracklet, config: PostprocessConfig = PostprocessConfig(),
           frame_rate: float | None = None, occluders: Occluders | None = None) -> Expanded:
    """The boxes of ``trajectory`` as post-processing writes them, interpolated if enabled (not smoothed).

    Gaps longer than ``interpolate_max_seconds`` at ``frame_rate`` stay gaps; in gaps longer than
    ``occlusion_seconds`` off the walk's line, boxes nothing in ``occluders`` could hide are left out, and every
    gap of a trajectory seen too little stays empty (:func:`unhidden`).
    """
    t = trajectory
    if not (config.interpolate and len(t) > 1):
        return Expanded(t.frames, t.boxes, t.scores, np.zeros(len(t), dtype=bool), t.det_index)
    frames, boxes, scores, filled = interpolate(t.frames, t.boxes, t.scores, max_interpolated_gap(config, frame_rate))
    keep = ~unhidden(t, frames, boxes, filled, config, frame_rate, occluders)
    frames, boxes, scores, filled = frames[keep], boxes[keep], scores[keep], filled[keep]
    det_index = np.full(len(frames), -1, dtype=np.int64)
    det_index[~filled] = t.det_index
    return Expanded(frames, boxes, scores, filled, det_index)


@dataclass(frozen=True)
class Gap:
    """One gap of a trajectory and what post-processing wrote in it (``sotmot explain`` prints it).

    Attributes
    ----------
    after, before
        The 1-based frames of the boxes around the gap (frames ``after + 1`` to ``before - 1`` had none).
    written
        Interpolated boxes written in the gap.
    left_out
        Boxes the occlusion check took out (``[postprocess] occlusion_seconds``).
    agreement
        The gap's motion agreement (:func:`gap_agreement`) when the occlusion check judged it, else None.
    why
        In words: which rule decided.
    """

    after: int
    before: int
    written: int
    left_out: int
    agreement: float | None
    why: str


def gaps_of(trajectory: Tracklet, config: PostprocessConfig = PostprocessConfig(), frame_rate: float | None = None,
            occluders: Occluders | None = None) -> list[Gap]:
    """Every gap of ``trajectory`` (frames without a box between two of its boxes) and what :func:`expand` wrote
    in it, with the rule that decided: interpolation off, longer than ``interpolate_max_seconds``, filled, or
    judged by the occlusion check (on the walk's line: filled on trust; off it: the boxes a detection in front could
    hide; a sparse trajectory's: left empty)."""
    t = trajectory
    gaps = np.flatnonzero(np.diff(t.frames) > 1)
    if not len(gaps):
        return []
    out = expand(t, config, frame_rate, occluders)
    written = np.bincount(np.searchsorted(t.frames, out.frames[out.filled]) - 1, minlength=len(t))
    limit = max_interpolated_gap(config, frame_rate)
    judged = judged_gaps(t, config, frame_rate, occluders)
    agreement, speed, off = {}, {}, {}
    if len(judged):
        a, v, o = judge_gaps(t.frames, t.boxes, judged, config, frame_rate)
        agreement, off = dict(zip(judged.tolist(), a.tolist())), dict(zip(judged.tolist(), o.tolist()))
        speed = {} if v is None else dict(zip(judged.tolist(), v.tolist()))
    report, sparse = [], occlusion_checked(config, frame_rate, occluders) and too_sparse(t, config)
    for k in gaps.tolist():
        length, n = int(t.frames[k + 1] - t.frames[k]) - 1, int(written[k])
        a = agreement.get(k)
        filled = config.interpolate and (limit is None or length + 1 <= limit)  # as interpolate's max_gap decides
        if not config.interpolate:
            why = "interpolation is off ([postprocess] interpolate)"
        elif not filled:
            why = (f"left empty: longer than [postprocess] interpolate_max_seconds = "
                   f"{config.interpolate_max_seconds:g} s ({limit} frames)")
        elif sparse:
            why = (f"left empty: the trajectory has boxes in {seen_share(t):.0%} of its frames, fewer than "
                   f"min_seen_share {config.min_seen_share:g} (no gap of a sparse trajectory is filled)")
        elif a is None:
            why = "interpolated"
        elif not off[k]:
            why = (f"interpolated on trust: the walk on both sides leads along the line (motion agreement {a:.3f} "
                   f">= min_agreement {config.min_agreement:g})")
        elif a >= config.min_agreement:
            why = (f"stood still across it ({speed[k]:.3f} heights per second < still_speed {config.still_speed:g}): "
                   f"a box is written only where a detection stands in front and could hide the person")
        else:
            why = (f"off the walk's line (motion agreement {a:.3f} < {config.min_agreement:g}): a box is written only "
                   f"where a detection stands in front and could hide the person")
        report.append(Gap(int(t.frames[k]), int(t.frames[k + 1]), n, length - n if filled else 0, a, why))
    return report


#: Scores the boxes of one expanded trajectory: ``(trajectory, expanded) -> (L,)`` probabilities.
BoxScorer = Callable[[Tracklet, Expanded], np.ndarray]


def to_tracks(trajectories: Sequence[Tracklet], detections: Detections,
              config: PostprocessConfig = PostprocessConfig(), scorer: BoxScorer | None = None,
              frame_rate: float | None = None, ids: Sequence[int | None] | None = None,
              occluders: Occluders | None = None) -> Tracks:
    """Post-process trajectories into the final :class:`Tracks`.

    Each trajectory is interpolated (if enabled; gaps up to
    ``interpolate_max_seconds`` when ``frame_rate`` is given) and smoothed, and
    written under the id :func:`output_ids` gives it (or dropped). With a
    ``scorer`` every box gets its probability of being a true positive in
    ``Tracks.confidence`` (the confirmation stage then chooses which to keep).
    ``ids``: :func:`output_ids` of the same trajectories, when the caller has them; ``occluders``: what can hide
    a person in long gaps (``[postprocess] occlusion_seconds``; in the trajectories' coordinates).
    """
    parts = []
    ids = output_ids(trajectories, config, frame_rate, occluders) if ids is None else ids
    for t, track_id in zip(trajectories, ids):
        if track_id is None:
            continue
        e = expand(t, config, frame_rate, occluders)
        sot = np.zeros(len(e.frames), dtype=bool)
        sot[~e.filled] = detections.from_sot[t.det_index]
        confidence = np.full(len(e.frames), np.nan) if scorer is None else scorer(t, e)
        boxes = smooth(e.frames, e.boxes, config.smooth_window, ~e.filled)
        parts.append((e.frames, np.full(len(e.frames), track_id), boxes, e.scores, e.filled, sot, confidence))
    if not parts:
        return Tracks.empty()
    parts.sort(key=lambda p: int(p[1][0]))
    cols = [np.concatenate(c) for c in zip(*parts)]
    return Tracks(*cols)
