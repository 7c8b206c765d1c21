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


def _report(path, scores):
    """A bench_peers.py report holding ``scores[tracker][sequence] = HOTA`` (MOTA and IDF1 alike)."""
    import json

    table = {t: {s: {"HOTA": v, "MOTA": v, "IDF1": v} for s, v in by.items()} for t, by in scores.items()}
    path.write_text(json.dumps({"table": table}))
    return path


def test_peers_paired_reads_the_lead_run_by_run_and_refuses_mismatched_reports(tmp_path, capsys):
    import json

    script = load_script("peers_paired")
    first = _report(tmp_path / "j0.json", {"sotmot": {"A": 60.0, "B": 50.0}, "P": {"A": 58.0, "B": 49.0}})
    copy = _report(tmp_path / "j1.json", {"sotmot": {"A": 59.0, "B": 48.0}, "P": {"A": 58.5, "B": 49.5}})
    assert script.main([str(first), str(copy), "--json", str(tmp_path / "out.json")]) == 0
    rows = json.loads((tmp_path / "out.json").read_text())["rows"]["HOTA"]
    assert rows["P"]["A"]["lead"] == [2.0, 0.5] and rows["P"]["A"]["verdict"] == "above in every run"
    assert rows["P"]["B"]["lead"] == [1.0, -1.5] and rows["P"]["B"]["verdict"] == "not told apart from chance"
    assert rows["sotmot"]["A"]["runs"] == [60.0, 59.0] and "lead" not in rows["sotmot"]["A"]
    assert "+2.00 (+0.50 to +2.00: above in every run)" in capsys.readouterr().out
    short = _report(tmp_path / "j2.json", {"sotmot": {"A": 59.0}, "P": {"A": 58.5}})
    for argv, said in (([str(first), str(short)], "no sotmot rows for B"), ([str(first)], "at least one"),
                       ([str(first), str(copy), "--reference", "X"], "no tracker 'X'"),
                       ([str(first), str(copy), "--json", str(copy)], "would write over")):
        with pytest.raises(SystemExit) as stop:
            script.main(argv)
        assert stop.value.code == 2 and said in capsys.readouterr().err, argv
    assert json.loads(copy.read_text())["table"]["P"]["A"]["HOTA"] == 58.5  # not written over
