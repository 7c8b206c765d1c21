"""Long-term association as min-cost flow, solved with OR-Tools' ``SimpleMinCostFlow``.

The network (Zhang et al. 2008; see :mod:`sotmot.association.flow_network`) has a link arc only
where the shared constraint function allows the pair, so this solver obeys the
same IoU, velocity and gap rules as the greedy merge, on every link it makes.
Unlike the greedy merge it optimises all links at once: the set of links that
minimises ``entry cost x trajectories + sum of (1 - affinity)``.
A status other than OPTIMAL raises :class:`~sotmot.errors.SolverError`.

It builds the network straight from the arrays of
:func:`sotmot.association.candidates.candidate_links` (the networkx graph of the same links is
what :mod:`sotmot.solvers.networkx_flow` and the inspection tools use).

:func:`solve_staged` (``flow-staged``) runs the same flow twice: first with
links over at most ``[association] flow_stage_gap`` frames, then on the
trajectories that stage made (merged, with their mean features). A
consecutive-link cover prefers a link that jumps over a tracklet of the same
person when the jump's affinity is high (issue #13); short links first leave
fewer tracklets to jump over, and the second stage compares whole
trajectories instead of short tracklets.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from sotmot.association.base import Association, Link
from sotmot.association.flow_network import association_from_links, flow_arcs
from sotmot.association.objective import link_cost
from sotmot.config import AssociationConfig
from sotmot.association.merge import link_order_key, merge_group
from sotmot.errors import SolverError
from sotmot.association.candidates import candidate_links
from sotmot.types import Tracklet


def solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association:
    """Min-cost-flow association of ``tracklets`` with OR-Tools."""
    from ortools.graph.python import min_cost_flow

    if not tracklets:
        return Association(groups=())
    cands = candidate_links(tracklets, config, disjoint=True)
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


def solve_staged(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association:
    """Two-stage min-cost flow: short links first, then links between the trajectories they made."""
    if not tracklets:
        return Association(groups=())
    short = solve(tracklets, dataclasses.replace(config, l_max=min(config.flow_stage_gap, config.l_max)))
    by_id = {t.id: t for t in tracklets}
    parts = [sorted((by_id[u] for u in group), key=link_order_key) for group in short.groups]
    merged = [merge_group(part, new_id=k) for k, part in enumerate(parts)]
    long = solve(merged, config)
    groups = sorted(tuple(sorted(u for k in group for u in short.groups[k])) for group in long.groups)
    # a second-stage link joins the last tracklet of one trajectory to the first of the next
    joins = [Link(a=max(parts[link.a], key=lambda t: (t.end, t.id)).id, b=parts[link.b][0].id,
                  affinity=link.affinity) for link in long.links]
    return Association(groups=tuple(groups), links=short.links + tuple(joins))
