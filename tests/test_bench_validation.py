"""scripts/bench_validation.py: updating a report with a rerun of some of its groups (``--merge``)."""

from __future__ import annotations

import pytest

from helpers import load_script


def row(hota: float, mota: float) -> dict:
    return {"HOTA": hota, "MOTA": mota, "IDF1": hota}


def report(configs: dict[str, dict[str, tuple[float, float]]], groups: dict[str, str], peers=None) -> dict:
    """A report as the script writes it, with only what the merge reads."""
    return {"machine": "m", "model": "r", "reference": "defaults",
            "configs": {n: {} for n in configs}, "configs_described": {n: n for n in configs},
            "groups": groups, "seconds": {s: 1.0 for s in groups},
            "sequences": {n: {s: row(*v) for s, v in rows.items()} for n, rows in configs.items()},
            "combined": {n: {g: row(0, 0) for g in set(groups.values())} for n in configs},
            "worst": {}, "peers": peers or {}}


def test_a_rerun_group_replaces_its_rows_and_the_worst_sequence_is_recomputed_over_all():
    script = load_script("bench_validation")
    groups = {"A": "frames", "L": "labels"}
    old = report({"defaults": {"A": (60, 70), "L": (40, 40)}, "x": {"A": (59, 70), "L": (41, 41)}}, groups)
    new = report({"defaults": {"L": (45, 45)}, "x": {"L": (43, 46)}}, {"L": "labels"}, peers={"SORT": {}})
    merged = script.merge_reports(old, new)
    assert merged["sequences"]["defaults"] == {"A": row(60, 70), "L": row(45, 45)}  # frames kept, labels rerun
    assert (merged["worst"]["x"]["HOTA"]["worst_sequence"], merged["worst"]["x"]["HOTA"]["worst"]) == ("L", -2)
    assert merged["worst"]["x"]["HOTA"]["sequences_below_-0.5"] == ["A", "L"]  # -1 on the kept row, -2 on the new
    assert merged["worst"]["x"]["MOTA"]["mean"] == pytest.approx(0.5)  # (0 + 1) / 2
    assert merged["peers"] == {"SORT": {}}
    assert merged["groups"] == groups
    merged_before = dict(merged, machine="m (rows not rerun); n (this run's rows)")
    again = script.merge_reports(merged_before, dict(new, machine="n"))
    assert again["machine"] == "m; n (rows not rerun); n (this run's rows)"  # not nested twice


def test_a_new_configuration_must_cover_every_sequence_and_the_reference_must_agree():
    script = load_script("bench_validation")
    old = report({"defaults": {"A": (60, 70), "L": (40, 40)}}, {"A": "frames", "L": "labels"})
    partial = report({"defaults": {"L": (45, 45)}, "y": {"L": (46, 46)}}, {"L": "labels"})
    with pytest.raises(ValueError, match="y would lack rows"):
        script.merge_reports(old, partial)
    other = dict(report({"defaults": {"L": (45, 45)}}, {"L": "labels"}), reference="other")
    with pytest.raises(ValueError, match="reference"):
        script.merge_reports(old, other)


def test_a_loss_counts_against_the_rule_only_beyond_the_sequence_noise_floor():
    script = load_script("bench_validation")
    reference = {"A": row(60, 70), "B": row(50, 50)}
    noise = {"runtime": {"A": row(61.5, 70), "B": row(50.2, 50)}, "jitter1": {"A": row(59, 69), "B": row(50, 50)}}
    floor = script.noise_floor(noise, reference)
    assert floor["A"] == {"HOTA": 1.5, "MOTA": 1.0, "IDF1": 1.5} and floor["B"]["HOTA"] == pytest.approx(0.2)
    per_seq = {"defaults": reference, "x": {"A": row(59, 70), "B": row(49.2, 50)}}  # -1.0 on A, -0.8 on B
    worst = script.worst_of(per_seq, "defaults", ["A", "B"], floor)["x"]["HOTA"]
    assert worst["sequences_below_-0.5"] == ["A", "B"]
    assert worst["below_noise_floor"] == ["B"]  # A's loss is within what a neutral change did to it
    assert "below_noise_floor" not in script.worst_of(per_seq, "defaults", ["A", "B"])["x"]["HOTA"]


def test_a_merge_keeps_the_noise_runs_and_recomputes_the_floor():
    script = load_script("bench_validation")
    groups = {"A": "frames", "L": "labels"}
    old = dict(report({"defaults": {"A": (60, 70), "L": (40, 40)}, "x": {"A": (59, 70), "L": (41, 41)}}, groups),
               noise={"jitter1": {"A": row(61, 70), "L": row(40, 40)}})
    new = dict(report({"defaults": {"L": (40, 40)}, "x": {"L": (38, 40)}}, {"L": "labels"}),
               noise={"jitter1": {"L": row(37, 40)}})
    merged = script.merge_reports(old, new)
    assert merged["noise"]["jitter1"] == {"A": row(61, 70), "L": row(37, 40)}
    assert merged["noise_floor"]["A"]["HOTA"] == 1 and merged["noise_floor"]["L"]["HOTA"] == 3
    assert merged["worst"]["x"]["HOTA"]["below_noise_floor"] == []  # -1 on A (floor 1), -2 on L (floor 3)


def test_the_results_page_shows_each_sequence_noise_floor_and_the_losses_beyond_it():
    script, page = load_script("bench_validation"), load_script("make_results_page")
    groups = {"A": "frames", "L": "labels"}
    data = dict(report({"defaults": {"A": (60, 70), "L": (40, 40)}, "x": {"A": (59, 70), "L": (38, 40)}}, groups),
                noise={"runtime": {"A": row(61.5, 70)}, "jitter1": {"A": row(60, 70), "L": row(40, 40)}})
    data = script.merge_reports(data, report({"defaults": {"L": (40, 40)}, "x": {"L": (38, 40)}}, {"L": "labels"}))
    for rows in [*data["sequences"].values(), *data["combined"].values()]:
        for r in rows.values():
            r.update(FP=7, FN=0)
    text = "\n".join(page.validation_section(data))
    assert "| A | 60.0 / 70.0 / 7 | 59.0 / 70.0 / 7 | 1.50 / 0.00 |" in text
    assert "| L | 40.0 / 40.0 / 7 | 38.0 / 40.0 / 7 | 0.00 / 0.00 |" in text
    assert "| x | -1.50 / -2.00 (L) |" in text and "| 2 / 0 of 2 | 1 / 0 |" in text  # A's -1 is within its floor
    assert "re-ID in the other runtime" in text and "(1 seed)" in text


def test_with_seeds_a_loss_counts_only_where_every_paired_run_shows_it():
    script = load_script("bench_validation")
    runs = {"defaults": [{"A": row(60, 70), "B": row(50, 50)}, {"A": row(59, 70), "B": row(50, 50)}],
            "x": [{"A": row(58, 70), "B": row(49, 50)}, {"A": row(59.2, 70), "B": row(49, 50)}]}  # A: -2, +0.2
    per_seq = {name: {s: script.mean_rows([r[s] for r in rows]) for s in ("A", "B")} for name, rows in runs.items()}
    assert per_seq["x"]["A"] == pytest.approx(row(58.6, 70)) and per_seq["defaults"]["A"]["HOTA"] == 59.5
    worst = script.worst_of(per_seq, "defaults", ["A", "B"], runs=runs)["x"]["HOTA"]
    assert worst["sequences_below_-0.5"] == ["A", "B"]  # the means: -0.9 and -1
    assert worst["below_in_every_run"] == ["B"]  # A gained in the second run


def test_seeds_is_a_report_of_its_own(capsys):
    script = load_script("bench_validation")
    for extra, said in ((["--seeds", "2", "--merge", "old.json", "--json", "new.json"], "not with --merge"),
                        (["--seeds", "2", "--noise"], "not with --merge"), (["--seeds", "-1"], "a count")):
        with pytest.raises(SystemExit):
            script.main(["--model", "r.onnx", *extra])
        assert said in capsys.readouterr().err


def test_private_detections_are_a_report_of_their_own(tmp_path, capsys):
    script, page = load_script("bench_validation"), load_script("make_results_page")
    detector = tmp_path / "det.xml"
    detector.write_text("<net/>")
    for extra, said in ((["--groups", "frames,labels"], "the label-only sequences have none"),
                        (["--seeds", "1"], "--seeds is for the public detections"),
                        (["--peers", "SORT"], "--peers is for the public detections"),
                        (["--detector-model", str(tmp_path / "none.xml")], "no such file")):
        with pytest.raises(SystemExit):
            script.main(["--model", "r.onnx", "--detector-model", str(detector), *extra])
        assert said in capsys.readouterr().err
    public = report({"defaults": {"A": (60, 70)}}, {"A": "frames"})
    private = dict(report({"defaults": {"A": (61, 71)}}, {"A": "frames"}), detections="private: det.xml")
    with pytest.raises(ValueError, match="one report per protocol"):
        script.merge_reports(public, private)
    for rows in [*private["sequences"].values(), *private["combined"].values()]:
        for r in rows.values():
            r.update(FP=7, FN=0)
    text = "\n".join(page.validation_section(dict(private, worst={})))
    assert "### The same from the built-in detector's boxes" in text and "the boxes of det.xml" in text
    assert "| full-length sequences with frames (the detector's boxes, re-ID) | defaults |" in text
