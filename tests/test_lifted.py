"""The lifted solver: exact on small instances, never skips a compatible tracklet, fails loudly."""

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import direction, one_person_in_three_pieces, tk
from sotmot.association import get_solver
from sotmot.association.flow_network import chains_from_links
from sotmot.solvers.lifted import LiftedWindowError
from sotmot.association.objective import lifted_objective, link_pairs, pair_scores
from sotmot.config import AssociationConfig
from sotmot.association.merge import link_order_key
from sotmot.association.candidates import candidate_links

# one window covers every test instance, so the solver's answer is the exact optimum of the whole instance; the
# threshold costs keep the hand-computed weights of these tests simple (the learned costs have their own tests)
CFG = AssociationConfig(min_affinity=0.5, lifted_costs="threshold", lifted_threshold=0.5, lifted_window=1000,
                        lifted_step=1000)
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


@pytest.mark.parametrize("cfg", [CFG, dataclasses.replace(CFG, lifted_costs="learned")], ids=["threshold", "learned"])
@settings(max_examples=40, deadline=None)
@given(specs=SPECS)
def test_cp_sat_optimum_equals_brute_force_and_beats_greedy(cfg, specs):
    ts = tuple(tk(k + 1, np.arange(s, s + n), [x, 100, 30, 60], feature=direction(angle))
               for k, (s, n, x, angle) in enumerate(specs))
    lifted = get_solver("lifted")(ts, cfg)
    value = lifted_objective(ts, lifted.groups, cfg)
    # the model's weights are rounded to 0.01: each scored pair may be off by 0.005 in either grouping
    slack = 0.01 * len(ts) ** 2
    assert value == pytest.approx(brute_force_best(ts, cfg), abs=slack)
    # greedy's grouping is one of the candidates whenever each of its groups is a chain of allowed links (greedy
    # may also join trajectories whose consecutive tracklets are no allowed link; then it is outside the search)
    greedy = get_solver("greedy")(ts, cfg).groups
    by_id = {t.id: t for t in ts}
    chains = [sorted((by_id[u] for u in g), key=link_order_key) for g in greedy]
    arcs = set(allowed_links(ts, cfg))
    if all((a.id, b.id) in arcs for chain in chains for a, b in zip(chain, chain[1:])):
        assert value >= lifted_objective(ts, greedy, cfg) - slack
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
    cfg = dataclasses.replace(CFG, lifted_window=20, lifted_step=10)
    result = get_solver("lifted")(ts, cfg)
    assert result.groups == (tuple(range(1, 20)),)
    assert result.stats["windows"] > 5


def test_a_window_without_a_solution_raises_and_names_its_frames():
    ts = tuple(tk(k, np.arange(3 * k, 3 * k + 3), BOX, feature=(1.0, 0.1 * k)) for k in range(1, 8))
    with pytest.raises(LiftedWindowError, match=r"frames 3-32.*lifted_time_limit"):
        get_solver("lifted")(ts, AssociationConfig(min_affinity=0.5, lifted_time_limit=1e-9))


def test_links_that_can_never_pay_are_pruned_and_strangers_stay_apart():
    ts = (tk(1, [1, 2, 3], BOX, feature=(1.0, 0.0)), tk(2, [5, 6], BOX, feature=(0.0, 1.0)))
    result = get_solver("lifted")(ts, CFG)
    assert result.groups == ((1,), (2,))
    assert result.stats["links"] == 1 and result.stats["links_pruned"] == 1


def features_with_affinities(affinity: np.ndarray) -> np.ndarray:
    """Unit features whose pairwise affinities ``1 - ||f_i - f_j|| / 2`` are ``affinity`` (symmetric, 1 on the
    diagonal), from the Gram matrix of the cosines they imply."""
    cosine = 1.0 - 2.0 * (1.0 - affinity) ** 2
    values, vectors = np.linalg.eigh(cosine)
    assert values.min() > -1e-9, "no unit vectors have these affinities"
    return vectors * np.sqrt(np.clip(values, 0.0, None))


def test_learned_costs_keep_two_people_apart_where_long_tracklets_outweigh_a_clear_short_link():
    # MOT17-09-FRCNN, persons 8 and 11: long pieces 1 and 4 of one person (affinity 0.71), person two's long
    # piece 3 between them at a mediocre 0.54 / 0.55 to either, and its short piece 2 (6 boxes) at a clear 0.75
    aff = np.full((4, 4), 0.4)  # the short piece to person one's pieces
    np.fill_diagonal(aff, 1.0)
    for (i, j), a in {(0, 2): 0.54, (2, 3): 0.55, (0, 3): 0.71, (1, 2): 0.75}.items():
        aff[i, j] = aff[j, i] = a
    f = features_with_affinities(aff)
    ts = (tk(1, np.arange(1, 31), BOX, feature=f[0]), tk(2, np.arange(1, 7), [300, 100, 30, 60], feature=f[1]),
          tk(3, np.arange(35, 56), BOX, feature=f[2]), tk(4, np.arange(60, 90), BOX, feature=f[3]))
    # the threshold costs: 30 * 21 * 0.04 + 21 * 30 * 0.05 for the two cross pairs beat the short link's 6 * 21 * 0.25
    assert get_solver("lifted")(ts, CFG).groups == ((1, 3, 4), (2,))
    learned = dataclasses.replace(CFG, lifted_costs="learned",
                                  lifted_coefficients=AssociationConfig().lifted_coefficients)
    assert get_solver("lifted")(ts, learned).groups == ((1, 4), (2, 3))


def test_learned_costs_ask_more_affinity_of_longer_tracklets():
    cfg = AssociationConfig()  # the shipped coefficients
    affinity = np.linspace(0.0, 1.0, 1001)
    pays_from = [affinity[np.argmax(pair_scores(affinity, np.full(1001, n), np.full(1001, 40.0), cfg) > 0)]
                 for n in (1.0, 5.0, 30.0)]
    assert 0.3 < pays_from[0] < pays_from[1] < pays_from[2] < 0.7
    # the score follows the formula of the coefficients, on the shorter tracklet's length
    c0, c1, c2, c3 = cfg.lifted_coefficients
    assert pair_scores(np.array([0.6]), np.array([40.0]), np.array([8.0]), cfg)[0] == pytest.approx(
        c0 + c1 * 0.6 + c2 * np.log(8.0) + c3 * 0.6 * np.log(8.0))


def test_tracklet_identities_and_the_learned_costs_fit(tmp_path):
    from conftest import write_sequence
    from sotmot.fitting.lifted import fit_lifted_costs, lifted_pair_samples, tracklet_identities
    from sotmot.io import read_seqinfo

    # two people over 8 frames; tracklet 3 covers person 1, then (a wrong link) person 2 for 3 of its 5 boxes
    gt = [f"{f},1,10,10,20,30,1,1,1" for f in range(1, 9)] + [f"{f},2,60,10,20,30,1,1,1" for f in range(1, 9)]
    seq = write_sequence(tmp_path, [], length=8, width=96, height=64, images=False, gt_lines=gt)
    one, two = [10, 10, 20, 30], [60, 10, 20, 30]
    ts = (tk(1, [1, 2], one), tk(2, [1, 2, 3], two), tk(3, [4, 5, 6, 7, 8], [one, one, two, two, two]),
          tk(4, [7, 8], [5, 40, 10, 10]))  # 4: on nobody
    ids = tracklet_identities(ts, read_seqinfo(seq), tmp_path / "work")
    assert ids[0] >= 0 and ids[1] >= 0 and ids[0] != ids[1]
    assert ids[2] == ids[1] and ids[3] == -1  # the majority: 3 of 5 boxes
    # on a moving camera tracklets hold reference-frame boxes: matched in each frame's own pixels through the motion
    from sotmot.motion import CameraMotion

    reference = np.tile(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), (9, 1, 1))
    reference[:, 0, 2] = -6.0 * np.arange(9)  # the camera pans right 6 px a frame: frame f's x is 6 f further on
    motion = CameraMotion(reference, reference.copy(), np.ones(9), True)
    moved = tuple(tk(t.id, t.frames.tolist(), motion.to_ref(t.frames, t.boxes)) for t in ts)
    assert tracklet_identities(moved, read_seqinfo(seq), tmp_path / "moved", motion).tolist() == ids.tolist()
    assert tracklet_identities(moved, read_seqinfo(seq), tmp_path / "unmapped").tolist() != ids.tolist()
    features, same = lifted_pair_samples(ts, ids, AssociationConfig())
    # 1-3 and 2-3 (one person); 1-2 overlap in time, 4 is nobody's
    assert same.tolist() == [0.0, 1.0] and features.shape == (2, 3)
    # a long tracklet needs more affinity: same-person affinity rises with length, other people's does not
    rng = np.random.default_rng(0)
    short = rng.integers(1, 31, 4000).astype(float)
    label = rng.random(4000) < 0.15
    affinity = np.where(label, 0.55 + 0.05 * np.log(short), 0.35) + rng.normal(0, 0.06, 4000)
    c0, c1, c2, c3 = fit_lifted_costs([(np.stack([affinity, np.log(short), affinity * np.log(short)], 1),
                                        label.astype(float))])
    pays_from = [-(c0 + c2 * np.log(n)) / (c1 + c3 * np.log(n)) for n in (1.0, 30.0)]
    assert 0.4 < pays_from[0] < pays_from[1] < 0.6
    with pytest.raises(ValueError, match="both"):
        fit_lifted_costs([(features[:1], same[:1])])
