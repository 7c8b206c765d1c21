import numpy as np
import pytest

from helpers import tk
from sotmot.config import PostprocessConfig
from sotmot.postprocess import (AUTO_WINDOWS, LINE_MIN_SAMPLES, expand, interpolate, line_checked, line_samples,
                                local_lines, smooth, smoothing_windows, to_tracks)
from sotmot.types import Detections


def test_linear_interpolation_fills_gaps():
    frames = np.array([1, 4])
    boxes = np.array([[0, 0, 10, 20], [30, 3, 13, 20]], float)
    f, b, s, filled = interpolate(frames, boxes, np.array([0.9, 0.6]))
    assert f.tolist() == [1, 2, 3, 4]
    np.testing.assert_allclose(b[:, 0], [0, 10, 20, 30])
    np.testing.assert_allclose(b[:, 2], [10, 11, 12, 13])
    assert filled.tolist() == [False, True, True, False]
    np.testing.assert_allclose(s, [0.9, 0.6, 0.6, 0.6])


def test_interpolation_of_several_kinds_of_score_treats_each_column_as_its_own_run():
    frames = np.array([1, 4, 6, 20])
    boxes = np.array([[0, 0, 10, 20], [30, 3, 13, 20], [40, 3, 13, 20], [50, 3, 13, 20]], float)
    scores, confidence = np.array([0.9, 0.6, 0.8, 0.7]), np.array([0.2, 0.5, np.nan, 0.4])
    f, b, both, filled = interpolate(frames, boxes, np.stack([scores, confidence], axis=1), max_gap=3)
    for column, kind in enumerate((scores, confidence)):
        f1, b1, s1, filled1 = interpolate(frames, boxes, kind, max_gap=3)
        assert f.tolist() == f1.tolist() and filled.tolist() == filled1.tolist()
        np.testing.assert_array_equal(b, b1)
        np.testing.assert_array_equal(both[:, column], s1)  # NaN where a NaN lies beside the gap, as alone
    assert both.shape == (len(f), 2) and np.isnan(both[f.tolist().index(5), 1])


def test_smoothing_is_a_window_mean_truncated_at_the_ends():
    frames = np.arange(1, 8)
    boxes = np.zeros((7, 4))
    boxes[:, 0] = [0, 0, 0, 70, 0, 0, 0]
    out = smooth(frames, boxes, window=3)
    # frame 1 averages frames 1-4 (70/4); frame 4 averages all 7 (10); frame 7 averages 4-7
    np.testing.assert_allclose(out[:, 0], [17.5, 14, 70 / 6, 10, 70 / 6, 14, 17.5])
    np.testing.assert_allclose(smooth(frames, boxes, 0), boxes)


def test_smoothing_with_gaps_uses_only_existing_boxes():
    out = smooth(np.array([1, 10]), np.array([[0, 0, 1, 1], [9, 0, 1, 1]], float), window=3)
    np.testing.assert_allclose(out[:, 0], [0, 9])


def test_local_lines_follow_a_walk_to_its_ends_where_a_mean_lags():
    frames = np.array([1, 2, 3, 4, 5, 6, 7, 10, 11])  # a gap of two frames inside
    x = 2.0 * frames
    fitted, n = local_lines(frames, x[:, None], 3)
    np.testing.assert_allclose(fitted[:, 0], x)
    assert n.tolist() == [4, 5, 6, 7, 6, 5, 5, 3, 2]
    mean = smooth(frames, np.column_stack([x, x * 0, x * 0 + 1, x * 0 + 1]), 3)[:, 0]
    assert mean[0] == 5.0 and mean[-1] > 20  # the paper's mean drags the ends inwards
    # left out: a row predicted from the others only (block 1: those within a frame of it too)
    held, n_held = local_lines(frames, x[:, None], 3, block=1)
    np.testing.assert_allclose(held[n_held >= 2, 0], x[n_held >= 2])
    assert n_held.tolist() == [2, 2, 3, 4, 3, 2, 3, 1, 0]


def test_auto_windows_are_long_for_noise_and_short_for_a_turn():
    rng = np.random.default_rng(0)
    frames = np.arange(1, 301)
    walk = np.column_stack([500 + 2.0 * frames + rng.normal(0, 4, 300), 300 + rng.normal(0, 4, 300),
                            40 + rng.normal(0, 2, 300), 100 + rng.normal(0, 2, 300)])
    assert (smoothing_windows(frames, walk) >= 6).all()
    turn = np.column_stack([500 + 80 * np.sin(frames / 4), 300 + 80 * np.cos(frames / 4), 40 + 0 * frames,
                            100 + 0 * frames]) + rng.normal(0, 0.2, (300, 4))
    assert smoothing_windows(frames, turn)[:2].tolist() == [min(AUTO_WINDOWS)] * 2
    assert smoothing_windows(frames[:3], walk[:3]).tolist() == [3] * 4  # too few boxes to choose


def test_auto_smoothing_fits_centre_and_size_with_the_windows_chosen_on_the_detected_boxes():
    rng = np.random.default_rng(1)
    frames = np.arange(1, 201)
    centre = np.column_stack([500 + 80 * np.sin(frames / 4), 300 + 2.0 * frames, 40 + 0 * frames, 100 + 0 * frames])
    centre += rng.normal(0, [0.2, 4, 2, 2], (200, 4))
    boxes = centre - np.array([0.5, 0.5, 0, 0]) * centre[:, [2, 3, 2, 3]]  # x, y, w, h
    # boxes filled in on a straight line (frames 50-149) are not detections: they must not choose the windows
    observed = np.ones(200, dtype=bool)
    observed[50:150] = False
    boxes[50:150] = np.linspace(boxes[49], boxes[150], 102)[1:-1]
    centre[50:150] = np.linspace(centre[49], centre[150], 102)[1:-1]
    windows = smoothing_windows(frames[observed], centre[observed])
    assert windows[0] == 3 and windows[1] >= 6  # the turning coordinate short, the noisy walk long
    expected = np.column_stack([local_lines(frames, centre[:, k:k + 1], int(w))[0][:, 0]
                                for k, w in enumerate(windows)])
    expected[:, :2] -= expected[:, 2:] / 2
    np.testing.assert_allclose(smooth(frames, boxes, "auto", observed), expected)
    assert smooth(frames[:1], boxes[:1], "auto").tolist() == boxes[:1].tolist()


def test_to_tracks_numbers_by_first_frame_marks_filled_and_drops_short():
    dets = Detections(np.arange(1, 7), np.ones((6, 4)), np.ones(6))
    a = tk(1, [3, 5], [[0, 0, 10, 10], [2, 0, 10, 10]], det_start=0)
    b = tk(2, [1, 2], [[50, 0, 10, 10]], det_start=2)
    c = tk(3, [6], [[90, 0, 10, 10]], det_start=4)
    tracks = to_tracks([a, b, c], dets, PostprocessConfig(smooth_window=0, min_length=2))
    assert tracks.ids.tolist() == [1, 1, 2, 2, 2]
    assert tracks.frames.tolist() == [1, 2, 3, 4, 5]
    assert tracks.interpolated.tolist() == [False, False, False, True, False]
    np.testing.assert_allclose(tracks.boxes[3], [1, 0, 10, 10])


def walker(x_after: float):
    """Walking right 2 px a frame for frames 1-10 (20 x 50 px), a 30-frame gap, then 10 more frames from x_after."""
    from sotmot.types import Tracklet

    frames = np.r_[np.arange(1, 11), np.arange(41, 51)]
    x = np.r_[2.0 * np.arange(10), x_after + 2.0 * np.arange(10)]
    boxes = np.stack([x, np.zeros(20), np.full(20, 20.0), np.full(20, 50.0)], axis=1)
    return Tracklet(id=1, frames=frames, boxes=boxes, scores=np.ones(20), det_index=np.arange(20),
                    feature=np.zeros(0), n_features=20)


def test_a_long_gap_with_nothing_in_front_is_filled_only_where_the_walk_leads_along_its_line():
    from sotmot.postprocess import Occluders, expand

    nothing = Occluders(Detections(np.zeros(0), np.zeros((0, 4)), np.zeros(0)))
    checked = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0, min_agreement=0.5)
    on_the_line = walker(x_after=80.0)  # where 2 px a frame leads: x = 18 + 2 * 31
    off_the_line = walker(x_after=-150.0)  # someone else, far behind where the walk leads
    assert expand(on_the_line, checked, 10, nothing).filled.sum() == 30
    assert expand(off_the_line, checked, 10, nothing).filled.sum() == 0
    trusting = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=None)
    assert expand(off_the_line, trusting, 10, nothing).filled.sum() == 30  # the check is what refuses it
    short = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=5.0)
    assert expand(off_the_line, short, 10, nothing).filled.sum() == 30  # a 3-s gap is under a 5-s check
    assert expand(off_the_line, checked, 10).filled.sum() == 30  # nothing to check against: on trust
    assert PostprocessConfig().occlusion_seconds == 1.0  # on by default


def test_off_the_line_a_long_gap_is_filled_where_a_detection_in_front_could_hide_the_person():
    from sotmot.postprocess import Occluders, expand

    person = walker(x_after=-150.0)  # frames 11-40 missed, and the walk does not lead there
    # frames 15-24: someone in front of the line (bottom edge lower); frames 25-29: someone behind it (higher up)
    line = expand(person, PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=None), 10)
    at = {int(f): b for f, b in zip(line.frames, line.boxes)}
    front = [(f, at[f] + [3.0, 5.0, 0.0, 0.0]) for f in range(15, 25)]
    behind = [(f, at[f] + [1.0, -20.0, 0.0, 0.0]) for f in range(25, 30)]
    far = [(f, at[f] + [500.0, 5.0, 0.0, 0.0]) for f in range(30, 35)]  # in front, but nowhere near
    f, b = zip(*(front + behind + far))
    occluders = Occluders(Detections(np.array(f), np.array(b), np.ones(len(f))))

    checked = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0)
    e = expand(person, checked, frame_rate=10, occluders=occluders)
    assert e.frames[e.filled].tolist() == list(range(15, 25))
    assert e.det_index[~e.filled].tolist() == list(range(20))
    # to_tracks writes what expand keeps
    tracks = to_tracks([person], Detections(person.frames, person.boxes, np.ones(20)),
                       PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0, smooth_window=0),
                       frame_rate=10, occluders=occluders)
    assert tracks.frames[tracks.interpolated].tolist() == list(range(15, 25))


def stander(frames_before: int = 10, gap: int = 30, drift: float = 0.0):
    """Standing at x = 100 (20 x 50 px) for ``frames_before`` frames, a ``gap``-frame gap, then 10 more frames
    ``drift`` px to the right: a person (or a thing) that did not walk."""
    from sotmot.types import Tracklet

    frames = np.r_[np.arange(1, frames_before + 1), np.arange(frames_before + gap + 1, frames_before + gap + 11)]
    x = np.r_[np.full(frames_before, 100.0), np.full(10, 100.0 + drift)]
    n = len(frames)
    boxes = np.stack([x, np.zeros(n), np.full(n, 20.0), np.full(n, 50.0)], axis=1)
    return Tracklet(id=1, frames=frames, boxes=boxes, scores=np.ones(n), det_index=np.arange(n),
                    feature=np.zeros(0), n_features=n)


def test_a_long_gap_across_which_the_box_stood_still_is_filled_only_where_someone_stands_in_front():
    """A sign the detector fires on now and then has a line that agrees with its 'walk' (none): still_speed sends
    such a gap to the occlusion check, where a person standing behind a passer-by keeps the boxes."""
    from sotmot.postprocess import Occluders, expand, gaps_of, off_the_line

    still = stander()
    nothing = Occluders(Detections(np.zeros(0), np.zeros((0, 4)), np.zeros(0)))
    trusting = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0, still_speed=None)
    checked = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0, still_speed=0.03)
    assert expand(still, trusting, 10, nothing).filled.sum() == 30  # on the line: filled on trust
    assert expand(still, checked, 10, nothing).filled.sum() == 0
    passer = [(f, np.array([95.0, 5.0, 20.0, 50.0])) for f in range(20, 26)]  # in front of it, frames 20-25
    f, b = zip(*passer)
    occluders = Occluders(Detections(np.array(f), np.array(b), np.ones(len(f))))
    e = expand(still, checked, 10, occluders)
    assert e.frames[e.filled].tolist() == list(range(20, 26))
    # 31 frames at 10 fps, one height 50 px: 4 px is 0.026 heights a second (still), 5 px 0.032 (moved)
    barely = stander(drift=4.0)
    assert off_the_line(barely.frames, barely.boxes, np.array([9]), checked, 10).tolist() == [True]
    moved = stander(drift=5.0)
    assert off_the_line(moved.frames, moved.boxes, np.array([9]), checked, 10).tolist() == [False]
    assert expand(walker(x_after=80.0), checked, 10, nothing).filled.sum() == 30  # a walk: on trust as before
    (gap,) = gaps_of(still, checked, 10, occluders)
    assert (gap.written, gap.left_out) == (6, 24) and "stood still across it (0.000 heights per second" in gap.why
    assert gap.agreement >= 0.5  # the line agreed; standing still is what sent it to the check
    (gap,) = gaps_of(barely, checked, 10, nothing)
    assert gap.written == 0 and "stood still across it (0.026 heights per second < still_speed 0.03)" in gap.why


def test_a_sparse_trajectory_gets_no_box_in_its_gaps_and_keeps_its_detections():
    """min_seen_share: a few detections joined across gaps (a sign fired on now and then, pieces of several people,
    the detector's second box on someone) are not a walk to fill, in a long gap or a short one, on the line or off
    it, hidden or not; their detections are kept."""
    from sotmot.errors import ConfigError
    from sotmot.postprocess import Occluders, expand, gaps_of, seen_share
    from sotmot.types import Tracklet

    # 6 boxes over 87 frames: 1-3, a 40-frame gap, 44 and 46 (a 1-frame gap), a 40-frame gap, 87
    frames = np.array([1, 2, 3, 44, 46, 87])
    boxes = np.stack([2.0 * frames, np.zeros(6), np.full(6, 20.0), np.full(6, 50.0)], axis=1)  # on one line
    sparse = Tracklet(id=1, frames=frames, boxes=boxes, scores=np.ones(6), det_index=np.arange(6),
                      feature=np.zeros(0), n_features=6)
    assert seen_share(sparse) == 6 / 87
    everywhere = Occluders(Detections(np.arange(1, 88), np.tile([0.0, 10.0, 400.0, 60.0], (87, 1)), np.ones(87)))
    base = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0, smooth_window=0,
                             min_seen_share=None)
    judged = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0, smooth_window=0)
    assert judged.min_seen_share == 0.3  # the default
    assert expand(sparse, base, 10, everywhere).filled.sum() == 81  # on the line, and hidden anyway
    e = expand(sparse, judged, 10, everywhere)
    assert not e.filled.any()  # the short gap (frame 45) too
    assert e.det_index[~e.filled].tolist() == list(range(6))  # every detection kept
    assert expand(sparse, judged, 10).filled.sum() == 81  # no occluders given: no long gap is judged
    assert expand(walker(x_after=80.0), judged, 10, everywhere).filled.sum() == 30  # seen in 20 of 50 frames
    whys = [g.why for g in gaps_of(sparse, judged, 10, everywhere)]
    assert all(w.startswith("left empty: the trajectory has boxes in 7% of its frames") for w in whys)
    assert [g.written for g in gaps_of(sparse, judged, 10, everywhere)] == [0, 0, 0]
    assert [g.why for g in gaps_of(sparse, judged, 10)][1] == "interpolated"  # no check without occluders
    with pytest.raises(ConfigError, match="min_seen_share must be in"):
        PostprocessConfig(min_seen_share=1.5)


def test_each_gap_says_what_was_written_in_it_and_which_rule_decided():
    """sotmot.postprocess.gaps_of (what `sotmot explain --ids N` prints): the counts are expand's, the words name
    the rule."""
    from sotmot.postprocess import Occluders, expand, gaps_of
    from sotmot.types import Tracklet

    person = walker(x_after=-150.0)
    line = expand(person, PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=None), 10)
    at = {int(f): b for f, b in zip(line.frames, line.boxes)}
    front = [(f, at[f] + [3.0, 5.0, 0.0, 0.0]) for f in range(15, 25)]
    f, b = zip(*front)
    occluders = Occluders(Detections(np.array(f), np.array(b), np.ones(len(f))))
    checked = PostprocessConfig(interpolate_max_seconds=None, occlusion_seconds=1.0)
    (gap,) = gaps_of(person, checked, 10, occluders)
    assert (gap.after, gap.before, gap.written, gap.left_out) == (10, 41, 10, 20)
    assert gap.agreement < 0.5 and "off the walk's line" in gap.why
    assert gap.written == expand(person, checked, 10, occluders).filled.sum()
    (trusted,) = gaps_of(walker(x_after=80.0), checked, 10, occluders)
    assert (trusted.written, trusted.left_out) == (30, 0) and "on trust" in trusted.why
    (empty,) = gaps_of(person, PostprocessConfig(interpolate_max_seconds=2.0), 10, occluders)
    assert (empty.written, empty.left_out) == (0, 0) and "longer than" in empty.why
    short = Tracklet(id=1, frames=np.array([1, 2, 5, 6]), boxes=np.tile([0.0, 0.0, 20.0, 50.0], (4, 1)),
                     scores=np.ones(4), det_index=np.arange(4), feature=np.zeros(0), n_features=4)
    (small,) = gaps_of(short, checked, 10, occluders)
    assert (small.after, small.before, small.written, small.why) == (2, 5, 2, "interpolated")
    assert gaps_of(walker(x_after=80.0), PostprocessConfig(interpolate=False), 10)[0].why.startswith("interpolation")


def swaying(tid: int, amplitude: float, period: float, frames=np.arange(1, 301)):
    """A person seen in every frame whose box swings sideways by ``amplitude`` pixels every ``period`` frames (a
    camera panning to and fro with nothing to compensate it); 0 is a straight walk."""
    x = 100.0 * tid + 1.5 * frames + amplitude * np.sin(2 * np.pi * frames / period)
    return tk(tid, frames, np.column_stack([x, 300 + 0.2 * frames, 40 + 0 * frames, 100 + 0 * frames]))


def test_the_line_check_lowers_the_interpolation_bound_only_where_the_line_does_not_hold():
    config = PostprocessConfig(line_check_seconds=2.0)  # gaps up to 4 s, the line checked over 2 s
    walks = [swaying(k, 0.0, 1) for k in range(3)]
    assert line_samples(walks, 20) == (168, 168)  # every 2-s line lands on the box halfway
    assert line_checked(config, walks, 10) is config
    # a sway the line follows over 1.5 s (every sample lands) but not over 2 s: gaps are filled up to 1.5 s
    mild = [swaying(k, 60.0, 60) for k in range(3)]
    assert line_samples(mild, 15)[0] == line_samples(mild, 15)[1] and line_samples(mild, 20)[0] < 84
    assert line_checked(config, mild, 10).interpolate_max_seconds == 1.5
    strong = [swaying(k, 80.0, 40) for k in range(3)]
    assert line_checked(config, strong, 10).interpolate_max_seconds == 1.0  # never below 1 s
    # what is left alone: the check off, no frame rate, a bound already as short, too few samples to judge
    for off in (PostprocessConfig(line_check_seconds=None), PostprocessConfig(interpolate_max_seconds=1.0)):
        assert line_checked(off, strong, 10) is off
    assert line_checked(config, strong, None) is config
    short = [swaying(0, 80.0, 40, np.arange(1, 30))]
    assert line_samples(short, 20)[1] < LINE_MIN_SAMPLES and line_checked(config, short, 10) is config


def test_a_gap_the_line_check_bounds_is_left_empty():
    strong = [swaying(k, 80.0, 40) for k in range(3)]
    frames = np.r_[np.arange(1, 101), np.arange(131, 301)]  # a 3-s gap at 10 fps
    person = tk(9, frames, strong[0].boxes[frames - 1])
    assert expand(person, PostprocessConfig(), 10).filled.sum() == 30  # expand() fills on trust, unchecked
    checked = line_checked(PostprocessConfig(line_check_seconds=2.0), strong, 10)
    assert expand(person, checked, 10).filled.sum() == 0
