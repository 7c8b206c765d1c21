"""Small data types that say what they hold.

Conventions everywhere in sotmot: boxes are ``x, y, w, h`` in pixels with a
top-left origin; frame numbers are 1-based, as in MOTChallenge files.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from functools import cached_property

import numpy as np


def _readonly(*arrays: np.ndarray) -> None:
    for a in arrays:
        a.setflags(write=False)


def rows_by_frame(frames: np.ndarray) -> dict[int, np.ndarray]:
    """Map each 1-based frame number in ``frames`` (one per row) to the indices of its rows (ascending)."""
    frames = np.asarray(frames)
    if len(frames) == 0:
        return {}
    order = np.argsort(frames, kind="stable")
    f = frames[order]
    starts = np.flatnonzero(np.r_[True, f[1:] != f[:-1]])
    ends = np.r_[starts[1:], len(f)]
    # a stable sort keeps each frame's rows in ascending order already
    return {int(f[s]): order[s:e].copy() for s, e in zip(starts, ends)}


@dataclass(frozen=True, eq=False)
class Detections:
    """A set of detection boxes of one sequence.

    Attributes
    ----------
    frames
        ``(N,)`` int64, 1-based frame number of each box.
    boxes
        ``(N, 4)`` float64, ``x, y, w, h`` in pixels.
    scores
        ``(N,)`` float64 detector confidence (any real range: DPM scores are not
        probabilities).
    from_sot
        ``(N,)`` bool, True for boxes added by the single-object-tracking step
        rather than by the detector.
    """

    frames: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    from_sot: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        frames = np.asarray(self.frames, dtype=np.int64).reshape(-1)
        boxes = np.asarray(self.boxes, dtype=np.float64).reshape(-1, 4)
        scores = np.asarray(self.scores, dtype=np.float64).reshape(-1)
        from_sot = (np.zeros(len(frames), dtype=bool) if self.from_sot is None
                    else np.asarray(self.from_sot, dtype=bool).reshape(-1))
        if not (len(frames) == len(boxes) == len(scores) == len(from_sot)):
            raise ValueError(
                f"Detections columns differ in length: frames {len(frames)}, boxes {len(boxes)}, "
                f"scores {len(scores)}, from_sot {len(from_sot)}")
        object.__setattr__(self, "frames", frames)
        object.__setattr__(self, "boxes", boxes)
        object.__setattr__(self, "scores", scores)
        object.__setattr__(self, "from_sot", from_sot)
        _readonly(frames, boxes, scores, from_sot)

    def __len__(self) -> int:
        return len(self.frames)

    def subset(self, index: np.ndarray) -> "Detections":
        """The boxes selected by an integer or boolean ``index``, in that order."""
        return Detections(self.frames[index], self.boxes[index], self.scores[index], self.from_sot[index])

    def sorted(self) -> "Detections":
        """The same boxes ordered by frame, then by descending score, then by box.

        A canonical order makes every later stage independent of the order of
        lines in the input file.
        """
        return self.subset(self.canonical_order())

    def canonical_order(self) -> np.ndarray:
        """The permutation :meth:`sorted` applies: by frame, then descending score, then box."""
        b = self.boxes
        return np.lexsort((b[:, 3], b[:, 2], b[:, 1], b[:, 0], -self.scores, self.frames))

    def by_frame(self) -> dict[int, np.ndarray]:
        """Map each frame number that has boxes to the indices of its boxes (ascending)."""
        return rows_by_frame(self.frames)


@dataclass(frozen=True, eq=False)
class Tracklet:
    """A trajectory piece: at most one box per frame, frames strictly increasing.

    Attributes
    ----------
    id
        Identifier, unique within one run of the tracker.
    frames
        ``(L,)`` int64, 1-based frames, strictly increasing (gaps allowed).
    boxes
        ``(L, 4)`` float64, ``x, y, w, h`` pixels.
    scores
        ``(L,)`` float64 detection score of each box.
    det_index
        ``(L,)`` int64 index of each box in the :class:`Detections` it came from.
    feature
        ``(D,)`` float32 mean appearance feature of the tracklet's detections
        (not re-normalised; see :func:`sotmot.appearance.affinity`).
    n_features
        How many detection features the mean is over (to merge means exactly).
    """

    id: int
    frames: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    det_index: np.ndarray
    feature: np.ndarray
    n_features: int

    def __post_init__(self) -> None:
        frames = np.asarray(self.frames, dtype=np.int64).reshape(-1)
        boxes = np.asarray(self.boxes, dtype=np.float64).reshape(-1, 4)
        scores = np.asarray(self.scores, dtype=np.float64).reshape(-1)
        det_index = np.asarray(self.det_index, dtype=np.int64).reshape(-1)
        feature = np.asarray(self.feature, dtype=np.float32).reshape(-1)
        if not (len(frames) == len(boxes) == len(scores) == len(det_index)) or len(frames) == 0:
            raise ValueError(f"tracklet {self.id}: columns empty or of different lengths")
        if np.any(np.diff(frames) <= 0):
            raise ValueError(f"tracklet {self.id}: frames must be strictly increasing")
        if not np.isfinite(feature).all():
            raise ValueError(f"tracklet {self.id}: its appearance feature has NaN or infinite values")
        for name, value in (("frames", frames), ("boxes", boxes), ("scores", scores),
                            ("det_index", det_index), ("feature", feature)):
            object.__setattr__(self, name, value)
        _readonly(frames, boxes, scores, det_index, feature)

    def __len__(self) -> int:
        return len(self.frames)

    @property
    def start(self) -> int:
        """First frame (1-based)."""
        return int(self.frames[0])

    @cached_property
    def max_gap(self) -> int:
        """Largest frame difference between consecutive boxes (0 for a single box)."""
        return int(np.diff(self.frames).max()) if len(self.frames) > 1 else 0

    @property
    def end(self) -> int:
        """Last frame (1-based)."""
        return int(self.frames[-1])


@dataclass(frozen=True, eq=False)
class Tracks:
    """Tracker output: one row per box, as written to a MOTChallenge results file.

    Attributes
    ----------
    frames
        ``(N,)`` int64 1-based frames.
    ids
        ``(N,)`` int64 track identities (1-based in written files).
    boxes
        ``(N, 4)`` float64 ``x, y, w, h`` pixels.
    scores
        ``(N,)`` float64 confidence (detection score; interpolated boxes carry
        the lower score of their neighbours).
    interpolated
        ``(N,)`` bool, True for boxes filled in by post-processing.
    from_sot
        ``(N,)`` bool, True for boxes that came from the SOT step.
    confidence
        ``(N,)`` float64 probability that the box is a true positive, from the
        confirmation stage (:mod:`sotmot.confidence`); NaN where not computed.
    """

    frames: np.ndarray
    ids: np.ndarray
    boxes: np.ndarray
    scores: np.ndarray
    interpolated: np.ndarray = field(default=None)  # type: ignore[assignment]
    from_sot: np.ndarray = field(default=None)  # type: ignore[assignment]
    confidence: np.ndarray = field(default=None)  # type: ignore[assignment]

    def __post_init__(self) -> None:
        n = len(np.asarray(self.frames).reshape(-1))
        cols = {
            "frames": np.asarray(self.frames, dtype=np.int64).reshape(-1),
            "ids": np.asarray(self.ids, dtype=np.int64).reshape(-1),
            "boxes": np.asarray(self.boxes, dtype=np.float64).reshape(-1, 4),
            "scores": np.asarray(self.scores, dtype=np.float64).reshape(-1),
            "interpolated": (np.zeros(n, bool) if self.interpolated is None
                             else np.asarray(self.interpolated, dtype=bool).reshape(-1)),
            "from_sot": (np.zeros(n, bool) if self.from_sot is None
                         else np.asarray(self.from_sot, dtype=bool).reshape(-1)),
            "confidence": (np.full(n, np.nan) if self.confidence is None
                           else np.asarray(self.confidence, dtype=np.float64).reshape(-1)),
        }
        if any(len(v) != n for v in cols.values()):
            raise ValueError("Tracks columns differ in length")
        for name, value in cols.items():
            object.__setattr__(self, name, value)
        _readonly(*cols.values())

    def __len__(self) -> int:
        return len(self.frames)

    @classmethod
    def empty(cls) -> "Tracks":
        """No boxes."""
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 4)), np.zeros(0))

    def subset(self, index: np.ndarray) -> "Tracks":
        """The rows selected by an integer or boolean ``index``."""
        return Tracks(self.frames[index], self.ids[index], self.boxes[index], self.scores[index],
                      self.interpolated[index], self.from_sot[index], self.confidence[index])

    @classmethod
    def concatenate(cls, parts: "Sequence[Tracks]") -> "Tracks":
        """The rows of ``parts`` one after another (in the order given); no parts: :meth:`empty`."""
        if not parts:
            return cls.empty()
        return cls(**{f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(cls)})

    def with_boxes(self, boxes: np.ndarray) -> "Tracks":
        """The same rows with other ``(N, 4)`` boxes (e.g. mapped to another frame of reference)."""
        return Tracks(self.frames, self.ids, boxes, self.scores, self.interpolated, self.from_sot, self.confidence)

    def to_lists(self) -> list[list]:
        """The columns as JSON-ready lists (NaN confidence as None), in field order: what a run record keeps of
        boxes a resumed run needs (:meth:`from_lists`)."""
        return [self.frames.tolist(), self.ids.tolist(), self.boxes.tolist(), self.scores.tolist(),
                self.interpolated.tolist(), self.from_sot.tolist(),
                [None if np.isnan(v) else v for v in self.confidence.tolist()]]

    @classmethod
    def from_lists(cls, columns: "Sequence[list]") -> "Tracks":
        """The tracks :meth:`to_lists` wrote."""
        frames, ids, boxes, scores, interpolated, from_sot, confidence = columns
        return cls(np.asarray(frames, np.int64), np.asarray(ids, np.int64),
                   np.asarray(boxes, np.float64).reshape(-1, 4), scores, interpolated, from_sot,
                   [np.nan if v is None else v for v in confidence])

    @property
    def n_tracks(self) -> int:
        """Number of distinct identities."""
        return int(len(np.unique(self.ids)))
