"""Why the tracker linked what it linked: the association graph of a run, exported and explained.

The graph is :func:`sotmot.association.candidates.build_graph` with the rejected candidates
kept, annotated with what the solver did: every node (tracklet) carries the
output track id it ended in; an edge is *taken* when its two tracklets ended
in one trajectory, one right after the other (ordered by start, end, id), and
for the greedy merge ``round`` says in which merge round they were joined.
A taken edge also carries what it adds to the lifted objective of
:mod:`sotmot.association.objective` (the one objective every solver is scored on):
``lifted_gain`` and ``lifted_pairs``, the pairs of tracklets the link puts
into one trajectory, as ``a->b:+w`` joined by ``;``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Sequence
from pathlib import Path

import networkx as nx
import numpy as np

from sotmot.appearance import motion_only
from sotmot.config import AssociationConfig, TrackerConfig
from sotmot.association.affinity import WALK_GAP_SECONDS
from sotmot.association.objective import link_pairs
from sotmot.association.merge import link_order_key
from sotmot.association.rules import RULES
from sotmot.confidence.box_model import FEATURES, SHORT_SECONDS, TOP_QUANTILE, BoxModel, box_features, logistic
from sotmot.errors import SotmotError
from sotmot.association.candidates import build_graph
from sotmot.io import write_files_atomic
from sotmot.pipeline import TrackResult
from sotmot.types import Tracklet


def inspection_graph(result: TrackResult, config: TrackerConfig, frames: tuple[int, int] | None = None) -> nx.DiGraph:
    """The annotated association graph of ``result``, optionally of tracklets inside ``frames = (A, B)``.

    Node attributes: ``start``, ``end``, ``length``, ``mean_score``,
    ``sot_boxes`` (boxes added by the SOT step), ``track`` (the id of its track
    in the results file, -1 for a trajectory too short to become a track),
    ``in_results`` (False when confirmation dropped every box of its track:
    the id is then in no results file). Edge attributes: those of
    :func:`~sotmot.association.candidates.build_graph` plus ``taken`` and ``round`` (greedy
    merge order, 0 when not taken or for solvers that decide at once), and on
    taken edges ``lifted_gain`` and ``lifted_pairs`` (see the module docstring).
    Graph attributes: ``l_max``, ``solver``, ``candidate_links`` (edges, the
    rejected ones included), ``tracks_in_results``; ``compensated`` (only when
    the camera moved): every position was compared in the reference frame
    (``[motion]``); ``motion_only`` (only without re-ID): the affinity is the
    two walks' agreement (:func:`~sotmot.association.affinity.motion_affinities`).
    """
    tracklets = result.tracklets
    if frames is not None:
        a, b = frames
        tracklets = [t for t in tracklets if t.end >= a and t.start <= b]
    gaps = config.association.at(result.info.frame_rate)  # the constraints as the solver saw them
    graph = build_graph(tracklets, gaps, include_rejected=True)
    graph.graph["l_max"] = gaps.l_max
    graph.graph["solver"] = config.association.solver
    graph.graph["candidate_links"] = graph.number_of_edges()
    written = {int(i) for i in np.unique(result.tracks.ids)}
    graph.graph["tracks_in_results"] = len(written)
    if result.motion is not None and result.motion.moving:  # a still camera's graph stays as it was
        graph.graph["compensated"] = True
    if motion_only(result.features):  # likewise a graph with re-ID
        graph.graph["motion_only"] = True
    track_of = {}
    for group, track in zip(result.association.groups, result.track_ids):
        for t in group:
            track_of[t] = -1 if track is None else track
    for t in tracklets:
        graph.nodes[t.id]["track"] = track_of.get(t.id, -1)
        graph.nodes[t.id]["in_results"] = track_of.get(t.id, -1) in written
        graph.nodes[t.id]["sot_boxes"] = int(result.detections.from_sot[t.det_index].sum())
    nx.set_edge_attributes(graph, False, "taken")
    nx.set_edge_attributes(graph, 0, "round")
    by_id = {t.id: t for t in result.tracklets}
    chains = [sorted((by_id[t] for t in group), key=link_order_key) for group in result.association.groups]
    rounds = _join_rounds(result.association, [(a.id, b.id) for chain in chains for a, b in zip(chain, chain[1:])])
    for chain in chains:
        for k in range(len(chain) - 1):
            u, v = chain[k].id, chain[k + 1].id
            if graph.has_edge(u, v):
                pairs = link_pairs(chain, k, gaps)
                graph.edges[u, v].update(taken=True, round=rounds.get((u, v), 0),
                                         lifted_gain=float(sum(w for _, _, w in pairs)),
                                         lifted_pairs=";".join(f"{a}->{b}:{w:+.1f}" for a, b, w in pairs))
    return graph


def _join_rounds(association, pairs: list[tuple[int, int]]) -> dict[tuple[int, int], int]:
    """For each ``(u, v)`` of ``pairs``: the round in which the solver's links first put both in one trajectory.

    Replays the links once, in order, merging member lists (smaller into
    larger); when two groups join, every asked pair split between them gets
    that link's round. Solvers whose links carry no round give 0.
    """
    partner: dict[int, list[int]] = {}
    for u, v in pairs:
        partner.setdefault(u, []).append(v)
        partner.setdefault(v, []).append(u)
    group_of: dict[int, int] = {}
    members: dict[int, list[int]] = {}
    rounds: dict[tuple[int, int], int] = {}
    for link in association.links:
        ga, gb = group_of.setdefault(link.a, link.a), group_of.setdefault(link.b, link.b)
        members.setdefault(ga, [ga])
        members.setdefault(gb, [gb])
        if ga == gb:
            continue
        if len(members[ga]) < len(members[gb]):
            ga, gb = gb, ga
        for x in members[gb]:
            for y in partner.get(x, ()):
                if group_of.get(y, y) == ga:
                    rounds[(x, y)] = rounds[(y, x)] = link.round
        for x in members[gb]:
            group_of[x] = ga
        members[ga].extend(members.pop(gb))
    return rounds


def json_scalar(value, digits: int | None = None, nonfinite: str | None = "text"):
    """GraphML and JSON friendly scalars: numpy types to Python, floats rounded to ``digits`` decimals if given;
    NaN and inf as ``nonfinite`` says: ``"text"`` (``"nan"``, for a page that shows them), ``"keep"`` (floats,
    for GraphML) or None (JSON's null)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            return {"text": str(float(value)), "keep": float(value), None: None}[nonfinite]
        return float(value) if digits is None else round(float(value), digits)
    return value


def export_graph(graph: nx.DiGraph, out_dir: str | Path) -> list[Path]:
    """Write ``graph.graphml`` and ``graph.json`` (networkx node-link) into ``out_dir``, both or neither."""
    files = {Path(out_dir) / name: data for name, data in graph_files(graph).items()}
    write_files_atomic(files)
    return list(files)


def graph_files(graph: nx.DiGraph) -> dict[str, bytes]:
    """``graph.graphml`` and ``graph.json`` (networkx node-link) of ``graph``: file name -> bytes.

    A measurement that does not exist (an affinity without re-ID, a velocity of a one-box tracklet: NaN) stays a
    number in GraphML (its key typed ``double``, read back as NaN) and is ``null`` in the JSON, which has no NaN;
    neither file holds it as text."""

    def clean(nonfinite) -> nx.DiGraph:
        out = nx.DiGraph(**{key: json_scalar(value, nonfinite=nonfinite) for key, value in graph.graph.items()})
        for n, data in graph.nodes(data=True):
            out.add_node(n, **{key: json_scalar(value, nonfinite=nonfinite) for key, value in data.items()})
        for u, v, data in graph.edges(data=True):
            out.add_edge(u, v, **{key: json_scalar(value, nonfinite=nonfinite) for key, value in data.items()})
        return out

    linked = nx.node_link_data(clean(None), edges="edges")
    return {"graph.graphml": ("\n".join(nx.generate_graphml(clean("keep"))) + "\n").encode("utf-8"),
            "graph.json": (json.dumps(linked, indent=1, allow_nan=False) + "\n").encode("utf-8")}


def _verdict(data: dict, gaps: AssociationConfig) -> list[str]:
    """One line per rule of :data:`~sotmot.association.rules.RULES`: its measurement in words, then ok or FAILS."""
    return [f"{rule.describe(data, gaps)} -> {'ok' if data[f'ok_{rule.name}'] else 'FAILS'}" for rule in RULES]


def fate(data: dict) -> str:
    """Where a tracklet (node ``data`` of :func:`inspection_graph`) ended, in the results file's words."""
    if data.get("track", -1) < 0:
        return "in no track (its trajectory was too short to be kept)"
    if not data.get("in_results", True):
        return f"in track {data['track']}, which is not in the results (confirmation dropped every box of it)"
    return f"in track {data['track']}"


def explain(graph: nx.DiGraph, track_a: int, track_b: int, config: TrackerConfig) -> str:
    """Plain words on why output tracks ``track_a`` and ``track_b`` (ids as in the results file) were not merged,
    or, with ``track_a == track_b``, why that track's tracklets were merged into one."""
    members = {}
    for track in (track_a, track_b):
        members[track] = sorted(n for n, d in graph.nodes(data=True) if d.get("track") == track)
        if not members[track]:
            raise SotmotError(f"track {track} has no tracklet in this run: no output track has that id (the "
                              f"results file's second column holds the ids)")
    tracks = list(dict.fromkeys((track_a, track_b)))
    head = "; ".join(f"track {track}: tracklets {members[track]}" for track in tracks)
    notes = [f"  track {track} is not in the results: confirmation dropped every box of it (more likely false than "
             f"true)" for track in tracks if not graph.nodes[members[track][0]].get("in_results", True)]
    if track_a == track_b:
        verdict = (f"-> the {len(members[track_a])} tracklets of track {track_a} were merged "
                   f"({config.association.solver})." if len(members[track_a]) > 1 else
                   f"-> track {track_a} is one tracklet: there was nothing to merge.")
    else:
        verdict = f"-> tracks {track_a} and {track_b} were not merged ({config.association.solver})."
    return _explain_members(graph, members[track_a], members[track_b], config, head, notes, verdict)


def explain_tracklets(graph: nx.DiGraph, a: int, b: int, config: TrackerConfig) -> str:
    """Plain words on why tracklets ``a`` and ``b`` (the ids ``sotmot graph`` draws) were or were not merged."""
    for t in (a, b):
        if t not in graph:
            raise SotmotError(f"tracklet {t} is not one of this run's tracklets ({graph.number_of_nodes()}, ids "
                              f"{min(graph, default=0)}-{max(graph, default=0)}); 'sotmot graph' draws them with "
                              f"their ids")
    da, db = graph.nodes[a], graph.nodes[b]
    same = da.get("track", -1) >= 0 and da.get("track") == db.get("track")
    head = f"tracklet {a} ended {fate(da)}; tracklet {b} ended {fate(db)}"
    verdict = (f"-> tracklets {a} and {b} were merged into track {da['track']} ({config.association.solver})."
               if same else f"-> tracklets {a} and {b} were not merged ({config.association.solver}).")
    return _explain_members(graph, [a], [b], config, head, [], verdict)


def _explain_members(graph: nx.DiGraph, first: list[int], second: list[int], config: TrackerConfig, head: str,
                     notes: list[str], verdict: str) -> str:
    """The explanation of every candidate link between the tracklets ``first`` and ``second`` (each pair once)."""
    # the gap limit the graph was built with (``l_max_seconds`` at the sequence's frame rate)
    gaps = dataclasses.replace(config.association, l_max=graph.graph.get("l_max", config.association.l_max),
                               l_max_seconds=None)
    out = [head, *notes]
    if graph.graph.get("compensated"):
        out.append("  the camera moved: IoU, velocity and gaps below are measured after camera-motion compensation, "
                   "in frame 1's pixels")
    if graph.graph.get("motion_only"):
        speed = config.association.motion_gap_speed
        out.append("  no re-ID (motion only): the affinity below is how well the two walks agree" + (
            "" if speed is None else f"; across a gap of more than {WALK_GAP_SECONDS:g} s it is 0 where the person "
                                     f"would have moved more than {speed:g} of their heights a second"))
    for t in dict.fromkeys(first + second):
        d = graph.nodes[t]
        out.append(f"  tracklet {t}: frames {d['start']}-{d['end']}, {d['length']} boxes "
                   f"({d['sot_boxes']} from SOT), mean score {d['mean_score']:.2f}")
    pairs = {tuple(sorted((u, v))) for u in first for v in second if u != v}  # each unordered pair once
    found = skipped = 0
    states: dict[str, int] = {}  # how each candidate link ended, counted for the summary
    for u, v in sorted(pairs):
        for x, y in ((u, v), (v, u)):
            if not graph.has_edge(x, y):
                continue
            found += 1
            data = graph.edges[x, y]
            if first == second and data["allowed"] and not data["taken"]:
                skipped += 1  # one track: a link past a tracklet between them, which the taken links join
                continue
            rounds = f" in round {data['round']}" if data["round"] else ""
            state = (f"TAKEN by {config.association.solver}" + rounds) \
                if data["taken"] else ("allowed, not taken" if data["allowed"] else
                                       f"REJECTED by {data['failed'].replace(',', ', ')}")
            outcome = "taken" if data["taken"] else "allowed but not taken" if data["allowed"] else \
                f"refused by {data['failed'].replace(',', ' and ')}"
            states[outcome] = states.get(outcome, 0) + 1
            out.append(f"candidate {x} -> {y}: {state}")
            if data.get("overlap_frames"):
                out.append(f"    the two share {data['overlap_frames']} frames: merged, their boxes would alternate "
                           f"between two places, so IoU decides; the gap and velocity below measure those jumps")
            out.extend("    " + line for line in _verdict(data, gaps))
            if data.get("lifted_pairs"):
                shown = data["lifted_pairs"].split(";")
                out.append(f"    lifted objective: the link joins {len(shown)} scored pair(s) of tracklets, "
                           f"total {data['lifted_gain']:+.1f}: " + ", ".join(shown[:6])
                           + (", ..." if len(shown) > 6 else ""))
    if skipped:
        out.append(f"{skipped} other candidate link(s) between these tracklets passed every rule but were not "
                   f"taken: each skips a tracklet that lies between its two in the track, and the taken links "
                   f"join them through it")
    if first != second and found > 1:  # two tracks (or tracklets): how their candidate links ended, in one line
        out.append(f"in short: {found} candidate links between them, " + ", ".join(
            f"{n} {outcome}" for outcome, n in sorted(states.items(), key=lambda item: (-item[1], item[0]))))
    if not found and pairs:
        out.append(f"no candidate pair between them: their tracklets are more than l_max = "
                   f"{gaps.l_max} frames apart, so they were never compared")
    out.append(verdict)
    return "\n".join(out)


def explain_gaps(result: TrackResult, config: TrackerConfig, track: int) -> str:
    """Plain words on the gaps of output track ``track``: for each, the frames without a box, how many boxes
    post-processing filled there, how many of them the confirmation then kept in the results and dropped, and the
    rule that decided (:func:`sotmot.postprocess.gaps_of`)."""
    from sotmot.postprocess import gaps_of

    found = [t for t, i in zip(result.trajectories, result.track_ids) if i == track]
    if not found:
        return f"track {track}: no trajectory of this run has that id"
    rate = result.info.frame_rate
    post = result.postprocess or config.postprocess
    gaps = gaps_of(found[0], post, rate, result.occluders)
    if not gaps:
        return f"track {track} has no gap: a box in every frame from {found[0].start} to {found[0].end}"
    out = [f"track {track}: {len(gaps)} gap(s) between its boxes"]
    if post.interpolate_max_seconds != config.postprocess.interpolate_max_seconds:
        out.append(f"  (the straight line does not hold over {config.postprocess.line_check_seconds:g} s on this "
                   f"sequence's trajectories, [postprocess] line_check_seconds: gaps are filled up to "
                   f"{post.interpolate_max_seconds:g} s)")

    def in_gap(tracks, g) -> int:
        """How many boxes of ``tracks`` with this id lie in the gap ``g``."""
        return int(np.sum((tracks.ids == track) & (tracks.frames > g.after) & (tracks.frames < g.before)))

    for g in gaps:
        missing = g.before - g.after - 1
        seconds = f", {missing / rate:.2f} s" if rate else ""
        left = f", {g.left_out} left out" if g.left_out else ""
        kept, dropped = in_gap(result.tracks, g), in_gap(result.dropped, g)
        if not g.written:
            boxes = "no box filled"
        elif dropped:
            boxes = (f"{g.written} box(es) filled, {kept} in the results and {dropped} dropped by the confirmation "
                     f"(more likely false than true)")
        else:
            boxes = f"{g.written} box(es) filled, all in the results"
        out.append(f"  frames {g.after + 1}-{g.before - 1} ({missing} frame(s){seconds}): {boxes}{left}; {g.why}")
    return "\n".join(out)


#: How :func:`explain_confirmation` names each of the box model's features (:data:`FEATURES` order), and how it
#: shows the track's value: ``"p"`` a mean log-odds shown as a probability, ``"share"`` a share of its boxes or
#: span, ``"value"`` as it is.
FEATURE_WORDS = {
    "box_conf": ("the box's detection confidence (an interpolated box: the higher of its gap's two ends)", "p"),
    "interpolated": ("boxes interpolated", "share"),
    "track_conf_mean": ("the track's mean detection confidence", "p"),
    "track_conf_top": (f"the track's {TOP_QUANTILE:.0%} quantile of detection confidence", "p"),
    "track_interp_share": ("frames of its span without a detection", "share"),
    "track_appearance": ("re-ID consistency (mean cosine of its detections to their mean feature)", "value"),
    "track_brevity": (f"brevity (log of how many times shorter than {SHORT_SECONDS:g} s; 0 when longer)", "value"),
}


def confirmation_inputs(result: TrackResult, config: TrackerConfig,
                        trajectory: Tracklet) -> tuple[BoxModel, np.ndarray]:
    """The box model confirmation applied to ``result`` and the ``(L, len(FEATURES))`` features of the boxes of
    one of its ``trajectory`` as post-processing wrote them (in frame order), as the pipeline computed them."""
    from sotmot.confidence.calibration import load_calibration, model_kind
    from sotmot.postprocess import expand

    model = load_calibration(config.confirm.calibration).box_models[model_kind(result.confidence_method)]
    rate = result.info.frame_rate
    expanded = expand(trajectory, result.postprocess or config.postprocess, rate, result.occluders)
    return model, box_features(trajectory, expanded, result.confidence, result.detections.from_sot,
                               result.features, rate)


def explain_confirmation(result: TrackResult, config: TrackerConfig, track: int) -> str:
    """Plain words on how confirmation judged output track ``track``: the probability of being a true positive it
    gave the track's boxes, the threshold it compared them with and where that came from, how many it kept, and
    what each feature of the box model (:mod:`sotmot.confidence.box_model`) added to the log-odds."""
    from sotmot.confidence.calibration import model_kind
    from sotmot.confirm import confirmation_threshold

    if not config.confirm.enabled:
        return f"confirmation: off ([confirm] enabled = false): every box of track {track} is kept"
    kept, dropped = (rows.confidence[rows.ids == track] for rows in (result.tracks, result.dropped))
    scored = np.concatenate([kept, dropped])
    scored = scored[np.isfinite(scored)]  # boxes the end extension added after confirmation have no score
    found = [t for t, i in zip(result.trajectories, result.track_ids) if i == track]
    if not found or not len(scored):
        return f"confirmation: track {track} has no box it scored"
    method = result.confidence_method
    kind = model_kind(method)
    threshold = confirmation_threshold(config, method)
    source = ("[confirm] threshold, --confirm-threshold" if config.confirm.threshold is not None else
              f"the calibration's for {kind!r} boxes; --confirm-threshold P sets another")
    n_dropped = int(np.isfinite(dropped).sum())
    packaged = config.confirm.threshold is None and config.confirm.calibration is None
    fate = ("it drops no box" + (" (in the packaged fit no threshold above 0 kept every scene within 0.5 HOTA and "
                                 "IDF1 of keeping every box; docs/calibration.md)" if packaged else "")
            if threshold <= 0 else f"all {len(scored)} kept" if not n_dropped else
            f"all {n_dropped} dropped" if n_dropped == len(scored) else
            f"{len(scored) - n_dropped} kept, {n_dropped} dropped")
    spread = (f"{scored.min():.2f}" if f"{scored.min():.2f}" == f"{scored.max():.2f}" else
              f"{scored.min():.2f} to {scored.max():.2f} (median {np.median(scored):.2f})")
    out = [f"confirmation: box model {kind!r} (for confidences from the {method!r} score map) gave "
           f"track {track}'s {len(scored)} boxes P(true) {spread}; threshold {threshold:g} ({source}): {fate}"]
    model, x = confirmation_inputs(result, config, found[0])
    terms = model.terms(x).mean(axis=0)
    out.append(f"  what each feature adds to the log-odds (mean over the boxes), against a box with every feature "
               f"at the fit's mean (log-odds {model.intercept:+.2f}, P(true) {logistic(model.intercept):.2f}):")
    for name, value, term in zip(FEATURES, x.mean(axis=0), terms):
        words, show = FEATURE_WORDS[name]
        shown = ("not measured (no re-ID): counted as the fit's mean" if not math.isfinite(value) else
                 f"{logistic(value):.2f}" if show == "p" else f"{value:.0%}" if show == "share" else
                 f"{value:.2f}")
        out.append(f"    {words}: {shown} -> {term:+.2f}")
    total = model.intercept + terms.sum()
    out.append(f"    in all {total:+.2f}: P(true) {logistic(total):.2f} at these mean terms (each box has its own, "
               f"within the range above)")
    return "\n".join(out)


def track_table(result: TrackResult, config: TrackerConfig) -> str:
    """Every output track of ``result`` in one table, the least certain first: its frames, boxes (detected,
    interpolated, added by SOT or weak boxes), the median P(true) confirmation gave its boxes and how many it kept;
    tracks confirmation dropped whole are marked. Where to look next with ``explain --ids``."""
    rows = []
    both = (result.tracks, result.dropped)
    for track in sorted({int(i) for part in both for i in np.unique(part.ids)}):
        kept, dropped = (part.subset(np.flatnonzero(part.ids == track)) for part in both)
        frames = np.concatenate([kept.frames, dropped.frames])
        interpolated = int(kept.interpolated.sum() + dropped.interpolated.sum())
        sot = int(kept.from_sot.sum() + dropped.from_sot.sum())
        confidence = np.concatenate([kept.confidence, dropped.confidence])
        scored = confidence[np.isfinite(confidence)]
        n_kept = len(kept)
        rows.append((float(np.median(scored)) if len(scored) else math.inf, track, int(frames.min()),
                     int(frames.max()), len(frames), len(frames) - interpolated - sot, interpolated, sot, n_kept))
    if not rows:
        return "no track: the run wrote no box"
    head = ["track", "frames", "boxes", "detected", "interpolated", "SOT/weak", "median P(true)", "kept"]
    lines = [[str(track), f"{first}-{last}", str(n), str(det), str(interp), str(sot),
              "-" if not math.isfinite(p) else f"{p:.2f}", str(kept) + ("" if kept else " (dropped whole)")]
             for p, track, first, last, n, det, interp, sot, kept in sorted(rows)]
    widths = [max(len(c) for c in column) for column in zip(head, *lines)]
    fmt = "  ".join(f"{{:>{w}}}" for w in widths)
    order = "by id (confirmation off: no P(true))"
    if config.confirm.enabled:
        from sotmot.confirm import confirmation_threshold

        order = (f"the least certain first; confirmation's threshold "
                 f"{confirmation_threshold(config, result.confidence_method):g}")
    whole = sum(1 for row in rows if not row[-1])
    note = f" ({whole} of them dropped whole by confirmation)" if whole else ""
    return "\n".join([f"{len(rows)} tracks{note}, {order}; 'sotmot explain --ids N' tells one",
                      fmt.format(*head), *(fmt.format(*line) for line in lines)])


def parse_frames(text: str | None, length: int | None = None, step: int = 1) -> tuple[int, int] | None:
    """``"A:B"`` -> ``(A, B)`` (1-based, inclusive); None stays None.

    With ``length`` (the sequence's ``seqLength``, or at ``step`` above 1 how
    many of its frames are tracked), a range that starts after the last frame
    is an error: it would select nothing.
    """
    if text is None:
        return None
    try:
        a, b = (int(x) for x in text.split(":"))
    except ValueError:
        raise SotmotError(f"--frames must look like A:B (e.g. 1:100), got {text!r}") from None
    if a < 1 or b < a:
        raise SotmotError(f"--frames {text}: need 1 <= A <= B")
    if length is not None and a > length:
        has = (f"the sequence has frames 1 to {length} only" if step == 1 else
               f"at step {step} the tracked frames are 1 to {length} only (frame k is the sequence's 1 + (k - 1) * "
               f"{step})")
        raise SotmotError(f"--frames {text}: {has}")
    return a, b


def parse_ids(text: str, what: str = "track") -> Sequence[int]:
    """``"3,17"`` -> ``[3, 17]``; for tracks also ``"5"`` -> ``[5, 5]`` (why one track's tracklets were merged)."""
    flag = "--ids" if what == "track" else f"--{what}s"
    try:
        ids = [int(x) for x in text.split(",")]
    except ValueError:
        raise SotmotError(f"{flag} must be {what} ids like 3,17, got {text!r}") from None
    if what == "track" and len(ids) == 1:
        return [ids[0], ids[0]]
    if len(ids) != 2:
        raise SotmotError(f"{flag} needs two {what} ids{' (or one track)' if what == 'track' else ''}, got {text!r}")
    if ids[0] == ids[1] and what != "track":
        raise SotmotError(f"{flag} needs two different {what} ids, got {text!r}")
    return ids
