"""Graph export and explanations: the decisions of a run, in files and in words."""

import dataclasses
import math
import re
import shutil
import subprocess

import cv2
import networkx as nx
import pytest

from conftest import GeometryEmbedder, write_sequence
from sotmot.config import TrackerConfig
from helpers import tk
from sotmot.inspect.explain import explain, explain_gaps, export_graph, inspection_graph
from sotmot.inspect.graph_view import draw_png, tracklet_crops, write_html
from sotmot.pipeline import track_sequence

# these tests are about association: the confirmation stage (which would judge four boxes of
# score 0.9 too weak to keep) is off
ASSOCIATION_ONLY = TrackerConfig().replace("confirm", enabled=False)


def teleport_run(tmp_path):
    # one 20x40 box walks 2 px/frame for frames 1-4, then the same-looking box is 240 px away in
    # frames 5-8: 4 fps gives batches of 4 frames, so two tracklets, and the velocity rule must
    # refuse to join them (240 px in 1 frame against a bound of w = 20 px/frame)
    lines = [f"{f},-1,{10 + 2 * f},50,20,40,0.9" for f in range(1, 5)]
    lines += [f"{f},-1,{250 + 2 * f},50,20,40,0.9" for f in range(5, 9)]
    seq = write_sequence(tmp_path, lines, length=8, frame_rate=4, width=320, height=120)
    config = ASSOCIATION_ONLY
    return config, track_sequence(seq, config, embedder=GeometryEmbedder())


def test_velocity_rejection_is_exported_and_explained(tmp_path):
    config, result = teleport_run(tmp_path)
    assert result.tracks.n_tracks == 2
    graph = inspection_graph(result, config)
    (edge,) = graph.edges(data=True)
    assert edge[2]["failed"] == "velocity" and not edge[2]["taken"]
    text = explain(graph, 1, 2, config)
    assert "REJECTED by velocity" in text
    assert "velocity: 242.00 px/frame" in text and "bound 20.00" in text
    assert "were not merged" in text


def test_graphml_and_json_round_trip(tmp_path):
    config, result = teleport_run(tmp_path)
    graph = inspection_graph(result, config)
    export_graph(graph, tmp_path / "out")
    back = nx.read_graphml(tmp_path / "out" / "graph.graphml", node_type=int)
    assert sorted(back.nodes) == sorted(graph.nodes) and sorted(back.edges) == sorted(graph.edges)
    u, v = next(iter(graph.edges))
    assert back.edges[u, v]["failed"] == "velocity"
    assert back.edges[u, v]["affinity"] == graph.edges[u, v]["affinity"]
    assert back.nodes[u]["track"] == graph.nodes[u]["track"]
    import json

    data = nx.node_link_graph(json.loads((tmp_path / "out" / "graph.json").read_text()), edges="edges")
    assert sorted(data.edges) == sorted(graph.edges)
    assert data.edges[u, v]["velocity_bound"] == graph.edges[u, v]["velocity_bound"]


def test_merged_tracks_are_explained_as_taken(tmp_path):
    lines = [f"{f},-1,{10 + 2 * f},50,20,40,0.9" for f in range(1, 9)]
    seq = write_sequence(tmp_path, lines, length=8, frame_rate=4, width=320, height=120)
    config = ASSOCIATION_ONLY
    result = track_sequence(seq, config, embedder=GeometryEmbedder())
    graph = inspection_graph(result, config)
    text = explain(graph, 1, 1, config)
    assert "TAKEN by greedy in round 1" in text and "were merged" in text
    assert text.count("candidate ") == 1  # one link inside one track, said once
    # what the link adds to the lifted objective: the one pair it joins (affinity 1, 4 boxes each), 4 * 4 times the
    # learned log-likelihood ratio
    c0, c1, c2, c3 = config.association.lifted_coefficients
    gain = 4 * 4 * (c0 + c1 + (c2 + c3) * math.log(4))
    assert f"lifted objective: the link joins 1 scored pair(s) of tracklets, total {gain:+.1f}" in text


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROME_FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                "--disable-background-networking", "--disable-component-update", "--disable-sync",
                "--enable-logging=stderr", "--v=0"]


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (.ci/run installs it)")
def test_html_page_works_in_a_real_headless_browser(tmp_path):
    config, result = teleport_run(tmp_path)
    graph = inspection_graph(result, config)
    page = write_html(graph, tmp_path / "graph.html", tracklet_crops(result, graph), "teleport")
    png = draw_png(graph, tmp_path / "graph.png")
    assert cv2.imread(str(png)) is not None
    profile = ["--user-data-dir=" + str(tmp_path / "profile")]
    url = page.resolve().as_uri() + "#click=edge-0"
    run = subprocess.run([CHROMIUM, *CHROME_FLAGS, *profile, "--dump-dom", url],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-2000:]
    affinity = graph.edges[next(iter(graph.edges))]["affinity"]
    # the click filled the details panel from the page's own data, through the page's script
    shown = re.search(r'class="v-affinity">([^<]+)<', run.stdout)
    assert shown and float(shown.group(1)) == pytest.approx(affinity, abs=1e-4)
    assert 'class="v-failed">velocity<' in run.stdout
    console = [line for line in run.stderr.splitlines() if "CONSOLE" in line or "Uncaught" in line]
    assert not any("rror" in line or "Uncaught" in line for line in console), console
    shot = tmp_path / "shot.png"
    run = subprocess.run([CHROMIUM, *CHROME_FLAGS, *profile, f"--screenshot={shot}", "--window-size=1400,500",
                          url], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0 and shot.is_file() and cv2.imread(str(shot)) is not None


def test_gaps_are_explained_with_the_bound_the_line_check_set(tmp_path):
    config, result = teleport_run(tmp_path)
    config = config.replace("postprocess", line_check_seconds=2.0)
    person = tk(1, [1, 2, 3, 4, 13, 14], [[10, 50, 20, 40]])  # an 8-frame gap: 2 s at 4 fps
    checked = dataclasses.replace(result, trajectories=[person], track_ids=[1],
                                  postprocess=dataclasses.replace(config.postprocess, interpolate_max_seconds=1.0))
    text = explain_gaps(checked, config, 1)
    assert "does not hold over 2 s" in text and "filled up to 1 s" in text and "left empty" in text
    kept = explain_gaps(dataclasses.replace(checked, postprocess=config.postprocess), config, 1)
    assert "does not hold" not in kept and "left empty" not in kept


def test_confirmation_is_explained_from_the_numbers_it_decided_on():
    """`explain --ids N` says how confirmation judged track N: its boxes' P(true), the threshold, what it kept, and
    each feature's share of the log-odds, recomputed exactly as the pipeline scored those boxes."""
    import numpy as np

    from conftest import DATA, require
    from sotmot.confirm import confirmation_threshold
    from sotmot.inspect.explain import FEATURE_WORDS, confirmation_inputs, explain_confirmation
    from sotmot.confidence.box_model import FEATURES

    assert list(FEATURE_WORDS) == list(FEATURES)  # every feature of the model has its words
    seq = require(DATA / "MOT16-02-clip30")
    config = TrackerConfig()
    result = track_sequence(seq, config)
    threshold = confirmation_threshold(config, result.confidence_method)
    assert threshold > 0 and len(result.dropped)  # the clip's DPM boxes: some tracks kept, some dropped
    checked = set()
    for trajectory, track in zip(result.trajectories, result.track_ids):
        if track is None:
            continue
        rows = [r.subset(np.flatnonzero(r.ids == track)) for r in (result.tracks, result.dropped)]
        frames = np.concatenate([r.frames for r in rows])
        confidence = np.concatenate([r.confidence for r in rows])
        scored = np.isfinite(confidence)  # the end extension's boxes come after confirmation, unscored
        model, x = confirmation_inputs(result, config, trajectory)
        assert np.allclose(model.predict(x), confidence[scored][np.argsort(frames[scored], kind="stable")])
        assert np.allclose(model.terms(x).sum(axis=1) + model.intercept,
                           np.log(model.predict(x) / (1 - model.predict(x))))
        text = explain_confirmation(result, config, track)
        p = confidence[scored]
        spread = f"{p.min():.2f}" if f"{p.min():.2f}" == f"{p.max():.2f}" else f"{p.min():.2f} to {p.max():.2f}"
        assert f"boxes P(true) {spread}" in text and f"threshold {threshold:g}" in text
        n_dropped = len(rows[1])
        fate = ("all" if not n_dropped else "mixed") if n_dropped < len(p) else "none"
        assert {"all": f"all {len(p)} kept", "none": f"all {n_dropped} dropped",
                "mixed": f"{len(p) - n_dropped} kept, {n_dropped} dropped"}[fate] in text
        assert all(words in text for words, _ in FEATURE_WORDS.values())
        checked.add(fate)
    assert {"all", "none"} <= checked
    # every track in one table, the least certain first; tracks confirmation dropped whole marked
    from sotmot.inspect.explain import track_table

    table = track_table(result, config).splitlines()
    ids = {int(i) for i in np.concatenate([result.tracks.ids, result.dropped.ids])}
    whole = {int(i) for i in np.unique(result.dropped.ids)} - {int(i) for i in np.unique(result.tracks.ids)}
    assert table[0].startswith(f"{len(ids)} tracks ({len(whole)} of them dropped whole by confirmation), the least "
                               f"certain first; confirmation's threshold {threshold:g}")
    rows = [line.split() for line in table[2:]]
    assert sorted(int(r[0]) for r in rows) == sorted(ids)
    medians = [float(r[6]) for r in rows]
    assert medians == sorted(medians)
    assert whole and {int(r[0]) for r in rows if "(dropped whole)" in " ".join(r)} == whole
    for r in rows:  # boxes = detected + interpolated + SOT, as the flags say
        assert int(r[2]) == int(r[3]) + int(r[4]) + int(r[5])
    assert ", by id (confirmation off: no P(true));" in track_table(result, config.replace("confirm", enabled=False))
    zero = explain_confirmation(result, config.replace("confirm", threshold=0.0), track)
    assert "threshold 0 ([confirm] threshold, --confirm-threshold): it drops no box" in zero
    assert "packaged fit" not in zero  # the remark on the packaged fit's threshold 0 is for that one alone
    off = config.replace("confirm", enabled=False)
    assert "confirmation: off" in explain_confirmation(result, off, result.track_ids[0] or 1)

    # one track's links: the taken and the rejected ones each explained, the allowed ones it did not need counted
    graph = inspection_graph(result, config)
    counts = {}
    for u, v, d in graph.edges(data=True):
        if graph.nodes[u]["track"] == graph.nodes[v]["track"] >= 0:
            kind = "taken" if d["taken"] else "allowed" if d["allowed"] else "rejected"
            counts.setdefault(graph.nodes[u]["track"], {"taken": 0, "allowed": 0, "rejected": 0})[kind] += 1
    track, n = max(counts.items(), key=lambda item: item[1]["allowed"])
    assert n["allowed"], "a track with links past its tracklets: the case to test"
    text = explain(graph, track, track, config)
    assert text.count("\ncandidate ") == n["taken"] + n["rejected"] == text.count("TAKEN") + text.count("REJECTED")
    assert f"{n['allowed']} other candidate link(s) between these tracklets passed every rule but were not " \
           f"taken" in text
    assert "in short:" not in text  # one track: its taken links are the story

    # two tracks: every candidate link between them said, then how they ended, counted in one line
    between = {}
    for u, v in graph.edges:
        a, b = graph.nodes[u]["track"], graph.nodes[v]["track"]
        if a >= 0 and b >= 0 and a != b:
            between[tuple(sorted((a, b)))] = between.get(tuple(sorted((a, b))), 0) + 1
    pair, links = max(between.items(), key=lambda item: item[1])
    assert links > 1
    text = explain(graph, *pair, config)
    summary = next(line for line in text.splitlines() if line.startswith("in short:"))
    assert summary.startswith(f"in short: {links} candidate links between them, ")
    assert sum(int(part.split()[0]) for part in summary.split("between them, ")[1].split(", ")) == links
    assert text.count("\ncandidate ") == links


def test_without_re_id_the_affinity_is_said_to_be_the_walks_and_the_speed_limit_named(tmp_path):
    # one person (20 x 40 px) walking 2 px a frame at 20 fps, 1 height a second, unseen for 1.5 s in the middle:
    # the walk's line leads across the gap and the velocity rule allows it, but the motion-only mode refuses a
    # join over 1 s above 0.75 heights a second, and the explanation says why its affinity is 0
    lines = [f"{f},-1,{10 + 2 * f},50,20,40,0.9" for f in [*range(1, 21), *range(51, 71)]]
    seq = write_sequence(tmp_path, lines, length=70, frame_rate=20, width=320, height=120, images=False)
    config = ASSOCIATION_ONLY.replace("appearance", backend="none")
    result = track_sequence(seq, config)
    graph = inspection_graph(result, config)
    assert graph.graph["motion_only"] and result.tracks.n_tracks == 2
    text = explain(graph, 1, 2, config)
    assert "no re-ID (motion only)" in text and "more than 0.75 of their heights a second" in text
    assert "affinity: 0.000" in text and "REJECTED by affinity" in text
    unlimited = config.replace("association", motion_gap_speed=None)
    assert track_sequence(seq, unlimited).tracks.n_tracks == 1  # the walk's line alone joins them
    re_id_config, re_id_result = teleport_run(tmp_path / "re-id")
    assert "motion_only" not in inspection_graph(re_id_result, re_id_config).graph


def test_a_frame_range_past_the_end_says_what_the_frames_count_at_a_step():
    from sotmot.errors import SotmotError
    from sotmot.inspect.explain import parse_frames

    assert parse_frames("3:9", 10) == (3, 9) and parse_frames(None, 10) is None
    with pytest.raises(SotmotError, match="the sequence has frames 1 to 10 only"):
        parse_frames("11:20", 10)
    with pytest.raises(SotmotError, match=r"at step 3 the tracked frames are 1 to 10 only \(frame k is the "
                                          r"sequence's 1 \+ \(k - 1\) \* 3\)"):
        parse_frames("11:20", 10, step=3)
