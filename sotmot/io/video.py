"""Video input: a video file is a sequence of its own, its frames read straight from the file.

Most users have a video, perhaps with a ``det.txt``, rather than a MOTChallenge
folder. :func:`video_info` describes a video as a :class:`~sotmot.io.mot.SeqInfo`
(name from the file name, frame rate from the container or ``fps``, size from
the first frame), and :class:`~sotmot.io.frames.VideoFile` decodes its frames
on demand, so every stage runs on it unchanged and nothing is written to disk
but the results. Frames are 1-based, as in MOTChallenge: the video's first
frame is frame 1.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Iterator
from functools import lru_cache
from pathlib import Path

from sotmot.errors import InputError
from sotmot.io.mot import MAX_FRAME_RATE, SeqInfo, is_plain_name

#: File extensions taken for videos (anything else is a sequence folder).
VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov", ".m4v", ".webm", ".mpg", ".mpeg", ".ts", ".mts", ".m2ts", ".3gp",
                  ".wmv", ".flv", ".ogv")
log = logging.getLogger(__name__)


def is_video(path: str | Path) -> bool:
    """Whether ``path`` names a video file (by extension) rather than a sequence folder."""
    path = Path(path)
    return path.suffix.lower() in VIDEO_SUFFIXES and not path.is_dir()


def video_info(video: str | Path, fps: float | None = None) -> SeqInfo:
    """The sequence a video file is: ``path`` and ``video`` the file, ``length`` its decodable frames.

    The frame count is the container's when its last frame decodes (one
    seek); otherwise (a truncated or damaged file, or a container that gives
    none) the frames are counted by reading through the file once, with a
    warning when fewer than announced. Described once per file, size,
    modification time and ``fps`` in a process.

    Raises
    ------
    InputError
        The video is missing, cannot be opened or has no frame, its name is
        not a plain file name, or the frame rate is unknown or above
        :data:`~sotmot.io.mot.MAX_FRAME_RATE` (``fps`` overrides the container's).
    """
    video = Path(video)
    if not video.is_file():
        raise InputError(video, "video file not found")
    st = video.stat()
    return _video_info(video.resolve(), video, st.st_size, st.st_mtime_ns, fps)


@lru_cache(maxsize=64)
def _video_info(resolved: Path, given: Path, size: int, mtime_ns: int, fps: float | None) -> SeqInfo:
    import cv2

    name = given.stem
    if not is_plain_name(name):
        raise InputError(given, f"the file name {name!r} cannot name a sequence")
    capture = cv2.VideoCapture(str(resolved))
    try:
        if not capture.isOpened():
            raise InputError(given, "OpenCV cannot open this video")
        rate = _frame_rate(capture, fps, given, "the container")
        ok, first = capture.read()
        if not ok or first is None:
            raise InputError(given, "the video has no frame OpenCV can decode")
        announced = int(capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        length = announced if announced > 0 and _decodes(capture, announced) else _count(resolved)
        if announced > length:
            log.warning("%s: the container announces %d frames but only %d could be decoded; the video may be "
                        "truncated or damaged, and frames %d to %d are not tracked", given, announced, length,
                        length + 1, announced)
    finally:
        capture.release()
    return SeqInfo(path=given, name=name, frame_rate=float(rate), length=length, width=first.shape[1],
                   height=first.shape[0], im_dir="", im_ext=given.suffix, video=given)


def _frame_rate(capture, fps: float | None, where: str | Path, what: str) -> float:
    """``fps``, else the rate an open ``cv2.VideoCapture`` gives (``what``: "the container", "the source").

    Raises
    ------
    InputError
        No rate (pass ``--fps``), or one above :data:`~sotmot.io.mot.MAX_FRAME_RATE`.
    """
    import cv2

    rate = fps if fps is not None else float(capture.get(cv2.CAP_PROP_FPS) or 0.0)
    if not rate or rate <= 0 or rate != rate:
        raise InputError(where, f"{what} gives no frame rate; pass --fps")
    if rate > MAX_FRAME_RATE:
        raise InputError(where, f"frame rate {rate:g} is above {MAX_FRAME_RATE:g} per second "
                                f"({'--fps' if fps is not None else f'{what} says so'}); pass the real rate with "
                                f"--fps")
    return float(rate)


def _decodes(capture, frame: int) -> bool:
    """Whether 1-based ``frame`` decodes, and no frame follows it."""
    import cv2

    if not capture.set(cv2.CAP_PROP_POS_FRAMES, frame - 1):
        return False
    ok, image = capture.read()
    return bool(ok) and image is not None and not capture.grab()


def _count(video: Path) -> int:
    """The decodable frames, counted from the start (grabbed, not converted)."""
    import cv2

    capture = cv2.VideoCapture(str(video))
    count = 0
    while capture.grab():
        count += 1
    capture.release()
    return count


#: A live source named by a URL: ``scheme://...`` (rtsp, http, udp, ...; a scheme of two letters or more, so
#: that ``C://`` is a drive), as OpenCV's FFmpeg back end opens them.
URL = re.compile(r"^[A-Za-z][A-Za-z0-9+.-]+://")


def paced(source: str) -> bool:
    """Whether a live source is a camera (its number) or a stream (a URL): it gives frames at its own pace,
    whoever reads them, and has no end of its own; else it is a video file."""
    return source.isdigit() or bool(URL.match(source))


def shown(source: str) -> str:
    """A live source as messages and run records name it: a URL's password replaced by ``***``
    (``rtsp://admin:secret@cam/live`` -> ``rtsp://admin:***@cam/live``; cameras are often opened so)."""
    if not URL.match(source):
        return source
    scheme, rest = source.split("://", 1)
    userinfo, at, host = rest.partition("@") if "@" in rest.split("/", 1)[0] else ("", "", rest)
    if ":" in userinfo:
        userinfo = userinfo.split(":", 1)[0] + ":***"
    return f"{scheme}://{userinfo}{at}{host}"


def live_name(source: str) -> str:
    """The name a live source's results get (``<name>.txt``): ``camera0`` for camera 0, a URL's host and path
    (no user or password) with every run of other characters than letters, digits, ``.``, ``_`` and ``-`` made
    one ``-`` (``rtsp://admin:pw@10.0.0.5:554/live`` -> ``10.0.0.5-554-live``), a video file's stem."""
    if source.isdigit():
        return f"camera{int(source)}"
    if URL.match(source):
        rest = source.split("://", 1)[1].split("?", 1)[0]
        host, slash, path = rest.partition("/")
        where = host.rpartition("@")[2] + slash + path
        return re.sub(r"[^A-Za-z0-9._-]+", "-", where).strip("-.") or "stream"
    return Path(source).stem


def open_live(source: str, fps: float | None = None) -> tuple[Iterator, float, str]:
    """Open a live source for :func:`sotmot.stream`: a camera (its number, ``"0"``), a network stream (a URL:
    ``rtsp://``, ``http://``, ...) or a video file read as it plays, once and from its start.

    Returns its frames (a generator of BGR images that releases the source when it ends or is closed; a read
    that fails ends it, as OpenCV cannot tell a dropped connection from the end of a stream), its frame rate
    (``fps``, else the source's) and its name (:func:`live_name`).

    Raises
    ------
    InputError
        OpenCV cannot open the source, the source gives no frame rate (pass ``fps``) or one above
        :data:`~sotmot.io.mot.MAX_FRAME_RATE`, or the name is not a plain file name (the source named as
        :func:`shown` names it).
    """
    import cv2

    name, where = live_name(source), shown(source)
    if not is_plain_name(name):
        raise InputError(where, f"the name {name!r} it would give its results cannot name a file")
    if not paced(source) and not Path(source).is_file():
        raise InputError(where, "not found: a live source is a camera's number (0), a stream's URL "
                                "(rtsp://..., http://...) or a video file")
    capture = cv2.VideoCapture(int(source) if source.isdigit() else source)
    try:
        if not capture.isOpened():
            raise InputError(where, "OpenCV cannot open this source (a camera's number, a stream's URL or a "
                                    "video file)")
        rate = _frame_rate(capture, fps, where, "the source")
    except BaseException:
        capture.release()
        raise

    def frames() -> Iterator:
        try:
            while True:
                ok, image = capture.read()
                if not ok or image is None:
                    return
                yield image
        finally:
            capture.release()

    return frames(), float(rate), name
