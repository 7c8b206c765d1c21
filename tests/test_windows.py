"""Committed time windows (issue #45): identities across window joins, the gap rule across an overlap, the
same results as the whole sequence where there is one window, in parallel as in series, and after a kill."""

from __future__ import annotations

import json

import pytest

from sotmot.cli import main
from sotmot.config import TrackerConfig
from sotmot.errors import ConfigError
from sotmot.windows import cut, plan

from conftest import DATA, require, stopped_at_window, write_sequence

RATE = 5  # frames per second of the synthetic sequences: the 4-s gap is 20 frames, windows of 8 s are 40


def _walkers(tmp_path, gaps: dict[int, tuple[int, int]] | None = None, length: int = 120, rate: float = RATE):
    """Two people walking the whole sequence in opposite directions, 60 px apart (3 px a frame at ``rate``);
    ``gaps``: person -> frames (first, last) where the detector misses them."""
    lines = []
    for f in range(1, length + 1):
        for person, (x0, dx, y) in enumerate(((10, 3.0 * RATE / rate, 20), (400, -3.0 * RATE / rate, 120))):
            first, last = (gaps or {}).get(person, (0, -1))
            if not first <= f <= last:
                lines.append(f"{f},-1,{x0 + dx * f:.2f},{y},30,60,0.9")
    return write_sequence(tmp_path, lines, length=length, frame_rate=rate, width=800, height=240, images=False)


def _track(seq, out, *extra) -> list[str]:
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--unconfirmed", "keep", "-q",
                 *extra]) == 0
    return (out / "SYN.txt").read_text().splitlines()


def _ids(lines: list[str]) -> set[str]:
    return {line.split(",")[1] for line in lines}


def test_the_plan_overlaps_by_the_gap_and_cuts_in_the_middle():
    config = TrackerConfig().replace("windows", seconds=8)
    windows = plan(120, RATE, config)
    assert windows == [(1, 40), (21, 60), (41, 80), (61, 100), (81, 120)]
    assert [cut(windows, k) for k in range(len(windows))] == [1, 31, 51, 71, 91]
    assert plan(30, RATE, config) == [(1, 30)]  # no longer than one window: the whole sequence
    with pytest.raises(ConfigError, match="less than twice the overlap"):
        plan(120, RATE, TrackerConfig().replace("windows", seconds=6))


def test_walkers_crossing_window_joins_keep_their_ids(tmp_path):
    seq = _walkers(tmp_path)
    whole = _track(seq, tmp_path / "whole")
    windowed = _track(seq, tmp_path / "win", "--window", "8")
    assert len(_ids(whole)) == len(_ids(windowed)) == 2
    assert windowed == whole  # the same boxes, the same ids
    record = json.loads((tmp_path / "win" / "SYN.run.json").read_text())
    assert len(record["windows"]["plan"]) == 5 and record["windows"]["complete"] is True
    assert [j["joined"] for j in record["windows"]["joins"]] == [2, 2, 2, 2]


@pytest.mark.parametrize("gap_frames, people", [(15, 2), (30, 3)])
def test_a_person_unseen_across_an_overlap_is_joined_only_when_the_gap_rule_allows(tmp_path, gap_frames, people):
    # person 0 missed around the cut of windows 1 and 2 (frame 31): 15 frames (3 s, within the 4-s gap) or 30
    gaps = {0: (31 - gap_frames // 2, 30 + (gap_frames + 1) // 2)}
    seq = _walkers(tmp_path, gaps)
    whole = _track(seq, tmp_path / "whole")
    windowed = _track(seq, tmp_path / "win", "--window", "8")
    assert len(_ids(whole)) == len(_ids(windowed)) == people


def test_a_clip_shorter_than_one_window_gives_the_whole_sequence_run(tmp_path):
    seq = require(DATA / "MOT16-02-clip30")
    assert main(["track", str(seq), "--out", str(tmp_path / "a"), "-q"]) == 0
    assert main(["track", str(seq), "--out", str(tmp_path / "b"), "--window", "10", "-q"]) == 0
    name = "MOT16-02-clip30.txt"
    assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()


@pytest.mark.slow
def test_windows_in_two_processes_equal_the_serial_run(tmp_path):
    seq = _walkers(tmp_path, {0: (50, 58)}, length=200)
    serial = _track(seq, tmp_path / "serial", "--window", "8")
    parallel = _track(seq, tmp_path / "parallel", "--window", "8", "--workers", "2")
    assert parallel == serial
    for name in ("SYN.flags.csv",):
        assert (tmp_path / "parallel" / name).read_bytes() == (tmp_path / "serial" / name).read_bytes()


def test_a_killed_run_resumes_after_its_last_window_with_the_same_results(tmp_path):
    seq = _walkers(tmp_path, {1: (64, 70)})
    reference = _track(seq, tmp_path / "ref", "--window", "8")
    out = tmp_path / "run"
    with stopped_at_window(2):  # as a kill would stop it: between two windows
        assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--unconfirmed", "keep", "-q",
                     "--window", "8"]) == 130  # "sotmot: interrupted"
    record = json.loads((out / "SYN.run.json").read_text())
    assert record["windows"]["complete"] is False and record["windows"]["done"] == 2
    committed = (out / "SYN.txt").read_text().splitlines()
    assert committed == [line for line in reference if int(line.split(",")[0]) < cut(plan(120, RATE, TrackerConfig(
        ).replace("windows", seconds=8)), 2)]  # the frames the first two windows own, final already
    with open(out / "SYN.txt", "a") as fh:  # a line appended after the record was written is made again
        fh.write("99,1,1,1,1,1,0.5,-1,-1,-1\n")
    resumed = _track(seq, out, "--window", "8", "--resume")
    assert resumed == reference
    assert json.loads((out / "SYN.run.json").read_text())["windows"]["complete"] is True


def test_a_run_in_windows_at_a_step_resumes_in_processes_to_the_uninterrupted_results(tmp_path):
    # 10 fps at step 2: 120 tracked frames at 5 fps in the five windows above. The box of frame 100, between the
    # last tracked frame the interrupted run committed (99) and the next (101), comes from its run record.
    seq = _walkers(tmp_path, {1: (128, 140)}, length=240, rate=2 * RATE)
    reference = _track(seq, tmp_path / "ref", "--window", "8", "--step", "2")
    # both people on every frame (the last, 240, after the last tracked one, holding 239's boxes), the 1.3-s miss
    # bridged and filled
    assert len(reference) == 2 * 240 and _ids(reference) == {"1", "2"}
    out = tmp_path / "run"
    with stopped_at_window(2):
        assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--unconfirmed", "keep", "-q",
                     "--window", "8", "--step", "2"]) == 130
    record = json.loads((out / "SYN.run.json").read_text())
    assert record["windows"]["done"] == 2 and record["windows"]["plan"] == [[1, 40], [21, 60], [41, 80], [61, 100],
                                                                            [81, 120]]
    committed = (out / "SYN.txt").read_text().splitlines()
    assert committed == [line for line in reference if int(line.split(",")[0]) <= 1 + (50 - 1) * 2]
    assert _track(seq, out, "--window", "8", "--step", "2", "--resume", "--workers", "2") == reference


def test_the_api_tracks_in_windows_as_the_command_line_does(tmp_path):
    import sotmot

    seq = _walkers(tmp_path, {0: (50, 58)})
    cli = _track(seq, tmp_path / "cli", "--window", "8")
    config = {"windows": {"seconds": 8}, "appearance": {"backend": "none"}, "confirm": {"enabled": False}}
    result = sotmot.track(seq, config=config)
    assert result.save(tmp_path / "api.txt").read_text().splitlines() == cli


def test_a_window_that_fails_keeps_what_was_committed_and_says_so(tmp_path, monkeypatch, capsys):
    import sotmot.windows as windows
    from sotmot.errors import InputError

    seq = _walkers(tmp_path)
    real = windows.track_window

    def fails_at_three(info, plan_, k, *args, **kwargs):
        if k == 3:
            raise InputError(info.path, "frame 62 cannot be decoded")
        return real(info, plan_, k, *args, **kwargs)

    monkeypatch.setattr(windows, "track_window", fails_at_three)
    out = tmp_path / "run"
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--unconfirmed", "keep", "-q",
                 "--window", "8"]) == 2
    err = capsys.readouterr().err
    assert "windows 1-3 of 5 are committed" in err and "what was committed before the failure is kept" in err
    assert (out / "SYN.txt").read_text().strip()
    monkeypatch.setattr(windows, "track_window", real)
    assert _track(seq, out, "--window", "8", "--resume") == _track(seq, tmp_path / "ref", "--window", "8")


def test_switches_at_joins_are_those_in_an_overlap_or_the_frame_after(tmp_path):
    # scripts/bench_long.py reports how many ID switches the joins made (issue #45)
    from helpers import load_script

    script = load_script("bench_long")
    gt, results = tmp_path / "gt.txt", tmp_path / "res.txt"
    gt.write_text("".join(f"{f},1,10,10,40,80,1,1,1\n" for f in range(1, 21)))
    # the person's track changes id at frame 11
    results.write_text("".join(f"{f},{1 if f <= 10 else 2},10,10,40,80,1,-1,-1,-1\n" for f in range(1, 21)))
    assert script.join_switches(results, gt, 20, "SYN", [(1, 12), (8, 20)]) == 1  # overlap 8-12
    assert script.join_switches(results, gt, 20, "SYN", [(1, 10), (7, 20)]) == 1  # the frame after the overlap
    assert script.join_switches(results, gt, 20, "SYN", [(1, 6), (4, 16), (14, 20)]) == 0  # away from both joins
    assert script.join_switches(results, gt, 20, "SYN", [(1, 20)]) == 0  # one window: no join


def test_a_run_killed_hard_mid_video_resumes_to_the_uninterrupted_results(tmp_path):
    """SIGKILL (no handler runs, nothing is tidied) while the windows are being committed: what is on disk is a
    whole number of windows and a record that says so, and --resume ends with the results of an uninterrupted run.
    The child sleeps before committing each window after the first, so the kill lands while the video is half
    done."""
    import os
    import signal
    import subprocess
    import sys
    import time

    seq = _walkers(tmp_path, {1: (64, 70)})
    reference = _track(seq, tmp_path / "ref", "--window", "8")
    slow = tmp_path / "slow"
    slow.mkdir()
    (slow / "sitecustomize.py").write_text(
        "import time\nimport sotmot.windows as w\nadd = w.Stitcher.add\n"
        "def slowly(self, k, result):\n    if k:\n        time.sleep(0.5)\n    return add(self, k, result)\n"
        "w.Stitcher.add = slowly\n")
    out = tmp_path / "run"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(slow), *sys.path])}
    child = subprocess.Popen([sys.executable, "-m", "sotmot", "track", str(seq), "--out", str(out), "--appearance",
                              "none", "--unconfirmed", "keep", "-q", "--window", "8"], env=env)
    record = out / "SYN.run.json"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and child.poll() is None:
        done = json.loads(record.read_text())["windows"]["done"] if record.exists() else 0
        if done >= 2:
            break
        time.sleep(0.02)
    assert child.poll() is None, "the run ended before it could be killed"
    os.kill(child.pid, signal.SIGKILL)
    child.wait(timeout=30)
    state = json.loads(record.read_text())["windows"]
    assert state["complete"] is False and 2 <= state["done"] < len(state["plan"])
    committed = (out / "SYN.txt").read_text().splitlines()
    assert committed == reference[:len(committed)]  # whole lines of the final results, nothing half-written
    assert _track(seq, out, "--window", "8", "--resume") == reference
    assert json.loads(record.read_text())["windows"]["complete"] is True
