"""Detection confidence (stage 1 of :mod:`sotmot.confidence`): detector scores mapped monotonically to [0, 1].

A stored map per detector family (``[preprocess] confidence``), the score's rank
in the sequence (``"quantile"``), the scores as they are (``"raw"``), or a map
fitted on the sequence from what association made of it (``"self"``, with the
one fit that runs at tracking time, :func:`isotonic`).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import logging
import typing
from collections.abc import Sequence

import numpy as np

from sotmot.boxes import centers
from sotmot.confidence.calibration import Calibration, load_calibration
from sotmot.config import ConfidenceMethod
from sotmot.errors import ConfigError
from sotmot.types import Detections, Tracklet

log = logging.getLogger(__name__)

#: Detector families with a stored calibration, and the names ``[preprocess] confidence`` accepts. ``pd0202`` is
#: the built-in detector (Intel's person-detection-0202): never guessed from scores, known from the detector run.
METHODS: tuple[str, ...] = typing.get_args(ConfidenceMethod)
FAMILIES = METHODS[4:]


def scores_are_uninformative(scores: np.ndarray) -> bool:
    """Whether every detection has the same score (a detector file that carries none, ``-1`` or ``1`` on every
    row): no family can be told from it and no box ranked by it."""
    scores = np.asarray(scores)
    return len(scores) > 1 and bool(scores.min() == scores.max())


def scores_are_flags(scores: np.ndarray) -> bool:
    """Whether the detections' scores take exactly two values (MOT20's public detections: 0 or 1): a flag, not a
    detector's ranking, so no family's map, fitted on a detector's continuous scores, can read it (the ``frcnn``
    map read MOT20-01's 0 as a weak box: 8,243 of its 12,610 boxes, 92 % of them on a person against 90 % of
    its 1s)."""
    return len(np.unique(np.asarray(scores))) == 2


def scores_are_probabilities(scores: np.ndarray) -> bool:
    """Whether detection scores all lie in [0, 1] (the public DPM and ACF detections' do not): the one test
    behind NMS ``auto`` (IoU for probabilities, IoM otherwise) and the ``frcnn`` family guess."""
    scores = np.asarray(scores)
    return not len(scores) or bool(scores.min() >= 0.0 and scores.max() <= 1.0)


#: MOTChallenge names a sequence's public detector at the end of its name (``MOT17-09-SDP``).
NAMED_FAMILIES = {"DPM": "dpm", "FRCNN": "frcnn", "SDP": "sdp"}


def family_from_name(name: str) -> str | None:
    """The detector family a sequence's name gives (``MOT17-04-SDP`` -> ``"sdp"``), or None."""
    return NAMED_FAMILIES.get(name.rsplit("-", 1)[-1].upper()) if "-" in name else None


def detector_family(scores: np.ndarray, name: str = "") -> str:
    """The detector family of a sequence's detections (``"auto"`` confidence): named, else guessed.

    The sequence ``name`` says it when it ends in a MOTChallenge detector's
    name (:data:`NAMED_FAMILIES`). Otherwise the score range decides: all in
    [0, 1]: ``"frcnn"`` (a probability-like detector); any score above 10:
    ``"acf"`` (the 2DMOT2015 ACF detections reach about 127); otherwise
    ``"dpm"`` (MOT16's public DPM, about -1 to 5). Name the family in the
    config (``[preprocess] confidence``) when it is known.
    """
    named = family_from_name(name)
    if named is not None:
        return named
    if scores_are_probabilities(scores):
        return "frcnn"
    return "acf" if np.max(scores) > 10.0 else "dpm"


def isotonic(x: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Monotone (non-decreasing) least-squares fit of ``y`` on ``x`` by pool-adjacent-violators.

    Returns knots ``(xs, ys)``: the mean ``x`` and fitted ``y`` of each pooled
    block, both increasing, for :func:`numpy.interp` (which keeps the map
    monotone and continuous between knots, flat beyond them).
    """
    order = np.argsort(np.asarray(x, dtype=np.float64), kind="stable")
    x = np.asarray(x, dtype=np.float64)[order]
    y = np.asarray(y, dtype=np.float64)[order]
    w = np.ones(len(x)) if weights is None else np.asarray(weights, dtype=np.float64)[order]
    blocks: list[list[float]] = []  # [sum w*y, sum w, sum w*x]
    for xi, yi, wi in zip(x, y, w):
        blocks.append([wi * yi, wi, wi * xi])
        while len(blocks) > 1 and blocks[-2][0] / blocks[-2][1] >= blocks[-1][0] / blocks[-1][1]:
            last = blocks.pop()
            blocks[-1] = [a + b for a, b in zip(blocks[-1], last)]
    xs = np.array([b[2] / b[1] for b in blocks])
    ys = np.array([b[0] / b[1] for b in blocks])
    return xs, ys


def quantile_map(reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knots of the empirical CDF of ``reference`` scores (mid-ranks in (0, 1); ties share a value)."""
    ref = np.sort(np.asarray(reference, dtype=np.float64))
    if not len(ref):
        return np.array([0.0]), np.array([0.5])
    values, first = np.unique(ref, return_index=True)
    last = np.r_[first[1:], len(ref)]
    return values, (first + last) / (2.0 * len(ref))


def confidence_knots(method: str, reference: np.ndarray, calibration: Calibration | None = None,
                     family: str | None = None, name: str = "") -> tuple[str, tuple[np.ndarray, np.ndarray] | None]:
    """Resolve ``method`` for a sequence: the method actually used and its knots (None for ``"raw"``, but for
    scores all the same, below).

    ``reference`` are the sequence's detector scores (the quantile map and
    ``"auto"`` look at them). ``"auto"`` takes the map of ``family`` when the
    detector is known (the built-in one), else of :func:`detector_family` (the
    sequence ``name``, then the scores), or ``"self"`` when ``calibration`` has
    none for that family (held out, a detector never seen: self-fitted maps
    tracked better than the ranks, ``scripts/transfer_confidence.py``). When
    every score is the same (:func:`scores_are_uninformative`: a detector file
    that carries none) ``"auto"`` gives ``"raw"`` with every box at confidence
    1, a box the detector stands behind, whatever the one value is: a family's
    map would read it as that score from its detector (a file of ``-1``
    throughout, read as DPM's, had every box dropped). When the scores take
    two values only (:func:`scores_are_flags`) ``"auto"`` gives ``"self"``:
    what each of the two means is learnt from the sequence's own trajectories.
    """
    if method not in METHODS:
        raise ConfigError(f"[preprocess] confidence must be one of {', '.join(METHODS)}; got {method!r}")
    if method not in ("raw", "quantile"):
        calibration = calibration or load_calibration()
    if method == "auto" and family is None and scores_are_uninformative(reference):
        value = float(np.asarray(reference)[0])
        log.warning("%s: every detection scores %g, so the scores tell nothing: each box is taken as one the detector "
                    "stands behind (confidence 1; the confirmation judges its trajectory)", name or "detections", value)
        return "raw", (np.array([value]), np.array([1.0]))
    if method == "auto" and family is None and scores_are_flags(reference):
        log.warning("%s: the detections' scores take two values only (%s), a flag rather than a detector's "
                    "ranking: what each means is learnt from this sequence's trajectories (confidence 'self')",
                    name or "detections", " and ".join(f"{v:g}" for v in np.unique(reference)))
        method = "self"
    if method == "auto":
        method = family or detector_family(reference, name)
        if method not in calibration.families:  # a family the calibration never saw: learn it from the sequence
            method = "self"
    if method == "raw":
        return method, None
    if method in ("quantile", "self"):  # "self": the ranks until association has run (then self_knots)
        return method, quantile_map(reference)
    if method not in calibration.families:
        raise ConfigError(f"no stored calibration for detector family {method!r} (have: "
                          f"{', '.join(sorted(calibration.families))}); use confidence = 'quantile'")
    xs, ys = calibration.families[method]
    return method, (np.asarray(xs), np.asarray(ys))


#: ``"self"`` confidence: a detection in a trajectory spanning at least this long (seconds) counts as true, one in
#: no trajectory or in one shorter than ``SELF_SHORT_SECONDS`` as false; those between teach nothing.
SELF_LONG_SECONDS = 2.0
SELF_SHORT_SECONDS = 0.5
#: A long trajectory whose centre stays within this share of its median box height (both ways) stands still: a
#: person waiting or a fixed object the detector keeps firing on, so it teaches nothing. A walker covers about
#: 0.8 of their height a second, so even a slow one leaves this spot within :data:`SELF_LONG_SECONDS`.
SELF_STILL_EXTENT = 0.5
#: The fewest detections of each kind a ``"self"`` map needs; with fewer the ranks (quantile map) stay.
SELF_MIN_SAMPLES = 20


def self_labels(n_detections: int, trajectories: Sequence[Tracklet], from_sot: np.ndarray,
                frame_rate: float) -> np.ndarray:
    """``(N,)`` pseudo-labels of a sequence's detections from its trajectories: 1 true, 0 false, -1 unknown.

    The tracker's own evidence, no ground truth: a person seen walking for
    :data:`SELF_LONG_SECONDS` or more is there; a box that joined no
    trajectory (a lone box) or a trajectory shorter than
    :data:`SELF_SHORT_SECONDS` is most likely not. A long trajectory that
    never leaves its spot (:data:`SELF_STILL_EXTENT`) teaches nothing: a
    detector that keeps firing on a fixed object makes one (MOT16-09's DPM:
    the longest trajectory, 17 s, is a false one that jitters in place), and
    taking it for a person made the map trust low scores (Brier score against
    the ground truth 0.133, 0.091 without them; ``docs/calibration.md``).
    Positions are the trajectories' own (after camera-motion compensation,
    when the camera moved). SOT boxes are left out.
    """
    labels = np.zeros(n_detections, dtype=np.int64)
    for t in trajectories:
        seconds = (t.end - t.start + 1) / frame_rate
        if seconds >= SELF_LONG_SECONDS:
            labels[t.det_index] = -1 if stands_still(t.boxes) else 1
        elif seconds >= SELF_SHORT_SECONDS:
            labels[t.det_index] = -1
    labels[np.asarray(from_sot, dtype=bool)] = -1
    return labels


def stands_still(boxes: np.ndarray) -> bool:
    """Whether ``(L, 4)`` ``x, y, w, h`` boxes keep their centre within :data:`SELF_STILL_EXTENT` of their median
    height, horizontally and vertically."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not len(boxes):
        return True
    extent = np.ptp(centers(boxes), axis=0).max()
    return bool(extent < SELF_STILL_EXTENT * np.median(boxes[:, 3]))


def self_knots(scores: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Monotone map of ``scores`` to the share of :func:`self_labels`' true ones; None with too few of either."""
    known = labels >= 0
    if (labels[known] == 1).sum() < SELF_MIN_SAMPLES or (labels[known] == 0).sum() < SELF_MIN_SAMPLES:
        return None
    return isotonic(np.asarray(scores, dtype=np.float64)[known], labels[known].astype(np.float64))


def self_map(detections: Detections, trajectories: Sequence[Tracklet],
             frame_rate: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The ``"self"`` knots of a sequence's ``detections`` from what association made of them (its
    ``trajectories``): :func:`self_labels`, then :func:`self_knots`; None when the sequence teaches too little."""
    return self_knots(detections.scores, self_labels(len(detections), trajectories, detections.from_sot, frame_rate))


def detection_confidence(scores: np.ndarray, knots: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """Confidences in [0, 1] of ``scores`` through monotone ``knots`` (None: scores clipped to [0, 1])."""
    scores = np.asarray(scores, dtype=np.float64)
    if knots is None:
        return np.clip(scores, 0.0, 1.0)
    return np.clip(np.interp(scores, knots[0], knots[1]), 0.0, 1.0)
