"""Regression tests of issue #89: nothing the user owns is lost, and no partial or silently different result
passes as the real one. Each test names the case of the issue it pins; each failed on main before its fix."""

from __future__ import annotations

import io
import json
import math

import cv2
import networkx as nx
import numpy as np
import pytest

import sotmot
from conftest import stopped_at_window, write_sequence, write_video
from sotmot.cli import main
from sotmot.errors import ConfigError, InputError
from sotmot.io import write_files_atomic

from test_live import _parts

#: Two people walking right, 2 px a frame, seen in every frame of a 12-frame sequence at 2 fps.
WALKERS = [f"{f},-1,{4 + 2 * f},10,12,24,0.9" for f in range(1, 13)] + \
          [f"{f},-1,{60 - 2 * f},14,12,24,0.8" for f in range(1, 13)]
MOTION_ONLY = {"appearance": {"backend": "none"}}


def _seq(tmp_path, **kwargs):
    return write_sequence(tmp_path / "data", WALKERS, length=12, width=96, height=64, **kwargs)


# 1. Result.save over a file the run read ------------------------------------------------------------------------

def test_result_save_never_writes_over_the_detections_that_frames_in_memory_were_tracked_from(tmp_path):
    seq = _seq(tmp_path)
    det = seq / "det" / "det.txt"
    before = det.read_bytes()
    frames = [cv2.imread(str(p)) for p in sorted((seq / "img1").glob("*.jpg"))]
    result = sotmot.track(frames, detections=det, frame_rate=2, config=MOTION_ONLY)
    with pytest.raises(InputError, match="which this run reads"):
        result.save(det)
    assert det.read_bytes() == before


def test_result_save_never_turns_an_image_of_a_list_of_paths_into_a_text_file(tmp_path):
    seq = _seq(tmp_path)
    images = sorted((seq / "img1").glob("*.jpg"))
    first = images[0].read_bytes()
    result = sotmot.track(images, detections=seq / "det" / "det.txt", frame_rate=2, config=MOTION_ONLY)
    with pytest.raises(InputError):
        result.save(images[0])
    assert images[0].read_bytes() == first


def test_result_save_refuses_the_sequence_folder_and_a_folder_in_the_way(tmp_path):
    seq = _seq(tmp_path)
    result = sotmot.track(seq, config=MOTION_ONLY)
    with pytest.raises(InputError, match="refusing to write into the sequence folder"):
        result.save(seq / "SYN.txt")  # track --out and render refuse this folder too: one rule
    (tmp_path / "busy").mkdir()
    with pytest.raises(InputError, match="is a folder"):  # was a raw IsADirectoryError naming a temporary file
        result.save(tmp_path / "busy")
    assert result.save(tmp_path / "out" / "SYN.txt").is_file()


# 2. a live session never replaces an earlier one's results -------------------------------------------------------

def test_a_second_live_session_into_the_same_folder_is_refused_and_the_first_kept(tmp_path, monkeypatch, capsys):
    import sotmot.api

    video = write_video(tmp_path / "street.avi", n=5)
    monkeypatch.setattr(sotmot.api, "stream", _parts(2, KeyboardInterrupt()))
    out = tmp_path / "L"
    assert main(["track", "--live", str(video), "--out", str(out), "-q"]) == 130
    first = {p.name: p.read_bytes() for p in out.iterdir()}
    assert len(first["street.txt"]) > 0
    (tmp_path / "b").mkdir()
    other = write_video(tmp_path / "b" / "street.avi", n=5)  # another video of the same name
    monkeypatch.setattr(sotmot.api, "stream", _parts(1, None))
    assert main(["track", "--live", str(other), "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "an earlier session of 'street' left its results here" in err and "street.txt" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == first


# 3. a failed or interrupted write never removes the earlier run's files ------------------------------------------

def test_a_results_path_that_is_a_folder_fails_before_tracking_and_keeps_the_earlier_files(tmp_path, capsys,
                                                                                          monkeypatch):
    seq = _seq(tmp_path)
    out = tmp_path / "out"
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q"]) == 0
    (out / "SYN.txt").unlink()
    (out / "SYN.txt").mkdir()  # the results path became a folder
    kept = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    assert {"SYN.flags.csv", "SYN.run.json"} <= set(kept)
    import sotmot.stepping

    def never(*args, **kwargs):
        raise AssertionError("tracked although the results could not be written")

    monkeypatch.setattr(sotmot.stepping, "track_whole", never)
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q"]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == kept


def test_ctrl_c_while_the_files_are_written_leaves_the_earlier_run_whole(tmp_path, monkeypatch):
    import sotmot.io.files

    seq = _seq(tmp_path)
    out = tmp_path / "out"
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q"]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    calls = []
    real_fsync = sotmot.io.files.os.fsync

    def interrupted(fd):
        calls.append(fd)
        if len(calls) == 2:
            raise KeyboardInterrupt
        real_fsync(fd)

    monkeypatch.setattr(sotmot.io.files.os, "fsync", interrupted)
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--unconfirmed", "keep",
                 "-q"]) == 130
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # nothing removed, nothing half-written


def test_write_files_atomic_checks_every_target_before_the_first_rename(tmp_path):
    (tmp_path / "a.txt").write_text("old a")
    (tmp_path / "b").mkdir()
    with pytest.raises(InputError, match="is a folder"):
        write_files_atomic({tmp_path / "b": b"new b", tmp_path / "a.txt": b"new a"})
    assert (tmp_path / "a.txt").read_text() == "old a" and sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b"]


# 4. partial results are said to be partial where they are read ---------------------------------------------------

def _partial_run(tmp_path, capsys):
    """A 12-frame sequence tracked in windows of 2 s (4 frames), stopped after its first window."""
    seq = _seq(tmp_path, gt_lines=[f"{f},1,{4 + 2 * f},10,12,24,1,1,1" for f in range(1, 13)])
    out = tmp_path / "out"
    with stopped_at_window(1):
        code = main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q", "--window", "2",
                     "--config", str(_short_gap(tmp_path))])
    return seq, out, code, capsys.readouterr().err


def _short_gap(tmp_path):
    path = tmp_path / "short.toml"
    path.write_text("[association]\nl_max_seconds = 0.5\n")
    return path


def test_an_interrupted_windowed_run_says_its_results_are_partial_and_how_to_finish(tmp_path, capsys):
    seq, out, code, err = _partial_run(tmp_path, capsys)
    assert code == 130
    assert "the results are partial: frames 1-" in err and "--resume continues" in err
    record = json.loads((out / "SYN.run.json").read_text())["windows"]
    assert record["complete"] is False and 0 < record["frames_final"] < 12 and record["length"] == 12


def test_eval_and_render_say_a_partial_result_is_partial_before_they_use_it(tmp_path, capsys):
    seq, out, code, _ = _partial_run(tmp_path, capsys)
    assert main(["eval", str(out), str(seq), "--json", str(tmp_path / "scores.json")]) == 0
    captured = capsys.readouterr()
    assert "SYN.txt is partial: its run stopped before the end (frames 1-" in captured.err
    assert "--resume" in captured.err
    assert "partial" in json.loads((tmp_path / "scores.json").read_text())["warnings"]["SYN"][0]
    assert main(["render", str(seq), str(out / "SYN.txt"), "--out", str(tmp_path / "pics"), "-q"]) == 0
    assert "is partial" in capsys.readouterr().err
    with pytest.warns(UserWarning, match="is partial"):
        sotmot.evaluate(out / "SYN.txt", seq)


# 7. graph.json has no "nan" text; GraphML keeps numbers numbers --------------------------------------------------

def test_graph_files_write_a_missing_measurement_as_null_in_json_and_a_number_in_graphml():
    from sotmot.inspect.explain import graph_files

    graph = nx.DiGraph()
    graph.add_edge(1, 2, weight=float("nan"), ok_iou=True)
    graph.add_edge(2, 3, weight=0.5, ok_iou=False)
    files = graph_files(graph)
    data = json.loads(files["graph.json"])
    assert [e["weight"] for e in data["edges"]] == [None, 0.5] and "nan" not in files["graph.json"].decode()
    back = nx.read_graphml(io.BytesIO(files["graph.graphml"]))
    weights = [d["weight"] for *_, d in back.edges(data=True)]
    assert math.isnan(weights[0]) and weights[1] == 0.5  # was the text "nan" and "0.5"


# 8. explain names the interpolated boxes the confirmation dropped ------------------------------------------------

def test_explain_gaps_says_which_filled_boxes_the_confirmation_dropped(monkeypatch):
    from types import SimpleNamespace

    import sotmot.postprocess
    from sotmot.config import TrackerConfig
    from sotmot.inspect.explain import explain_gaps
    from sotmot.types import Tracks

    config = TrackerConfig()
    trajectory = SimpleNamespace(start=1, end=6)
    gap = SimpleNamespace(after=1, before=6, written=4, left_out=0, why="within 4 s: filled")
    kept = Tracks(frames=[1, 2, 6], ids=[13] * 3, boxes=[[0, 0, 5, 5]] * 3, scores=[1] * 3)
    dropped = Tracks(frames=[3, 4, 5], ids=[13] * 3, boxes=[[0, 0, 5, 5]] * 3, scores=[1] * 3)
    result = SimpleNamespace(trajectories=[trajectory], track_ids=[13], info=SimpleNamespace(frame_rate=2.0),
                             postprocess=None, occluders=None, tracks=kept, dropped=dropped)
    monkeypatch.setattr(sotmot.postprocess, "gaps_of", lambda *args: [gap])
    text = explain_gaps(result, config, 13)
    assert "4 box(es) filled, 1 in the results and 3 dropped by the confirmation" in text
    assert "written" not in text


# 9. a name given to a folder's run is used; None is not taken for frames needing a rate --------------------------

def test_track_of_a_folder_takes_the_name_it_is_given(tmp_path):
    seq = _seq(tmp_path)
    result = sotmot.track(seq, config=MOTION_ONLY, name="other")
    assert result.info.name == "other" and result.info.path == seq
    with pytest.raises(ConfigError, match="plain file name"):
        sotmot.track(seq, config=MOTION_ONLY, name="a/b")


def test_track_of_none_says_what_frames_must_be_not_that_a_frame_rate_is_missing():
    with pytest.raises(InputError, match="frames must be a video file"):
        sotmot.track(None)


# one rule for every command, and messages that said the wrong thing ---------------------------------------------

def test_reports_and_graph_files_never_land_inside_the_sequence_folder(tmp_path, capsys):
    seq = _seq(tmp_path, gt_lines=[f"{f},1,{4 + 2 * f},10,12,24,1,1,1" for f in range(1, 13)])
    assert main(["track", str(seq), "--out", str(tmp_path / "out"), "--appearance", "none", "-q"]) == 0
    assert main(["eval", str(tmp_path / "out"), str(seq), "--json", str(seq / "scores.json")]) == 2
    assert "refusing to write into the sequence folder" in capsys.readouterr().err
    assert main(["graph", str(seq), "--out", str(seq / "graph"), "--appearance", "none", "-q"]) == 2
    assert "refusing to write into the sequence folder" in capsys.readouterr().err
    assert not (seq / "scores.json").exists() and not (seq / "graph").exists()


def test_an_empty_out_is_refused_not_taken_for_the_current_folder(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["track", str(tmp_path), "--out", ""])
    assert "--out: an empty path" in capsys.readouterr().err


def test_models_refuses_a_missing_model_file_named_in_the_environment(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SOTMOT_REID_MODEL", str(tmp_path / "gone.onnx"))
    assert main(["models"]) == 2
    assert "SOTMOT_REID_MODEL=" in capsys.readouterr().err


def test_explain_of_an_unknown_id_does_not_name_a_flag_explain_has_not():
    from sotmot.config import TrackerConfig
    from sotmot.errors import SotmotError
    from sotmot.inspect.explain import explain

    graph = nx.DiGraph()
    graph.add_node(0, track=1)
    with pytest.raises(SotmotError) as info:
        explain(graph, 1, 99, TrackerConfig())
    assert "--frames" not in str(info.value) and "no output track has that id" in str(info.value)
    from sotmot.inspect.explain import explain_tracklets

    with pytest.raises(SotmotError) as info:
        explain_tracklets(graph, 0, 7, TrackerConfig())
    assert "--frames" not in str(info.value) and "tracklet 7 is not one of this run's tracklets" in str(info.value)


def test_a_folder_of_images_without_a_rate_names_the_flag_of_the_command_in_use(tmp_path, capsys):
    (tmp_path / "imgs").mkdir()
    for k in range(3):
        cv2.imwrite(str(tmp_path / "imgs" / f"{k}.jpg"), np.full((16, 16, 3), 100, np.uint8))
    (tmp_path / "r.txt").write_text("1,1,1,1,4,4,1,-1,-1,-1\n")
    assert main(["render", str(tmp_path / "imgs"), str(tmp_path / "r.txt"), "--out", str(tmp_path / "v"),
                 "-q"]) == 2
    err = capsys.readouterr().err
    assert "--fps N" in err and "sotmot track --fps" not in err


# 5. frames in memory and the same folder give the same boxes where the camera moves ---------------------------

def test_frames_in_memory_and_their_folder_give_the_same_boxes_where_the_camera_moves():
    from conftest import DATA, require

    seq = require(DATA / "MOT16-05-clip30")
    info = sotmot.io.read_seqinfo(seq)
    frames = [cv2.imread(str(info.frame_path(f))) for f in range(1, info.length + 1)]
    folder = sotmot.track(seq, config=MOTION_ONLY)
    memory = sotmot.track(frames, detections=info.det_path, frame_rate=info.frame_rate, name=info.name,
                          config=MOTION_ONLY)
    assert folder.found["camera_motion"]["moving"] and folder.found == memory.found
    assert len(folder.tracks) == len(memory.tracks) > 50
    np.testing.assert_array_equal(folder.tracks.boxes, memory.tracks.boxes)  # were up to 1.9 px apart


# 6. the summary names the score map auto chose ------------------------------------------------------------------

def test_the_summary_names_the_score_map_auto_chose_and_keeps_quiet_when_the_user_chose(tmp_path, capsys):
    seq = _seq(tmp_path)
    assert main(["track", str(seq), "--out", str(tmp_path / "a"), "--appearance", "none", "-q"]) == 0
    out = capsys.readouterr().out
    assert "scores read as 'quantile' (--confidence sets the map)" in out  # 0.9 and 0.8: a flag, too few to learn
    assert "the camera moves" not in out  # grey frames: no corner, no motion measured (was "moves (0.0 px ...)")
    assert main(["track", str(seq), "--out", str(tmp_path / "b"), "--appearance", "none", "--confidence", "frcnn",
                 "-q"]) == 0
    assert "scores read as" not in capsys.readouterr().out


# messages: a one-frame video's empty result, and --resume where nothing needs writing --------------------------

def test_a_sequence_too_short_for_any_tracklet_says_why_it_has_no_track(tmp_path, capsys):
    seq = write_sequence(tmp_path / "data", ["1,-1,5,5,10,20,0.9", "1,-1,40,5,10,20,0.8"], length=1, width=96,
                         height=64)
    assert main(["track", str(seq), "--out", str(tmp_path / "out"), "--appearance", "none", "-q"]) == 0
    out = capsys.readouterr().out
    assert "0 tracks, 0 boxes (2 detections, but a tracklet needs a person seen in more than [tracklets] l_min = 1" \
           in out and "the sequence has 1" in out


def test_resume_into_a_folder_it_cannot_write_skips_what_is_complete(tmp_path, capsys, monkeypatch):
    import sotmot.io

    seq = _seq(tmp_path)
    out = tmp_path / "out"
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q"]) == 0
    capsys.readouterr()

    def read_only(path):
        raise InputError(path, "cannot write results here: Permission denied")

    monkeypatch.setattr(sotmot.io, "check_output_dir", read_only)  # as a read-only folder answers a user
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--resume", "-q"]) == 0
    assert "skipped (--resume)" in capsys.readouterr().out
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q"]) == 2  # without: refused
    assert "Permission denied" in capsys.readouterr().err


def test_detections_model_runs_the_detector_rather_than_looking_for_a_file_named_model(tmp_path):
    seq = _seq(tmp_path)
    result = sotmot.track(seq, detections="model", config=MOTION_ONLY)
    assert result.config.detection.source == "model" and result.config.detection.file is None


def test_a_ground_truth_file_cut_mid_line_is_called_cut_not_a_layout_of_too_few_columns(tmp_path):
    from sotmot.io import read_ground_truth

    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,1,1,10,10,1,1,1\n2,1,1,1,10,10,1")
    with pytest.raises(InputError, match=r"gt.txt:2: the file ends in the middle of this line \(7 of 9 columns\)"):
        read_ground_truth(gt, 5)


def test_a_window_too_short_for_the_gap_says_a_shorter_gap_allows_it(tmp_path, capsys):
    seq = _seq(tmp_path)
    assert main(["track", str(seq), "--out", str(tmp_path / "o"), "--window", "2", "--appearance", "none",
                 "-q"]) == 2
    assert "or a shorter association gap ([association] l_max_seconds" in capsys.readouterr().err


def test_an_empty_folder_with_fps_says_it_is_empty_not_how_seqinfo_works(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    assert main(["track", str(tmp_path / "empty"), "--out", str(tmp_path / "o"), "--fps", "5", "-q"]) == 2
    err = capsys.readouterr().err
    assert "holds neither images" in err and "frameRate" not in err


@pytest.mark.parametrize("command", [["render", "URL", "r.txt", "--out", "o"], ["graph", "URL", "--out", "o"],
                                     ["eval", "res", "URL"], ["track", "URL", "--out", "o"]])
def test_a_stream_url_given_as_a_path_is_named_without_its_password(tmp_path, capsys, command):
    argv = ["rtsp://admin:s3cret@10.0.0.5/live" if a == "URL" else a for a in command]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "rtsp://admin:***@10.0.0.5/live" in err and "s3cret" not in err and "rtsp:/admin" not in err


def test_a_broken_model_file_gets_sotmot_s_message_without_the_parsers_noise(tmp_path, capfd):
    from sotmot.appearance import make_embedder
    from sotmot.config import AppearanceConfig
    from sotmot.errors import ModelError

    broken = tmp_path / "bad.onnx"
    broken.write_text("not a model")
    with pytest.raises(ModelError, match="bad.onnx: cannot be loaded by OpenVINO"):
        make_embedder(AppearanceConfig(model=str(broken), backend="openvino"))
    assert "tensorflow" not in capfd.readouterr().err.lower()  # TensorFlow's front end printed its parse errors


def test_a_resumed_windowed_run_counts_the_tracks_of_its_file(tmp_path, capsys):
    seq, out, code, _ = _partial_run(tmp_path, capsys)
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q", "--window", "2", "--config",
                 str(_short_gap(tmp_path)), "--resume"]) == 0
    said = capsys.readouterr().out
    ids = {line.split(",")[1] for line in (out / "SYN.txt").read_text().splitlines()}
    assert f"), {len(ids)} tracks (" in said and "in the windows tracked now)" in said and "resumed after" in said
