"""The paper's greedy merge (Sec. 3.4).

Repeatedly merge the pair of trajectories with the highest appearance
affinity (trajectory feature = mean feature of its detections) among the
pairs that satisfy the constraint A(t1, t2) of :mod:`sotmot.constraints`,
until no allowed pair is left.

To scale, candidate pairs (only those within ``l_max`` frames) live in a
max-heap keyed by affinity, and the constraint is checked *lazily*: the best
entries are popped a batch at a time and checked together in one vectorised
:func:`~sotmot.constraints.check_pairs` call, then taken in heap order; a
pair whose trajectories are both still alive has the same answer it would
have had when pushed, so this is exactly the eager greedy merge, while most
pairs are never checked because a merge retires them first. A merge creates
a new trajectory and retires its two parts; heap entries that name a retired
trajectory are skipped (lazy invalidation), and the new trajectory's pairs
with live trajectories within ``l_max`` frames are pushed. Ties in affinity
are broken by the smallest input tracklet ids of the two trajectories, so
the result does not depend on the order of the input.
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence

import numpy as np

from solvers.base import Association, Link
from sotmot.appearance import affinity_rows
from sotmot.config import AssociationConfig
from sotmot.constraints import candidate_pairs, check_pairs, merge
from sotmot.types import Tracklet

#: How many heap entries are checked together.
BATCH = 64


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
    verdict: dict[tuple[int, int], bool] = {}  # constraint answers of popped, still-pending pairs

    def push(pairs: np.ndarray) -> None:
        if len(pairs) == 0:
            return
        # orient each pair by the smallest input id, so ties in box score never depend on input order
        lead = first_member[pairs[:, 0]] > first_member[pairs[:, 1]]
        pairs = np.where(lead[:, None], pairs[:, ::-1], pairs)
        aff = affinity_rows(features[pairs[:, 0]], features[pairs[:, 1]])
        keep = aff >= config.min_affinity  # the affinity rule needs no boxes: apply it now
        for (i, j), a in zip(pairs[keep].tolist(), aff[keep].tolist()):
            heapq.heappush(heap, (-a, int(first_member[i]), int(first_member[j]), i, j))

    def next_allowed() -> tuple[float, int, int] | None:
        """Pop entries until the best live, allowed pair; undecided ones are checked a batch at a time."""
        while heap:
            if not (alive[heap[0][3]] and alive[heap[0][4]]):
                heapq.heappop(heap)
                continue
            if (heap[0][3], heap[0][4]) not in verdict:
                # take the best live entries off the heap, check them together, put them back
                taken: list[tuple[float, int, int, int, int]] = []
                while heap and len(taken) < BATCH:
                    entry = heapq.heappop(heap)
                    if alive[entry[3]] and alive[entry[4]]:
                        taken.append(entry)
                undecided = [e for e in taken if (e[3], e[4]) not in verdict]
                pairs = np.array([(e[3], e[4]) for e in undecided], dtype=np.int64)
                allowed = check_pairs(nodes, pairs, np.array([-e[0] for e in undecided]), config).allowed
                verdict.update(zip(((e[3], e[4]) for e in undecided), allowed.tolist()))
                for entry in taken:
                    heapq.heappush(heap, entry)
                continue
            neg_aff, _, _, i, j = heapq.heappop(heap)
            if verdict.pop((i, j)):
                return -neg_aff, i, j
        return None

    push(candidate_pairs(nodes, config.l_max))
    links: list[Link] = []
    while (best := next_allowed()) is not None:
        aff, i, j = best
        a, b = nodes[i], nodes[j]
        first, second = (a, b) if (a.start, a.end) <= (b.start, b.end) else (b, a)
        links.append(Link(a=owner[int(first.det_index[-1])] if first.end < second.start else min(members[i]),
                          b=owner[int(second.det_index[0])] if first.end < second.start else min(members[j]),
                          affinity=aff, round=len(links) + 1))
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
