"""``[preprocess] mask`` (``--mask``): detections standing on the mask's dark pixels are ignored."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from conftest import GeometryEmbedder, write_sequence
from sotmot.cli import main
from sotmot.config import TrackerConfig
from sotmot.errors import InputError
from sotmot.io import format_results
from sotmot.io.mask import read_mask
from sotmot.pipeline import track_sequence
from sotmot.sot.support import DetectorSupport

#: Two people walking right on a 320 x 240 frame: one on the upper half (feet at y = 100), one on the lower
#: (feet at y = 220).
LINES = [f"{f},-1,{10 + 8 * f},40,30,60,0.9,-1,-1,-1" for f in range(1, 13)] + \
        [f"{f},-1,{12 + 8 * f},100,40,120,0.9,-1,-1,-1" for f in range(1, 13)]


def mask_file(path: Path, width: int = 320, height: int = 240, dark=(slice(0, 0), slice(0, 0))) -> Path:
    image = np.full((height, width), 255, np.uint8)
    image[dark] = 0
    cv2.imwrite(str(path), image)
    return path


def track(seq: Path, mask: Path | None):
    config = TrackerConfig().replace("confirm", enabled=False).replace("preprocess", mask=mask and str(mask))
    return track_sequence(seq, config, embedder=GeometryEmbedder())


def test_a_box_is_ignored_by_its_foot_point(tmp_path):
    mask = read_mask(mask_file(tmp_path / "m.png", dark=(slice(100, 140), slice(50, 150))), 320, 240)
    boxes = np.array([[60, 40, 40, 80],     # feet at (80, 120): on the dark patch
                      [60, 0, 40, 60],      # the same column, feet at (80, 60): above it, kept
                      [60, 100, 40, 100],   # head on the patch, feet at (80, 200): below it, kept
                      [280, 60, 80, 60],    # feet at (320, 120), clipped to the last column: white
                      [-50, 90, 300, 30]])  # feet at (100, 120), a box partly outside the image
    assert mask.ignores(boxes).tolist() == [True, False, False, False, True]
    assert mask.ignored_share == pytest.approx(40 * 100 / (320 * 240))


def test_only_the_people_outside_the_mask_are_tracked(tmp_path):
    seq = write_sequence(tmp_path, LINES, length=12, frame_rate=4, width=320, height=240)
    lower = mask_file(tmp_path / "lower.png", dark=(slice(180, 240), slice(None)))
    result = track(seq, lower)
    assert result.tracks.n_tracks == 1
    assert (result.tracks.boxes[:, 1] + result.tracks.boxes[:, 3] < 180).all()
    assert len(result.detections) == 12
    # a mask that ignores nothing changes nothing
    assert format_results(track(seq, mask_file(tmp_path / "white.png")).tracks) == format_results(
        track(seq, None).tracks)


def test_the_detector_s_weak_boxes_are_masked_too(tmp_path):
    mask = read_mask(mask_file(tmp_path / "m.png", dark=(slice(180, 240), slice(None))), 320, 240)
    boxes = np.array([[10, 40, 30, 60], [10, 100, 40, 120]], float)
    found = {3: (boxes, np.array([0.3, 0.3]))}
    assert DetectorSupport.from_pass(found, mask)(3, None).tolist() == [[10, 40, 30, 60]]
    assert len(DetectorSupport.from_pass(found)(3, None)) == 2


@pytest.mark.parametrize("make, words", [
    (lambda p: p, "the mask cannot be read"),
    (lambda p: p.write_bytes(b"not an image") and p, "cannot be decoded as an image"),
    (lambda p: mask_file(p, 160, 120), "the mask is 160 x 120 pixels and the frames of SYN 320 x 240"),
    (lambda p: mask_file(p, dark=(slice(None), slice(None))), "dark everywhere"),
])
def test_a_bad_mask_is_one_error_naming_it(tmp_path, make, words):
    seq = write_sequence(tmp_path, LINES, length=12, frame_rate=4, width=320, height=240)
    path = tmp_path / "mask.png"
    make(path)
    with pytest.raises(InputError, match=words) as caught:
        track(seq, path)
    assert caught.value.path == path


def test_the_run_record_holds_the_mask_and_resume_sees_it_change(tmp_path, capsys):
    seq = write_sequence(tmp_path, LINES, length=12, frame_rate=4, width=320, height=240)
    mask, out = mask_file(tmp_path / "m.png", dark=(slice(180, 240), slice(None))), tmp_path / "out"
    args = ["track", str(seq), "--out", str(out), "--appearance", "none", "--mask", str(mask), "--resume"]
    assert main(args) == 0
    record = (out / "SYN.run.json").read_text()
    assert str(mask) in record and '"sha256"' in record
    assert main(args) == 0
    assert "skipped" in capsys.readouterr().out
    mask_file(mask, dark=(slice(0, 120), slice(None)))  # the same file, now the upper half
    assert main(args) == 0
    assert "skipped" not in capsys.readouterr().out
    tracked = np.loadtxt(out / "SYN.txt", delimiter=",", ndmin=2)
    assert (tracked[:, 3] + tracked[:, 5] > 120).all()
