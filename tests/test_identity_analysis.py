"""scripts/identity_analysis.py: fragmentations and switches counted from a hand-made matching."""

from __future__ import annotations

from helpers import load_script
from sotmot.scoring import FrameErrors


def test_a_person_on_three_ids_is_two_fragmentations_and_an_id_on_two_people_one_switch():
    script = load_script("identity_analysis")
    errors = FrameErrors()
    # person 0: output ids 1, 1, 2, 3 over frames 1-4; person 1: output id 3 in frames 5-6 (id 3 takes them over)
    errors.identities = {(1, 1): 0, (2, 1): 0, (3, 2): 0, (4, 3): 0, (5, 3): 1, (6, 3): 1}
    assert script.counts(errors) == {"fragmentations": 2, "switches": 1}
    people, tracks = script.lives(errors)
    assert script.changes(people[0]) == [(2, 1, 3, 2), (3, 2, 4, 3)]
    assert script.changes(tracks[3]) == [(4, 0, 5, 1)]


def test_a_choice_is_counted_for_each_judge_and_a_detection_of_no_one_is_not():
    import numpy as np

    from sotmot.config import TrackletConfig
    from sotmot.types import Detections

    script = load_script("identity_analysis")
    # frame 1: person 1 at A, person 2 at B; frame 2: person 1 again on B's very box, looking like A; a box of no one
    boxes = [[0, 0, 10, 40], [4, 0, 10, 40], [4, 0, 10, 40], [5, 0, 10, 40]]
    dets = Detections(frames=[1, 1, 2, 2], boxes=boxes, scores=[1.0] * 4)
    features = np.array([[1, 0, 0], [0.6, 0.8, 0], [1, 0.1, 0], [1, 0.1, 0]], dtype=np.float32)
    persons = np.array([1, 2, 1, -1])
    counts = script.choices(dets, features, persons, TrackletConfig())
    # appearance (0.95 against 0.60) picks person 1; the IoU (0.43 against 1) and the sum pick person 2
    assert counts == {"choices": 1, "appearance": 1, "IoU": 0, "affinity + IoU": 0}
    assert script.choices(dets, np.zeros((4, 0), np.float32), persons, TrackletConfig())["choices"] == 0


def test_a_switch_at_a_filled_box_is_told_by_the_people_on_either_side_of_the_gap():
    script = load_script("identity_analysis")
    errors = FrameErrors()
    # output id 7: detected in frames 1, 2 and 6, 7 (3-5 filled); frame 10 detected but matched to no one
    errors.identities = {(1, 7): 0, (2, 7): 0, (4, 7): 1, (6, 7): 1, (7, 7): 1}
    detected = [1, 2, 6, 7, 10]
    assert script.gap_kind(detected, errors, 7, 2, 4) == "interpolation: joins two people"
    errors.identities[(6, 7)] = 0  # the far side is person 0 again: the filled box strayed onto person 1
    assert script.gap_kind(detected, errors, 7, 2, 4) == "interpolation: filled off the person"
    assert script.gap_kind(detected, errors, 7, 8, 9) == "interpolation: an end unmatched"
    assert script.gap_kind([], errors, 7, 2, 4) == "interpolation: an end unmatched"


def test_a_missing_detector_model_is_refused_before_any_tracking(tmp_path, capsys):
    import pytest

    script = load_script("identity_analysis")
    with pytest.raises(SystemExit) as stop:
        script.main(["--model", "unused.onnx", "--data", str(tmp_path), "--detector-model", str(tmp_path / "no.xml")])
    assert stop.value.code == 2 and "--detector-model: no such file" in capsys.readouterr().err


def test_a_peer_folder_without_the_sequences_results_is_refused_before_any_tracking(tmp_path, capsys):
    import pytest

    from conftest import DATA, require

    require(DATA / "MOT16-02-clip30")
    script = load_script("identity_analysis")
    (tmp_path / "StrongSORT_+GSI").mkdir()  # the peer without its 4-s memory: another folder
    with pytest.raises(SystemExit) as stop:
        script.main(["--model", "unused.onnx", "--data", str(DATA), "--sequences", "MOT16-02-clip30",
                     "--peer", str(tmp_path / "StrongSORT_+GSI_4s")])
    assert stop.value.code == 2 and "StrongSORT_+GSI_4s/MOT16-02-clip30.txt" in capsys.readouterr().err
