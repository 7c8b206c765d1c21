"""Camera motion: the estimate against known shifts, the reference frame, and a still camera left alone."""

from pathlib import Path

import numpy as np
import pytest

from conftest import DATA, GeometryEmbedder, require
from sotmot.config import MotionConfig, TrackerConfig
from sotmot.errors import InputError
from sotmot.io import read_detections, read_seqinfo
from sotmot.motion import CameraMotion, compose, estimate_motion, estimate_pair, invert, reduce_factor
from sotmot.pipeline import prepare_sequence, track_sequence

WORLD_H, WORLD_W = 140, 520


def world(seed: int = 0) -> np.ndarray:
    """A textured grey 'world' (random 6 px blocks, slightly blurred) the camera looks at."""
    import cv2

    rng = np.random.default_rng(seed)
    blocks = rng.integers(30, 225, (WORLD_H // 6 + 1, WORLD_W // 6 + 1)).astype(np.uint8)
    image = cv2.resize(blocks, (blocks.shape[1] * 6, blocks.shape[0] * 6), interpolation=cv2.INTER_NEAREST)
    return cv2.GaussianBlur(image[:WORLD_H, :WORLD_W], (3, 3), 0.8)


def shifted(image: np.ndarray, dx: float, dy: float, size: tuple[int, int]) -> np.ndarray:
    """The ``size = (w, h)`` window whose top-left corner is at ``(dx, dy)`` of ``image`` (bilinear)."""
    import cv2

    return cv2.warpAffine(image, np.array([[1.0, 0, -dx], [0, 1.0, -dy]]), size, flags=cv2.INTER_LINEAR)


@pytest.mark.parametrize("dx, dy", [(3.0, -2.0), (7.5, 1.25), (0.0, 0.0)])
def test_estimate_matches_a_known_shift_within_a_tenth_of_a_pixel(dx, dy):
    base = world()
    previous = shifted(base, 40, 20, (320, 100))
    current = shifted(base, 40 + dx, 20 + dy, (320, 100))  # the camera moved right by dx: the image moves left
    transform, confidence = estimate_pair(previous, current)
    # current's pixel p shows what previous showed at p + (dx, dy)
    assert confidence > 0.5
    np.testing.assert_allclose(transform[:, 2], [dx, dy], atol=0.1)
    np.testing.assert_allclose(transform[:, :2], np.eye(2), atol=0.005)


def test_estimate_on_reduced_frames_is_in_full_size_pixels():
    import cv2

    base = world(1)
    previous, current = shifted(base, 40, 20, (400, 112)), shifted(base, 48, 16, (400, 112))
    small = [cv2.resize(img, (200, 56), interpolation=cv2.INTER_AREA) for img in (previous, current)]
    transform, _ = estimate_pair(*small, factor=2)
    np.testing.assert_allclose(transform[:, 2], [8, -4], atol=0.3)
    assert reduce_factor(1920) == 4 and reduce_factor(640) == 2 and reduce_factor(320) == 1


def test_people_masked_out_do_not_pull_the_estimate():
    base = world(2)
    previous, current = shifted(base, 40, 20, (320, 100)), shifted(base, 44, 20, (320, 100))
    # a large "person" moving left by 10 px on its own, over half the frame
    person = world(3)[:80, :150]
    previous[10:90, 100:250] = person
    current[10:90, 90:240] = person
    transform, _ = estimate_pair(previous, current, people=np.array([[95.0, 5, 160, 90]]))
    np.testing.assert_allclose(transform[:, 2], [4, 0], atol=0.15)


def test_boxes_round_trip_through_the_reference_frame():
    pair = np.tile(np.array([[1.0, 0, 0], [0, 1.0, 0]]), (6, 1, 1))
    pair[2:, 0, 2], pair[2:, 1, 2] = 5.0, -2.0  # each frame's pixels sit 5 px right, 2 px up of the previous's
    pair[4] = np.array([[1.02, 0, 3.0], [0, 1.02, 1.0]])  # with a zoom
    motion = CameraMotion.from_pairs(pair, np.ones(6))
    frames = np.array([1, 2, 3, 4, 5, 5])
    boxes = np.array([[10.0, 20, 30, 60], [0, 0, 10, 20], [5, 5, 5, 5], [100, 50, 40, 80], [1, 2, 3, 4], [7, 7, 7, 7]])
    ref = motion.to_ref(frames, boxes)
    np.testing.assert_allclose(ref[0], boxes[0])  # frame 1 is the reference
    np.testing.assert_allclose(ref[1], [5, -2, 10, 20])
    np.testing.assert_allclose(ref[2], [15, 1, 5, 5])
    np.testing.assert_allclose(motion.from_ref(frames, ref), boxes, atol=1e-9)
    np.testing.assert_allclose(compose(invert(pair[4]), pair[4]), pair[0], atol=1e-12)


def _panning_sequence(root: Path, pan: float, length: int = 8, name: str = "PAN") -> Path:
    """A camera panning ``pan`` px a frame across the textured world, and one person standing still in it.

    The person (a flat dark block 24 x 48 at world x = 250) is detected in every frame where they are fully seen.
    8 frames a second: the whole sequence is one tracklet batch.
    """
    import cv2

    base = world(4)
    base[40:88, 250:274] = 20
    seq = root / name
    (seq / "img1").mkdir(parents=True)
    (seq / "det").mkdir()
    lines = []
    for f in range(1, length + 1):
        left = 20 + pan * (f - 1)
        cv2.imwrite(str(seq / "img1" / f"{f:06d}.jpg"), shifted(base, left, 10, (240, 120)),
                    [cv2.IMWRITE_JPEG_QUALITY, 98])
        x = 250 - left
        if 0 <= x <= 240 - 24:
            lines.append(f"{f},-1,{x:.2f},30,24,48,0.95,-1,-1,-1")
    (seq / "det" / "det.txt").write_text("\n".join(lines) + "\n")
    (seq / "seqinfo.ini").write_text(f"[Sequence]\nname={name}\nimDir=img1\nframeRate=8\nseqLength={length}\n"
                                     f"imWidth=240\nimHeight=120\nimExt=.jpg\n")
    return seq


def test_a_person_standing_still_while_the_camera_pans_is_one_tracklet(tmp_path):
    seq = _panning_sequence(tmp_path, pan=28.0)  # more than the box's width a frame: no overlap in the image
    off = TrackerConfig().replace("motion", compensation="off").replace("ends", seconds=0.0)
    prepared_off = prepare_sequence(seq, off, GeometryEmbedder())
    prepared_on = prepare_sequence(seq, off.replace("motion", compensation="auto"), GeometryEmbedder())
    # in the image the boxes never overlap: each stays alone (and a lone box is no tracklet, l_min = 1)
    assert len(prepared_off.tracklets) == 0
    assert prepared_on.motion.moving
    assert len(prepared_on.tracklets) == 1 and len(prepared_on.tracklets[0]) == 7
    np.testing.assert_allclose(prepared_on.motion.pair[2:, 0, 2], 28.0, atol=0.3)
    result = track_sequence(seq, off.replace("motion", compensation="auto"), GeometryEmbedder())
    assert result.tracks.n_tracks == 1
    # written in each frame's own pixels: the box follows the person across the image
    dets = read_detections(seq / "det" / "det.txt")
    rows = np.isin(result.tracks.frames, dets.frames)
    np.testing.assert_allclose(result.tracks.boxes[rows][:, 0], dets.boxes[:, 0], atol=1.0)


def test_the_confidence_fits_label_the_boxes_the_tracker_writes_when_the_camera_moves(tmp_path):
    """The fits (sotmot.fitting.confidence) label and score the very boxes finish_sequence writes: in each frame's
    own pixels, not the reference frame's (they once matched the ground truth in frame 1's pixels, so every box of
    a panning camera's person was a false positive)."""
    from sotmot.fitting.confidence import label_sequence, unconfirmed_tracks
    from sotmot.pipeline import finish_sequence

    seq = _panning_sequence(tmp_path, pan=28.0)
    (seq / "gt").mkdir()
    rows = [line.split(",") for line in (seq / "det" / "det.txt").read_text().split()]
    (seq / "gt" / "gt.txt").write_text("".join(f"{r[0]},1,{','.join(r[2:6])},1,1,1\n" for r in rows))
    config = TrackerConfig().replace("confirm", enabled=False).replace("ends", seconds=0.0)
    prepared = prepare_sequence(seq, config, GeometryEmbedder())
    assert prepared.motion.moving
    labelled = label_sequence(prepared, prepared.detections.scores, config, tmp_path / "labels")
    written = finish_sequence(prepared, config).tracks
    fitted = unconfirmed_tracks(labelled, config)
    np.testing.assert_array_equal(fitted.frames, written.frames)
    np.testing.assert_allclose(fitted.boxes, written.boxes)
    assert len(labelled.labels) == len(written) == 7 and set(labelled.labels.values()) == {1}


def test_a_still_camera_gives_the_identity_and_identical_results(tmp_path):
    seq = _panning_sequence(tmp_path, pan=0.0, name="STILL")
    info = read_seqinfo(seq)
    dets = read_detections(info.det_path, info.length)
    motion = estimate_motion(info, dets, MotionConfig())
    assert not motion.moving
    np.testing.assert_array_equal(motion.to_reference, CameraMotion.still(info.length).to_reference)
    base = TrackerConfig().replace("ends", seconds=0.0)
    auto = track_sequence(seq, base, GeometryEmbedder())
    off = track_sequence(seq, base.replace("motion", compensation="off"), GeometryEmbedder())
    for column in ("frames", "ids", "boxes", "scores", "interpolated", "from_sot"):
        np.testing.assert_array_equal(getattr(auto.tracks, column), getattr(off.tracks, column))
    assert auto.motion is not None and not auto.motion.moving


def test_an_untrustworthy_pair_falls_back_to_no_motion():
    flat = np.full((100, 320), 128, np.uint8)
    transform, confidence = estimate_pair(flat, flat)
    assert confidence == 0.0
    np.testing.assert_array_equal(transform, [[1, 0, 0], [0, 1, 0]])


def test_a_missing_frame_names_the_file(tmp_path):
    seq = _panning_sequence(tmp_path, pan=10.0)
    (seq / "img1" / "000003.jpg").unlink()
    info = read_seqinfo(seq)
    with pytest.raises(InputError, match="000003.jpg"):
        estimate_motion(info, read_detections(info.det_path, info.length), MotionConfig(compensation="on"))


def test_motion_config_is_checked():
    from sotmot.errors import ConfigError

    with pytest.raises(ConfigError, match="compensation"):
        TrackerConfig().replace("motion", compensation="sometimes")
    with pytest.raises(ConfigError, match="still_pixels"):
        MotionConfig(still_pixels=0.0)


def test_explain_and_graph_say_the_positions_were_compensated(tmp_path):
    from sotmot.inspect.explain import explain, inspection_graph
    from sotmot.inspect.graph_view import html_page

    config = TrackerConfig().replace("ends", seconds=0.0)
    moving = track_sequence(_panning_sequence(tmp_path, pan=28.0), config, GeometryEmbedder())
    graph = inspection_graph(moving, config)
    assert graph.graph["compensated"]
    assert "after camera-motion compensation" in explain(graph, 1, 1, config)
    assert "camera-motion compensation" in html_page(graph)
    still = track_sequence(_panning_sequence(tmp_path, pan=0.0, name="STILL"), config, GeometryEmbedder())
    assert "compensated" not in inspection_graph(still, config).graph


def test_the_sot_step_follows_the_camera(tmp_path):
    """Algorithm 1 on a panning camera: its overlap checks and prior follow the camera, and it runs to the end."""
    seq = _panning_sequence(tmp_path, pan=12.0)
    config = TrackerConfig().replace("sot", variant="template").replace("ends", seconds=0.0)
    result = track_sequence(seq, config, GeometryEmbedder())
    assert result.motion.moving and result.tracks.n_tracks == 1


def test_the_still_check_chains_short_sequences_and_samples_long_ones():
    from sotmot.motion import STILL_CHECK_PAIRS, still_check_pairs

    assert still_check_pairs(10, 4) == [(1, 3), (3, 5), (5, 7), (7, 9), (9, 10)]
    assert len(still_check_pairs(30 * 3600, 30)) == 30 * 3600 // 15  # JPEG frames: every half second
    long = still_check_pairs(30 * 3600, 30, video=True)
    assert len(long) == STILL_CHECK_PAIRS and long[0] == (1, 16) and long[-1][1] <= 30 * 3600
    assert all(b - a == 15 for a, b in long)


def test_make_moving_writes_a_panned_window_with_its_path_and_refuses_an_existing_folder(tmp_path):
    import subprocess
    import sys

    from conftest import ROOT, write_sequence

    seq = write_sequence(tmp_path, ["1,-1,10,10,12,24,0.9,-1,-1,-1", "4,-1,20,12,12,24,0.8,-1,-1,-1"], length=6,
                         frame_rate=2, width=96, height=72, gt_lines=["1,1,10,10,12,24,1,1,1", "4,1,20,12,12,24,1,1,1"])
    out = tmp_path / "moving"
    script = [sys.executable, str(ROOT / "scripts" / "make_moving.py"), str(seq), str(out), "--quiet"]
    assert subprocess.run(script, capture_output=True, text=True).returncode == 0
    info = read_seqinfo(out)
    assert (info.width, info.height, info.length) == (80, 60, 6)
    path = np.loadtxt(out / "path.txt", delimiter=",")
    assert path.shape == (6, 7) and np.allclose(path[:, [1, 5]], 1.0)
    assert np.allclose(path[:, [3, 6]], np.round(path[:, [3, 6]]))  # whole pixels: no resampling
    dets = read_detections(out / "det" / "det.txt")
    for frame, box in zip(dets.frames, dets.boxes):  # every box moved with its frame's window
        tx, ty = path[frame - 1, 3], path[frame - 1, 6]
        source = {1: (10, 10), 4: (20, 12)}[int(frame)]
        np.testing.assert_allclose(box[:2], (source[0] + tx, source[1] + ty))
    again = subprocess.run(script, capture_output=True, text=True)
    assert again.returncode != 0 and "exists" in again.stderr
    assert not (tmp_path / "moving.partial").exists()


def test_make_moving_drives_forward_zooming_and_turning_and_refuses_a_path_out_of_the_frame(tmp_path):
    import subprocess
    import sys

    from conftest import ROOT, write_sequence

    seq = write_sequence(tmp_path, ["1,-1,40,30,12,24,0.9,-1,-1,-1", "6,-1,44,32,12,24,0.8,-1,-1,-1"], length=6,
                         frame_rate=2, width=96, height=72, gt_lines=["1,1,40,30,12,24,1,1,1", "6,1,44,32,12,24,1,1,1"])
    out = tmp_path / "forward"
    script = [sys.executable, str(ROOT / "scripts" / "make_moving.py"), str(seq), str(out), "--quiet",
              "--forward", "1.5", "--rotate", "2", "--turn", "4", "--pan-x", "0", "--pan-y", "0", "--jitter", "0"]
    run = subprocess.run(script, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    path = np.loadtxt(out / "path.txt", delimiter=",")
    a = path[:, 1:].reshape(-1, 2, 3)
    np.testing.assert_allclose(np.hypot(a[:, 0, 0], a[:, 1, 0]), np.linspace(1.0, 1.5, 6), atol=1e-5)  # steady zoom
    np.testing.assert_allclose(np.degrees(np.arctan2(a[:, 1, 0], a[:, 0, 0])), np.linspace(0.0, 2.0, 6), atol=1e-4)
    dets = read_detections(out / "det" / "det.txt")
    for frame, box in zip(dets.frames, dets.boxes):  # the centre moves with the image, the size with the zoom
        x, y = {1: (40, 30), 6: (44, 32)}[int(frame)]
        m = a[frame - 1]
        np.testing.assert_allclose(box[:2] + box[2:] / 2, m[:, :2] @ (x + 6, y + 12) + m[:, 2], atol=1e-3)
        np.testing.assert_allclose(box[2:], np.array([12, 24]) * np.hypot(m[0, 0], m[1, 0]), atol=1e-3)
    far = subprocess.run(script[:3] + [str(tmp_path / "far"), "--turn", "60", "--quiet"], capture_output=True,
                         text=True)
    assert far.returncode != 0 and "leaves the frame" in far.stderr


def test_the_same_view_reference_sees_the_still_window_through_the_moving_one(tmp_path):
    """make_moving.same_view keeps the still window's frames with only the detections the moving window kept, and
    through() shows results of the still window as the moving window would: the still ground truth seen through
    the forward window is the forward window's own ground truth; window_share() says how much of each box the
    moving window shows."""
    import subprocess
    import sys

    from conftest import ROOT, write_sequence

    sys.path.insert(0, str(ROOT / "scripts"))
    import make_moving

    dets = ["1,-1,40,30,12,24,0.9,-1,-1,-1", "3,-1,8,30,12,24,0.7,-1,-1,-1", "6,-1,44,32,12,24,0.8,-1,-1,-1"]
    truth = ["1,1,40,30,12,24,1,1,1", "3,2,8,30,12,24,1,1,1", "6,1,44,32,12,24,1,1,1"]
    seq = write_sequence(tmp_path, dets, length=6, frame_rate=2, width=96, height=72, gt_lines=truth)
    common = [sys.executable, str(ROOT / "scripts" / "make_moving.py"), str(seq), "--quiet"]
    forward, still = tmp_path / "forward", tmp_path / "still"
    for out, extra in ((forward, ["--forward", "1.5", "--pan-x", "0", "--pan-y", "0", "--jitter", "0"]),
                       (still, ["--still"])):
        run = subprocess.run(common[:3] + [str(out)] + common[3:] + extra, capture_output=True, text=True)
        assert run.returncode == 0, run.stderr
    view = tmp_path / "view"
    make_moving.same_view(still, forward, view)
    with pytest.raises(FileExistsError, match="exists"):
        make_moving.same_view(still, forward, view)
    kept = make_moving.read_rows(view / "det" / "det.txt")
    assert len(make_moving.read_rows(still / "det" / "det.txt")) == 3 and len(kept) == 2  # frame 3's left the view
    assert read_seqinfo(view).name == "view" and (view / "img1").resolve() == (still / "img1").resolve()
    seen = tmp_path / "seen.txt"
    make_moving.through(still / "gt" / "gt.txt", still, forward, seen)
    np.testing.assert_allclose(make_moving.read_rows(seen), make_moving.read_rows(forward / "gt" / "gt.txt"),
                               atol=2e-6)
    # frame 3's person, 12 px wide at the still window's left edge, is 14.4 px wide at x = -8 in the zoomed window:
    # 6.4 px of it inside, less than half (the bench drops the still window's end-extension boxes there)
    np.testing.assert_allclose(make_moving.window_share(make_moving.read_rows(still / "gt" / "gt.txt"), still, forward),
                               [1.0, 6.4 / 14.4, 1.0], atol=1e-6)


def test_positions_compared_in_a_reference_of_another_scale_and_offset_give_the_same_tracks(monkeypatch):
    """Every rule that compares positions (tracklet IoU, association's IoU, velocity against the boxes' width and gap,
    the interpolated line, the occlusion check) is unchanged by a change of scale and offset: comparing two frames
    in frame 1's pixels is comparing them in either frame's own, however far the camera moved (issue #41, item 2).
    A reference 0.4 times the image's size and shifted must track a real sequence exactly as the image itself."""
    import sotmot.pipeline

    seq = require(DATA / "TUD-Stadtmitte")
    config = TrackerConfig().replace("appearance", backend="none")
    still = track_sequence(seq, config, None)

    def smaller(info, detections, motion_config, progress=False, seen=None):
        reference = np.tile(np.array([[0.4, 0.0, 130.0], [0.0, 0.4, -70.0]]), (info.length + 1, 1, 1))
        return CameraMotion(reference, reference.copy(), np.ones(info.length + 1), True)

    monkeypatch.setattr(sotmot.pipeline, "estimate_motion", smaller)
    scaled = track_sequence(seq, config, None)
    assert scaled.motion.moving and [t.det_index.tolist() for t in scaled.tracklets] == \
        [t.det_index.tolist() for t in still.tracklets]
    np.testing.assert_array_equal(scaled.tracks.ids, still.tracks.ids)
    np.testing.assert_array_equal(scaled.tracks.frames, still.tracks.frames)
    np.testing.assert_allclose(scaled.tracks.boxes, still.tracks.boxes, atol=1e-9)


def _panning_frames(still: int, length: int = 40) -> list[np.ndarray]:
    """BGR frames of the world: the camera still for ``still`` frames, then panning right 4 px a frame."""
    import cv2

    base = world()
    return [cv2.cvtColor(shifted(base, 40 + 4.0 * max(0, f - still), 20, (320, 100)), cv2.COLOR_GRAY2BGR)
            for f in range(1, length + 1)]


@pytest.mark.parametrize("still", [0, 12, 40])
def test_the_motion_measured_in_the_pass_is_the_estimate_after_it(still):
    """PassMotion sees each frame as the pass decodes it: a camera moving from the start is estimated there, to
    the bit what estimate_motion gives after the pass; one still at first and moving later is found moving there
    and estimated after; a still one is found still. Boxes other than the detections' (people left out), or a
    frame the pass skipped, set the pass's estimate aside: it is measured again, the same."""
    import sotmot.motion
    from sotmot.io import SeqInfo
    from sotmot.motion import PassMotion
    from sotmot.types import Detections

    frames = _panning_frames(still)
    info = SeqInfo(path=Path("<pan>"), name="pan", frame_rate=10.0, length=len(frames), width=320, height=100,
                   frames=frames)
    people = Detections(np.arange(1, 41), np.c_[np.arange(100.0, 140.0), np.tile([30.0, 20.0, 50.0], (40, 1))],
                        np.ones(40))
    config = MotionConfig()
    masked = []
    with pytest.MonkeyPatch.context() as patched:  # each pair leaves out the people of its earlier frame
        patched.setattr(sotmot.motion, "estimate_pair",
                        lambda *args, **kwargs: masked.append(args[3][0, 0]) or estimate_pair(*args, **kwargs))
        after = estimate_motion(info, people, config)
    assert masked[-(info.length - 1):] == list(np.arange(100.0, 139.0)) or not after.moving
    assert after.moving is (still < 40)
    by_frame = people.by_frame()

    def passed(skip: int = 0, other: int = 0) -> PassMotion:
        measure = PassMotion(info, config)
        for f in range(1, info.length + 1):
            if f != skip:
                boxes = people.boxes[by_frame[f]]
                measure.see(f, frames[f - 1], boxes[:0] if f == other else boxes)
        return measure

    known = passed().outcome(people)
    if still == 12:
        assert known is True  # found moving in the pass (its second pair), estimated after it
    else:
        assert isinstance(known, CameraMotion) and known.moving is (still == 0)
    for measure in (passed(), passed(skip=20), passed(other=1), passed(other=6)):
        motion = estimate_motion(info, people, config, seen=measure)
        np.testing.assert_array_equal(motion.pair, after.pair)
        np.testing.assert_array_equal(motion.confidence, after.confidence)
    assert passed(other=1).outcome(people) is None  # frame 1 begins the still check's first pair


def test_one_frame_preprocessed_alone_keeps_what_the_whole_sequence_keeps():
    from sotmot.config import PreprocessConfig
    from sotmot.preprocess import frame_preprocessor, preprocess
    from sotmot.types import Detections

    rng = np.random.default_rng(3)
    n = 60
    xy = rng.uniform(0, 60, (n, 2))
    boxes = np.hstack([xy, rng.uniform(10, 30, (n, 2))])
    dets = Detections(rng.integers(1, 6, n), boxes, rng.uniform(0, 1, n)).sorted()
    for config in (PreprocessConfig(), PreprocessConfig(score_threshold=0.3, nms="iom", nms_threshold=0.5)):
        whole = preprocess(dets, config)
        one = frame_preprocessor(config)
        for f in range(1, 6):
            mine = dets.frames == f
            shuffled = rng.permutation(np.flatnonzero(mine))  # a detector gives a frame's boxes in any order
            np.testing.assert_array_equal(one(f, (dets.boxes[shuffled], dets.scores[shuffled])),
                                          whole.boxes[whole.frames == f])
        assert len(whole) < len(dets)  # NMS and the threshold removed boxes: the test compares something
