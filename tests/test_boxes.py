import numpy as np
import pytest

from sotmot.boxes import (centers, iom_matrix, iou_aligned, iou_matrix, nms, xywh_to_xyxy,
                          xyxy_to_xywh)


def test_iou_hand_computed():
    a = np.array([[0, 0, 10, 10]])
    b = np.array([[5, 0, 10, 10], [0, 0, 10, 10], [20, 20, 5, 5], [0, 0, 5, 5]])
    # overlap 5x10 = 50, union 150; identical; disjoint; contained 25/100
    np.testing.assert_allclose(iou_matrix(a, b), [[50 / 150, 1.0, 0.0, 0.25]])


def test_iom_is_intersection_over_smaller_box():
    a = np.array([[0, 0, 10, 10]])
    b = np.array([[0, 0, 5, 5], [5, 0, 10, 10]])
    np.testing.assert_allclose(iom_matrix(a, b), [[1.0, 0.5]])


def test_touching_boxes_and_degenerate_boxes_have_zero_overlap():
    assert iou_matrix([0, 0, 10, 10], [10, 0, 10, 10])[0, 0] == 0.0
    assert iou_matrix([0, 0, 0, 0], [0, 0, 0, 0])[0, 0] == 0.0


def test_iou_aligned_matches_matrix_diagonal():
    rng = np.random.default_rng(1)
    a = np.c_[rng.uniform(0, 50, (20, 2)), rng.uniform(1, 30, (20, 2))]
    b = a + rng.normal(0, 5, a.shape)
    b[:, 2:] = np.abs(b[:, 2:]) + 1
    np.testing.assert_allclose(iou_aligned(a, b), np.diag(iou_matrix(a, b)))


def test_conversions_round_trip_and_centers():
    b = np.array([[1.0, 2.0, 3.0, 4.0]])
    np.testing.assert_allclose(xywh_to_xyxy(b), [[1, 2, 4, 6]])
    np.testing.assert_allclose(xyxy_to_xywh(xywh_to_xyxy(b)), b)
    np.testing.assert_allclose(centers(b), [[2.5, 4.0]])


def test_nms_iou_keeps_best_and_distant_boxes():
    boxes = np.array([[0, 0, 10, 10], [1, 0, 10, 10], [50, 50, 10, 10]])
    scores = np.array([0.9, 0.95, 0.5])
    # box 1 (best) suppresses box 0 (IoU 90/110 > 0.6); box 2 is far away
    assert nms(boxes, scores, 0.6, "iou").tolist() == [1, 2]


def test_nms_iom_removes_a_small_box_inside_a_large_one_but_iou_does_not():
    boxes = np.array([[0, 0, 100, 200], [10, 10, 30, 60]])
    scores = np.array([2.0, 1.0])
    assert nms(boxes, scores, 0.6, "iou").tolist() == [0, 1]
    assert nms(boxes, scores, 0.6, "iom").tolist() == [0]


def test_nms_ties_break_by_index_and_empty_input():
    boxes = np.array([[0, 0, 10, 10], [0, 0, 10, 10]])
    assert nms(boxes, np.array([1.0, 1.0]), 0.5).tolist() == [0]
    assert nms(np.zeros((0, 4)), np.zeros(0), 0.5).tolist() == []


def test_bad_shapes_and_kinds_raise():
    with pytest.raises(ValueError):
        iou_matrix(np.zeros((2, 3)), np.zeros((2, 4)))
    with pytest.raises(ValueError):
        nms(np.zeros((2, 4)), np.zeros(3), 0.5)
    with pytest.raises(ValueError):
        nms(np.ones((2, 4)), np.zeros(2), 0.5, "dice")


def test_nms_row_by_row_equals_the_matrix_and_stays_small(monkeypatch):
    import tracemalloc

    from sotmot import boxes as boxes_module

    rng = np.random.default_rng(1)
    xy = rng.uniform(0, 400, size=(3000, 2))
    b = np.hstack([xy, rng.uniform(10, 60, size=(3000, 2))])
    s = rng.uniform(-1, 2, size=3000)
    tracemalloc.start()
    rows = nms(b, s, 0.5, "iom")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6  # a 3000 x 3000 float matrix alone is 72 MB
    monkeypatch.setattr(boxes_module, "NMS_MATRIX_MAX", 10_000)
    assert np.array_equal(rows, nms(b, s, 0.5, "iom"))
