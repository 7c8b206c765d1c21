"""The paper's greedy merge (Sec. 3.4).

Repeatedly merge the pair of trajectories with the highest appearance
affinity (trajectory feature = mean feature of its detections) among the
pairs that satisfy the constraint A(t1, t2) of :mod:`sotmot.constraints`,
until no allowed pair is left.

To scale, candidate pairs live in a max-heap keyed by affinity. A merge
creates a new trajectory and retires its two parts; heap entries that name a
retired trajectory are skipped when popped (lazy invalidation), and only the
new trajectory's pairs with live trajectories within ``l_max`` frames are
checked and pushed. Ties in affinity are broken by the smallest input
tracklet ids of the two trajectories, so the result does not depend on the
order of the input.
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence

import numpy as np

from solvers.base import Association, Link
from sotmot.appearance import affinity_rows
from sotmot.config import AssociationConfig
from sotmot.constraints import candidate_pair_array, check_pairs, merge
from sotmot.types import Tracklet


def solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association:
    """Greedy merge of ``tracklets`` into trajectories (see the module docstring)."""
    nodes: list[Tracklet] = list(tracklets)
    n = len(nodes)
    if n == 0:
        return Association(groups=())
    ids = [t.id for t in nodes]
    if len(set(ids)) != n:
        raise ValueError("tracklet ids must be unique")
    owner = {int(d): t.id for t in nodes for d in t.det_index}
    members: list[tuple[int, ...]] = [(t.id,) for t in nodes]
    capacity = 2 * n
    first_member = np.zeros(capacity, dtype=np.int64)  # smallest input id of each node
    first_member[:n] = ids
    alive = np.zeros(capacity, dtype=bool)
    alive[:n] = True
    starts = np.zeros(capacity, dtype=np.int64)
    ends = np.zeros(capacity, dtype=np.int64)
    starts[:n] = [t.start for t in nodes]
    ends[:n] = [t.end for t in nodes]

    features = np.zeros((capacity, len(nodes[0].feature)), dtype=np.float64)
    features[:n] = [t.feature for t in nodes]
    # entries: (-affinity, smaller min-member id, larger min-member id, node, node)
    heap: list[tuple[float, int, int, int, int]] = []

    def push(pairs: np.ndarray) -> None:
        if len(pairs) == 0:
            return
        # orient each pair by the smallest input id, so ties in box score never depend on input order
        lead = first_member[pairs[:, 0]] > first_member[pairs[:, 1]]
        pairs = np.where(lead[:, None], pairs[:, ::-1], pairs)
        aff = affinity_rows(features[pairs[:, 0]], features[pairs[:, 1]])
        for r in np.flatnonzero(check_pairs(nodes, pairs, aff, config).allowed):
            i, j = int(pairs[r, 0]), int(pairs[r, 1])
            heapq.heappush(heap, (-float(aff[r]), members[i][0], members[j][0], i, j))

    push(candidate_pair_array(nodes, config.l_max))
    links: list[Link] = []
    while heap:
        neg_aff, _, _, i, j = heapq.heappop(heap)
        if not (alive[i] and alive[j]):
            continue
        a, b = nodes[i], nodes[j]
        first, second = (a, b) if (a.start, a.end) <= (b.start, b.end) else (b, a)
        links.append(Link(a=owner[int(first.det_index[-1])] if first.end < second.start else min(members[i]),
                          b=owner[int(second.det_index[0])] if first.end < second.start else min(members[j]),
                          affinity=-neg_aff, round=len(links) + 1))
        k = len(nodes)
        nodes.append(merge(a, b, new_id=k))
        members.append(tuple(sorted(members[i] + members[j])))
        first_member[k] = members[k][0]
        alive[i] = alive[j] = False
        alive[k] = True
        starts[k], ends[k] = nodes[k].start, nodes[k].end
        features[k] = nodes[k].feature
        near = np.flatnonzero(alive[:k] & (starts[:k] <= ends[k] + config.l_max)
                              & (ends[:k] >= starts[k] - config.l_max))
        push(np.stack([near, np.full(len(near), k)], axis=1))
    groups = sorted(members[k] for k in np.flatnonzero(alive))
    return Association(groups=tuple(groups), links=tuple(links))
