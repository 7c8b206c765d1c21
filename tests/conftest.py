"""Shared fixtures: where the real data and models are, and tiny synthetic sequences.

Real data comes from ``../shared/data`` beside the project (override with
``SOTMOT_DATA``) and models from ``../shared/models`` (``SOTMOT_MODELS``).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("SOTMOT_DATA", ROOT.parent / "shared" / "data"))
MODELS = Path(os.environ.get("SOTMOT_MODELS", ROOT.parent / "shared" / "models"))
MODEL_0288 = MODELS / "person-reidentification-retail-0288.onnx"


def require(path: Path) -> Path:
    """Skip the test, naming the path, when shared data or a model is absent."""
    if not path.exists():
        pytest.skip(f"{path} not found (set SOTMOT_DATA / SOTMOT_MODELS to the shared folder)")
    return path


@pytest.fixture
def model_0288() -> Path:
    return require(MODEL_0288)


@pytest.fixture(scope="session")
def real_crops() -> np.ndarray:
    """24 ground-truth pedestrian crops of MOT16-04-clip30 (frames 1, 15, 30), as the re-ID backends take them."""
    from sotmot.appearance.base import crop_boxes
    from sotmot.io import FrameReader, read_ground_truth, read_seqinfo

    info = read_seqinfo(require(DATA / "MOT16-04-clip30"))
    gt = read_ground_truth(info.gt_path, info.length).pedestrians(0.5)
    reader = FrameReader(info)
    return np.concatenate([crop_boxes(reader(f), gt.boxes[gt.frames == f][:8]) for f in (1, 15, 30)])


def write_sequence(root: Path, det_lines: list[str], length: int = 5, frame_rate: float = 2,
                   width: int = 64, height: int = 48, name: str = "SYN", images: bool = True,
                   gt_lines: list[str] | None = None) -> Path:
    """A tiny MOTChallenge folder: seqinfo.ini, det/det.txt, optional gt/gt.txt and grey frames."""
    import cv2

    seq = root / name
    (seq / "det").mkdir(parents=True)
    (seq / "seqinfo.ini").write_text(
        f"[Sequence]\nname={name}\nimDir=img1\nframeRate={frame_rate}\nseqLength={length}\n"
        f"imWidth={width}\nimHeight={height}\nimExt=.jpg\n")
    (seq / "det" / "det.txt").write_text("".join(line + "\n" for line in det_lines))
    if gt_lines is not None:
        (seq / "gt").mkdir()
        (seq / "gt" / "gt.txt").write_text("".join(line + "\n" for line in gt_lines))
    if images:
        (seq / "img1").mkdir()
        for f in range(1, length + 1):
            cv2.imwrite(str(seq / "img1" / f"{f:06d}.jpg"), np.full((height, width, 3), 128, np.uint8))
    return seq


@contextmanager
def stopped_at_window(k: int) -> Iterator[None]:
    """Inside the block, ``sotmot.windows.Stitcher.add`` raises ``KeyboardInterrupt`` when window ``k`` (0-based)
    comes, as Ctrl-C or a kill between two windows stops a run; the real ``add`` is back after the block."""
    import sotmot.windows as windows

    real = windows.Stitcher.add

    def add(self, index, result):
        if index == k:
            raise KeyboardInterrupt
        return real(self, index, result)

    windows.Stitcher.add = add
    try:
        yield
    finally:
        windows.Stitcher.add = real


def write_video(path: Path, n: int = 12, fps: float = 5.0) -> Path:
    """A small MJPG ``.avi`` (120 x 80) of a dark block moving right 3 px a frame over grey."""
    import cv2

    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), fps, (120, 80))
    for f in range(1, n + 1):
        img = np.full((80, 120, 3), 120, np.uint8)
        img[20:60, 10 + 3 * f:30 + 3 * f] = 30
        writer.write(img)
    writer.release()
    return path


class GeometryEmbedder:
    """A deterministic stand-in for a re-ID model: the feature is a function of the box size.

    Boxes of (nearly) the same width and height get (nearly) the same feature,
    so synthetic people that keep their size keep their "appearance".
    """

    dim = 8

    def embed(self, frame: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        from sotmot.appearance import normalize

        b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        k = np.arange(1, self.dim + 1)
        feats = np.cos(np.outer(b[:, 2] / 7.0, k) + np.outer(b[:, 3] / 11.0, k[::-1]))
        return normalize(feats)
