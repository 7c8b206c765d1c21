"""Video input: a video file (and a detector's output, if the user has one) become a MOTChallenge sequence folder.

Most users have a video, perhaps with a ``det.txt``, rather than a MOTChallenge folder.
:func:`sequence_from_video` decodes the video once with OpenCV into a folder
of JPEG frames beside a ``seqinfo.ini`` (name from the file name, frame rate
from the container or ``fps``, size from the first frame) and a copy of the
detections, so every command runs on it unchanged. Frames are 1-based, as in
MOTChallenge: the video's first frame is frame 1.
"""

from __future__ import annotations

import logging
import shutil
from collections.abc import Callable, Iterable
from pathlib import Path

from sotmot.errors import InputError
from sotmot.io.mot import MAX_FRAME_RATE, is_plain_name

#: File extensions taken for videos (anything else is a sequence folder).
VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov", ".m4v", ".webm", ".mpg", ".mpeg")
#: JPEG quality of the extracted frames.
JPEG_QUALITY = 95
log = logging.getLogger(__name__)


def is_video(path: str | Path) -> bool:
    """Whether ``path`` names a video file (by extension) rather than a sequence folder."""
    path = Path(path)
    return path.suffix.lower() in VIDEO_SUFFIXES and not path.is_dir()


def sequence_from_video(video: str | Path, work: str | Path, det: str | Path | None = None,
                        fps: float | None = None,
                        progress: Callable[[Iterable[int]], Iterable[int]] | None = None) -> Path:
    """Write ``work/<name>/`` (seqinfo.ini, img1/, det/det.txt) from ``video`` and return it.

    Parameters
    ----------
    video
        The video file.
    work
        A folder for the sequence (a temporary one, usually).
    det
        The detections (MOTChallenge ``det.txt`` layout, frames counted from 1
        at the video's first frame); None writes no ``det.txt``: the detector
        (``[detection] source = "auto"``) finds the people; render needs none.
    fps
        Frame rate; None takes the container's.

    Raises
    ------
    InputError
        The video cannot be opened or has no frame, its name is not a plain
        file name, the frame rate is unknown, or ``det`` is missing.
    """
    import cv2

    video = Path(video)
    if not video.is_file():
        raise InputError(video, "video file not found")
    if det is not None and not Path(det).is_file():
        raise InputError(Path(det), "detections file not found (--det)")
    name = video.stem
    if not is_plain_name(name):
        raise InputError(video, f"the file name {name!r} cannot name a sequence")
    capture = cv2.VideoCapture(str(video))
    if not capture.isOpened():
        raise InputError(video, "OpenCV cannot open this video")
    rate = fps if fps is not None else float(capture.get(cv2.CAP_PROP_FPS) or 0.0)
    if not rate or rate <= 0 or rate != rate:
        capture.release()
        raise InputError(video, "the container gives no frame rate; pass --fps")
    if rate > MAX_FRAME_RATE:
        capture.release()
        raise InputError(video, f"frame rate {rate:g} is above {MAX_FRAME_RATE:g} per second "
                         f"({'--fps' if fps is not None else 'the container says so'}); pass the real rate with --fps")
    announced = int(capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
    seq = Path(work) / name
    try:
        Path(work).mkdir(parents=True, exist_ok=True)
        seq.mkdir()  # a new folder: never one that was there before
    except FileExistsError:
        capture.release()
        raise InputError(seq, "already exists; decode the video into an empty folder") from None
    try:
        _fill_sequence(seq, video, capture, rate, announced, det, progress)
    except BaseException:
        shutil.rmtree(seq, ignore_errors=True)  # made by this call: nothing half-written stays
        raise
    finally:
        capture.release()
    return seq


def _fill_sequence(seq: Path, video: Path, capture, rate: float, announced: int, det: str | Path | None,
                   progress: Callable[[Iterable[int]], Iterable[int]] | None) -> None:
    """Decode ``capture`` into ``seq/img1`` and write ``seqinfo.ini`` and ``det/det.txt`` beside it."""
    import cv2

    (seq / "img1").mkdir()
    (seq / "det").mkdir()  # det/det.txt only with ``det``
    count, size = 0, None
    frames = iter(int, 1)  # 0, 0, ... until the video ends
    for _ in (progress(frames) if progress else frames):
        ok, image = capture.read()
        if not ok:
            break
        count += 1
        size = size or (image.shape[1], image.shape[0])
        if not cv2.imwrite(str(seq / "img1" / f"{count:06d}.jpg"), image, [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY]):
            raise InputError(seq / "img1", f"frame {count} could not be written (disk full?)")
    if count == 0 or size is None:
        raise InputError(video, "the video has no frame OpenCV can decode")
    if announced > count:
        log.warning("%s: the container announces %d frames but only %d could be decoded; the video may be "
                    "truncated or damaged, and frames %d to %d are not tracked", video, announced, count,
                    count + 1, announced)
    (seq / "seqinfo.ini").write_text(
        f"[Sequence]\nname={seq.name}\nimDir=img1\nframeRate={rate:g}\nseqLength={count}\n"
        f"imWidth={size[0]}\nimHeight={size[1]}\nimExt=.jpg\n", encoding="utf-8")
    if det is not None:  # without, the folder has no det/det.txt: the detector finds the people
        from sotmot.io.mot import read_detections

        read_detections(det, count, size)  # errors name the user's file and line, not the copy
        shutil.copyfile(det, seq / "det" / "det.txt")
