"""The torch re-ID backend computes the ONNX model's embeddings."""

import numpy as np
import pytest

from conftest import DATA, MODELS, require
from sotmot.appearance import make_embedder
from sotmot.appearance.base import crop_boxes
from sotmot.config import AppearanceConfig
from sotmot.errors import ModelError
from sotmot.io import FrameReader, read_ground_truth, read_seqinfo

torch = pytest.importorskip("torch", reason="the torch extra is not installed (pip install 'sotmot[torch]')")
onnx = pytest.importorskip("onnx", reason="the torch extra is not installed (pip install 'sotmot[torch]')")


@pytest.mark.parametrize("model", ["person-reidentification-retail-0288.onnx",
                                   "person-reidentification-retail-0277.onnx"])
def test_torch_matches_onnxruntime_on_real_crops(model, real_crops):
    path = str(require(MODELS / model))
    ref = make_embedder(AppearanceConfig(model=path, backend="onnx")).embed_crops(real_crops)
    got = make_embedder(AppearanceConfig(model=path, backend="torch")).embed_crops(real_crops)
    assert got.shape == ref.shape == (len(real_crops), 256)
    assert np.abs(got - ref).max() < 1e-4


def test_weights_are_trainable_and_a_state_dict_round_trips(model_0288, real_crops, tmp_path):
    emb = make_embedder(AppearanceConfig(model=str(model_0288), backend="torch"))
    params = [p for p in emb.module.parameters()]
    assert len(params) > 100 and all(p.requires_grad for p in params)
    torch.save(emb.module.state_dict(), tmp_path / "m.pt")
    other = make_embedder(AppearanceConfig(model=str(model_0288), backend="torch"))
    with torch.no_grad():
        for p in other.module.parameters():
            p.add_(0.01)
    assert np.abs(other.embed_crops(real_crops[:4]) - emb.embed_crops(real_crops[:4])).max() > 1e-3
    other.module.load_state_dict(torch.load(tmp_path / "m.pt"))
    np.testing.assert_array_equal(other.embed_crops(real_crops[:4]), emb.embed_crops(real_crops[:4]))


def test_a_model_of_the_wrong_shape_is_refused(tmp_path):
    from onnx import TensorProto, helper

    x = helper.make_tensor_value_info("x", TensorProto.FLOAT, ["N", 3, 64, 64])
    y = helper.make_tensor_value_info("y", TensorProto.FLOAT, ["N", 3, 64, 64])
    graph = helper.make_graph([helper.make_node("Relu", ["x"], ["y"])], "not-reid", [x], [y])
    path = tmp_path / "classifier.onnx"
    onnx.save(helper.make_model(graph), str(path))
    with pytest.raises(ModelError, match="expected one input of shape N x 3 x 256 x 128"):
        make_embedder(AppearanceConfig(model=str(path), backend="torch"))


def test_cuda_without_a_gpu_is_an_error_not_a_fallback(model_0288):
    if torch.cuda.is_available():
        pytest.skip("this machine has a CUDA GPU")
    with pytest.raises(ModelError, match="no CUDA GPU"):
        make_embedder(AppearanceConfig(model=str(model_0288), backend="torch", device="cuda"))


def test_one_training_step_lowers_the_triplet_loss_on_a_fixed_batch(model_0288, real_crops):
    from sotmot.train import batch_hard_triplet

    emb = make_embedder(AppearanceConfig(model=str(model_0288), backend="torch"))
    batch = real_crops[:12]
    labels = torch.tensor([0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3])  # a hard, arbitrary grouping
    params = list(emb.module.parameters())[-12:]
    opt = torch.optim.SGD(params, lr=1e-2)
    before = batch_hard_triplet(emb.forward_crops(batch), labels, 0.3)
    opt.zero_grad()
    before.backward()
    opt.step()
    with torch.no_grad():
        after = batch_hard_triplet(emb.forward_crops(batch), labels, 0.3)
    assert float(after) < float(before.detach())


def test_a_trained_checkpoint_loads_back_with_identical_embeddings(model_0288, real_crops, tmp_path):
    from sotmot.train import TrainConfig, train

    seq = require(DATA / "MOT16-05-clip30")
    out = tmp_path / "tuned.pt"
    summary = train([seq], AppearanceConfig(model=str(model_0288), backend="torch"), out,
                    TrainConfig(epochs=1, per_identity=4, lr=1e-3))
    assert out.is_file() and summary["identities_train"] >= 2 and len(summary["history"]) == 1
    saved = torch.load(out, weights_only=True)
    a = make_embedder(AppearanceConfig(model=str(model_0288), backend="torch", weights=str(out)))
    b = make_embedder(AppearanceConfig(model=str(model_0288), backend="torch"))
    b.module.load_state_dict(saved["state_dict"])
    np.testing.assert_array_equal(a.embed_crops(real_crops[:4]), b.embed_crops(real_crops[:4]))
    with pytest.raises(ModelError, match="not weights for"):
        make_embedder(AppearanceConfig(model=str(MODELS / "person-reidentification-retail-0277.onnx"),
                                       backend="torch", weights=str(out)))


def test_vectorised_crops_equal_opencv_crops_within_one_grey_level(model_0288):
    from sotmot.appearance import affinity_rows
    from sotmot.appearance.torch import crop_boxes_torch

    info = read_seqinfo(require(DATA / "MOT16-04-clip30"))
    gt = read_ground_truth(info.gt_path, info.length)
    frame = FrameReader(info)(1)
    boxes = np.vstack([gt.boxes[gt.frames == 1][:12], [[-20, -10, 60, 120], [1900, 1000, 100, 200]]])
    ref = crop_boxes(frame, boxes).astype(np.float32).transpose(0, 3, 1, 2)
    got = crop_boxes_torch(torch.from_numpy(np.ascontiguousarray(frame.transpose(2, 0, 1))).float(), boxes)
    assert np.abs(got.numpy() - ref).max() <= 1.0
    # whole-box embeddings of the two backends differ only by that crop rounding
    a = make_embedder(AppearanceConfig(model=str(model_0288))).embed(frame, boxes)
    b = make_embedder(AppearanceConfig(model=str(model_0288), backend="torch")).embed(frame, boxes)
    assert affinity_rows(a, b).min() > 0.95
