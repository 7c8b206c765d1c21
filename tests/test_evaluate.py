"""The TrackEval wrapper, cross-checked against published numbers."""

from importlib.metadata import PackageNotFoundError, distribution

import pytest

from conftest import write_sequence
from sotmot.errors import InputError
from sotmot.scoring import evaluate, evaluate_files, format_table


def tud_campus():
    try:
        path = distribution("motmetrics").locate_file("motmetrics/data/TUD-Campus")
    except PackageNotFoundError:
        pytest.skip("motmetrics (test data only) is not installed; scripts/bootstrap.sh installs it")
    return path


def test_tud_campus_matches_the_numbers_py_motmetrics_asserts():
    # py-motmetrics' own tests check these against the official MOTChallenge devkit
    path = tud_campus()
    report = evaluate_files([(path / "test.txt", path / "gt.txt", 71, "TUD-Campus")])
    s = report.sequences["TUD-Campus"]
    assert s["MOTA"] == pytest.approx(52.6462, abs=1e-3)
    assert s["IDF1"] == pytest.approx(55.7659, abs=1e-3)
    assert (s["FP"], s["FN"], s["IDSW"]) == (13, 150, 7)
    assert report.benchmark["TUD-Campus"] == "MOT15"


def test_perfect_results_score_100_and_missing_results_are_named(tmp_path):
    gt = ["1,1,10,10,20,40,1,1,1", "2,1,12,10,20,40,1,1,1", "2,2,40,5,10,20,0,1,1"]
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,40,1"], length=2, gt_lines=gt, images=False)
    out = tmp_path / "res"
    out.mkdir()
    with pytest.raises(InputError, match="no results for sequence SYN"):
        evaluate(out, [seq])
    (out / "SYN.txt").write_text("1,1,10,10,20,40,1,-1,-1,-1\n2,1,12,10,20,40,1,-1,-1,-1\n")
    report = evaluate(out, [seq])
    s = report.sequences["SYN"]
    assert report.benchmark["SYN"] == "MOT16"  # 9 columns: MOT16 rules, the consider=0 row ignored
    assert s["HOTA"] == pytest.approx(100.0) and s["MOTA"] == pytest.approx(100.0) and s["FN"] == 0
    assert "SYN" in format_table(report)


def test_mot15_rules_leave_out_a_person_marked_0_and_count_a_box_on_them_as_false(tmp_path):
    """What `sotmot eval` says of the MOT15 rules: a ground-truth row whose 7th column is 0 is no one to find, and
    an output box on that person is a false positive (PETS09-S2L1 marks its far walkers so)."""
    gt = ["1,1,10,10,20,40,1,-1,-1,-1", "1,2,60,10,20,40,0,-1,-1,-1"]  # 10 columns: the 2DMOT2015 layout
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,40,1"], length=1, gt_lines=gt, images=False)
    out = tmp_path / "res"
    out.mkdir()
    (out / "SYN.txt").write_text("1,1,10,10,20,40,1,-1,-1,-1\n1,2,60,10,20,40,1,-1,-1,-1\n")
    report = evaluate(out, [seq])
    s = report.sequences["SYN"]
    assert report.benchmark["SYN"] == "MOT15"
    assert (s["FP"], s["FN"]) == (1, 0) and s["MOTA"] == pytest.approx(0.0)


def test_malformed_results_are_reported_with_file_and_line(tmp_path):
    seq = write_sequence(tmp_path, ["1,-1,10,10,20,40,1"], length=2, gt_lines=["1,1,10,10,20,40,1,1,1"],
                         images=False)
    out = tmp_path / "res"
    out.mkdir()
    (out / "SYN.txt").write_text("1,1,10,10,20,40,1,-1,-1,-1\n3,1,10,10,20,40,1,-1,-1,-1\n")
    with pytest.raises(InputError, match=r"SYN.txt:2: frame 3 is outside 1..2"):
        evaluate(out, [seq])


def test_frame_errors_count_what_trackeval_counts():
    # the per-frame matching used for drawing errors must agree with TrackEval's CLEAR numbers
    from sotmot.scoring import frame_errors

    path = tud_campus()
    totals = frame_errors(path / "test.txt", path / "gt.txt", 71, "TUD-Campus").totals()
    assert (totals["FP"], totals["FN"], totals["IDSW"]) == (13, 150, 7)


def test_miss_positions_say_gap_end_or_never(tmp_path):
    # person 1 is matched by track 7 at frames 1 and 4, missed at 2-3 (inside that trajectory), matched by track 8
    # at frame 6 (missed at 5: between two trajectories) and missed at 7-8 (past its end); person 2 is never
    # matched, so it needs a trajectory of its own
    from sotmot.scoring import frame_errors

    gt = [f"{f},1,10,10,20,40,1,1,1" for f in range(1, 9)] + [f"{f},2,40,5,10,20,1,1,1" for f in (2, 3)]
    seq = write_sequence(tmp_path, [], length=8, width=64, height=48, gt_lines=gt, images=False)
    results = tmp_path / "res.txt"
    results.write_text("".join(f"{f},{t},10,10,20,40,1,-1,-1,-1\n" for f, t in ((1, 7), (4, 7), (6, 8))))
    errors = frame_errors(results, seq / "gt" / "gt.txt", 8, "SYN")
    positions = errors.miss_positions()
    person = {f: dict(zip(errors.missed_ids[f], positions[f])) for f in positions}
    one = errors.identities[1, 7]
    two = next(g for g in person[2] if g != one)
    assert [person[f][one] for f in (2, 3, 5, 7, 8)] == [("gap", 1), ("gap", 1), ("link", 1), ("end", 1),
                                                          ("end", 2)]
    assert person[2][two] == person[3][two] == ("never", -1)
    assert sum(map(len, positions.values())) == errors.totals()["FN"] == 7
