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
