"""``[input] step`` (``sotmot track --step K``): every k-th frame tracked as a sequence of its own at the frame
rate divided by k, the tracks' boxes put back on every frame on the line between the tracked frames around them.

The tracked frames' boxes are those of a copy of the sequence made of its every k-th frame (the validation set's
rate copies, ``sotmot.benchmarks.subsampled_sequence``), box for box; the frames between are filled by hand-checked
lines; a stream with a step gives, part by part, the frames it read, and a file in windows what a copy of its
every k-th frame gives in the same windows; the runs that cannot take a step say so."""

from __future__ import annotations

import json

import numpy as np
import pytest

import sotmot
from sotmot.config import TrackerConfig, config_from_dict
from sotmot.errors import ConfigError
from sotmot.stepping import Densifier, stepped_detections, tracked_count
from sotmot.types import Detections, Tracks

from conftest import DATA, require

CLIP = DATA / "MOT16-02-clip30"


def _tracks(rows: list[tuple[int, int, float, float]], sot: tuple[int, ...] = ()) -> Tracks:
    """Tracks of ``(frame, id, x, score)`` rows, boxes ``x, 10, 20, 40``; ``sot``: rows found by SOT."""
    frames, ids, xs, scores = (np.array(c) for c in zip(*rows))
    return Tracks(frames, ids, np.column_stack([xs, np.full(len(xs), 10.0), np.full(len(xs), 20.0),
                                                np.full(len(xs), 40.0)]), scores,
                  from_sot=[k in sot for k in range(len(rows))])


def _rows(tracks: Tracks) -> list[tuple]:
    return [(int(f), int(i), float(b[0]), float(s), bool(n)) for f, i, b, s, n in
            zip(tracks.frames, tracks.ids, tracks.boxes, tracks.scores, tracks.interpolated)]


def test_the_frames_between_tracked_ones_are_on_the_line_between_them():
    # step 3: tracked frames 1, 2, 3 are frames 1, 4, 7. Track 1 at all three, moving 30 px a tracked frame;
    # track 2 at tracked frames 1 and 3 only (a gap the run left open) gets nothing between them.
    stepped = _tracks([(1, 1, 0.0, 0.9), (2, 1, 30.0, 0.6), (3, 1, 60.0, 0.8), (1, 2, 100.0, 0.9),
                       (3, 2, 100.0, 0.7)], sot=(1,))
    dense = Densifier(3).add(stepped, 3)
    assert _rows(dense.subset(dense.ids == 1)) == [
        (1, 1, 0.0, 0.9, False), (2, 1, 10.0, 0.6, True), (3, 1, 20.0, 0.6, True), (4, 1, 30.0, 0.6, False),
        (5, 1, 40.0, 0.6, True), (6, 1, 50.0, 0.6, True), (7, 1, 60.0, 0.8, False)]
    assert _rows(dense.subset(dense.ids == 2)) == [(1, 2, 100.0, 0.9, False), (7, 2, 100.0, 0.7, False)]
    assert dense.frames[dense.from_sot].tolist() == [4]  # SOT's box stays SOT's; the lines are not
    assert dense.ids.tolist() == [1] * 7 + [2] * 2  # by track, then frame, as a run's tracks are


def test_parts_put_back_one_by_one_give_what_the_whole_gives():
    stepped = _tracks([(1, 1, 0.0, 0.9), (2, 1, 30.0, 0.6), (3, 1, 60.0, 0.8), (4, 1, 60.0, 0.8),
                       (2, 2, 5.0, 0.5), (3, 2, 8.0, 0.5)])
    whole = Densifier(2).add(stepped, 4)
    parts = Densifier(2)
    # the first part ends at tracked frame 2 (frame 3); the second fills frame 4 from the first part's frame 3
    pieces = [parts.add(stepped.subset(stepped.frames <= 2), 2), parts.add(stepped.subset(stepped.frames > 2), 4)]
    assert pieces[0].frames.max() == 3 and pieces[1].frames.min() == 4
    assert sorted(_rows(Tracks.concatenate(pieces))) == sorted(_rows(whole))


def test_the_tracked_frames_detections_are_kept_and_renumbered():
    d = Detections(np.array([1, 2, 3, 4, 7, 8]), np.ones((6, 4)), np.arange(6) / 10)
    kept = stepped_detections(d, 3)
    assert kept.frames.tolist() == [1, 2, 3] and kept.scores.tolist() == [0.0, 0.3, 0.4]
    assert [tracked_count(n, 3) for n in (0, 1, 3, 4, 7)] == [0, 1, 1, 2, 3]


@pytest.mark.parametrize("value", [0, 11, 1.5, True, "2"])
def test_a_step_that_is_not_a_whole_number_of_frames_is_refused(value):
    with pytest.raises(ConfigError, match=r"\[input\] step"):
        config_from_dict({"input": {"step": value}})


def test_a_stepped_run_tracks_what_a_copy_of_every_kth_frame_tracks_and_fills_the_rest(tmp_path):
    from sotmot.benchmarks import subsampled_sequence

    seq = require(CLIP)
    copy = subsampled_sequence(seq, 3, tmp_path / "copies")
    alone = sotmot.track(copy).tracks  # the copy's frames 1..10 are the clip's 1, 4, ..., 28
    stepped = sotmot.track(seq, config={"input": {"step": 3}})
    assert stepped.info.length == 30 and len(alone) > 50
    tracked = stepped.tracks.subset((stepped.tracks.frames - 1) % 3 == 0)
    assert np.array_equal((tracked.frames - 1) // 3 + 1, alone.frames)
    for a, b in ((tracked.ids, alone.ids), (tracked.boxes, alone.boxes), (tracked.scores, alone.scores)):
        assert np.array_equal(a, b)
    between = stepped.tracks.subset((stepped.tracks.frames - 1) % 3 != 0)
    assert len(between) and between.interpolated.all() and not tracked.interpolated.any()
    # the frames after the last tracked one (29, 30) hold its boxes, flagged filled (issue #89: they had none)
    after = stepped.tracks.subset(stepped.tracks.frames > 28)
    at_28 = stepped.tracks.subset(stepped.tracks.frames == 28)
    assert set(after.frames) == {29, 30} and after.interpolated.all() and len(after) == 2 * len(at_28)
    for frame in (29, 30):
        held = after.subset(after.frames == frame)
        assert np.array_equal(held.ids, at_28.ids) and np.array_equal(held.boxes, at_28.boxes)


def test_a_stepped_stream_gives_every_frame_it_read_and_the_stepped_tracks(tmp_path):
    import cv2

    seq = require(CLIP)
    frames = [cv2.imread(str(p)) for p in sorted((seq / "img1").glob("*.jpg"))[:29]]
    det = np.loadtxt(seq / "det" / "det.txt", delimiter=",", ndmin=2)[:, [0, 2, 3, 4, 5, 6]]
    det = det[det[:, 0] <= 29]
    small = {"association": {"l_max_seconds": 0.6}, "windows": {"seconds": 1.5}}  # 5-frame windows at 10 fps
    parts = list(sotmot.stream(iter(frames), det, frame_rate=30, config={**small, "input": {"step": 3}}))
    assert [(p.first, p.last) for p in parts][0][0] == 1 and parts[-1].last == 29
    assert all(a.last + 1 == b.first for a, b in zip(parts, parts[1:]))
    # frame 29 comes after the last tracked one, 28, in a part of its own: 28's boxes held there
    assert parts[-1].first == 29 and len(parts[-1].tracks) == np.sum(parts[-2].tracks.frames == 28) > 0
    assert parts[-1].tracks.interpolated.all()
    # the same as the stream of the tracked frames alone, put back on every frame
    kept = det[(det[:, 0] - 1) % 3 == 0]
    kept[:, 0] = (kept[:, 0] - 1) // 3 + 1
    alone = list(sotmot.stream(iter(frames[::3]), kept, frame_rate=10, config=small))
    densifier = Densifier(3)
    expected = Tracks.concatenate([*(densifier.add(p.tracks, p.last) for p in alone), parts[-1].tracks])
    got = Tracks.concatenate([p.tracks for p in parts])
    assert len(got) > len(Tracks.concatenate([p.tracks for p in alone]))
    assert np.array_equal(got.frames, expected.frames) and np.array_equal(got.boxes, expected.boxes)


def test_sotmot_track_step_writes_every_frame_and_records_the_step(tmp_path):
    from sotmot.cli import main

    seq = require(CLIP)
    assert main(["track", str(seq), "--out", str(tmp_path), "--step", "2", "-q"]) == 0
    rows = np.loadtxt(tmp_path / f"{seq.name}.txt", delimiter=",", ndmin=2)
    assert set(rows[:, 0].astype(int)) >= {2, 4, 28}  # frames between tracked ones have boxes
    flags = np.loadtxt(tmp_path / f"{seq.name}.flags.csv", delimiter=",", skiprows=1, ndmin=2, usecols=(0, 2))
    assert flags[flags[:, 0] % 2 == 0, 1].all()  # every box of an even frame is filled in
    record = json.loads((tmp_path / f"{seq.name}.run.json").read_text())
    assert record["config"]["input"]["step"] == 2
    assert record["plan"]["l_max_frames"] == TrackerConfig().association.at(15).l_max  # counted at 15 fps


def test_a_file_in_windows_at_a_step_tracks_what_a_copy_of_every_kth_frame_tracks_in_those_windows(tmp_path):
    from sotmot.benchmarks import subsampled_sequence
    from sotmot.cli import main

    seq = require(CLIP)
    small = {"association": {"l_max_seconds": 0.2}, "windows": {"seconds": 0.5}}  # at 10 fps: 5-frame windows
    copy = subsampled_sequence(seq, 3, tmp_path / "copies")
    alone = np.loadtxt(sotmot.track(copy, config=small).save(tmp_path / "alone.txt"), delimiter=",", ndmin=2)
    config = tmp_path / "small.toml"
    config.write_text("[association]\nl_max_seconds = 0.2\n[windows]\nseconds = 0.5\n")
    out = tmp_path / "out"
    assert main(["track", str(seq), "--out", str(out), "--config", str(config), "--step", "3", "-q"]) == 0
    record = json.loads((out / f"{seq.name}.run.json").read_text())
    assert record["windows"]["plan"] == [[1, 5], [4, 8], [7, 10]]  # of the 10 tracked frames, 2 in each overlap
    text = (out / f"{seq.name}.txt").read_text()
    rows = np.loadtxt(out / f"{seq.name}.txt", delimiter=",", ndmin=2)
    tracked = rows[(rows[:, 0] - 1) % 3 == 0]
    tracked[:, 0] = (tracked[:, 0] - 1) // 3 + 1
    assert len(alone) > 50 and np.array_equal(tracked, alone)  # the same boxes, the same ids
    flags = np.loadtxt(out / f"{seq.name}.flags.csv", delimiter=",", skiprows=1, ndmin=2, usecols=(0, 2))
    between = (flags[:, 0] - 1) % 3 != 0
    assert between.sum() > 50 and flags[between, 1].all()  # every box between tracked frames is filled in
    assert rows[:, 0].max() == 30 and np.sum(rows[:, 0] == 30) == np.sum(rows[:, 0] == 28)  # 28's boxes held
    api = sotmot.track(seq, config={**small, "input": {"step": 3}}).save(tmp_path / "api.txt")
    assert api.read_text() == text  # the API tracks in windows at a step as the command line does


def test_the_runs_that_track_every_frame_refuse_a_step():
    from sotmot.pipeline import track_sequence

    seq = require(CLIP)
    with pytest.raises(ConfigError, match="step = 2 is for sotmot track"):
        track_sequence(seq, TrackerConfig().replace("input", step=2))


@pytest.mark.parametrize("window", [[], ["--window", "20"]])
def test_a_step_that_leaves_too_few_frames_a_second_is_refused_before_anything_is_written(tmp_path, capsys, window):
    # 5 fps at step 5: 1 tracked frame a second, so the 1-s batches hold one box each and l_min drops them all
    from sotmot.cli import main

    from conftest import write_sequence

    seq = write_sequence(tmp_path, [f"{f},-1,{10 + 3 * f},20,30,60,0.9" for f in range(1, 101)], length=100,
                         frame_rate=5, width=400, height=120, images=False)
    out = tmp_path / "out"
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--step", "5", "-q", *window]) == 2
    err = capsys.readouterr().err
    assert "at 1 frames/s gives batches of 1 frame(s)" in err and "a smaller [input] step than 5" in err
    assert not out.exists()


def test_explain_at_a_step_tells_the_tracks_of_the_results_file_in_the_tracked_frames(tmp_path, capsys):
    from sotmot.cli import main

    seq = require(CLIP)
    assert main(["track", str(seq), "--out", str(tmp_path), "--step", "3", "-q"]) == 0
    rows = np.loadtxt(tmp_path / f"{seq.name}.txt", delimiter=",", ndmin=2)
    capsys.readouterr()
    assert main(["explain", str(seq), "--config", str(tmp_path / f"{seq.name}.run.json"), "--tracks", "-q"]) == 0
    out, err = capsys.readouterr()
    assert "frame k here is the sequence's frame 1 + (k - 1) * 3" in err
    table = out.splitlines()[2:]
    assert {int(line.split()[0]) for line in table} >= set(rows[:, 1].astype(int))  # the ids the file holds
    assert max(int(line.split()[1].split("-")[1]) for line in table) <= 10  # the 10 tracked frames of 30
