"""Deep person re-ID features from an ONNX model run with onnxruntime (the backend where OpenVINO is missing).

Made for Intel's Open Model Zoo person-reidentification-retail models; the
input contract and everything shared with the other backends is in
:mod:`sotmot.appearance.base`.
"""

from __future__ import annotations

import logging

import numpy as np

from sotmot.appearance.base import CropEmbedder, check_model_io, fixed_dim, resolve_model_path
from sotmot.config import AppearanceConfig
from sotmot.errors import ModelError

log = logging.getLogger(__name__)


class OnnxReidEmbedder(CropEmbedder):
    """Flip-averaged re-ID features from an ONNX model run with onnxruntime.

    Parameters
    ----------
    config
        ``model`` (path), ``flip``, ``batch_size``, ``threads`` and ``device`` are used.
    """

    def __init__(self, config: AppearanceConfig) -> None:
        import onnxruntime as ort

        self.path = resolve_model_path(config.model)
        self.flip = config.flip
        self.batch_size = config.batch_size
        options = ort.SessionOptions()
        options.log_severity_level = 3  # the Intel models trigger harmless "unused initializer" warnings
        if config.threads:
            options.intra_op_num_threads = config.threads
        providers = ["CPUExecutionProvider"]
        if config.device == "cuda":
            if "CUDAExecutionProvider" not in ort.get_available_providers():
                raise ModelError("device 'cuda' asked for, but this onnxruntime has no CUDA provider "
                                 "(install onnxruntime-gpu, or use --appearance torch on a CUDA machine)")
            providers = ["CUDAExecutionProvider"]
        try:
            self.session = ort.InferenceSession(str(self.path), sess_options=options, providers=providers)
        except Exception as exc:  # onnxruntime raises its own untyped errors
            raise ModelError(f"{self.path}: cannot be loaded as an ONNX model: {exc}") from exc
        self.input_name, dim = check_model_io(self.path, [(i.name, list(i.shape)) for i in self.session.get_inputs()],
                                              [(o.name, list(o.shape)) for o in self.session.get_outputs()])
        self.dim = fixed_dim(self.path, dim)
        log.info("re-ID model %s: %d-d embedding", self.path, self.dim)

    def _run(self, tensor: np.ndarray) -> np.ndarray:
        return self.session.run(None, {self.input_name: tensor})[0]
