"""SOT after association: trajectory ends extended where the detector stopped (issue #12)."""

from __future__ import annotations

import numpy as np

from conftest import GeometryEmbedder
from sotmot.config import EndsConfig, SotConfig, TrackerConfig
from sotmot.boxes import inside_share
from sotmot.sot.extend import end_velocity, extend_ends
from sotmot.sot.support import SUPPORTED_AFFINITY, SUPPORTED_STOP_IOU, WEAK_MIN_SCORE, DetectorSupport
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
    out = extend_ends(tracks, {1: LOOK}, images.__getitem__, LENGTH, 10.0,
                      GeometryEmbedder(), SotConfig(), EndsConfig(seconds=1.5))
    added = out.subset(out.from_sot)
    # fully inside until frame 27 (x + w = 182), then leaving: followed past the image's edge while at least
    # half of them is inside (frame 29: 60 %), not at frame 30 (30 %)
    assert added.frames.tolist() == list(range(21, 30))
    assert added.boxes[-1, 0] + added.boxes[-1, 2] > WIDTH  # a box partly outside, as MOTChallenge draws it
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
    out = extend_ends(both, feats, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(), SotConfig(),
                      EndsConfig(seconds=1.5))
    assert out.frames[out.from_sot & (out.ids == 1)].tolist() == [21, 22, 23]
    short = extend_ends(walker, {1: feats[1]}, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(),
                        SotConfig(), EndsConfig(seconds=0.2))
    assert short.frames[short.from_sot].tolist() == [21, 22]


def test_a_different_looking_candidate_is_refused():
    images = frames_with_walker()
    detected = range(1, 21)
    tracks = Tracks(list(detected), [1] * 20, [[walker_x(f), 40, 20, 40] for f in detected], [0.9] * 20)
    stranger = -LOOK  # the opposite feature: affinity 0
    out = extend_ends(tracks, {1: stranger}, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(),
                      SotConfig(), EndsConfig(seconds=1.5))
    assert not out.from_sot.any()


def test_velocity_and_inside_share():
    frames = np.array([1, 2, 3])
    boxes = np.array([[0, 0, 10, 10], [3, 0, 10, 10], [6, 0, 10, 10]], float)
    assert end_velocity(frames, boxes, 1).tolist() == [3.0, 0.0]
    assert end_velocity(frames, boxes, -1).tolist() == [-3.0, 0.0]
    np.testing.assert_array_equal(inside_share(np.array([[95.0, 0, 10, 10], [200, 0, 10, 10], [10, 10, 5, 5]]), 100,
                                               100), [0.5, 0.0, 1.0])


def test_pipeline_extends_ends_by_default_and_not_when_turned_off(tmp_path):
    from conftest import write_sequence
    from sotmot.pipeline import track_sequence

    lines = [f"{f},-1,{10 + 2 * f},20,20,40,0.95" for f in range(1, 9)]
    seq = write_sequence(tmp_path, lines, length=10, frame_rate=4, width=120, height=80)
    config = TrackerConfig().replace("confirm", enabled=False)
    off = track_sequence(seq, config.replace("ends", seconds=0.0), embedder=GeometryEmbedder())
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
                          SotConfig(), EndsConfig(seconds=1.5, min_confidence=0.7))
        return int(out.from_sot.sum())

    assert extended(0.9) >= 7 and extended(0.6) == 0
    assert extended(float("nan")) >= 7  # confirmation off: no confidence to judge by


class StubDetector:
    """A person detector that sees the walker in some frames only, a box 2 px off the truth, with a weak score."""

    def __init__(self, images: dict[int, np.ndarray], frames: range) -> None:
        self.seen = {images[f].tobytes(): f for f in frames}

    def detect(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        frame = self.seen.get(image.tobytes())
        if frame is None:
            return np.zeros((0, 4)), np.zeros(0)
        return np.array([[walker_x(frame) + 2.0, 41.0, 20.0, 40.0], [0.0, 0.0, 20.0, 40.0]]), np.array([0.15, 0.05])


def test_weak_boxes_extend_an_end_under_their_own_gate_where_sot_boxes_would_not():
    """[detection] weak_boxes: the ends grow by the detector's weak boxes near the motion prior (no template search),
    each needing the re-ID affinity SUPPORTED_AFFINITY; an SOT box needs [ends] min_affinity."""
    images = frames_with_walker()
    detected = range(1, 21)
    tracks = Tracks(list(detected), [1] * 20, [[walker_x(f), 40, 20, 40] for f in detected], [0.9] * 20)
    # the identity a little off the walker's look: affinity about 0.9, below a strict SOT gate of 0.95
    identity = GeometryEmbedder().embed(None, np.array([[0.0, 0.0, 21.0, 41.0]]))[0]
    affinity = float(identity @ LOOK)
    assert SUPPORTED_AFFINITY < affinity < 0.95
    strict = EndsConfig(seconds=1.5, min_affinity=0.95)
    support = DetectorSupport(StubDetector(images, [21, 22, 23, 26]))
    read: list[int] = []
    trace: list[dict] = []
    out = extend_ends(tracks, {1: identity}, lambda f: read.append(f) or images[f], LENGTH, 10.0, GeometryEmbedder(),
                      SotConfig(), strict, trace=trace, support=support)
    added = out.subset(out.from_sot)
    assert added.frames.tolist() == [21, 22, 23]  # frame 24 has no box: the end stops there, 26 is never reached
    assert read == [21, 22, 23, 24]  # only the frames searched: no template, so the end frame 20 is not decoded
    np.testing.assert_allclose(added.boxes, [[walker_x(f) + 2.0, 41.0, 20.0, 40.0] for f in (21, 22, 23)])
    assert [b["supported"] for b in trace] == [True] * 3
    # without the weak boxes nothing passes the strict gate; with the usual gate, the template's boxes
    nothing = extend_ends(tracks, {1: identity}, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(), SotConfig(),
                          strict)
    assert not nothing.from_sot.any()
    usual = extend_ends(tracks, {1: identity}, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(), SotConfig(),
                        EndsConfig(seconds=1.5))
    assert usual.frames[usual.from_sot & (usual.frames > 20)].tolist()[:7] == list(range(21, 28))


def test_under_the_public_protocol_no_track_starts_from_a_detector_box(tmp_path, monkeypatch):
    """With [detection] weak_boxes = "on" the detector only extends trajectories the given detections started:
    a person the detector sees in every frame, but who is in no det.txt line, never becomes a track."""
    import cv2

    import sotmot.detection as detection
    from sotmot.pipeline import track_sequence

    images = frames_with_walker()
    ghost = [100.0, 0.0, 20.0, 38.0]  # someone standing in the top rows, never in det.txt
    texture = np.random.default_rng(1).integers(0, 256, size=(38, 20, 3), dtype=np.uint8)
    seq = tmp_path / "SYN"
    (seq / "img1").mkdir(parents=True)
    (seq / "det").mkdir()
    for f, img in images.items():
        img[0:38, 100:120] = texture
        cv2.imwrite(str(seq / "img1" / f"{f:06d}.png"), img)
    (seq / "seqinfo.ini").write_text(f"[Sequence]\nname=SYN\nimDir=img1\nframeRate=10\nseqLength={LENGTH}\n"
                                     f"imWidth={WIDTH}\nimHeight={HEIGHT}\nimExt=.png\n")
    (seq / "det" / "det.txt").write_text("".join(f"{f},-1,{walker_x(f)},40,20,40,0.9\n" for f in range(1, 21)))

    class SeesEveryone:
        def detect(self, image):
            frame = next(f for f, img in images.items() if np.array_equal(img[40:80], image[40:80]))
            return np.array([[walker_x(frame), 40.0, 20.0, 40.0], ghost]), np.array([0.3, 0.3])

    monkeypatch.setattr(detection, "make_detector", lambda config: SeesEveryone())
    # (the weak-box search needs its motion prior at IoU 0.5 with the detector's box: no smoothing, which at 6 px a
    # frame pulls the end box 11 px behind the walker, and no camera motion, which this synthetic background fools)
    config = (TrackerConfig().replace("confirm", enabled=False).replace("detection", weak_boxes="on")
              .replace("ends", seconds=0.5).replace("postprocess", smooth_window=0)
              .replace("motion", compensation="off"))
    result = track_sequence(seq, config, embedder=GeometryEmbedder())
    tracks = result.tracks
    assert set(tracks.ids.tolist()) == {1}
    assert tracks.frames[tracks.from_sot].tolist() == [21, 22, 23, 24, 25]  # the walker, followed half a second
    from sotmot.boxes import iou_matrix

    assert iou_matrix(np.array(ghost), tracks.boxes).max() < 0.1
    # prepared with the check, finished with an "auto" configuration (bench_accuracy's private runs): kept
    from sotmot.pipeline import finish_sequence, prepare_sequence

    prepared = prepare_sequence(seq, config, embedder=GeometryEmbedder())
    again = finish_sequence(prepared, config.replace("detection", weak_boxes="auto"), embedder=GeometryEmbedder())
    assert prepared.support.frames_detected > 0
    np.testing.assert_array_equal(again.tracks.boxes, tracks.boxes)
    assert prepare_sequence(seq, config.replace("detection", weak_boxes="auto"),
                            embedder=GeometryEmbedder()).support is None


def test_with_the_detectors_own_boxes_its_weak_boxes_come_from_the_same_pass_and_extend_the_ends(tmp_path,
                                                                                                monkeypatch):
    """Private detections (issue #25): the detector runs once per frame at the lower of its two thresholds; boxes
    at [detection] min_score or above are tracked, the weaker ones only extend trajectory ends ([detection]
    weak_boxes "auto"), and the detector is never run again for them."""
    import cv2

    import sotmot.pipeline as pipeline
    from sotmot.config import DetectionConfig

    images = frames_with_walker()
    seq = tmp_path / "SYN"
    (seq / "img1").mkdir(parents=True)
    for f, img in images.items():
        img[HEIGHT - 1, 0] = f  # each frame says its number in a corner pixel
        cv2.imwrite(str(seq / "img1" / f"{f:06d}.png"), img)
    (seq / "seqinfo.ini").write_text(f"[Sequence]\nname=SYN\nimDir=img1\nframeRate=10\nseqLength={LENGTH}\n"
                                     f"imWidth={WIDTH}\nimHeight={HEIGHT}\nimExt=.png\n")
    calls, thresholds = [], []

    class Fading:  # sees the walker strongly until frame 20, weakly in 21-24, then not at all
        def __init__(self, config: DetectionConfig) -> None:
            self.min_score = config.min_score
            thresholds.append(config.min_score)

        def detect(self, image):
            frame = int(image[HEIGHT - 1, 0, 0])
            calls.append(frame)
            score = 0.9 if frame <= 20 else 0.15 if frame <= 24 else 0.0
            keep = score >= self.min_score
            return np.array([[walker_x(frame), 40.0, 20.0, 40.0]])[:int(keep)], np.array([score])[:int(keep)]

    monkeypatch.setattr(pipeline, "make_detector", Fading)
    config = (TrackerConfig().replace("detection", source="model", model="/models/fading.xml")
              .replace("confirm", enabled=False).replace("postprocess", smooth_window=0)
              .replace("ends", seconds=1.0))
    result = pipeline.track_sequence(seq, config, embedder=GeometryEmbedder())
    assert thresholds == [WEAK_MIN_SCORE]  # one detector, at the weak boxes' threshold
    assert sorted(calls) == list(range(1, LENGTH + 1))  # each frame detected once
    assert result.detections.frames.tolist() == list(range(1, 21))  # the weak boxes are not tracked
    assert result.detected.frames.tolist() == list(range(1, 21))  # nor written to <name>.det.txt
    added = result.tracks.subset(result.tracks.from_sot)
    assert added.frames.tolist() == [21, 22, 23, 24]
    np.testing.assert_array_equal(added.boxes, [[walker_x(f), 40.0, 20.0, 40.0] for f in range(21, 25)])
    calls.clear()
    off = pipeline.track_sequence(seq, config.replace("detection", weak_boxes="off"), embedder=GeometryEmbedder())
    assert thresholds[-1] == config.detection.min_score and sorted(calls) == list(range(1, LENGTH + 1))
    # without the weak boxes the template search extends the end (and runs on past the detector's last weak box)
    assert off.tracks.frames[off.tracks.from_sot].max() > 24


def test_the_run_record_says_whether_the_detector_checked_the_sot_boxes(tmp_path):
    """[detection] weak_boxes "auto" as the plan decided it, in <name>.run.json: private runs use the weak boxes, a
    det.txt does not unless asked; the plan never makes --resume re-run (it follows from what is compared)."""
    from conftest import write_sequence
    from sotmot.io import read_seqinfo
    from sotmot.provenance import IGNORED, run_record

    info = read_seqinfo(write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False))
    model = tmp_path / "detector.xml"
    model.write_bytes(b"<net/>")
    public = TrackerConfig().replace("detection", model=str(model))
    plan = run_record(info, public)["plan"]
    assert (plan["weak_boxes"], plan["ends_from"], plan["detections"]) == (False, "sot", "file")
    assert run_record(info, public)["detector_model"]["path"] is None
    refined = run_record(info, public.replace("detection", weak_boxes="on"))["plan"]
    assert (refined["weak_boxes"], refined["ends_from"], refined["detector_min_score"]) == (True, "detections", None)
    record = run_record(info, public.replace("detection", source="model"))
    assert (record["plan"]["weak_boxes"], record["plan"]["ends_from"]) == (True, "detections")
    assert record["plan"]["detector_min_score"] == WEAK_MIN_SCORE  # one pass: the tracked boxes and the weak ones
    assert record["detector_model"]["path"] == str(model) and "plan" in IGNORED


def test_a_detector_box_beside_another_trajectory_extends_an_end_where_a_template_box_would_stop(monkeypatch):
    """SUPPORTED_STOP_IOU: a weak detector box overlapping someone else's box at about 0.6 is a person of its own
    and extends the end; with the template's [ends] stop_iou (0.3) in its place the same end stops there."""
    import sotmot.sot.extend as extend

    images = frames_with_walker()
    walker = [(f, 1, [walker_x(f), 40, 20, 40]) for f in range(1, 21)]
    beside = [(f, 2, [walker_x(f) + 7.0, 40, 20, 40]) for f in range(21, 25)]  # someone walking just ahead
    frames, ids, boxes = zip(*(walker + beside))
    tracks = Tracks(list(frames), list(ids), list(boxes), [0.9] * len(frames))
    features = {1: LOOK, 2: -LOOK}

    def run() -> list[int]:
        support = DetectorSupport(StubDetector(images, range(21, 25)))
        out = extend_ends(tracks, features, images.__getitem__, LENGTH, 10.0, GeometryEmbedder(), SotConfig(),
                          EndsConfig(seconds=0.4), support=support)
        return out.frames[out.from_sot & (out.ids == 1)].tolist()

    assert SUPPORTED_STOP_IOU == 0.7 and run() == [21, 22, 23, 24]
    monkeypatch.setattr(extend, "SUPPORTED_STOP_IOU", EndsConfig().stop_iou)
    assert run() == []


def test_neither_decoding_ahead_nor_walking_in_frame_order_changes_an_extended_end(model_0288, monkeypatch):
    """A real clip (MOT16-13, a camera on a vehicle): the end extension decoding the next frame in the background
    gives the very tracks it gives decoding each frame when asked (and it did decode ahead); walking the ends in
    frame order gives those of walking them one after another (and the frames were read in another order)."""
    import sotmot.sot.extend as extend
    from conftest import DATA, require
    from sotmot.appearance import make_embedder
    from sotmot.io import FrameReader
    from sotmot.pipeline import finish_sequence, prepare_sequence

    config = TrackerConfig().replace("appearance", model=str(model_0288))
    prepared = prepare_sequence(require(DATA / "MOT16-13-clip30"), config)
    embedder = make_embedder(config.appearance)
    asked: list[int] = []
    prefetch, read = FrameReader.prefetch, FrameReader.__call__

    def counted(self, frame):
        asked.append(frame)
        prefetch(self, frame)

    def reads(order: list[int]):
        def call(self, frame):
            order.append(frame)
            return read(self, frame)
        return call

    in_frame_order: list[int] = []
    monkeypatch.setattr(FrameReader, "prefetch", counted)
    monkeypatch.setattr(FrameReader, "__call__", reads(in_frame_order))
    ahead = finish_sequence(prepared, config, embedder).tracks
    monkeypatch.setattr(FrameReader, "prefetch", lambda self, frame: None)
    plain = finish_sequence(prepared, config, embedder).tracks
    one_by_one: list[int] = []
    monkeypatch.setattr(FrameReader, "__call__", reads(one_by_one))
    monkeypatch.setattr(extend._End, "key", property(lambda end: 0))
    in_end_order = finish_sequence(prepared, config, embedder).tracks
    assert asked and ahead.from_sot.any() and in_frame_order != one_by_one
    for run in (plain, in_end_order):
        for a, b in [(ahead.frames, run.frames), (ahead.ids, run.ids), (ahead.boxes, run.boxes),
                     (ahead.from_sot, run.from_sot)]:
            np.testing.assert_array_equal(a, b)


def test_ends_walked_in_frame_order_claim_each_frame_as_walking_them_one_after_another_does(monkeypatch):
    """One walker, two tracks: id 2 holds frames 1-14, id 1 frames 19-26. Walked one end after another (id 1 first),
    id 1's first end takes the gap (15-18) and id 2's last end finds it taken. In frame order id 2's end, which
    reads frame 14 first, waits for id 1's at each frame: the same boxes. Without waiting it would take the gap."""
    import sotmot.sot.extend as extend

    images = frames_with_walker()
    rows = [(f, 2, [walker_x(f), 40, 20, 40]) for f in range(1, 15)] + \
        [(f, 1, [walker_x(f), 40, 20, 40]) for f in range(19, 27)]
    frames, ids, boxes = zip(*rows)
    tracks = Tracks(list(frames), list(ids), list(boxes), [0.9] * len(rows))

    def added(asked: list[int]) -> dict[int, list[int]]:
        def read(frame: int) -> np.ndarray:
            asked.append(frame)
            return images[frame]

        out = extend_ends(tracks, {1: LOOK, 2: LOOK}, read, LENGTH, 10.0, GeometryEmbedder(), SotConfig(),
                          EndsConfig(seconds=1.5))
        return {i: out.frames[out.from_sot & (out.ids == i)].tolist() for i in (1, 2)}

    in_frame_order: list[int] = []
    assert added(in_frame_order) == {1: [15, 16, 17, 18, 27, 28, 29], 2: []}
    monkeypatch.setattr(extend._End, "key", property(lambda end: 0))  # one end after another, in their order
    one_by_one: list[int] = []
    assert added(one_by_one) == {1: [15, 16, 17, 18, 27, 28, 29], 2: []}
    assert in_frame_order != one_by_one and in_frame_order.index(14) < in_frame_order.index(26)
    monkeypatch.undo()
    monkeypatch.setattr(extend._End, "may_search", lambda end, frame: False)  # nobody waits
    assert added([]) == {1: [27, 28, 29], 2: [15, 16, 17, 18]}
