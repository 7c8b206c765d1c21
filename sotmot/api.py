"""Tracking from Python: :func:`track` a video, a MOTChallenge folder or frames held in memory, and
:func:`evaluate` the result.

sotmot is an **offline** tracker by design: tracklets are built per second and
long-term association looks at the whole sequence at once (paper Sec. 3.4), so
:func:`track` returns when it has seen every frame; it does not give tracks
frame by frame. :func:`stream` tracks a stream of frames in committed windows
and yields each window's part as soon as it is final. Models are the two
bundled ones unless the configuration names others (``sotmot models``);
nothing is downloaded.

Example (``docs/api.md`` holds more; a test runs them)::

    import sotmot
    result = sotmot.track("../shared/data/MOT16-02-clip30")
    print(result.tracks.n_tracks, "people")
    result.save("out/MOT16-02.txt")
    print(result.scores(gt="../shared/data/MOT16-02-clip30/gt/gt.txt")["HOTA"])

Boxes are ``x, y, w, h`` in pixels and frames 1-based, as in MOTChallenge files.
"""

from __future__ import annotations

import contextlib
import dataclasses
import tempfile
import threading
import warnings
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sotmot.config import TrackerConfig, config_from_dict, load_config
from sotmot.errors import ConfigError, InputError
from sotmot.io import (
    SeqInfo, detections_from_array, format_results, is_plain_name, read_detections, read_results, read_seqinfo,
    guard_outputs, write_text_atomic,
)
from sotmot.io.frames import not_an_image
from sotmot.io.images import image_list_info
from sotmot.io.sequence import takes_frame_rate
from sotmot.types import Detections, Tracks


@dataclass(frozen=True, eq=False)
class Result:
    """What :func:`track` made of a sequence.

    Attributes
    ----------
    tracks
        The tracked boxes (:class:`~sotmot.types.Tracks`): ``frames``, ``ids``,
        ``boxes`` (``x, y, w, h`` pixels), ``scores`` as numpy arrays, one row
        per box, exactly what :meth:`save` writes.
    dropped
        Boxes confirmation judged more likely false than true (not in ``tracks``).
    info
        The sequence: name, frame rate, length, image size.
    config
        The configuration the run used.
    found
        What the run found or chose by itself, as ``sotmot track``'s run record keeps it
        (:func:`sotmot.provenance.findings`): ``camera_motion`` where the camera was found moving and compensated,
        ``line_check`` where the line check lowered the interpolation bound, ``confidence_method``. Empty for a
        run in windows, which decides them window by window.
    """

    tracks: Tracks
    dropped: Tracks
    info: SeqInfo
    config: TrackerConfig
    found: dict = field(default_factory=dict)

    def save(self, path: str | Path) -> Path:
        """Write :attr:`tracks` as a MOTChallenge results file (``frame, id, x, y, w, h, score, -1, -1, -1``),
        atomically: byte for byte what ``sotmot track`` writes for the same run. Never over one of the
        sequence's files, never over a file the run read (its detections, an image of a list of paths), never
        inside its sequence folder or folder of images (:func:`sotmot.io.guard_outputs`). Returns the path."""
        path = Path(path)
        info = self.info
        reads = [self.config.detection.file, self.config.preprocess.mask, *(info.files or ())]
        folders = []
        if info.frames is None:  # frames in memory: ``info.path`` only names them
            reads += [info.source, info.det_path, info.gt_path]
            if info.video is None:  # a MOTChallenge folder or a folder of images
                folders = [info.path, info.frames_dir]
        guard_outputs([path], reads, folders, "choose another path")
        path.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(path, format_results(self.tracks))
        return path

    def scores(self, gt: str | Path) -> dict[str, float]:
        """TrackEval's scores (HOTA, DetA, AssA, MOTA, IDF1, IDSW, FP, FN, ...) of :attr:`tracks` against the
        ground truth ``gt`` (a ``gt.txt``, or a sequence folder holding ``gt/gt.txt``); see :func:`evaluate`."""
        return evaluate(self, gt)

    def __repr__(self) -> str:
        return (f"Result({self.info.name!r}: {self.tracks.n_tracks} tracks, {len(self.tracks)} boxes over "
                f"{self.info.length} frames at {self.info.frame_rate:g} fps)")


_END = object()  # a one-pass iterable's end


class _Spool:
    """Frames of a one-pass iterable kept on disk as ``.npy`` files in ``folder``, so that the stages that look
    back and ahead read them again without holding them all in memory. Frames come in with :meth:`extend`;
    a stream forgets those no window reads any more (:meth:`release`)."""

    def __init__(self, folder: Path, name: str) -> None:
        self.folder, self.name = folder, name
        self.count = 0  # frames written so far
        self.kept_from = 1  # the first frame still on disk

    def _path(self, frame: int) -> Path:
        return self.folder / f"{frame:08d}.npy"

    def extend(self, frames: Iterable) -> None:
        """Write every frame of ``frames``."""
        for image in frames:
            self.write(image)
            self.count += 1

    def write(self, image: Any) -> None:
        """Write ``image`` as the next frame, ``count + 1`` (counted by the caller, once it is whole).

        Raises
        ------
        InputError
            It is not a BGR ``uint8`` image.
        """
        problem = not_an_image(image, self.count + 1)
        if problem:
            raise InputError(self.name, problem)
        np.save(self._path(self.count + 1), np.asarray(image), allow_pickle=False)

    def release(self, before: int) -> None:
        """Delete the frames before 1-based ``before`` (this spool wrote them)."""
        for frame in range(self.kept_from, before):
            self._path(frame).unlink()
        self.kept_from = max(self.kept_from, before)

    def __len__(self) -> int:
        return self.count

    def __getitem__(self, index: int) -> np.ndarray:
        if not self.kept_from <= index + 1 <= self.count:
            raise IndexError(f"frame {index + 1} is not held (frames {self.kept_from}..{self.count} are)")
        return np.load(self._path(index + 1), allow_pickle=False)


class _ReadAhead:
    """Fills a :class:`_Spool` from a one-pass iterable in a thread of its own, holding at most ``capacity`` frames
    on disk (beyond that it waits for :meth:`release`), so that a source with a pace of its own (a camera) is read
    while windows are tracked. Only that thread touches the iterable; its exception is raised by :meth:`wait`."""

    def __init__(self, frames: Iterator, spool: _Spool, capacity: int) -> None:
        self.spool, self.capacity = spool, capacity
        self.ended = False
        self.error: BaseException | None = None
        self._stop = False
        self._changed = threading.Condition()
        self._thread = threading.Thread(target=self._run, args=(frames,), name="sotmot-stream-reader", daemon=True)
        self._thread.start()

    def _run(self, frames: Iterator) -> None:
        spool = self.spool
        try:
            while True:
                with self._changed:
                    while not self._stop and spool.count - spool.kept_from + 1 >= self.capacity:
                        self._changed.wait()
                    if self._stop:
                        return
                image = next(frames, _END)  # a camera waits here for its next frame
                if image is _END or self._stop:
                    return
                spool.write(image)
                with self._changed:
                    spool.count += 1
                    self._changed.notify_all()
        except BaseException as exc:  # the consumer raises it (wait)
            self.error = exc
        finally:
            with self._changed:
                self.ended = True
                self._changed.notify_all()

    def wait(self, upto: int) -> int:
        """Wait until ``upto`` frames have come or the stream has ended; how many have come. The iterable's
        exception, when it raised one before ``upto``."""
        with self._changed:
            while self.spool.count < upto and not self.ended:
                self._changed.wait()
            count = self.spool.count
        if count < upto and self.error is not None:
            raise self.error
        return count

    def release(self, before: int) -> None:
        """Forget the frames before 1-based ``before``: room for as many more."""
        with self._changed:
            self.spool.release(before)
            self._changed.notify_all()

    def close(self) -> None:
        """Stop reading (after the frame being read, if any), before the spool's folder goes."""
        with self._changed:
            self._stop = True
            self._changed.notify_all()
        self._thread.join(timeout=READ_AHEAD_JOIN_SECONDS)


#: How long a stream that ends waits for its reader to finish the frame it is reading: a camera blocked in its
#: read is left behind (it writes nothing more).
READ_AHEAD_JOIN_SECONDS = 10.0


def _config(config: TrackerConfig | dict | str | Path | None) -> TrackerConfig:
    if config is None:
        return TrackerConfig()
    if isinstance(config, TrackerConfig):
        return config
    if isinstance(config, dict):
        return config_from_dict(config)
    if isinstance(config, (str, Path)):
        return load_config(config)
    raise ConfigError(f"config must be a TrackerConfig, a dict of sections or a .toml/.json path; got "
                      f"{type(config).__name__}")


def _in_memory(frames: Any, frame_rate: float | None, name: str, stack: contextlib.ExitStack) -> SeqInfo:
    """The sequence of frames held by the caller (spooled to a temporary folder when they come one pass only)."""
    if frames is None or isinstance(frames, (int, float, bool)):
        raise InputError(name, f"frames must be a video file, a MOTChallenge folder, a folder of images, a list of "
                               f"image paths or the images themselves; got {frames!r}")
    frame_rate = _frame_rate(frame_rate, name)
    if isinstance(frames, (list, tuple)) and frames and all(isinstance(f, (str, Path)) for f in frames):
        return image_list_info(list(frames), frame_rate, name)  # image files, read when a stage needs them
    if isinstance(frames, np.ndarray) and frames.ndim == 3:
        raise InputError(name, "frames is one image; pass a list (or an iterable, or a 4-D array) of images")
    if not (hasattr(frames, "__len__") and hasattr(frames, "__getitem__")):
        if not isinstance(frames, Iterable):
            raise InputError(name, f"frames must be images (a list, an iterable or a 4-D array), a video path or a "
                                   f"folder; got {type(frames).__name__}")
        spool = _Spool(Path(stack.enter_context(tempfile.TemporaryDirectory(prefix="sotmot-frames-"))), name)
        spool.extend(frames)
        frames = spool
    return _frames_info(frames, frame_rate, name)


def _check_name(name: str) -> None:
    """Refuse a sequence name that is not a plain file name (it names the results file)."""
    if not is_plain_name(name):
        raise ConfigError(f"name must be a plain file name (no path separators); got {name!r}")


def _frame_rate(frame_rate: float | None, name: str) -> float:
    """``frame_rate`` checked as ``--fps`` is, and ``name`` as a results file's name."""
    if frame_rate is None:
        raise ConfigError("frame_rate is needed for frames held in memory (a video or a MOTChallenge folder says "
                          "its own)")
    _check_name(name)
    return float(TrackerConfig().replace("input", fps=frame_rate).input.fps)


def _frames_info(frames: Any, frame_rate: float, name: str) -> SeqInfo:
    """The sequence of ``frames`` (indexable; the first tells the image size)."""
    if len(frames) == 0:
        raise InputError(name, "no frames")
    first = frames[0]
    problem = not_an_image(first, 1)
    if problem:
        raise InputError(name, problem)
    first = np.asarray(first)
    return SeqInfo(path=Path(f"<{name}>"), name=name, frame_rate=frame_rate, length=len(frames),
                   width=int(first.shape[1]), height=int(first.shape[0]), frames=frames)


def track(frames: Any, detections: Any = None, *, frame_rate: float | None = None,
          config: TrackerConfig | dict | str | Path | None = None, name: str | None = None,
          progress: bool = False) -> Result:
    """Track the people in a sequence and return the tracks (offline: the whole sequence is associated at once).

    Parameters
    ----------
    frames
        A video file, a MOTChallenge folder (``seqinfo.ini``, ``img1/``), a
        folder of images without ``seqinfo.ini`` (frames in the order of their
        names, numbers compared as numbers; ``frame_rate`` needed), a list of
        image paths (frames in the list's order; ``frame_rate`` needed), or the
        frames themselves: a list, a 4-D array or any sequence of BGR ``uint8``
        images (as ``cv2.imread`` gives them), each fetched when a stage needs
        it, or any iterable of them (read once, kept on disk in a temporary
        folder while tracking, so memory stays bounded; uncompressed, 6 MB a
        1080p frame: give a long stream as its video file).
    detections
        ``None``: a folder's ``det/det.txt`` when it has one, else the bundled
        person detector runs on the frames. ``"model"``: the detector runs even where a ``det.txt`` exists.
        A ``det.txt`` path. Or an
        ``(N, 6)`` array ``frame, x, y, w, h, score`` (frames 1-based, boxes in
        pixels), checked as a file is.
    frame_rate
        Frames per second: needed for frames in memory and for a folder of
        images; for a video it replaces the container's rate; a folder's
        ``seqinfo.ini`` says its own.
    config
        A :class:`~sotmot.config.TrackerConfig`, a dict of sections as a config
        file holds them (e.g. ``{"association": {"l_max_seconds": 3}}``), or the
        path of a ``.toml``/``.json`` file; ``None`` for the defaults.
        ``{"input": {"step": 2}}`` tracks every 2nd frame and fills the
        frames between (:mod:`sotmot.stepping`; with ``[windows]``, windows of
        the tracked frames).
    name
        The sequence's name (``Result.info.name``, the results file's in ``sotmot track``): for frames in memory
        ``"frames"`` when omitted; a folder or a video has its own (``seqinfo.ini``'s, the file's stem), which a
        name given here replaces.
    progress
        Progress bars on stderr.

    Returns
    -------
    Result
        ``tracks`` (numpy arrays), ``save(path)``, ``scores(gt=...)``, ``found`` (what the run found by
        itself: a moving camera, a lowered interpolation bound).

    Raises
    ------
    InputError, ConfigError, ModelError
        What the command line prints for the same input, e.g. a bad detection
        row named by its number.
    """
    from sotmot.detection import file_detections
    from sotmot.provenance import findings
    from sotmot.stepping import track_whole
    from sotmot.windows import plan, track_in_windows

    cfg = _config(config)
    given = None
    with contextlib.ExitStack() as stack:
        if isinstance(frames, (str, Path)):
            path = Path(frames)
            if not path.exists():
                raise InputError(path, "not found; expected a video file, a MOTChallenge folder (seqinfo.ini) or a "
                                       "folder of images")
            if frame_rate is not None and takes_frame_rate(path):
                cfg = cfg.replace("input", fps=frame_rate)
            info = read_seqinfo(path, cfg.input.fps)
            if frame_rate is not None and frame_rate != info.frame_rate:
                raise ConfigError(f"{info.source}: the folder's frame rate is {info.frame_rate:g}; frame_rate "
                                  f"{frame_rate:g} does not apply to a folder (edit frameRate in seqinfo.ini)")
            if name is not None:
                _check_name(name)
                info = dataclasses.replace(info, name=name)
        else:
            info = _in_memory(frames, frame_rate, "frames" if name is None else name, stack)
            if detections is None and not cfg.detection.file:
                cfg = cfg.replace("detection", source="model")
        if isinstance(detections, str) and detections == "model":  # the bundled detector, asked for by name
            cfg = cfg.replace("detection", source="model", file=None)
        elif isinstance(detections, (str, Path)):
            cfg = cfg.replace("detection", source="file", file=str(detections))
        elif detections is not None:
            given = detections_from_array(detections, info.length, (info.width, info.height))
            cfg = cfg.replace("detection", source="file", file=None)
        windows = plan(info.length, info.frame_rate, cfg)
        if len(windows) > 1:  # [windows] on: tracked window by window, joined (sotmot.windows)
            if given is None:
                given = file_detections(cfg.detection, info)
            tracks, dropped = track_in_windows(info, windows, cfg, given, progress=progress)
            return Result(tracks, dropped, info, cfg)
        result = track_whole(info, cfg, progress=progress, detections=given)  # every k-th frame with [input] step
    return Result(result.tracks, result.dropped, info, cfg, findings(result, cfg))


@dataclass(frozen=True, eq=False)
class Committed:
    """The boxes of a stream's frames ``first..last`` (1-based, inclusive), final: what :func:`stream` yields as
    soon as no later frame can change them.

    Attributes
    ----------
    first, last
        The frames these boxes cover; the next :class:`Committed` starts at ``last + 1``.
    tracks
        Their boxes (:class:`~sotmot.types.Tracks`, ``x, y, w, h`` pixels), ids the same from one part to the
        next for one person (joined across windows, as ``sotmot track --window`` joins them).
    dropped
        The boxes of those frames confirmation judged more likely false than true (not in ``tracks``).
    detected
        The built-in detector's boxes of those frames, every one it found (its weak ones too), as ``sotmot
        track`` writes them to ``<name>.det.txt``; None when the detections were given.
    """

    first: int
    last: int
    tracks: Tracks
    dropped: Tracks
    detected: Detections | None = None

    def __repr__(self) -> str:
        return f"Committed(frames {self.first}-{self.last}: {self.tracks.n_tracks} tracks, {len(self.tracks)} boxes)"


#: The window of :func:`stream` when the configuration sets none (``[windows] seconds = 0``): tracking a
#: sequence in 30-s windows costs at most 0.2 HOTA against the whole of it on the full-length sequences
#: (docs/results.md, "Committed windows"), 10-s windows up to 3.
STREAM_WINDOW_SECONDS = 30.0


def stream_config(config: TrackerConfig) -> TrackerConfig:
    """``config`` as :func:`stream` tracks with it: its ``[windows] seconds``, or :data:`STREAM_WINDOW_SECONDS`
    where it sets none."""
    return config if config.windows.seconds > 0 else config.replace("windows", seconds=STREAM_WINDOW_SECONDS)


def stream(frames: Iterable, detections: Any = None, *, frame_rate: float,
           config: TrackerConfig | dict | str | Path | None = None, name: str = "stream",
           progress: bool = False) -> Iterator[Committed]:
    """Track a stream of frames (a camera, a decoder, a generator) in committed windows, yielding the boxes of
    each stretch of frames as soon as they are final.

    Window ``k`` (``[windows] seconds``, or :data:`STREAM_WINDOW_SECONDS` when the configuration sets none;
    consecutive windows overlap by the association's gap, 4 s) is tracked once its last frame and the one after
    it have come, and its part of the stream is yielded then (:mod:`sotmot.windows`: the frames up to the middle
    of its overlap with the next). So the boxes of frame ``t`` are final once the frame a window after ``t`` has
    come, and tracking it takes. The frames are read in a thread of their own, from the first part asked for,
    while windows are tracked (a camera is read at its own pace), up to a window ahead of the one tracked: at
    most two windows of frames are kept, on disk in a temporary folder (uncompressed: a 1080p frame is 6 MB,
    30 s at 25 fps 4.7 GB; shorter windows keep less and cost more identity switches at their joins). The
    iterable is used by that thread alone; an exception it raises is raised here.

    The parts put together are the tracks ``sotmot.track(frames, detections, config=...)`` gives with the same
    windows (``{"windows": {"seconds": ...}}``), box for box.

    With ``[input] step`` k above 1 (a camera faster than the tracker), frames 1, 1 + k, ... are tracked as a
    stream of their own at the frame rate divided by k, and each part holds every frame it covers, those
    between tracked frames on the line between their tracks' boxes (:mod:`sotmot.stepping`); the frames after
    the last tracked one come as a last part, holding its boxes. Detections' rows of the frames between are not
    used.

    Parameters
    ----------
    frames
        Any iterable of BGR ``uint8`` images of one size, as OpenCV reads them (a generator over
        ``cv2.VideoCapture.read``, a list), read once.
    detections
        ``None``: the bundled person detector runs on each window's frames. A ``det.txt`` path or an
        ``(N, 6)`` array ``frame, x, y, w, h, score`` (frames 1-based, counted from the stream's first frame;
        boxes in pixels), checked as a file is; a row past the stream's last frame is an error when the stream
        ends.
    frame_rate
        Frames per second of the stream.
    config, name, progress
        As for :func:`track`.

    Yields
    ------
    Committed
        ``first``, ``last``, ``tracks``, ``dropped``, ``detected``: consecutive stretches of frames, from frame 1
        to the stream's last.

    Raises
    ------
    InputError, ConfigError, ModelError
        As :func:`track`: settings and detections are checked before the first frame is read; a frame of
        another size or type when a window reads it; no frames at all when the stream ends.
    """
    from sotmot.windows import window_size

    rate = _frame_rate(frame_rate, name)
    cfg = stream_config(_config(config))
    step = cfg.input.step
    size, overlap = window_size(rate / step, cfg)
    if isinstance(frames, (str, Path)) or not isinstance(frames, Iterable):
        raise InputError(name, f"frames must be an iterable of images; got {type(frames).__name__} (a video file "
                               f"or a folder: sotmot.track, or sotmot track --window)")
    if detections is None and cfg.detection.file:
        detections = cfg.detection.file
    if isinstance(detections, (str, Path)):
        cfg = cfg.replace("detection", source="file", file=str(detections))
    elif detections is not None:
        cfg = cfg.replace("detection", source="file", file=None)
    else:
        cfg = cfg.replace("detection", source="model")
    _given(detections)  # bad rows are errors now; boxes against the image size once the first frame has come
    if step == 1:
        return _stream(iter(frames), detections, rate, cfg, name, size, overlap, progress)
    return _stepped_stream(iter(frames), detections, rate, cfg, name, size, overlap, progress)


def _stepped_stream(frames: Iterator, detections: Any, rate: float, cfg: TrackerConfig, name: str, size: int,
                    overlap: int, progress: bool) -> Iterator[Committed]:
    """:func:`stream` of every ``[input] step``-th frame (:mod:`sotmot.stepping`): the tracked frames streamed
    as a stream of their own, each part's boxes put back on every frame and numbered as the stream counts them;
    a last part holds the frames after the last tracked one (its boxes held there)."""
    import itertools

    from sotmot.stepping import Densifier, counted, full_frames, inner_config, stepped_detections

    step = cfg.input.step
    frames, count = counted(frames)
    if detections is not None:  # the tracked frames' rows, numbered as the tracked stream counts them
        kept = stepped_detections(_given(detections), step)
        detections = np.column_stack([kept.frames, kept.boxes, kept.scores])
    densifier, done = Densifier(step), 0
    parts = _stream(itertools.islice(frames, 0, None, step), detections, rate / step, inner_config(cfg), name, size,
                    overlap, progress)
    with contextlib.closing(parts):
        for part in parts:
            last = int(full_frames(part.last, step))
            yield Committed(done + 1, last, *densifier.put_back(part.tracks, part.dropped, part.detected, part.last))
            done = last
    if count() > done:  # the frames after the last tracked one: the last tracked boxes held there
        none = None if detections is not None else Detections(np.zeros(0, np.int64), np.zeros((0, 4)), np.zeros(0))
        yield Committed(done + 1, count(), densifier.tail(count()), Tracks.empty(), none)


def _given(detections: Any, image_size: tuple[int, int] | None = None) -> Detections | None:
    """A stream's detections (:func:`stream`), checked as a file is; None for the detector."""
    if detections is None:
        return None
    if isinstance(detections, (str, Path)):
        return read_detections(detections, None, image_size)
    return detections_from_array(detections, None, image_size)


def _stream(frames: Iterator, detections: Any, rate: float, cfg: TrackerConfig, name: str, size: int, overlap: int,
            progress: bool) -> Iterator[Committed]:
    """:func:`stream` once its arguments are checked: the frames spooled by a reader thread, tracked window by
    window."""
    with tempfile.TemporaryDirectory(prefix="sotmot-stream-") as tmp:
        spool = _Spool(Path(tmp), name)
        reader = _ReadAhead(frames, spool, 2 * size + 1)  # this window, the frame after it, and one more window
        try:
            yield from _windows(reader, detections, rate, cfg, name, size, overlap, progress)
        finally:
            reader.close()


def _windows(reader: _ReadAhead, detections: Any, rate: float, cfg: TrackerConfig, name: str, size: int,
             overlap: int, progress: bool) -> Iterator[Committed]:
    """:func:`stream`'s windows over the frames ``reader`` brings."""
    import dataclasses

    from sotmot.appearance import embedder_for
    from sotmot.windows import Stitcher, cut, track_window

    windows: list[tuple[int, int]] = []  # grows as the stream does; the stitcher reads the same list
    stitcher = Stitcher(windows, cfg.windows.join_iou)
    info, given, embedder, start, k = None, None, None, 1, 0
    while True:
        count = reader.wait(start + size)  # the window's frames and one more: is there a next window?
        if info is None:
            info = _frames_info(reader.spool, rate, name)
            given = _given(detections, (info.width, info.height))
        end = min(start + size - 1, count)
        windows[k:] = [(start, end)] if count == end else [(start, end), (end - overlap + 1, count)]
        if len(windows) == k + 1 and given is not None and len(given) and given.frames.max() > end:
            source = detections if isinstance(detections, (str, Path)) else "detections"
            raise InputError(source, f"frame {int(given.frames.max())} is past the stream's last frame, {end}")
        embedder = embedder_for(cfg.appearance, embedder)  # one model for every window
        result = track_window(dataclasses.replace(info, length=count), windows, k, cfg, given, embedder, progress)
        if len(windows) == 1:  # the whole stream in one window: its own ids, as sotmot.track gives them
            yield Committed(1, end, result.tracks, result.dropped, result.detected)
            return
        tracks, dropped, detected = stitcher.add(k, result)
        last = cut(windows, k + 1) - 1 if len(windows) > k + 1 else end
        yield Committed(cut(windows, k), last, tracks, dropped, detected)
        if len(windows) == k + 1:
            return
        k, start = k + 1, windows[k + 1][0]
        reader.release(start)


def evaluate(results: "Result | Tracks | str | Path", gt: str | Path, *, length: int | None = None,
             name: str | None = None) -> dict[str, float]:
    """TrackEval's scores of one sequence's tracks against its ground truth.

    Parameters
    ----------
    results
        A :class:`Result`, :class:`~sotmot.types.Tracks`, or a MOTChallenge results file (a file whose run
        record says its run stopped before the end, or that it changed since, is scored with a warning).
    gt
        A ``gt.txt`` (MOT16 or 2DMOT2015 layout), or a sequence folder with ``gt/gt.txt``.
    length
        The sequence's number of frames: from the result or the folder's
        ``seqinfo.ini`` when omitted, else the last frame of either file.
    name
        The sequence's name in the scores (default: the result's or the folder's).

    Returns
    -------
    dict
        Metric name -> value (``HOTA``, ``DetA``, ``AssA``, ``MOTA``, ``MOTP``,
        ``IDF1``, ``IDSW``, ``FP``, ``FN``, ...; fractions as percentages).

    Raises
    ------
    InputError, EvaluationError
        A malformed file (named, with its line), or TrackEval missing or failing.
    """
    from sotmot.io import read_ground_truth
    from sotmot.provenance import results_doubts
    from sotmot.scoring import evaluate_files

    gt = Path(gt)
    if gt.is_dir():
        folder = read_seqinfo(gt, rate_needed=False)
        gt, length, name = folder.gt_path, length or folder.length, name or folder.name
    if isinstance(results, Result):
        length, name = length or results.info.length, name or results.info.name
        results = results.tracks
    with tempfile.TemporaryDirectory(prefix="sotmot-scores-") as tmp:
        if isinstance(results, Tracks):
            path = Path(tmp) / "results.txt"
            path.write_text(format_results(results), encoding="utf-8")
        else:
            path = Path(results)
            for doubt in results_doubts(path):  # a partial or changed file is scored, but never silently
                warnings.warn(doubt, stacklevel=2)
        if length is None:
            frames = [read_results(path).frames, read_ground_truth(gt).frames]
            length = int(max((f.max() for f in frames if len(f)), default=1))
        name = name or "sequence"
        return evaluate_files([(path, gt, length, name)]).sequences[name]


__all__ = ["Result", "evaluate", "track"]
