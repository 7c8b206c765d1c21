"""What every re-ID backend shares: the model-input contract, crops, batching and the flip average.

Made for Intel's Open Model Zoo person-reidentification-retail models
(input ``N x 3 x 256 x 128``, BGR, raw 0-255, mean and scale inside the model;
output ``N x D``), but any model with that input contract works. The model
file comes from the configuration or from the
environment variable ``SOTMOT_REID_MODEL``, else the bundled
person-reidentification-retail-0288 (:mod:`sotmot.models`).
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from sotmot.appearance.affinity import normalize
from sotmot.boxes import pixel_bounds
from sotmot.errors import ModelError
from sotmot.models import MODELS, resolve_model_file

log = logging.getLogger(__name__)

ENV_VAR = MODELS["reid"].env_var
CROP_HEIGHT = 256
CROP_WIDTH = 128


def resolve_model_path(model: str | None) -> Path:
    """The model path from the config, else from ``SOTMOT_REID_MODEL`` (it must exist), else the bundled one."""
    return resolve_model_file(model, "reid")


def check_model_io(path: Path, inputs: list[tuple[str, list]], outputs: list[tuple[str, list]]) -> tuple[str, object]:
    """The input name and embedding size of a re-ID model, or a :class:`ModelError` saying what is wrong.

    ``inputs`` and ``outputs`` are ``(name, shape)`` as the model file declares
    them (symbolic dimensions as strings). Every backend checks a model here:
    one input ``N x 3 x 256 x 128`` (BGR crops) and one output ``N x D``.
    """
    if len(inputs) != 1 or len(inputs[0][1]) != 4 or list(inputs[0][1])[1:] != [3, CROP_HEIGHT, CROP_WIDTH]:
        raise ModelError(f"{path}: not a person re-ID model of the expected kind: expected one input of shape "
                         f"N x 3 x {CROP_HEIGHT} x {CROP_WIDTH} (BGR crops), got {inputs}")
    if len(outputs) != 1 or len(outputs[0][1]) != 2:
        raise ModelError(f"{path}: expected one output of shape N x D (an embedding), got {outputs}")
    return inputs[0][0], outputs[0][1][1]


def flip_average(features: np.ndarray, mirrored: np.ndarray | None, source: object) -> np.ndarray:
    """Unit features from a network's raw outputs: ``features`` ``(N, D)`` of the crops and, with the
    flip of paper eq. 1, ``mirrored`` ``(N, D)`` of their mirror images (each normalised, averaged,
    normalised again). Every backend ends here.

    Raises
    ------
    ModelError
        An output is NaN or infinite (named after ``source``, the model file): a feature that
        cannot be compared must not enter tracking.
    """
    features = np.asarray(features, dtype=np.float32)
    if not np.isfinite(features).all() or (mirrored is not None and not np.isfinite(mirrored).all()):
        raise ModelError(f"{source}: the model gave NaN or infinite features; is it a re-ID model taking BGR "
                         f"0-255 crops?")
    if mirrored is None:
        return normalize(features)
    return normalize(normalize(features) + normalize(mirrored))


def crop_boxes(frame: np.ndarray, boxes: np.ndarray, height: int = CROP_HEIGHT,
               width: int = CROP_WIDTH) -> np.ndarray:
    """Crops of ``(N, 4)`` ``x, y, w, h`` boxes resized to ``(N, height, width, 3)`` uint8.

    Boxes are clipped to the image first (boxes partly outside the frame are
    common at image borders); a box entirely outside becomes the nearest
    one-pixel strip of the border.
    """
    import cv2

    x1, y1, x2, y2 = pixel_bounds(boxes, frame.shape[1], frame.shape[0])
    out = np.empty((len(x1), height, width, 3), dtype=np.uint8)
    for i in range(len(x1)):
        out[i] = cv2.resize(frame[y1[i]:y2[i], x1[i]:x2[i]], (width, height), interpolation=cv2.INTER_LINEAR)
    return out


def with_mirrored(crops: np.ndarray) -> np.ndarray:
    """``(2N, H, W, 3)``: the ``(N, H, W, 3)`` crops, then each mirrored left to right, in the same order (OpenCV
    flips a crop about 20 times faster than numpy copies a reversed view; the same bytes)."""
    import cv2

    crops = np.ascontiguousarray(crops)
    both = np.empty((2 * len(crops),) + crops.shape[1:], dtype=crops.dtype)
    both[:len(crops)] = crops
    for i, crop in enumerate(crops):
        cv2.flip(crop, 1, dst=both[len(crops) + i])
    return both


class CropEmbedder:
    """Flip-averaged re-ID features (paper eq. 1) of boxes, batching crops through a runtime.

    The feature of a box is the mean of the unit-normalised features of its
    crop and of the mirrored crop, normalised again. A runtime backend sets
    ``path``, ``flip``, ``batch_size`` and ``dim`` and implements
    :meth:`_run`; cropping, batching and flip-averaging live here, once.
    """

    path: Path
    flip: bool
    batch_size: int
    dim: int

    def _run(self, tensor: np.ndarray) -> np.ndarray:
        """Raw ``(B, D)`` features of one ``(B, 3, 256, 128)`` float32 BGR batch."""
        raise NotImplementedError

    def _forward(self, crops: np.ndarray) -> np.ndarray:
        """Raw features ``(N, D)`` of ``(N, 256, 128, 3)`` uint8 BGR crops."""
        out = np.empty((len(crops), self.dim), dtype=np.float32)
        for start in range(0, len(crops), self.batch_size):
            batch = crops[start:start + self.batch_size]
            out[start:start + len(batch)] = self._run(np.ascontiguousarray(batch.transpose(0, 3, 1, 2),
                                                                           dtype=np.float32))
        return out

    def embed_crops(self, crops: np.ndarray) -> np.ndarray:
        """Flip-averaged unit features ``(N, D)`` of ``(N, 256, 128, 3)`` uint8 BGR crops."""
        if len(crops) == 0:
            return np.zeros((0, self.dim), dtype=np.float32)
        raw = self._forward(with_mirrored(crops) if self.flip else crops)
        n = len(crops)
        return flip_average(raw[:n], raw[n:] if self.flip else None, self.path)

    def embed(self, frame: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Features ``(N, D)`` float32, unit length, of ``(N, 4)`` ``x, y, w, h`` boxes in ``frame``."""
        return self.embed_crops(crop_boxes(frame, boxes))


def fixed_dim(path: Path, dim: object) -> int:
    """The embedding size ``D`` a model declares, which must be a fixed number."""
    if not isinstance(dim, int):
        raise ModelError(f"{path}: the embedding size D of the output N x D must be fixed, got {dim!r}")
    return dim
