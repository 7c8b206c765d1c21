"""The association constraint A(t1, t2), one rule at a time, with numbers computed by hand."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from helpers import tk
from sotmot.config import AssociationConfig
from sotmot.boxes import iou_matrix
from sotmot.association.checks import candidate_pairs, check_pair, check_pairs
from sotmot.association.merge import merge

CFG = AssociationConfig(min_affinity=0.5)
BOX = [100, 100, 30, 60]  # width 30: bounds 30, 20, 10 px/frame for gaps 1, 2..5, >5


def moved(dx):
    return [100 + dx, 100, 30, 60]


def test_adjacent_gap_velocity_bound_is_one_width():
    a = tk(1, [1, 2, 3], BOX)
    assert check_pair(a, tk(2, [4, 5], moved(30)), CFG).allowed  # 30 px in 1 frame = w
    c = check_pair(a, tk(2, [4, 5], moved(31)), CFG)
    assert c.failed == ("velocity",) and c.velocity == 31 and c.velocity_bound == 30 and c.velocity_gap == 1


def test_short_gap_bound_is_two_thirds_width():
    a = tk(1, [1, 2, 3], BOX)
    assert check_pair(a, tk(2, [6, 7], moved(60)), CFG).allowed  # gap 3: 20 px/frame = 2/3 w
    c = check_pair(a, tk(2, [6, 7], moved(61)), CFG)
    assert c.failed == ("velocity",) and math.isclose(c.velocity_bound, 20.0)


def test_long_gap_bound_is_one_third_width_using_mean_width():
    a = tk(1, [1, 2, 3], [100, 100, 20, 60])
    b = tk(2, [13, 14], [200, 100, 40, 60])  # gap 10; centres 110 -> 220 = 110 px; w = 30 -> bound 10
    c = check_pair(a, b, CFG)
    assert c.failed == ("velocity",)
    assert math.isclose(c.velocity, 11.0) and math.isclose(c.velocity_bound, 10.0)
    assert check_pair(a, tk(2, [13, 14], [190, 100, 40, 60]), CFG).allowed  # exactly 10 px/frame


def test_gap_longer_than_l_max_fails():
    a = tk(1, [1, 2], BOX)
    assert check_pair(a, tk(2, [62, 63], BOX), CFG).allowed  # gap 60
    c = check_pair(a, tk(2, [63, 64], BOX), CFG)
    assert c.failed == ("gap",) and c.max_gap == 61


def test_overlap_needs_mean_iou_above_tau_on_every_segment():
    a = tk(1, [1, 2, 3, 4, 5], BOX)
    same = tk(2, [4, 5, 6], BOX)
    c = check_pair(a, same, CFG)
    assert c.allowed and c.overlap_frames == 2 and c.min_segment_iou == 1.0
    # shifted by 10 px: IoU = 20*60 / (2*1800 - 1200) = 0.5, not > 0.5
    c = check_pair(a, tk(2, [4, 5, 6], moved(10)), CFG)
    assert c.failed == ("iou",) and math.isclose(c.min_segment_iou, 0.5)


def test_two_overlap_segments_are_judged_separately():
    # shared frames {2, 3} (IoU 1) and {6, 7} (b shifted 20 px: IoU 0.2); the mean over all four
    # shared frames (0.6) would pass, but the second segment alone fails
    a = tk(1, [1, 2, 3, 5, 6, 7], BOX)
    b = tk(2, [2, 3, 4, 6, 7], [BOX, BOX, BOX, moved(20), moved(20)])
    c = check_pair(a, b, CFG)
    assert c.overlap_frames == 4 and c.failed == ("iou",)
    assert math.isclose(c.min_segment_iou, iou_of_shift(20))
    assert check_pair(a, tk(2, [2, 3], BOX), CFG).allowed


def iou_of_shift(dx):
    inter = (30 - dx) * 60
    return inter / (2 * 1800 - inter)


def test_affinity_gate():
    a = tk(1, [1, 2], BOX, feature=(1, 0))
    b = tk(2, [3, 4], BOX, feature=(0, 1))  # orthogonal: affinity 1 - sqrt(2)/2 = 0.293
    c = check_pair(a, b, CFG)
    assert c.failed == ("affinity",) and math.isclose(c.affinity, 1 - math.sqrt(2) / 2)
    assert check_pair(a, b, CFG, pair_affinity=0.9).allowed


def test_a_bridge_must_be_more_certain_the_longer_it_is():
    rising = AssociationConfig(min_affinity=0.5, l_max=60, long_gap_affinity=0.7)
    a = tk(1, [1, 2], BOX)
    # gate 0.5 up to a 30-frame gap, then linear: 0.6 at 45 frames, 0.7 at 60
    assert check_pair(a, tk(2, [32, 33], BOX), rising, pair_affinity=0.55).allowed  # gap 30
    c = check_pair(a, tk(2, [47, 48], BOX), rising, pair_affinity=0.55)  # gap 45
    assert c.failed == ("bridge",) and c.velocity_gap == 45
    assert check_pair(a, tk(2, [47, 48], BOX), rising, pair_affinity=0.61).allowed
    assert check_pair(a, tk(2, [47, 48], BOX), CFG, pair_affinity=0.55).allowed  # off by default
    below_both = check_pair(a, tk(2, [47, 48], BOX), rising, pair_affinity=0.4)
    assert below_both.failed == ("affinity",)  # reported once, by the affinity rule


def test_several_failures_are_all_reported_in_order():
    c = check_pair(tk(1, [1, 2], BOX, feature=(1, 0)), tk(2, [80, 81], moved(1500), feature=(0, 1)), CFG)
    assert c.failed == ("gap", "velocity", "affinity")


def test_merge_keeps_the_higher_score_box_and_pools_features():
    a = tk(1, [1, 2, 3], BOX, scores=[0.9, 0.5, 0.9], feature=(1, 0))
    b = tk(2, [2, 3, 4], moved(3), scores=[0.8, 0.95, 0.7], feature=(0, 1))
    m = merge(a, b, new_id=7)
    assert m.id == 7 and m.frames.tolist() == [1, 2, 3, 4]
    assert m.boxes[:, 0].tolist() == [100, 103, 103, 103]
    assert m.scores.tolist() == [0.9, 0.8, 0.95, 0.7]
    np.testing.assert_allclose(m.feature, [0.5, 0.5])
    assert m.n_features == 6


def test_check_is_symmetric_and_does_not_mutate():
    a = tk(1, [1, 2, 3], BOX)
    b = tk(2, [5, 6], moved(25))
    before = (a.frames.copy(), a.boxes.copy())
    assert check_pair(a, b, CFG) == check_pair(b, a, CFG)
    np.testing.assert_array_equal(a.frames, before[0])
    np.testing.assert_array_equal(a.boxes, before[1])


def test_candidate_pairs_are_those_within_l_max():
    ts = [tk(1, [1, 2], BOX), tk(2, [50, 51], BOX), tk(3, [120, 121], BOX), tk(4, [1, 200], BOX)]
    assert candidate_pairs(ts, l_max=60).tolist() == [[0, 1], [0, 3], [1, 3], [2, 3]]  # 51 -> 120 is 69 frames


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(1, 100), st.integers(1, 8), st.floats(0, 300), st.floats(0, 300),
                          st.floats(5, 60), st.floats(-1, 1), st.integers(0, 3)), min_size=2, max_size=8))
def test_vectorised_checks_agree_with_a_plain_reading_of_the_rules(specs):
    """check_pairs against a direct, loop-by-loop statement of A(t1, t2) on the merged trajectory."""
    ts = []
    for k, (start, length, x, y, w, f, hole) in enumerate(specs):
        frames = np.arange(start, start + length + hole)
        frames = np.delete(frames, slice(1, 1 + hole)) if hole and length > 1 else frames[:max(length, 1)]
        boxes = [[x + 3 * t, y, w, 2 * w] for t in range(len(frames))]
        ts.append(tk(k, frames, boxes, feature=(f, 1 - abs(f)), scores=np.linspace(0.5, 1, len(frames))))
    pairs = np.array([(i, j) for i in range(len(ts)) for j in range(len(ts)) if i != j])
    from sotmot.appearance import affinity_rows
    aff = affinity_rows(np.stack([ts[i].feature for i in pairs[:, 0]]), np.stack([ts[j].feature for j in pairs[:, 1]]))
    screen = check_pairs(ts, pairs, aff, CFG, complete=True)
    for r, (i, j) in enumerate(pairs):
        assert screen.allowed[r] == plain_rules(ts[i], ts[j], aff[r], CFG), (i, j)
        assert screen.check(r) == check_pair(ts[i], ts[j], CFG, pair_affinity=aff[r])
    fast = check_pairs(ts, pairs, aff, CFG)
    np.testing.assert_array_equal(fast.allowed, screen.allowed)


def plain_rules(a, b, aff, cfg):
    """A(a, b) read straight from the paper's wording, one frame at a time."""
    if aff < cfg.min_affinity:
        return False
    fa, fb = dict(zip(a.frames.tolist(), range(len(a)))), dict(zip(b.frames.tolist(), range(len(b))))
    shared = sorted(set(fa) & set(fb))
    segment = []
    for n, f in enumerate(shared + [None]):
        if segment and (f is None or f != segment[-1] + 1):
            ious = [iou_matrix(a.boxes[fa[g]], b.boxes[fb[g]])[0, 0] for g in segment]
            if not np.mean(ious) > cfg.tau_iou:
                return False
            segment = []
        if f is not None:
            segment.append(f)
    merged = merge(a, b, new_id=0)
    lo, hi = max(a.start, b.start), min(a.end, b.end)
    w0, w1 = (lo, hi) if lo <= hi else (hi + 1, lo - 1)  # gaps touching the common span or the junction
    inner = max(a.max_gap, b.max_gap)
    for k in range(len(merged) - 1):
        f1, f2 = int(merged.frames[k]), int(merged.frames[k + 1])
        if f2 - f1 > cfg.l_max:
            return False
        if f2 >= w0 and f1 <= w1:
            c1, c2 = merged.boxes[k, :2] + merged.boxes[k, 2:] / 2, merged.boxes[k + 1, :2] + merged.boxes[k + 1, 2:] / 2
            w = (merged.boxes[k, 2] + merged.boxes[k + 1, 2]) / 2
            factor = 1.0 if f2 - f1 == 1 else (2 / 3 if f2 - f1 <= cfg.short_gap else 1 / 3)
            if np.linalg.norm(c2 - c1) / (f2 - f1) > factor * w:
                return False
    return inner <= cfg.l_max


def test_regression_interleaved_pair_checks_the_gaps_it_fills():
    # found by hypothesis: a trajectory with a hole at frame 2 and a one-box tracklet 200 px away
    # in that hole; the first windowed check looked only strictly inside the common span and let
    # the 200 px jumps through
    a = tk(1, [1, 3], BOX)
    b = tk(2, [2], moved(200))
    c = check_pair(a, b, CFG)
    assert c.failed == ("velocity",) and c.velocity == 200 and c.velocity_gap == 1


def test_a_large_check_split_into_pieces_gives_the_same_answers(monkeypatch):
    import sotmot.association.checks as checks

    rng = np.random.default_rng(3)
    ts = [tk(k, np.arange(s, s + n), [100 + 15 * (k % 4), 100, 30, 60], feature=(1.0, 0.1 * (k % 3)))
          for k, (s, n) in enumerate(zip(rng.integers(1, 80, 40), rng.integers(1, 25, 40)))]
    pairs = candidate_pairs(ts, CFG.l_max)
    aff = rng.uniform(0.3, 1.0, len(pairs))
    whole = check_pairs(ts, pairs, aff, CFG, complete=True)
    monkeypatch.setattr(checks, "CHECK_FRAMES", 200)
    pieces = check_pairs(ts, pairs, aff, CFG, complete=True)
    for name in ("allowed", "overlap", "max_gap", "velocity_gap", "speed", "bound"):
        np.testing.assert_array_equal(getattr(pieces, name), getattr(whole, name))
    np.testing.assert_array_equal(pieces.min_iou, whole.min_iou)  # NaN where no shared frames, in both
    assert whole.allowed.any() and not whole.allowed.all()


def test_pair_affinities_in_chunks_equal_affinity_rows():
    from sotmot.appearance import affinity_rows, pair_affinities, unit

    rng = np.random.default_rng(0)
    feats = rng.normal(size=(50, 8))
    pairs = rng.integers(0, 50, (300, 2))
    np.testing.assert_allclose(pair_affinities(unit(feats), pairs, chunk=7),
                               affinity_rows(feats[pairs[:, 0]], feats[pairs[:, 1]]), atol=1e-12)


def test_a_rule_is_one_entry_checked_explained_and_drawn(monkeypatch):
    """Adding a rule to the table is enough for the checker, the explanation and the drawing to use it."""
    from sotmot.association import rules as constraints
    from sotmot.inspect import explain
    from sotmot.config import TrackerConfig

    tall = constraints.Rule("gap", ("max_gap",), lambda m, a: np.asarray(m["max_gap"]) > 3,
                            lambda d, a: f"short gaps only: {d['max_gap']}", (1, 2, 3))
    table = constraints.RULES[:1] + (tall,)
    monkeypatch.setattr(constraints, "RULES", table)  # what editing the table in rules.py does
    monkeypatch.setattr(explain, "RULES", table)
    failures = constraints.rule_failures(0, np.nan, np.array([2, 5]), 0.0, np.inf, np.array([0.9, 0.9]), CFG)
    assert set(failures) == {"iou", "gap"} and failures["gap"].tolist() == [False, True]
    lines = explain._verdict({"overlap_frames": 0, "max_gap": 5, "ok_iou": True, "ok_gap": False}, TrackerConfig())
    assert lines == ["IoU: no shared frames (rule does not apply) -> ok", "short gaps only: 5 -> FAILS"]
