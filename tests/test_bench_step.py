"""scripts/bench_step.py: each sequence tracked at every k-th frame and scored on every frame, beside step 1."""

from __future__ import annotations

import json

from conftest import DATA, require
from helpers import load_script


def test_a_clip_at_steps_1_and_2_is_scored_on_every_frame(tmp_path):
    script = load_script("bench_step")
    require(DATA / "MOT16-02-clip30")
    assert script.main(["--data", str(DATA), "--sequences", "MOT16-02-clip30", "--steps", "1,2,3",
                        "--min-fps", "12", "--detections", "public", "--json", str(tmp_path / "step.json")]) == 0
    rows = json.loads((tmp_path / "step.json").read_text())["rows"]
    assert [(r["step"], r["tracked_fps"]) for r in rows] == [(1, 30), (2, 15)]  # 10 fps is below --min-fps
    one, two = rows
    assert one["filled"] < two["filled"] and two["boxes"] > 0 and 10 < two["HOTA"] < 100
    assert script.step_table(rows)[3].startswith("| MOT16-02-clip30 | 30 | 2 | 15 |")
