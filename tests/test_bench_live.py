"""scripts/bench_live.py: frames handed over no sooner than a camera at the sequence's rate gives them, each
frame's lag from its coming to its boxes being final, and how far a run fell behind."""

from __future__ import annotations

import json

from conftest import DATA, require
from helpers import load_script


def test_a_clip_played_at_its_rate_lags_by_the_stream_and_the_tracking(tmp_path):
    script = load_script("bench_live")
    require(DATA / "MOT16-02-clip30")
    assert script.main(["--data", str(DATA), "--sequences", "MOT16-02-clip30", "--windows", "10",
                        "--json", str(tmp_path / "live.json")]) == 0
    row, = json.loads((tmp_path / "live.json").read_text())["rows"]
    assert row["parts"] == [{**row["parts"][0], "first": 1, "last": 30}]  # 1 s of stream, one 10-s window
    # the first frame waited for the whole stream (30 frames at 30 fps come over 29/30 s), the last for none of it
    assert row["lag_max_s"] >= 0.9 and row["lag_max_s"] - row["lag_last_frame_s"] >= 0.85  # each rounded to 0.1
    assert row["wall_s"] >= row["lag_max_s"] and row["behind_s"] is None and row["HOTA"] > 20


def test_behind_compares_the_parts_a_window_cut():
    script = load_script("bench_live")
    parts = [{"lag_last_s": 4.0}, {"lag_last_s": 4.2}, {"lag_last_s": 9.5}, {"lag_last_s": 1.0}]
    assert script.behind(parts) == 5.5  # the stream's own last part (1.0) waits for no window: left out
    assert script.behind(parts[:2]) is None
    # every 2nd frame of 60 tracked: the last tracked frame is 59, and frame 60 comes as a part of its own after
    # the part that ends there, the stream's end; both are left out
    stepped = [{"last": 20, "lag_last_s": 4.0}, {"last": 40, "lag_last_s": 3.0}, {"last": 59, "lag_last_s": 1.5},
               {"last": 60, "lag_last_s": 1.5}]
    assert script.behind(stepped, 59) == -1.0
    assert script.behind(stepped[1:], 59) is None


def test_a_clip_played_twice_is_one_stream_scored_against_its_ground_truth_twice(tmp_path):
    script = load_script("bench_live")
    require(DATA / "MOT16-02-clip30")
    assert script.main(["--data", str(DATA), "--sequences", "MOT16-02-clip30:2", "--windows", "10",
                        "--cache", str(tmp_path / "cache"), "--json", str(tmp_path / "live.json")]) == 0
    row, = json.loads((tmp_path / "live.json").read_text())["rows"]
    assert row["sequence"] == "MOT16-02-clip30 x2" and row["frames"] == 60 and row["stream_s"] == 2.0
    assert row["parts"][-1]["last"] == 60
    assert row["peak_rss_mb"] >= max(p["rss_mb"] for p in row["parts"]) > 100  # models loaded: hundreds of MB
    # the second copy's people are new people, so HOTA stays what one copy scores (about), not half of it
    assert row["HOTA"] > 20 and (tmp_path / "cache" / "MOT16-02-clip30-x2.gt.txt").is_file()
