"""scripts/bench_peers.py: what it refuses before any tracker runs."""

from __future__ import annotations

import pytest

from helpers import load_script


def test_the_mot17_clips_are_refused_where_every_tracker_gets_the_detectors_boxes(tmp_path, capsys):
    script = load_script("bench_peers")
    with pytest.raises(SystemExit) as stop:
        script.main(["--model", "reid.onnx", "--out", str(tmp_path / "out"), "--mot17-clips",
                     "--detector-model", "detector.xml"])
    assert stop.value.code == 2
    assert "would be the MOT16 clips' runs again" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # refused before anything was written
