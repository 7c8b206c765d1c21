import dataclasses
import json
import re

import pytest

from sotmot.config import SotConfig, TrackerConfig, config_from_dict, load_config
from sotmot.errors import ConfigError


def test_defaults_are_the_papers_values_where_the_paper_gives_them():
    c = TrackerConfig()
    assert c.preprocess.nms_threshold == 0.6
    assert c.tracklets.batch_seconds == 1.0 and c.tracklets.tail == 5 and c.tracklets.l_min == 1
    a = c.association
    assert (a.tau_iou, a.l_max, a.short_gap) == (0.5, 60, 5)
    assert (a.velocity_adjacent, a.velocity_short, a.velocity_long) == (1.0, 2 / 3, 1 / 3)
    assert c.postprocess.smooth_window == "auto"  # chosen on the validation set; the paper's 3 is one value away


def test_unknown_key_is_an_error_listing_valid_keys(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text("[association]\nlmax = 30\n")
    with pytest.raises(ConfigError) as err:
        load_config(path)
    assert "unknown key(s) lmax" in str(err.value) and "l_max" in str(err.value) and str(path) in str(err.value)


def test_unknown_section_and_bad_types():
    with pytest.raises(ConfigError, match="unknown section"):
        config_from_dict({"asociation": {}})
    with pytest.raises(ConfigError, match="l_max must be an integer"):
        config_from_dict({"association": {"l_max": 2.5}})
    with pytest.raises(ConfigError, match="nms must be one of"):
        config_from_dict({"preprocess": {"nms": "dice"}})
    with pytest.raises(ConfigError, match="tau_iou must be in"):
        config_from_dict({"association": {"tau_iou": 1.5}})


def test_json_and_toml_files_load(tmp_path):
    (tmp_path / "c.json").write_text(json.dumps({"association": {"l_max": 30}, "preprocess": {"score_threshold": 0}}))
    c = load_config(tmp_path / "c.json")
    assert c.association.l_max == 30 and c.preprocess.score_threshold == 0.0
    (tmp_path / "c.toml").write_text("[postprocess]\nsmooth_window = 0\n")
    assert load_config(tmp_path / "c.toml").postprocess.smooth_window == 0
    (tmp_path / "c.toml").write_text('[postprocess]\nsmooth_window = "auto"\n')
    assert load_config(tmp_path / "c.toml").postprocess.smooth_window == "auto"
    for bad in ('"autox"', "2.5", "true"):
        (tmp_path / "c.toml").write_text(f"[postprocess]\nsmooth_window = {bad}\n")
        with pytest.raises(ConfigError, match="smooth_window must be an integer or 'auto'"):
            load_config(tmp_path / "c.toml")
    (tmp_path / "c.yaml").write_text("")
    with pytest.raises(ConfigError, match="must be a .toml or .json"):
        load_config(tmp_path / "c.yaml")


def test_an_optional_number_is_turned_off_by_none_in_toml_and_null_in_json(tmp_path):
    (tmp_path / "c.toml").write_text('[postprocess]\nocclusion_seconds = "none"\ninterpolate_max_seconds = "none"\n')
    c = load_config(tmp_path / "c.toml").postprocess
    assert c.occlusion_seconds is None and c.interpolate_max_seconds is None
    assert TrackerConfig().postprocess.occlusion_seconds == 1.0  # the default is on
    assert config_from_dict({"postprocess": {"occlusion_seconds": None}}).postprocess.occlusion_seconds is None
    with pytest.raises(ConfigError, match="occlusion_seconds must be a finite number"):
        config_from_dict({"postprocess": {"occlusion_seconds": "off"}})
    # "none" means None for numbers only: a string field keeps it as written
    assert config_from_dict({"appearance": {"model": "none"}}).appearance.model == "none"
    (tmp_path / "line.toml").write_text('[postprocess]\nline_check_seconds = 2\n')
    assert load_config(tmp_path / "line.toml").postprocess.line_check_seconds == 2.0
    assert TrackerConfig().postprocess.line_check_seconds == 2.0  # on by default
    assert config_from_dict({"postprocess": {"line_check_seconds": "none"}}).postprocess.line_check_seconds is None
    with pytest.raises(ConfigError, match="line_check_seconds must be in"):
        config_from_dict({"postprocess": {"line_check_seconds": 0}})


def test_replace_validates():
    c = TrackerConfig().replace("association", l_max=10)
    assert c.association.l_max == 10
    with pytest.raises(ConfigError):
        TrackerConfig().replace("association", bogus=1)
    assert TrackerConfig().tracklets.yield_weaker == 0.0  # off: the paper's matching
    with pytest.raises(ConfigError, match="yield_weaker must be in"):
        TrackerConfig().replace("tracklets", yield_weaker=1.5)


def test_importing_the_config_imports_no_plug_in_and_no_numeric_library():
    """The name tables live in the leaf sotmot.plugins: validating a solver, backend or detector name imports none
    of them (issue #23's cycle: config imported the solver and backend registries, which imported config)."""
    import subprocess
    import sys

    code = ("import sys, sotmot.config as c; c.TrackerConfig(); "
            "print(sorted(m.split('.')[0] if not m.startswith('sotmot') else m for m in sys.modules))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    for heavy in ("numpy", "solvers", "sotmot.appearance", "sotmot.detection", "onnxruntime", "openvino", "torch",
                  "ortools", "cv2", "scipy", "networkx"):
        assert f"'{heavy}'" not in loaded, f"importing sotmot.config imported {heavy}"
    assert "'sotmot.plugins'" in loaded


@pytest.mark.parametrize("section, name", [("sot", "tau"), ("sot", "tau_a"), ("ends", "min_affinity"),
                                           ("ends", "min_confidence"), ("ends", "stop_iou")])
def test_every_sot_and_ends_share_is_checked_to_lie_in_0_1(section, name):
    with pytest.raises(ConfigError, match=f"{name} must be in"):
        config_from_dict({section: {name: 1.5}})


def test_the_sot_section_is_algorithm_1_alone():
    """Issue #40: [sot] holds Algorithm 1 as published (at most 12 fields); the trajectory ends have [ends]."""
    assert len(dataclasses.fields(SotConfig)) <= 12
    assert not {f.name for f in dataclasses.fields(SotConfig)} & {"extend_seconds", "verify", "rules", "must_link"}


@pytest.mark.parametrize("old, says", [("extend_seconds = 2.0", "now [ends] seconds"),
                                       ("verify = \"detector\"", "now [detection] weak_boxes"),
                                       ("rules = \"confident\"", "removed: Algorithm 1 runs as the paper publishes"),
                                       ("extend_supported_stop_iou = 0.7", "removed: the detector's weak boxes")])
def test_a_key_that_left_the_sot_section_says_where_it_went(tmp_path, old, says):
    path = tmp_path / "old.toml"
    path.write_text(f"[sot]\nvariant = \"template\"\n{old}\n")
    with pytest.raises(ConfigError, match=re.escape(says)) as failure:
        load_config(path)
    assert str(path) in str(failure.value)


def test_the_frame_rate_the_association_reads_is_the_run_s_not_a_setting(tmp_path):
    path = tmp_path / "rate.toml"
    path.write_text("[association]\nframe_rate = 25\n")
    with pytest.raises(ConfigError, match=re.escape("[association] frame_rate: set by each run")):
        load_config(path)
    empty = config_from_dict({"association": {"frame_rate": None}})  # as a run record holds it
    assert empty.association.frame_rate is None and empty.association.at(12.5).frame_rate == 12.5


def test_gap_refinement_is_gone_and_an_old_file_is_told_why(tmp_path):
    path = tmp_path / "old.toml"
    path.write_text("[ends]\nseconds = 1.0\nrefine_gaps = true\n")
    with pytest.raises(ConfigError, match=re.escape("removed: SOT or the weak boxes inside gaps gained nothing")):
        load_config(path)


def test_the_plan_decides_the_weak_boxes_once(tmp_path):
    """[detection] weak_boxes "auto": on when the detections come from the detector, off for a det.txt; "on"
    refines a public run with the detector at the weak boxes' threshold; the gap limit is in frames."""
    from conftest import write_sequence
    from sotmot.io import read_seqinfo
    from sotmot.plan import resolve
    from sotmot.sot.support import WEAK_MIN_SCORE

    info = read_seqinfo(write_sequence(tmp_path, ["1,-1,10,10,5,8,0.9"], images=False, frame_rate=10))
    public = resolve(TrackerConfig(), info)
    assert (public.source, public.weak_boxes, public.detector, public.weak_detector) == ("file", False, None, None)
    assert public.ends_from == "sot"
    assert public.association.l_max == round(10 * TrackerConfig().association.l_max_seconds)  # seconds at 10 fps
    refined = resolve(TrackerConfig().replace("detection", weak_boxes="on"), info)
    assert refined.weak_boxes and refined.detector is None and refined.weak_detector.min_score == WEAK_MIN_SCORE
    private = resolve(TrackerConfig().replace("detection", source="model"), info)
    assert private.weak_boxes and private.detector.min_score == WEAK_MIN_SCORE and private.ends_from == "detections"
    off = resolve(TrackerConfig().replace("detection", source="model", weak_boxes="off"), info)
    assert not off.weak_boxes and off.detector.min_score == TrackerConfig().detection.min_score


def test_the_gap_limit_in_seconds_is_checked_and_read_from_a_file(tmp_path):
    path = tmp_path / "gap.toml"
    path.write_text("[association]\nl_max_seconds = 4\n")
    assert load_config(path).association.l_max_seconds == 4.0
    with pytest.raises(ConfigError, match="l_max_seconds must be in"):
        TrackerConfig().replace("association", l_max_seconds=0.0)


def test_a_run_record_is_a_configuration_file_with_its_runs_settings(tmp_path, caplog):
    """`--config results/<name>.run.json` runs with that run's settings: the record's config table, a bundled model
    it names by SHA-256 taken from this installation (the recorded path may be another machine's)."""
    import logging

    from sotmot import __version__
    from sotmot.models import MODELS

    ran = TrackerConfig().replace("association", l_max_seconds=3.0, solver="flow").replace("confirm", threshold=0.7)
    elsewhere = "/elsewhere/site-packages/sotmot/models/"
    settings = ran.to_dict()
    settings["appearance"]["model"] = elsewhere + MODELS["reid"].files[0][0]
    settings["detection"]["model"] = "/mine/my-detector.xml"  # not a bundled one: kept as recorded
    record = {"sotmot": __version__, "sequence": "clip", "results_sha256": "0" * 64, "config": settings,
              "reid_model": {"path": settings["appearance"]["model"], "sha256": MODELS["reid"].files[0][1]},
              "detector_model": {"path": "/mine/my-detector.xml", "sha256": "f" * 64}}
    path = tmp_path / "clip.run.json"
    path.write_text(json.dumps(record))
    loaded = load_config(path)
    assert loaded.association == ran.association and loaded.confirm == ran.confirm
    assert loaded.appearance.model == str(MODELS["reid"].path)
    assert loaded.detection.model == "/mine/my-detector.xml"
    assert loaded.replace("appearance", model=None).replace("detection", model=None) == ran
    assert "written by sotmot" not in caplog.text and "read the detections" not in caplog.text
    settings["detection"]["file"] = "/data/clip.det.txt"  # a replayed detections file is an input, said aloud
    path.write_text(json.dumps(record))
    with caplog.at_level(logging.WARNING):
        assert load_config(path).detection.file == "/data/clip.det.txt"
    assert "its run read the detections of clip from /data/clip.det.txt, and so does this one" in caplog.text
    settings["detection"]["file"] = None
    path.write_text(json.dumps({**record, "sotmot": "0.0.1"}))
    with caplog.at_level(logging.WARNING):
        load_config(path)
    assert f"written by sotmot 0.0.1, this is {__version__}" in caplog.text
    assert "other library versions" not in caplog.text  # a record without them (older sotmot) says nothing
    import numpy

    from sotmot.versions import cpu, environment

    ran_on = environment()
    ran_on["packages"]["numpy"] = "1.0"
    ran_on["packages"].pop("ortools", None)
    path.write_text(json.dumps({**record, "environment": ran_on}))
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        load_config(path)
    assert f"or another CPU (numpy 1.0 -> {numpy.__version__}; ortools absent -> " in caplog.text
    assert "CPU " not in caplog.text.split("another CPU", 1)[1]  # the same CPU is not named
    ran_on = environment()
    ran_on["cpu"] = {"model": "Some Other CPU", "features": ["avx2"]}  # re-ID in bf16 rounds otherwise there
    path.write_text(json.dumps({**record, "environment": ran_on}))
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        load_config(path)
    model, features = cpu()
    assert f"(CPU Some Other CPU (avx2) -> {model}" in caplog.text
    assert all(name in caplog.text for name in features)
    del record["results_sha256"]  # not a record: its extra keys are errors, as in any configuration file
    path.write_text(json.dumps(record))
    with pytest.raises(ConfigError, match="outside any"):
        load_config(path)
