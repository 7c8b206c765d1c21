"""Committed time windows: a sequence of any length tracked window by window (``[windows]``).

Window ``k`` covers frames ``[s_k, e_k]``; consecutive windows overlap by
``O`` frames, at least the association's gap limit, so every link the gap
rule allows (a gap of at most ``l_max`` frames) lies wholly inside one window.
Each window is tracked as a sequence of its own (the whole pipeline: its
detections, re-ID, tracklets, association, interpolation, confirmation, end
extension). Tracks of consecutive windows are joined where their boxes agree
in the overlap (mean IoU over the frames both hold a box, at least
``join_iou``; one to one, by the Hungarian method); a track with no partner
gets a new id. Each frame's boxes come from one window: the earlier up to the
middle of the overlap (the *cut*), the later from there on. So the boxes of
frame ``t`` are final as soon as the window holding ``t`` and the one before
it are tracked, whatever the sequence's length, and windows can be tracked in
any order or in parallel: the joins are made in order, from the windows alone.

Frames are 1-based, boxes ``x, y, w, h`` pixels.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from sotmot.boxes import iou_matrix
from sotmot.config import TrackerConfig
from sotmot.errors import ConfigError
from sotmot.io import FrameReader, SeqInfo
from sotmot.types import Detections, Tracks
from sotmot.workers import dask_worker_threads, process_threads, worker_embedder

Window = tuple[int, int]


def overlap_frames(frame_rate: float, config: TrackerConfig) -> int:
    """The overlap of consecutive windows in frames: ``[windows] overlap_seconds``, never less than the
    association's gap limit at this frame rate."""
    gap = config.association.at(frame_rate).l_max
    asked = config.windows.overlap_seconds
    return max(gap, int(round(asked * frame_rate)) if asked is not None else 0)


def plan(length: int, frame_rate: float, config: TrackerConfig) -> list[Window]:
    """The windows ``[(first, last), ...]`` (1-based, inclusive) of a sequence of ``length`` frames; one window
    (the whole sequence) when windows are off or the sequence is no longer than one.

    Raises
    ------
    ConfigError
        A window shorter than twice the overlap; several windows with ``[input] step`` above 1 (a file tracked
        window by window is tracked at every frame).
    """
    if config.windows.seconds <= 0:
        return [(1, length)]
    size, overlap = window_size(frame_rate, config)
    windows, start = [], 1
    while True:
        end = min(start + size - 1, length)
        windows.append((start, end))
        if end == length:
            break
        start = end - overlap + 1
    if len(windows) > 1 and config.input.step > 1:
        raise ConfigError(f"[input] step = {config.input.step} with [windows] seconds = {config.windows.seconds:g}: "
                          f"a file tracked window by window is tracked at every frame; track it whole (no "
                          f"--window), or a video as a live source (--live VIDEO), whose windows take the step")
    return windows


def window_size(frame_rate: float, config: TrackerConfig) -> tuple[int, int]:
    """``(size, overlap)``: a window's length and the overlap of consecutive windows, in frames, for ``[windows]
    seconds`` (> 0) at ``frame_rate``. Consecutive windows share ``overlap`` frames.

    Raises
    ------
    ConfigError
        A window shorter than twice the overlap.
    """
    size = max(1, int(round(config.windows.seconds * frame_rate)))
    overlap = overlap_frames(frame_rate, config)
    if size < 2 * overlap:
        raise ConfigError(f"[windows] seconds = {config.windows.seconds:g} is {size} frames, less than twice the "
                          f"overlap of {overlap} frames ({overlap / frame_rate:g} s, at least the association's gap "
                          f"limit): give windows of at least {2 * overlap / frame_rate:g} s")
    return size, overlap


def cut(windows: list[Window], k: int) -> int:
    """The first frame whose boxes come from window ``k``: 1 for the first, else the middle of its overlap with
    window ``k - 1``."""
    if k == 0:
        return 1
    start, previous_end = windows[k][0], windows[k - 1][1]
    return start + (previous_end - start + 1) // 2


class WindowFrames:
    """The frames ``start, start + 1, ...`` of a sequence, as a window reads them (``window[0]`` is ``start``)."""

    def __init__(self, reader: FrameReader, start: int, length: int) -> None:
        self.reader, self.start, self.length = reader, start, length

    def __len__(self) -> int:
        return self.length

    def __getitem__(self, index: int) -> np.ndarray:
        return self.reader(self.start + index)


def window_sequence(info: SeqInfo, window: Window, reader: FrameReader) -> SeqInfo:
    """Window ``(first, last)`` of ``info`` as a sequence of its own: frames renumbered from 1, read through
    ``reader`` (the sequence's own), everything else (name, folder, frame rate, size) kept."""
    first, last = window
    if info.frames is None and info.video is None and not info.frames_dir.is_dir():
        return dataclasses.replace(info, length=last - first + 1)  # no frames at all (labels only): none to read
    return dataclasses.replace(info, length=last - first + 1, frames=WindowFrames(reader, first, last - first + 1))


def _shift(tracks: Tracks, by: int) -> Tracks:
    return dataclasses.replace(tracks, frames=tracks.frames + by)


def _relabel(tracks: Tracks, ids: dict[int, int]) -> Tracks:
    return dataclasses.replace(tracks, ids=[ids[int(i)] for i in tracks.ids])


def _between(tracks: Tracks, first: int, last: int) -> Tracks:
    return tracks.subset((tracks.frames >= first) & (tracks.frames <= last))


@dataclass
class WindowResult:
    """One window's output, in the sequence's frame numbers; ids are the window's own."""

    tracks: Tracks
    dropped: Tracks
    detected: Detections | None


def sequence_detections(info: SeqInfo, config: TrackerConfig) -> Detections | None:
    """The detections every window slices, read once from the sequence's detections file; None when the
    detector runs on each window's frames (``[detection] source``)."""
    from sotmot.detection import detection_source
    from sotmot.io import read_detections

    source, path = detection_source(config.detection, info)
    return read_detections(path, info.length, (info.width, info.height)) if source == "file" else None


def track_window(info: SeqInfo, windows: list[Window], k: int, config: TrackerConfig,
                 detections: Detections | None = None, embedder=None, progress=False) -> WindowResult:
    """Track window ``k`` of ``windows`` of sequence ``info``: ``detections`` (the whole sequence's, already
    read) sliced to it, or the detector run on its frames when None."""
    from sotmot.pipeline import track_sequence

    first, last = windows[k]
    reader = FrameReader(info, cache_size=8)
    try:
        given = None
        if detections is not None:
            keep = (detections.frames >= first) & (detections.frames <= last)
            part = detections.subset(np.flatnonzero(keep))
            given = Detections(part.frames - (first - 1), part.boxes, part.scores).sorted()
        result = track_sequence(window_sequence(info, windows[k], reader), config, embedder=embedder,
                                progress=progress, detections=given)
    finally:
        reader.close()
    detected = None
    if result.detected is not None:
        d = result.detected
        detected = Detections(d.frames + (first - 1), d.boxes, d.scores)
    return WindowResult(_shift(result.tracks, first - 1), _shift(result.dropped, first - 1), detected)


def join(earlier: Tracks, later: Tracks, min_iou: float) -> dict[int, int]:
    """Which track of ``later`` continues which of ``earlier``: ``{later id: earlier id}``, one to one, for
    pairs whose boxes in the frames both hold one have a mean IoU of at least ``min_iou`` (the largest total
    agreement first: Hungarian on the mean IoU)."""
    from scipy.optimize import linear_sum_assignment

    ids_a, ids_b = np.unique(earlier.ids), np.unique(later.ids)
    if not len(ids_a) or not len(ids_b):
        return {}
    col_a = {int(i): n for n, i in enumerate(ids_a)}
    col_b = {int(i): n for n, i in enumerate(ids_b)}
    total = np.zeros((len(ids_a), len(ids_b)))
    shared = np.zeros((len(ids_a), len(ids_b)))
    for frame in np.intersect1d(earlier.frames, later.frames):
        ia, ib = np.flatnonzero(earlier.frames == frame), np.flatnonzero(later.frames == frame)
        ra = [col_a[int(i)] for i in earlier.ids[ia]]
        rb = [col_b[int(i)] for i in later.ids[ib]]
        total[np.ix_(ra, rb)] += iou_matrix(earlier.boxes[ia], later.boxes[ib])
        shared[np.ix_(ra, rb)] += 1
    mean = np.divide(total, shared, out=np.zeros_like(total), where=shared > 0)
    rows, cols = linear_sum_assignment(-mean)
    return {int(ids_b[c]): int(ids_a[r]) for r, c in zip(rows, cols) if mean[r, c] >= min_iou}


@dataclass
class Stitcher:
    """Joins windows in order into one identity space and says which boxes each window commits.

    ``carry`` holds the previous window's boxes (final ids) in its overlap
    with the next; ``next_id`` the next new id. Both travel in the run record,
    so an interrupted run resumes at the next window (:meth:`state`,
    :meth:`from_state`). ``windows`` may grow while windows are added (a
    stream's, :func:`sotmot.api.stream`): adding window ``k`` reads window
    ``k + 1``'s first frame, and whether there is one.
    """

    windows: list[Window]
    min_iou: float
    next_id: int = 1
    done: int = 0
    carry: Tracks = field(default_factory=Tracks.empty)
    joins: list[dict] = field(default_factory=list)

    def add(self, k: int, result: WindowResult) -> tuple[Tracks, Tracks, Detections | None]:
        """Window ``k``'s boxes with their final ids, and the boxes of the frames it owns: ``(tracks, dropped,
        detected)`` to commit. Windows must come in order."""
        if k != self.done:
            raise ValueError(f"window {k} added after {self.done} windows")
        first, last = self.windows[k]
        ids: dict[int, int] = {}
        if k > 0:
            overlap = (first, self.windows[k - 1][1])
            ids = join(self.carry, _between(result.tracks, *overlap), self.min_iou)
            self.joins.append({"window": k, "frames": list(overlap), "joined": len(ids),
                               "tracks_before": int(len(np.unique(self.carry.ids)))})
        ids = self._new_ids(ids, result.tracks)
        tracks = _relabel(result.tracks, ids)
        dropped = _relabel(result.dropped, self._new_ids(ids, result.dropped))
        begin = cut(self.windows, k)
        end = cut(self.windows, k + 1) - 1 if k + 1 < len(self.windows) else last
        self.carry = _between(tracks, self.windows[k + 1][0], last) if k + 1 < len(self.windows) else Tracks.empty()
        self.done = k + 1
        detected = result.detected
        if detected is not None:
            detected = detected.subset(np.flatnonzero((detected.frames >= begin) & (detected.frames <= end)))
        return _between(tracks, begin, end), _between(dropped, begin, end), detected

    def _new_ids(self, ids: dict[int, int], tracks: Tracks) -> dict[int, int]:
        """``ids`` completed with a new id for every track of ``tracks`` it lacks, in order of first box."""
        ids = dict(ids)
        order = np.lexsort((tracks.ids, tracks.frames))
        for i in dict.fromkeys(int(x) for x in tracks.ids[order]):
            if i not in ids:
                ids[i] = self.next_id
                self.next_id += 1
        return ids

    def state(self) -> dict:
        """What resuming after :attr:`done` windows needs, as JSON."""
        c = self.carry
        return {"done": self.done, "next_id": self.next_id, "joins": self.joins,
                "carry": [c.frames.tolist(), c.ids.tolist(), c.boxes.tolist(), c.scores.tolist(),
                          c.interpolated.tolist(), c.from_sot.tolist(),
                          [None if np.isnan(v) else v for v in c.confidence.tolist()]]}

    @classmethod
    def from_state(cls, windows: list[Window], min_iou: float, state: dict) -> "Stitcher":
        """The stitcher :meth:`state` describes."""
        f, i, b, s, interp, sot, conf = state["carry"]
        carry = Tracks(np.asarray(f, np.int64), np.asarray(i, np.int64), np.asarray(b, np.float64).reshape(-1, 4),
                       s, interp, sot, [np.nan if v is None else v for v in conf])
        return cls(windows, min_iou, int(state["next_id"]), int(state["done"]), carry, list(state["joins"]))


def windowed(info: SeqInfo, windows: list[Window], config: TrackerConfig, detections: Detections | None,
             start: int = 0, workers: int = 1, embedder=None, progress=False,
             submit=None) -> Iterator[tuple[int, WindowResult]]:
    """``(k, result)`` for windows ``start, start + 1, ...`` in order, tracked here (``workers`` 1), in that many
    processes, or by ``submit(function, *args) -> future`` (a Dask client's); each window is independent, so the
    results are the same."""
    if submit is not None:
        yield from _in_order(submit, info, windows, config, detections, start)
        return
    if workers <= 1:
        from sotmot.appearance import embedder_for

        embedder = embedder_for(config.appearance, embedder)  # one model for every window
        for k in range(start, len(windows)):
            yield k, track_window(info, windows, k, config, detections, embedder, progress)
        return
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    context = multiprocessing.get_context("spawn")  # no forked OpenVINO or onnxruntime state
    with ProcessPoolExecutor(workers, mp_context=context) as pool:
        yield from _in_order(pool.submit, info, windows, process_threads(config, workers), detections, start)


def _in_order(submit, info: SeqInfo, windows: list[Window], config: TrackerConfig, detections: Detections | None,
              start: int) -> Iterator[tuple[int, WindowResult]]:
    """Every window from ``start`` submitted at once (``submit(function, *args) -> future``), the results
    yielded in window order as they are needed."""
    futures = {k: submit(_window_job, info, windows, k, config, detections) for k in range(start, len(windows))}
    for k in range(start, len(windows)):
        yield k, futures.pop(k).result()


def track_in_windows(info: SeqInfo, windows: list[Window], config: TrackerConfig, detections: Detections | None,
                     workers: int = 1, embedder=None, progress=False) -> tuple[Tracks, Tracks]:
    """The tracks and the unconfirmed boxes of ``info`` tracked in ``windows``, all in memory (the API's way;
    ``sotmot track`` writes each window's boxes as it commits them)."""
    stitcher = Stitcher(windows, config.windows.join_iou)
    kept, dropped = [], []
    for k, result in windowed(info, windows, config, detections, 0, workers, embedder, progress):
        tracks, low, _ = stitcher.add(k, result)
        kept.append(tracks)
        dropped.append(low)
    return Tracks.concatenate(kept), Tracks.concatenate(dropped)


def _window_job(info: SeqInfo, windows: list[Window], k: int, config: TrackerConfig,
                detections: Detections | None) -> WindowResult:
    """One window in a worker process, a local pool's or a Dask worker (its re-ID model built once per process,
    its models' threads the Dask worker's own there)."""
    config = dask_worker_threads(config)
    return track_window(info, windows, k, config, detections, worker_embedder(config.appearance))


__all__ = ["Stitcher", "WindowFrames", "WindowResult", "cut", "join", "overlap_frames", "plan",
           "sequence_detections", "track_in_windows", "track_window", "window_sequence", "window_size", "windowed"]
