"""The motion-only mode (``[appearance] backend = "none"``): tracking with geometry alone, frames or none."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np
import pytest

from conftest import DATA, require, write_sequence
from sotmot.appearance import make_embedder
from sotmot.association.affinity import link_affinities, motion_affinities
from sotmot.config import AppearanceConfig, TrackerConfig
from sotmot.confidence.box_model import FEATURES, BoxModel
from sotmot.errors import ConfigError
from sotmot.pipeline import track_sequence
from sotmot.tracklets import build_tracklets
from sotmot.types import Detections, Tracklet

MOTION_ONLY = TrackerConfig().replace("appearance", backend="none")


def walker(tid: int, frames: range, x0: float, vx: float, y: float = 100.0, w: float = 40.0) -> Tracklet:
    """A person walking right at ``vx`` px/frame: ``x = x0 + vx (f - first)``, 40 x 100 px boxes."""
    f = np.asarray(frames)
    boxes = np.stack([x0 + vx * (f - f[0]), np.full(len(f), y), np.full(len(f), w), np.full(len(f), 100.0)], 1)
    return Tracklet(id=tid, frames=f, boxes=boxes, scores=np.ones(len(f)), det_index=f + 1000 * tid,
                    feature=np.zeros(0, np.float32), n_features=len(f))


def test_motion_affinity_prefers_the_trajectory_where_the_walk_leads():
    before = walker(1, range(1, 11), 0.0, 5.0)  # at x = 45 in frame 10
    same = walker(2, range(31, 41), 150.0, 5.0)  # where 20 more frames of walking lead: x = 45 + 5 * 21
    stopped = walker(3, range(31, 41), 40.0, 0.0)  # someone standing where the first one was last seen
    other = walker(4, range(31, 41), 300.0, 0.0)  # someone standing elsewhere
    aff = motion_affinities([before, same, stopped, other], np.array([[0, 1], [0, 2], [0, 3]]))
    assert aff[0] > 0.9  # the prediction lands on the box
    assert aff[0] > aff[1] > aff[2]  # one prediction of two lands: in between
    assert aff[2] < 0.45  # below the association gate: neither walk leads there


def test_motion_affinity_of_meeting_spans_is_their_iou_in_the_later_start():
    a = walker(1, range(1, 11), 0.0, 0.0)
    b = walker(2, range(5, 15), 20.0, 0.0)  # shifted by half a width in every shared frame
    assert motion_affinities([a, b], np.array([[1, 0]]))[0] == pytest.approx(20 * 100 / (60 * 100))


def test_a_tracklet_inside_a_gap_scores_by_the_walk_it_fills():
    # one person walking right at 5 px a frame, seen in frames 1-10 and 41-50; gap 11-40
    first, second = walker(1, range(1, 11), 0.0, 5.0), walker(1, range(41, 51), 200.0, 5.0)
    a = Tracklet(id=1, frames=np.r_[first.frames, second.frames], boxes=np.r_[first.boxes, second.boxes],
                 scores=np.ones(20), det_index=np.arange(20), feature=np.zeros(0, np.float32), n_features=20)
    on_the_walk = walker(2, range(21, 31), 100.0, 5.0)  # where the walk is in frames 21-30
    off_the_walk = walker(3, range(21, 31), 100.0, 0.0, y=400.0)  # someone standing elsewhere meanwhile
    past_the_gap = walker(4, range(21, 46), 100.0, 5.0)  # starts in the gap, runs past it
    aff = motion_affinities([a, on_the_walk, off_the_walk, past_the_gap], np.array([[0, 1], [2, 0], [0, 3]]))
    assert aff[0] > 0.9  # both joins land: it fills the gap
    assert aff[1] < 0.45  # below the association gate
    assert aff[2] == 0.0  # the IoU rule's case, with no box of the first where it starts


def test_over_a_gap_of_more_than_a_second_only_a_slow_person_is_joined():
    config = MOTION_ONLY.association.at(10.0)  # 10 fps: 0.75 heights (75 px) a second at most over a long gap
    before = walker(1, range(1, 11), 0.0, 7.0)  # walking 0.7 heights a second, seen up to x = 63 in frame 10
    walked_on = walker(2, range(31, 41), 203.0, 7.0)  # where 2.1 s more of that walk lead: 0.67 / s
    ran_on = walker(3, range(31, 41), 243.0, 9.0)  # 180 px in 2.1 s: 0.86 heights a second
    soon = walker(4, range(16, 26), 138.0, 15.0)  # 75 px after 0.6 s: fast, but not a long gap
    pairs = np.array([[0, 1], [0, 2], [0, 3]])
    free = motion_affinities([before, walked_on, ran_on, soon], pairs)
    limited = motion_affinities([before, walked_on, ran_on, soon], pairs, config)
    assert (free > 0.45).all()  # the walk's line leads to each
    assert limited[0] == free[0] and limited[2] == free[2]  # slow enough, or a gap of under a second
    assert limited[1] == 0.0  # too far for the time
    unlimited = dataclasses.replace(config, motion_gap_speed=None)
    assert motion_affinities([before, ran_on], np.array([[0, 1]]), unlimited)[0] == free[1]
    # appearance decides wherever re-ID runs: the rule is the motion-only affinity's
    units = np.array([[1.0, 0.0], [1.0, 0.0]])
    assert link_affinities([before, ran_on], np.array([[0, 1]]), units, config)[0] == pytest.approx(1.0)


def test_the_objectives_read_the_motion_affinity_too():
    # compare scores every solver on the flow and lifted objectives, and the lifted solver maximises the latter:
    # without re-ID they must see the affinity the solvers rank links by, not that of empty features
    from sotmot.association.objective import entry_cost, flow_objective, link_cost, pair_inputs

    config = MOTION_ONLY.association.at(10.0)
    before, walked_on = walker(1, range(1, 11), 0.0, 5.0), walker(2, range(16, 26), 75.0, 5.0)
    motion = motion_affinities([before, walked_on], np.array([[0, 1]]), config)[0]
    assert motion > 0.9
    expected = entry_cost(config) + link_cost(motion)
    assert flow_objective([before, walked_on], [(1, 2)], config) == pytest.approx(expected)
    assert pair_inputs([before, walked_on], np.array([0]), np.array([1]), config)[0][0] == motion


def test_link_affinities_use_appearance_whenever_features_exist():
    a, b = walker(1, range(1, 5), 0.0, 1.0), walker(2, range(8, 12), 300.0, 1.0)
    units = np.array([[1.0, 0.0], [1.0, 0.0]])
    assert link_affinities([a, b], np.array([[0, 1]]), units)[0] == pytest.approx(1.0)  # same look, far apart
    assert link_affinities([a, b], np.array([[0, 1]]), np.zeros((2, 0)))[0] < 0.1  # no look: the walk decides


def test_tracklets_without_features_follow_the_box_overlap():
    # two people crossing nothing: one still, one walking 5 px a frame, three frames
    frames = np.array([1, 1, 2, 2, 3, 3])
    boxes = np.array([[0, 0, 40, 100], [200, 0, 40, 100], [0, 0, 40, 100], [205, 0, 40, 100],
                      [0, 0, 40, 100], [210, 0, 40, 100]], float)
    dets = Detections(frames=frames, boxes=boxes, scores=np.ones(6))
    tracklets = build_tracklets(dets, np.zeros((6, 0), np.float32), frame_rate=10)
    assert sorted(t.det_index.tolist() for t in tracklets) == [[0, 2, 4], [1, 3, 5]]


def test_the_none_backend_embeds_nothing():
    embedder = make_embedder(AppearanceConfig(backend="none"))
    assert embedder.embed(np.zeros((10, 10, 3), np.uint8), np.ones((3, 4))).shape == (3, 0)


def test_a_missing_box_feature_counts_as_its_training_mean():
    model = BoxModel(mean=tuple(range(len(FEATURES))), scale=(1.0,) * len(FEATURES),
                     coef=(0.5,) * len(FEATURES), intercept=0.1)
    x = np.arange(len(FEATURES), dtype=float)[None, :] + 1.0
    missing = x.copy()
    missing[0, FEATURES.index("track_appearance")] = np.nan
    at_mean = x.copy()
    at_mean[0, FEATURES.index("track_appearance")] = model.mean[FEATURES.index("track_appearance")]
    assert model.predict(missing)[0] == pytest.approx(model.predict(at_mean)[0])


def test_a_sequence_without_frames_is_tracked_from_its_labels(tmp_path):
    """A label-only copy of a clip (no img1/): tracked in the motion-only mode, no frame read, the same people."""
    clip = require(DATA / "MOT16-02-clip30")
    seq = tmp_path / "MOT16-02-clip30"
    seq.mkdir()
    for part in ("seqinfo.ini", "det", "gt"):
        (shutil.copytree if (clip / part).is_dir() else shutil.copy)(clip / part, seq / part)
    result = track_sequence(seq, MOTION_ONLY)
    assert result.features.shape == (len(result.detections), 0)
    assert not result.motion.moving
    assert result.tracks.n_tracks >= 5  # MOT16-02's first second: about a dozen people, most detected
    assert len(result.tracks) > 0.5 * len(result.detections)


def test_the_motion_only_mode_needs_no_model_and_refuses_sot(tmp_path):
    seq = write_sequence(tmp_path, [f"{f},-1,{5 + f},10,10,20,1" for f in range(1, 6)], images=False)
    result = track_sequence(seq, MOTION_ONLY)
    assert result.tracks.n_tracks == 1
    with pytest.raises(ConfigError, match="needs a re-ID model"):
        track_sequence(seq, MOTION_ONLY.replace("sot", variant="template"))


def test_subsampled_sequences_keep_every_nth_frame_and_say_their_rate(tmp_path):
    from sotmot.benchmarks import subsampled_sequence
    from sotmot.io import read_detections, read_seqinfo

    seq = write_sequence(tmp_path, [f"{f},-1,{f},10,10,20,1" for f in range(1, 8)], length=7, frame_rate=30,
                         name="SYN-SDP", gt_lines=[f"{f},1,{f},10,10,20,1,1,1" for f in range(1, 8)])
    out = subsampled_sequence(seq, 3, tmp_path / "rates")
    info = read_seqinfo(out)
    assert (out.name, info.frame_rate, info.length) == ("SYN-every3-SDP", 10.0, 3)
    dets = read_detections(info.det_path, info.length)
    assert dets.frames.tolist() == [1, 2, 3] and dets.boxes[:, 0].tolist() == [1, 4, 7]
    assert info.frame_path(3).resolve() == (seq / "img1" / "000007.jpg").resolve()
    assert subsampled_sequence(seq, 3, tmp_path / "rates") == out  # made once


def test_detector_clips_put_another_detectors_boxes_on_the_frames_of_the_same_video(tmp_path):
    from sotmot.benchmarks import detector_clips, for_group, validation_set
    from sotmot.io import read_detections, read_ground_truth, read_seqinfo

    data = tmp_path / "data"
    clip = write_sequence(data, [f"{f},-1,1,1,10,20,-0.5" for f in range(1, 4)], length=3, frame_rate=14,
                          name="MOT16-07-clip3", gt_lines=[f"{f},1,1,1,10,20,1,1,1" for f in range(1, 4)])
    rows = [f"{f},-1,{f},10,10,20,0.9" for f in range(1, 8)]
    gt = [f"{f},4,{f},10,10,20,1,1,1" for f in range(1, 8)]
    write_sequence(data / "MOT17-labels", rows, length=7, frame_rate=14, name="MOT17-07-SDP", images=False,
                   gt_lines=gt)
    write_sequence(data / "MOT17-labels", rows, length=7, frame_rate=30, name="MOT17-07-FRCNN", images=False,
                   gt_lines=gt)  # another rate: another video
    write_sequence(data / "MOT16-labels", rows, length=7, frame_rate=14, name="MOT16-07", images=False,
                   gt_lines=gt)  # the clip's own detections
    write_sequence(data / "MOT17-labels", rows, length=7, frame_rate=14, name="MOT17-08-SDP", images=False,
                   gt_lines=gt)  # no clip of its video

    made = detector_clips(data, tmp_path / "clips")
    assert [p.name for p in made] == ["MOT17-07-SDP-clip3"]
    info = read_seqinfo(made[0])
    assert (info.name, info.length, info.frame_rate) == ("MOT17-07-SDP-clip3", 3, 14.0)
    assert read_detections(info.det_path, info.length).boxes[:, 0].tolist() == [1, 2, 3]
    assert read_ground_truth(info.gt_path, info.length).frames.tolist() == [1, 2, 3]
    assert info.frame_path(3).resolve() == (clip / "img1" / "000003.jpg").resolve()
    assert detector_clips(data, tmp_path / "clips") == made  # made once

    members = validation_set(data, tmp_path / "cache", ("clips",))  # the clip itself and the boxes put on it
    assert [(g, p.name) for g, p in members] == [("clips", "MOT16-07-clip3"), ("clips", "MOT17-07-SDP-clip3")]
    assert members[1][1].parent == tmp_path / "cache" / "clips"
    private = validation_set(data, tmp_path / "cache", ("clips",), private=True)  # a detector makes the boxes
    assert [p.name for _, p in private] == ["MOT16-07-clip3"]
    assert for_group(TrackerConfig(), "clips", "reid.onnx").appearance.backend == "auto"  # tracked with re-ID


def test_the_validation_set_tracks_label_only_sequences_and_their_lower_rates_without_frames(tmp_path):
    from sotmot.benchmarks import for_group, validation_set
    from sotmot.io import read_seqinfo

    data = tmp_path / "data"
    gt = [f"{f},1,{f},10,10,20,1,1,1" for f in range(1, 8)]
    write_sequence(data / "MOT17-labels", [f"{f},-1,{f},10,10,20,1" for f in range(1, 8)], length=7,
                   frame_rate=30, name="L-SDP", images=False, gt_lines=gt)
    write_sequence(data / "MOT17-labels", [f"{f},-1,{f},10,10,20,1" for f in range(1, 8)], length=7,
                   frame_rate=14, name="SLOW-SDP", images=False, gt_lines=gt)
    members = validation_set(data, tmp_path / "cache")
    assert [(g, p.name) for g, p in members] == [("labels", "L-SDP"), ("labels", "SLOW-SDP"),
                                                ("label-rates", "L-every2-SDP")]  # 14 fps has no lower rate here
    assert read_seqinfo(members[2][1]).frame_rate == 15.0
    assert [g for g, _ in validation_set(data, tmp_path / "cache", ("label-rates",))] == ["label-rates"]
    for group in ("labels", "label-rates"):
        assert for_group(TrackerConfig(), group, "reid.onnx").appearance.backend == "none"
    assert for_group(TrackerConfig(), "rates", "reid.onnx").appearance.backend == "auto"


def test_the_crowd_and_the_vehicle_join_the_frames_group_when_built_and_are_said_missing_when_not(tmp_path):
    from sotmot.benchmarks import more_sequences, validation_set

    data, more = tmp_path / "data", tmp_path / "more"
    data.mkdir()
    found, said = more_sequences(None)
    assert found == [] and "prepare.sh" in said and "MOT20-01" in said
    write_sequence(more, [f"{f},-1,1,1,10,20,1" for f in range(1, 130)], length=129, frame_rate=25,
                   name="MOT20-01", width=32, height=32, gt_lines=[f"{f},1,1,1,10,20,1,1,1" for f in range(1, 130)])
    found, said = more_sequences(more)
    assert [p.name for p in found] == ["MOT20-01"]
    assert said.startswith("MOT16-13, MOT17-13-DPM, MOT17-13-FRCNN not under") and "prepare.sh" in said
    members = validation_set(data, tmp_path / "cache", ("frames", "rates"), more=found)
    assert [(g, p.name) for g, p in members] == [("frames", "MOT20-01"), ("rates", "MOT20-01-every2"),
                                                ("rates", "MOT20-01-every3")]


def test_jittered_sequences_move_each_box_by_under_half_a_pixel_and_keep_the_rest(tmp_path):
    from sotmot.benchmarks import jittered_sequence
    from sotmot.io import read_detections, read_seqinfo

    gt = [f"{f},1,{f},10,10,20,1,1,1" for f in range(1, 8)]
    seq = write_sequence(tmp_path, [f"{f},-1,{10 * f},10.5,10,20,0.{f}" for f in range(1, 8)], length=7,
                         frame_rate=30, name="SYN-SDP", gt_lines=gt)
    out = jittered_sequence(seq, 1, tmp_path / "noise")
    info, original = read_seqinfo(out), read_seqinfo(seq)
    assert out == tmp_path / "noise" / "jitter1" / "SYN-SDP"
    assert (info.name, info.frame_rate, info.length) == (original.name, original.frame_rate, original.length)
    moved, before = read_detections(info.det_path, 7), read_detections(original.det_path, 7)
    shift = moved.boxes[:, :2] - before.boxes[:, :2]
    assert 0 < np.abs(shift).max() <= 0.5 and np.abs(shift).min() > 0
    assert np.array_equal(moved.boxes[:, 2:], before.boxes[:, 2:]) and np.array_equal(moved.scores, before.scores)
    assert np.array_equal(moved.frames, before.frames)
    assert info.gt_path.read_text() == original.gt_path.read_text()
    assert info.frame_path(7).resolve() == (seq / "img1" / "000007.jpg").resolve()
    assert jittered_sequence(seq, 1, tmp_path / "noise") == out  # made once
    again = read_detections(read_seqinfo(jittered_sequence(seq, 1, tmp_path / "again")).det_path, 7)
    other = read_detections(read_seqinfo(jittered_sequence(seq, 2, tmp_path / "noise")).det_path, 7)
    assert np.array_equal(again.boxes, moved.boxes) and not np.array_equal(other.boxes, moved.boxes)  # by seed
    # a detector run's boxes (a det.txt of their own) move the very same way, into a file made once
    from sotmot.benchmarks import jittered_detections

    file = jittered_detections(original.det_path, 1, tmp_path / "private")
    assert file == tmp_path / "private" / "jitter1" / "det.txt" and file.read_text() == info.det_path.read_text()
    # a header line (sotmot track writes one in <name>.det.txt) is kept, and the boxes move as without it
    from sotmot.benchmarks import jittered_text

    header = "# sotmot detections: detector=x sha256=0 family=unknown\n"
    text = original.det_path.read_text()
    assert jittered_text(header + text, 1, 0.5) == header + jittered_text(text, 1, 0.5)


def test_cached_features_refuse_an_embedder_that_flips_otherwise_than_asked(tmp_path):
    from types import SimpleNamespace

    from sotmot.benchmarks import cached_features

    seq = write_sequence(tmp_path, [f"{f},-1,{f},10,10,20,1" for f in range(1, 4)], length=3)
    config = TrackerConfig().replace("appearance", model=str(tmp_path / "reid.onnx"))
    with pytest.raises(ValueError, match="one box per"):
        cached_features(seq, config, tmp_path / "cache", [SimpleNamespace(flip=False)])
    assert not (tmp_path / "cache").exists()  # nothing embedded, nothing stored
