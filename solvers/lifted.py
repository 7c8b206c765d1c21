"""Long-term association by the lifted objective, solved exactly per window with OR-Tools CP-SAT.

A consecutive-link objective (the flow network of :mod:`sotmot.association.flow_network`)
scores a link by the affinity of the two tracklets it joins and nothing else,
so it prefers a link that jumps over a tracklet of the same person to the two
links through it, and the skipped tracklet becomes a parallel track. The
*lifted* objective (after the lifted disjoint paths of Hornakova et al., ICML
2020) scores what a trajectory holds instead: every pair of its tracklets
``a`` before ``b`` (in start, end, id order) with ``gap(a, b) <= H`` frames
(``b``'s first frame minus ``a``'s last; <= 0 when they overlap) adds ::

    w(a, b) = n_a * n_b * s(a, b)

with ``n`` the detections of a tracklet and ``s`` one of (``[association]
lifted_costs``):

* ``"learned"`` (default): the log-likelihood ratio of "one person" against
  "two people", ``c0 + c1 a + c2 log m + c3 a log m`` with ``a`` the affinity
  and ``m = min(n_a, n_b)`` (:func:`pair_features`), fitted on ground truth by
  ``scripts/fit_lifted.py`` (``lifted_coefficients``). A long
  tracklet's mean feature is steadier, so the same affinity says less for two
  long tracklets than for two short ones: with a fixed threshold the products
  ``n_a * n_b`` let mediocre affinities between long tracklets of two people
  outweigh a clear link of a short one.
* ``"threshold"``: ``affinity(a, b) - tau``, ``tau`` = ``lifted_threshold``
  (None uses the affinity gate ``min_affinity``).

A trajectory pays for a link through the pairs the link puts into one chain, so
a jump over a compatible tracklet gains nothing over the path through it.
The greedy merge's test (mean-feature affinity >= tau) is a local form of the
same objective.

Solved on windows of ``lifted_window`` frames that advance by
``lifted_step`` frames: the tracklets that start in the window are decided
together with the open ends (*tails*) of the trajectories decided so far; the
links into tracklets that start before the next window are committed. A tail
carries its trajectory: its lifted weight to a new tracklet ``b`` sums
``w(a, b)`` over the trajectory's tracklets ``a``. Each window is an exact
CP-SAT model:

* ``x[u, v]`` for every link between tracklets whose spans do not meet that
  the IoU, velocity and gap rules of the constraint function allow (the very
  rules of the other solvers, :func:`sotmot.association.candidates.candidate_links`), with at most one successor and one
  predecessor per tracklet; no affinity gate on links: the objective decides;
* ``y[a, b]`` ("same trajectory") for every pair the links can join within
  ``H`` frames, tied to the links exactly: ``x[a, c]`` forces ``y[a, b] =
  y[c, b]`` (``y[a, c] = 1``), and ``y[a, b]`` needs a link out of ``a``
  towards ``b``;
* maximise ``sum w(a, b) * y[a, b]`` (weights scaled to integers).

Links that can never pay (their own weight plus every positive weight they
could bring into one chain is <= 0) are pruned before the model is built,
and independent components are solved separately. Each model is warm-started
from the greedy merge's links. A component for which CP-SAT finds no
solution within ``lifted_time_limit`` seconds raises
:class:`LiftedWindowError` naming the window's frames; a component solved
but not proven optimal is counted in the association's statistics
(``components_not_optimal``, and ``bound_gap``: the summed distance from its
solution to CP-SAT's proved bound).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from sotmot.association.base import Association, Link
from sotmot.association.candidates import candidate_links
from sotmot.association.flow_network import chains_from_links
from sotmot.association.objective import lifted_horizon, lifted_weights
from sotmot.association.merge import link_order_key
from sotmot.config import AssociationConfig
from sotmot.errors import SolverError
from sotmot.types import Tracklet

log = logging.getLogger(__name__)

#: Integer objective units per 1.0 of lifted weight.
WEIGHT_SCALE = 100


class LiftedWindowError(SolverError):
    """CP-SAT found no solution for one window within its time limit."""


@dataclass
class _Window:
    """One window's problem over local nodes ``0..m-1`` (tails first): arcs, lifted weights, hint."""

    nodes: np.ndarray  # (m,) positions in the tracklet sequence
    arcs: np.ndarray  # (K, 2) local indices, u before v
    weight: np.ndarray  # (m, m) float lifted weight of a -> b (tails: summed over their trajectory)
    scored: np.ndarray  # (m, m) bool: a before b, within the horizon (gap <= H)
    hint: set  # local arcs of the greedy solution


def _reach(m: int, arcs: np.ndarray, order: np.ndarray) -> np.ndarray:
    """``(m, m)`` bool: ``b`` is reachable from ``a`` by one or more arcs (``order``: a topological order)."""
    reach = np.zeros((m, m), dtype=bool)
    succ: list[list[int]] = [[] for _ in range(m)]
    for u, v in arcs.tolist():
        succ[u].append(v)
    for a in order[::-1].tolist():
        for c in succ[a]:
            reach[a, c] = True
            reach[a] |= reach[c]
    return reach


def _prune(window: _Window, order: np.ndarray) -> np.ndarray:
    """The arcs that can pay: an arc whose own weight plus every positive weight between the
    trajectories it could join is <= 0 is never part of a strictly better solution."""
    arcs = window.arcs
    m = len(window.nodes)
    positive = np.maximum(window.weight, 0.0)
    while len(arcs):
        reach = _reach(m, arcs, order)
        into = reach | np.eye(m, dtype=bool)  # a reaches u, or a == u
        u, v = arcs[:, 0], arcs[:, 1]
        # sum over a in anc(u) + u, b in desc(v) + v of positive[a, b], minus the arc's own positive part
        gain = ((into[:, u].T.astype(np.float64) @ positive) * into[v]).sum(axis=1)
        pays = window.weight[u, v] - positive[u, v] + gain > 0
        if pays.all():
            break
        arcs = arcs[pays]
    return arcs


@dataclass
class _Stats:
    """What :func:`solve` reports in ``Association.stats`` (counts summed over windows and components)."""

    windows: int = 0
    components: int = 0
    not_optimal: int = 0
    bound_gap: float = 0.0
    arcs: int = 0
    pruned_arcs: int = 0
    pairs: int = 0


def _needed_pairs(comp: np.ndarray, arcs: np.ndarray, reach: np.ndarray, scored: np.ndarray) -> np.ndarray:
    """Pairs of ``comp`` that get a "same trajectory" variable: the scored reachable pairs, closed under
    "``a -> c`` is an arc and ``y[a, b]`` exists, so ``y[c, b]`` must exist" (the tie of ``y`` to the links)."""
    where = {int(g): k for k, g in enumerate(comp)}
    succ = np.zeros((len(comp), len(comp)), dtype=np.int64)
    succ[[where[u] for u in arcs[:, 0].tolist()], [where[v] for v in arcs[:, 1].tolist()]] = 1
    sub = np.ix_(comp, comp)
    reach_c = reach[sub]
    needed = reach_c & scored[sub]
    while True:
        grown = needed | ((succ.T @ needed.astype(np.int64) > 0) & reach_c)
        if (grown == needed).all():
            return needed
        needed = grown


def _solve_component(window: _Window, comp: np.ndarray, arcs: np.ndarray, reach: np.ndarray, scored: np.ndarray,
                     config: AssociationConfig, label: str, stats: _Stats) -> list[tuple[int, int]]:
    """Exact CP-SAT solution of one connected component; returns its chosen local arcs."""
    from ortools.sat.python import cp_model

    model = cp_model.CpModel()
    x = {(u, v): model.new_bool_var(f"x{u}_{v}") for u, v in arcs.tolist()}
    succ: dict[int, list[int]] = {int(a): [] for a in comp}
    pred: dict[int, list[int]] = {int(a): [] for a in comp}
    for u, v in x:
        succ[u].append(v)
        pred[v].append(u)
    for a in comp.tolist():
        if len(succ[a]) > 1:
            model.add_at_most_one(x[a, c] for c in succ[a])
        if len(pred[a]) > 1:
            model.add_at_most_one(x[c, a] for c in pred[a])
    pa, pb = np.nonzero(_needed_pairs(comp, arcs, reach, scored))
    pa, pb = comp[pa], comp[pb]
    y = {(a, b): model.new_bool_var(f"y{a}_{b}") for a, b in zip(pa.tolist(), pb.tolist())}
    for (a, b), yab in y.items():
        towards = [c for c in succ[a] if c == b or reach[c, b]]
        model.add_bool_or([x[a, c] for c in towards] + [yab.Not()])
        for c in towards:
            if c == b:
                model.add_implication(x[a, b], yab)
            else:
                model.add(yab == y[c, b]).only_enforce_if(x[a, c])
    weights = np.rint(window.weight[pa, pb] * WEIGHT_SCALE).astype(np.int64)
    model.maximize(sum(int(w) * y[a, b] for a, b, w in zip(pa.tolist(), pb.tolist(), weights.tolist()) if w))
    # the greedy merge's links (those the window allows) as a complete hint
    hinted = {(u, v) for u, v in window.hint if (u, v) in x}
    for key, var in x.items():
        model.add_hint(var, key in hinted)
    hint_succ = dict(hinted)
    for (a, b), yab in y.items():
        c = hint_succ.get(a)
        while c is not None and c != b and window.nodes[c] < window.nodes[b]:
            c = hint_succ.get(c)
        model.add_hint(yab, c == b)
    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = config.lifted_time_limit
    solver.parameters.num_workers = config.lifted_workers
    # probing in presolve costs more than it saves on these models (PETS09-S2L1: 8.8 -> 7.0 s, the same optima)
    solver.parameters.cp_model_probing_level = 0
    status = solver.solve(model)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        raise LiftedWindowError(f"lifted solver: CP-SAT found no solution for the window of frames {label} "
                                f"({len(x)} links, {len(y)} pairs) within {config.lifted_time_limit} s "
                                f"(status {solver.status_name(status)}); raise [association] lifted_time_limit "
                                "or lower lifted_window")
    stats.components += 1
    stats.pairs += len(y)
    if status != cp_model.OPTIMAL:
        stats.not_optimal += 1
        stats.bound_gap += (solver.best_objective_bound - solver.objective_value) / WEIGHT_SCALE
    return [key for key, var in x.items() if solver.boolean_value(var)]


def solve(tracklets: Sequence[Tracklet], config: AssociationConfig) -> Association:
    """Lifted association of ``tracklets`` (see the module docstring)."""
    from sotmot.solvers.greedy import solve as greedy

    n = len(tracklets)
    if n == 0:
        return Association(groups=())
    # one canonical order, so that the model, and the optimum CP-SAT picks among ties, do not depend on the input's
    tracklets = sorted(tracklets, key=link_order_key)
    # every path-cover link the IoU, velocity and gap rules allow: the objective, not an affinity gate, decides
    cands = candidate_links(tracklets, dataclasses.replace(config, min_affinity=0.0), disjoint=True)
    starts = np.array([t.start for t in tracklets], dtype=np.int64)
    ends = np.array([t.end for t in tracklets], dtype=np.int64)
    arc_u, arc_v = cands.u, cands.v  # oriented by link_order_key, i.e. by position here
    affinity = dict(zip(zip(arc_u.tolist(), arc_v.tolist()), cands.screen.affinity.tolist()))
    by_v: dict[int, list[int]] = {}
    for u, v in zip(arc_u.tolist(), arc_v.tolist()):
        by_v.setdefault(v, []).append(u)
    position = {t.id: i for i, t in enumerate(tracklets)}
    hint_succ: dict[int, int] = {}
    for group in greedy(tracklets, config).groups:
        chain = sorted(position[u] for u in group)  # positions follow link_order_key
        hint_succ.update(zip(chain[:-1], chain[1:]))
    horizon = lifted_horizon(config)
    pred = np.full(n, -1, dtype=np.int64)  # committed predecessor of each decided tracklet
    has_succ = np.zeros(n, dtype=bool)
    decided = np.zeros(n, dtype=bool)
    stats = _Stats()
    first, last = int(starts.min()), int(starts.max())
    window_start = first
    while not decided.all():
        stop = window_start + config.lifted_window
        final = stop > last
        new = np.flatnonzero(~decided & (starts < stop))
        new_set = set(new.tolist())
        tails = sorted({u for v in new.tolist() for u in by_v.get(v, ()) if decided[u] and not has_succ[u]})
        nodes = np.array(tails + new.tolist(), dtype=np.int64)
        local = {int(g): k for k, g in enumerate(nodes)}
        arcs = np.array([(local[u], local[v]) for v in new.tolist() for u in by_v.get(v, ())
                         if u in new_set or (u in local and decided[u])], dtype=np.int64).reshape(-1, 2)
        window = _window(tracklets, nodes, len(tails), arcs, pred, starts, ends, horizon, config)
        window.hint = {(local[u], local[v]) for u, v in hint_succ.items() if u in local and v in local}
        chosen = _solve_window(window, config, f"{window_start}-{stop - 1}", stats)
        commit = stop if final else window_start + config.lifted_step
        for u, v in chosen:
            gu, gv = int(nodes[u]), int(nodes[v])
            if starts[gv] < commit:
                pred[gv] = gu
                has_succ[gu] = True
        decided[new[starts[new] < commit]] = True
        window_start += config.lifted_step
    log.info("lifted: %d windows, %d components (%d not proven optimal), %d of %d links pruned, %d pairs",
             stats.windows, stats.components, stats.not_optimal, stats.pruned_arcs, stats.arcs, stats.pairs)
    links = [(tracklets[int(pred[v])].id, tracklets[v].id) for v in np.flatnonzero(pred >= 0).tolist()]
    groups = chains_from_links([t.id for t in tracklets], links)
    chosen_aff = {(tracklets[int(pred[v])].id, tracklets[v].id): affinity[int(pred[v]), v]
                  for v in np.flatnonzero(pred >= 0).tolist()}
    return Association(groups=groups, links=tuple(Link(a=u, b=v, affinity=chosen_aff[u, v]) for u, v in sorted(links)),
                       stats={"windows": stats.windows, "components": stats.components,
                              "components_not_optimal": stats.not_optimal, "bound_gap": stats.bound_gap,
                              "links": stats.arcs, "links_pruned": stats.pruned_arcs, "pairs": stats.pairs})


def _window(tracklets: Sequence[Tracklet], nodes: np.ndarray, n_tails: int, arcs: np.ndarray, pred: np.ndarray,
            starts: np.ndarray, ends: np.ndarray, horizon: int, config: AssociationConfig) -> _Window:
    """The window's lifted weights: between its new tracklets, and from each tail's trajectory to them."""
    m = len(nodes)
    a, b = np.meshgrid(np.arange(m), np.arange(n_tails, m), indexing="ij")
    a, b = a.ravel(), b.ravel()
    gap = starts[nodes[b]] - ends[nodes[a]]
    keep = (nodes[a] < nodes[b]) & (gap <= horizon)  # positions follow link_order_key
    a, b = a[keep], b[keep]
    weight = np.zeros((m, m))
    scored = np.zeros((m, m), dtype=bool)
    scored[a, b] = True
    weight[a, b] = lifted_weights(tracklets, nodes[a], nodes[b], config)
    # a tail's weight to b adds its trajectory's earlier tracklets within the horizon
    earliest = starts[nodes[n_tails:]].min() - horizon if m > n_tails else 0
    for k in range(n_tails):
        members = []
        g = int(pred[nodes[k]])
        while g >= 0 and ends[g] >= earliest:
            members.append(g)
            g = int(pred[g])
        if members:
            late = np.arange(n_tails, m)
            ea, lb = np.meshgrid(np.array(members), nodes[late], indexing="ij")
            weight[k, late] += lifted_weights(tracklets, ea.ravel(), lb.ravel(), config).reshape(ea.shape).sum(axis=0)
    return _Window(nodes=nodes, arcs=arcs, weight=weight, scored=scored, hint=set())


def _solve_window(window: _Window, config: AssociationConfig, label: str, stats: _Stats) -> list[tuple[int, int]]:
    """Prune the window's arcs, split it into connected components and solve each exactly."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    stats.windows += 1
    stats.arcs += len(window.arcs)
    m = len(window.nodes)
    order = np.argsort(window.nodes)  # positions follow link_order_key: a topological order of the arcs
    arcs = _prune(window, order)
    stats.pruned_arcs += len(window.arcs) - len(arcs)
    if len(arcs) == 0:
        return []
    reach = _reach(m, arcs, order)
    graph = coo_matrix((np.ones(len(arcs)), (arcs[:, 0], arcs[:, 1])), shape=(m, m))
    _, labels = connected_components(graph, directed=False)
    chosen: list[tuple[int, int]] = []
    for comp_label in np.unique(labels[arcs[:, 0]]):
        comp = np.flatnonzero(labels == comp_label)
        comp_arcs = arcs[labels[arcs[:, 0]] == comp_label]
        chosen += _solve_component(window, comp, comp_arcs, reach, window.scored, config, label, stats)
    return chosen
