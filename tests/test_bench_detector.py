"""scripts/bench_detector.py: recall by height band and precision from hand-made boxes."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import write_sequence
from helpers import load_script
from sotmot.io import read_seqinfo


def test_recall_is_counted_per_height_band_and_a_box_on_an_uncounted_person_is_no_false_one(tmp_path):
    script = load_script("bench_detector")
    # a 100-px-high frame: person 1 far (8 px high), person 2 mid (20 px), person 3 near (40 px); in frame 2 a
    # distractor (class 8) that a detection hits
    gt = ["1,1,10,10,4,8,1,1,1", "1,2,30,10,10,20,1,1,1", "1,3,50,10,20,40,1,1,1",
          "2,1,10,10,4,8,1,1,1", "2,4,70,10,10,20,1,8,1"]
    seq = write_sequence(tmp_path, [], length=2, width=100, height=100, images=False, gt_lines=gt)
    detections = [
        (np.array([[30.0, 10, 10, 20], [50, 10, 20, 40], [0, 80, 10, 10]]), np.array([0.9, 0.3, 0.9])),
        (np.array([[70.0, 10, 10, 20]]), np.array([0.8])),  # on the distractor
    ]
    info = read_seqinfo(seq)
    high, people = script.score(info, detections, 0.4, tmp_path / "work")  # the near person's box scores 0.3
    assert (high["recall_far"], high["recall_mid"], high["recall_near"]) == (0.0, 100.0, 0.0)
    assert people["far"] == 2 and people["mid"] == 1 and people["near"] == 1
    assert high["precision"] == pytest.approx(100 * 2 / 3)  # the box on no one is false, the distractor's is not
    low, _ = script.score(info, detections, 0.1, tmp_path / "work")
    assert low["recall_near"] == 100.0 and low["recall"] == pytest.approx(50.0)


def test_larger_inputs_keep_the_aspect_and_the_stride():
    script = load_script("bench_detector")
    assert script.scaled((448, 768), 1.25) == (576, 960)
    assert script.scaled((512, 672), 1.5) == (768, 1024)
