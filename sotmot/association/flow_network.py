"""What the two min-cost-flow solvers share: the network, its costs, and reading the links back.

The formulation (Zhang, Li, Nevatia, CVPR 2008, as
cited by the paper): each tracklet ``u`` becomes ``("in", u) -> ("out", u)``
with a unit-capacity observation arc, a source ``"S"`` enters every ``in``
node, every ``out`` node exits to the sink ``"T"``, and a link arc
``("out", u) -> ("in", v)`` exists for every allowed edge between tracklets
whose spans do not meet (a path cover's links; see
:func:`sotmot.association.candidates.candidate_links`). A bypass arc
``S -> T`` lets the solver choose how many trajectories to start.

Costs (floats, before scaling to integers by :func:`integer_costs`):

* link ``u -> v``: ``1 - affinity(u, v)``;
* entering (one per trajectory): ``1 - min_affinity``, so a link pays off
  exactly when its affinity exceeds the gate;
* observation: ``-(entry + 1)``, a reward large enough that every tracklet
  is covered, as the greedy merge keeps every tracklet too.

So the solver finds the set of links (at most one successor and one
predecessor per tracklet) that maximises the summed affinity margin, i.e.
the fewest, most similar trajectories.

:func:`flow_arcs` lays the network out as arc arrays and returns where the
link arcs are, so a solver maps its flows back to links without knowing the
layout (:mod:`sotmot.solvers.mincostflow`); :func:`flow_network` gives the same arcs
for a networkx association graph (:mod:`sotmot.solvers.networkx_flow`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import networkx as nx
import numpy as np

from sotmot.association.base import Association, Link
from sotmot.association.objective import entry_cost
from sotmot.config import AssociationConfig
from sotmot.errors import SolverError
from sotmot.types import Tracklet

SOURCE = "S"
SINK = "T"
#: Integer cost units per 1.0 of float cost.
COST_SCALE = 10_000
_INT64_SAFE = 2**62


def integer_costs(costs: np.ndarray, n_paths: int, scale: int = COST_SCALE) -> np.ndarray:
    """Round float costs to integers (``scale`` units per 1.0), refusing any risk of int64 overflow.

    Parameters
    ----------
    costs
        Float arc costs.
    n_paths
        Upper bound on the flow (units through the network); the total cost
        is bounded by ``n_paths * sum(|cost|)``.
    """
    costs = np.asarray(costs, dtype=np.float64)
    if not np.isfinite(costs).all():
        raise SolverError("arc costs must be finite")
    scaled = np.rint(costs * scale)
    bound = float(np.abs(scaled).sum()) * max(1, n_paths)
    if bound >= _INT64_SAFE:
        raise SolverError(f"arc costs too large for 64-bit integers after scaling by {scale} "
                          f"(bound {bound:.3g}); lower the scale")
    return scaled.astype(np.int64)


def flow_arcs(tracklet_ids: Sequence[int], link_u: np.ndarray, link_v: np.ndarray, link_weight: np.ndarray,
              config: AssociationConfig) -> tuple[list, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The min-cost-flow network as arc arrays, from links given as tracklet ids and float costs.

    Returns
    -------
    nodes
        Node keys: ``"S"``, ``"T"``, then ``("in", u)``, ``("out", u)`` per tracklet, by id.
    tails, heads
        ``(A,)`` indices into ``nodes`` of each arc: the bypass ``S -> T``,
        then per tracklet its entry, observation and exit arcs, then the
        links sorted by ``(u, v)``.
    capacities
        ``(A,)`` all 1 except the bypass ``S -> T`` (the number of tracklets).
    costs
        ``(A,)`` integer costs (see the module docstring).
    link_arcs
        ``(K,)`` the arc index of each input link, in the order given: a
        solver reads ``flows[link_arcs]`` and never relies on the layout.
    """
    ids = np.sort(np.asarray(tracklet_ids, dtype=np.int64))
    n = len(ids)
    nodes: list = [SOURCE, SINK] + [(side, int(u)) for u in ids.tolist() for side in ("in", "out")]
    inn, out = 2 + 2 * np.arange(n), 3 + 2 * np.arange(n)
    link_u, link_v = np.asarray(link_u, dtype=np.int64), np.asarray(link_v, dtype=np.int64)
    order = np.lexsort((link_v, link_u))
    lu, lv = np.searchsorted(ids, link_u[order]), np.searchsorted(ids, link_v[order])
    enter = entry_cost(config)
    per_tracklet = np.stack([np.stack([np.zeros(n), inn, np.ones(n), np.full(n, enter)], axis=1),
                             np.stack([inn, out, np.ones(n), np.full(n, -(enter + 1.0))], axis=1),
                             np.stack([out, np.ones(n), np.ones(n), np.zeros(n)], axis=1)], axis=1).reshape(-1, 4)
    links = np.stack([out[lu], inn[lv], np.ones(len(lu)), np.asarray(link_weight, dtype=np.float64)[order]], axis=1)
    arr = np.concatenate([[[0, 1, n, 0.0]], per_tracklet, links.reshape(-1, 4)])
    costs = integer_costs(arr[:, 3], n)
    link_arcs = np.empty(len(order), dtype=np.int64)
    link_arcs[order] = 1 + 3 * n + np.arange(len(order))  # after the bypass and three arcs per tracklet
    return (nodes, arr[:, 0].astype(np.int64), arr[:, 1].astype(np.int64), arr[:, 2].astype(np.int64), costs,
            link_arcs)


def flow_network(graph: nx.DiGraph, config: AssociationConfig) -> tuple[list, np.ndarray, np.ndarray,
                                                                        np.ndarray, np.ndarray, np.ndarray]:
    """The min-cost-flow network of an association graph (its allowed edges), as :func:`flow_arcs` gives it."""
    edges = [(u, v, data["weight"]) for u, v, data in graph.edges(data=True) if data.get("allowed", True)]
    u, v, w = (np.array(col) for col in zip(*edges)) if edges else (np.zeros(0, np.int64),) * 3
    return flow_arcs(list(graph.nodes), u, v, w, config)


def chains_from_links(tracklet_ids: Sequence[int], links: Sequence[tuple[int, int]]) -> tuple[tuple[int, ...], ...]:
    """Groups of tracklet ids from ``u -> v`` links (each id at most once as u and once as v)."""
    succ = dict(links)
    has_pred = {v for _, v in links}
    if len(succ) != len(links) or len(has_pred) != len(links):
        raise SolverError("a tracklet has two successors or two predecessors in the flow solution")
    groups = []
    for u in sorted(tracklet_ids):
        if u in has_pred:
            continue
        chain = [u]
        while chain[-1] in succ:
            chain.append(succ[chain[-1]])
        groups.append(tuple(sorted(chain)))
    if sum(len(g) for g in groups) != len(tracklet_ids):
        raise SolverError("the flow solution has a cycle or leaves tracklets out")
    return tuple(sorted(groups))


def association_from_links(tracklets: Sequence[Tracklet], links: Sequence[tuple[int, int]],
                           affinity: Mapping[tuple[int, int], float]) -> Association:
    """An :class:`Association` from the chosen ``u -> v`` links (tracklet ids) and their affinities."""
    groups = chains_from_links([t.id for t in tracklets], links)
    return Association(groups=groups, links=tuple(Link(a=u, b=v, affinity=affinity[u, v]) for u, v in sorted(links)))
