"""scripts/bench_peers.py: what it refuses before any tracker runs, and its runs on offset copies (``--jitter``);
scripts/peers_paired.py, which reads them; the results page's table of them."""

from __future__ import annotations

import json

import pytest

from conftest import DATA, require, write_sequence
from helpers import load_script


def test_the_mot17_clips_are_refused_where_every_tracker_gets_the_detectors_boxes(tmp_path, capsys):
    script = load_script("bench_peers")
    with pytest.raises(SystemExit) as stop:
        script.main(["--model", "reid.onnx", "--out", str(tmp_path / "out"), "--mot17-clips",
                     "--detector-model", "detector.xml"])
    assert stop.value.code == 2
    assert "would be the MOT16 clips' runs again" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # refused before anything was written
    with pytest.raises(SystemExit) as stop:
        script.main(["--model", "reid.onnx", "--out", str(tmp_path / "out"), "--jitter", "-1"])
    assert stop.value.code == 2 and "0 or more, not -1" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


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


def test_jitter_runs_every_tracker_again_on_offset_copies_of_the_detections(tmp_path, model_0288):
    clip = require(DATA / "MOT16-05-clip30")
    script = load_script("bench_peers")
    out = tmp_path / "out"
    assert script.main(["--model", str(model_0288), "--out", str(out), "--data", str(clip.parent), "--runs", "1",
                        "--sequences", clip.name, "--trackers", "sotmot,sotmot flow", "--jitter", "1"]) == 0
    report = json.loads((out / "peers.json").read_text())
    jitter = report["jitter"]
    assert jitter["copies"] == 1 and jitter["trackers"] == ["sotmot", "sotmot flow"] and len(jitter["tables"]) == 1
    assert set(jitter["tables"][0]["sotmot flow"]) == set(report["table"]["sotmot flow"]) - {"fps", "e2e fps"}
    first = (out / "results" / "sotmot" / f"{clip.name}.txt").read_text()
    moved = (out / "jitter1" / "results" / "sotmot" / f"{clip.name}.txt").read_text()
    assert first and moved and first != moved  # the copy's boxes moved, so its results did
    assert "sotmot's lead over it, run by run" in (out / "peers.md").read_text()
    assert sorted(p.name for p in out.iterdir()) == ["jitter1", "peers.json", "peers.md", "peers.png", "results"]


def _report(path, scores, copies=()):
    """A bench_peers.py report holding ``scores[tracker][sequence] = HOTA`` (MOTA and IDF1 alike); with
    ``copies``, such score dicts of ``--jitter`` runs."""
    def table_of(by_tracker):
        return {t: {s: {"HOTA": v, "MOTA": v, "IDF1": v} for s, v in by.items()} for t, by in by_tracker.items()}

    report = {"table": table_of(scores)}
    if copies:
        report["jitter"] = {"copies": len(copies), "pixels": 0.5, "trackers": list(copies[0]),
                            "tables": [table_of(c) for c in copies]}
    path.write_text(json.dumps(report))
    return path


def test_peers_paired_reads_the_lead_run_by_run_and_refuses_mismatched_reports(tmp_path, capsys):
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
    for argv, said in (([str(first), str(short)], "no sotmot rows for B"), ([str(first)], "no runs on offset"),
                       ([str(first), str(copy), "--reference", "X"], "no tracker 'X'"),
                       ([str(first), str(copy), "--json", str(copy)], "would write over")):
        with pytest.raises(SystemExit) as stop:
            script.main(argv)
        assert stop.value.code == 2 and said in capsys.readouterr().err, argv
    assert json.loads(copy.read_text())["table"]["P"]["A"]["HOTA"] == 58.5  # not written over


def test_one_report_with_its_jitter_runs_reads_like_the_reports_of_each_run(tmp_path, capsys):
    script = load_script("peers_paired")
    first = _report(tmp_path / "j0.json", {"sotmot": {"A": 60.0}, "P": {"A": 58.0}})
    copy = _report(tmp_path / "j1.json", {"sotmot": {"A": 59.0}, "P": {"A": 58.5}})
    both = _report(tmp_path / "both.json", {"sotmot": {"A": 60.0}, "P": {"A": 58.0}, "kept peer": {"A": 70.0}},
                   copies=[{"sotmot": {"A": 59.0}, "P": {"A": 58.5}}])
    assert script.main([str(first), str(copy)]) == 0
    apart = capsys.readouterr().out
    assert script.main([str(both)]) == 0
    assert capsys.readouterr().out == apart  # the row kept from an earlier run (no copies) is left out
    broken = _report(tmp_path / "broken.json", {"sotmot": {"A": 60.0, "B": 1.0}, "P": {"A": 58.0, "B": 1.0}},
                     copies=[{"sotmot": {"A": 59.0}, "P": {"A": 58.5}}])
    with pytest.raises(SystemExit) as stop:
        script.main([str(broken)])
    assert stop.value.code == 2 and "broken.json's copy 1: no sotmot rows for B" in capsys.readouterr().err


def test_the_results_page_names_the_peer_sotmot_leads_least_and_marks_a_lead_of_no_one_sign(tmp_path):
    page = load_script("make_results_page")
    report = json.loads(_report(
        tmp_path / "r.json", {"sotmot": {"A": 60.0, "full-length": 60.0, "ALL": 60.0}, "P": {"A": 55.0,
                              "full-length": 59.0, "ALL": 59.0}, "Q": {"A": 58.0, "full-length": 50.0, "ALL": 50.0}},
        copies=[{"sotmot": {"A": 60.0, "full-length": 59.0, "ALL": 59.0}, "P": {"A": 59.0, "full-length": 59.5,
                 "ALL": 59.5}, "Q": {"A": 57.0, "full-length": 50.0, "ALL": 50.0}}]).read_text())
    lines = page.peers_by_run(report)
    rows = [line for line in lines if line.startswith("| A |") or line.startswith("| combined |")]
    assert rows[0].startswith("| A | 60.0 (60.0-60.0); +5.0 (+1.0 to +5.0) over P |")  # P: lowest lead, +1
    assert rows[1].startswith("| combined | 60.0 (59.0-60.0); +1.0 (-0.5 to +1.0) over P **not one sign** |")
    assert not any(line.startswith("| all |") for line in lines)  # "ALL" is the one group again
    assert page.peers_by_run({"table": report["table"]}) == []  # no --jitter runs, no table


def test_a_kept_report_of_other_detections_or_sequences_is_refused_before_anything_runs(tmp_path, capsys):
    data = tmp_path / "data"
    write_sequence(data, ["1,-1,10,10,10,20,1"], name="A")
    script = load_script("bench_peers")
    report = {"machine": "M", "runs": 1, "detections": "public", "table": {"sotmot": {"B": {}}, "SORT": {"B": {}}}}
    keep = tmp_path / "keep.json"
    for text, said in ((json.dumps(dict(report, detections="private: x/det.xml")),
                        "made with private: x/det.xml detections"),
                       (json.dumps(report), "SORT has no rows for A; run it now"),
                       ("[]", "not a report (a JSON object was expected, found list)"),
                       ("{}", "not a report of the kind asked for (no table, machine, detections, runs)")):
        keep.write_text(text)
        with pytest.raises(SystemExit) as stop:
            script.main(["--model", "reid.onnx", "--out", str(tmp_path / "out"), "--data", str(data),
                         "--trackers", "sotmot", "--keep", str(keep)])
        assert stop.value.code == 2 and said in capsys.readouterr().err
        assert not (tmp_path / "out").exists()


def test_rows_kept_twice_keep_the_machine_they_were_measured_on():
    script, page = load_script("bench_peers"), load_script("make_results_page")
    earlier = {"machine": "B", "kept": {"machine": "A", "rows": ["P"]}}  # P measured on A, Q and sotmot on B
    machines = script.kept_machines(earlier, ["P", "Q"])
    assert machines == {"P": "A", "Q": "B"}
    assert script.kept_machines({"machine": "C", "kept": {"machines": machines, "rows": ["P", "Q"]}}, ["P", "Q"]) \
        == machines
    assert page.kept_where({"rows": ["P", "Q"], "machines": machines}) == "P on A; Q on B"
    assert page.kept_where({"rows": ["P"], "machine": "A"}) == "machine: A"
