"""Regression tests of issue #22: never destroy what the user owns, no run that lies or lingers, checks made
before the work. Each test names the item of the issue it pins; each failed on main before its fix."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from conftest import GeometryEmbedder, write_sequence, write_video
from sotmot.cli import main
from sotmot.config import TrackerConfig, load_config
from sotmot.errors import ConfigError, InputError
from sotmot.io import read_results, read_seqinfo, write_results
from sotmot.types import Tracks


def _tree(folder):
    """Every file below ``folder`` with its bytes."""
    return {p.relative_to(folder): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _sequence_and_results(tmp_path):
    seq = write_sequence(tmp_path / "data", ["1,-1,5,5,10,20,1"], length=3, width=96, height=64)
    results = tmp_path / "r.txt"
    write_results(results, Tracks(frames=[1], ids=[7], boxes=[[20, 20, 30, 30]], scores=[1]))
    return seq, results


# 1. render's folder swap deleted the folder it was pointed at ------------------------------------------------

def test_render_into_a_folder_of_other_files_is_refused_and_the_folder_kept(tmp_path, capsys):
    seq, results = _sequence_and_results(tmp_path)
    mine = tmp_path / "mine"
    (mine / "sub").mkdir(parents=True)
    (mine / "notes.txt").write_text("keep me")
    (mine / "sub" / "photo.jpg").write_bytes(b"\xff\xd8 not really")
    before = _tree(mine)
    assert main(["render", str(seq), str(results), "--out", str(mine), "-q"]) == 2
    assert "holds other files" in capsys.readouterr().err
    assert _tree(mine) == before


def test_render_into_the_folder_above_the_sequence_is_refused_and_the_sequence_kept(tmp_path, capsys):
    seq, results = _sequence_and_results(tmp_path)
    before = _tree(seq)
    assert main(["render", str(seq), str(results), "--out", str(seq.parent), "-q"]) == 2
    assert "holds the sequence folder" in capsys.readouterr().err
    assert _tree(seq) == before


def test_render_writes_into_an_earlier_render_file_by_file(tmp_path):
    seq, results = _sequence_and_results(tmp_path)
    out = tmp_path / "frames"
    assert main(["render", str(seq), str(results), "--out", str(out), "-q"]) == 0
    inode = out.stat().st_ino
    assert main(["render", str(seq), str(results), "--out", str(out), "-q"]) == 0
    assert out.stat().st_ino == inode  # the same folder, written into; not replaced
    assert sorted(p.name for p in out.iterdir()) == ["000001.jpg", "000002.jpg", "000003.jpg"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


# 2. render over its own input video ---------------------------------------------------------------------------

def test_render_refuses_to_write_over_its_input_video_results_or_flags(tmp_path, capsys):
    video = write_video(tmp_path / "clip.avi")
    results = tmp_path / "r.txt"
    write_results(results, Tracks(frames=[1], ids=[7], boxes=[[20, 20, 30, 30]], scores=[1]))
    before = video.read_bytes()
    assert main(["render", str(video), str(results), "--out", str(video), "-q"]) == 2
    assert "which this run reads" in capsys.readouterr().err
    assert video.read_bytes() == before
    seq, results = _sequence_and_results(tmp_path / "s")
    avi = results.with_suffix(".avi")
    avi.write_bytes(b"results kept in an odd name")
    assert main(["render", str(seq), str(avi), "--out", str(avi), "-q"]) == 2
    assert avi.read_bytes() == b"results kept in an odd name"


# 3. results over the detections -------------------------------------------------------------------------------

def test_track_video_refuses_results_over_its_detections(tmp_path, capsys):
    video = write_video(tmp_path / "street.avi")
    det = tmp_path / "street.txt"
    det.write_text("1,-1,10,20,20,40,0.9\n")
    assert main(["track", str(video), "--det", str(det), "--out", str(tmp_path), "-q"]) == 2
    assert "which this run reads" in capsys.readouterr().err
    assert det.read_text() == "1,-1,10,20,20,40,0.9\n"


def test_a_sequence_named_det_is_not_written_over_its_own_detections(tmp_path):
    from sotmot.runs import track_one

    lines = [f"{f},-1,{10 + 2 * f},20,20,40,0.95" for f in range(1, 9)]
    seq = write_sequence(tmp_path, lines, length=10, frame_rate=4, width=120, height=80, name="det")
    before = (seq / "det" / "det.txt").read_text()
    outcome = track_one(str(seq), str(seq / "det"), TrackerConfig(), False, embedder=GeometryEmbedder())
    assert outcome.status == "failed" and "which this run reads" in outcome.message
    assert (seq / "det" / "det.txt").read_text() == before
    assert sorted(p.name for p in (seq / "det").iterdir()) == ["det.txt"]


# 4. --resume that skipped a changed model or a damaged results file -------------------------------------------

def test_the_model_from_the_environment_is_recorded_and_a_change_reruns(tmp_path, monkeypatch):
    from sotmot.runs import resolve_paths
    from sotmot.provenance import run_record, why_rerun, write_record

    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False)
    a, b = tmp_path / "a.onnx", tmp_path / "b.onnx"
    a.write_bytes(b"model a")
    b.write_bytes(b"model b")
    info = read_seqinfo(seq)
    results = tmp_path / "out" / "SYN.txt"
    write_results(results, Tracks(frames=[1], ids=[1], boxes=[[10, 10, 5, 8]], scores=[1]))
    monkeypatch.setenv("SOTMOT_REID_MODEL", str(a))
    record = run_record(info, resolve_paths(TrackerConfig()))
    assert record["reid_model"]["path"] == str(a.resolve()) and record["reid_model"]["sha256"]
    record["results_sha256"] = __import__("hashlib").sha256(results.read_bytes()).hexdigest()
    write_record(results, record)
    assert why_rerun(results, run_record(info, resolve_paths(TrackerConfig()))) is None
    monkeypatch.setenv("SOTMOT_REID_MODEL", str(b))
    assert "reid_model.sha256" in why_rerun(results, run_record(info, resolve_paths(TrackerConfig())))


@pytest.mark.parametrize("damage", ["emptied", "cut"])
def test_resume_reruns_a_results_file_that_was_emptied_or_cut(tmp_path, damage):
    from sotmot.runs import track_one

    lines = [f"{f},-1,{10 + 2 * f},20,20,40,0.95" for f in range(1, 9)]
    seq = write_sequence(tmp_path, lines, length=10, frame_rate=4, width=120, height=80)
    out = tmp_path / "out"
    assert track_one(str(seq), str(out), TrackerConfig(), True, embedder=GeometryEmbedder()).status == "done"
    whole = (out / "SYN.txt").read_text()
    assert track_one(str(seq), str(out), TrackerConfig(), True,
                     embedder=GeometryEmbedder()).status == "skipped"
    (out / "SYN.txt").write_text("" if damage == "emptied" else "".join(whole.splitlines(True)[:-2]))
    again = track_one(str(seq), str(out), TrackerConfig(), True, embedder=GeometryEmbedder())
    assert again.status == "done" and "changed since it was written" in again.message
    assert (out / "SYN.txt").read_text() == whole


# 5. --workers 1000000 ----------------------------------------------------------------------------------------

def test_workers_are_capped_by_sequences_and_cpus():
    from sotmot.runs import usable_workers

    assert usable_workers(1_000_000, 2) == min(2, os.cpu_count() or 1)
    assert usable_workers(6, 2) <= 2
    assert usable_workers(3, 100) == min(3, os.cpu_count() or 1)
    assert usable_workers(1, 0) == 1


# 6. workers outliving their parent ----------------------------------------------------------------------------

def test_a_worker_dies_with_its_parent(tmp_path):
    script = textwrap.dedent("""
        import multiprocessing, sys, time
        from sotmot.runs import _die_with_parent

        def child():
            _die_with_parent()
            time.sleep(60)

        if __name__ == "__main__":
            p = multiprocessing.get_context("fork").Process(target=child)
            p.start()
            print(p.pid, flush=True)
            time.sleep(60)
    """)
    (tmp_path / "parent.py").write_text(script)
    parent = subprocess.Popen([sys.executable, str(tmp_path / "parent.py")], stdout=subprocess.PIPE, text=True)
    try:
        child = int(parent.stdout.readline())
        time.sleep(0.5)
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(5)
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and _alive(child):
            time.sleep(0.1)
        assert not _alive(child), "the worker outlived its killed parent"
    finally:
        parent.kill()


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(") ")[-1][0] != "Z"  # a zombie has ended
    except FileNotFoundError:
        return False


# 7. SIGTERM during track VIDEO left the decoded frames ---------------------------------------------------------

def test_sigterm_cleans_the_temporary_frames_of_a_video(tmp_path, monkeypatch, capsys):
    import tempfile

    from sotmot.cli import commands as cli

    video = write_video(tmp_path / "street.avi")
    det = tmp_path / "d.txt"
    det.write_text("1,-1,10,20,20,40,0.9\n")
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))
    seen = []

    def terminated_while_tracking(args, config, seq_dirs):
        seen.extend(seq_dirs)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5)
        return 0

    monkeypatch.setattr(cli, "_track", terminated_while_tracking)
    previous = signal.getsignal(signal.SIGTERM)
    try:
        assert main(["track", str(video), "--det", str(det), "--out", str(tmp_path / "out"), "-q"]) == 143
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert seen and "terminated" in capsys.readouterr().err
    assert list(scratch.iterdir()) == []


def test_ctrl_c_after_failed_runs_is_an_interrupt_not_a_crash(tmp_path):
    """Two runs that fail mid-way (a frame that is None), their OpenVINO models held by the exceptions until a
    garbage collection, then Ctrl-C: a KeyboardInterrupt. Before the compiled models were kept for the process
    (sotmot.models.openvino_compiled), OpenVINO's CPU plugin left the thread's alternate signal stack on freed
    memory and the signal crashed the process (seen on a Xeon with AMX; other CPUs passed either way)."""
    script = textwrap.dedent("""
        import gc, os, signal, time
        import numpy as np
        import sotmot
        signal.signal(signal.SIGINT, signal.default_int_handler)  # also where SIGINT came ignored (a background job)
        frames = [np.full((48, 64, 3), 128, np.uint8)] * 19 + [None]
        det = np.array([[1, 10, 10, 10, 20, 0.9], [20, 10, 10, 10, 20, 0.9]])
        failed = []
        for _ in range(2):
            try:
                sotmot.track(frames, det, frame_rate=30, config={"appearance": {"backend": "openvino"}})
            except sotmot.errors.InputError as exc:
                failed.append(exc)
        failed.clear()
        gc.collect()
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5)
        except KeyboardInterrupt:
            print("interrupted after", 2, "failed runs")
    """)
    (tmp_path / "interrupt.py").write_text(script)
    run = subprocess.run([sys.executable, str(tmp_path / "interrupt.py")], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0 and "interrupted after 2 failed runs" in run.stdout, (run.returncode, run.stderr[-2000:])


# 8. a truncated video, an absurd frame rate -------------------------------------------------------------------

def test_a_truncated_video_is_tracked_with_a_warning(tmp_path, caplog):
    from sotmot.io import FrameReader

    whole = write_video(tmp_path / "whole.avi", n=30)
    cut = tmp_path / "cut.avi"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    with caplog.at_level("WARNING"):
        info = read_seqinfo(cut)
    length = info.length
    assert 0 < length < 30
    reader = FrameReader(info, cache_size=1)
    assert reader(length).shape == (info.height, info.width, 3)  # the last frame counted decodes
    with pytest.raises(InputError, match=f"outside the video's frames 1..{length}"):
        reader(length + 1)
    assert any("announces 30 frames" in r.getMessage() and "truncated" in r.getMessage() for r in caplog.records)


def test_an_absurd_frame_rate_is_refused(tmp_path, capsys):
    video = write_video(tmp_path / "street.avi")
    det = tmp_path / "d.txt"
    det.write_text("1,-1,10,20,20,40,0.9\n")
    # the configuration's check, the one statement of the bound, named by the flag
    assert main(["track", str(video), "--det", str(det), "--out", str(tmp_path / "out"), "--fps", "10000"]) == 2
    assert "--fps 10000: [input] fps must be a frame rate above 0 and at most 240" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
    with pytest.raises(InputError, match="above 240"):
        read_seqinfo(write_video(tmp_path / "fast.avi", fps=10000.0))
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False, frame_rate=10000)
    with pytest.raises(InputError, match="frameRate='10000'.*above 240") as err:
        read_seqinfo(seq)
    assert err.value.line == 4


# 9. outputs checked after the work -----------------------------------------------------------------------------

def test_graph_out_that_is_a_file_fails_before_tracking(tmp_path, monkeypatch, capsys):
    from sotmot.cli import commands as cli

    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False)
    (tmp_path / "taken").write_text("x")
    monkeypatch.setattr(cli, "_track_for_inspection", lambda args: pytest.fail("tracked before checking --out"))
    assert main(["graph", str(seq), "--out", str(tmp_path / "taken"), "-q"]) == 2
    assert "--out must be a folder" in capsys.readouterr().err
    assert (tmp_path / "taken").read_text() == "x"


def test_graph_files_are_written_all_or_none(tmp_path, monkeypatch):
    import sotmot.io.files as io_files
    from sotmot.io import write_files_atomic

    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "graph.json").write_text("old")
    real = os.fsync
    calls = []

    def full_disk(fd):
        calls.append(fd)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        real(fd)

    monkeypatch.setattr(io_files.os, "fsync", full_disk)
    files = {tmp_path / "out" / name: b"new" for name in ("graph.graphml", "graph.json", "graph.png", "graph.html")}
    with pytest.raises(OSError):
        write_files_atomic(files)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["graph.json"]
    assert (tmp_path / "out" / "graph.json").read_text() == "old"


def test_render_out_below_a_file_is_an_error_not_a_traceback(tmp_path, capsys):
    seq, results = _sequence_and_results(tmp_path)
    (tmp_path / "taken").write_text("x")
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "taken" / "frames"), "-q"]) == 2
    assert "--out must be a folder" in capsys.readouterr().err


# 10. eval of ids TrackEval cannot take ------------------------------------------------------------------------

@pytest.mark.parametrize("bad_id", ["-7", "0", "1e20", "2.5"])
def test_results_with_an_impossible_id_are_refused_with_file_and_line(tmp_path, bad_id):
    path = tmp_path / "r.txt"
    path.write_text(f"1,1,10,10,5,8,1,-1,-1,-1\n2,{bad_id},10,10,5,8,1,-1,-1,-1\n")
    with pytest.raises(InputError, match="id .* must be an integer from 1 to") as err:
        read_results(path, 5)
    assert err.value.line == 2


# 11. arguments that select nothing ----------------------------------------------------------------------------

@pytest.mark.parametrize("solvers", ["", ",", "greedy,greedy", "greedy,"])
def test_compare_refuses_an_empty_or_repeated_solver_list(tmp_path, solvers, capsys, monkeypatch):
    from sotmot.inspect import compare

    monkeypatch.setattr(compare, "compare", lambda *a, **k: pytest.fail("compared with a bad solver list"))
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False)
    assert main(["compare", str(seq), "--solvers", solvers, "-q"]) == 2
    assert "--solvers" in capsys.readouterr().err


def test_explain_refuses_one_id_twice_and_graph_frames_past_the_end(tmp_path, capsys, monkeypatch):
    from sotmot.cli import commands as cli

    monkeypatch.setattr(cli, "_track_for_inspection", lambda args: pytest.fail("tracked with bad arguments"))
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], length=30, images=False)
    assert main(["explain", str(seq), "--tracklets", "1,1", "-q"]) == 2
    assert "two different tracklet ids" in capsys.readouterr().err
    assert main(["explain", str(seq), "--ids", "1,2,3", "-q"]) == 2
    assert "--ids needs two track ids (or one track)" in capsys.readouterr().err
    assert main(["graph", str(seq), "--out", str(tmp_path / "g"), "--frames", "40:50", "-q"]) == 2
    assert "frames 1 to 30 only" in capsys.readouterr().err
    assert not (tmp_path / "g").exists()


# 12. config values that overflow, allocate or run for minutes; duplicate JSON keys ---------------------------

@pytest.mark.parametrize("text", ["[postprocess]\ninterpolate_max_seconds = 1e308\n",
                                  "[sot]\nscales = [1e-9]\n",
                                  "[sot]\nrerank = 1000000000\n",
                                  "[sot]\nsearch_radius = 1e9\n",
                                  "[appearance]\nbatch_size = 100000000\n",
                                  "[tracklets]\nbatch_seconds = 1e9\n",
                                  "[postprocess]\nsmooth_window = 1000000000\n"])
def test_config_values_out_of_bounds_are_refused_at_load_time(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=str(path)):
        load_config(path)


def test_duplicate_json_keys_are_refused(tmp_path):
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"sot": {}}).replace("{}", '{"L": 10, "L": 20}'))
    with pytest.raises(ConfigError, match="'L' is given twice"):
        load_config(path)
    path.write_text('{"sot": {"L": 10}, "sot": {"L": 20}}')
    with pytest.raises(ConfigError, match="'sot' is given twice"):
        load_config(path)


# 13. --eval without ground truth -----------------------------------------------------------------------------

def test_eval_without_ground_truth_is_refused_before_tracking(tmp_path, capsys, monkeypatch):
    from sotmot import runs as batch

    monkeypatch.setattr(batch, "track_many", lambda *a, **k: pytest.fail("tracked before checking --eval"))
    gt = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], name="A", images=False, gt_lines=["1,1,10,10,5,8,1,1,1"])
    nogt = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], name="B", images=False)
    assert main(["track", str(gt), str(nogt), "--out", str(tmp_path / "out"), "--eval", "-q"]) == 2
    err = capsys.readouterr().err
    assert "--eval needs the ground truth of B" in err and str(nogt / "gt" / "gt.txt") in err
    video = write_video(tmp_path / "street.avi")
    det = tmp_path / "d.txt"
    det.write_text("1,-1,10,20,20,40,0.9\n")
    assert main(["track", str(video), "--det", str(det), "--out", str(tmp_path / "out"), "--eval", "-q"]) == 2
    err = capsys.readouterr().err
    assert "a video has none" in err and "sotmot-video-" not in err


def test_json_reports_never_land_on_an_input_and_are_checked_before_the_work(tmp_path, capsys, monkeypatch):
    from sotmot import scoring
    from sotmot.inspect import compare

    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False, gt_lines=["1,1,10,10,5,8,1,1,1"])
    results = tmp_path / "res"
    results.mkdir()
    (results / "SYN.txt").write_text("1,1,10,10,5,8,1,-1,-1,-1\n")
    before = (seq / "gt" / "gt.txt").read_text()
    monkeypatch.setattr(scoring, "evaluate", lambda *a, **k: pytest.fail("scored before checking --json"))
    monkeypatch.setattr(compare, "compare", lambda *a, **k: pytest.fail("compared before checking --json"))
    for target in (seq / "gt" / "gt.txt", results / "SYN.txt"):
        assert main(["eval", str(results), str(seq), "--json", str(target)]) == 2
        assert "which this run reads" in capsys.readouterr().err
    assert main(["compare", str(seq), "--json", str(seq / "det" / "det.txt"), "-q"]) == 2
    assert "which this run reads" in capsys.readouterr().err
    assert (seq / "gt" / "gt.txt").read_text() == before


def test_train_appearance_never_writes_its_checkpoint_over_the_model_it_starts_from(tmp_path, capsys):
    model = tmp_path / "model.onnx"
    model.write_bytes(b"the user's model")
    seq = write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False, gt_lines=["1,1,10,10,5,8,1,1,1"])
    assert main(["train-appearance", str(seq), "--init", str(model), "--out", str(model), "-q"]) == 2
    assert "which this run reads" in capsys.readouterr().err
    assert model.read_bytes() == b"the user's model"
