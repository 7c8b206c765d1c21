"""The openvino re-ID backend computes the onnxruntime backend's embeddings, from ONNX or IR files."""

import numpy as np
import pytest

from conftest import MODELS, require
from sotmot.appearance import make_embedder
from sotmot.config import AppearanceConfig
from sotmot.errors import ModelError

pytest.importorskip("openvino", reason="openvino is not installed (a dependency of sotmot)")


@pytest.mark.parametrize("model", ["person-reidentification-retail-0288.onnx",
                                   "openvino-ir/person-reidentification-retail-0288.xml"])
def test_openvino_matches_onnxruntime_on_real_crops(model, real_crops):
    ref = make_embedder(AppearanceConfig(model=str(require(MODELS / "person-reidentification-retail-0288.onnx"))))
    got = make_embedder(AppearanceConfig(model=str(require(MODELS / model)), backend="openvino", batch_size=7))
    a, b = ref.embed_crops(real_crops), got.embed_crops(real_crops)
    assert b.shape == a.shape and b.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(b, axis=1), 1.0, atol=1e-5)
    assert (a * b).sum(axis=1).min() > 0.999  # cosine of the two backends' features of each crop


def test_openvino_without_flip_embeds_the_crop_alone(real_crops):
    path = str(require(MODELS / "person-reidentification-retail-0288.onnx"))
    flipped = make_embedder(AppearanceConfig(model=path, backend="openvino")).embed_crops(real_crops[:4])
    plain = make_embedder(AppearanceConfig(model=path, backend="openvino", flip=False)).embed_crops(real_crops[:4])
    assert np.abs(flipped - plain).max() > 1e-3


def test_openvino_refuses_cuda_and_broken_files(tmp_path):
    path = str(require(MODELS / "person-reidentification-retail-0288.onnx"))
    with pytest.raises(ModelError, match="CPU"):
        make_embedder(AppearanceConfig(model=path, backend="openvino", device="cuda"))
    broken = tmp_path / "broken.onnx"
    broken.write_bytes(b"not a model")
    with pytest.raises(ModelError, match="broken.onnx"):
        make_embedder(AppearanceConfig(model=str(broken), backend="openvino"))
