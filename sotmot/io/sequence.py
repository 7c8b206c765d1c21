"""A sequence, whatever form it comes in: a MOTChallenge folder, a video file or a folder of images."""

from __future__ import annotations

import math
from pathlib import Path

from sotmot.errors import ConfigError, InputError
from sotmot.io.images import frames_folder, image_folder_info
from sotmot.io.mot import SeqInfo, read_seqinfo_ini
from sotmot.io.video import VIDEO_SUFFIXES, is_video, video_info


def read_seqinfo(seq: str | Path, fps: float | None = None, *, rate_needed: bool = True) -> SeqInfo:
    """The sequence ``seq``: a folder's ``seqinfo.ini``, a video file read as a sequence of its own
    (:func:`sotmot.io.video.video_info`; frame rate ``fps`` when given, else the container's), or a folder of
    images without a ``seqinfo.ini`` (:func:`sotmot.io.images.image_folder_info`; frame rate ``fps``).
    ``rate_needed=False`` (scoring: a name, a length and a ``gt.txt`` are all it reads) lets a folder of images
    be read without ``fps``; its ``frame_rate`` is then NaN.

    Raises
    ------
    InputError
        What is wrong with the folder, its ``seqinfo.ini``, the video or the images, naming the file; a folder
        of images without ``fps``.
    ConfigError
        ``fps`` given for a folder, whose ``seqinfo.ini`` says its frame rate.
    """
    if is_video(seq):
        return video_info(seq, fps)
    if Path(seq).is_file():
        raise InputError(seq, _not_a_sequence(Path(seq)))
    found = frames_folder(seq)
    if found is not None:
        return image_folder_info(seq, fps if fps is not None or rate_needed else math.nan, found)
    if fps is not None and Path(seq).is_dir() and not (Path(seq) / "seqinfo.ini").is_file():
        raise InputError(seq, "holds neither images (.jpg, .png, ... here or in img1/) nor a seqinfo.ini: nothing "
                              "to track at --fps")
    if fps is not None:  # applied nowhere, it would only be recorded (and force a re-run on --resume)
        raise ConfigError(f"{seq}: --fps ([input] fps) is for a video or a folder of images; a sequence folder's "
                          f"frame rate is frameRate in its seqinfo.ini")
    return read_seqinfo_ini(seq)


def _not_a_sequence(path: Path) -> str:
    """Why the file ``path`` is no sequence, and what was likely meant: a run record or a settings file is given
    as the settings (``--config``, the API's ``config=``), beside the sequence."""
    if path.name.endswith(".run.json"):
        return ("a run record (how a results file was made), not a sequence: give the sequence its run tracked, "
                "and this file as --config FILE (config=FILE from Python) to use that run's settings")
    if path.suffix in (".toml", ".json"):
        return ("a settings file, not a sequence: give the sequence, and this file as --config FILE (config=FILE "
                "from Python)")
    return (f"a file, not a sequence folder; a video is known by its extension ({', '.join(VIDEO_SUFFIXES)}): "
            f"rename it if it is one")


def takes_frame_rate(seq: str | Path) -> bool:
    """Whether ``seq`` is read with a frame rate the caller gives (``--fps``): a video file or a folder of images,
    not a MOTChallenge folder (whose ``seqinfo.ini`` says its rate)."""
    return is_video(seq) or frames_folder(seq) is not None
