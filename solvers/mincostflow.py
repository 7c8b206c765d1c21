"""Long-term association as min-cost flow, solved with OR-Tools' ``SimpleMinCostFlow``.

The network (Zhang et al. 2008; see :mod:`solvers.flow_common`) has a link arc only
where the shared constraint function allows the pair, so this solver obeys the
same IoU, velocity and gap rules as the greedy merge, on every link it makes.
Unlike the greedy merge it optimises all links at once: the set of links that
minimises ``entry cost x trajectories + sum of (1 - affinity)``.
A status other than OPTIMAL raises :class:`~sotmot.errors.SolverError`.

It builds the network straight from the arrays of
:func:`sotmot.graph.candidate_links` (the networkx graph of the same links is
what :mod:`solvers.networkx_flow` and the inspection tools use).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from solvers.base import Association
from solvers.flow_common import association_from_links, flow_arcs, link_cost
from sotmot.config import AssociationConfig
from sotmot.errors import SolverError
from sotmot.graph import candidate_links
from sotmot.types import Tracklet


def solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association:
    """Min-cost-flow association of ``tracklets`` with OR-Tools."""
    from ortools.graph.python import min_cost_flow

    if not tracklets:
        return Association(groups=())
    cands = candidate_links(tracklets, config)
    ids = np.array([t.id for t in tracklets], dtype=np.int64)
    u, v, affinity = ids[cands.u], ids[cands.v], cands.screen.affinity
    nodes, tails, heads, capacities, costs, link_arcs = flow_arcs(ids, u, v, link_cost(affinity), config)
    smcf = min_cost_flow.SimpleMinCostFlow()
    arcs = smcf.add_arcs_with_capacity_and_unit_cost(tails, heads, capacities, costs)
    supplies = np.zeros(len(nodes), dtype=np.int64)
    supplies[0], supplies[1] = len(tracklets), -len(tracklets)
    smcf.set_nodes_supplies(np.arange(len(nodes)), supplies)
    status = smcf.solve()
    if status != smcf.OPTIMAL:
        raise SolverError(f"OR-Tools min-cost flow ended with status {status!r}, not OPTIMAL")
    flows = smcf.flows(arcs)
    chosen = np.flatnonzero(flows[link_arcs] > 0)
    links = list(zip(u[chosen].tolist(), v[chosen].tolist()))
    return association_from_links(tracklets, links, dict(zip(links, affinity[chosen].tolist())))
