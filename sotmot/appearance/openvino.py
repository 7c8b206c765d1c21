"""Deep person re-ID features from the same ONNX (or OpenVINO IR) model, run with the OpenVINO runtime.

The model contract, cropping, batching and flip-averaging are those of
:mod:`sotmot.appearance.onnx`; only the runtime differs. On the 2-core
CPUs these benchmarks ran on, OpenVINO runs model 0288 about twice as fast
as onnxruntime with the same features (cosine >= 0.999; docs/benchmarks.md).
OpenVINO is a dependency of sotmot (it also runs the bundled detector); CPU only.
"""

from __future__ import annotations

import logging

import numpy as np

from sotmot.appearance.base import CROP_HEIGHT, CROP_WIDTH, CropEmbedder, check_model_io, fixed_dim, resolve_model_path
from sotmot.config import AppearanceConfig
from sotmot.errors import ModelError, runtime_message
from sotmot.models import openvino_compiled, openvino_cpu_options

log = logging.getLogger(__name__)


def _shape(port) -> list:
    """A port's shape as :func:`check_model_io` reads it: numbers, and names for dynamic dimensions."""
    return [d.get_length() if d.is_static else "N" for d in port.get_partial_shape()]


class OpenVinoReidEmbedder(CropEmbedder):
    """Flip-averaged re-ID features from an ONNX or OpenVINO IR model run with OpenVINO on the CPU.

    Parameters
    ----------
    config
        ``model`` (path to ``.onnx`` or ``.xml``), ``flip``, ``batch_size`` and ``threads`` are used;
        ``device = "cuda"`` is refused (OpenVINO here runs on the CPU).
    """

    def __init__(self, config: AppearanceConfig) -> None:
        import openvino as ov

        if config.device == "cuda":
            raise ModelError("the openvino appearance backend runs on the CPU; for 'cuda' use --appearance torch "
                             "(or onnx with onnxruntime-gpu)")
        self.path = resolve_model_path(config.model)
        self.flip = config.flip
        self.batch_size = config.batch_size
        core = ov.Core()
        try:
            model = core.read_model(str(self.path))
        except Exception as exc:  # OpenVINO raises its own untyped errors
            raise ModelError(f"{self.path}: cannot be loaded by OpenVINO: {runtime_message(exc)}") from exc
        _, dim = check_model_io(self.path, [(p.any_name, _shape(p)) for p in model.inputs],
                                [(p.any_name, _shape(p)) for p in model.outputs])
        self.dim = fixed_dim(self.path, dim)
        if model.inputs[0].get_partial_shape()[0].is_static:  # e.g. Intel's IR files: batch fixed at 1
            model.reshape({model.inputs[0]: ov.PartialShape([-1, 3, CROP_HEIGHT, CROP_WIDTH])})
        compiled = openvino_compiled(core, model, self.path, openvino_cpu_options(config.threads))
        self._output = compiled.outputs[0]
        self._request = compiled.create_infer_request()
        log.info("re-ID model %s (OpenVINO %s): %d-d embedding", self.path, ov.__version__, self.dim)

    def _run(self, tensor: np.ndarray) -> np.ndarray:
        # the batch is read where it lies (share_inputs: no copy of it into the runtime's own tensor)
        return np.array(self._request.infer({0: tensor}, share_inputs=True)[self._output], dtype=np.float32,
                        copy=True)
