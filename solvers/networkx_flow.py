"""Reference min-cost-flow solver: ``networkx.min_cost_flow`` (network simplex) on the same network.

Slow on large graphs; it exists to cross-check the OR-Tools solver on small
ones and to show the formulation in networkx's own vocabulary (``demand``,
``capacity``, ``weight``).
"""

from __future__ import annotations

from collections.abc import Sequence

import networkx as nx

from sotmot.association.base import Association
from sotmot.association.flow_network import SINK, SOURCE, association_from_links, flow_network
from sotmot.config import AssociationConfig
from sotmot.errors import SolverError
from sotmot.association.candidates import build_graph
from sotmot.types import Tracklet


def network(tracklets: Sequence[Tracklet], config: AssociationConfig) -> tuple[nx.DiGraph, nx.DiGraph]:
    """The association graph and its flow network as a networkx ``DiGraph``."""
    graph = build_graph(tracklets, config, disjoint=True)
    nodes, tails, heads, capacities, costs, _ = flow_network(graph, config)
    net = nx.DiGraph()
    for key in nodes:
        net.add_node(key, demand=0)
    net.nodes[SOURCE]["demand"] = -len(tracklets)
    net.nodes[SINK]["demand"] = len(tracklets)
    for t, h, c, w in zip(tails, heads, capacities, costs):
        net.add_edge(nodes[t], nodes[h], capacity=int(c), weight=int(w))
    return graph, net


def solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association:
    """Min-cost-flow association of ``tracklets`` with networkx."""
    if not tracklets:
        return Association(groups=())
    graph, net = network(tracklets, config)
    try:
        flow = nx.min_cost_flow(net, demand="demand", capacity="capacity", weight="weight")
    except (nx.NetworkXUnfeasible, nx.NetworkXUnbounded) as exc:
        raise SolverError(f"networkx min-cost flow failed: {exc}") from exc
    links = [(u[1], v[1]) for u, targets in flow.items() if isinstance(u, tuple) and u[0] == "out"
             for v, f in targets.items() if f > 0 and isinstance(v, tuple)]
    return association_from_links(tracklets, links, {(u, v): graph.edges[u, v]["affinity"] for u, v in links})
