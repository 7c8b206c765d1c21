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

import os
import re
from pathlib import Path

from sotmot.errors import InputError
from sotmot.io.frames import read_image
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


def frames_folder(seq: str | Path) -> tuple[Path, list[Path]] | None:
    """Where the frames of a folder without ``seqinfo.ini`` lie, and the images there (:func:`image_files`): its
    ``img1/`` when that holds images, else the folder itself when it does; None when ``seq`` is not such a folder
    (it has a ``seqinfo.ini``, or no image)."""
    seq = Path(seq)
    if not seq.is_dir() or (seq / "seqinfo.ini").exists():
        return None
    for folder in (seq / "img1", seq):
        files = image_files(folder)
        if files:
            return folder, files
    return None


def image_folder_info(seq: str | Path, fps: float | None,
                      found: tuple[Path, list[Path]] | None = None) -> SeqInfo:
    """The sequence a folder of images is (see the module's docstring); ``fps`` its frame rate (NaN: read for
    what scoring needs, its name, length and ``gt.txt``, with no rate); ``found``: what :func:`frames_folder`
    gave for it, when the caller has asked already.

    Raises
    ------
    InputError
        No frame rate was given, it is above :data:`~sotmot.io.mot.MAX_FRAME_RATE`, the folder's name
        cannot name a sequence, or the first image does not decode.
    """
    seq = Path(seq)
    found = found or frames_folder(seq)
    if found is None:
        raise InputError(seq, "neither a MOTChallenge folder (seqinfo.ini) nor a folder of images")
    folder, files = found
    where = f"{len(files)} images{' in img1/' if folder != seq else ''} but no seqinfo.ini"
    if fps is None:
        raise InputError(seq, f"holds {where}, so no frame rate: give it (--fps N; "
                              f"sotmot.track(..., frame_rate=N)), or write a seqinfo.ini ([Sequence] name, "
                              f"frameRate, seqLength, imWidth, imHeight; frames img1/NNNNNN.jpg)")
    if fps > MAX_FRAME_RATE:  # NaN is not
        raise InputError(seq, f"--fps {fps:g} is above {MAX_FRAME_RATE:g} frames per second; every stage counts "
                              f"time in frames from it, so it must be the real rate")
    name = seq.resolve().name
    if not is_plain_name(name):
        raise InputError(seq, f"the folder's name {name!r} cannot name a sequence")
    return _sequence_of(seq, name, files, float(fps), folder.name if folder != seq else ".")


def image_list_info(files: "list[str | Path]", fps: float, name: str) -> SeqInfo:
    """The sequence of the image files ``files`` in the order given (frame 1 the first), at ``fps``, named ``name``
    (:func:`sotmot.track` on a list of paths). Its folder, where a ``det/det.txt`` would be looked for, is the one
    the files share.

    Raises
    ------
    InputError
        A file is missing, or the first does not decode.
    """
    files = [Path(f) for f in files]
    missing = next((f for f in files if not f.is_file()), None)
    if missing is not None:
        raise InputError(missing, f"frame {files.index(missing) + 1} of the list is not a file")
    folder = Path(os.path.commonpath([str(f.resolve().parent) for f in files]))
    return _sequence_of(folder, name, files, float(fps), ".")


def _sequence_of(path: Path, name: str, files: "list[Path]", fps: float, im_dir: str) -> SeqInfo:
    """The :class:`SeqInfo` of ``files``, frame 1 the first, its size the first image's."""
    import cv2

    first = read_image(files[0], 1, cv2.IMREAD_COLOR)
    return SeqInfo(path=path, name=name, frame_rate=fps, length=len(files), width=first.shape[1],
                   height=first.shape[0], im_dir=im_dir, im_ext="", files=tuple(files))
