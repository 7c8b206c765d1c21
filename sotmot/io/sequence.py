"""A sequence, whatever form it comes in: a MOTChallenge folder or a video file."""

from __future__ import annotations

from pathlib import Path

from sotmot.io.mot import SeqInfo, read_seqinfo_ini
from sotmot.io.video import is_video, video_info


def read_seqinfo(seq: str | Path, fps: float | None = None) -> SeqInfo:
    """The sequence ``seq``: a folder's ``seqinfo.ini``, or a video file read as a sequence of its own
    (:func:`sotmot.io.video.video_info`; frame rate ``fps`` when given, else the container's).

    Raises
    ------
    InputError
        What is wrong with the folder, its ``seqinfo.ini`` or the video, naming the file.
    """
    return video_info(seq, fps) if is_video(seq) else read_seqinfo_ini(seq)
