"""The two models sotmot ships with, and where a run's models come from.

Both are Intel Open Model Zoo models (release 2022.3) under the Apache-2.0
licence (``LICENSE-open_model_zoo.txt`` beside them), small enough to travel
inside the package:

- ``person-reidentification-retail-0288.onnx`` (0.98 MB): the re-ID network,
  input ``N x 3 x 256 x 128`` BGR 0-255, output ``N x 256``;
- ``person-detection-0202.FP16-INT8.xml`` with its ``.bin`` (2.4 MB): the person
  detector (SSD, MobileNetV2), INT8 weights.

A run's model is the one the user gives (a flag, the config, or an environment
variable), else the bundled one. The bundled files are checked against the
SHA-256 in :data:`MODELS` before first use in a process, so a changed or cut
file is one :class:`~sotmot.errors.ModelError` that names it, never a model
that silently computes something else.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from sotmot.errors import ModelError
from sotmot.hashing import file_sha256

#: The folder of the bundled model files (package data).
HERE = Path(__file__).resolve().parent
#: The licence of the bundled models.
LICENCE_FILE = "LICENSE-open_model_zoo.txt"


@dataclass(frozen=True)
class BundledModel:
    """One model shipped with sotmot.

    Attributes
    ----------
    kind
        ``"reid"`` or ``"detector"``.
    files
        ``(file name, SHA-256)`` of each file, the one a run opens first
        (an OpenVINO ``.xml`` is followed by its ``.bin``).
    env_var
        The environment variable that names another model of this kind.
    flag, key
        The command-line flag and the config key that name another model.
    origin
        Where the files come from.
    """

    kind: str
    files: tuple[tuple[str, str], ...]
    env_var: str
    flag: str
    key: str
    origin: str
    licence: str = "Apache-2.0"

    @property
    def path(self) -> Path:
        """The file a run opens (not checked; :func:`bundled_path` checks it)."""
        return HERE / self.files[0][0]

    @property
    def size(self) -> int:
        """Bytes of all the model's files."""
        return sum((HERE / name).stat().st_size for name, _ in self.files)


#: The bundled models by kind, with the SHA-256 of every file: the one table of what ships.
MODELS: dict[str, BundledModel] = {
    "reid": BundledModel(
        "reid",
        (("person-reidentification-retail-0288.onnx",
          "f74e96dd34deac5d3b616a555a94a5b947db22d8ca3cb479dfeb508826bf5815"),),
        "SOTMOT_REID_MODEL", "--reid-model", "[appearance] model",
        "Intel Open Model Zoo 2022.3, person-reidentification-retail-0288 (OpenVINO IR converted to ONNX)"),
    "detector": BundledModel(
        "detector",
        (("person-detection-0202.FP16-INT8.xml", "9216c8f5e8e035008b71be94896da4c5ea995d0b87d02b16200512228ac07c34"),
         ("person-detection-0202.FP16-INT8.bin", "d55d090008d69a8e0d410317a9a53e276535de5c75efecbdbe85250012be182f")),
        "SOTMOT_DETECTOR_MODEL", "--detector-model", "[detection] model",
        "Intel Open Model Zoo 2022.3, person-detection-0202, FP16-INT8 (byte-identical to the release)"),
}

_WHAT = {"reid": "person re-ID model", "detector": "person detector"}


@lru_cache(maxsize=None)
def _checked(kind: str, stamps: tuple) -> Path:
    model = MODELS[kind]
    for (name, expected), stamp in zip(model.files, stamps):
        path = HERE / name
        if stamp is None:
            raise ModelError(f"the bundled {_WHAT[kind]} file is missing: {path}; reinstall sotmot, or give another "
                             f"model with {model.flag} PATH (or {model.env_var})")
        found = file_sha256(path)
        if found != expected:
            raise ModelError(f"the bundled {_WHAT[kind]} file is changed or truncated: {path} ({stamp[0]:,} bytes, "
                             f"SHA-256 {found[:12]}..., expected {expected[:12]}...); reinstall sotmot, or give "
                             f"another model with {model.flag} PATH (or {model.env_var})")
    return model.path


def bundled_path(kind: str) -> Path:
    """The bundled model of ``kind`` (``"reid"``, ``"detector"``), its files checked against :data:`MODELS`.

    Checked once per process while the files stay as they are (size and
    modification time); a file changed since is checked again.

    Raises
    ------
    ModelError
        A file is missing, or its SHA-256 is not the one in :data:`MODELS`.
    """
    stamps = []
    for name, _ in MODELS[kind].files:
        try:
            st = (HERE / name).stat()
            stamps.append((st.st_size, st.st_mtime_ns))
        except OSError:
            stamps.append(None)
    return _checked(kind, tuple(stamps))


def model_given(given: str | None, kind: str) -> str | None:
    """The model path the user gave for ``kind``: ``given`` (a flag or the config), else the environment
    variable (:attr:`BundledModel.env_var`); None when neither names one (the bundled model runs)."""
    return given or os.environ.get(MODELS[kind].env_var) or None


def model_in_use(given: str | None, kind: str) -> str:
    """The model a run of ``kind`` opens, unchecked: the one the user gave (:func:`model_given`), else the
    bundled one."""
    return model_given(given, kind) or str(MODELS[kind].path)


def resolve_model_file(given: str | None, kind: str) -> Path:
    """The model file a run opens for ``kind``: the user's (``given``, else the environment variable), which
    must exist, or else the bundled one (checked, :func:`bundled_path`).

    Raises
    ------
    ModelError
        The user's file does not exist, or the bundled one is missing or changed.
    """
    model = MODELS[kind]
    value = model_given(given, kind)
    if not value:
        return bundled_path(kind)
    path = Path(value).expanduser()
    if not path.is_file():
        raise ModelError(f"{_WHAT[kind]} not found: {path} (from {model.flag}, {model.key} in the config, or "
                         f"{model.env_var}); leave them unset to use the bundled model")
    return path


def describe() -> list[dict]:
    """What :command:`sotmot models` prints: each bundled model's kind, files, origin, licence, size and
    SHA-256, and the model a run uses now (from the environment, else the bundled one)."""
    rows = []
    for kind, model in MODELS.items():
        rows.append({"kind": kind, "files": [name for name, _ in model.files],
                     "sha256": {name: digest for name, digest in model.files}, "origin": model.origin,
                     "licence": f"{model.licence} ({HERE / LICENCE_FILE})", "bytes": model.size,
                     "path": str(model.path), "in_use": model_in_use(None, kind),
                     "how_to_change": f"{model.flag} PATH, {model.key} in the config, or {model.env_var}"})
    return rows


def openvino_cpu_options(threads: int = 0, **extra) -> dict:
    """OpenVINO CPU compile options of sotmot's models: latency-first, ``threads`` inference threads (0: the
    runtime's choice), and no pinning of threads to cores. The detector, the re-ID model and frame decoding run
    at once in one pass (:func:`sotmot.passes.frame_pass`); pinned, OpenVINO put both models' threads on the same
    cores, and on two cores the two models side by side ran 20-40 % slower (docs/benchmarks.md, "Speed").
    Pinning changes no result."""
    options = {"PERFORMANCE_HINT": "LATENCY", "ENABLE_CPU_PINNING": False, **extra}
    if threads:
        options["INFERENCE_NUM_THREADS"] = threads
    return options


#: Compiled OpenVINO models of this process (:func:`openvino_compiled`), by model file, input shape and options.
_COMPILED: dict[tuple, object] = {}
_COMPILING = threading.Lock()


def openvino_compiled(core, model, path: Path, options: dict):
    """``core.compile_model(model, "CPU", options)``, made once per process for each model file (its path, size
    and modification time), input shape (as ``model`` has it now) and options, and kept for the process's life;
    each caller makes its own infer requests on it.

    Kept, not only to compile once: OpenVINO's CPU plugin (2026.4, on a Xeon with AMX) points the calling
    thread's alternate signal stack at memory of each compiled model it makes, and when one goes it puts back the
    stack that was there before it. Compiled models that go in another order than the last-made first (a failed
    run's models held by its exception's traceback until a garbage collection) leave the thread's alternate stack
    on freed memory, and the next signal Python handles there (Ctrl-C, SIGTERM) crashed the process with a
    segmentation fault. Compiled models that never go keep it on memory that lives."""
    stat = path.stat()
    shape = tuple(str(port.get_partial_shape()) for port in model.inputs)
    key = (str(path.resolve()), stat.st_size, stat.st_mtime_ns, shape, tuple(sorted(options.items())))
    with _COMPILING:
        if key not in _COMPILED:
            _COMPILED[key] = core.compile_model(model, "CPU", options)
        return _COMPILED[key]


__all__ = ["HERE", "LICENCE_FILE", "MODELS", "BundledModel", "bundled_path", "describe", "model_given",
           "model_in_use", "openvino_compiled", "openvino_cpu_options", "resolve_model_file"]
