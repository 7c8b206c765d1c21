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


def test_a_sequence_name_with_no_folder_is_refused_not_skipped(tmp_path, capsys):
    data = tmp_path / "data"
    (data / "A" / "img1").mkdir(parents=True)
    (data / "A" / "seqinfo.ini").write_text("[Sequence]\nname=A\n")
    script = load_script("bench_peers")
    with pytest.raises(SystemExit) as stop:
        script.main(["--model", "reid.onnx", "--out", str(tmp_path / "out"), "--data", str(data),
                     "--trackers", "sotmot", "--sequences", "A,B"])
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "no sequence named B here; there are A" in err
    assert not (tmp_path / "out").exists()
