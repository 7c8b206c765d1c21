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

With ``[input] step`` above 1 the windows are windows of the tracked frames
(:mod:`sotmot.stepping`): window ``k`` covers tracked frames ``[s_k, e_k]``
(tracked frame ``j`` is the sequence's frame ``1 + (j - 1) * step``), its
length and overlap counted at the frame rate divided by the step, and each
committed part's boxes are put back on every frame before they are written.

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
from sotmot.stepping import Densifier, SteppedFrames, full_frames, inner_config, stepped_detections, tracked_count
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
    """The windows ``[(first, last), ...]`` (1-based, inclusive) of a sequence of ``length`` frames at
    ``frame_rate``; one window (the whole sequence) when windows are off or the sequence is no longer than one.
    With ``[input] step`` above 1, windows of its tracked frames (numbered as the stepped run counts them) at
    the frame rate divided by the step.

    Raises
    ------
    ConfigError
        A window shorter than twice the overlap.
    """
    step = config.input.step
    length = tracked_count(length, step)
    if config.windows.seconds <= 0:
        return [(1, length)]
    size, overlap = window_size(frame_rate / step, config)
    windows, start = [], 1
    while True:
        end = min(start + size - 1, length)
        windows.append((start, end))
        if end == length:
            break
        start = end - overlap + 1
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
                          f"limit): give windows of at least {2 * overlap / frame_rate:g} s, or a shorter "
                          f"association gap ([association] l_max_seconds; the overlap follows it) for shorter "
                          f"windows")
    return size, overlap


def cut(windows: list[Window], k: int) -> int:
    """The first frame whose boxes come from window ``k``: 1 for the first, else the middle of its overlap with
    window ``k - 1``."""
    if k == 0:
        return 1
    start, previous_end = windows[k][0], windows[k - 1][1]
    return start + (previous_end - start + 1) // 2


def window_sequence(info: SeqInfo, window: Window, reader: FrameReader, step: int = 1) -> SeqInfo:
    """Window ``(first, last)`` of ``info`` as a sequence of its own: frames renumbered from 1, read through
    ``reader`` (the sequence's own), everything else (name, folder, frame rate, size) kept. With ``step`` above
    1 the window's frames are tracked frames (:class:`~sotmot.stepping.SteppedFrames`) and its frame rate is the
    sequence's divided by ``step``."""
    first, last = window
    window_info = dataclasses.replace(info, length=last - first + 1)
    if step > 1:
        window_info = dataclasses.replace(window_info, frame_rate=info.frame_rate / step)
    if info.frames is None and info.video is None and not info.frames_dir.is_dir():
        return window_info  # no frames at all (labels only): none to read
    return dataclasses.replace(window_info, frames=SteppedFrames(reader, step, last - first + 1, first))


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


def track_window(info: SeqInfo, windows: list[Window], k: int, config: TrackerConfig,
                 detections: Detections | None = None, embedder=None, progress=False) -> WindowResult:
    """Track window ``k`` of ``windows`` of sequence ``info``: ``detections`` (the whole sequence's, already
    read, the sequence's frame numbers) sliced to it, or the detector run on its frames when None. With
    ``[input] step`` above 1, window ``k`` is of the tracked frames, and so is the result."""
    from sotmot.pipeline import track_sequence

    step = config.input.step
    first, last = windows[k]
    reader = FrameReader(info, cache_size=8)
    try:
        given = None
        if detections is not None:
            start, end = int(full_frames(first, step)), int(full_frames(last, step))  # the sequence's frames
            part = detections.subset(np.flatnonzero((detections.frames >= start) & (detections.frames <= end)))
            shifted = Detections(part.frames - (start - 1), part.boxes, part.scores)
            given = stepped_detections(shifted, step).sorted()
        result = track_sequence(window_sequence(info, windows[k], reader, step), inner_config(config),
                                embedder=embedder, progress=progress, detections=given)
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
    ``k + 1``'s first frame, and whether there is one. With ``step`` above 1
    the windows are of the tracked frames, and what each commits is put back
    on every frame (:class:`~sotmot.stepping.Densifier`, whose state travels
    too).
    """

    windows: list[Window]
    min_iou: float
    next_id: int = 1
    done: int = 0
    carry: Tracks = field(default_factory=Tracks.empty)
    joins: list[dict] = field(default_factory=list)
    step: int = 1
    densifier: Densifier | None = None
    #: the sequence's frames (with ``step`` above 1: the last window holds its last boxes on those after the last
    #: tracked frame, :meth:`~sotmot.stepping.Densifier.tail`); 0: unknown (a stream's, which does that itself)
    length: int = 0

    def __post_init__(self) -> None:
        if self.densifier is None:
            self.densifier = Densifier(self.step)

    def add(self, k: int, result: WindowResult) -> tuple[Tracks, Tracks, Detections | None]:
        """Window ``k``'s boxes with their final ids, and the boxes of the frames it owns: ``(tracks, dropped,
        detected)`` to commit, in the sequence's frame numbers. Windows must come in order."""
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
        tracks, dropped = _between(tracks, begin, end), _between(dropped, begin, end)
        if self.step > 1:  # tracked frames: their boxes put back on every frame
            return self.densifier.put_back(tracks, dropped, detected, end,
                                           until=self.length if self.done == len(self.windows) else 0)
        return tracks, dropped, detected

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
        state = {"done": self.done, "next_id": self.next_id, "joins": self.joins, "carry": self.carry.to_lists()}
        if self.step > 1:
            state["filled_from"] = self.densifier.state()
        return state

    @classmethod
    def from_state(cls, windows: list[Window], min_iou: float, state: dict, step: int = 1,
                   length: int = 0) -> "Stitcher":
        """The stitcher :meth:`state` describes (``step``: the run's, as it was made; ``length``: the sequence's
        frames)."""
        densifier = Densifier.from_state(step, state["filled_from"]) if step > 1 else None
        return cls(windows, min_iou, int(state["next_id"]), int(state["done"]), Tracks.from_lists(state["carry"]),
                   list(state["joins"]), step, densifier, length)


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
    stitcher = Stitcher(windows, config.windows.join_iou, step=config.input.step, length=info.length)
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


__all__ = ["Stitcher", "WindowResult", "cut", "join", "overlap_frames", "plan", "track_in_windows", "track_window",
           "window_sequence", "window_size", "windowed"]
