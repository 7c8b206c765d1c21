"""Frames as every stage reads them: one reader, a bounded cache, and a source per kind of input.

A sequence's frames come from a MOTChallenge folder of JPEGs
(:class:`JpegFolder`) or straight from a video file (:class:`VideoFile`, no
temporary frames on disk). Stages never touch a source: they call a
:class:`FrameReader`, which keeps at most ``cache_size`` decoded frames (the
least recently used go first), so a stage that looks back or ahead (the SOT
windows, the end extension) decodes a frame once while it stays in the cache
and memory stays bounded for any length. A stage that knows which frame it
will ask for next says so (:meth:`FrameReader.prefetch`), and a folder of
JPEGs decodes it in a background thread meanwhile. Frames are 1-based,
images BGR ``uint8`` ``(H, W, 3)``, read-only.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from sotmot.errors import InputError
from sotmot.io.mot import SeqInfo

#: A video is read forward (grabbing the frames between) when the next frame asked for is at most this many
#: frames ahead; farther, or behind, it seeks. Grabbing a 1080p MPEG-4 frame costs about 2-4 ms, a seek 40-110 ms
#: (it decodes from the last key frame). A video whose seeks cost more reads farther ahead (:class:`VideoFile`
#: measures both): in an H.264 file with a key frame every 250 frames a seek costs 0.45 s, 150 frames grabbed.
SKIP_AHEAD = 24


def reduced_size(height: int, width: int, factor: int) -> tuple[int, int]:
    """``(height, width)`` of an image read ``factor`` times smaller on each side (rounded up, as JPEG does)."""
    return -(-height // factor), -(-width // factor)


#: A :class:`FrameReader` with at least this many frames of cache reads a video backwards a block at a time.
READ_BACK_CACHE = 8


#: Frames a :class:`FrameReader` decodes ahead at most (:meth:`FrameReader.prefetch`), beside its cache.
PREFETCH_AHEAD = 2
#: Frames :meth:`FrameReader.walking` keeps of a folder of JPEGs: with 2 the end extension decoded 271 frames of
#: the MOT17-09 video, with 8 259, and each 1080p frame held is 6 MB (MOT16-09's peak memory 600 -> 556 MB).
WALK_CACHE = 2


class FrameSource(Protocol):
    """Decodes one frame of a sequence; :attr:`decodes` counts the frames it decoded (tests, benchmarks).
    :attr:`independent`: any frame decodes on its own, from any thread, while another decodes (a folder of
    JPEGs), so a reader may decode ahead in the background; not a video (one decoder, read in order)."""

    decodes: int
    independent: bool

    def read(self, frame: int) -> np.ndarray:
        """The image of 1-based ``frame``; :class:`InputError` when it cannot be decoded."""
        ...

    def read_grey(self, frame: int, factor: int) -> np.ndarray:
        """``frame`` in grey, ``factor`` (1, 2, 4 or 8) times smaller on each side (rounded up): the full image
        made small (:func:`grey_reduced`), the same pixels from every source; the camera-motion estimate reads
        frames this way."""
        ...

    def close(self) -> None:
        """Release what the source holds open."""
        ...


def grey_reduced(image: np.ndarray, factor: int) -> np.ndarray:
    """A decoded BGR ``image`` in grey, ``factor`` times smaller on each side (rounded up; area averaging)."""
    import cv2

    grey = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    if factor == 1:
        return grey
    height, width = reduced_size(*grey.shape, factor)
    return cv2.resize(grey, (width, height), interpolation=cv2.INTER_AREA)


def read_image(path: Path, frame: int, flags: int) -> np.ndarray:
    """The image file of 1-based ``frame`` decoded by OpenCV with ``flags`` (``cv2.IMREAD_*``)
    (:func:`decode_image_file`)."""
    return decode_image_file(path, flags, f"frame {frame}")


def decode_image_file(path: Path | str, flags: int, what: str, formats: str = "") -> np.ndarray:
    """The image file at ``path`` decoded by OpenCV with ``flags`` (``cv2.IMREAD_*``); ``what`` names it in errors
    (``"frame 12"``, ``"the mask"``), ``formats`` follows "cannot be decoded as an image" there.

    The bytes are read by Python and decoded by OpenCV: ``cv2.imread`` crashes on some paths (not valid
    UTF-8), and an empty file would fail inside OpenCV rather than as the file's own error.

    Raises
    ------
    InputError
        The file cannot be read, or its bytes are not an image.
    """
    import cv2

    try:
        data = np.fromfile(path, dtype=np.uint8)
    except OSError as exc:
        raise InputError(path, f"{what} cannot be read: {exc.strerror}") from exc
    image = cv2.imdecode(data, flags) if len(data) else None
    if image is None:
        raise InputError(path, f"{what} cannot be decoded as an image{formats}")
    return image


class JpegFolder:
    """The ``img1/NNNNNN.jpg`` files of a MOTChallenge folder, each decoded on request."""

    independent = True

    def __init__(self, info: SeqInfo) -> None:
        self.info = info
        self.decodes = 0
        self._counting = threading.Lock()  # a reader's background thread decodes beside the caller's

    def read(self, frame: int) -> np.ndarray:
        import cv2

        return self._decode(frame, cv2.IMREAD_COLOR, 1)

    def read_grey(self, frame: int, factor: int) -> np.ndarray:
        # the full image made small, as frames in memory and a video's are (grey_reduced): JPEG's own reduced
        # decoding (DCT scaling) is cheaper but gives other pixels, and the camera's motion estimated from them
        # moved boxes by up to 1.9 px against the same frames handed over in memory (issue #89)
        return grey_reduced(self.read(frame), factor)

    def _decode(self, frame: int, flags: int, factor: int) -> np.ndarray:
        path = self.info.frame_path(frame)
        if not path.is_file():
            absent = "" if self.info.frames_dir.is_dir() else (
                f" (there is no {self.info.im_dir}/ folder: put the frames there, or track from the detections "
                f"alone with --appearance none, the motion-only mode)")
            raise InputError(path, f"frame {frame} is missing from {self.info.im_dir}/{absent}")
        try:
            image = read_image(path, frame, flags)
        finally:
            with self._counting:
                self.decodes += 1
        if image.shape[:2] != reduced_size(self.info.height, self.info.width, factor):
            said = (f"frame 1 is {self.info.width} x {self.info.height}" if self.info.files is not None
                    else f"seqinfo.ini says imWidth={self.info.width}, imHeight={self.info.height}")
            raise InputError(path, f"frame {frame} is {image.shape[1] * factor} x {image.shape[0] * factor} px but "
                             f"{said}")
        return image

    def close(self) -> None:
        pass


class VideoFile:
    """A video file read with OpenCV: forward reads in order, a seek only to go back or far ahead.

    Frame ``f`` is the video's ``f``-th decodable frame (the first is 1), the
    same numbering :func:`sotmot.io.video.video_info` counts and a ``det.txt``
    of the video uses.
    """

    independent = False

    def __init__(self, info: SeqInfo) -> None:
        self.info = info
        self.decodes = 0
        self.seeks = 0
        self._capture = None
        self._next = 1  # the frame the capture returns on its next read
        self._seek_seconds = 0.0  # the last seek's time, and a frame read forward's (a running mean)
        self._frame_seconds = 0.0

    @property
    def skip_ahead(self) -> int:
        """How far ahead a frame may be to be read forward rather than by a seek: :data:`SKIP_AHEAD`, or as many
        frames as a seek of this video was measured to cost, if more."""
        if self._frame_seconds <= 0:
            return SKIP_AHEAD
        return max(SKIP_AHEAD, int(self._seek_seconds / self._frame_seconds))

    @property
    def position(self) -> int:
        """The frame the next forward read returns without a seek."""
        return self._next

    def _open(self):
        import cv2

        capture = cv2.VideoCapture(str(self.info.video))
        if not capture.isOpened():
            raise InputError(self.info.video, "OpenCV cannot open this video")
        return capture

    def read(self, frame: int) -> np.ndarray:
        if not 1 <= frame <= self.info.length:
            raise InputError(self.info.video, f"frame {frame} is outside the video's frames 1..{self.info.length}")
        if self._capture is None:
            self._capture, self._next = self._open(), 1
        if frame < self._next or frame - self._next > self.skip_ahead:
            self._seek(frame)
        began, passed = time.perf_counter(), frame - self._next + 1
        while self._next < frame:  # a few frames ahead: grabbing them is cheaper than a seek
            if not self._capture.grab():
                self._ended(frame)
            self._next += 1
        ok, image = self._capture.read()
        if not ok or image is None:
            self._ended(frame)
        self._next += 1
        self.decodes += 1
        each = (time.perf_counter() - began) / passed
        self._frame_seconds = each if self._frame_seconds <= 0 else 0.9 * self._frame_seconds + 0.1 * each
        if image.shape[:2] != (self.info.height, self.info.width):
            raise InputError(self.info.video, f"frame {frame} is {image.shape[1]} x {image.shape[0]} px, not "
                             f"{self.info.width} x {self.info.height} as the first frame")
        return image

    def read_grey(self, frame: int, factor: int) -> np.ndarray:
        return grey_reduced(self.read(frame), factor)

    def _seek(self, frame: int) -> None:
        import cv2

        self.seeks += 1
        began = time.perf_counter()
        if self._capture.set(cv2.CAP_PROP_POS_FRAMES, frame - 1) and \
                int(self._capture.get(cv2.CAP_PROP_POS_FRAMES)) == frame - 1:
            self._next = frame
            self._seek_seconds = time.perf_counter() - began
            return
        # a container that cannot seek to a frame exactly: read again from the start
        self._capture.release()
        self._capture, self._next = self._open(), 1
        self._seek_seconds = self._frame_seconds * frame  # what reaching the frame will cost from the start

    def _ended(self, frame: int) -> None:
        raise InputError(self.info.video, f"frame {frame} of {self.info.length} cannot be decoded; the video may "
                         f"be damaged (re-encoding it, e.g. with ffmpeg, usually mends it)")

    def close(self) -> None:
        if self._capture is not None:
            self._capture.release()
            self._capture = None


def not_an_image(image: Any, frame: int) -> str | None:
    """What is wrong with ``image`` as 1-based ``frame`` of frames held in memory, or None for a BGR ``uint8``
    image (any size)."""
    if image is None:
        return (f"frame {frame} is None, not an image (cv2.imread and VideoCapture.read give None for a frame they "
                f"could not read)")
    if isinstance(image, (str, Path)):
        return (f"frame {frame} is a path ({str(image)!r}), not an image: read it (cv2.imread), or give sotmot.track "
                f"a list of the paths")
    array = np.asarray(image)
    if array.dtype != np.uint8 or array.ndim != 3 or array.shape[2] != 3:
        return (f"frame {frame} is a {array.dtype} array of shape {array.shape}; expected a BGR uint8 image "
                f"(height, width, 3), as OpenCV reads one")
    return None


class ArrayFrames:
    """Frames the caller holds (``info.frames``): a list, a 4-D array or any sequence of BGR ``uint8`` images,
    ``frames[k]`` being frame ``k + 1``, each fetched when a stage asks for it. Never changed: the reader
    marks a view read-only, not the caller's array."""

    independent = False  # nothing to decode ahead; and a window's frames come through another reader

    def __init__(self, info: SeqInfo) -> None:
        self.info = info
        self.decodes = 0

    def read(self, frame: int) -> np.ndarray:
        if not 1 <= frame <= self.info.length:
            raise InputError(self.info.path, f"frame {frame} is outside the frames 1..{self.info.length}")
        image = self.info.frames[frame - 1]
        self.decodes += 1
        problem = not_an_image(image, frame)
        image = np.asarray(image)
        if problem or image.shape != (self.info.height, self.info.width, 3):
            raise InputError(self.info.path, problem or f"frame {frame} is a {image.dtype} array of shape "
                             f"{image.shape}; expected BGR uint8 ({self.info.height}, {self.info.width}, 3) as the "
                             f"first frame")
        return image.view()

    def read_grey(self, frame: int, factor: int) -> np.ndarray:
        return grey_reduced(self.read(frame), factor)

    def close(self) -> None:
        pass


def frame_source(info: SeqInfo) -> FrameSource:
    """The source of ``info``'s frames: the images the caller holds, its video file, or its folder of JPEGs."""
    if info.frames is not None:
        return ArrayFrames(info)
    return VideoFile(info) if info.video is not None else JpegFolder(info)


class FrameReader:
    """Reads the frames of a sequence as BGR ``uint8`` arrays, keeping at most ``cache_size`` in memory.

    Parameters
    ----------
    info
        The sequence: a MOTChallenge folder or a video file (:func:`frame_source`).
    cache_size
        How many decoded frames to keep (least recently used are dropped), so
        stages that revisit frames do not decode them again; never more. A
        video read backwards fills it with the frames before the one asked
        for (up to ``cache_size - 2``, one seek for them all) when the cache
        holds at least :data:`READ_BACK_CACHE` frames; a :meth:`walking`
        reader does so reading forward too, with the frames it passes.
    ahead
        Decode every frame in the reader's thread, never the caller's, so that
        any source can be decoded ahead (:meth:`prefetch`), a video too, whose
        one decoder then reads the frames in the order they were asked for
        (:func:`sotmot.passes.frame_pass`: each next frame decodes while this
        one is searched).

    A reader is called from one thread; :meth:`prefetch` decodes ahead in a
    thread of its own (at most :data:`PREFETCH_AHEAD` frames beside the cache).
    ``decode_seconds`` adds up the time spent decoding, in whichever thread.
    """

    def __init__(self, info: SeqInfo, cache_size: int = 8, ahead: bool = False) -> None:
        if cache_size < 1:
            raise ValueError("a frame reader keeps at least one frame")
        self.info = info
        self.cache_size = cache_size
        self.source = frame_source(info)
        self.decode_seconds = 0.0
        self._timing = threading.Lock()
        self._cache: OrderedDict[int, np.ndarray] = OrderedDict()
        self._ahead: OrderedDict[int, Future] = OrderedDict()  # frame -> its decoding in the background
        self._decoder: ThreadPoolExecutor | None = None
        self._owned = ahead  # every decode in the reader's thread
        self._walked = False  # keep the frames passed reading forward (walking)

    @classmethod
    def walking(cls, info: SeqInfo) -> FrameReader:
        """A reader for a stage that walks frame by frame away from many starting frames, forward and back (the
        end extension, in frame order): a video keeps :data:`READ_BACK_CACHE` frames, and the frames before the
        one asked for come into the cache with it, read on the way forward (not grabbed past) or, behind, after
        one seek for the block, so a walk back from there seeks once a block at most; a folder of JPEGs keeps
        :data:`WALK_CACHE` and its caller decodes each next step ahead (:meth:`prefetch`)."""
        reader = cls(info, cache_size=READ_BACK_CACHE)
        reader._walked = True
        if reader.source.independent:
            reader.cache_size = WALK_CACHE
        return reader

    def prefetch(self, frame: int) -> None:
        """Start decoding 1-based ``frame`` in the background, for a stage that will ask for it next.

        Only a source whose frames decode independently does (a folder of
        JPEGs), or a reader made to decode ``ahead`` (a video: its one decoder
        reads in order, in the reader's thread alone); a frame already held or
        on its way, or outside the sequence, is left alone. At most
        :data:`PREFETCH_AHEAD` frames are decoded ahead: the oldest not asked
        for is forgotten. A frame that cannot be decoded raises its
        :class:`InputError` when it is asked for, not here.
        """
        if not (self.source.independent or self._owned) or frame in self._cache or frame in self._ahead \
                or not 1 <= frame <= self.info.length:
            return
        self._ahead[frame] = self._in_thread(self._read, frame)
        if len(self._ahead) > PREFETCH_AHEAD:
            self._ahead.popitem(last=False)[1].cancel()  # not asked for: dropped, or never started

    def _in_thread(self, work: Callable, *args) -> Future:
        if self._decoder is None:
            self._decoder = ThreadPoolExecutor(max_workers=1, thread_name_prefix="sotmot-decode")
        return self._decoder.submit(work, *args)

    def _read(self, frame: int) -> np.ndarray:
        began = time.perf_counter()
        try:
            return self.source.read(frame)
        finally:
            with self._timing:  # a JPEG folder's frames decode in the caller's thread too
                self.decode_seconds += time.perf_counter() - began

    def __call__(self, frame: int) -> np.ndarray:
        """The image of 1-based ``frame``, shape ``(H, W, 3)`` BGR, read-only.

        Raises
        ------
        InputError
            The frame is missing or cannot be decoded, or its size is not the sequence's.
        """
        cached = self._cache.get(frame)
        if cached is not None:
            self._cache.move_to_end(frame)
            return cached
        decoding = self._ahead.pop(frame, None)
        if decoding is not None:
            return self._keep(frame, decoding.result())
        if self._owned:
            return self._in_thread(self._missed, frame).result()
        return self._missed(frame)

    def _missed(self, frame: int) -> np.ndarray:
        """Decode ``frame``, not held nor on its way, into the cache (in the reader's thread when it owns the
        decoding; the caller waits)."""
        position = getattr(self.source, "position", None)
        if position is not None and self.cache_size >= READ_BACK_CACHE and (frame < position or self._walked):
            # a video read backwards (the end extension before a trajectory's first box): one seek, then the
            # frames up to this one read forward into the cache, so the next steps back cost no seek each; walking
            # forward, the frames on the way come into the cache too (not grabbed past), for a walk back from here
            first = max(1, frame - (self.cache_size - 2))
            if frame >= position:
                first = max(first, position)
            for earlier in range(first, frame):
                if earlier not in self._cache:
                    self._keep(earlier, self._read(earlier))
        return self._keep(frame, self._read(frame))

    def _keep(self, frame: int, image: np.ndarray) -> np.ndarray:
        image.setflags(write=False)
        self._cache[frame] = image
        self._cache.move_to_end(frame)
        if len(self._cache) > self.cache_size:
            self._cache.popitem(last=False)
        return image

    @property
    def cached(self) -> int:
        """How many decoded frames the reader holds now (never more than ``cache_size``)."""
        return len(self._cache)

    def close(self) -> None:
        """Release the source (an open video) and the thread decoding ahead; the reader reopens both if called
        again."""
        if self._decoder is not None:
            self._decoder.shutdown(wait=False, cancel_futures=True)
            self._decoder = None
        self._ahead.clear()
        self.source.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # interpreter shutdown: nothing left to release
            pass
