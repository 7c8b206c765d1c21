"""Where people are tracked: an image the size of the frames, dark where detections are ignored
(``[preprocess] mask``).

A detection is ignored when its foot point (the middle of its bottom edge, clipped into the image) falls on
a dark pixel: a poster, a mannequin, a shop window's reflection, a screen, the bonnet of the vehicle the camera
rides on, a clock burnt into the picture. Every detector box is tested, the ones tracked and the detector's
weak boxes alike; a person who walks in front of an ignored poster stands on the floor below it and is kept.
The mask is in the frame's pixels: with a moving camera it covers a part of the image, not of the scene.

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sotmot.boxes import as_boxes
from sotmot.errors import InputError
from sotmot.io.frames import decode_image_file

#: Pixels darker than this (0-255, the mask read as grey) ignore the detections standing on them.
DARK = 128


@dataclass(frozen=True, eq=False)
class Mask:
    """A mask read and checked against the frames' size.

    Attributes
    ----------
    path
        The image file.
    tracked
        ``(height, width)`` bool: True where detections are kept.
    """

    path: Path
    tracked: np.ndarray

    @property
    def ignored_share(self) -> float:
        """The share of the image's pixels where detections are ignored."""
        return float(1.0 - self.tracked.mean())

    def ignores(self, boxes: np.ndarray) -> np.ndarray:
        """``(N,)`` True for the ``(N, 4)`` ``x, y, w, h`` boxes whose foot point lies on an ignored pixel."""
        b = as_boxes(boxes) if len(boxes) else np.zeros((0, 4))
        height, width = self.tracked.shape
        x = np.clip(np.floor(b[:, 0] + 0.5 * b[:, 2]), 0, width - 1).astype(np.int64)
        y = np.clip(np.floor(b[:, 1] + b[:, 3]), 0, height - 1).astype(np.int64)
        return ~self.tracked[y, x]


def read_mask(path: str | Path, width: int, height: int, sequence: str = "the sequence") -> Mask:
    """The mask at ``path`` (any image OpenCV decodes; colour is read as grey), checked to be ``width`` x
    ``height`` pixels, the frames of ``sequence``.

    Raises
    ------
    InputError
        The file cannot be read or decoded, its size is not the frames', or it ignores every pixel.
    """
    path = Path(path).expanduser()
    try:
        st = path.stat()
    except OSError as exc:
        raise InputError(path, f"the mask cannot be read: {exc.strerror}") from None
    tracked = _read(str(path.resolve()), st.st_size, st.st_mtime_ns)
    if tracked.shape != (height, width):
        raise InputError(path, f"the mask is {tracked.shape[1]} x {tracked.shape[0]} pixels and the frames of "
                               f"{sequence} {width} x {height}: it must be the frames' size")
    if not tracked.any():
        raise InputError(path, f"the mask is dark everywhere, so every detection would be ignored; pixels of "
                               f"{DARK} and above (white) mark where people are tracked, darker ones where not")
    return Mask(path, tracked)


@functools.lru_cache(maxsize=4)
def _read(path: str, size: int, mtime_ns: int) -> np.ndarray:
    """The mask's pixels as ``tracked`` (read once per file version; a windowed run reads it for every window)."""
    import cv2

    grey = decode_image_file(path, cv2.IMREAD_GRAYSCALE, "the mask",
                             " (PNG, JPEG, BMP or any format OpenCV reads)")
    tracked = grey >= DARK
    tracked.setflags(write=False)
    return tracked
