"""Regression tests of the hardening issue (#14): each failed on main before its fix."""

from __future__ import annotations

import argparse
import json

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import GeometryEmbedder, write_sequence, write_video
from sotmot.config import TrackerConfig, load_config
from sotmot.errors import ConfigError, EvaluationError, InputError
from sotmot.io import read_detections, read_seqinfo, results_path


@pytest.mark.parametrize("name", ["../../x", "/tmp/x", "a/b", "..", ".", "", "a\\b"])
def test_sequence_name_that_would_escape_out_is_refused_with_its_line(tmp_path, name):
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False)
    text = (seq / "seqinfo.ini").read_text().replace("name=SYN", f"name={name}")
    (seq / "seqinfo.ini").write_text(text)
    with pytest.raises(InputError, match="plain file name") as err:
        read_seqinfo(seq)
    assert err.value.line == 2 or name == ""


def test_results_path_refuses_a_name_with_a_separator(tmp_path):
    with pytest.raises(InputError, match="outside this folder"):
        results_path(tmp_path, "../evil")
    assert results_path(tmp_path, "MOT16-09") == tmp_path / "MOT16-09.txt"


def test_track_never_writes_outside_out(tmp_path):
    from sotmot.runs import track_one

    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=True)
    (seq / "seqinfo.ini").write_text((seq / "seqinfo.ini").read_text().replace("name=SYN", "name=../escaped"))
    outcome = track_one(str(seq), str(tmp_path / "out"), TrackerConfig(), False,
                        embedder=GeometryEmbedder())
    assert outcome.status == "failed" and "plain file name" in outcome.message
    assert not (tmp_path / "escaped.txt").exists() and not (tmp_path / "escaped.flags.csv").exists()


def test_evaluation_refuses_names_with_separators(tmp_path):
    from sotmot.scoring import evaluate_files

    with pytest.raises(EvaluationError, match="plain file names"):
        evaluate_files([(tmp_path / "r.txt", tmp_path / "gt.txt", 5, "../x")])


def test_percent_in_seqinfo_is_a_character(tmp_path):
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False)
    (seq / "seqinfo.ini").write_text((seq / "seqinfo.ini").read_text() + "comment=100% real\n")
    assert read_seqinfo(seq).name == "SYN"


def test_utf8_bom_is_tolerated_in_seqinfo_det_and_config(tmp_path):
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9", "2,-1,10,10,5,8,0.8"], images=False)
    for path in (seq / "seqinfo.ini", seq / "det" / "det.txt"):
        path.write_bytes(b"\xef\xbb\xbf" + path.read_bytes())
    info = read_seqinfo(seq)
    assert len(read_detections(info.det_path, info.length)) == 2
    config = tmp_path / "c.toml"
    config.write_bytes(b"\xef\xbb\xbf[association]\nl_max = 45\n")
    assert load_config(config).association.l_max == 45


def test_non_utf8_config_is_one_clear_error(tmp_path):
    config = tmp_path / "c.toml"
    config.write_bytes(b"[association]\n# caf\xe9\nl_max = 45\n")
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_config(config)


def test_workers_must_be_positive(capsys):
    from sotmot.cli import main

    with pytest.raises(SystemExit):
        main(["track", "x", "--out", "y", "--workers", "0"])
    assert "must be at least 1" in capsys.readouterr().err


def test_progress_bars_only_on_a_terminal(monkeypatch):
    import sys

    from sotmot.cli.commands import _progress

    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    assert not _progress(argparse.Namespace(quiet=False))
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)
    assert _progress(argparse.Namespace(quiet=False)) and not _progress(argparse.Namespace(quiet=True))


def test_space_separated_ground_truth_gets_the_same_rules_as_comma_separated(tmp_path):
    from sotmot.io import gt_style

    comma = tmp_path / "a.txt"
    comma.write_text("1,1,10,10,5,8,1,1,1\n")
    spaces = tmp_path / "b.txt"
    spaces.write_text("1 1 10 10 5 8 1 1 1\n")
    assert gt_style(comma) == gt_style(spaces) == "MOT16"


def test_absurd_box_is_an_error_with_its_line_and_outside_boxes_a_warning(tmp_path, caplog):
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9", "1,-1,0,0,1e12,1e12,2.0", "2,-1,-50,10,20,8,0.9"],
                         images=False)
    info = read_seqinfo(seq)
    with pytest.raises(InputError, match="far larger than the 64 x 48 image") as err:
        read_detections(info.det_path, info.length, (info.width, info.height))
    assert err.value.line == 2
    (seq / "det" / "det.txt").write_text("1,-1,10,10,5,8,0.9\n2,-1,-50,10,20,8,0.9\n")
    with caplog.at_level("WARNING"):
        assert len(read_detections(info.det_path, info.length, (info.width, info.height))) == 2
    assert "1 box(es) lie mostly outside the 64 x 48 image (first on line 2)" in caplog.text


def test_common_mistakes_in_a_detections_file_are_named(tmp_path, caplog):
    """Frames counted from 0, boxes relative to the image, corners instead of width and height: each said."""
    seq = write_sequence(tmp_path, ["0,-1,10,10,5,8,0.9", "1,-1,12,10,5,8,0.9"], images=False)
    info = read_seqinfo(seq)
    size = (info.width, info.height)
    with pytest.raises(InputError, match="frame 0 is outside 1..5.*start at 0: add 1 to the first column"):
        read_detections(info.det_path, info.length, size)
    (seq / "det" / "det.txt").write_text("1,-1,0,10,5,8,0.9\n9,-1,2,10,5,8,0.9\n")
    with pytest.raises(InputError, match=r"frame 9 is outside 1..5, the sequence's frames$"):
        read_detections(info.det_path, info.length, size)
    (seq / "det" / "det.txt").write_text("1,-1,0.1,0.2,0.1,0.5,0.9\n2,-1,0.12,0.2,0.1,0.5,0.9\n")
    with pytest.raises(InputError, match=r"every box lies within 0..1 .*multiply x and w by 64, y and h by 48"):
        read_detections(info.det_path, info.length, size)
    (seq / "det" / "det.txt").write_text("1,-1,10,10,5,8\n")  # no score column
    with pytest.raises(InputError, match=r"6 columns, expected 7 to 10 .*no score column\? .*add the same score"):
        read_detections(info.det_path, info.length, size)
    (seq / "det" / "det.txt").write_text("1,-1,10,10,40,30,0.9\n2,-1,30,20,60,44,0.9\n")  # x1, y1, x2, y2
    with caplog.at_level("WARNING"):
        assert len(read_detections(info.det_path, info.length, size)) == 2
    assert "if its columns are x1, y1, x2, y2" in caplog.text


def test_frame_of_the_wrong_size_and_frames_read_as_bytes(tmp_path):
    from sotmot.io import FrameReader

    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], length=2)
    info = read_seqinfo(seq)
    assert FrameReader(info)(1).shape == (48, 64, 3)
    import cv2
    import numpy as np

    cv2.imwrite(str(seq / "img1" / "000002.jpg"), np.zeros((10, 10, 3), np.uint8))
    with pytest.raises(InputError, match="is 10 x 10 px but seqinfo.ini says imWidth=64"):
        FrameReader(info)(2)


def test_train_appearance_options_are_checked_before_any_work(capsys):
    from sotmot.cli import main

    for option, value, problem in (("--epochs", "0", "must be at least 1"), ("--lr", "-5", "above 0")):
        with pytest.raises(SystemExit):
            main(["train-appearance", "x", "--init", "m.onnx", "--out", "t.pt", option, value])
        assert problem in capsys.readouterr().err


def test_verbose_after_the_command(tmp_path):
    from sotmot.cli import build_parser

    args = build_parser().parse_args(["eval", str(tmp_path), str(tmp_path), "-vv"])
    assert args.verbose == 2
    assert build_parser().parse_args(["-v", "eval", str(tmp_path), str(tmp_path)]).verbose == 1


def _walker_sequence(tmp_path):
    lines = [f"{f},-1,{10 + 2 * f},20,20,40,0.95" for f in range(1, 9)]
    return write_sequence(tmp_path, lines, length=10, frame_rate=4, width=120, height=80)


def test_results_carry_a_run_record_and_resume_reruns_only_when_it_differs(tmp_path):
    import json

    import numpy as np

    from sotmot import __version__
    from sotmot.runs import track_one

    seq = _walker_sequence(tmp_path)
    out = tmp_path / "out"
    config = TrackerConfig()
    first = track_one(str(seq), str(out), config, True, embedder=GeometryEmbedder())
    assert first.status == "done"
    record = json.loads((out / "SYN.run.json").read_text())
    assert record["solver"] == "greedy" and record["config"]["association"]["l_max"] == 60
    assert len(record["inputs"]["detections"]["sha256"]) == 64 and record["sotmot"] == __version__
    assert record["environment"]["packages"]["numpy"] == np.__version__ and record["environment"]["python"]
    assert track_one(str(seq), str(out), config, True, embedder=GeometryEmbedder()).status == "skipped"
    record["environment"]["packages"]["numpy"] = "1.0"  # recorded, not compared: an upgrade does not re-run
    (out / "SYN.run.json").write_text(json.dumps(record))
    assert track_one(str(seq), str(out), config, True, embedder=GeometryEmbedder()).status == "skipped"
    changed = track_one(str(seq), str(out), config.replace("association", l_max=45), True,
                        embedder=GeometryEmbedder())
    assert changed.status == "done" and "re-run: made with a different config.association.l_max" in changed.message
    other_solver = track_one(str(seq), str(out), config.replace("association", l_max=45, solver="flow"), True,
                             embedder=GeometryEmbedder())
    assert "different config.association.solver" in other_solver.message
    (out / "SYN.run.json").unlink()
    again = track_one(str(seq), str(out), config, True, embedder=GeometryEmbedder())
    assert again.status == "done" and "has no run record" in again.message
    (seq / "det" / "det.txt").write_text((seq / "det" / "det.txt").read_text() + "9,-1,30,20,20,40,0.9\n")
    edited = track_one(str(seq), str(out), config, True, embedder=GeometryEmbedder())
    assert "inputs.detections.sha256" in edited.message


def test_out_that_is_a_file_fails_before_any_work(tmp_path):
    from sotmot.runs import track_many

    seq = _walker_sequence(tmp_path)
    (tmp_path / "taken").write_text("x")
    with pytest.raises(InputError, match="must be a folder"):
        track_many([seq], tmp_path / "taken", TrackerConfig())


def test_version(capsys):
    """One version: the code's ``__version__``, which ``--version``, run records and the package metadata carry."""
    from importlib.metadata import version

    from sotmot import __version__
    from sotmot.cli import main

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out == f"sotmot {__version__}\n"
    assert version("sotmot") == __version__


def test_one_frame_batches_are_an_error_not_zero_tracks(tmp_path):
    from sotmot.pipeline import track_sequence

    seq = _walker_sequence(tmp_path)
    config = TrackerConfig().replace("tracklets", batch_seconds=1e-9)
    with pytest.raises(ConfigError, match="batches of 1 frame"):
        track_sequence(seq, config, embedder=GeometryEmbedder())


def test_json_pointing_at_a_folder_is_one_line(tmp_path, capsys):
    from sotmot.cli import main

    seq = _walker_sequence(tmp_path)
    (tmp_path / "res").mkdir()
    (tmp_path / "res" / "SYN.txt").write_text("1,1,10,20,20,40,1,-1,-1,-1\n")
    (seq / "gt").mkdir()
    (seq / "gt" / "gt.txt").write_text("1,1,10,20,20,40,1,1,1\n")
    assert main(["eval", str(tmp_path / "res"), str(seq), "--json", str(tmp_path)]) == 2
    assert "--json must name a file, but this is a folder" in capsys.readouterr().err


def test_threads_beyond_the_cpus_are_capped_with_a_warning(caplog, model_0288):
    import os

    from sotmot.appearance import make_embedder
    from sotmot.config import AppearanceConfig

    with caplog.at_level("WARNING"):
        make_embedder(AppearanceConfig(model=str(model_0288), threads=1000))
    assert f"using {os.cpu_count()}" in caplog.text


ROW_BYTES = st.lists(st.sampled_from([b"1", b"-1", b"10", b"2.5", b"nan", b"x", b",", b" ", b"\n", b"\t",
                                      b"\xef\xbb\xbf", b"\xff", b"1e400", b"0", b"-", b"."]), max_size=60).map(b"".join)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.one_of(ROW_BYTES, st.binary(max_size=200)))
def test_readers_never_raise_anything_but_input_error(tmp_path, data):
    from sotmot.io import read_ground_truth

    path = tmp_path / "f.txt"
    path.write_bytes(data)
    for reader in (read_detections, read_ground_truth):
        try:
            reader(path, 5)
        except InputError as exc:
            assert str(exc).startswith(str(path))
    seq = tmp_path / "seq"
    seq.mkdir(exist_ok=True)
    (seq / "seqinfo.ini").write_bytes(b"[Sequence]\n" + data)
    try:
        read_seqinfo(seq)
    except InputError as exc:
        assert str(exc).startswith(str(seq / "seqinfo.ini"))


def test_duplicate_ids_in_ground_truth_name_the_line(tmp_path):
    from sotmot.io import read_ground_truth

    path = tmp_path / "gt.txt"
    path.write_text("1,1,10,10,5,8,1,1,1\n1,2,30,10,5,8,1,1,1\n1,1,50,10,5,8,1,1,1\n")
    with pytest.raises(InputError, match="id 1 has a second box in frame 1") as err:
        read_ground_truth(path, 5)
    assert err.value.line == 3


def test_corrupt_weights_are_one_clear_error(tmp_path, model_0288):
    pytest.importorskip("torch")
    from sotmot.appearance import make_embedder
    from sotmot.config import AppearanceConfig
    from sotmot.errors import ModelError

    bad = tmp_path / "tuned.pt"
    bad.write_bytes(b"not a checkpoint" * 10)
    with pytest.raises(ModelError, match="not a readable checkpoint") as err:
        make_embedder(AppearanceConfig(model=str(model_0288), backend="torch", weights=str(bad)))
    assert "weights_only" not in str(err.value)


def test_absurd_l_max_is_a_config_error():
    with pytest.raises(ConfigError, match="l_max must be between"):
        TrackerConfig().replace("association", l_max=10**20)


def _video(tmp_path, n=12, fps=5.0):
    return write_video(tmp_path / "street.avi", n, fps)


def test_track_a_video_with_its_detections_then_render_it(tmp_path, model_0288, capsys, monkeypatch):
    from sotmot.cli import main
    from sotmot.io import read_results

    video = _video(tmp_path)
    det = tmp_path / "street_det.txt"
    det.write_text("".join(f"{f},-1,{10 + 3 * f},20,20,40,0.9\n" for f in range(1, 13)))
    out = tmp_path / "res"
    assert main(["track", str(video), "--det", str(det), "--out", str(out), "--reid-model", str(model_0288),
                 "--unconfirmed", "keep", "-q"]) == 0
    tracks = read_results(out / "street.txt")
    assert tracks.n_tracks == 1 and len(tracks) == 12 and tracks.frames.min() == 1
    assert main(["render", str(video), str(out / "street.txt"), "--out", str(tmp_path / "r.avi"), "-q"]) == 0
    assert (tmp_path / "r.avi").is_file()
    capsys.readouterr()
    monkeypatch.delenv("SOTMOT_DETECTOR_MODEL", raising=False)  # the bundled detector finds the people
    assert main(["track", str(video), "--out", str(tmp_path / "model"), "--reid-model", str(model_0288), "-q"]) == 0
    assert (tmp_path / "model" / "street.det.txt").is_file()
    record = json.loads((tmp_path / "model" / "street.run.json").read_text())
    assert record["detector_model"]["path"].endswith("sotmot/models/person-detection-0202.FP16-INT8.xml")


def test_video_detections_are_checked_against_the_user_file(tmp_path, capsys, model_0288):
    from sotmot.cli import main

    video = _video(tmp_path, n=4)
    det = tmp_path / "d.txt"
    det.write_text("1,-1,10,20,20,40,0.9\n9,-1,10,20,20,40,0.9\n")
    assert main(["track", str(video), "--det", str(det), "--out", str(tmp_path / "out"), "--reid-model",
                 str(model_0288), "-q"]) == 2
    err = capsys.readouterr().err
    assert f"{det}:2" in err and "frame 9 is outside 1..4" in err
    info = read_seqinfo(video, fps=12.5)
    assert (info.name, info.length, info.width, info.height, info.frame_rate) == ("street", 4, 120, 80, 12.5)
    assert info.video == video and read_seqinfo(video).frame_rate == 5.0


def test_a_failed_results_write_leaves_no_side_files(tmp_path, monkeypatch):
    import sotmot.io.files as io_files
    from sotmot import runs as batch

    seq = _walker_sequence(tmp_path)
    real, calls = io_files.os.fsync, []

    def full_disk(fd):  # the disk fills while the third of the run's files is written
        calls.append(fd)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        real(fd)

    monkeypatch.setattr(io_files.os, "fsync", full_disk)
    outcome = batch.track_one(str(seq), str(tmp_path / "out"), TrackerConfig(), False,
                              embedder=GeometryEmbedder())
    assert outcome.status == "failed"
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == []


def test_the_solver_is_configuration():
    from sotmot.cli import build_parser
    from sotmot.cli.flags import build_config

    from sotmot.association import SOLVERS

    with pytest.raises(ConfigError, match="solver must be one of " + ", ".join(sorted(SOLVERS))):
        TrackerConfig().replace("association", solver="magic")
    args = build_parser().parse_args(["track", "x", "--out", "y", "--merger", "flow"])
    assert build_config(args).association.solver == "flow"
    args = build_parser().parse_args(["track", "x", "--out", "y"])
    assert build_config(args).association.solver == "greedy"


def test_resume_skips_a_copied_sequence_and_a_video_decoded_again(tmp_path, model_0288):
    import shutil
    import time

    from sotmot.runs import track_one
    from sotmot.cli import main

    seq = _walker_sequence(tmp_path)
    out = tmp_path / "out"
    assert track_one(str(seq), str(out), TrackerConfig(), True, embedder=GeometryEmbedder()).status == "done"
    time.sleep(0.01)
    copy = shutil.copytree(seq, tmp_path / "copy" / "SYN")  # new modification times, same files
    assert track_one(str(copy), str(out), TrackerConfig(), True,
                     embedder=GeometryEmbedder()).status == "skipped"
    video = _video(tmp_path)
    det = tmp_path / "street_det.txt"
    det.write_text("".join(f"{f},-1,{10 + 3 * f},20,20,40,0.9\n" for f in range(1, 13)))
    args = ["track", str(video), "--det", str(det), "--out", str(tmp_path / "v"), "--reid-model", str(model_0288),
            "-q", "--resume"]
    assert main(args) == 0
    record = (tmp_path / "v" / "street.run.json").stat().st_mtime_ns
    assert main(args) == 0 and (tmp_path / "v" / "street.run.json").stat().st_mtime_ns == record  # skipped


def test_a_folder_without_its_frames_says_how_to_track_without_them(tmp_path, capsys):
    from sotmot.cli import main

    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9", "2,-1,11,10,5,8,0.9"], images=False)
    assert main(["track", str(seq), "--out", str(tmp_path / "out"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "frame 1 is missing from img1/ (there is no img1/ folder" in err and "--appearance none" in err
    assert main(["track", str(seq), "--out", str(tmp_path / "out"), "-q", "--appearance", "none"]) == 0


def test_a_file_that_is_neither_folder_nor_known_video_says_so(tmp_path):
    from sotmot.io.video import is_video

    camcorder = tmp_path / "street.MTS"
    camcorder.write_bytes(b"")
    assert is_video(camcorder) and is_video(tmp_path / "clip.ts")
    notes = tmp_path / "det.txt"
    notes.write_text("1,-1,10,10,5,8,0.9\n")
    with pytest.raises(InputError, match=r"det\.txt: a file, not a sequence folder; a video is known by its extension"):
        read_seqinfo(notes)
    with pytest.raises(InputError, match="not a sequence folder .it does not exist"):
        read_seqinfo(tmp_path / "missing")
    record, settings = tmp_path / "street.run.json", tmp_path / "mine.toml"
    record.write_text("{}")
    settings.write_text("")
    with pytest.raises(InputError, match=r"street\.run\.json: a run record .*--config FILE"):
        read_seqinfo(record)
    with pytest.raises(InputError, match=r"mine\.toml: a settings file, not a sequence: .*--config FILE"):
        read_seqinfo(settings)
