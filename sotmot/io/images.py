"""A folder of images without a ``seqinfo.ini``: frames as a user extracted them, read as a sequence.

Many users have their frames as image files (``ffmpeg -i video.mp4 frames/%05d.png``, a camera's
dump, a dataset of another format) rather than a MOTChallenge folder. :func:`image_folder_info`
describes such a folder as a :class:`~sotmot.io.mot.SeqInfo`: the images directly in it, or in its
``img1/`` when it has one, in the order of their names with numbers compared as numbers
(``frame_2.png`` before ``frame_10.png``); frame 1 is the first of them, as in MOTChallenge. Its name
is the folder's; its size the first image's (every frame must match it); its frame rate is what the
caller gives (``--fps``), since images carry none. ``det/det.txt`` and ``gt/gt.txt`` are read where a
MOTChallenge folder has them, so a folder that lacks only its ``seqinfo.ini`` tracks as one.
"""

from __future__ import annotations

import re
from pathlib import Path

from sotmot.errors import InputError
from sotmot.io.mot import MAX_FRAME_RATE, SeqInfo, is_plain_name

#: File extensions taken for frames (lower case); what OpenCV decodes.
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".tif", ".tiff", ".webp")


def natural_key(name: str) -> tuple:
    """Sort key of a file name with its runs of digits compared as numbers: ``f2`` before ``f10``."""
    return tuple((0, int(part), part) if part.isdigit() else (1, 0, part.lower())
                 for part in re.split(r"(\d+)", name) if part)


def image_files(folder: Path) -> list[Path]:
    """The image files directly in ``folder``, in :func:`natural_key` order of their names (none: empty). Hidden
    files are not frames (macOS leaves a ``._name.jpg`` beside each image it copies to some drives)."""
    if not folder.is_dir():
        return []
    found = [p for p in folder.iterdir()
             if p.suffix.lower() in IMAGE_SUFFIXES and not p.name.startswith(".") and p.is_file()]
    return sorted(found, key=lambda p: natural_key(p.name))


def frames_folder(seq: str | Path) -> Path | None:
    """Where the frames of a folder without ``seqinfo.ini`` lie: its ``img1/`` when that holds images, else the
    folder itself when it does; None when ``seq`` is not such a folder (it has a ``seqinfo.ini``, or no image)."""
    seq = Path(seq)
    if not seq.is_dir() or (seq / "seqinfo.ini").exists():
        return None
    for folder in (seq / "img1", seq):
        if image_files(folder):
            return folder
    return None


def image_folder_info(seq: str | Path, fps: float | None) -> SeqInfo:
    """The sequence a folder of images is (see the module's docstring); ``fps`` its frame rate (NaN: read for
    what scoring needs, its name, length and ``gt.txt``, with no rate).

    Raises
    ------
    InputError
        No frame rate was given, it is above :data:`~sotmot.io.mot.MAX_FRAME_RATE`, the folder's name
        cannot name a sequence, or the first image does not decode.
    """
    import cv2
    import numpy as np

    seq = Path(seq)
    folder = frames_folder(seq)
    if folder is None:
        raise InputError(seq, "neither a MOTChallenge folder (seqinfo.ini) nor a folder of images")
    files = image_files(folder)
    where = f"{len(files)} images{' in img1/' if folder != seq else ''} but no seqinfo.ini"
    if fps is None:
        raise InputError(seq, f"holds {where}, so no frame rate: give it (sotmot track --fps N, "
                              f"sotmot.track(..., frame_rate=N)), or write a seqinfo.ini ([Sequence] name, "
                              f"frameRate, seqLength, imWidth, imHeight; frames img1/NNNNNN.jpg)")
    if fps > MAX_FRAME_RATE:  # NaN is not
        raise InputError(seq, f"--fps {fps:g} is above {MAX_FRAME_RATE:g} frames per second; every stage counts "
                              f"time in frames from it, so it must be the real rate")
    name = seq.resolve().name
    if not is_plain_name(name):
        raise InputError(seq, f"the folder's name {name!r} cannot name a sequence")
    try:
        first = cv2.imdecode(np.fromfile(files[0], dtype=np.uint8), cv2.IMREAD_COLOR)
    except OSError as exc:
        raise InputError(files[0], f"frame 1 cannot be read: {exc.strerror}") from exc
    if first is None:
        raise InputError(files[0], "frame 1 cannot be decoded as an image")
    return SeqInfo(path=seq, name=name, frame_rate=float(fps), length=len(files), width=first.shape[1],
                   height=first.shape[0], im_dir=folder.name if folder != seq else ".", im_ext="",
                   files=tuple(files))
