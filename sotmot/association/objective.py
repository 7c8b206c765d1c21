"""The objectives every solver is scored on, whichever one it optimises.

* The flow objective (:func:`flow_objective`): a link ``u -> v`` between
  consecutive tracklets of a trajectory costs :func:`link_cost` ``= 1 -
  affinity(u, v)`` and each trajectory costs :func:`entry_cost` ``= 1 -
  min_affinity`` (the network that minimises it: :mod:`sotmot.association.flow_network`).
* The lifted objective (:func:`lifted_objective`, after the lifted disjoint
  paths of Hornakova et al., ICML 2020): every pair of a trajectory's
  tracklets ``a`` before ``b`` (in start, end, id order) with ``gap(a, b) <=
  H`` frames (``b``'s first frame minus ``a``'s last; <= 0 when they overlap)
  adds ``w(a, b) = n_a * n_b * s(a, b)``, with ``n`` the detections of a
  tracklet and ``s`` one of (``[association] lifted_costs``): ``"learned"``
  (default), the log-likelihood ratio of "one person" against "two people",
  ``c0 + c1 a + c2 log m + c3 a log m`` with ``a`` the affinity and ``m =
  min(n_a, n_b)`` (:func:`pair_features`), fitted on ground truth by
  ``scripts/fit_lifted.py``; or ``"threshold"``, ``affinity(a, b) - tau``.
  The solver that maximises it: :mod:`sotmot.solvers.lifted`.

``compare`` reports both for every solver's grouping; ``explain`` shows which
pairs paid for a link (:func:`link_pairs`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from sotmot.appearance import unit
from sotmot.association.affinity import link_affinities
from sotmot.association.merge import link_order_key
from sotmot.config import AssociationConfig
from sotmot.types import Tracklet


def link_cost(affinity: float | np.ndarray) -> float | np.ndarray:
    """Flow cost of linking two tracklets with this appearance affinity: ``1 - affinity``."""
    return 1.0 - affinity


def entry_cost(config: AssociationConfig) -> float:
    """Cost of starting a trajectory: ``1 - min_affinity``."""
    return 1.0 - config.min_affinity


def flow_objective(tracklets: Sequence[Tracklet], groups: Sequence[Sequence[int]],
                   config: AssociationConfig) -> float:
    """Float cost of any grouping under the flow objective, so solvers can be compared on it.

    ``entry_cost * number of trajectories + sum of link costs`` over consecutive
    tracklets of each group (ordered by start, end, id), without the constant
    observation rewards. For the flow solvers' own groupings this equals their
    optimal cost; the greedy merge, which never sees this objective, is
    costed the same way.
    """
    by_id = {t.id: t for t in tracklets}
    total = entry_cost(config) * len(groups)
    for group in groups:
        order = sorted((by_id[u] for u in group), key=link_order_key)
        if len(order) > 1:
            consecutive = np.stack([np.arange(len(order) - 1), np.arange(1, len(order))], axis=1)
            aff = link_affinities(order, consecutive, unit(np.stack([t.feature for t in order])), config)
            total += float(np.sum(link_cost(aff)))
    return float(total)


def lifted_threshold(config: AssociationConfig) -> float:
    """The affinity above which two tracklets in one trajectory add to the lifted objective."""
    return config.min_affinity if config.lifted_threshold is None else config.lifted_threshold


def lifted_horizon(config: AssociationConfig) -> int:
    """Largest gap (frames) between two tracklets of one trajectory that the lifted objective scores."""
    return config.l_max if config.lifted_horizon is None else config.lifted_horizon


#: The learned costs' inputs, in the order of ``lifted_coefficients[1:]``.
PAIR_FEATURES = ("affinity", "log_min_boxes", "affinity_x_log_min_boxes")


def pair_features(affinity: np.ndarray, n_early: np.ndarray, n_late: np.ndarray) -> np.ndarray:
    """``(K, 3)`` :data:`PAIR_FEATURES` of pairs of tracklets: affinity, log of the shorter one's boxes, product."""
    shorter = np.log(np.maximum(np.minimum(n_early, n_late), 1.0))
    affinity = np.asarray(affinity, dtype=np.float64)
    return np.stack([affinity, shorter, affinity * shorter], axis=1)


def pair_scores(affinity: np.ndarray, n_early: np.ndarray, n_late: np.ndarray,
                config: AssociationConfig) -> np.ndarray:
    """What one pair of boxes of two tracklets in one trajectory adds (``s(a, b)`` of the module docstring)."""
    if config.lifted_costs == "threshold":
        return np.asarray(affinity, dtype=np.float64) - lifted_threshold(config)
    coef = np.asarray(config.lifted_coefficients, dtype=np.float64)
    return coef[0] + pair_features(affinity, n_early, n_late) @ coef[1:]


def pair_inputs(tracklets: Sequence[Tracklet], early: np.ndarray, late: np.ndarray,
                config: AssociationConfig | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What the lifted costs read of every pair ``early[k]`` -> ``late[k]`` (positions in ``tracklets``): their
    affinity (:func:`~sotmot.association.affinity.link_affinities` under ``config``, as every solver ranks links:
    the appearance of their mean features, or without re-ID their motion), the detections of each, and the gap in
    frames (``late``'s first frame minus ``early``'s last). Shared by the solver and the fit of the learned
    costs."""
    early, late = np.asarray(early, dtype=np.int64), np.asarray(late, dtype=np.int64)
    # only the tracklets asked about, so that a window's call costs its own size, not the sequence's
    used, where = np.unique(np.concatenate([early, late]), return_inverse=True)
    early, late = where[:len(early)], where[len(early):]
    chosen = [tracklets[i] for i in used.tolist()]
    starts = np.array([t.start for t in chosen])
    ends = np.array([t.end for t in chosen])
    counts = np.array([t.n_features for t in chosen], dtype=np.float64)
    units = unit(np.stack([t.feature for t in chosen]))
    affinity = link_affinities(chosen, np.stack([early, late], axis=1), units, config)
    return affinity, counts[early], counts[late], starts[late] - ends[early]


def lifted_weights(tracklets: Sequence[Tracklet], early: np.ndarray, late: np.ndarray,
                   config: AssociationConfig) -> np.ndarray:
    """``w(a, b)`` for every ``early[k]`` -> ``late[k]`` (positions in ``tracklets``, each ``early`` tracklet before
    its ``late`` one in :func:`~sotmot.association.merge.link_order_key` order); 0 where the gap exceeds ``H``."""
    if len(early) == 0:
        return np.zeros(0)
    aff, n_early, n_late, gap = pair_inputs(tracklets, early, late, config)
    scored = gap <= lifted_horizon(config)
    return np.where(scored, n_early * n_late * pair_scores(aff, n_early, n_late, config), 0.0)


def lifted_objective(tracklets: Sequence[Tracklet], groups: Sequence[Sequence[int]],
                     config: AssociationConfig) -> float:
    """The lifted objective of any grouping of ``tracklets`` (groups of ids), so every solver is scored on it."""
    ordered = sorted(tracklets, key=link_order_key)
    position = {t.id: i for i, t in enumerate(ordered)}
    early, late = [], []
    for group in groups:
        members = np.sort(np.array([position[u] for u in group], dtype=np.int64))
        a, b = np.triu_indices(len(members), k=1)
        early.append(members[a])
        late.append(members[b])
    if not early:
        return 0.0
    return float(lifted_weights(ordered, np.concatenate(early), np.concatenate(late), config).sum())


def link_pairs(chain: Sequence[Tracklet], k: int, config: AssociationConfig) -> list[tuple[int, int, float]]:
    """What pays for the link ``chain[k] -> chain[k + 1]`` of one trajectory (tracklets in time order).

    The pairs ``(a id, b id, w(a, b))`` with ``a`` up to ``chain[k]`` and ``b``
    from ``chain[k + 1]`` on and ``w != 0``: the link puts exactly these pairs
    into one trajectory, so their sum is what the link adds to the objective.
    Largest ``|w|`` first.
    """
    early, late = np.meshgrid(np.arange(k + 1), np.arange(k + 1, len(chain)), indexing="ij")
    weights = lifted_weights(chain, early.ravel(), late.ravel(), config)
    pairs = [(chain[a].id, chain[b].id, float(w)) for a, b, w in zip(early.ravel(), late.ravel(), weights) if w]
    return sorted(pairs, key=lambda p: -abs(p[2]))
