"""scripts/fp_analysis.py: each output box put under the stage that wrote it, each FP under what lies there."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from helpers import load_script, tk
from sotmot.config import PostprocessConfig
from sotmot.scoring import FrameErrors
from sotmot.types import Tracks

BOX = (0.0, 0.0, 40.0, 100.0)


def walk(frames, velocity, start=(0.0, 0.0)) -> np.ndarray:
    """``x, y, w, h`` boxes 40 x 100 moving at ``velocity`` pixels a frame from ``start`` at frame 1."""
    f = np.asarray(frames, dtype=float)[:, None] - 1.0
    xy = np.asarray(start, dtype=float) + f * np.asarray(velocity, dtype=float)
    return np.column_stack([xy, np.full((len(f), 2), (40.0, 100.0))])


def test_a_box_is_put_under_the_stage_that_wrote_it():
    script = load_script("fp_analysis")
    seen = np.r_[1:6, 7:12, 30:35]  # a 2-frame gap (short at 10 fps) and a 19-frame one (long: over 1 s)
    straight = tk(1, seen, walk(seen, (10.0, 0.0)))  # the walk leads along both gaps' lines
    # after its long gap the second person walks back the way they came: the straight line is off the walk
    turned = tk(2, np.r_[1:6, 30:35], np.vstack([walk(np.r_[1:6], (10.0, 0.0)),
                                                  walk(np.r_[30:35], (-10.0, 0.0), start=(500.0, 300.0))]))
    rows = [(f, 7, False, False) for f in seen] + [(6, 7, True, False)] + [(f, 7, True, False) for f in range(12, 30)]
    rows += [(35, 7, False, True)]  # the end extension's box
    rows += [(f, 8, False, False) for f in turned.frames] + [(f, 8, True, False) for f in range(6, 30)]
    frames, ids, filled, sot = (np.array(c) for c in zip(*rows))
    tracks = Tracks(frames, ids, np.tile(BOX, (len(rows), 1)), np.ones(len(rows)), filled, sot, np.ones(len(rows)))
    result = SimpleNamespace(tracks=tracks, trajectories=[straight, turned], track_ids=[7, 8],
                             info=SimpleNamespace(frame_rate=10.0))
    origin = script.origins(result, PostprocessConfig())
    assert origin[1, 7] == origin[30, 8] == "detection"
    assert origin[35, 7] == "sot"
    assert origin[6, 7] == "short gap"
    assert origin[12, 7] == origin[29, 7] == "long gap, on the line"
    assert origin[6, 8] == origin[29, 8] == "long gap, off the line"
    # with a longer occlusion_seconds the 19-frame gap is a short one
    assert script.origins(result, PostprocessConfig(occlusion_seconds=2.0))[12, 7] == "short gap"


def test_a_false_box_is_misplaced_double_or_on_no_one():
    script = load_script("fp_analysis")
    person, missed = np.array([0.0, 0.0, 40.0, 100.0]), np.array([200.0, 0.0, 40.0, 100.0])
    errors = FrameErrors()
    errors.matched = {1: [(person, person, 1, False)]}
    errors.misses = {1: [missed]}
    errors.false_positives = {1: [(missed + [15.0, 0, 0, 0], 2),  # IoU 0.45 with the person nobody matched
                                  (person + [2.0, 0, 0, 0], 3),  # a second box on the matched person
                                  (np.array([600.0, 0, 40, 100]), 4)]}  # on no one
    origin = {(1, 1): "detection", (1, 2): "long gap, on the line", (1, 3): "sot", (1, 4): "detection"}
    counts = script.classify(errors, origin)
    assert counts["detection"] == {"boxes": 2, "FP": 1, "misplaced": 0, "double": 0, "no one": 1}
    assert counts["long gap, on the line"] == {"boxes": 1, "FP": 1, "misplaced": 1, "double": 0, "no one": 0}
    assert counts["sot"] == {"boxes": 1, "FP": 1, "misplaced": 0, "double": 1, "no one": 0}
    assert script.combine([counts, counts])["detection"]["boxes"] == 4
    lines = script.table(counts)
    assert lines[2].split()[:6] == ["detection", "2", "1", "33%", "50.0%", "+0"]  # one right box, one false
    assert script.net(counts["sot"]) == -1


def test_private_detections_are_refused_on_sequences_without_frames(tmp_path, capsys):
    script = load_script("fp_analysis")
    model = tmp_path / "detector.xml"
    model.write_text("<net/>")
    try:
        script.main(["--model", "reid.onnx", "--detector-model", str(model), "--data", str(tmp_path)])
    except SystemExit as exc:
        assert exc.code == 2
    else:
        raise AssertionError("the label-only group was taken with --detector-model")
    assert "label-only sequences have none" in capsys.readouterr().err
