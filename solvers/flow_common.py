"""What the two min-cost-flow solvers share: the network from the graph, and reading the links back."""

from __future__ import annotations

from collections.abc import Sequence

from solvers.base import Association, Link
from sotmot.graph import chains_from_links
from sotmot.types import Tracklet


def association_from_links(tracklets: Sequence[Tracklet], graph, links: Sequence[tuple[int, int]]) -> Association:
    """An :class:`Association` from the chosen ``u -> v`` links."""
    groups = chains_from_links([t.id for t in tracklets], links)
    return Association(groups=groups, links=tuple(Link(a=u, b=v, affinity=graph.edges[u, v]["affinity"])
                                                  for u, v in sorted(links)))

