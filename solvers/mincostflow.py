"""Long-term association as min-cost flow, solved with OR-Tools' ``SimpleMinCostFlow``.

The network (Zhang et al. 2008; see :mod:`sotmot.graph`) has a link arc only
where the shared constraint function allows the pair, so this solver obeys the
same IoU, velocity and gap rules as the greedy merge, on every link it makes.
Unlike the greedy merge it optimises all links at once: the set of links that
minimises ``entry cost x trajectories + sum of (1 - affinity)``.
A status other than OPTIMAL raises :class:`~sotmot.errors.SolverError`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from solvers.base import Association
from solvers.flow_common import association_from_links
from sotmot.config import AssociationConfig
from sotmot.errors import SolverError
from sotmot.graph import build_graph, flow_network
from sotmot.types import Tracklet


def solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association:
    """Min-cost-flow association of ``tracklets`` with OR-Tools."""
    from ortools.graph.python import min_cost_flow

    if not tracklets:
        return Association(groups=())
    graph = build_graph(tracklets, config)
    nodes, tails, heads, capacities, costs = flow_network(graph, config)
    smcf = min_cost_flow.SimpleMinCostFlow()
    arcs = smcf.add_arcs_with_capacity_and_unit_cost(tails, heads, capacities, costs)
    supplies = np.zeros(len(nodes), dtype=np.int64)
    supplies[0], supplies[1] = len(tracklets), -len(tracklets)
    smcf.set_nodes_supplies(np.arange(len(nodes)), supplies)
    status = smcf.solve()
    if status != smcf.OPTIMAL:
        raise SolverError(f"OR-Tools min-cost flow ended with status {status!r}, not OPTIMAL")
    flows = smcf.flows(arcs)
    links = [(nodes[t][1], nodes[h][1]) for t, h, f in zip(tails, heads, flows)
             if f > 0 and isinstance(nodes[t], tuple) and isinstance(nodes[h], tuple) and nodes[t][0] == "out"]
    return association_from_links(tracklets, graph, links)
