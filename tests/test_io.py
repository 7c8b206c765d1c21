"""MOTChallenge reading and writing: every bad input names the file, the line and the problem."""

import os

import numpy as np
import pytest

from conftest import DATA, require, write_sequence
from sotmot.errors import InputError
from sotmot.io import (FrameReader, read_detections, read_ground_truth, read_results, read_seqinfo,
                       write_results)
from sotmot.types import Tracks

GOOD = "1,-1,10,10,5,8,0.9,-1,-1,-1"


@pytest.mark.parametrize("line, problem", [
    ("1,-1,10,10,5", "5 columns"),
    ("1,-1,10,abc,5,8,0.9", "non-numeric field 'abc'"),
    ("1,-1,10,10,0,8,0.9", "width and height must be positive"),
    ("1,-1,10,10,5,-2,0.9", "width and height must be positive"),
    ("9,-1,10,10,5,8,0.9", "frame 9 is outside 1..5"),
    ("0,-1,10,10,5,8,0.9", "frame 0 is outside 1..5"),
    ("1,-1,nan,10,5,8,0.9", "NaN and inf"),
    ("1,-1,10,10,5,8,inf", "NaN and inf"),
    ("1.5,-1,10,10,5,8,0.9", "not an integer"),
])
def test_bad_detection_line_names_file_line_and_problem(tmp_path, line, problem):
    seq = write_sequence(tmp_path, [GOOD, GOOD.replace("10,10", "30,10"), line], images=False)
    with pytest.raises(InputError) as err:
        read_detections(seq / "det" / "det.txt", seq_length=5)
    assert err.value.line == 3
    assert str(err.value).startswith(f"{seq / 'det' / 'det.txt'}:3: ")
    assert problem in str(err.value)


def test_blank_lines_are_skipped_and_line_numbers_stay_true(tmp_path):
    seq = write_sequence(tmp_path, [GOOD, "", "1,-1,1,1,1"], images=False)
    with pytest.raises(InputError) as err:
        read_detections(seq / "det" / "det.txt")
    assert err.value.line == 3


def test_missing_files_are_named(tmp_path):
    with pytest.raises(InputError, match="not a sequence folder"):
        read_seqinfo(tmp_path / "nope")
    with pytest.raises(InputError, match="seqinfo.ini: missing"):
        read_seqinfo(tmp_path)
    with pytest.raises(InputError, match="det.txt: missing"):
        read_detections(tmp_path / "det.txt")


@pytest.mark.parametrize("text, problem", [
    ("[Sequence]\nname=X\nframeRate=10\nimWidth=5\nimHeight=5\n", "missing key 'seqLength'"),
    ("[Sequence]\nname=X\nframeRate=ten\nseqLength=5\nimWidth=5\nimHeight=5\n", "frameRate='ten'"),
    ("[Sequence]\nname=X\nframeRate=10\nseqLength=0\nimWidth=5\nimHeight=5\n", "must be a positive number"),
    ("[Other]\nname=X\n", "no [Sequence] section"),
])
def test_bad_seqinfo(tmp_path, text, problem):
    (tmp_path / "seqinfo.ini").write_text(text)
    with pytest.raises(InputError) as err:
        read_seqinfo(tmp_path)
    assert problem in str(err.value)
    assert "seqinfo.ini" in str(err.value)


def test_bad_seqinfo_value_names_its_line(tmp_path):
    (tmp_path / "seqinfo.ini").write_text("[Sequence]\nname=X\nframeRate=ten\nseqLength=5\nimWidth=5\nimHeight=5\n")
    with pytest.raises(InputError) as err:
        read_seqinfo(tmp_path)
    assert err.value.line == 3


def test_missing_and_unreadable_frames(tmp_path):
    seq = write_sequence(tmp_path, [GOOD], length=3)
    reader = FrameReader(read_seqinfo(seq))
    assert reader(1).shape == (48, 64, 3)
    (seq / "img1" / "000002.jpg").unlink()
    with pytest.raises(InputError, match="frame 2 is missing"):
        reader(2)
    (seq / "img1" / "000003.jpg").write_bytes(b"not a jpeg")
    with pytest.raises(InputError, match="000003.jpg: frame 3 cannot be decoded"):
        reader(3)


def test_detections_come_back_in_canonical_order(tmp_path):
    lines = ["2,-1,1,1,5,5,0.5", "1,-1,1,1,5,5,0.2", "1,-1,9,9,5,5,0.8"]
    seq = write_sequence(tmp_path, lines, images=False)
    d = read_detections(seq / "det" / "det.txt", 5)
    assert d.frames.tolist() == [1, 1, 2]
    assert d.scores.tolist() == [0.8, 0.2, 0.5]
    assert not d.boxes.flags.writeable


def test_results_round_trip_and_duplicate_id_in_a_frame_is_an_error(tmp_path):
    tracks = Tracks(frames=[1, 1, 2], ids=[1, 2, 1], boxes=[[1, 2, 3, 4], [5, 6, 7, 8], [1.5, 2, 3, 4]],
                    scores=[0.9, 0.8, 0.7])
    path = tmp_path / "out" / "r.txt"
    write_results(path, tracks)
    back = read_results(path, 5)
    np.testing.assert_allclose(back.boxes, tracks.boxes)
    assert back.ids.tolist() == [1, 2, 1]
    path.write_text(path.read_text() + "2,1,0,0,1,1,1,-1,-1,-1\n")
    with pytest.raises(InputError, match="id 1 has a second box in frame 2") as err:
        read_results(path)
    assert err.value.line == 4


def test_failed_write_leaves_old_file_and_no_partial_file(tmp_path, monkeypatch):
    path = tmp_path / "r.txt"
    path.write_text("old\n")

    def boom(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(OSError):
        write_results(path, Tracks(frames=[1], ids=[1], boxes=[[1, 2, 3, 4]], scores=[1]))
    assert path.read_text() == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["r.txt"]


def test_real_sequences_read():
    pets = read_seqinfo(require(DATA / "PETS09-S2L1"))
    assert (pets.frame_rate, pets.length, pets.width, pets.height) == (7.0, 795, 768, 576)
    dets = read_detections(pets.det_path, pets.length)
    assert len(dets) == 4359
    gt = read_ground_truth(pets.gt_path, pets.length)
    assert gt.style == "MOT15" and len(np.unique(gt.ids)) == 19
    mot = read_seqinfo(require(DATA / "MOT16-05-clip30"))
    gt16 = read_ground_truth(mot.gt_path, mot.length)
    assert gt16.style == "MOT16"
    assert set(np.unique(gt16.pedestrians().classes)) == {1}


def test_atomic_path_renames_on_success_and_leaves_nothing_on_error(tmp_path):
    from sotmot.io import atomic_path

    target = tmp_path / "model.pt"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("disk full")
    assert target.read_text() == "old" and sorted(p.name for p in tmp_path.iterdir()) == ["model.pt"]
    with atomic_path(target) as tmp:
        tmp.write_text("new")
    assert target.read_text() == "new" and sorted(p.name for p in tmp_path.iterdir()) == ["model.pt"]
