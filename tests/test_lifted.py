"""The lifted solver: exact on small instances, never skips a compatible tracklet, fails loudly."""

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import direction, one_person_in_three_pieces, tk
from solvers import get_solver
from solvers.flow_common import chains_from_links
from solvers.lifted import LiftedWindowError, lifted_objective, link_pairs
from sotmot.config import AssociationConfig
from sotmot.constraints import link_order_key
from sotmot.graph import candidate_links

# one window covers every test instance, so the solver's answer is the exact optimum of the whole instance
CFG = AssociationConfig(min_affinity=0.5, lifted_threshold=0.5, lifted_window=1000, lifted_step=1000)
BOX = [100, 100, 30, 60]


def allowed_links(ts, cfg) -> list[tuple[int, int]]:
    """The path-cover links the IoU, velocity and gap rules allow (no affinity gate), as ``(u id, v id)``."""
    cands = candidate_links(ts, dataclasses.replace(cfg, min_affinity=0.0), disjoint=True)
    return [(ts[u].id, ts[v].id) for u, v in zip(cands.u.tolist(), cands.v.tolist())]


def brute_force_best(ts, cfg) -> float:
    """The best lifted objective over every chain cover built from the links the IoU, velocity and gap rules allow."""
    arcs = allowed_links(ts, cfg)
    best = lifted_objective(ts, [(t.id,) for t in ts], cfg)
    for k in range(1, len(arcs) + 1):
        for subset in itertools.combinations(arcs, k):
            tails, heads = [u for u, _ in subset], [v for _, v in subset]
            if len(set(tails)) < k or len(set(heads)) < k:
                continue
            best = max(best, lifted_objective(ts, chains_from_links([t.id for t in ts], subset), cfg))
    return best


SPECS = st.lists(st.tuples(st.integers(1, 30), st.integers(1, 4), st.sampled_from([100, 112, 300]),
                           st.sampled_from([0.0, 20.0, 45.0, 70.0])), min_size=1, max_size=6)


@settings(max_examples=40, deadline=None)
@given(specs=SPECS)
def test_cp_sat_optimum_equals_brute_force_and_beats_greedy(specs):
    ts = tuple(tk(k + 1, np.arange(s, s + n), [x, 100, 30, 60], feature=direction(angle))
               for k, (s, n, x, angle) in enumerate(specs))
    lifted = get_solver("lifted")(ts, CFG)
    value = lifted_objective(ts, lifted.groups, CFG)
    assert value == pytest.approx(brute_force_best(ts, CFG), abs=0.05)  # integer weights: 0.01 per pair
    # greedy's grouping is one of the candidates whenever each of its groups is a chain of allowed links (greedy
    # may also join trajectories whose consecutive tracklets are no allowed link; then it is outside the search)
    greedy = get_solver("greedy")(ts, CFG).groups
    by_id = {t.id: t for t in ts}
    chains = [sorted((by_id[u] for u in g), key=link_order_key) for g in greedy]
    arcs = set(allowed_links(ts, CFG))
    if all((a.id, b.id) in arcs for chain in chains for a, b in zip(chain, chain[1:])):
        assert value >= lifted_objective(ts, greedy, CFG) - 0.05
    assert lifted.stats["components_not_optimal"] == 0


def test_person_16_pattern_flow_skips_a_tracklet_lifted_does_not():
    first, middle, last = one_person_in_three_pieces()
    ts = (tk(1, [1, 2, 3], BOX, feature=first), tk(2, [5, 6, 7], BOX, feature=middle),
          tk(3, [9, 10, 11], BOX, feature=last))
    assert get_solver("flow")(ts, CFG).groups == ((1, 3), (2,))  # the consecutive-link cover jumps over 2
    lifted = get_solver("lifted")(ts, CFG)
    assert lifted.groups == ((1, 2, 3),)
    assert [(link.a, link.b) for link in lifted.links] == [(1, 2), (2, 3)]
    # what pays for the link 1 -> 2: the pairs it joins, 1-2 and 1-3 (9 * 0.1 and 9 * 0.3)
    pairs = link_pairs(ts, 0, CFG)
    assert {(a, b) for a, b, _ in pairs} == {(1, 2), (1, 3)}
    assert sum(w for _, _, w in pairs) == pytest.approx(9 * 0.1 + 9 * 0.3, abs=0.05)


def test_windows_carry_a_trajectory_across_their_borders():
    # one person in 3-frame pieces over 100 frames, decided in windows of 20 frames that commit 10
    ts = tuple(tk(k, np.arange(5 * k, 5 * k + 3), BOX, feature=(1.0, 0.05 * (k % 2))) for k in range(1, 20))
    cfg = AssociationConfig(min_affinity=0.5, lifted_window=20, lifted_step=10)
    result = get_solver("lifted")(ts, cfg)
    assert result.groups == (tuple(range(1, 20)),)
    assert result.stats["windows"] > 5


def test_a_window_without_a_solution_raises_and_names_its_frames():
    ts = tuple(tk(k, np.arange(3 * k, 3 * k + 3), BOX, feature=(1.0, 0.1 * k)) for k in range(1, 8))
    with pytest.raises(LiftedWindowError, match=r"frames 3-62.*lifted_time_limit"):
        get_solver("lifted")(ts, AssociationConfig(min_affinity=0.5, lifted_time_limit=1e-9))


def test_links_that_can_never_pay_are_pruned_and_strangers_stay_apart():
    ts = (tk(1, [1, 2, 3], BOX, feature=(1.0, 0.0)), tk(2, [5, 6], BOX, feature=(0.0, 1.0)))
    result = get_solver("lifted")(ts, CFG)
    assert result.groups == ((1,), (2,))
    assert result.stats["links"] == 1 and result.stats["links_pruned"] == 1
