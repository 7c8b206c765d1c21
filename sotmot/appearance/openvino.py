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
from sotmot.errors import ModelError, native_noise_held, runtime_message
from sotmot.models import openvino_compiled, openvino_cpu_options

log = logging.getLogger(__name__)


def _shape(port) -> list:
    """A port's shape as :func:`check_model_io` reads it: numbers, and names for dynamic dimensions."""
    return [d.get_length() if d.is_static else "N" for d in port.get_partial_shape()]


def precision_options(precision: str) -> dict:
    """OpenVINO's compile options for ``[appearance] precision``: ``"f32"`` pins float32 (OpenVINO's CPU plugin
    otherwise runs a float model in bf16 on CPUs that have it, and features then differ from one CPU to
    another); ``"fast"`` leaves the choice to OpenVINO."""
    return {"INFERENCE_PRECISION_HINT": "f32"} if precision == "f32" else {}


def _type_name(value) -> str:
    """OpenVINO's element type (``<Type: 'float32'>``) as a short name: ``"f32"``, ``"bf16"``."""
    text = str(getattr(value, "get_type_name", lambda: value)())
    return {"float32": "f32", "bfloat16": "bf16", "float16": "f16"}.get(text, text)


def openvino_precision(precision: str) -> str:
    """The arithmetic the OpenVINO backend runs a float model in on this CPU under ``[appearance] precision``:
    ``"f32"``, or for ``"fast"`` what the CPU plugin picks (``"bf16"`` where the CPU has it)."""
    if precision == "f32":
        return "f32"
    import openvino as ov

    return _type_name(ov.Core().get_property("CPU", "INFERENCE_PRECISION_HINT"))


class OpenVinoReidEmbedder(CropEmbedder):
    """Flip-averaged re-ID features from an ONNX or OpenVINO IR model run with OpenVINO on the CPU.

    Parameters
    ----------
    config
        ``model`` (path to ``.onnx`` or ``.xml``), ``flip``, ``batch_size``, ``threads`` and ``precision`` are used;
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
            with native_noise_held():
                model = core.read_model(str(self.path))
        except Exception as exc:  # OpenVINO raises its own untyped errors
            raise ModelError(f"{self.path}: cannot be loaded by OpenVINO: {runtime_message(exc)}") from exc
        _, dim = check_model_io(self.path, [(p.any_name, _shape(p)) for p in model.inputs],
                                [(p.any_name, _shape(p)) for p in model.outputs])
        self.dim = fixed_dim(self.path, dim)
        if model.inputs[0].get_partial_shape()[0].is_static:  # e.g. Intel's IR files: batch fixed at 1
            model.reshape({model.inputs[0]: ov.PartialShape([-1, 3, CROP_HEIGHT, CROP_WIDTH])})
        options = openvino_cpu_options(config.threads, **precision_options(config.precision))
        compiled = openvino_compiled(core, model, self.path, options)
        self._output = compiled.outputs[0]
        self._request = compiled.create_infer_request()
        #: the arithmetic OpenVINO runs the model in here ("f32", "bf16", ...)
        self.precision = _type_name(compiled.get_property("INFERENCE_PRECISION_HINT"))
        log.info("re-ID model %s (OpenVINO %s, %s): %d-d embedding", self.path, ov.__version__, self.precision,
                 self.dim)

    def _run(self, tensor: np.ndarray) -> np.ndarray:
        # the batch is read where it lies (share_inputs: no copy of it into the runtime's own tensor)
        return np.array(self._request.infer({0: tensor}, share_inputs=True)[self._output], dtype=np.float32,
                        copy=True)
