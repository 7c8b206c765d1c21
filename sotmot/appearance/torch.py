"""The ONNX person re-ID model as a ``torch.nn.Module``, weights read from the ONNX file.

The model's graph is executed op by op in torch (the Intel re-ID models use
Conv, Relu, LeakyRelu, Add, Sub, Mul, MatMul, LayerNormalization,
ReduceMean, Sigmoid, Reshape, Gather, MaxPool and AveragePool); its weights
become parameters (Conv, MatMul, LayerNormalization scales and biases) or
buffers (every other constant), so the module runs on the CPU or a CUDA GPU,
can be fine-tuned, and saved with ``torch.save(module.state_dict())``.
The ``onnx`` package reads the file; no torchvision is needed.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from sotmot.appearance.base import (CROP_HEIGHT, CROP_WIDTH, check_model_io, flip_average, resolve_model_path,
                                    with_mirrored)
from sotmot.boxes import pixel_bounds
from sotmot.config import AppearanceConfig
from sotmot.errors import ModelError

log = logging.getLogger(__name__)

SUPPORTED = {"Constant", "Gather", "Sub", "Add", "Mul", "MatMul", "LayerNormalization", "Conv", "Relu",
             "LeakyRelu", "Sigmoid", "MaxPool", "AveragePool", "ReduceMean", "Reshape"}
_TRAINABLE = {"Conv": (1, 2), "MatMul": (1,), "LayerNormalization": (1, 2)}  # which inputs are weights


def _build_module(path: Path):
    import onnx
    import torch
    from onnx import numpy_helper

    try:
        model = onnx.load(str(path))
    except Exception as exc:  # onnx raises DecodeError and friends
        raise ModelError(f"{path}: cannot be read as an ONNX model: {exc}") from exc
    graph = model.graph
    def shape(value) -> list:
        return [d.dim_value or d.dim_param for d in value.type.tensor_type.shape.dim]

    check_model_io(path, [(i.name, shape(i)) for i in graph.input], [(o.name, shape(o)) for o in graph.output])
    inputs = list(graph.input)
    unknown = sorted({n.op_type for n in graph.node} - SUPPORTED)
    if unknown:
        raise ModelError(f"{path}: uses ONNX ops the torch backend does not implement: {', '.join(unknown)}")

    constants = {n.output[0]: numpy_helper.to_array(n.attribute[0].t) for n in graph.node if n.op_type == "Constant"}
    constants.update({t.name: numpy_helper.to_array(t) for t in graph.initializer})
    trainable = {n.input[k] for n in graph.node if n.op_type in _TRAINABLE
                 for k in _TRAINABLE[n.op_type] if k < len(n.input) and n.input[k] in constants}

    class OnnxGraph(torch.nn.Module):
        """Runs the ONNX graph's nodes in order; see the module docstring."""

        def __init__(self) -> None:
            super().__init__()
            self.input_name = inputs[0].name
            self.output_name = graph.output[0].name
            self.keys: dict[str, str] = {}
            self.ints: dict[str, list[int]] = {}
            self.params = torch.nn.ParameterDict()
            for k, (name, value) in enumerate(constants.items()):
                if value.dtype.kind in "iu":
                    self.ints[name] = value.astype(np.int64).reshape(-1).tolist()
                    continue
                key = f"c{k}"
                self.keys[name] = key
                tensor = torch.from_numpy(np.array(value, dtype=np.float32, copy=True))
                if name in trainable:
                    self.params[key] = torch.nn.Parameter(tensor)
                else:
                    self.register_buffer(key, tensor)
            self.nodes = [(n.op_type, list(n.input), list(n.output),
                           {a.name: onnx.helper.get_attribute_value(a) for a in n.attribute})
                          for n in graph.node if n.op_type != "Constant"]

        def _value(self, env: dict, name: str):
            if name in env:
                return env[name]
            key = self.keys[name]
            return self.params[key] if key in self.params else getattr(self, key)

        def forward(self, x):
            import torch.nn.functional as F

            env = {self.input_name: x}
            for op, ins, outs, at in self.nodes:
                if op == "Gather":
                    index = torch.tensor(self.ints[ins[1]], device=x.device)
                    y = torch.index_select(self._value(env, ins[0]), at.get("axis", 0), index)
                elif op in ("Add", "Sub", "Mul"):
                    a, b = self._value(env, ins[0]), self._value(env, ins[1])
                    y = a + b if op == "Add" else a - b if op == "Sub" else a * b
                elif op == "MatMul":
                    y = torch.matmul(self._value(env, ins[0]), self._value(env, ins[1]))
                elif op == "LayerNormalization":
                    v = self._value(env, ins[0])
                    axis = at.get("axis", -1) % v.dim()
                    dims = tuple(range(axis, v.dim()))
                    mean = v.mean(dim=dims, keepdim=True)
                    var = ((v - mean) ** 2).mean(dim=dims, keepdim=True)
                    y = (v - mean) / torch.sqrt(var + at.get("epsilon", 1e-5)) * self._value(env, ins[1])
                    if len(ins) > 2 and ins[2]:
                        y = y + self._value(env, ins[2])
                elif op == "Conv":
                    pads = at.get("pads", [0, 0, 0, 0])
                    if pads[:2] != pads[2:]:
                        raise ModelError(f"asymmetric Conv padding {pads} is not supported")
                    bias = self._value(env, ins[2]) if len(ins) > 2 and ins[2] else None
                    y = F.conv2d(self._value(env, ins[0]), self._value(env, ins[1]), bias,
                                 stride=tuple(at.get("strides", [1, 1])), padding=tuple(pads[:2]),
                                 dilation=tuple(at.get("dilations", [1, 1])), groups=at.get("group", 1))
                elif op == "Relu":
                    y = torch.relu(self._value(env, ins[0]))
                elif op == "LeakyRelu":
                    y = F.leaky_relu(self._value(env, ins[0]), at.get("alpha", 0.01))
                elif op == "Sigmoid":
                    y = torch.sigmoid(self._value(env, ins[0]))
                elif op in ("MaxPool", "AveragePool"):
                    pads = at.get("pads", [0, 0, 0, 0])
                    if pads[:2] != pads[2:] or at.get("ceil_mode", 0):
                        raise ModelError(f"{op} with pads {pads} / ceil_mode is not supported")
                    kw = dict(kernel_size=tuple(at["kernel_shape"]), stride=tuple(at.get("strides", [1, 1])),
                              padding=tuple(pads[:2]))
                    v = self._value(env, ins[0])
                    y = F.max_pool2d(v, **kw) if op == "MaxPool" else \
                        F.avg_pool2d(v, count_include_pad=bool(at.get("count_include_pad", 0)), **kw)
                elif op == "ReduceMean":
                    axes = self.ints[ins[1]] if len(ins) > 1 else at.get("axes")
                    y = self._value(env, ins[0]).mean(dim=tuple(axes), keepdim=bool(at.get("keepdims", 1)))
                elif op == "Reshape":
                    v = self._value(env, ins[0])
                    shape = [v.shape[i] if s == 0 else s for i, s in enumerate(self.ints[ins[1]])]
                    y = v.reshape(shape)
                else:  # pragma: no cover - rejected at load time
                    raise ModelError(f"unsupported op {op}")
                env[outs[0]] = y
            return env[self.output_name]

    return OnnxGraph()


def crop_boxes_torch(frame, boxes: np.ndarray, height: int = CROP_HEIGHT, width: int = CROP_WIDTH):
    """All boxes of a frame cropped and resized in one ``grid_sample`` call.

    Parameters
    ----------
    frame
        ``(3, H, W)`` float tensor (BGR, 0-255) on any device.
    boxes
        ``(N, 4)`` ``x, y, w, h`` pixels; clipped to the image exactly as
        :func:`~sotmot.appearance.base.crop_boxes` does, then sampled
        bilinearly at the pixel centres of the output, as OpenCV's linear
        resize does.

    Returns
    -------
    torch.Tensor
        ``(N, 3, height, width)`` float crops.
    """
    import torch
    import torch.nn.functional as F

    img_h, img_w = frame.shape[1:]
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    x1, y1, x2, y2 = (c.astype(np.float64) for c in pixel_bounds(b, img_w, img_h))
    # source pixel coordinate of each output pixel centre, then to grid_sample's [-1, 1] (align_corners=False)
    xs = x1[:, None] + (np.arange(width) + 0.5)[None, :] * ((x2 - x1) / width)[:, None] - 0.5
    ys = y1[:, None] + (np.arange(height) + 0.5)[None, :] * ((y2 - y1) / height)[:, None] - 0.5
    xs = np.clip(xs, x1[:, None], x2[:, None] - 1)  # OpenCV replicates the crop's own border
    ys = np.clip(ys, y1[:, None], y2[:, None] - 1)
    gx = torch.as_tensor((xs + 0.5) / img_w * 2 - 1, dtype=frame.dtype, device=frame.device)
    gy = torch.as_tensor((ys + 0.5) / img_h * 2 - 1, dtype=frame.dtype, device=frame.device)
    grid = torch.stack([gx[:, None, :].expand(-1, height, -1), gy[:, :, None].expand(-1, -1, width)], dim=-1)
    return F.grid_sample(frame[None].expand(len(b), -1, -1, -1), grid, mode="bilinear",
                         padding_mode="border", align_corners=False)


class TorchReidEmbedder:
    """Flip-averaged re-ID features computed with torch (CPU, or CUDA with ``device="cuda"``).

    Same protocol and same numbers as :class:`~sotmot.appearance.onnx.OnnxReidEmbedder`
    (within float rounding); the module is in :attr:`module` for fine-tuning.
    """

    def __init__(self, config: AppearanceConfig) -> None:
        import torch

        self.path = resolve_model_path(config.model)
        self.flip = config.flip
        self.batch_size = config.batch_size
        if config.device == "cuda" and not torch.cuda.is_available():
            raise ModelError("device 'cuda' asked for, but torch sees no CUDA GPU here")
        self.device = torch.device(config.device)
        if config.threads:
            torch.set_num_threads(config.threads)
        self.module = _build_module(self.path)
        if config.weights:
            self.load_weights(config.weights)
        self.module = self.module.to(self.device).eval()
        with torch.no_grad():
            probe = self.module(torch.zeros(1, 3, CROP_HEIGHT, CROP_WIDTH, device=self.device))
        if probe.dim() != 2:
            raise ModelError(f"{self.path}: expected an N x D embedding, got shape {tuple(probe.shape)}")
        self.dim = int(probe.shape[1])

    def load_weights(self, path: str | Path) -> None:
        """Load a checkpoint written by ``sotmot train-appearance`` (or a bare state dict)."""
        import torch

        path = Path(path)
        if not path.is_file():
            raise ModelError(f"fine-tuned weights not found: {path}")
        try:
            payload = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as exc:  # UnpicklingError, EOFError, zip errors...; torch's text suggests an unsafe fix
            raise ModelError(f"{path}: not a readable checkpoint from 'sotmot train-appearance' (corrupt, truncated, "
                             f"or another format; {type(exc).__name__})") from None
        try:
            state = payload["state_dict"] if isinstance(payload, dict) and "state_dict" in payload else payload
            self.module.load_state_dict(state)
        except (RuntimeError, KeyError, TypeError, ValueError) as exc:
            raise ModelError(f"{path}: not weights for {self.path.name}: {exc}") from exc

    def forward_crops(self, crops: np.ndarray):
        """Raw model outputs ``(N, D)`` (a torch tensor on the device) of ``(N, 256, 128, 3)`` BGR crops."""
        import torch

        x = torch.from_numpy(np.ascontiguousarray(crops.transpose(0, 3, 1, 2), dtype=np.float32)).to(self.device)
        return self.module(x)

    def embed_crops(self, crops: np.ndarray) -> np.ndarray:
        """Flip-averaged unit features ``(N, D)`` float32 of ``(N, 256, 128, 3)`` uint8 BGR crops."""
        import torch

        if len(crops) == 0:
            return np.zeros((0, self.dim), dtype=np.float32)
        both = with_mirrored(crops) if self.flip else crops
        out = []
        with torch.no_grad():
            for start in range(0, len(both), self.batch_size):
                out.append(self.forward_crops(both[start:start + self.batch_size]).float().cpu().numpy())
        feats = np.concatenate(out)
        n = len(crops)
        return flip_average(feats[:n], feats[n:] if self.flip else None, self.path)

    def embed(self, frame: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """Features ``(N, D)`` float32, unit length, of ``(N, 4)`` ``x, y, w, h`` boxes in ``frame``.

        Crops are cut on the device in one :func:`crop_boxes_torch` call.
        """
        import torch

        if len(boxes) == 0:
            return np.zeros((0, self.dim), dtype=np.float32)
        image = torch.from_numpy(np.ascontiguousarray(frame.transpose(2, 0, 1))).to(self.device).float()
        with torch.no_grad():
            crops = crop_boxes_torch(image, boxes).round()  # the ONNX path feeds uint8 crops
            feats = [self.module(crops[i:i + self.batch_size]) for i in range(0, len(crops), self.batch_size)]
            if self.flip:
                mirrored = crops.flip(-1)
                back = [self.module(mirrored[i:i + self.batch_size]) for i in range(0, len(crops), self.batch_size)]
        out = torch.cat(feats).float().cpu().numpy()
        return flip_average(out, torch.cat(back).float().cpu().numpy() if self.flip else None, self.path)
