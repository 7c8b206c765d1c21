"""Detection confidence, box confirmation and the interpolation bound (issue: tell true detections from false)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import ROOT, GeometryEmbedder, write_sequence
from helpers import tk
from sotmot.confidence.box_model import FEATURES, BoxModel
from sotmot.confidence.calibration import load_calibration
from sotmot.confidence.maps import confidence_knots, detection_confidence, detector_family, isotonic
from sotmot.config import PostprocessConfig, TrackerConfig
from sotmot.errors import ConfigError
from sotmot.fitting.logistic import fit_box_model
from sotmot.postprocess import expand, interpolate

SCORES = st.lists(st.floats(-5.0, 200.0, allow_nan=False), min_size=1, max_size=60)


@settings(max_examples=60, deadline=None)
@given(SCORES, st.sampled_from(["dpm", "acf", "frcnn", "quantile", "raw", "auto"]))
def test_confidence_is_monotone_and_in_unit_interval_for_every_method(scores, method):
    scores = np.sort(np.asarray(scores))
    used, knots = confidence_knots(method, scores)
    conf = detection_confidence(scores, knots)
    assert np.all((conf >= 0.0) & (conf <= 1.0))
    assert np.all(np.diff(conf) >= 0.0), used


def test_auto_guesses_the_family_from_the_score_range():
    assert detector_family(np.array([0.05, 0.5, 1.0])) == "frcnn"
    assert detector_family(np.array([-0.8, 0.3, 4.2])) == "dpm"
    assert detector_family(np.array([-0.2, 30.0, 120.0])) == "acf"


def test_stored_family_maps_rise_from_weak_to_strong_scores():
    # fitted on real detections: the detector's strongest boxes are far more often right than its weakest
    families = load_calibration().families
    for family, (low, high) in {"dpm": (-0.5, 2.0), "acf": (0.0, 80.0), "frcnn": (0.5, 1.0)}.items():
        xs, ys = map(np.asarray, families[family])
        assert np.interp(high, xs, ys) - np.interp(low, xs, ys) > 0.3, family


def test_quantile_map_is_the_rank_within_the_sequence():
    _, knots = confidence_knots("quantile", np.array([3.0, 1.0, 2.0, 4.0]))
    assert detection_confidence(np.array([1.0, 2.0, 3.0, 4.0]), knots).tolist() == [0.125, 0.375, 0.625, 0.875]


def test_isotonic_pools_violators_by_hand():
    xs, ys = isotonic(np.array([1.0, 2.0, 3.0, 4.0]), np.array([0.0, 1.0, 0.0, 1.0]))
    # (2, 1) and (3, 0) violate the order and pool into one block of mean 0.5 at x = 2.5
    assert xs.tolist() == [1.0, 2.5, 4.0] and ys.tolist() == [0.0, 0.5, 1.0]


def test_unknown_method_and_stale_model_are_clear_errors():
    with pytest.raises(ConfigError, match="confidence must be one of"):
        confidence_knots("magic", np.zeros(3))
    with pytest.raises(ConfigError, match="refit it with scripts/fit_confidence.py"):
        BoxModel.from_dict({"features": ["old"], "mean": [0], "scale": [1], "coef": [0], "intercept": 0})


def test_logistic_fit_recovers_a_separable_direction():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(400, len(FEATURES)))
    y = (x[:, 0] + 0.1 * rng.normal(size=400) > 0).astype(float)
    model = fit_box_model(x, y, l2=1.0)
    assert model.coef[0] > 5 * max(abs(c) for c in model.coef[1:])
    assert model.predict(np.eye(len(FEATURES))[:1] * 3)[0] > 0.9


def test_interpolation_fills_only_gaps_up_to_the_bound():
    frames = np.array([1, 3, 10, 12])
    boxes = np.tile([0.0, 0.0, 10.0, 20.0], (4, 1))
    full, _, _, filled = interpolate(frames, boxes, np.ones(4), max_gap=2)
    # the 1 -> 3 and 10 -> 12 gaps (2 frames) are filled, the 3 -> 10 gap (7 frames) is not
    assert full.tolist() == [1, 2, 3, 10, 11, 12]
    assert filled.tolist() == [False, True, False, False, True, False]
    t = tk(1, frames, boxes)
    at_4fps = expand(t, PostprocessConfig(interpolate_max_seconds=0.5), frame_rate=4.0)
    assert at_4fps.frames.tolist() == [1, 2, 3, 10, 11, 12]
    assert expand(t, PostprocessConfig(interpolate_max_seconds=None), 4.0).frames.tolist() == list(range(1, 13))
    assert expand(t, PostprocessConfig(interpolate_max_seconds=2.0), 4.0).frames.tolist() == list(range(1, 13))


def _scene(tmp_path, short_score: float, long_score: float):
    """Two people: one detected for 2 frames only, one for all 40 frames; DPM-like scores."""
    lines = [f"{f},-1,20,30,30,60,{short_score}" for f in (5, 6)]
    lines += [f"{f},-1,{150 + f},40,40,80,{long_score + 0.01 * (f % 5)}" for f in range(1, 41)]
    lines += ["1,-1,400,200,10,20,4.0"]  # one strong box elsewhere: the scores span DPM's range
    return write_sequence(tmp_path, lines, length=40, frame_rate=10, width=480, height=240)


def test_short_weak_trajectory_is_dropped_and_long_weak_consistent_one_kept(tmp_path):
    from sotmot.pipeline import track_sequence

    seq = _scene(tmp_path, short_score=-0.4, long_score=-0.1)
    result = track_sequence(seq, TrackerConfig(), embedder=GeometryEmbedder())
    kept = {int(i): int((result.tracks.ids == i).sum()) for i in np.unique(result.tracks.ids)}
    dropped = {int(i): int((result.dropped.ids == i).sum()) for i in np.unique(result.dropped.ids)}
    assert 40 in kept.values(), (kept, dropped)  # the 40-frame person stays, every box
    assert 2 in dropped.values() and 2 not in kept.values(), (kept, dropped)  # the 2-frame one goes
    probabilities = result.dropped.confidence
    assert np.all(probabilities < load_calibration().thresholds["calibrated"])
    off = track_sequence(seq, TrackerConfig().replace("confirm", enabled=False), embedder=GeometryEmbedder())
    assert len(off.tracks) == len(result.tracks) + len(result.dropped) and len(off.dropped) == 0


def test_threshold_zero_keeps_every_box(tmp_path):
    from sotmot.pipeline import track_sequence

    seq = _scene(tmp_path, short_score=-0.4, long_score=-0.1)
    result = track_sequence(seq, TrackerConfig().replace("confirm", threshold=0.0), embedder=GeometryEmbedder())
    assert len(result.dropped) == 0 and np.all(np.isfinite(result.tracks.confidence))


def test_unconfirmed_file_holds_the_dropped_boxes(tmp_path):
    from sotmot.runs import track_one
    from sotmot.io import read_results

    seq = _scene(tmp_path, short_score=-0.4, long_score=-0.1)
    config = TrackerConfig().replace("confirm", low_confidence="file")
    outcome = track_one(str(seq), str(tmp_path / "out"), config, False, embedder=GeometryEmbedder())
    assert outcome.status == "done", outcome.message
    low = read_results(tmp_path / "out" / "SYN.low.txt", 40)
    kept = read_results(tmp_path / "out" / "SYN.txt", 40)
    assert len(low) == 2 and len(kept) == 40 and "2 unconfirmed written to SYN.low.txt" in outcome.message
    flags = (tmp_path / "out" / "SYN.flags.csv").read_text().splitlines()
    assert flags[0].endswith(",confidence") and all(float(line.split(",")[4]) >= 0.5 for line in flags[1:])


def test_fit_script_runs_leave_one_out_on_two_tiny_sequences(tmp_path, model_0288):
    data = tmp_path / "data"
    for name, offset in (("A", 0), ("B", 7)):
        people = [(10 + offset, 20, 2, 40), (120, 30 + offset, -1, 50)]
        lines, gt = [], []
        for pid, (x, y, v, w) in enumerate(people, 1):
            for f in range(1, 13):
                lines.append(f"{f},-1,{x + v * f},{y},{w},{2 * w},{0.6 + 0.03 * pid}")
                gt.append(f"{f},{pid},{x + v * f},{y},{w},{2 * w},1,1,1")
        lines += [f"{f},-1,250,150,20,40,0.55" for f in (3, 4)]  # a false pair
        write_sequence(data, lines, length=12, frame_rate=4, width=320, height=240, name=name, gt_lines=gt)
    out = tmp_path / "fit.json"
    calib = tmp_path / "calib.json"
    proc = subprocess.run([sys.executable, str(ROOT / "scripts" / "fit_confidence.py"), "--data", str(data),
                           "--min-length", "5", "--labels-only", "--model", str(model_0288),
                           "--cache", str(tmp_path / "cache"), "--thresholds", "0.3,0.5",
                           "--json", str(out), "--write", str(calib)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(out.read_text())
    assert set(report["folds"]) == {"A", "B"}
    assert set(report["methods"]["auto"]["held_out"]["sequences"]) == {"A", "B"}
    assert "held out, confidence=auto" in proc.stdout
    fitted = load_calibration(calib)
    assert set(fitted.box_models) == {"calibrated", "quantile"} and "frcnn" in fitted.families


def test_auto_learns_a_family_the_calibration_lacks_from_the_sequence():
    full = load_calibration()
    partial = type(full)({k: v for k, v in full.families.items() if k != "acf"}, full.box_models,
                         full.thresholds, {})
    acf_like = np.array([-0.2, 20.0, 60.0, 120.0])
    assert confidence_knots("auto", acf_like, full)[0] == "acf"
    used, knots = confidence_knots("auto", acf_like, partial)
    assert used == "self"  # ranks until association has run; then the sequence's own map (self_knots)
    np.testing.assert_array_equal(knots[1], confidence_knots("quantile", acf_like)[1][1])
    with pytest.raises(ConfigError, match="no stored calibration for detector family 'acf'"):
        confidence_knots("acf", acf_like, partial)


def test_scores_that_are_all_the_same_make_every_box_one_the_detector_stands_behind(caplog):
    """A detector file that carries no score (-1 or 1 on every row): read as DPM's -1 every box was dropped."""
    for value in (-1.0, 1.0):
        with caplog.at_level("WARNING"):
            method, knots = confidence_knots("auto", np.full(50, value), name="street")
        assert method == "raw" and (detection_confidence(np.full(50, value), knots) == 1.0).all()
        assert f"street: every detection scores {value:g}, so the scores tell nothing" in caplog.text
    assert confidence_knots("auto", np.full(50, -1.0), name="MOT17-04-SDP")[0] == "raw"  # not the name's map
    assert confidence_knots("auto", np.array([-1.0, 0.5, 2.0]))[0] == "dpm"
    assert confidence_knots("auto", np.full(50, 0.9), family="pd0202")[0] == "pd0202"  # a known detector's own


def test_scores_of_two_values_are_a_flag_whose_meaning_the_sequence_teaches(caplog):
    """MOT20's public detections score 0 or 1 (issue #87): read with Faster R-CNN's map, every 0 was a weak box
    and the confirmation dropped 7,635 of MOT20-01's boxes, most of them on people."""
    flags = np.r_[np.zeros(30), np.ones(20)]
    with caplog.at_level("WARNING"):
        assert confidence_knots("auto", flags, name="MOT20-01")[0] == "self"
    assert "two values only (0 and 1)" in caplog.text
    assert confidence_knots("auto", flags, family="pd0202")[0] == "pd0202"  # a known detector: its own map
    assert confidence_knots("frcnn", flags)[0] == "frcnn"  # asked for by name: as asked
    assert confidence_knots("auto", np.r_[flags, 0.5])[0] == "frcnn"  # three values: a detector's scores


def test_the_built_in_detector_has_its_own_map_model_and_threshold_and_needs_all_three():
    """The packaged calibration holds person-detection-0202's family (scripts/fit_detector_confidence.py) beside
    the public families, with its own box model: public runs keep theirs."""
    import json
    from importlib import resources

    from sotmot.confidence.calibration import Calibration, load_calibration, model_kind

    packaged = load_calibration()
    assert "pd0202" in packaged.families and model_kind("pd0202") == "pd0202"
    assert {"calibrated", "quantile", "pd0202"} <= set(packaged.box_models) <= set(packaged.thresholds)
    assert model_kind("frcnn") == model_kind("dpm") == "calibrated"
    assert confidence_knots("auto", np.array([0.5, 0.9]), packaged, "pd0202")[0] == "pd0202"
    assert confidence_knots("auto", np.array([0.5, 0.7, 0.9]), packaged)[0] == "frcnn"  # scores alone: guessed
    data = json.loads(resources.files("sotmot").joinpath("data", "confidence.json").read_text())
    del data["box_models"]["pd0202"]
    with pytest.raises(ConfigError, match="no box model or threshold for pd0202"):
        Calibration.from_dict(data)


def test_a_motchallenge_name_says_the_detector_before_the_scores_are_looked_at():
    from sotmot.confidence.maps import family_from_name

    assert family_from_name("MOT17-04-SDP") == "sdp" and family_from_name("mot17-09-frcnn") == "frcnn"
    assert family_from_name("MOT17-05-DPM") == "dpm"
    assert family_from_name("PETS09-S2L1") is None and family_from_name("MOT16-09") is None
    assert family_from_name("clip") is None
    scores = np.array([0.4, 0.9, 1.0])
    assert detector_family(scores, "MOT17-09-SDP") == "sdp" and detector_family(scores, "walk") == "frcnn"
    assert "sdp" in load_calibration().families  # the packaged calibration has a map for it


def test_self_labels_and_map_come_from_the_trajectories_alone():
    from sotmot.confidence.maps import SELF_MIN_SAMPLES, self_knots, self_labels

    # detections 0..29: one person walking for 3 s at 10 frames/s (strong scores); 30..59: lone boxes (weak scores)
    walking = np.c_[10.0 + 2.0 * np.arange(30), np.tile([10.0, 20, 40], (30, 1))]
    long = tk(1, np.arange(1, 31), walking, det_start=0)
    short = tk(2, np.array([40, 41]), np.tile([200.0, 10, 20, 40], (2, 1)), det_start=60)
    n = 62
    labels = self_labels(n, [long, short], np.zeros(n, bool), frame_rate=10.0)
    assert (labels[:30] == 1).all() and (labels[30:60] == 0).all() and (labels[60:] == 0).all()
    mid = tk(3, np.arange(1, 11), np.tile([300.0, 10, 20, 40], (10, 1)), det_start=0)  # 1 s: neither
    assert (self_labels(10, [mid], np.zeros(10, bool), 10.0) == -1).all()
    # 3 s in one spot (the centre within 19 px, under half the 40 px height): a fixed object or someone waiting
    still = tk(4, np.arange(1, 31), np.c_[300.0 + np.arange(30) % 20, np.tile([10.0, 20, 40], (30, 1))], det_start=0)
    assert (self_labels(30, [still], np.zeros(30, bool), 10.0) == -1).all()
    assert (self_labels(30, [tk(5, np.arange(1, 31), walking, det_start=0)], np.zeros(30, bool), 10.0) == 1).all()
    scores = np.r_[np.linspace(0.6, 1.0, 30), np.linspace(0.1, 0.5, 32)]
    xs, ys = self_knots(scores, labels)
    conf = detection_confidence(scores, (xs, ys))
    assert conf[29] == 1.0 and conf[30] == 0.0  # the strongest score is the long trajectory's, the weakest lone
    assert conf[:30].mean() > 0.8 and conf[30:].mean() < 0.2
    few = labels.copy()
    few[SELF_MIN_SAMPLES // 2:30] = -1
    assert self_knots(scores, few) is None  # too few true ones to fit anything


def test_self_confidence_tracks_a_sequence_end_to_end(tmp_path):
    from sotmot.pipeline import track_sequence

    seq = _scene(tmp_path, short_score=-0.4, long_score=-0.1)
    result = track_sequence(seq, TrackerConfig().replace("preprocess", confidence="self"),
                            embedder=GeometryEmbedder())
    assert 40 in np.unique(result.tracks.ids, return_counts=True)[1]  # the 40-frame person stays whole


def test_a_detections_file_without_scores_tracks_its_people(tmp_path):
    """Every row scored -1 (a detector file that carries none): the 40-frame person is kept, not dropped as a run
    of weak DPM boxes."""
    from sotmot.pipeline import track_sequence

    seq = _scene(tmp_path, short_score=-1.0, long_score=-1.0)
    det = seq / "det" / "det.txt"
    det.write_text("".join(",".join(line.split(",")[:6] + ["-1"]) + "\n" for line in det.read_text().splitlines()))
    result = track_sequence(seq, TrackerConfig(), embedder=GeometryEmbedder())
    assert 40 in np.unique(result.tracks.ids, return_counts=True)[1]
