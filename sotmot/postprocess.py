"""Post-processing of trajectories (paper Sec. 3.5): linear interpolation and smoothing.

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from sotmot.boxes import VELOCITY_BOXES, end_velocity, intersection_aligned, motion_agreement
from sotmot.config import PostprocessConfig
from sotmot.types import Detections, Tracklet, Tracks

#: A detection stands in front of a box when its bottom edge is no higher than the box's by more than this share
#: of the box's height (nearer the camera, so it can hide the person).
FRONT_MARGIN = 0.05
_NONE = np.zeros(0, dtype=np.int64)


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
        ``(L,)`` scores; a filled box gets the lower score of the two boxes
        around its gap.
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


def gap_agreement(frames: np.ndarray, boxes: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """``(K,)`` motion agreement (:func:`~sotmot.boxes.motion_agreement`, up to :data:`~sotmot.boxes.VELOCITY_BOXES`
    boxes each side) of the gaps after boxes ``gaps`` ``(K,)`` of one trajectory's ``(L,)`` 1-based ``frames`` and
    ``(L, 4)`` ``x, y, w, h`` ``boxes``: how well the straight line through each gap fits the walk around it."""
    gaps = np.asarray(gaps, dtype=np.int64)
    before = [slice(max(0, k + 1 - VELOCITY_BOXES), k + 1) for k in gaps.tolist()]
    after = [slice(k + 1, k + 1 + VELOCITY_BOXES) for k in gaps.tolist()]
    return motion_agreement(boxes[gaps], np.array([end_velocity(frames[s], boxes[s]) for s in before]).reshape(-1, 2),
                            boxes[gaps + 1], np.array([end_velocity(frames[s], boxes[s]) for s in after]).reshape(-1, 2),
                            frames[gaps + 1] - frames[gaps])


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


def judged_gaps(trajectory: Tracklet, config: PostprocessConfig, frame_rate: float | None,
                occluders: Occluders | None) -> np.ndarray:
    """Indices ``k`` of the gaps (after box ``k``) of ``trajectory`` that ``[postprocess] occlusion_seconds`` judges:
    those longer than it; none when there is no check, no frame rate or no ``occluders``."""
    if config.occlusion_seconds is None or frame_rate is None or occluders is None:
        return _NONE
    return np.flatnonzero(np.diff(trajectory.frames) > long_gap_frames(config.occlusion_seconds, frame_rate))


def long_gap_frames(seconds: float, frame_rate: float) -> int:
    """The frame difference a gap must exceed to be longer than ``seconds`` at ``frame_rate`` (at least 1): the
    gaps ``[postprocess] occlusion_seconds`` judges (:func:`judged_gaps`)."""
    return max(1, int(round(seconds * frame_rate)))


def unhidden(trajectory: Tracklet, frames: np.ndarray, boxes: np.ndarray, filled: np.ndarray,
             config: PostprocessConfig, frame_rate: float | None, occluders: Occluders | None) -> np.ndarray:
    """``(L,)`` True for each interpolated box of ``trajectory`` (expanded to ``frames``, ``boxes``, ``filled``) that
    ``[postprocess] occlusion_seconds`` takes out: in a gap longer than it whose straight line the walk around it
    does not lead along (:func:`gap_agreement` below ``min_agreement``), with nothing in front that could hide the
    person (:meth:`Occluders.hide`). All False when there is no check, no frame rate or no ``occluders``."""
    out = np.zeros(len(frames), dtype=bool)
    long = judged_gaps(trajectory, config, frame_rate, occluders) if filled.any() else _NONE
    if not len(long):
        return out
    t = trajectory
    off_line = long[gap_agreement(t.frames, t.boxes, long) < config.min_agreement]
    gap = np.searchsorted(t.frames, frames) - 1  # the gap each interpolated box lies in (after box ``gap``)
    candidates = np.flatnonzero(filled & np.isin(gap, off_line))
    out[candidates] = ~occluders.hide(frames[candidates], boxes[candidates])
    return out


def expand(trajectory: Tracklet, config: PostprocessConfig = PostprocessConfig(),
           frame_rate: float | None = None, occluders: Occluders | None = None) -> Expanded:
    """The boxes of ``trajectory`` as post-processing writes them, interpolated if enabled (not smoothed).

    Gaps longer than ``interpolate_max_seconds`` at ``frame_rate`` stay gaps; in gaps longer than
    ``occlusion_seconds`` off the walk's line, boxes nothing in ``occluders`` could hide are left out
    (:func:`unhidden`).
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
    hide)."""
    t = trajectory
    gaps = np.flatnonzero(np.diff(t.frames) > 1)
    if not len(gaps):
        return []
    out = expand(t, config, frame_rate, occluders)
    written = np.bincount(np.searchsorted(t.frames, out.frames[out.filled]) - 1, minlength=len(t))
    limit = max_interpolated_gap(config, frame_rate)
    judged = judged_gaps(t, config, frame_rate, occluders)
    agreement = dict(zip(judged.tolist(), gap_agreement(t.frames, t.boxes, judged).tolist()))
    report = []
    for k in gaps.tolist():
        length, n = int(t.frames[k + 1] - t.frames[k]) - 1, int(written[k])
        a = agreement.get(k)
        filled = config.interpolate and (limit is None or length + 1 <= limit)  # as interpolate's max_gap decides
        if not config.interpolate:
            why = "interpolation is off ([postprocess] interpolate)"
        elif not filled:
            why = (f"left empty: longer than [postprocess] interpolate_max_seconds = "
                   f"{config.interpolate_max_seconds:g} s ({limit} frames)")
        elif a is None:
            why = "interpolated"
        elif a >= config.min_agreement:
            why = (f"interpolated on trust: the walk on both sides leads along the line (motion agreement {a:.3f} "
                   f">= min_agreement {config.min_agreement:g})")
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
        boxes = smooth(e.frames, e.boxes, config.smooth_window)
        parts.append((e.frames, np.full(len(e.frames), track_id), boxes, e.scores, e.filled, sot, confidence))
    if not parts:
        return Tracks.empty()
    parts.sort(key=lambda p: int(p[1][0]))
    cols = [np.concatenate(c) for c in zip(*parts)]
    return Tracks(*cols)
