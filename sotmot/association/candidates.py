"""The association graph: tracklets as nodes, candidate links as edges (networkx).

An edge ``u -> v`` joins two tracklets whose time spans lie within ``l_max``
frames, oriented from the one that starts first (ties: ends first, then the
smaller id), so the graph is acyclic. Every edge carries what the shared
constraint function :func:`sotmot.association.checks.check_pair` found: the
appearance affinity, the gap, the velocity and its bound, each constraint's
pass/fail, and the link cost of the flow formulation (which lives beside the
solvers that use it, in :mod:`sotmot.association.flow_network`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import networkx as nx
import numpy as np

from sotmot.association.objective import link_cost
from sotmot.appearance import unit
from sotmot.association.affinity import link_affinities
from sotmot.config import AssociationConfig
from sotmot.association.checks import PairChecks, candidate_pairs, check_pairs
from sotmot.association.merge import link_order_key
from sotmot.association.rules import CONSTRAINTS
from sotmot.errors import SolverError
from sotmot.types import Tracklet

@dataclass(frozen=True)
class Candidates:
    """Candidate links as arrays, oriented ``u -> v`` (see :func:`candidate_links`).

    Attributes
    ----------
    u, v
        ``(K,)`` positions in the tracklet sequence of each link's earlier and later tracklet.
    screen
        The constraint check of each link (``screen.allowed``, ``screen.affinity``, ...).
    """

    u: np.ndarray
    v: np.ndarray
    screen: PairChecks


def candidate_links(tracklets: Sequence[Tracklet], config: AssociationConfig,
                    include_rejected: bool = False, disjoint: bool = False) -> Candidates:
    """Every candidate link of ``tracklets`` checked at once; only the allowed ones unless ``include_rejected``.

    A link joins tracklets within ``l_max`` frames, oriented by :func:`link_order_key`.
    ``disjoint`` keeps only pairs whose time spans do not meet: the links of a
    path cover (the flow and lifted solvers). In a chain ``u -> v -> w`` whose
    ``v`` overlaps ``u``, the merged trajectory may end with ``u``'s boxes, so
    the checked junction ``v -> w`` is not the gap the merge makes; between
    disjoint tracklets every junction of a chain is a checked link.
    """
    ids = [t.id for t in tracklets]
    if len(set(ids)) != len(ids):
        raise SolverError("tracklet ids must be unique")
    pairs = candidate_pairs(tracklets, config.l_max)
    if disjoint and len(pairs):
        starts = np.array([t.start for t in tracklets])
        ends = np.array([t.end for t in tracklets])
        pairs = pairs[starts[pairs].max(axis=1) > ends[pairs].min(axis=1)]
    features = unit(np.stack([t.feature for t in tracklets])) if tracklets else np.zeros((0, 1))
    aff = link_affinities(tracklets, pairs, features, config)
    screen = check_pairs(tracklets, pairs, aff, config, complete=include_rejected)
    if not include_rejected:
        keep = np.flatnonzero(screen.allowed)
        pairs, screen = pairs[keep], screen.take(keep)
    order = np.empty(len(tracklets), dtype=np.int64)
    order[sorted(range(len(tracklets)), key=lambda i: link_order_key(tracklets[i]))] = np.arange(len(tracklets))
    forward = order[pairs[:, 0]] < order[pairs[:, 1]]
    return Candidates(u=np.where(forward, pairs[:, 0], pairs[:, 1]), v=np.where(forward, pairs[:, 1], pairs[:, 0]),
                      screen=screen)


def build_graph(tracklets: Sequence[Tracklet], config: AssociationConfig,
                include_rejected: bool = False, disjoint: bool = False) -> nx.DiGraph:
    """The association graph of ``tracklets`` (see the module docstring).

    Parameters
    ----------
    tracklets
        Input tracklets; ids must be unique.
    config
        The constraint thresholds.
    include_rejected
        Also add candidate edges that fail a constraint (``allowed=False``),
        for inspection. Solvers use only allowed edges.
    disjoint
        Only edges between tracklets whose spans do not meet (the flow
        network's links; see :func:`candidate_links`).

    Returns
    -------
    networkx.DiGraph
        Nodes are tracklet ids with attributes ``start``, ``end``, ``length``
        and ``mean_score``; edges have ``affinity``, ``weight`` (the float link
        cost), ``gap`` (frames between them, 0 if they overlap), ``max_gap`` (of
        the merged trajectory), ``velocity_gap``, ``velocity``, ``velocity_bound``
        (the worst checked gap), ``overlap_frames``,
        ``min_segment_iou``, ``allowed``, ``failed`` (comma-separated) and one
        boolean per constraint (``ok_iou``, ``ok_gap``, ...).
    """
    links = candidate_links(tracklets, config, include_rejected, disjoint)
    graph = nx.DiGraph()
    for t in tracklets:
        graph.add_node(t.id, start=t.start, end=t.end, length=len(t), mean_score=float(t.scores.mean()))
    for r, (i, j) in enumerate(zip(links.u.tolist(), links.v.tolist())):
        u, v = tracklets[i], tracklets[j]
        check = links.screen.check(r)
        attrs = {f"ok_{c}": c not in check.failed for c in CONSTRAINTS}
        graph.add_edge(u.id, v.id, affinity=check.affinity, weight=float(link_cost(check.affinity)),
                       gap=max(0, v.start - u.end), max_gap=check.max_gap, velocity_gap=check.velocity_gap,
                       velocity=check.velocity, velocity_bound=check.velocity_bound,
                       overlap_frames=check.overlap_frames, min_segment_iou=check.min_segment_iou,
                       allowed=check.allowed, failed=",".join(check.failed), **attrs)
    return graph
