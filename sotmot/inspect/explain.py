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

from sotmot.config import AssociationConfig, TrackerConfig
from sotmot.association.objective import link_pairs
from sotmot.association.merge import link_order_key
from sotmot.association.rules import RULES
from sotmot.errors import SotmotError
from sotmot.association.candidates import build_graph
from sotmot.io import write_files_atomic
from sotmot.pipeline import TrackResult


def inspection_graph(result: TrackResult, config: TrackerConfig, frames: tuple[int, int] | None = None) -> nx.DiGraph:
    """The annotated association graph of ``result``, optionally of tracklets inside ``frames = (A, B)``.

    Node attributes: ``start``, ``end``, ``length``, ``mean_score``,
    ``sot_boxes`` (boxes added by the SOT step), ``track`` (output id, -1 if
    the trajectory was dropped). Edge attributes: those of
    :func:`~sotmot.association.candidates.build_graph` plus ``taken`` and ``round`` (greedy
    merge order, 0 when not taken or for solvers that decide at once), and on
    taken edges ``lifted_gain`` and ``lifted_pairs`` (see the module docstring).
    Graph attribute ``compensated`` (only when the camera moved): every
    position was compared in the reference frame (``[motion]``).
    """
    tracklets = result.tracklets
    if frames is not None:
        a, b = frames
        tracklets = [t for t in tracklets if t.end >= a and t.start <= b]
    gaps = config.association.at(result.info.frame_rate)  # the constraints as the solver saw them
    graph = build_graph(tracklets, gaps, include_rejected=True)
    graph.graph["l_max"] = gaps.l_max
    if result.motion is not None and result.motion.moving:  # a still camera's graph stays as it was
        graph.graph["compensated"] = True
    track_of = {}
    for group, track in zip(result.association.groups, result.track_ids):
        for t in group:
            track_of[t] = -1 if track is None else track
    for t in tracklets:
        graph.nodes[t.id]["track"] = track_of.get(t.id, -1)
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


def json_scalar(value, digits: int | None = None):
    """GraphML and JSON friendly scalars: numpy types to Python, NaN and inf to strings,
    floats rounded to ``digits`` decimals if given."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            return str(float(value))
        return float(value) if digits is None else round(float(value), digits)
    return value


def export_graph(graph: nx.DiGraph, out_dir: str | Path) -> list[Path]:
    """Write ``graph.graphml`` and ``graph.json`` (networkx node-link) into ``out_dir``, both or neither."""
    files = {Path(out_dir) / name: data for name, data in graph_files(graph).items()}
    write_files_atomic(files)
    return list(files)


def graph_files(graph: nx.DiGraph) -> dict[str, bytes]:
    """``graph.graphml`` and ``graph.json`` (networkx node-link) of ``graph``: file name -> bytes."""
    clean = nx.DiGraph()
    for n, data in graph.nodes(data=True):
        clean.add_node(n, **{key: json_scalar(value) for key, value in data.items()})
    for u, v, data in graph.edges(data=True):
        clean.add_edge(u, v, **{key: json_scalar(value) for key, value in data.items()})
    return {"graph.graphml": ("\n".join(nx.generate_graphml(clean)) + "\n").encode("utf-8"),
            "graph.json": (json.dumps(nx.node_link_data(clean, edges="edges"), indent=1) + "\n").encode("utf-8")}


def _verdict(data: dict, gaps: AssociationConfig) -> list[str]:
    """One line per rule of :data:`~sotmot.association.rules.RULES`: its measurement in words, then ok or FAILS."""
    return [f"{rule.describe(data, gaps)} -> {'ok' if data[f'ok_{rule.name}'] else 'FAILS'}" for rule in RULES]


def explain(graph: nx.DiGraph, track_a: int, track_b: int, config: TrackerConfig) -> str:
    """Plain words on why output tracks ``track_a`` and ``track_b`` were or were not merged."""
    members = {}
    for track in (track_a, track_b):
        members[track] = sorted(n for n, d in graph.nodes(data=True) if d.get("track") == track)
        if not members[track]:
            raise SotmotError(f"track {track} has no tracklet in this graph (wrong id, or outside --frames)")
    out = []
    # the gap limit the graph was built with (``l_max_seconds`` at the sequence's frame rate)
    gaps = dataclasses.replace(config.association, l_max=graph.graph.get("l_max", config.association.l_max),
                               l_max_seconds=None)
    same = track_a == track_b
    out.append(f"track {track_a}: tracklets {members[track_a]}; track {track_b}: tracklets {members[track_b]}")
    if graph.graph.get("compensated"):
        out.append("  the camera moved: IoU, velocity and gaps below are measured after camera-motion compensation, "
                   "in frame 1's pixels")
    for t in members[track_a] + ([] if same else members[track_b]):
        d = graph.nodes[t]
        out.append(f"  tracklet {t}: frames {d['start']}-{d['end']}, {d['length']} boxes "
                   f"({d['sot_boxes']} from SOT), mean score {d['mean_score']:.2f}")
    # within one track each unordered pair once (both directions are looked at below)
    pairs = [(u, v) for u in members[track_a] for v in members[track_b] if (u < v if same else u != v)]
    found = 0
    for u, v in pairs:
        for x, y in ((u, v), (v, u)):
            if not graph.has_edge(x, y):
                continue
            found += 1
            data = graph.edges[x, y]
            rounds = f" in round {data['round']}" if data["round"] else ""
            state = (f"TAKEN by {config.association.solver}" + rounds) \
                if data["taken"] else ("allowed, not taken" if data["allowed"] else
                                       f"REJECTED by {data['failed'].replace(',', ', ')}")
            out.append(f"candidate {x} -> {y}: {state}")
            out.extend("    " + line for line in _verdict(data, gaps))
            if data.get("lifted_pairs"):
                shown = data["lifted_pairs"].split(";")
                out.append(f"    lifted objective: the link joins {len(shown)} scored pair(s) of tracklets, "
                           f"total {data['lifted_gain']:+.1f}: " + ", ".join(shown[:6])
                           + (", ..." if len(shown) > 6 else ""))
    if not found:
        out.append(f"no candidate pair between them: their tracklets are more than l_max = "
                   f"{gaps.l_max} frames apart, so they were never compared")
    verdict = "were merged" if same else "were not merged"
    out.append(f"-> tracks {track_a} and {track_b} {verdict} ({config.association.solver}).")
    return "\n".join(out)


def parse_frames(text: str | None, length: int | None = None) -> tuple[int, int] | None:
    """``"A:B"`` -> ``(A, B)`` (1-based, inclusive); None stays None.

    With ``length`` (the sequence's ``seqLength``), a range that starts
    after the last frame is an error: it would select nothing.
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
        raise SotmotError(f"--frames {text}: the sequence has frames 1 to {length} only")
    return a, b


def parse_ids(text: str) -> Sequence[int]:
    """``"3,17"`` -> ``[3, 17]``."""
    try:
        ids = [int(x) for x in text.split(",")]
    except ValueError:
        raise SotmotError(f"--ids must be two track ids like 3,17, got {text!r}") from None
    if len(ids) != 2:
        raise SotmotError(f"--ids needs exactly two track ids, got {text!r}")
    if ids[0] == ids[1]:
        raise SotmotError(f"--ids needs two different track ids, got {text!r}")
    return ids
