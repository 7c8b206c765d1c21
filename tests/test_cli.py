"""The command line, end to end on real data, and its errors."""

import json
import re

import pytest

from conftest import DATA, require
from sotmot.cli import main


def test_track_and_eval_on_mot16_05_clip_matches_pinned_scores(tmp_path, model_0288, capsys):
    seq = require(DATA / "MOT16-05-clip30")
    out = tmp_path / "res"
    assert main(["track", str(seq), "--out", str(out), "--reid-model", str(model_0288), "-q"]) == 0
    assert (out / "MOT16-05-clip30.txt").is_file()
    assert main(["eval", str(out), str(seq), "--json", str(tmp_path / "s.json")]) == 0
    scores = json.loads((tmp_path / "s.json").read_text())["sequences"]["MOT16-05-clip30"]
    # pinned from a run with the default configuration (model 0288, greedy merge, confirmation with the
    # packaged calibration: 39.0 / 26.2 / 40.6; before confirmation 39.2 / 28.8 / 44.2); the tolerance
    # absorbs onnxruntime's small numeric differences between CPUs
    assert scores["HOTA"] == pytest.approx(39.0, abs=1.5)
    assert scores["MOTA"] == pytest.approx(26.2, abs=2.0)
    assert scores["IDF1"] == pytest.approx(40.6, abs=2.0)
    assert scores["IDSW"] <= 2
    printed = capsys.readouterr().out
    assert "MOT16-05-clip30" in printed and "HOTA" in printed and "TrackEval rules: MOT16-05-clip30 MOT16" in printed


def test_help_teaches(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["track", "--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "--merger" in text and "greedy" in text and "SOTMOT_REID_MODEL" in text and "examples:" in text


def test_unknown_solver_given_by_its_old_flag_is_rejected_with_the_valid_names(capsys):
    with pytest.raises(SystemExit):
        main(["track", "x", "--out", "y", "--merger", "magic"])
    assert "greedy" in capsys.readouterr().err


def test_errors_print_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "c.toml"
    bad.write_text("[tracklets]\ntial = 3\n")
    assert main(["track", str(tmp_path), "--out", str(tmp_path / "o"), "--config", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("sotmot: error: ") and "tial" in err and "Traceback" not in err
    assert main(["track", str(tmp_path / "missing"), "--out", str(tmp_path / "o")]) == 2
    assert "not a sequence folder" in capsys.readouterr().err


def test_missing_model_error_names_the_flag(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SOTMOT_REID_MODEL", str(tmp_path / "gone.onnx"))
    seq = require(DATA / "MOT16-05-clip30")
    assert main(["track", str(seq), "--out", str(tmp_path)]) == 2
    assert "gone.onnx (from --reid-model" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())  # nothing half-written


def test_compare_runs_every_solver_on_the_same_tracklets(tmp_path, model_0288, capsys):
    seq = require(DATA / "MOT16-05-clip30")
    out = tmp_path / "cmp.json"
    assert main(["compare", str(seq), "--mergers", "greedy,flow,flow-nx", "--reid-model", str(model_0288),
                 "-q", "--json", str(out)]) == 0
    rows = json.loads(out.read_text())["rows"]
    assert set(rows) == {"MOT16-05-clip30", "COMBINED"}
    by = rows["MOT16-05-clip30"]
    assert set(by) == {"greedy", "flow", "flow-nx"}
    # both flow solvers are optimal on the same network: the same cost
    assert by["flow"]["flow_net_cost"] == pytest.approx(by["flow-nx"]["flow_net_cost"], abs=1e-6)
    assert "tracks" in capsys.readouterr().out
    assert main(["compare", str(seq), "--mergers", "greedy,nope", "--reid-model", str(model_0288)]) == 2
    assert "valid solvers" in capsys.readouterr().err


def test_appearance_backend_and_flip_come_from_the_command_line():
    from sotmot.cli import build_parser
    from sotmot.cli.flags import build_config

    config = build_config(build_parser().parse_args(["track", "x", "--out", "y"]))
    assert config.appearance.backend == "auto" and config.appearance.flip
    args = build_parser().parse_args(["track", "x", "--out", "y", "--appearance", "onnx", "--no-flip"])
    config = build_config(args)
    assert config.appearance.backend == "onnx" and not config.appearance.flip


def test_auto_backend_is_openvino_where_installed_on_the_cpu_else_onnx(monkeypatch):
    import importlib.util

    from sotmot.appearance import resolve_backend
    from sotmot.config import AppearanceConfig

    pytest.importorskip("openvino")
    assert resolve_backend(AppearanceConfig()).backend == "openvino"
    assert resolve_backend(AppearanceConfig(device="cuda")).backend == "onnx"  # OpenVINO here runs on CPUs only
    assert resolve_backend(AppearanceConfig(backend="onnx")).backend == "onnx"  # asked for: kept
    found = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "openvino" else found(name, *a))
    assert resolve_backend(AppearanceConfig()).backend == "onnx"


def test_the_run_record_names_the_backend_that_ran(tmp_path, model_0288, capsys):
    seq = require(DATA / "MOT16-05-clip30")
    assert main(["track", str(seq), "--out", str(tmp_path), "--reid-model", str(model_0288)]) == 0
    pytest.importorskip("openvino")
    record = json.loads((tmp_path / "MOT16-05-clip30.run.json").read_text())
    assert record["config"]["appearance"]["backend"] == "openvino"
    assert "re-ID by openvino" in capsys.readouterr().err
    # on --device cuda auto takes onnxruntime; the notice says why, not to install what is installed
    main(["track", str(seq), "--out", str(tmp_path / "cuda"), "--device", "cuda"])  # fails later here: no CUDA
    err = capsys.readouterr().err
    assert "re-ID by onnx" in err and "not used on --device cuda" in err and "pip install openvino" not in err


def test_graph_and_explain_commands_run_to_the_end(tmp_path, model_0288, capsys):
    """The inspection commands as a user types them: every file written, the explanation printed."""
    seq = require(DATA / "MOT16-05-clip30")
    out = tmp_path / "graph"
    assert main(["graph", str(seq), "--out", str(out), "--reid-model", str(model_0288), "-q"]) == 0
    written = sorted(p.name for p in out.iterdir())
    assert written == ["graph.graphml", "graph.html", "graph.json", "graph.png"], written
    assert (out / "graph.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    nodes = json.loads((out / "graph.json").read_text())["nodes"]
    assert nodes and "taken by greedy" in capsys.readouterr().out
    assert main(["explain", str(seq), "--ids", "1,2", "--reid-model", str(model_0288), "-q"]) == 0
    assert "tracks 1 and 2" in capsys.readouterr().out
    assert main(["explain", str(seq), "--ids", "1", "--reid-model", str(model_0288), "-q"]) == 0
    said = capsys.readouterr().out  # one track: why its tracklets were merged, and what filled its gaps
    assert "of track 1" in said and re.search(r"^track 1( has no gap|: \d+ gap)", said, re.M), said


def test_weak_boxes_with_a_missing_detector_fail_before_tracking(tmp_path, model_0288, capsys):
    seq = require(DATA / "MOT16-05-clip30")
    assert main(["track", str(seq), "--out", str(tmp_path / "out"), "--reid-model", str(model_0288),
                 "--weak-boxes", "on", "--detector-model", str(tmp_path / "gone.xml"), "-q"]) == 2
    assert "person detector not found" in capsys.readouterr().err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_a_run_is_repeated_from_its_run_record_and_the_record_is_never_written_over(tmp_path, capsys):
    seq = require(DATA / "MOT16-02-clip30")
    (tmp_path / "c.toml").write_text("[confirm]\nthreshold = 0.7\n")
    first, again, plain = tmp_path / "first", tmp_path / "again", tmp_path / "plain"
    assert main(["track", str(seq), "--out", str(first), "--config", str(tmp_path / "c.toml"), "--extend-ends", "0",
                 "-q"]) == 0
    record = first / "MOT16-02-clip30.run.json"
    assert main(["track", str(seq), "--out", str(again), "--config", str(record), "-q"]) == 0
    assert main(["track", str(seq), "--out", str(plain), "-q"]) == 0
    results = {d: (d / "MOT16-02-clip30.txt").read_bytes() for d in (first, again, plain)}
    assert results[again] == results[first] != results[plain]  # the settings came back, and they matter here
    assert (json.loads((again / "MOT16-02-clip30.run.json").read_text())["config"]
            == json.loads(record.read_text())["config"])
    before = record.read_bytes()
    capsys.readouterr()
    assert main(["track", str(seq), "--out", str(first), "--config", str(record), "-q"]) == 2
    assert "which this run reads; choose another --out" in capsys.readouterr().err
    assert record.read_bytes() == before


def test_explain_says_it_ignores_windows_and_whose_ids_it_speaks_of(tmp_path, capsys):
    seq = require(DATA / "MOT16-02-clip30")
    (tmp_path / "w.toml").write_text("[windows]\nseconds = 30\n")  # as a windowed run's record holds it
    assert main(["explain", str(seq), "--ids", "1", "--config", str(tmp_path / "w.toml"), "-q"]) == 0
    assert "[windows] seconds = 30 is ignored here: the whole sequence is tracked at once" in capsys.readouterr().err
    assert main(["explain", str(seq), "--ids", "1", "-q"]) == 0
    assert "[windows]" not in capsys.readouterr().err


def test_explain_lists_every_track_the_least_certain_first(tmp_path, capsys):
    seq = require(DATA / "MOT16-02-clip30")
    assert main(["explain", str(seq), "--tracks", "-q"]) == 0
    out = capsys.readouterr().out
    assert "the least certain first; confirmation's threshold" in out and "median P(true)" in out
    assert main(["explain", str(seq), "--tracks", "--ids", "1", "-q"]) == 2
    assert "give one of --ids" in capsys.readouterr().err


def test_compare_with_jitter_scores_each_solver_on_moved_copies_and_judges_them_run_by_run(tmp_path, capsys):
    seq, other = require(DATA / "MOT16-05-clip30"), require(DATA / "MOT16-02-clip30")
    out = tmp_path / "cmp.json"
    assert main(["compare", str(seq), str(other), "--solvers", "greedy,flow", "--jitter", "2", "-q",
                 "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    data = json.loads(out.read_text())
    assert data["jitter"]["copies"] == 2 and data["jitter"]["pixels"] == 0.5
    runs = data["jitter"]["runs"]
    assert set(runs) == {"MOT16-05-clip30", "MOT16-02-clip30", "COMBINED"}
    for name, by_solver in runs.items():
        assert set(by_solver) == {"greedy", "flow"}
        for solver, scores in by_solver.items():
            for column in ("HOTA", "MOTA", "IDF1"):  # the sequence itself first: the table's own value
                assert len(scores[column]) == 3 and scores[column][0] == data["rows"][name][solver][column]
            # each copy holds its own sequence's boxes, moved a little (two det.txt files, one name)
            assert max(scores["HOTA"]) - min(scores["HOTA"]) < 5, (name, solver, scores["HOTA"])
    assert "over 3 runs (in 2 of them every box moved by under 0.5 px)" in printed
    assert re.search(r"flow - greedy, HOTA: [+-]\d+\.\d\d \(runs [+-]\d+\.\d\d to [+-]\d+\.\d\d: ", printed)
    assert not list(tmp_path.glob("sotmot-compare-*"))  # the copies lived in a temporary folder only
    # without --jitter: no runs in the JSON, no spread in the table
    assert main(["compare", str(seq), "--solvers", "greedy", "-q", "--json", str(tmp_path / "one.json")]) == 0
    assert "over " not in capsys.readouterr().out
    assert "jitter" not in json.loads((tmp_path / "one.json").read_text())
    with pytest.raises(SystemExit) as stop:
        main(["compare", str(seq), "--jitter", "-1"])
    assert stop.value.code == 2 and "must be at least 0" in capsys.readouterr().err


def test_jittered_runs_move_the_detections_the_run_reads(tmp_path):
    import numpy as np

    from conftest import write_sequence
    from sotmot.config import TrackerConfig
    from sotmot.inspect.compare import jitter_runs
    from sotmot.io import read_detections
    from sotmot.types import Detections

    lines = ["# sotmot detections: detector=x sha256=0 family=unknown"] + [
        f"{f},-1,{10 * f},10.5,10,20,0.9" for f in range(1, 6)]
    gt = [f"{f},1,{10 * f},10,10,20,1,1,1" for f in range(1, 6)]
    seq = write_sequence(tmp_path, lines[1:], length=5, gt_lines=gt)
    config = TrackerConfig()
    runs = jitter_runs(seq, config, 2, tmp_path / "noise")
    assert len(runs) == 2
    before = read_detections(seq / "det" / "det.txt", 5)
    files = [c.detection.file for c in runs]
    assert len(set(files)) == 2 and all(str(tmp_path / "noise") in f for f in files)
    for file in files:  # the folder's det.txt, moved by under half a pixel, by seed
        moved = read_detections(file, 5)
        assert 0 < np.abs(moved.boxes[:, :2] - before.boxes[:, :2]).max() <= 0.5
        assert np.array_equal(moved.boxes[:, 2:], before.boxes[:, 2:])
    # a detections file of its own (with sotmot's header line): that file moved, its header kept
    own = tmp_path / "own.det.txt"
    own.write_text("\n".join(lines) + "\n")
    runs = jitter_runs(seq, config.replace("detection", file=str(own)), 1, tmp_path / "own")
    text = open(runs[0].detection.file).read()
    assert text.splitlines()[0] == lines[0] and text != own.read_text()
    assert jitter_runs(seq, config, 0, tmp_path / "none") == [] and not (tmp_path / "none").exists()
    # boxes from the detector: the boxes it gave the first run, written with its header, then moved
    model = config.replace("detection", source="model")
    with pytest.raises(ValueError, match="boxes of the run on the sequence itself"):
        jitter_runs(seq, model, 1, tmp_path / "model")
    found = Detections(before.frames, before.boxes, before.scores)
    moved_config, = jitter_runs(seq, model, 1, tmp_path / "model", found)
    assert moved_config.detection.source == "file"
    text = open(moved_config.detection.file).read()
    assert text.startswith("# sotmot detections: detector=person-detection-0202") and "family=pd0202" in text
    assert 0 < np.abs(read_detections(moved_config.detection.file, 5).boxes[:, :2] - before.boxes[:, :2]).max() <= 0.5


def test_compare_with_jitter_moves_the_boxes_the_detector_found(tmp_path, capsys):
    seq = require(DATA / "MOT16-05-clip30")
    out = tmp_path / "cmp.json"
    assert main(["compare", str(seq), "--solvers", "greedy", "--detections", "model", "--jitter", "1", "-q",
                 "--json", str(out)]) == 0
    data = json.loads(out.read_text())
    hota = data["jitter"]["runs"]["MOT16-05-clip30"]["greedy"]["HOTA"]
    assert hota[0] == data["rows"]["MOT16-05-clip30"]["greedy"]["HOTA"] and abs(hota[1] - hota[0]) < 5, hota


def test_paired_verdicts_need_one_sign_in_every_run():
    from sotmot.inspect.compare import paired_verdict

    assert paired_verdict([0.4, 1.2, 0.1]) == "above in every run"
    assert paired_verdict([-0.4, -1.2]) == "below in every run"
    assert paired_verdict([0.0, 0.0]) == "equal in every run"
    assert paired_verdict([1.0, -0.2]) == paired_verdict([0.0, 0.3]) == "not told apart from chance"


def test_the_run_says_where_the_line_check_lowered_the_interpolation_bound_and_where_the_camera_moves(
        tmp_path, capsys):
    moving = require(DATA / "MOT17-labels" / "MOT17-10-SDP")  # a hand-held camera, tracked without its frames
    still, walking = require(DATA / "TUD-Stadtmitte"), require(DATA / "MOT16-05-clip30")
    said = {}
    for seq in (moving, still, walking):
        assert main(["track", str(seq), "--appearance", "none", "--out", str(tmp_path / seq.name)]) == 0
        printed = capsys.readouterr()
        said[seq.name] = printed.out + printed.err
    record = json.loads((tmp_path / "MOT17-10-SDP" / "MOT17-10-SDP.run.json").read_text())
    assert record["line_check"] == {"interpolate_max_seconds": 1.5}
    assert "gaps filled up to 1.5 s: the straight line did not hold over 2 s here" in said["MOT17-10-SDP"]
    assert "line_check" not in json.loads((tmp_path / "TUD-Stadtmitte" / "TUD-Stadtmitte.run.json").read_text())
    assert re.search(r"the camera moves \(\d+\.\d px a frame at the median\), compensated", said["MOT16-05-clip30"])
    assert "camera" not in said["TUD-Stadtmitte"] + said["MOT17-10-SDP"]
    # what the run found, not a setting: --resume does not track again for it
    assert main(["track", str(moving), "--appearance", "none", "--out", str(tmp_path / "MOT17-10-SDP"),
                 "--resume"]) == 0
    printed = capsys.readouterr()
    assert "skipped (--resume)" in printed.out + printed.err
