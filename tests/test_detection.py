"""The built-in person detector (issue #24): real frames, a video with no detection file, clear errors."""

from __future__ import annotations

import builtins

import numpy as np
import pytest

from conftest import DATA, MODEL_0288, MODELS, require
from sotmot.config import DetectionConfig
from sotmot.errors import ConfigError, ModelError

DETECTOR = MODELS / "person-detection-0202" / "person-detection-0202.FP16-INT8.xml"


@pytest.fixture(scope="module")
def detector():
    pytest.importorskip("openvino")
    from sotmot.detection import make_detector

    return make_detector(DetectionConfig(model=str(require(DETECTOR)), min_score=0.5))


def _matches(found: np.ndarray, truth: np.ndarray) -> int:
    """Greedy one-to-one matches at IoU >= 0.5, best pairs first."""
    from sotmot.boxes import iou_matrix

    if not len(found) or not len(truth):
        return 0
    iou = iou_matrix(found, truth)
    matched = 0
    while iou.size and iou.max() >= 0.5:
        i, j = np.unravel_index(np.argmax(iou), iou.shape)
        iou[i, :] = iou[:, j] = -1
        matched += 1
    return matched


def test_the_detector_finds_the_people_of_three_pets_frames(detector):
    from sotmot.io import FrameReader, read_ground_truth, read_seqinfo

    info = read_seqinfo(require(DATA / "PETS09-S2L1"))
    gt = read_ground_truth(info.gt_path, info.length)
    reader = FrameReader(info)
    hits = found = truth = 0
    for frame in (1, 200, 400):
        boxes, scores = detector.detect(reader(frame))
        assert boxes.shape == (len(scores), 4) and (scores >= 0.5).all() and (scores <= 1).all()
        assert (boxes[:, 2:] > 0).all() and (boxes[:, 0] >= 0).all() and (boxes[:, 0] + boxes[:, 2] <= 768).all()
        people = gt.boxes[gt.frames == frame]
        hits, found, truth = hits + _matches(boxes, people), found + len(boxes), truth + len(people)
    recall, precision = hits / truth, hits / found
    # measured: 13 of 13 people found, no false box (INT8 model, aspect kept, score >= 0.5); one miss or one
    # false box more is within the tolerance, two are not
    assert truth == 13
    assert recall == pytest.approx(1.0, abs=0.08) and precision == pytest.approx(1.0, abs=0.08)


def test_the_detector_says_which_input_size_it_uses_once_per_size(caplog):
    import logging

    pytest.importorskip("openvino")
    from sotmot.detection import make_detector

    fresh = make_detector(DetectionConfig(model=str(require(DETECTOR)), min_score=0.5))  # no size compiled yet
    with caplog.at_level(logging.INFO, logger="sotmot.detection.openvino"):
        for _ in range(2):
            fresh.detect(np.zeros((1080, 1920, 3), np.uint8))
    said = [r.getMessage() for r in caplog.records if "input" in r.getMessage()]
    assert said == ["person detector input 544 x 960 for 1080 x 1920 frames (automatic)"]


def test_input_size_keeps_the_aspect_ratio_and_shrinks_large_frames_at_most_twice():
    from sotmot.detection.openvino import input_size

    assert input_size(1280, 720) == (448, 768)
    assert input_size(640, 480) == (512, 672) == input_size(768, 576)
    assert input_size(1920, 1080) == (544, 960)  # never shrunk more than 2x: small people stay findable
    assert input_size(3840, 2160) == (672, 1152)  # up to 1.5x the sides: a 4K frame does not cost 5x the time
    assert all(side % 32 == 0 for side in input_size(1000, 333))


def _pets_video(tmp_path, frames: int = 10):
    """The first frames of PETS09-S2L1 as an MJPG video (7 fps), ground truth cut to them."""
    import cv2

    from sotmot.io import FrameReader, read_seqinfo

    info = read_seqinfo(require(DATA / "PETS09-S2L1"))
    reader = FrameReader(info)
    path = tmp_path / "pets.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), info.frame_rate, (info.width, info.height))
    for f in range(1, frames + 1):
        writer.write(reader(f))
    writer.release()
    return path


def test_a_video_tracks_with_no_detection_file_and_its_det_txt_repeats_the_run(tmp_path, monkeypatch, capsys):
    pytest.importorskip("openvino")
    from sotmot.cli import main
    from sotmot.io import read_detections, read_results

    require(DETECTOR)
    video = _pets_video(tmp_path)
    monkeypatch.setenv("SOTMOT_DETECTOR_MODEL", str(DETECTOR))
    out = tmp_path / "out"
    assert main(["track", str(video), "--out", str(out), "--reid-model", str(require(MODEL_0288)), "-q"]) == 0
    tracks = read_results(out / "pets.txt", 10)
    assert tracks.n_tracks >= 3 and len(tracks) >= 30
    found = read_detections(out / "pets.det.txt", 10)
    assert len(found) >= len(tracks) / 2 and found.frames.min() == 1
    again = tmp_path / "again"
    assert main(["track", str(video), "--det", str(out / "pets.det.txt"), "--out", str(again), "--reid-model",
                 str(MODEL_0288), "-q"]) == 0
    assert (again / "pets.txt").read_bytes() == (out / "pets.txt").read_bytes()
    assert (again / "pets.flags.csv").read_bytes() == (out / "pets.flags.csv").read_bytes()
    assert not (again / "pets.det.txt").exists()  # detections from a file are not written again


def test_a_model_of_another_output_layout_is_one_clear_error():
    pytest.importorskip("openvino")
    from sotmot.detection import make_detector

    reid_ir = require(MODELS / "openvino-ir" / "person-reidentification-retail-0288.xml")
    with pytest.raises(ModelError, match="expected one output 1 x 1 x K x 7"):
        make_detector(DetectionConfig(model=str(reid_ir)))


def test_a_file_that_is_no_model_is_one_clear_error(tmp_path):
    pytest.importorskip("openvino")
    from sotmot.detection import make_detector

    bad = tmp_path / "detector.xml"
    bad.write_text("<net>not a model</net>")
    with pytest.raises(ModelError, match="cannot be loaded by OpenVINO as a detector"):
        make_detector(DetectionConfig(model=str(bad)))
    with pytest.raises(ModelError, match="person detector not found"):
        make_detector(DetectionConfig(model=str(tmp_path / "missing.xml")))


def test_a_missing_openvino_is_one_clear_error(monkeypatch):
    import sys

    from sotmot.detection import make_detector

    real_import = builtins.__import__

    def no_openvino(name, *args, **kwargs):
        if name == "openvino" or name.startswith("openvino."):
            raise ImportError("No module named 'openvino'", name="openvino")
        return real_import(name, *args, **kwargs)

    monkeypatch.delitem(sys.modules, "sotmot.detection.openvino", raising=False)
    monkeypatch.setattr(builtins, "__import__", no_openvino)
    with pytest.raises(ConfigError, match=r"needs 'openvino': pip install openvino \(a dependency of sotmot\)"):
        make_detector(DetectionConfig(model="any.xml"))


def test_auto_takes_the_file_when_there_is_one_else_the_model(tmp_path):
    from conftest import write_sequence
    from sotmot.detection import detection_source
    from sotmot.io import read_seqinfo

    seq = read_seqinfo(write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False))
    assert detection_source(DetectionConfig(), seq) == ("file", seq.det_path)
    assert detection_source(DetectionConfig(source="model"), seq) == ("model", None)
    seq.det_path.unlink()
    assert detection_source(DetectionConfig(), seq) == ("model", None)
    assert detection_source(DetectionConfig(source="file"), seq) == ("file", seq.det_path)
    other = tmp_path / "other.txt"
    assert detection_source(DetectionConfig(file=str(other)), seq) == ("model", None)
    other.write_text("")
    assert detection_source(DetectionConfig(file=str(other)), seq) == ("file", other)


class _CornerDetector:
    """Finds one box in the top-left corner of every even frame, none in odd ones."""

    def detect(self, frame):
        from sotmot.detection import rounded

        index = int(frame[0, 0, 0])
        if index % 2:
            return np.zeros((0, 4)), np.zeros(0)
        return rounded([[1.234, 2.0, 10.0, 20.0]], [0.876543])


def test_detect_sequence_gathers_every_frame_in_canonical_order_with_or_without_features(tmp_path):
    import cv2

    from conftest import GeometryEmbedder, write_sequence
    from sotmot.io import read_seqinfo
    from sotmot.passes import detect_sequence

    seq = write_sequence(tmp_path, [], length=6, images=True)
    for f in range(1, 7):  # each frame says its own number in the corner pixel
        cv2.imwrite(str(seq / "img1" / f"{f:06d}.png"), np.full((48, 64, 3), f, np.uint8))
    (seq / "seqinfo.ini").write_text((seq / "seqinfo.ini").read_text().replace(".jpg", ".png"))
    info = read_seqinfo(seq)
    found, features = detect_sequence(info, _CornerDetector())
    assert found.frames.tolist() == [2, 4, 6] and features.shape == (3, 0)
    assert found.boxes[0].tolist() == [1.23, 2.0, 10.0, 20.0] and found.scores[0] == 0.87654
    found, features = detect_sequence(info, _CornerDetector(), GeometryEmbedder())
    assert features.shape == (3, GeometryEmbedder.dim)
    assert np.allclose(features, GeometryEmbedder().embed(None, found.boxes))


def test_decoding_detection_and_re_id_run_in_three_threads_with_two_frames_held(tmp_path, monkeypatch):
    # issue #42: the detector searches one frame while the next decodes and the caller embeds earlier ones; a
    # decoded frame waits for the detector at most one frame ahead (memory), and the result is the serial one's
    import threading

    import sotmot.passes as passes
    from conftest import GeometryEmbedder, write_sequence
    from sotmot.io import read_seqinfo
    from sotmot.io.frames import JpegFolder

    seq = write_sequence(tmp_path, [], length=12, images=True)
    info = read_seqinfo(seq)
    decoded, searched, threads = [], [], {}
    read = JpegFolder.read

    def decode(self, frame):
        threads.setdefault("decode", set()).add(threading.current_thread().name)
        decoded.append(frame)
        assert len(decoded) - len(searched) <= 2, "the decoder ran more than one frame ahead of the detector"
        return read(self, frame)

    class Detector(_CornerDetector):
        def detect(self, frame):
            threads.setdefault("detect", set()).add(threading.current_thread().name)
            searched.append(len(searched) + 1)
            return super().detect(frame)

    class Embedder(GeometryEmbedder):
        def embed(self, image, boxes):
            threads.setdefault("embed", set()).add(threading.current_thread().name)
            return super().embed(image, boxes)

    monkeypatch.setattr(JpegFolder, "read", decode)
    found, features = passes.detect_sequence(info, Detector(), Embedder())
    assert decoded == list(range(1, 13)) and len(searched) == 12
    assert len(set.union(*threads.values())) == 3 and all(len(names) == 1 for names in threads.values())
    assert threads["embed"] == {threading.current_thread().name}
    assert np.allclose(features, GeometryEmbedder().embed(None, found.boxes))


def test_openvino_models_are_compiled_unpinned_with_the_threads_asked():
    # pinned, OpenVINO put the detector's and the re-ID model's threads on the same cores (issue #42)
    from sotmot.appearance.openvino import OpenVinoReidEmbedder
    from sotmot.config import AppearanceConfig

    embedder = OpenVinoReidEmbedder(AppearanceConfig(threads=1))
    compiled = embedder._request.get_compiled_model()
    assert compiled.get_property("ENABLE_CPU_PINNING") is False
    assert compiled.get_property("INFERENCE_NUM_THREADS") == 1

def test_the_built_in_detectors_family_is_known_from_the_run_not_guessed(tmp_path):
    import json

    from conftest import write_sequence
    from sotmot.detection import detections_header, known_family
    from sotmot.io import read_seqinfo

    info = read_seqinfo(write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False))
    ours = "/models/person-detection-0202.FP16-INT8.xml"
    assert known_family(DetectionConfig(source="model", model=ours), info) == "pd0202"
    assert known_family(DetectionConfig(source="model", model="/models/other-ssd.xml"), info) is None
    assert known_family(DetectionConfig(), info) is None  # a public det.txt: guessed from its scores
    replay = tmp_path / "out" / "SYN.det.txt"
    replay.parent.mkdir()
    replay.write_text("1,-1,10,10,5,8,0.9\n")
    assert known_family(DetectionConfig(file=str(replay)), info) is None  # no header: any detector's file
    # a run record beside it that says "model" does not make it so (it may belong to another run's results)
    record = {"inputs": {"detections": {"source": "model"}}, "detector_model": {"path": ours}}
    (tmp_path / "out" / "SYN.run.json").write_text(json.dumps(record))
    assert known_family(DetectionConfig(file=str(replay)), info) is None
    model = tmp_path / "person-detection-0202.FP16-INT8.xml"
    model.write_text("<net/>")
    copy = tmp_path / "any-name.txt"  # the header travels with the file, under any name
    copy.write_text(detections_header(model) + "1,-1,10,10,5,8,0.9\n")
    assert known_family(DetectionConfig(file=str(copy)), info) == "pd0202"


def test_a_video_asked_to_read_a_det_file_it_does_not_have_says_so_before_decoding(tmp_path, capsys):
    from conftest import write_video
    from sotmot.cli import main

    video = write_video(tmp_path / "street.avi")
    assert main(["track", str(video), "--detections", "file", "--out", str(tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "a video has no det.txt: give its detections with --det FILE" in err and "sotmot-video-" not in err


def test_a_replayed_det_txt_is_checked_by_the_detector_only_when_that_same_detector_is_given(tmp_path):
    from conftest import write_sequence
    from sotmot.detection import detections_header, detector_detections
    from sotmot.io import read_seqinfo

    info = read_seqinfo(write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False))
    ours, other = tmp_path / "a.xml", tmp_path / "b.xml"
    ours.write_text("<net>ours</net>")
    other.write_text("<net>other</net>")
    replay = tmp_path / "out" / "boxes.txt"
    replay.parent.mkdir()
    replay.write_text(detections_header(ours) + "1,-1,10,10,5,8,0.9\n")
    assert detector_detections(DetectionConfig(file=str(replay), model=str(ours)), info)
    moved = tmp_path / "elsewhere" / "a.xml"  # the same detector at another path: the same file by its hash
    moved.parent.mkdir()
    moved.write_text("<net>ours</net>")
    assert detector_detections(DetectionConfig(file=str(replay), model=str(moved)), info)
    assert not detector_detections(DetectionConfig(file=str(replay), model=str(other)), info)
    assert not detector_detections(DetectionConfig(model=str(ours)), info)  # a public det.txt
    assert detector_detections(DetectionConfig(source="model", model=str(ours)), info)
