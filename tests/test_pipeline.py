"""The whole pipeline on synthetic sequences: invariants checked with hypothesis."""

import math
import tempfile
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import GeometryEmbedder, write_sequence
from sotmot.config import PreprocessConfig, TrackerConfig, config_from_dict
from sotmot.io import format_results, read_detections
from sotmot.pipeline import track_sequence
from sotmot.preprocess import preprocess

PEOPLE = st.lists(st.tuples(st.integers(0, 250), st.integers(0, 150), st.integers(-6, 6), st.integers(-3, 3),
                            st.integers(15, 40), st.integers(1, 12), st.integers(0, 10)),
                  min_size=1, max_size=6)


def det_lines(people, length):
    lines = []
    for x, y, vx, vy, w, first, dur in people:
        for f in range(first, min(length, first + dur) + 1):
            t = f - first
            lines.append(f"{f},-1,{x + vx * t},{y + vy * t},{w},{2 * w},{0.5 + w / 100:.2f},-1,-1,-1")
    return lines


def run(lines, length=12):
    with tempfile.TemporaryDirectory() as tmp:
        seq = write_sequence(Path(tmp), lines, length=length, frame_rate=4, width=320, height=240)
        # association only: the confirmation stage has tests of its own (test_confidence.py)
        result = track_sequence(seq, TrackerConfig().replace("confirm", enabled=False), embedder=GeometryEmbedder())
    return result


@settings(max_examples=25, deadline=None)
@given(PEOPLE, st.randoms())
def test_one_box_per_id_per_frame_and_independent_of_line_order(people, rnd):
    lines = det_lines(people, 12)
    if not lines:
        return
    tracks = run(lines).tracks
    pairs = list(zip(tracks.frames.tolist(), tracks.ids.tolist()))
    assert len(pairs) == len(set(pairs))
    shuffled = lines[:]
    rnd.shuffle(shuffled)
    assert format_results(run(shuffled).tracks) == format_results(tracks)


def test_two_people_walking_become_two_tracks_across_batches():
    people = [(10, 50, 3, 0, 20, 1, 11), (200, 60, -3, 0, 30, 1, 11)]
    result = run(det_lines(people, 12))
    # 4 fps: batches of 4 frames, so each person starts as 3 tracklets that the greedy merge joins
    assert len(result.tracklets) == 6
    assert result.tracks.n_tracks == 2
    assert len(result.tracks) == 24


def test_preprocess_threshold_and_auto_nms(tmp_path):
    lines = ["1,-1,0,0,100,200,1.5", "1,-1,10,10,30,60,0.9", "1,-1,300,0,50,100,-0.5"]
    seq = write_sequence(tmp_path, lines, images=False)
    d = read_detections(seq / "det" / "det.txt", 5)
    # scores outside [0, 1] -> IoM: the small box inside the big one goes
    assert preprocess(d, PreprocessConfig()).scores.tolist() == [1.5, -0.5]
    assert preprocess(d, PreprocessConfig(nms="iou")).scores.tolist() == [1.5, 0.9, -0.5]
    assert preprocess(d, PreprocessConfig(score_threshold=0.0)).scores.tolist() == [1.5]


def test_a_frame_missing_while_embedding_is_the_reader_s_error(tmp_path):
    # frames are decoded in a background thread ahead of the re-ID model: its error must still reach the caller
    from sotmot.errors import InputError
    from sotmot.io import read_seqinfo
    from sotmot.passes import embed_detections

    seq = write_sequence(tmp_path, [f"{f},-1,10,10,5,8,0.9" for f in range(1, 5)], length=4)
    (seq / "img1" / "000003.jpg").unlink()
    info = read_seqinfo(seq)
    dets = read_detections(info.det_path, info.length)
    with pytest.raises(InputError, match="frame 3 is missing"):
        embed_detections(info, dets, GeometryEmbedder())
    timings = {}
    good = embed_detections(info, dets.subset([0, 1, 3]), GeometryEmbedder(), timings=timings)
    assert good.shape == (3, GeometryEmbedder().dim)
    assert timings["decode"] > 0  # the reading time, measured in the decoding thread


def test_the_gap_limit_in_seconds_follows_the_frame_rate(tmp_path):
    """[association] l_max_seconds: the longest gap association bridges, in seconds at the sequence's frame rate
    (l_max counts frames). One person, unseen for 3 s (30 frames at 10 fps): the paper's 60 frames bridge it, 2 s
    does not, 4 s does; explain names the limit in frames that the run used."""
    import numpy as np

    from sotmot.inspect.explain import explain, inspection_graph

    seen = [*range(1, 21), *range(51, 71)]
    seq = write_sequence(tmp_path, [f"{f},-1,{10 + 3 * f},40,20,40,0.9" for f in seen], length=70, frame_rate=10,
                         width=320, height=120)
    base = TrackerConfig().replace("confirm", enabled=False).replace("ends", seconds=0.0)
    tracks = {}
    for label, seconds in (("frames", None), ("2 s", 2.0), ("4 s", 4.0)):
        config = base.replace("association", l_max_seconds=seconds)
        result = track_sequence(seq, config, embedder=GeometryEmbedder())
        tracks[label] = result.tracks.n_tracks
        if label == "2 s":
            ids = np.unique(result.tracks.ids).tolist()
            assert "more than l_max = 20 frames apart" in explain(inspection_graph(result, config), *ids, config)
    assert tracks == {"frames": 1, "2 s": 2, "4 s": 1}
    assert base.association.l_max_seconds == 4.0  # the default counts seconds
    resolved = base.association.at(7.0)
    assert (resolved.l_max, resolved.l_max_seconds) == (28, None)  # in frames, so a solver may narrow it
    frames = base.replace("association", l_max=45).association  # a gap given in frames alone counts frames
    assert frames.l_max_seconds is None and frames.at(10.0).l_max == 45 and frames.at(7.0).l_max == 45
    both = base.replace("association", l_max=45, l_max_seconds=3.0).association  # both given: seconds win
    assert both.at(10.0).l_max == 30
    assert config_from_dict({"association": {"l_max": 45}}).association.at(30.0).l_max == 45
    assert config_from_dict({"association": {"min_affinity": 0.5}}).association.at(30.0).l_max == 120


@pytest.mark.parametrize("case", ["defaults", "sot template", "weak boxes at ends", "detector"])
def test_once_the_plan_is_made_no_stage_replaces_configuration(case, model_0288, monkeypatch):
    """Issue #40: every "auto" is decided by sotmot.plan.resolve; the stages read the plan, so nothing builds a
    changed copy of a configuration section (dataclasses.replace, TrackerConfig.replace) while the run goes on."""
    import dataclasses

    from conftest import DATA, MODELS, require
    from sotmot.config import SECTIONS
    from sotmot.io import read_seqinfo
    from sotmot.pipeline import track_plan
    from sotmot.plan import resolve

    seq = require(DATA / "MOT16-05-clip30")
    config = TrackerConfig().replace("appearance", model=str(model_0288))
    if case == "sot template":
        config = config.replace("sot", variant="template")
    elif case == "weak boxes at ends":  # public, refined: the detector on the frames the searches visit
        pytest.importorskip("openvino")
        detector = require(MODELS / "person-detection-0202" / "person-detection-0202.FP16-INT8.xml")
        config = config.replace("detection", weak_boxes="on", model=str(detector))
    elif case == "detector":
        pytest.importorskip("openvino")
        detector = require(MODELS / "person-detection-0202" / "person-detection-0202.FP16-INT8.xml")
        config = config.replace("detection", source="model", model=str(detector))
    plan = resolve(config, read_seqinfo(seq))
    replaced: list[str] = []
    original = dataclasses.replace
    kinds = (TrackerConfig, *SECTIONS.values())

    def watching(obj, /, **changes):
        if isinstance(obj, kinds):
            replaced.append(f"{type(obj).__name__}({', '.join(changes)})")
        return original(obj, **changes)

    monkeypatch.setattr(dataclasses, "replace", watching)
    result = track_plan(plan)
    assert len(result.tracks) and replaced == []
    # the watch itself works: a replace of a section is seen
    config.replace("ends", seconds=0.5)
    assert replaced == ["TrackerConfig(ends)"]


def test_one_run_enters_each_stage_module_at_most_twice(tmp_path):
    """Issue #40: traced through one run of track_sequence, the pipeline calls into each module of sotmot at most
    twice (consecutive calls into one module are one entry): the data goes forward through the stages, not back
    and forth. sotmot.types is left out: its calls are methods of the detections and tracks themselves."""
    import collections
    import sys

    lines = [f"{f},-1,{10 + 2 * f},20,20,40,0.95" for f in range(1, 9)] + \
            [f"{f},-1,{90 - 2 * f},30,20,40,0.9" for f in range(1, 11)]
    seq = write_sequence(tmp_path, lines, length=10, frame_rate=4, width=120, height=80)
    entries: list[str] = []

    def watch(frame, event, arg):
        if event != "call" or frame.f_back is None or frame.f_back.f_globals.get("__name__") != "sotmot.pipeline":
            return
        module = frame.f_globals.get("__name__", "")
        if module.startswith("sotmot") and module not in ("sotmot.pipeline", "sotmot.types") \
                and (not entries or entries[-1] != module):
            entries.append(module)

    sys.setprofile(watch)
    try:
        result = track_sequence(seq, TrackerConfig(), embedder=GeometryEmbedder())
    finally:
        sys.setprofile(None)
    assert "extend" in result.timings and "sotmot.sot.extend" in entries  # every stage ran, the ends too
    assert {"sotmot.plan", "sotmot.motion", "sotmot.tracklets", "sotmot.confirm"} <= set(entries)
    twice = {m: n for m, n in collections.Counter(entries).items() if n > 2}
    assert not twice, f"entered more than twice: {twice} in {entries}"


def test_where_the_line_does_not_hold_the_run_fills_shorter_gaps():
    # three people whose boxes swing sideways as a camera panning to and fro would move them (nothing to
    # compensate it here): over 2 s the straight line misses them (over 1.5 s it holds), so a 2-s gap of one of
    # them stays empty
    lines = []
    for k in range(3):
        for f in range(1, 121):
            if k == 0 and 61 <= f <= 68:
                continue
            x = 60 + 200 * k + 40 * math.sin(2 * math.pi * f / 12)
            lines.append(f"{f},-1,{x:.2f},{40 + 60 * k},40,80,0.9,-1,-1,-1")
    with tempfile.TemporaryDirectory() as tmp:
        seq = write_sequence(Path(tmp), lines, length=120, frame_rate=4, width=700, height=300)
        config = TrackerConfig().replace("confirm", enabled=False)  # the default: the line checked over 2 s
        trust = config.replace("postprocess", line_check_seconds=None)
        checked = track_sequence(seq, config, embedder=GeometryEmbedder())
        trusting = track_sequence(seq, trust, embedder=GeometryEmbedder())
    assert checked.postprocess.interpolate_max_seconds == 1.5 and trusting.postprocess == trust.postprocess
    # the gap is bridged either way; trusting the line, its 8 frames are filled
    assert [len(t) for t in checked.trajectories] == [112, 120, 120] == [len(t) for t in trusting.trajectories]
    assert trusting.tracks.interpolated.sum() == 8 and checked.tracks.interpolated.sum() == 0
