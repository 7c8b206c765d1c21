"""The glue that runs other trackers on sotmot's inputs for the benchmarks (``sotmot.peers``)."""

from pathlib import Path

import numpy as np
import pytest

from sotmot.io import SeqInfo
from sotmot.peers import SeqInput, as_tracks, frames_of, peer_scores, run_peer
from sotmot.types import Detections


def test_peer_scores_keep_probabilities_and_rank_the_rest():
    probabilities = np.array([0.2, 0.9, 0.5])
    assert np.array_equal(peer_scores(probabilities), probabilities)
    dpm = np.array([-1.5, 3.0, 0.2, 0.2])
    mapped = peer_scores(dpm)
    assert mapped.min() > 0 and mapped.max() == 1.0
    assert mapped[0] < mapped[2] == mapped[3] < mapped[1]  # monotone, ties kept


def scene(length=4):
    info = SeqInfo(path=Path("toy"), name="toy", frame_rate=10.0, length=length, width=200, height=100)
    frames = [1, 1, 2, 4]
    dets = Detections(frames, [[10, 10, 20, 40], [100, 10, 20, 40], [12, 10, 20, 40], [16, 10, 20, 40]],
                      [0.9, 0.8, 0.9, 0.9])
    feats = np.eye(4, dtype=np.float32)[[0, 1, 0, 0]]
    return SeqInput(None, info, dets, feats, peer_scores(dets.scores), 0.0)


def test_frames_of_lists_every_frame_with_its_rows():
    rows = frames_of(scene())
    assert [r.tolist() for r in rows] == [[0, 1], [2], [], [3]]


def test_peer_output_becomes_tracks_with_consecutive_ids():
    out = as_tracks([(1, np.array([7, 3]), np.array([[0, 0, 10, 20], [5, 5, 15, 25]], float), np.ones(2)),
                   (2, np.array([7]), np.array([[1, 0, 11, 20]], float), np.ones(1))], boxes_are_xyxy=True)
    assert sorted(set(out.ids.tolist())) == [1, 2] and out.boxes[0].tolist() == [0, 0, 10, 20]


def test_deepsort_runs_on_sotmot_features():
    pytest.importorskip("deep_sort_realtime")
    tracks, seconds = run_peer("DeepSORT", scene(), min_affinity=0.5)
    assert seconds >= 0 and set(tracks.frames.tolist()) <= {1, 2, 3, 4}


def test_gsi_over_seconds_writes_one_box_per_track_and_frame():
    """boxmot's interpolation computes frames as floats: between frames 2 and 25 one lands a hair below an
    integer and a frame of the track came out twice (issue #38's 4-s rows); the peers' rows keep one box."""
    pytest.importorskip("boxmot")
    from sotmot.peers import gsi
    from sotmot.types import Tracks

    boxes = np.array([[0, 0, 20, 40], [10, 0, 20, 40.0]])
    tracks = Tracks(frames=np.array([2, 25]), ids=np.array([1, 1]), boxes=boxes, scores=np.ones(2))
    out = gsi(tracks, interval=120)
    assert sorted(out.frames.tolist()) == list(range(2, 26))  # every frame once


def test_trackers_given_sotmot_memory_keep_a_lost_person_and_fill_the_gap():
    """A person walking 2 px a frame is missed for 2 s at 10 fps: SORT as it comes (a lost track kept 1 s) starts
    a new track; ``SORT +GSI 4s`` keeps the same one and boxmot's GSI fills the gap."""
    pytest.importorskip("trackers")
    pytest.importorskip("boxmot")
    seen = [f for f in range(1, 51) if not 11 <= f <= 30]
    info = SeqInfo(path=Path("toy"), name="toy", frame_rate=10.0, length=50, width=400, height=200)
    dets = Detections(seen, [[10 + 2 * f, 50, 30, 80] for f in seen], [0.9] * len(seen))
    seq = SeqInput(None, info, dets, np.zeros((len(seen), 0), np.float32), peer_scores(dets.scores), 0.0)
    plain, _ = run_peer("SORT", seq, min_affinity=0.5)
    kept, _ = run_peer("SORT +GSI 4s", seq, min_affinity=0.5)
    assert len(set(plain.ids.tolist())) == 2
    assert len(set(kept.ids.tolist())) == 1 and {20, 25} <= set(kept.frames.tolist())
