"""Rendering results on frames."""

import cv2
import numpy as np

from conftest import write_sequence
from sotmot.cli import main
from sotmot.io import read_results, read_seqinfo, write_results
from sotmot.inspect.render import colour, render
from sotmot.io.flags import read_flags, write_flags
from sotmot.types import Tracks


def test_video_has_every_frame_and_flags_round_trip(tmp_path):
    seq = write_sequence(tmp_path, ["1,-1,5,5,10,20,1"], length=6, width=96, height=64)
    tracks = Tracks(frames=[1, 2, 3, 3], ids=[1, 1, 1, 2], boxes=[[5, 5, 10, 20]] * 4, scores=[1, 1, 1, 1],
                    interpolated=[False, True, False, False], from_sot=[False, False, True, False])
    results = tmp_path / "res" / "SYN.txt"
    write_results(results, tracks)
    write_flags(results, tracks)
    back = read_flags(results, read_results(results))
    assert back.interpolated.tolist() == [False, True, False, False]
    assert back.from_sot.tolist() == [False, False, True, False]
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "v.avi"), "-q"]) == 0
    cap = cv2.VideoCapture(str(tmp_path / "v.avi"))
    assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 6
    ok, first = cap.read()
    assert ok and first.shape == (64, 96, 3)
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())  # no partial file left


def test_frames_folder_and_drawing(tmp_path):
    seq = write_sequence(tmp_path, ["1,-1,5,5,10,20,1"], length=2, width=96, height=64)
    tracks = Tracks(frames=[1], ids=[7], boxes=[[20, 20, 30, 30]], scores=[1])
    render(read_seqinfo(seq), tracks, tmp_path / "frames")
    img = cv2.imread(str(tmp_path / "frames" / "000001.jpg"))
    plain = cv2.imread(str(seq / "img1" / "000001.jpg"))
    assert sorted(p.name for p in (tmp_path / "frames").iterdir()) == ["000001.jpg", "000002.jpg"]
    assert np.abs(img.astype(int) - plain.astype(int)).max() > 50  # the box was drawn
    assert colour(7) == colour(7) and colour(7) != colour(8)


def test_render_with_ground_truth_marks_errors_side_by_side(tmp_path):
    gt = ["1,1,10,10,20,30,1,1,1", "2,1,12,10,20,30,1,1,1", "2,2,60,20,20,30,1,1,1"]
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,1"], length=2, width=96, height=64, gt_lines=gt)
    results = tmp_path / "res" / "SYN.txt"
    # frame 1: a hit and a false box; frame 2: person 1 found under another id (a switch), person 2 missed
    results.parent.mkdir()
    results.write_text("1,1,10,10,20,30,1,-1,-1,-1\n1,5,70,5,10,10,1,-1,-1,-1\n2,3,12,10,20,30,1,-1,-1,-1\n")
    from sotmot.scoring import frame_errors

    errors = frame_errors(results, seq / "gt" / "gt.txt", 2, "SYN")
    assert errors.totals() == {"TP": 2, "FP": 1, "FN": 1, "IDSW": 1}
    assert [m[3] for m in errors.matched[2]] == [True]
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "v.avi"), "--gt", "-q"]) == 0
    cap = cv2.VideoCapture(str(tmp_path / "v.avi"))
    ok, first = cap.read()
    assert ok and first.shape == (64, 192, 3)  # results and ground truth side by side


def test_render_refuses_to_write_into_the_sequence_and_odd_targets(tmp_path, capsys):
    import pytest

    from sotmot.errors import InputError

    seq = write_sequence(tmp_path, ["1,-1,5,5,10,20,1"], length=2, width=96, height=64)
    info = read_seqinfo(seq)
    tracks = Tracks(frames=[1], ids=[7], boxes=[[20, 20, 30, 30]], scores=[1])
    before = (seq / "img1" / "000001.jpg").read_bytes()
    for target, problem in ((seq / "img1", "refusing to write into the sequence folder"),
                            (seq / "render", "refusing to write into the sequence folder"),
                            (tmp_path / "v.mkv", "cannot write '.mkv'"),
                            (tmp_path / "v.gif", "cannot write '.gif'")):
        with pytest.raises(InputError, match=problem):
            render(info, tracks, target)
    assert (seq / "img1" / "000001.jpg").read_bytes() == before
    (tmp_path / "taken").write_text("x")
    with pytest.raises(InputError, match="a file is in the way"):
        render(info, tracks, tmp_path / "taken")
    results = tmp_path / "r.txt"
    write_results(results, tracks)
    assert main(["render", str(seq), str(results), "--out", str(seq / "img1"), "-q"]) == 2
    assert "refusing" in capsys.readouterr().err


def test_failed_frame_write_is_an_error_and_leaves_nothing_half_written(tmp_path, monkeypatch):
    import pytest

    from sotmot.inspect import render as render_module
    from sotmot.errors import InputError

    seq = write_sequence(tmp_path, ["1,-1,5,5,10,20,1"], length=3, width=96, height=64)
    tracks = Tracks(frames=[1], ids=[7], boxes=[[20, 20, 30, 30]], scores=[1])
    render(read_seqinfo(seq), tracks, tmp_path / "frames")  # an earlier, complete render
    real, calls = render_module.write_bytes_atomic, []

    def full_disk(path, data):
        calls.append(path)
        if len(calls) >= 2:
            raise OSError(28, "No space left on device")
        real(path, data)

    monkeypatch.setattr(render_module, "write_bytes_atomic", full_disk)
    for target in (tmp_path / "frames", tmp_path / "new"):
        calls.clear()
        with pytest.raises(InputError, match="could not be written"):
            render(read_seqinfo(seq), tracks, target)
    assert sorted(p.name for p in tmp_path.iterdir() if p.name.startswith(".")) == []
    assert not (tmp_path / "new").exists()  # a new folder appears only when complete
    # an existing folder is written into frame by frame: every frame there is whole (old or new)
    frames = sorted((tmp_path / "frames").iterdir())
    assert [p.name for p in frames] == ["000001.jpg", "000002.jpg", "000003.jpg"]
    assert all(cv2.imread(str(p)) is not None for p in frames)


def test_dropped_boxes_are_drawn_grey_only_when_asked_and_only_the_runs_own(tmp_path, capsys):
    seq = write_sequence(tmp_path, ["1,-1,5,5,10,20,1"], length=2, width=96, height=64)
    results = tmp_path / "res" / "SYN.txt"
    write_results(results, Tracks(frames=[1], ids=[1], boxes=[[5, 5, 10, 20]], scores=[1]))
    low = results.with_name("SYN.low.txt")
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "none"), "--dropped", "-q"]) == 2
    assert f"{low}: --dropped draws the boxes confirmation dropped" in capsys.readouterr().err
    write_results(low, Tracks(frames=[1], ids=[2], boxes=[[40, 10, 30, 40]], scores=[0.2]))
    for name, extra in (("plain", []), ("dropped", ["--dropped"])):
        assert main(["render", str(seq), str(results), "--out", str(tmp_path / name), "-q", *extra]) == 0
    said = capsys.readouterr().out
    assert "2 frames, 1 tracks and 1 dropped boxes" in said and "2 frames, 1 tracks ->" in said
    plain, dropped = (cv2.imread(str(tmp_path / name / "000001.jpg")).astype(int) for name in ("plain", "dropped"))
    edge = (slice(9, 12), slice(40, 48))  # the top edge of the dropped box, where its first dash lies
    assert np.abs(dropped[edge] - plain[edge]).max() > 50 and np.abs(dropped[30:, :30] - plain[30:, :30]).max() < 30
    assert main(["render", str(seq), str(low), "--out", str(tmp_path / "x"), "-q"]) == 0  # a low.txt is results too


def test_a_low_file_the_run_did_not_write_is_not_drawn_as_its_dropped_boxes(tmp_path, capsys):
    from conftest import DATA, require

    seq = require(DATA / "MOT16-02-clip30")
    assert main(["track", str(seq), "--out", str(tmp_path / "r"), "-q"]) == 0  # --unconfirmed drop: no low.txt
    results = tmp_path / "r" / "MOT16-02-clip30.txt"
    results.with_name("MOT16-02-clip30.low.txt").write_text(results.read_text())
    capsys.readouterr()
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "v"), "--dropped", "-q"]) == 2
    assert "MOT16-02-clip30.low.txt is not one of the files the run of MOT16-02-clip30.txt wrote" in \
        capsys.readouterr().err


def test_the_pixels_a_mask_ignores_are_shaded_and_the_mask_is_never_written_over(tmp_path, capsys):
    seq = write_sequence(tmp_path, ["1,-1,5,5,10,20,1"], length=2, width=96, height=64)
    results = tmp_path / "res" / "SYN.txt"
    write_results(results, Tracks(frames=[1], ids=[1], boxes=[[5, 5, 10, 20]], scores=[1]))
    mask = np.full((64, 96), 255, np.uint8)
    mask[40:, 50:] = 0
    cv2.imwrite(str(tmp_path / "mask.png"), mask)
    for name, extra in (("plain", []), ("masked", ["--mask", str(tmp_path / "mask.png")])):
        assert main(["render", str(seq), str(results), "--out", str(tmp_path / name), "-q", *extra]) == 0
    plain, masked = (cv2.imread(str(tmp_path / name / "000002.jpg")).astype(int) for name in ("plain", "masked"))
    assert np.abs(masked[44:, 54:] - plain[44:, 54:]).sum(axis=2).min() > 60  # shaded
    assert np.abs(masked[:36] - plain[:36]).max() < 10  # untouched (JPEG noise aside)
    out = tmp_path / "mask.png"
    assert main(["render", str(seq), str(results), "--out", str(out), "--mask", str(out), "-q"]) == 2
    assert "which this run reads" in capsys.readouterr().err
    small = tmp_path / "small.png"
    cv2.imwrite(str(small), mask[:32, :48])
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "v"), "--mask", str(small), "-q"]) == 2
    assert "the mask is 48 x 32 pixels and the frames of SYN 96 x 64" in capsys.readouterr().err
