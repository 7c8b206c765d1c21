"""A sequence, whatever form it comes in: a MOTChallenge folder or a video file."""

from __future__ import annotations

from pathlib import Path

from sotmot.errors import ConfigError
from sotmot.io.mot import SeqInfo, read_seqinfo_ini
from sotmot.io.video import is_video, video_info


def read_seqinfo(seq: str | Path, fps: float | None = None) -> SeqInfo:
    """The sequence ``seq``: a folder's ``seqinfo.ini``, or a video file read as a sequence of its own
    (:func:`sotmot.io.video.video_info`; frame rate ``fps`` when given, else the container's).

    Raises
    ------
    InputError
        What is wrong with the folder, its ``seqinfo.ini`` or the video, naming the file.
    ConfigError
        ``fps`` given for a folder, whose ``seqinfo.ini`` says its frame rate.
    """
    if is_video(seq):
        return video_info(seq, fps)
    if fps is not None:  # applied nowhere, it would only be recorded (and force a re-run on --resume)
        raise ConfigError(f"{seq}: --fps ([input] fps) is for a video; a sequence folder's frame rate is frameRate in "
                          f"its seqinfo.ini")
    return read_seqinfo_ini(seq)
