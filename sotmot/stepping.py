"""Tracking every k-th frame (``[input] step``, ``--step``): frames 1, 1 + k, 1 + 2k, ... tracked as a sequence
of their own at the frame rate divided by k, and the tracks' boxes put back on every frame.

Every stage sees only the tracked frames, so a run costs about a k-th of the time: re-ID and the detector take
nearly all of it (docs/benchmarks.md, "Speed"), and a camera faster than the tracker can be kept up with
(``sotmot track --live``). A frame between two tracked ones gets each track's box on the straight line between
that track's boxes in the tracked frames around it (:func:`sotmot.postprocess.interpolate`, flagged
``interpolated``, its score and confidence the lower of the two); a track absent from either of them gets none
there, and the frames after the last tracked one (fewer than ``step``) hold its boxes (:meth:`Densifier.tail`).
A detections file's rows of the frames between are not used. Frames are 1-based and boxes ``x, y, w, h`` pixels,
as everywhere.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from sotmot.config import TrackerConfig
from sotmot.io import SeqInfo
from sotmot.postprocess import interpolate
from sotmot.types import Detections, Tracks


def tracked_count(length: int, step: int) -> int:
    """How many of frames ``1..length`` are tracked at every ``step``-th frame (frames 1, 1 + step, ...)."""
    return (length - 1) // step + 1 if length > 0 else 0


def full_frames(frames: np.ndarray | int, step: int) -> np.ndarray:
    """The sequence's frame numbers of the tracked frames ``frames`` (an array, or one frame; numbered 1, 2, ... as
    the stepped run counts them): ``1 + (f - 1) * step``."""
    return 1 + (np.asarray(frames, dtype=np.int64) - 1) * step


class SteppedFrames:
    """Tracked frames ``start, start + 1, ...`` of a sequence tracked at every ``step``-th frame, as a sequence of
    their own (``frames[k]`` is tracked frame ``start + k``, the sequence's frame ``1 + (start - 1 + k) * step``),
    each read by ``read`` (1-based frame of the sequence -> BGR image) when a stage asks for it. A window of the
    sequence (:func:`sotmot.windows.window_sequence`) is one at step 1."""

    def __init__(self, read: Callable[[int], Any], step: int, length: int, start: int = 1) -> None:
        self.read, self.step, self.length, self.start = read, step, length, start

    def __len__(self) -> int:
        return self.length

    def __getitem__(self, index: int) -> Any:
        if not 0 <= index < self.length:
            raise IndexError(f"tracked frame {index + 1} of {self.length}")
        return self.read(int(full_frames(self.start + index, self.step)))


def stepped_sequence(info: SeqInfo, step: int, read: Callable[[int], Any] | None = None) -> SeqInfo:
    """``info``'s every ``step``-th frame as a sequence of its own: ``length`` the tracked frames, ``frame_rate``
    divided by ``step``, everything else kept. A folder's frames are its own image files (decoded as the folder's
    are); a video's or frames held in memory are read by ``read`` (a :class:`sotmot.io.frames.FrameReader` of
    ``info``, which the caller closes); a sequence without frames (labels only) has none to read."""
    length = tracked_count(info.length, step)
    stepped = dataclasses.replace(info, length=length, frame_rate=info.frame_rate / step)
    if info.frames is None and info.video is None:
        if info.files is None and not info.frames_dir.is_dir():
            return stepped  # no frames at all (labels only, the motion-only mode)
        return dataclasses.replace(stepped, files=tuple(info.frame_path(1 + k * step) for k in range(length)))
    if read is None:
        raise ValueError(f"{info.name}: a video's frames or frames in memory are read by a reader")
    return dataclasses.replace(stepped, frames=SteppedFrames(read, step, length))


def stepped_detections(detections: Detections, step: int) -> Detections:
    """The rows of the tracked frames, renumbered as the stepped run counts them; the others are left out."""
    keep = (detections.frames - 1) % step == 0
    part = detections.subset(np.flatnonzero(keep))
    return dataclasses.replace(part, frames=(part.frames - 1) // step + 1)


def at_full_frames(tracks: Tracks, step: int) -> Tracks:
    """``tracks`` of the tracked frames with the sequence's frame numbers (no box added)."""
    return dataclasses.replace(tracks, frames=full_frames(tracks.frames, step))


def detections_at_full_frames(detections: Detections | None, step: int) -> Detections | None:
    """:func:`at_full_frames` of detections (None stays None)."""
    if detections is None:
        return None
    return dataclasses.replace(detections, frames=full_frames(detections.frames, step))


class Densifier:
    """Puts a stepped run's boxes back on every frame, part after part (a whole run is one part; a stream's
    committed windows are several): each part's tracks at the sequence's frame numbers with the frames between
    filled, those between the part's first tracked frame and the tracked frame before it too, from the boxes
    that frame had (kept from the part before; ids are the same across parts)."""

    def __init__(self, step: int) -> None:
        self.step = step
        self._before = Tracks.empty()  # the last part's boxes of its last tracked frame, at full frame numbers

    def state(self) -> list[list]:
        """What putting back the next part needs, as JSON (a resumed run's :meth:`from_state`)."""
        return self._before.to_lists()

    @classmethod
    def from_state(cls, step: int, state: list[list]) -> "Densifier":
        """The densifier :meth:`state` describes."""
        densifier = cls(step)
        densifier._before = Tracks.from_lists(state)
        return densifier

    def add(self, tracks: Tracks, last: int) -> Tracks:
        """``tracks`` of tracked frames up to ``last`` (numbered as the stepped run counts them) on every frame:
        the frames from the one after the last part's last tracked frame to this part's last tracked frame."""
        full = at_full_frames(tracks, self.step)
        both = Tracks.concatenate([self._before, full])
        out = []
        for track in np.unique(both.ids):
            rows = np.flatnonzero(both.ids == track)
            rows = rows[np.argsort(both.frames[rows], kind="stable")]
            frames = both.frames[rows]
            if len(rows) == 1:  # one box: nothing to fill
                out.append(both.subset(rows))
                continue
            kinds = np.stack([both.scores[rows], both.confidence[rows]], axis=1)
            filled_frames, boxes, kinds, filled = interpolate(frames, both.boxes[rows], kinds, max_gap=self.step)
            scores, confidence = kinds[:, 0].copy(), kinds[:, 1].copy()
            at = np.searchsorted(frames, filled_frames, side="right") - 1  # the box before (or at) each frame
            out.append(Tracks(filled_frames, np.full(len(filled_frames), track), boxes, scores,
                              both.interpolated[rows][at] | filled, both.from_sot[rows][at] & ~filled,
                              confidence))
        dense = Tracks.concatenate(out) if out else Tracks.empty()
        dense = dense.subset(dense.frames > (self._before.frames.max() if len(self._before) else 0))
        end = int(full_frames(last, self.step))
        self._before = full.subset(full.frames == end)
        return dense.subset(np.lexsort((dense.frames, dense.ids)))  # by track, then frame, as a run's are

    def put_back(self, tracks: Tracks, dropped: Tracks, detected: Detections | None, last: int,
                 until: int = 0) -> tuple[Tracks, Tracks, Detections | None]:
        """One part of a stepped run, up to tracked frame ``last``, at the sequence's frame numbers: its ``tracks``
        on every frame (:meth:`add`), its unconfirmed boxes ``dropped`` and the detector's boxes ``detected``
        (None stays None) renumbered, no box added. ``until``: the run's last part, and the sequence's last
        frame, whose frames after the last tracked one get :meth:`tail`'s boxes."""
        dense = self.add(tracks, last)
        if until:
            dense = Tracks.concatenate([dense, self.tail(until)])
            dense = dense.subset(np.lexsort((dense.frames, dense.ids)))
        return dense, at_full_frames(dropped, self.step), detections_at_full_frames(detected, self.step)

    def tail(self, until: int) -> Tracks:
        """The boxes of the last tracked frame (the last part's) held on each frame after it up to ``until``, the
        sequence's last frame (fewer than ``step`` frames), flagged interpolated: a person tracked there is still
        there a fraction of a second later, where a run at every frame has a box. By track, then frame."""
        before = self._before
        if not len(before):
            return Tracks.empty()
        frames = np.arange(int(before.frames.max()) + 1, until + 1)
        rows = np.repeat(np.arange(len(before)), len(frames))
        held = dataclasses.replace(before.subset(rows), frames=np.tile(frames, len(before)),
                                   interpolated=np.ones(len(rows), bool), from_sot=np.zeros(len(rows), bool))
        return held.subset(np.lexsort((held.frames, held.ids)))


def counted(frames: Iterator) -> tuple[Iterator, Callable[[], int]]:
    """``frames`` passed on, and a function that says how many have passed."""
    seen = [0]

    def passing() -> Iterator:
        for frame in frames:
            seen[0] += 1
            yield frame

    return passing(), lambda: seen[0]


def track_whole(info: SeqInfo, config: TrackerConfig, embedder=None, progress=False,
                detections: Detections | None = None):
    """A whole sequence tracked (no windows): :func:`sotmot.pipeline.track_sequence` of ``info``, or with
    ``[input] step`` above 1 :func:`track_stepped`. ``detections``: handed over (the sequence's frame numbers),
    else the run's detections file or the detector."""
    from sotmot.pipeline import track_sequence

    if config.input.step == 1:
        return track_sequence(info, config, embedder=embedder, progress=progress, detections=detections)
    return track_stepped(info, config, embedder, progress, detections)


def track_stepped(info: SeqInfo, config: TrackerConfig, embedder=None, progress=False,
                  detections: Detections | None = None):
    """:func:`sotmot.pipeline.track_sequence` of ``info`` at every ``[input] step``-th frame: the
    :class:`~sotmot.pipeline.TrackResult` of the tracked frames (:func:`track_tracked_frames`) whose ``tracks`` are
    on every frame (:class:`Densifier`) and whose ``dropped`` and ``detected`` boxes have the sequence's frame
    numbers."""
    result = track_tracked_frames(info, config, embedder, progress, detections)
    tracks, dropped, detected = Densifier(config.input.step).put_back(result.tracks, result.dropped, result.detected,
                                                                      result.info.length, until=info.length)
    return dataclasses.replace(result, tracks=tracks, dropped=dropped, detected=detected)


def track_tracked_frames(info: SeqInfo, config: TrackerConfig, embedder=None, progress=False,
                         detections: Detections | None = None):
    """The tracked frames of ``info`` at ``[input] step`` tracked as a sequence of their own: the
    :class:`~sotmot.pipeline.TrackResult` of that run, ``info`` the stepped sequence and everything (detections,
    tracklets, tracks) numbered as it counts the frames; its track ids are the stepped run's (what
    :func:`track_stepped` puts back on every frame, and what ``sotmot explain`` and ``sotmot graph`` show).
    ``detections``: handed over (the sequence's frame numbers), else read from the detections file as the run
    would, else the detector's."""
    from sotmot.detection import file_detections
    from sotmot.io.frames import FrameReader
    from sotmot.pipeline import track_sequence

    step = config.input.step
    if detections is None:
        detections = file_detections(config.detection, info)
    given = None if detections is None else stepped_detections(detections, step)
    reader = FrameReader(info, cache_size=8) if info.frames is not None or info.video is not None else None
    try:
        return track_sequence(stepped_sequence(info, step, reader), inner_config(config), embedder=embedder,
                              progress=progress, detections=given)
    finally:
        if reader is not None:
            reader.close()


def inner_config(config: TrackerConfig) -> TrackerConfig:
    """``config`` as the stepped run's stages take it: their sequence is the tracked frames, every one of them
    tracked."""
    return config.replace("input", step=1)


__all__ = ["Densifier", "SteppedFrames", "at_full_frames", "counted", "detections_at_full_frames", "full_frames",
           "inner_config", "stepped_detections", "stepped_sequence", "track_stepped", "track_tracked_frames",
           "track_whole", "tracked_count"]
