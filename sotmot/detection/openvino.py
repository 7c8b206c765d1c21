"""Person detection with an OpenVINO IR model of the Open Model Zoo SSD kind (e.g. person-detection-0202).

The contract, checked when the model is loaded:

- one input ``1 x 3 x H x W``: the whole frame resized (no letterbox), BGR,
  raw 0-255 (mean and scale are inside the graph);
- one output ``1 x 1 x K x 7``: rows ``[image_id, label, conf, x1, y1, x2, y2]``,
  corners in 0..1 of the image, non-maximum suppression already applied,
  rows with ``image_id < 0`` unused.

The input is reshaped to keep the frame's aspect ratio (see
:func:`input_size`). OpenVINO would run an FP16 model in bf16 on CPUs that
have it, silently; the precision is pinned to f32 so that the boxes do not
depend on whether the CPU has bf16 (on an Intel Xeon with AMX it costs no
time: 14.8 against 15.1 ms a 544 x 960 frame); re-ID is pinned likewise
(``[appearance] precision``). Results still differed a little between CPUs
when re-ID ran in bf16 where it could (and other instruction sets round
otherwise): tracked from the detector's boxes, the validation set's
rows on that Xeon lie within 0.22 HOTA and 0.8 MOTA of an AMD EPYC's
(docs/benchmarks.md, "The noise floor"). Needs the ``openvino`` extra.
"""

from __future__ import annotations

import logging
import math

import numpy as np
import openvino as ov  # a missing runtime fails this module's import: make_detector names the extra

from sotmot.boxes import clip_xyxy, xyxy_to_xywh
from sotmot.config import DetectionConfig
from sotmot.detection import resolve_detector_path, rounded
from sotmot.errors import ModelError, native_noise_held, runtime_message
from sotmot.models import openvino_compiled, openvino_cpu_options

log = logging.getLogger(__name__)

#: The least input area of the automatic size (512 x 672 = 448 x 768): what the model card's sizes share.
INPUT_AREA = 512 * 672
#: The automatic size shrinks a frame's sides at most this much while the area stays under :data:`MAX_INPUT_AREA`:
#: a 1080p frame squeezed to 448 x 768 (2.4x) left the detector missing small people (issue #41).
MAX_SHRINK = 2.0
#: The largest input area of the automatic size (1.5x the model card's sides): a 4K frame is shrunk more than
#: :data:`MAX_SHRINK` rather than cost the detector over twice its time.
MAX_INPUT_AREA = INPUT_AREA * 1.5 ** 2
#: Input sides are multiples of this (the network's stride).
STRIDE = 32


def input_size(width: int, height: int) -> tuple[int, int]:
    """The network input ``(height, width)`` for a ``width x height`` frame: aspect kept, each side a multiple
    of :data:`STRIDE`, the area :data:`INPUT_AREA` or, for a frame that would be shrunk more than
    :data:`MAX_SHRINK` to it, the frame's area shrunk by that much (at most :data:`MAX_INPUT_AREA`).

    Gives 448 x 768 for 16:9 frames up to 1536 x 864, 544 x 960 for 1080p (issue #41: far people on 1080p
    video, measured on MOT16-09 and the 1080p clips: docs/benchmarks.md), and 512 x 672 for 4:3 frames up to
    1344 x 1008 (PETS09-S2L1's 768 x 576, TUD-Stadtmitte's 640 x 480).
    """
    area = min(max(INPUT_AREA, width * height / MAX_SHRINK ** 2), MAX_INPUT_AREA)
    side = max(STRIDE, round(math.sqrt(area * height / width) / STRIDE) * STRIDE)
    return side, max(STRIDE, round(area / side / STRIDE) * STRIDE)


def network_input(config: DetectionConfig, width: int, height: int) -> tuple[int, int]:
    """The input ``(height, width)`` the detector runs a ``width x height`` frame at: ``[detection] input_height``
    and ``input_width`` when given, else :func:`input_size`."""
    return (config.input_height, config.input_width) if config.input_height else input_size(width, height)


class OpenVinoDetector:
    """An SSD-style person detector run by OpenVINO on the CPU.

    Parameters
    ----------
    config
        ``model`` (the ``.xml``; its ``.bin`` beside it), ``min_score``,
        ``input_height`` / ``input_width`` (0: :func:`input_size` of each
        frame size met) and ``threads`` are used.

    Raises
    ------
    ModelError
        The model cannot be read, or its input or output is not of the layout above.
    """

    def __init__(self, config: DetectionConfig) -> None:
        self.path = resolve_detector_path(config.model)
        self.min_score = config.min_score
        self._config = config
        self._core = ov.Core()
        try:
            with native_noise_held():
                self._model = self._core.read_model(str(self.path))
        except Exception as exc:  # OpenVINO raises its own untyped errors
            raise ModelError(f"{self.path}: cannot be loaded by OpenVINO as a detector: "
                             f"{runtime_message(exc)}") from exc
        inputs, outputs = self._model.inputs, self._model.outputs
        in_shape = [d.get_length() if d.is_static else -1 for d in inputs[0].get_partial_shape()] if inputs else []
        out_shape = [d.get_length() if d.is_static else -1 for d in outputs[0].get_partial_shape()] if outputs else []
        if len(inputs) != 1 or len(in_shape) != 4 or in_shape[:2] != [1, 3]:
            raise ModelError(f"{self.path}: not a detector of the expected kind: expected one input 1 x 3 x H x W "
                             f"(a BGR frame), got {[(p.any_name, str(p.get_partial_shape())) for p in inputs]}")
        if len(outputs) != 1 or len(out_shape) != 4 or out_shape[:2] != [1, 1] or out_shape[3] != 7:
            raise ModelError(f"{self.path}: not a detector of the expected kind: expected one output 1 x 1 x K x 7 "
                             f"(image_id, label, conf, x1, y1, x2, y2), got "
                             f"{[(p.any_name, str(p.get_partial_shape())) for p in outputs]}")
        self._options = openvino_cpu_options(config.threads, INFERENCE_PRECISION_HINT="f32")
        self._compiled: dict[tuple[int, int], tuple] = {}  # input size -> (request, output port)
        log.info("person detector %s (OpenVINO %s)", self.path, ov.__version__)

    def _request(self, size: tuple[int, int], frame: tuple[int, int]):
        if size not in self._compiled:
            log.info("person detector input %d x %d for %d x %d frames (%s)", size[0], size[1], frame[0], frame[1],
                     "[detection] input_height, input_width" if self._config.input_height else "automatic")
            self._model.reshape({self._model.inputs[0]: ov.PartialShape([1, 3, *size])})
            compiled = openvino_compiled(self._core, self._model, self.path, self._options)
            self._compiled[size] = (compiled.create_infer_request(), compiled.outputs[0])
        return self._compiled[size]

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Boxes ``(N, 4)`` ``x, y, w, h`` pixels (clipped to the frame) and scores ``(N,)`` >= ``min_score``."""
        import cv2

        height, width = frame.shape[:2]
        size = network_input(self._config, width, height)
        request, output = self._request(size, (height, width))
        tensor = cv2.resize(frame, (size[1], size[0]), interpolation=cv2.INTER_LINEAR)
        tensor = np.ascontiguousarray(tensor.transpose(2, 0, 1)[None], dtype=np.float32)
        rows = np.asarray(request.infer({0: tensor}, share_inputs=True)[output]).reshape(-1, 7)  # no input copy
        rows = rows[(rows[:, 0] >= 0) & (rows[:, 2] >= self.min_score)]
        corners = clip_xyxy(rows[:, 3:7].astype(np.float64) * [width, height, width, height], width, height)
        boxes, scores = rounded(xyxy_to_xywh(corners), rows[:, 2])
        keep = (boxes[:, 2] > 0) & (boxes[:, 3] > 0)  # a box squeezed to nothing by the frame edge
        return boxes[keep], scores[keep]
