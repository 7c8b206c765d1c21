"""Hungarian tracklets on hand-built frames."""

import numpy as np

from sotmot.config import TrackletConfig
from sotmot.tracklets import batch_length, build_tracklets
from sotmot.types import Detections

from helpers import direction

RED, BLUE, GREEN = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)


def dets(rows):
    """rows: (frame, x, y, feature) with 20x40 boxes, score 1."""
    frames = [r[0] for r in rows]
    boxes = [[r[1], r[2], 20, 40] for r in rows]
    return Detections(frames, boxes, np.ones(len(rows))), np.array([r[3] for r in rows], dtype=np.float32)


def groups(tracklets):
    return [t.det_index.tolist() for t in tracklets]


def test_three_frames_two_people_crossing_are_matched_by_appearance():
    # red walks right, blue walks left; in frame 2 they are side by side, close enough that
    # IoU alone would be ambiguous, but appearance decides
    d, f = dets([(1, 0, 0, RED), (1, 30, 0, BLUE),
                 (2, 8, 0, RED), (2, 22, 0, BLUE),
                 (3, 16, 0, RED), (3, 14, 0, BLUE)])
    ts = build_tracklets(d, f, frame_rate=10, config=TrackletConfig(min_iou=0.0))
    assert groups(ts) == [[0, 2, 4], [1, 3, 5]]
    assert [t.id for t in ts] == [1, 2]


def test_hungarian_beats_greedy_choice():
    # tails A=(1,0,0) and B=(0.8,0.6,0); detection x=(0.9,0.44,0) is B's best and A's best,
    # detection y=(1,0,0) is A's only good match: the optimum gives y to A and x to B
    a, b = (1, 0, 0), (0.8, 0.6, 0)
    x, y = (0.9, 0.44, 0), (1, 0, 0)
    d, f = dets([(1, 0, 0, a), (1, 100, 0, b), (2, 0, 0, x), (2, 100, 0, y)])
    ts = build_tracklets(d, f, frame_rate=10, config=TrackletConfig(min_iou=0.0, min_affinity=0.0))
    assert sorted(groups(ts)) == [[0, 3], [1, 2]]


def test_affinity_and_iou_gates_and_l_min():
    d, f = dets([(1, 0, 0, RED), (2, 0, 0, BLUE), (3, 0, 0, BLUE), (1, 200, 0, GREEN), (2, 300, 0, GREEN)])
    cfg = TrackletConfig(min_affinity=0.6, min_iou=0.3)
    ts = build_tracklets(d, f, frame_rate=10, config=cfg)
    # red->blue fails the affinity gate; green jumps 100 px (IoU 0): both become singletons, dropped
    assert groups(ts) == [[1, 2]]
    cfg0 = TrackletConfig(min_affinity=0.6, min_iou=0.3, l_min=0)
    assert len(build_tracklets(d, f, frame_rate=10, config=cfg0)) == 4


def test_batches_cut_tracklets_every_second_and_a_missing_frame_closes_them():
    rows = [(k, 0, 0, RED) for k in (1, 2, 3, 4, 5, 7, 8)]
    d, f = dets(rows)
    # 2 fps -> batches of 2 frames: {1,2}, {3,4}, {5,6}, {7,8}; frame 6 is missing
    ts = build_tracklets(d, f, frame_rate=2, config=TrackletConfig(l_min=0))
    assert [t.frames.tolist() for t in ts] == [[1, 2], [3, 4], [5], [7, 8]]
    assert batch_length(7, 1.0) == 7 and batch_length(0.4, 1.0) == 1


def test_tail_mean_uses_last_detections():
    # the appearance turns 15 degrees per frame: each step passes the gate (cos 15 deg -> affinity 0.87),
    # but against the mean of the last tail features the 4th is 30 degrees off (affinity 0.74): cut
    # there; the second piece (45-75 deg) is cut the same way and the last detection is left alone
    feats = [(np.cos(a), np.sin(a), 0.0) for a in np.radians(15 * np.arange(7))]
    d, f = dets([(k + 1, 0, 0, feats[k]) for k in range(7)])
    cfg1 = TrackletConfig(tail=1, min_affinity=0.8, min_iou=0.0)
    cfg5 = TrackletConfig(tail=5, min_affinity=0.8, min_iou=0.0)
    assert len(build_tracklets(d, f, frame_rate=100, config=cfg1)[0]) == 7
    assert [len(t) for t in build_tracklets(d, f, frame_rate=100, config=cfg5)] == [3, 3]


def test_tracklet_feature_is_the_mean_of_its_detection_features():
    d, f = dets([(1, 0, 0, RED), (2, 0, 0, (0.8, 0.6, 0))])
    (t,) = build_tracklets(d, f, frame_rate=10, config=TrackletConfig(min_affinity=0.0))
    np.testing.assert_allclose(t.feature, [0.9, 0.3, 0.0], atol=1e-6)


def test_a_speeding_walker_stays_one_tracklet_only_when_the_box_is_predicted():
    """20-px-wide boxes: a first step of 8 px (IoU 0.43), then 16 px a frame, whose boxes overlap the last one
    at IoU 4/36 < min_iou 0.2: without the prediction the tracklet breaks every frame from the third on, with it
    the walk is one tracklet."""
    from sotmot.config import TrackletConfig
    from sotmot.tracklets import build_tracklets
    from sotmot.types import Detections

    x = np.array([0.0, 8, 24, 40, 56, 72])
    n = len(x)
    dets = Detections(frames=np.arange(1, n + 1), boxes=np.column_stack(
        [x, np.zeros(n), np.full(n, 20.0), np.full(n, 50.0)]), scores=np.ones(n))
    features = np.ones((n, 2), np.float32)
    assert len(build_tracklets(dets, features, 30, TrackletConfig(l_min=0))) == 5
    assert len(build_tracklets(dets, features, 30, TrackletConfig(l_min=0, predict=True))) == 1


def test_of_two_overlapping_tracklets_the_one_scoring_less_yields_the_detection_both_may_take():
    # front (scores 0.9) and behind (scores 0.5) overlap; in frame 3 the detector keeps one box, which looks a
    # little more like the one behind (affinity 0.97 against 0.95): the paper's matching gives it to the one behind
    front, behind, box = direction(0.0), direction(9.17), direction(5.73)
    rows = [(1, 0, 0, front), (1, 6, 0, behind), (2, 0, 0, front), (2, 6, 0, behind), (3, 3, 0, box)]
    d, f = dets(rows)
    d = Detections(d.frames, d.boxes, np.array([0.9, 0.5, 0.9, 0.5, 0.8]))
    paper = build_tracklets(d, f, frame_rate=10, config=TrackletConfig(l_min=0))
    assert groups(paper) == [[0, 2], [1, 3, 4]]
    yielding = build_tracklets(d, f, frame_rate=10, config=TrackletConfig(l_min=0, yield_weaker=0.05))
    assert groups(yielding) == [[0, 2, 4], [1, 3]]
    # apart (last boxes 30 px apart, IoU 0 with each other), nobody yields: the paper's matching again
    far = Detections(d.frames, d.boxes + np.array([[0, 0, 0, 0], [30, 0, 0, 0]] * 2 + [[0, 0, 0, 0]]), d.scores)
    assert groups(build_tracklets(far, f, frame_rate=10, config=TrackletConfig(l_min=0, min_iou=0.0,
                                                                                 yield_weaker=0.05))) == \
        groups(build_tracklets(far, f, frame_rate=10, config=TrackletConfig(l_min=0, min_iou=0.0)))
