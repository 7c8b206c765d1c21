"""A folder of images without seqinfo.ini tracks as the MOTChallenge folder of the same frames does: frames in
the order of their names (numbers compared as numbers), the rate from --fps / frame_rate, det/det.txt and
img1/ found where a MOTChallenge folder keeps them; and what is missing or wrong is one clear error."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

import sotmot
from sotmot.cli import main
from sotmot.errors import ConfigError, InputError
from sotmot.io import read_seqinfo
from sotmot.io.images import natural_key

from conftest import DATA, require

CLIP = DATA / "MOT16-02-clip30"


def _renamed_frames(seq: Path, folder: Path, pattern: str = "frame_{}.jpg", count: int | None = None) -> Path:
    """The sequence's frames copied to ``folder`` under names whose plain string order is not frame order."""
    folder.mkdir(parents=True)
    for k, path in enumerate(sorted((seq / "img1").glob("*.jpg"))[:count], 1):
        shutil.copyfile(path, folder / pattern.format(k))
    return folder


def test_names_are_ordered_with_their_numbers_compared_as_numbers():
    names = ["frame_10.jpg", "frame_2.jpg", "Frame_1.jpg", "frame_100.png", "frame_11.jpg"]
    assert sorted(names, key=natural_key) == ["Frame_1.jpg", "frame_2.jpg", "frame_10.jpg", "frame_11.jpg",
                                              "frame_100.png"]


def test_a_folder_of_images_tracks_as_its_motchallenge_folder(tmp_path):
    seq = require(CLIP)
    expected = sotmot.track(str(seq)).save(tmp_path / "mot.txt").read_bytes()
    plain = _renamed_frames(seq, tmp_path / "street")
    (plain / "._frame_1.jpg").write_bytes(b"macOS metadata")  # hidden: not a frame
    (plain / "notes.txt").write_text("not a frame either")
    info = read_seqinfo(plain, 30)
    assert (info.name, info.length, info.width, info.height, info.frame_rate) == ("street", 30, 1920, 1080, 30.0)
    assert info.frame_path(10).name == "frame_10.jpg" and info.frame_path(2).name == "frame_2.jpg"
    det = seq / "det" / "det.txt"
    assert sotmot.track(str(plain), detections=det, frame_rate=30).save(tmp_path / "api.txt").read_bytes() == expected
    assert main(["track", str(plain), "--fps", "30", "--det", str(det), "--out", str(tmp_path / "cli"), "-q"]) == 0
    assert (tmp_path / "cli" / "street.txt").read_bytes() == expected
    # img1/ and det/det.txt where a MOTChallenge folder has them, only seqinfo.ini missing: det.txt is read
    laid_out = tmp_path / "laid_out"
    _renamed_frames(seq, laid_out / "img1", "{:05d}.jpg")
    for part in ("det", "gt"):
        (laid_out / part).mkdir()
        shutil.copyfile(seq / part / f"{part}.txt", laid_out / part / f"{part}.txt")
    assert main(["track", str(laid_out), "--fps", "30", "--out", str(tmp_path / "cli"), "--eval", "-q"]) == 0
    assert (tmp_path / "cli" / "laid_out.txt").read_bytes() == expected
    scores = sotmot.evaluate(tmp_path / "cli" / "laid_out.txt", laid_out)  # scoring needs no frame rate
    assert scores["HOTA"] == pytest.approx(sotmot.evaluate(tmp_path / "mot.txt", seq)["HOTA"])


def test_an_annotation_export_without_seqinfo_is_compared_and_scored(tmp_path, capsys):
    """img1/, gt/gt.txt and det/det.txt but no seqinfo.ini, as annotation tools export MOT: compare takes --fps."""
    seq = require(CLIP)
    export = tmp_path / "export"
    _renamed_frames(seq, export / "img1", "frame_{:06d}.jpg")
    for part in ("det", "gt"):
        (export / part).mkdir()
        shutil.copyfile(seq / part / f"{part}.txt", export / part / f"{part}.txt")
    assert main(["compare", str(export), "--fps", "30", "--solvers", "greedy,flow"]) == 0
    out = capsys.readouterr().out
    assert "export" in out and "greedy" in out and "flow" in out
    assert main(["compare", str(export), "--solvers", "greedy"]) == 2  # no rate: said, not guessed
    assert "--fps N" in capsys.readouterr().err


def test_the_detector_runs_on_a_folder_of_images_without_detections(tmp_path):
    seq = require(CLIP)
    plain = _renamed_frames(seq, tmp_path / "few", count=8)
    assert main(["track", str(plain), "--fps", "30", "--out", str(tmp_path / "out"), "-q"]) == 0
    tracks = np.loadtxt(tmp_path / "out" / "few.txt", delimiter=",", ndmin=2)
    assert len(tracks) > 0 and tracks[:, 0].min() >= 1 and tracks[:, 0].max() <= 8
    assert (tmp_path / "out" / "few.det.txt").is_file()  # the boxes the detector found, to replay with --det


def test_what_is_missing_or_wrong_is_one_clear_error(tmp_path, capsys):
    seq = require(CLIP)
    plain = _renamed_frames(seq, tmp_path / "clip", count=3)
    with pytest.raises(InputError, match=r"clip: holds 3 images but no seqinfo\.ini, so no frame rate: give it"):
        read_seqinfo(plain)
    assert main(["track", str(plain), "--out", str(tmp_path / "out")]) == 2
    assert "--fps N" in capsys.readouterr().err
    with pytest.raises(InputError, match="above 240"):
        read_seqinfo(plain, 1000)
    with pytest.raises(ConfigError, match="frameRate in its seqinfo.ini"):  # a MOTChallenge folder says its own
        read_seqinfo(seq, 30)
    assert main(["track", str(plain), "--fps", "30", "--out", str(plain / "results")]) == 2
    assert "refusing to write into the sequence folder" in capsys.readouterr().err
    import cv2

    small = cv2.resize(cv2.imread(str(plain / "frame_2.jpg")), (640, 360))
    cv2.imwrite(str(plain / "frame_2.jpg"), small)
    with pytest.raises(InputError, match=r"frame_2\.jpg: frame 2 is 640 x 360 px but frame 1 is 1920 x 1080"):
        sotmot.track(str(plain), frame_rate=30)
    (plain / "frame_1.jpg").write_bytes(b"not an image")
    with pytest.raises(InputError, match=r"frame_1\.jpg: frame 1 cannot be decoded"):
        read_seqinfo(plain, 30)
    (plain / "frame_1.jpg").write_bytes(b"")  # empty: its own error, not one from inside OpenCV
    with pytest.raises(InputError, match=r"frame_1\.jpg: frame 1 cannot be decoded"):
        read_seqinfo(plain, 30)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(InputError, match="seqinfo.ini: missing"):  # no images: still asked for as a sequence folder
        read_seqinfo(empty)
    shutil.copytree(seq, empty / "MOT16-02", ignore=shutil.ignore_patterns("img1"))
    with pytest.raises(InputError, match=r"holds 1 sequence folder\(s\) \(MOT16-02\): give those, e.g. .*empty/\*"):
        read_seqinfo(empty)  # the folder above the sequences


def test_an_export_whose_first_label_is_not_people_is_warned_of(tmp_path, caplog):
    """CVAT numbers gt.txt's classes by its labels.txt; MOTChallenge's scoring takes class 1 for pedestrians."""
    seq = require(CLIP)
    export = tmp_path / "export"
    _renamed_frames(seq, export / "img1", "{:06d}.jpg")
    (export / "gt").mkdir()
    shutil.copyfile(seq / "gt" / "gt.txt", export / "gt" / "gt.txt")
    results = tmp_path / "r.txt"
    results.write_text("1,1,912,484,97,109,1,-1,-1,-1\n")
    (export / "gt" / "labels.txt").write_text("car\nperson\n")
    with caplog.at_level("WARNING"):
        sotmot.evaluate(results, export)
    assert "class 1 is 'car' by labels.txt, and the people are class 2" in caplog.text
    caplog.clear()
    (export / "gt" / "labels.txt").write_text("person\ncar\n")
    with caplog.at_level("WARNING"):
        sotmot.evaluate(results, export)
    assert "labels.txt" not in caplog.text


def test_a_list_of_image_paths_tracks_as_the_folder_does(tmp_path):
    seq = require(CLIP)
    paths = [str(p) for p in sorted((seq / "img1").glob("*.jpg"))]
    det = np.loadtxt(seq / "det" / "det.txt", delimiter=",", ndmin=2)[:, [0, 2, 3, 4, 5, 6]]
    listed = sotmot.track(paths, detections=det, frame_rate=30, name="MOT16-02")
    assert listed.save(tmp_path / "list.txt").read_bytes() == \
        sotmot.track(str(seq)).save(tmp_path / "folder.txt").read_bytes()
    with pytest.raises(InputError, match=r"nope\.jpg: frame 4 of the list is not a file"):
        sotmot.track(paths[:3] + [str(tmp_path / "nope.jpg")], frame_rate=30)
    with pytest.raises(ConfigError, match="frame_rate is needed"):
        sotmot.track(paths)
