"""The contract every long-term association solver fulfils."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

from sotmot.config import AssociationConfig
from sotmot.types import Tracklet


@dataclass(frozen=True)
class Link:
    """One decision of a solver: tracklet groups joined through a pair of tracklets.

    Attributes
    ----------
    a, b
        Ids of the two input tracklets whose check allowed the join (for the
        greedy merge: the first tracklets of the two trajectories merged).
    affinity
        Appearance affinity of the two joined trajectories at that moment.
    round
        1-based order of the decision (greedy merge round); 0 where a solver
        takes all its decisions at once.
    """

    a: int
    b: int
    affinity: float
    round: int = 0


@dataclass(frozen=True)
class Association:
    """What a solver returns.

    Attributes
    ----------
    groups
        One tuple of input tracklet ids per output trajectory, each sorted;
        every input tracklet is in exactly one group; groups ordered by their
        smallest id.
    links
        The joins the solver made, in decision order.
    stats
        What the solver reports about its own work (e.g. the lifted solver's
        windows not proven optimal); empty for solvers that report nothing.
    """

    groups: tuple[tuple[int, ...], ...]
    links: tuple[Link, ...] = ()
    stats: dict[str, float] = field(default_factory=dict)


class Solver(Protocol):
    """``solve(tracklets, config) -> Association``."""

    def __call__(self, tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association: ...
