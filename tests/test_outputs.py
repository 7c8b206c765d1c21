"""Every file sotmot reads or writes tells the truth (issue #44): ordinary text quirks read cleanly, replays
repeat, no stale side file goes unnoticed, the inspection commands agree with ``track``. Each test failed on the
commit before its fix."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from sotmot.cli import main

from conftest import DATA, require, write_sequence

GT = ["1,1,10,10,20,30,1,1,1", "2,1,12,10,20,30,1,1,1", "3,1,14,10,20,30,1,1,1",
      "1,2,40,5,10,20,1,1,1", "2,2,40,6,10,20,1,1,1"]
RESULTS = ["1,1,10,10,20,30,0.9,-1,-1,-1", "2,1,12,10,20,30,0.9,-1,-1,-1", "3,1,14,10,20,30,0.9,-1,-1,-1",
           "1,2,40,5,10,20,0.8,-1,-1,-1", "2,2,41,6,10,20,0.8,-1,-1,-1"]


def _scored(tmp_path, results_text: str, gt_bytes: bytes, capsys) -> tuple[int, str, str]:
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,0.9"], length=3, images=False, gt_lines=[])
    (seq / "gt" / "gt.txt").write_bytes(gt_bytes)
    out = tmp_path / "res"
    out.mkdir(exist_ok=True)
    (out / "SYN.txt").write_text(results_text)
    capsys.readouterr()
    rc = main(["eval", str(out), str(seq)])
    captured = capsys.readouterr()
    return rc, captured.out, captured.err


def _hota(table: str) -> str:
    return next(line for line in table.splitlines() if line.startswith("SYN"))


@pytest.mark.parametrize("quirk", ["blank line at the end of the results", "blank lines in gt.txt",
                                   "byte-order mark in gt.txt", "CRLF line ends"])
def test_eval_reads_ordinary_text_quirks_as_a_text_reader_would(tmp_path, capsys, quirk):
    clean_results, clean_gt = "\n".join(RESULTS) + "\n", ("\n".join(GT) + "\n").encode()
    rc, reference, err = _scored(tmp_path / "clean", clean_results, clean_gt, capsys)
    assert rc == 0, err
    results, gt = clean_results, clean_gt
    if quirk == "blank line at the end of the results":
        results = clean_results + "\n\n"
    elif quirk == "blank lines in gt.txt":
        gt = b"\n" + clean_gt.replace(b"\n", b"\n\n")
    elif quirk == "byte-order mark in gt.txt":
        gt = b"\xef\xbb\xbf" + clean_gt
    else:
        results, gt = clean_results.replace("\n", "\r\n"), clean_gt.replace(b"\n", b"\r\n")
    rc, table, err = _scored(tmp_path / "quirk", results, gt, capsys)
    assert rc == 0, err
    assert _hota(table) == _hota(reference)


@pytest.mark.parametrize("lines, bad_line", [
    (RESULTS[:-1] + ["2,2,41,6,10,20,0.8"], 5),                     # the last line cut after the score
    (RESULTS[:2] + ["3,1,14,10,20,30,0.9,-1,-1"] + RESULTS[3:], 3),  # a 9-column line among 10-column ones
])
def test_a_cut_or_mixed_line_is_one_error_naming_file_and_line(tmp_path, capsys, lines, bad_line):
    rc, _, err = _scored(tmp_path, "\n".join(lines) + "\n", ("\n".join(GT) + "\n").encode(), capsys)
    assert rc == 2
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert f"SYN.txt:{bad_line}: " in err and "columns where line 1 has 10" in err


def test_render_with_gt_reads_a_blank_line_and_names_a_cut_one(tmp_path, capsys):
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,0.9"], length=3, gt_lines=GT)
    (seq / "gt" / "gt.txt").write_text("\n".join(GT) + "\n\n")
    results = tmp_path / "SYN.txt"
    results.write_text("\n".join(RESULTS) + "\n\n")
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "frames"), "--gt", "-q"]) == 0
    results.write_text("\n".join(RESULTS[:-1] + ["2,2,41,6,10,20,0.8"]) + "\n")
    capsys.readouterr()
    assert main(["render", str(seq), str(results), "--out", str(tmp_path / "frames2"), "--gt", "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{results}:5: " in err, err


def _strict_json(text: str):
    def refuse(constant):
        raise ValueError(f"{constant} is not JSON")

    return json.loads(text, parse_constant=refuse)


def test_compare_json_is_json_its_table_aligned_and_its_tracks_those_track_writes(tmp_path, capsys):
    seq = require(DATA / "MOT16-02-clip30")
    out = tmp_path / "cmp.json"
    assert main(["compare", str(seq), "--solvers", "greedy,flow-staged", "-q", "--json", str(out)]) == 0
    table = capsys.readouterr().out
    rows = _strict_json(out.read_text())["rows"]  # NaN (window_gap of solvers without a bound) is null
    assert rows["MOT16-02-clip30"]["greedy"]["window_gap"] is None
    block = [line for line in table.splitlines() if line.startswith("  ")][:3]
    header, *solver_rows = block
    assert [len(r) for r in solver_rows] == [len(header)] * 2, block
    for column in ("HOTA", "tracks", "solver_s"):  # each value ends where its column's name ends
        end = header.index(column) + len(column)
        for row in solver_rows:
            assert row[end - 1] != " " and (end == len(row) or row[end] == " "), (column, row)
    assert main(["track", str(seq), "--out", str(tmp_path / "res"), "-q"]) == 0
    written = (tmp_path / "res" / "MOT16-02-clip30.txt").read_text().splitlines()
    ids = {line.split(",")[1] for line in written}
    assert rows["MOT16-02-clip30"]["greedy"]["tracks"] == len(ids)


def test_track_refuses_an_out_folder_inside_the_sequence_folder_as_render_does(tmp_path, capsys):
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,0.9"], length=3, images=False)
    before = sorted(p.relative_to(seq) for p in seq.rglob("*"))
    for out in (seq, seq / "results", seq / "det"):
        assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "-q"]) == 2
        assert "refusing to write into the sequence folder" in capsys.readouterr().err
    assert sorted(p.relative_to(seq) for p in seq.rglob("*")) == before  # not even an empty folder made
    assert main(["track", str(seq), "--out", str(tmp_path / "res"), "--appearance", "none", "-q"]) == 0


def test_eval_warns_of_a_results_file_cut_since_its_run_and_of_an_empty_one(tmp_path, capsys):
    seq = write_sequence(tmp_path, [f"{f},-1,{10 + 2 * f},10,20,30,0.9" for f in range(1, 4)], length=3,
                         images=False, gt_lines=GT)
    out = tmp_path / "res"
    assert main(["track", str(seq), "--out", str(out), "--appearance", "none", "--unconfirmed", "keep", "-q"]) == 0
    capsys.readouterr()
    assert main(["eval", str(out), str(seq)]) == 0
    assert "warning" not in capsys.readouterr().err
    results = out / "SYN.txt"
    results.write_text(results.read_text().splitlines()[0] + "\n")  # cut
    assert main(["eval", str(out), str(seq)]) == 0
    err = capsys.readouterr().err
    assert "warning" in err and "not the file its run record SYN.run.json describes" in err
    results.write_text("")
    assert main(["eval", str(out), str(seq)]) == 0
    assert "SYN.txt is empty" in capsys.readouterr().err


def test_fps_on_a_folder_is_refused_not_recorded(tmp_path, capsys):
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,0.9"], length=3, images=False)
    assert main(["track", str(seq), "--out", str(tmp_path / "res"), "--appearance", "none", "--fps", "10",
                 "-q"]) == 2
    assert "--fps ([input] fps) is for a video" in capsys.readouterr().err


def test_render_onto_a_short_video_speaks_of_the_video_not_of_seqinfo(tmp_path, capsys):
    from conftest import write_video

    video = write_video(tmp_path / "street.avi", n=12)
    results = tmp_path / "street.txt"
    results.write_text("1,1,10,20,20,40,0.9,-1,-1,-1\n20,1,10,20,20,40,0.9,-1,-1,-1\n")
    assert main(["render", str(video), str(results), "--out", str(tmp_path / "r.avi"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "frame 20 is outside 1..12" in err and "seqinfo.ini" not in err


def test_a_failed_single_sequence_says_nothing_was_written_and_leaves_no_folder(tmp_path, capsys):
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,0.9"], length=3, images=False)  # re-ID needs frames
    out = tmp_path / "res"
    assert main(["track", str(seq), "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "the sequence failed; no results written" in err and "others" not in err
    assert not out.exists()
    out.mkdir()  # a folder the user made stays
    assert main(["track", str(seq), "--out", str(out), "-q"]) == 2
    assert out.is_dir()


def test_unconfirmed_boxes_kept_in_a_file_are_not_called_dropped(tmp_path, capsys):
    seq = require(DATA / "MOT16-02-clip30")
    assert main(["track", str(seq), "--out", str(tmp_path / "res"), "--unconfirmed", "file"]) == 0
    out = capsys.readouterr().out
    assert "unconfirmed written to MOT16-02-clip30.low.txt" in out and "dropped" not in out
    # the summary counts the boxes no detection gave, as the flags file beside the results marks them
    rows = [line.split(",") for line in (tmp_path / "res" / "MOT16-02-clip30.flags.csv").read_text().split()[1:]]
    interpolated, sot = sum(r[2] == "1" for r in rows), sum(r[3] == "1" for r in rows)
    assert interpolated, "the clip has interpolated boxes: the case to test"
    made = ", ".join([f"{interpolated} interpolated"] + [f"{sot} added by SOT or weak boxes"] * (sot > 0))
    assert f"{len(rows)} boxes ({made})," in out


def test_compare_on_a_video_is_refused_before_the_work(tmp_path, capsys):
    from conftest import write_video

    video = write_video(tmp_path / "street.avi")
    assert main(["compare", str(video), "--solvers", "greedy,flow", "-q"]) == 2
    err = capsys.readouterr().err
    assert "a video has none" in err and "gt/gt.txt" in err and "street.avi/gt" not in err


def test_a_top_level_toml_key_is_not_called_a_section(tmp_path):
    from sotmot.config import load_config
    from sotmot.errors import ConfigError

    path = tmp_path / "c.toml"
    path.write_text("l_max_seconds = 3\n[association]\nsolver = 'flow'\n")
    with pytest.raises(ConfigError, match=r"key\(s\) l_max_seconds outside any \[section\]"):
        load_config(path)


def test_train_appearance_warns_when_too_few_people_are_held_out(tmp_path, capsys, monkeypatch):
    import sotmot.train

    summary = {"history": [{"epoch": 1, "train_loss": 0.1, "val_auc": 1.0}], "identities_train": 6,
               "identities_val": 2, "crops": 100, "val_auc_before": 0.9, "val_auc_best": 1.0, "best_epoch": 1,
               "seconds": 1.0, "out": str(tmp_path / "t.pt")}
    monkeypatch.setattr(sotmot.train, "train", lambda *a, **k: summary)
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,0.9"], length=3, images=False, gt_lines=GT)
    assert main(["train-appearance", str(seq), "--out", str(tmp_path / "t.pt"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "only 2 validation identities" in err


def _model_run(tmp_path, capsys) -> tuple[Path, Path]:
    """A model run on a short video made from MOT16-02-clip30 (the bundled detector finds the people)."""
    import cv2

    seq = require(DATA / "MOT16-02-clip30")
    video = tmp_path / "street.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10, (640, 360))
    for path in sorted((seq / "img1").glob("*.jpg"))[:15]:
        writer.write(cv2.resize(cv2.imread(str(path)), (640, 360), interpolation=cv2.INTER_AREA))
    writer.release()
    out = tmp_path / "model"
    assert main(["track", str(video), "--out", str(out), "-q"]) == 0
    capsys.readouterr()
    return video, out


def test_a_replayed_det_txt_repeats_the_run_under_any_name_and_without_its_record(tmp_path, capsys):
    video, out = _model_run(tmp_path, capsys)
    record = json.loads((out / "street.run.json").read_text())
    assert record["confidence_method"] == "pd0202"
    assert set(record["side_files"]) == {"street.det.txt", "street.flags.csv"}
    copy = tmp_path / "boxes.txt"  # another name, no run record beside it
    shutil.copy(out / "street.det.txt", copy)
    assert main(["track", str(video), "--det", str(copy), "--out", str(tmp_path / "replay"), "-q"]) == 0
    assert (tmp_path / "replay" / "street.txt").read_bytes() == (out / "street.txt").read_bytes()
    replay = json.loads((tmp_path / "replay" / "street.run.json").read_text())
    assert replay["confidence_method"] == "pd0202" and replay["plan"]["detections"] == "file"
    decided = ("weak_boxes", "ends_from", "confidence_family")  # the replay decides as the detector's run did
    assert [replay["plan"][k] for k in decided] == [record["plan"][k] for k in decided]
    assert [record["plan"][k] for k in decided] == [True, "detections", "pd0202"]


def test_side_files_belong_to_one_run_resume_rewrites_a_lost_one_render_says_so(tmp_path, capsys):
    video, out = _model_run(tmp_path, capsys)
    det = tmp_path / "boxes.txt"
    shutil.copy(out / "street.det.txt", det)
    # a run from a detections file into the same folder writes no .det.txt: the earlier one is said to be stale
    assert main(["track", str(video), "--det", str(det), "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "street.det.txt beside it is from an earlier run, not this one" in said
    assert "street.det.txt" not in json.loads((out / "street.run.json").read_text())["side_files"]
    (out / "street.flags.csv").unlink()
    assert main(["track", str(video), "--det", str(det), "--out", str(out), "--resume"]) == 0
    assert "re-run: its side file street.flags.csv is missing" in capsys.readouterr().out
    assert (out / "street.flags.csv").is_file()
    (out / "street.flags.csv").unlink()
    assert main(["render", str(video), str(out / "street.txt"), "--out", str(tmp_path / "r.avi"), "-q"]) == 0
    err = capsys.readouterr().err
    assert "street.flags.csv, written with street.txt, is missing: drawn without the SOT and interpolation" in err


def test_graph_and_explain_speak_of_the_tracks_of_the_results_file(tmp_path, capsys):
    from sotmot.config import TrackerConfig
    from sotmot.inspect.explain import explain_tracklets, inspection_graph
    from sotmot.pipeline import track_sequence

    seq = require(DATA / "MOT16-02-clip30")
    assert main(["track", str(seq), "--out", str(tmp_path / "res"), "-q"]) == 0
    written = {int(line.split(",")[1]) for line in (tmp_path / "res" / "MOT16-02-clip30.txt").read_text().split()}
    config = TrackerConfig()
    graph = inspection_graph(track_sequence(seq, config), config)
    nodes = dict(graph.nodes(data=True))
    assert {d["track"] for d in nodes.values() if d["in_results"]} == written
    dropped = sorted({d["track"] for d in nodes.values() if d["track"] >= 0 and not d["in_results"]})
    assert dropped, "the clip's confirmation drops whole tracks: the case the issue names"

    capsys.readouterr()
    assert main(["graph", str(seq), "--out", str(tmp_path / "g"), "-q"]) == 0
    said = capsys.readouterr().out
    assert f"in {len(written)} tracks of the results (and {len(dropped)} tracks confirmation dropped)" in said
    assert f"{graph.number_of_edges()} candidate links" in said and "the picture and the page draw" in said
    data = _strict_json((tmp_path / "g" / "graph.json").read_text())
    assert data["graph"]["candidate_links"] == graph.number_of_edges() and data["graph"]["solver"] == "greedy"
    page = (tmp_path / "g" / "graph.html").read_text()
    assert f"T{dropped[0]} dropped" in page and f"of {graph.number_of_edges()} candidate links" in page

    kept = sorted(written)
    assert main(["explain", str(seq), "--ids", f"{kept[0]},{dropped[0]}", "-q"]) == 0
    said = capsys.readouterr().out
    assert f"track {dropped[0]} is not in the results: confirmation dropped every box" in said

    merged = next(t for t in kept if sum(d["track"] == t for d in nodes.values()) > 1)
    members = sorted(n for n, d in nodes.items() if d["track"] == merged)
    assert main(["explain", str(seq), "--ids", str(merged), "-q"]) == 0
    assert f"the {len(members)} tracklets of track {merged} were merged" in capsys.readouterr().out
    text = explain_tracklets(graph, members[0], members[1], config)
    assert f"were merged into track {merged}" in text

    overlapping = next((u, v) for u, v, d in graph.edges(data=True) if d["overlap_frames"] > 0)
    text = explain_tracklets(graph, *overlapping, config)
    assert "share" in text and "IoU decides" in text and "REJECTED by iou" in text


def test_render_and_eval_given_their_arguments_the_wrong_way_round_say_so(tmp_path, capsys):
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,30,0.9"], length=3, gt_lines=GT)
    out = tmp_path / "out"
    out.mkdir()
    results = out / "SYN.txt"
    results.write_text("\n".join(RESULTS) + "\n")
    capsys.readouterr()
    assert main(["render", str(results), str(seq), "--out", str(tmp_path / "frames"), "-q"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"sotmot render {seq} {results} --out" in err, err
    assert not (tmp_path / "frames").exists()
    assert main(["eval", str(seq), str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"sotmot eval {out} {seq}" in err, err
    assert main(["eval", str(out), str(seq)]) == 0  # the right way round scores
