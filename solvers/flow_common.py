"""What the two min-cost-flow solvers share: reading the links back into an association."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from solvers.base import Association, Link
from sotmot.graph import chains_from_links
from sotmot.types import Tracklet


def association_from_links(tracklets: Sequence[Tracklet], links: Sequence[tuple[int, int]],
                           affinity: Mapping[tuple[int, int], float]) -> Association:
    """An :class:`Association` from the chosen ``u -> v`` links (tracklet ids) and their affinities."""
    groups = chains_from_links([t.id for t in tracklets], links)
    return Association(groups=groups, links=tuple(Link(a=u, b=v, affinity=affinity[u, v]) for u, v in sorted(links)))
