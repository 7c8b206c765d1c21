"""The paper's greedy merge (Sec. 3.4).

Repeatedly merge the pair of trajectories with the highest appearance
affinity (trajectory feature = mean feature of its detections) among the
pairs that satisfy the constraint A(t1, t2) of :mod:`sotmot.association.rules`,
until no allowed pair is left. Ties in affinity are broken by the smallest
input tracklet ids of the two trajectories, so the result does not depend on
the order of the input.

How it scales (the result is exactly that of the plain loop above):

* Only pairs whose time spans lie within ``l_max`` frames are candidates,
  and pairs below the affinity gate are dropped at once (that rule needs no
  boxes).
* Candidates live in sorted *lists*: one for the pairs of the input
  tracklets, all checked in one vectorised
  :func:`~sotmot.association.checks.check_pairs` call; and one per merged
  trajectory, holding its pairs with the live trajectories near it,
  unchecked. A heap holds one entry per list, keyed by the list's head, so a
  merge costs a few heap operations however many pairs it creates.
* A merge retires its two parts; entries naming a retired trajectory are
  skipped when a list's head moves past them, and a retired trajectory's own
  list is dropped whole.
* A list whose head is unchecked when it reaches the top checks its next
  few unchecked entries in one call. A pair whose two trajectories are
  alive has the answer it would have had when listed, so checking late
  changes nothing, while most pairs are never checked because a merge
  retires them first.
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence

import numpy as np

from sotmot.association.base import Association, Link
from sotmot.appearance import unit
from sotmot.association.affinity import link_affinities
from sotmot.config import AssociationConfig
from sotmot.association.checks import candidate_pairs, check_pairs
from sotmot.association.merge import merge
from sotmot.association.rules import passes_affinity_gate
from sotmot.types import Tracklet

#: At most this many entries of one list are checked in one call (measured best on MOT16-04:
#: larger batches check many pairs a merge would have retired, smaller ones cost more calls).
MAX_CHECK = 32
#: Entries looked at per step while moving a list's head past retired or rejected pairs.
_STRIDE = 64
_UNCHECKED, _ALLOWED, _REJECTED = 0, 1, -1


class _CandidateLists:
    """Candidate lists sorted best first, and the heap of their heads (see the module docstring)."""

    def __init__(self, alive: np.ndarray) -> None:
        self.alive = alive
        self.pairs: list[np.ndarray] = []  # (m, 2) node indices, smaller input id first
        self.affinity: list[np.ndarray] = []  # (m,) descending
        self.ties: list[np.ndarray] = []  # (m, 2) smallest input ids of the two nodes
        self.state: list[np.ndarray] = []  # (m,) _UNCHECKED / _ALLOWED / _REJECTED
        self.head: list[int] = []
        self.owner: list[int] = []  # the node every entry names, or -1
        self.heap: list[tuple[float, int, int, int]] = []

    def add(self, pairs: np.ndarray, affinity: np.ndarray, ties: np.ndarray, state: np.ndarray, owner: int) -> None:
        order = np.lexsort((ties[:, 1], ties[:, 0], -affinity))
        self.pairs.append(pairs[order])
        self.affinity.append(affinity[order])
        self.ties.append(ties[order])
        self.state.append(state[order])
        self.head.append(0)
        self.owner.append(owner)
        self._push(len(self.head) - 1)

    def _settle(self, k: int) -> bool:
        """Move list ``k``'s head to its first entry that is alive and not rejected; False if none."""
        pairs, state, pos = self.pairs[k], self.state[k], self.head[k]
        while pos < len(pairs):
            stop = min(len(pairs), pos + _STRIDE)
            ok = self.alive[pairs[pos:stop, 0]] & self.alive[pairs[pos:stop, 1]] & (state[pos:stop] != _REJECTED)
            hit = int(ok.argmax())
            if ok[hit]:
                self.head[k] = pos + hit
                return True
            pos = stop
        self.head[k] = pos
        return False

    def _key(self, k: int) -> tuple[float, int, int, int]:
        e = self.head[k]
        return (-float(self.affinity[k][e]), int(self.ties[k][e, 0]), int(self.ties[k][e, 1]), k)

    def _push(self, k: int) -> None:
        if self._settle(k):
            heapq.heappush(self.heap, self._key(k))

    def best(self, tracklets: Sequence[Tracklet], config: AssociationConfig) -> tuple[float, int, int] | None:
        """Remove and return the best live allowed pair ``(affinity, i, j)``, or None when there is none."""
        while self.heap:
            key = heapq.heappop(self.heap)
            k = key[3]
            if self.owner[k] >= 0 and not self.alive[self.owner[k]]:
                continue  # every entry names the retired owner
            if not self._settle(k):
                continue
            if self._key(k) != key:  # the head moved past retired pairs: requeue at its true rank
                heapq.heappush(self.heap, self._key(k))
                continue
            e = self.head[k]
            if self.state[k][e] == _UNCHECKED:
                self._check(k, tracklets, config)
                self._push(k)
                continue
            self.state[k][e] = _REJECTED  # taken: never offered again
            self._push(k)
            return float(self.affinity[k][e]), int(self.pairs[k][e, 0]), int(self.pairs[k][e, 1])
        return None

    def _check(self, k: int, tracklets: Sequence[Tracklet], config: AssociationConfig) -> None:
        """Check up to :data:`MAX_CHECK` unchecked live entries of list ``k`` from its head on, in one call."""
        e = self.head[k]
        pairs, state = self.pairs[k][e:e + MAX_CHECK], self.state[k][e:e + MAX_CHECK]
        rows = np.flatnonzero((state == _UNCHECKED) & self.alive[pairs[:, 0]] & self.alive[pairs[:, 1]])
        allowed = check_pairs(tracklets, pairs[rows], self.affinity[k][e:e + MAX_CHECK][rows], config).allowed
        state[rows] = np.where(allowed, _ALLOWED, _REJECTED)


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
    features = np.zeros((capacity, len(nodes[0].feature)), dtype=np.float64)  # unit length, see appearance.unit
    features[:n] = unit(np.stack([t.feature for t in nodes]))
    lists = _CandidateLists(alive)

    def gated(pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pairs above the affinity gate, oriented by smallest input id; their affinities and tie keys."""
        # the orientation makes ties in box score independent of the input order
        lead = first_member[pairs[:, 0]] > first_member[pairs[:, 1]]
        pairs = np.where(lead[:, None], pairs[:, ::-1], pairs)
        aff = link_affinities(nodes, pairs, features, config)
        keep = passes_affinity_gate(aff, config)
        return pairs[keep], aff[keep], first_member[pairs[keep]]

    pairs, aff, ties = gated(candidate_pairs(nodes, config.l_max))
    allowed = check_pairs(nodes, pairs, aff, config).allowed
    lists.add(pairs[allowed], aff[allowed], ties[allowed], np.full(int(allowed.sum()), _ALLOWED, np.int8), -1)
    links: list[Link] = []
    while (best := lists.best(nodes, config)) is not None:
        aff_ij, i, j = best
        a, b = nodes[i], nodes[j]
        first, second = (a, b) if (a.start, a.end) <= (b.start, b.end) else (b, a)
        links.append(Link(a=owner[int(first.det_index[-1])] if first.end < second.start else min(members[i]),
                          b=owner[int(second.det_index[0])] if first.end < second.start else min(members[j]),
                          affinity=aff_ij, round=len(links) + 1))
        k = len(nodes)
        nodes.append(merge(a, b, new_id=k))
        members.append(tuple(sorted(members[i] + members[j])))
        first_member[k] = members[k][0]
        alive[i] = alive[j] = False
        alive[k] = True
        starts[k], ends[k] = nodes[k].start, nodes[k].end
        features[k] = unit(nodes[k].feature)
        near = np.flatnonzero(alive[:k] & (starts[:k] <= ends[k] + config.l_max)
                              & (ends[:k] >= starts[k] - config.l_max))
        pairs, aff, ties = gated(np.stack([near, np.full(len(near), k)], axis=1))
        lists.add(pairs, aff, ties, np.full(len(pairs), _UNCHECKED, np.int8), k)
    groups = sorted(members[k] for k in np.flatnonzero(alive))
    return Association(groups=tuple(groups), links=tuple(links))
