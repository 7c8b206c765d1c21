"""SOT after association: trajectory ends extended where the detector stopped (issue #12)."""

from __future__ import annotations

import numpy as np

from conftest import GeometryEmbedder
from sotmot.config import SotConfig, TrackerConfig
from sotmot.sot.extend import end_velocity, extend_ends, inside_fraction, refine_gaps
from sotmot.types import Tracks

WIDTH, HEIGHT, LENGTH = 200, 120, 34
#: The walker's "appearance" as GeometryEmbedder sees it (a function of the box size only).
LOOK = GeometryEmbedder().embed(None, np.array([[0.0, 0.0, 20.0, 40.0]]))[0]


def walker_x(frame: int) -> float:
    """A 20 x 40 person walking right 6 px per frame; fully visible until frame 29, half out at 30."""
    return 20.0 + 6.0 * (frame - 1)


def frames_with_walker() -> dict[int, np.ndarray]:
    rng = np.random.default_rng(0)
    texture = rng.integers(0, 256, size=(40, 20, 3), dtype=np.uint8)
    out = {}
    for f in range(1, LENGTH + 1):
        img = np.full((HEIGHT, WIDTH, 3), 120, np.uint8)
        x = int(walker_x(f))
        visible = max(0, min(WIDTH, x + 20) - x)
        if visible:
            img[40:80, x:x + visible] = texture[:, :visible]
        out[f] = img
    return out


def test_end_is_extended_while_the_person_is_visible_and_stops_when_they_leave():
    images = frames_with_walker()
    detected = range(1, 21)  # the detector lost the person after frame 20
    tracks = Tracks(list(detected), [1] * 20, [[walker_x(f), 40, 20, 40] for f in detected], [0.9] * 20)
    config = SotConfig(extend_seconds=1.5)
    out = extend_ends(tracks, {1: LOOK}, images.__getitem__, LENGTH, 10.0,
                      GeometryEmbedder(), config)
    added = out.subset(out.from_sot)
    # fully inside until frame 27 (x + w = 182), leaving from 28 on (the template search only places
    # whole boxes in the image, so the last frames of the exit are not found); never past frame 29
    assert added.frames[:7].tolist() == list(range(21, 28)) and added.frames.max() <= 29
    assert np.abs(added.boxes[:, 0] - [walker_x(f) for f in added.frames]).max() <= 2.0
    assert set(out.ids.tolist()) == {1} and len(out) == 20 + len(added)
    assert np.all(np.diff(out.frames) == 1)  # rows stay in track, frame order


def test_extension_stops_at_another_trajectory_and_after_its_time():
    images = frames_with_walker()
    detected = range(1, 21)
    blocker = Tracks([24], [2], [[walker_x(24), 40, 20, 40]], [0.9])  # someone else stands where it goes
    walker = Tracks(list(detected), [1] * 20, [[walker_x(f), 40, 20, 40] for f in detected], [0.9] * 20)
    both = Tracks(np.r_[walker.frames, blocker.frames], np.r_[walker.ids, blocker.ids],
                  np.r_[walker.boxes, blocker.boxes], np.r_[walker.scores, blocker.scores])
    feats = {1: LOOK, 2: LOOK}
    out = extend_ends(both, feats, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(), SotConfig(extend_seconds=1.5))
    assert out.frames[out.from_sot & (out.ids == 1)].tolist() == [21, 22, 23]
    short = extend_ends(walker, {1: feats[1]}, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(),
                        SotConfig(extend_seconds=0.2))
    assert short.frames[short.from_sot].tolist() == [21, 22]


def test_a_different_looking_candidate_is_refused():
    images = frames_with_walker()
    detected = range(1, 21)
    tracks = Tracks(list(detected), [1] * 20, [[walker_x(f), 40, 20, 40] for f in detected], [0.9] * 20)
    stranger = -LOOK  # the opposite feature: affinity 0
    out = extend_ends(tracks, {1: stranger}, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(),
                      SotConfig(extend_seconds=1.5))
    assert not out.from_sot.any()


def test_velocity_and_inside_fraction():
    frames = np.array([1, 2, 3])
    boxes = np.array([[0, 0, 10, 10], [3, 0, 10, 10], [6, 0, 10, 10]], float)
    assert end_velocity(frames, boxes, 1).tolist() == [3.0, 0.0]
    assert end_velocity(frames, boxes, -1).tolist() == [-3.0, 0.0]
    assert inside_fraction(np.array([95.0, 0, 10, 10]), 100, 100) == 0.5


def test_pipeline_extends_ends_by_default_and_not_when_turned_off(tmp_path):
    from conftest import write_sequence
    from sotmot.pipeline import track_sequence

    lines = [f"{f},-1,{10 + 2 * f},20,20,40,0.95" for f in range(1, 9)]
    seq = write_sequence(tmp_path, lines, length=10, frame_rate=4, width=120, height=80)
    config = TrackerConfig().replace("confirm", enabled=False)
    off = track_sequence(seq, config.replace("sot", extend_seconds=0.0), embedder=GeometryEmbedder())
    assert "extend" not in off.timings
    on = track_sequence(seq, config, embedder=GeometryEmbedder())
    assert "extend" in on.timings and len(on.tracks) >= len(off.tracks)


def test_doubtful_trajectories_are_not_extended():
    images = frames_with_walker()
    detected = range(1, 21)
    boxes = [[walker_x(f), 40, 20, 40] for f in detected]

    def extended(confidence):
        tracks = Tracks(list(detected), [1] * 20, boxes, [0.9] * 20, confidence=[confidence] * 20)
        out = extend_ends(tracks, {1: LOOK}, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(),
                          SotConfig(extend_seconds=1.5, extend_min_confidence=0.7))
        return int(out.from_sot.sum())

    assert extended(0.9) >= 7 and extended(0.6) == 0
    assert extended(float("nan")) >= 7  # confirmation off: no confidence to judge by


def test_an_interpolated_box_off_the_person_is_replaced_by_the_box_found_there():
    images = frames_with_walker()
    frames = list(range(1, 21))
    boxes = np.array([[walker_x(f), 40, 20, 40] for f in frames])
    interpolated = np.isin(frames, [9, 10, 11])
    boxes[interpolated, 0] -= 7  # interpolation put the box 7 px behind the person (they sped up)
    tracks = Tracks(frames, [1] * 20, boxes, [0.9] * 20, interpolated=interpolated)
    out = refine_gaps(tracks, {1: LOOK}, images.__getitem__, GeometryEmbedder(), SotConfig())
    assert out.from_sot.tolist() == interpolated.tolist() and not out.interpolated.any()
    assert np.abs(out.boxes[interpolated, 0] - [walker_x(f) for f in (9, 10, 11)]).max() <= 1.0
    assert np.array_equal(out.boxes[~interpolated], tracks.boxes[~interpolated])
    kept = refine_gaps(tracks, {1: -LOOK}, images.__getitem__, GeometryEmbedder(), SotConfig())
    assert np.array_equal(kept.boxes, tracks.boxes) and kept.interpolated.tolist() == interpolated.tolist()
