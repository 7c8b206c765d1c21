"""scripts/miss_analysis.py: where the misses lie and what evidence their frames hold (issue #25)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from conftest import DATA, MODELS, ROOT, require
from helpers import load_script


def test_a_box_is_evidence_only_for_the_person_it_overlaps_most():
    # two people side by side, the one behind (missed) 4 px right of the one in front: the front person's box
    # overlaps the missed box at IoU 0.67 but overlaps its own person exactly, so it is no evidence for the miss
    covering = load_script("miss_analysis").covering
    front, behind = np.array([10.0, 10, 20, 40]), np.array([14.0, 10, 20, 40])
    people = np.stack([front, behind])
    assert covering(behind, front[None], people).tolist() == [False]
    assert covering(behind, np.array([[15.0, 10, 20, 40]]), people).tolist() == [True]
    assert covering(behind, np.array([[40.0, 10, 20, 40]]), people).tolist() == [False]  # IoU 0
    assert covering(behind, np.zeros((0, 4)), people).tolist() == []


def test_every_miss_is_counted_once_and_the_ceiling_is_a_part_of_them(tmp_path, model_0288):
    pytest.importorskip("openvino")
    detector = require(MODELS / "person-detection-0202" / "person-detection-0202.FP16-INT8.xml")
    out = tmp_path / "misses.json"
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "miss_analysis.py"), "--data", str(DATA),
                           "--model", str(model_0288), "--detector-model", str(detector), "--sequences",
                           "MOT16-02-clip30", "--min-length", "0", "--det-cache", str(tmp_path / "cache"),
                           "--json", str(out)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    report = json.loads(out.read_text())
    counts = report["sequences"]["MOT16-02-clip30"]
    total = sum(counts[p][e] for p in counts for e in ("input", "weak", "faint", "none"))
    assert total == report["metrics"]["MOT16-02-clip30"]["FN"] > 0  # TrackEval's FN, each miss in one cell
    assert 0 <= report["ceiling"]["MOT16-02-clip30"] <= total
    assert all(counts[p]["hidden"] <= sum(counts[p][e] for e in ("input", "weak", "faint", "none")) for p in counts)
    assert "ceiling for SOT checked by the detector" in done.stdout
