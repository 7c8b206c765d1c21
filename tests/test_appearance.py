"""The ONNX re-ID backend on real crops, and the affinity definition."""

import math

import numpy as np
import pytest

from conftest import DATA, require
from sotmot.appearance import affinity, affinity_rows, make_embedder, normalize
from sotmot.config import AppearanceConfig
from sotmot.errors import ModelError
from sotmot.io import FrameReader, read_ground_truth, read_seqinfo


def test_affinity_definition():
    a = np.array([[1.0, 0.0]])
    assert affinity(a, a)[0, 0] == pytest.approx(1.0)
    assert affinity(a, [[0.0, 1.0]])[0, 0] == pytest.approx(1 - math.sqrt(2) / 2)
    assert affinity(a, [[-1.0, 0.0]])[0, 0] == pytest.approx(0.0)
    assert affinity([[3.0, 0.0]], [[0.5, 0.0]])[0, 0] == pytest.approx(1.0)  # scale does not matter
    rng = np.random.default_rng(0)
    x, y = rng.normal(size=(5, 16)), rng.normal(size=(5, 16))
    np.testing.assert_allclose(affinity_rows(x, y), np.diag(affinity(x, y)))


def test_no_model_runs_the_bundled_one_and_a_missing_one_says_how_to_point_at_one(monkeypatch):
    from sotmot.models import MODELS

    monkeypatch.delenv("SOTMOT_REID_MODEL", raising=False)
    assert make_embedder(AppearanceConfig(backend="onnx")).path == MODELS["reid"].path
    with pytest.raises(ModelError, match="not found.*--reid-model"):
        make_embedder(AppearanceConfig(model="/nonexistent/model.onnx"))


def test_a_file_that_is_not_a_model_is_a_clear_error(tmp_path):
    bad = tmp_path / "bad.onnx"
    bad.write_bytes(b"this is not onnx")
    with pytest.raises(ModelError, match="cannot be loaded as an ONNX model"):
        make_embedder(AppearanceConfig(model=str(bad), backend="onnx"))
    pytest.importorskip("openvino")
    with pytest.raises(ModelError, match="cannot be loaded by OpenVINO") as caught:
        make_embedder(AppearanceConfig(model=str(bad), backend="openvino"))
    assert "\n" not in str(caught.value) and "src/inference" not in str(caught.value)  # one line a user can read


@pytest.fixture(scope="module")
def pets_crops():
    info = read_seqinfo(require(DATA / "PETS09-S2L1"))
    gt = read_ground_truth(info.gt_path, info.length)
    frame = 1
    idx = np.flatnonzero(gt.frames == frame)
    return FrameReader(info)(frame), gt.boxes[idx], gt.ids[idx], info, gt


def test_embeddings_are_unit_float32_and_flip_invariant(model_0288, pets_crops):
    frame, boxes, _, _, _ = pets_crops
    emb = make_embedder(AppearanceConfig(model=str(model_0288)))
    f = emb.embed(frame, boxes)
    assert f.shape == (len(boxes), 256) and f.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(f, axis=1), 1.0, atol=1e-5)
    # flip-averaging (paper eq. 1) makes the feature of a mirrored image the same
    mirrored = np.ascontiguousarray(frame[:, ::-1])
    mb = boxes.copy()
    mb[:, 0] = frame.shape[1] - boxes[:, 0] - boxes[:, 2]
    np.testing.assert_allclose(emb.embed(mirrored, mb), f, atol=2e-3)
    no_flip = make_embedder(AppearanceConfig(model=str(model_0288), flip=False)).embed(frame, boxes)
    assert not np.allclose(no_flip, f, atol=1e-3)


def test_same_person_is_more_similar_than_other_people(model_0288, pets_crops):
    _, _, _, info, gt = pets_crops
    reader = FrameReader(info)
    emb = make_embedder(AppearanceConfig(model=str(model_0288)))
    a = np.flatnonzero(gt.frames == 10)
    b = np.flatnonzero(gt.frames == 11)
    fa = emb.embed(reader(10), gt.boxes[a])
    fb = emb.embed(reader(11), gt.boxes[b])
    aff = affinity(fa, fb)
    same = gt.ids[a][:, None] == gt.ids[b][None, :]
    assert aff[same].mean() > aff[~same].mean() + 0.15
    # the best match of nearly every person one frame later is that person
    assert (gt.ids[b][aff.argmax(axis=1)] == gt.ids[a]).mean() >= 0.8


def test_boxes_partly_outside_the_image_are_embedded(model_0288, pets_crops):
    frame, _, _, _, _ = pets_crops
    emb = make_embedder(AppearanceConfig(model=str(model_0288)))
    boxes = np.array([[-20, -30, 50, 100], [740, 500, 60, 120], [2000, 2000, 10, 10]], float)
    f = emb.embed(frame, boxes)
    assert np.isfinite(f).all() and f.shape == (3, 256)
    assert emb.embed(frame, np.zeros((0, 4))).shape == (0, 256)


def test_normalize_leaves_zero_rows_alone():
    out = normalize(np.array([[0.0, 0.0], [3.0, 4.0]]))
    np.testing.assert_allclose(out, [[0, 0], [0.6, 0.8]])


def test_flip_average_and_non_finite_outputs_are_refused():
    from sotmot.appearance import flip_average
    from sotmot.errors import ModelError

    a = np.array([[3.0, 0.0]])
    b = np.array([[0.0, 2.0]])
    assert np.allclose(flip_average(a, b, "m"), [[np.sqrt(0.5), np.sqrt(0.5)]])
    assert np.allclose(flip_average(a, None, "m"), [[1.0, 0.0]])
    with pytest.raises(ModelError, match="m: the model gave NaN or infinite features"):
        flip_average(np.array([[np.nan, 1.0]]), None, "m")
    with pytest.raises(ModelError):
        flip_average(a, np.array([[np.inf, 0.0]]), "m")


def test_the_affinity_gate_is_one_rule_and_nan_never_passes():
    from sotmot.config import AssociationConfig
    from sotmot.association.rules import passes_affinity_gate, rule_failures

    cfg = AssociationConfig(min_affinity=0.5)
    assert passes_affinity_gate([0.49, 0.5, np.nan], cfg).tolist() == [False, True, False]
    assert rule_failures(0, np.nan, 0, 0.0, np.inf, np.array([np.nan]), cfg)["affinity"].tolist() == [True]


def test_both_backends_refuse_a_model_of_the_wrong_shape_with_one_message(tmp_path):
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper

    x = helper.make_tensor_value_info("data", TensorProto.FLOAT, ["N", 3, 64, 64])
    y = helper.make_tensor_value_info("out", TensorProto.FLOAT, ["N", 3, 64, 64])
    graph = helper.make_graph([helper.make_node("Relu", ["data"], ["out"])], "g", [x], [y])
    path = tmp_path / "wrong.onnx"
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)]), str(path))
    for backend in ("onnx", "torch"):
        with pytest.raises(ModelError, match="expected one input of shape N x 3 x 256 x 128"):
            make_embedder(AppearanceConfig(model=str(path), backend=backend))


def test_mirrored_crops_are_the_crops_reversed_left_to_right_after_the_crops():
    from sotmot.appearance.base import with_mirrored

    crops = np.random.default_rng(0).integers(0, 256, (3, 8, 6, 3), dtype=np.uint8)
    for given in (crops, crops[::-1]):  # a view with a negative stride too
        np.testing.assert_array_equal(with_mirrored(given), np.concatenate([given, given[:, :, ::-1]]))
