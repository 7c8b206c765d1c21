"""Detection: where the boxes come from, behind one protocol.

A detector turns one frame into person boxes::

    detector.detect(frame) -> (boxes (N, 4) float64 x, y, w, h pixels, scores (N,) float64 in [0, 1])

where ``frame`` is a BGR ``uint8`` image ``(H, W, 3)``. A ``det.txt`` is one
source of detections, a model run on the frames another (``[detection]
source``). Detectors are registered in :data:`sotmot.plugins.DETECTORS` and
imported only when used, so ``import sotmot`` does not load OpenVINO.

Boxes leave a detector rounded to what a MOTChallenge ``det.txt`` holds (2
decimals, scores 5), so the ``<name>.det.txt`` written beside the results,
fed back as the detections file, gives the very same run.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Protocol

import numpy as np

from sotmot.config import DetectionConfig
from sotmot.errors import ConfigError
from sotmot.hashing import file_sha256
from sotmot.io import read_detections
from sotmot.models import MODELS, model_in_use, resolve_model_file
from sotmot.plugins import DETECTORS, EXTRAS

#: The environment variable that may name the detector model.
ENV_VAR = MODELS["detector"].env_var
#: How a ``det.txt`` written by sotmot holds boxes and scores; :func:`rounded` gives exactly these values.
BOX_FORMAT, SCORE_FORMAT = "%.2f", "%.5f"


class Detector(Protocol):
    """What the tracker needs from a person detector."""

    def detect(self, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Boxes ``(N, 4)`` ``x, y, w, h`` pixels and scores ``(N,)`` of the people in one BGR frame."""
        ...


def resolve_detector_path(model: str | None) -> Path:
    """The detector model from the config (or ``--detector-model``), else from ``SOTMOT_DETECTOR_MODEL``, else
    the bundled person-detection-0202 (:mod:`sotmot.models`).

    Raises
    ------
    ModelError
        The given file is missing, or the bundled one is missing or changed.
    """
    return resolve_model_file(model, "detector")


def make_detector(config: DetectionConfig) -> Detector:
    """Build the detector that ``config.backend`` names.

    Raises
    ------
    ConfigError
        An unknown backend, or its runtime is not installed (the message says
        which extra installs it).
    ModelError
        The model is missing, unreadable, or not of the expected layout.
    """
    target = DETECTORS.get(config.backend)
    if target is None:
        raise ConfigError(f"unknown detector backend {config.backend!r}; valid: {', '.join(sorted(DETECTORS))}")
    module, name = target.split(":")
    try:
        loaded = importlib.import_module(module)
    except ImportError as exc:
        raise ConfigError(f"detector backend {config.backend!r} needs {exc.name!r}: pip install "
                          f"{EXTRAS.get(config.backend, repr(exc.name))}") from exc
    return getattr(loaded, name)(config)


def detection_source(config: DetectionConfig, info) -> tuple[str, Path | None]:
    """``("file", path)`` or ``("model", None)``: where the detections of sequence ``info`` come from.

    ``[detection] source = "auto"`` takes the detections file (``file``, else
    the sequence's ``det/det.txt``) when there is one, the model otherwise.
    """
    path = Path(config.file) if config.file else info.det_path
    if config.source == "file" or (config.source == "auto" and path.is_file()):
        return "file", path
    return "model", None


def file_detections(config: DetectionConfig, info):
    """The detections of sequence ``info`` read once from its detections file (:func:`detection_source`), for
    the runs that hand parts of them on (windows, every k-th frame); None when the detector runs on the frames."""
    source, path = detection_source(config, info)
    return read_detections(path, info.length, (info.width, info.height)) if source == "file" else None


#: Confidence families of known detector models, by the start of the model file's name (``sotmot.confidence``).
KNOWN_FAMILIES = {"person-detection-0202": "pd0202"}


#: The first line of a ``<name>.det.txt`` that ``sotmot track`` writes: which detector made the boxes (its file's
#: SHA-256) and their confidence family, so that the file replays the run under any name and without the run
#: record beside it. Readers of MOTChallenge files skip lines starting with ``#`` (``numpy.loadtxt`` does too).
HEADER = "# sotmot detections:"


def _family_of(model: str | Path) -> str | None:
    """The confidence family of a detector model known by its file name (:data:`KNOWN_FAMILIES`), else None."""
    name = Path(model).name
    return next((family for start, family in KNOWN_FAMILIES.items() if name.startswith(start)), None)


def detections_header(model: str | Path) -> str:
    """The header line (:data:`HEADER`) of the detections that ``model`` found."""
    return f"{HEADER} detector={Path(model).name} sha256={file_sha256(model)} family={_family_of(model) or 'unknown'}\n"


def read_header(path: str | Path) -> dict[str, str]:
    """The fields of a detections file's :data:`HEADER` line (``detector``, ``sha256``, ``family``); empty for a
    file without one (any detector's ``det.txt``)."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as fh:
            first = fh.readline().strip()
    except OSError:
        return {}
    if not first.startswith(HEADER):
        return {}
    return dict(part.split("=", 1) for part in first[len(HEADER):].split() if "=" in part)


def known_family(config: DetectionConfig, info) -> str | None:
    """The confidence family of sequence ``info``'s detections when the detector that made them is known: the
    model itself (``source = model``), or the one a ``sotmot track`` detections file names in its header
    (:func:`read_header`), its family in :data:`KNOWN_FAMILIES`. None: the family is guessed from the scores."""
    source, path = detection_source(config, info)
    if source == "model":
        return _family_of(model_in_use(config.model, "detector"))
    family = read_header(path).get("family")
    return family if family in KNOWN_FAMILIES.values() else None


def detector_detections(config: DetectionConfig, info) -> bool:
    """Whether the detector's own judgement is at hand for ``info``'s detections (what ``[detection] weak_boxes =
    "auto"`` turns on): they come from the model now, or they are a replayed detections file whose header names the very
    detector in use (by its SHA-256: its weak boxes can be found again, and the replay repeats the run)."""
    source, path = detection_source(config, info)
    if source == "model":
        return True
    made_by = read_header(path).get("sha256")
    return made_by is not None and made_by == file_sha256(model_in_use(config.model, "detector"))


def rounded(boxes: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Boxes and scores as a ``det.txt`` written by :func:`format_detections` holds them (the same floats)."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    scores = np.asarray(scores, dtype=np.float64).reshape(-1)
    return (np.char.mod(BOX_FORMAT, boxes).astype(np.float64).reshape(-1, 4),
            np.char.mod(SCORE_FORMAT, scores).astype(np.float64).reshape(-1))


def format_detections(frames: np.ndarray, boxes: np.ndarray, scores: np.ndarray, header: str = "") -> str:
    """MOTChallenge ``det.txt`` text: ``frame, -1, x, y, w, h, score, -1, -1, -1`` a line, in the given order,
    after ``header`` (:func:`detections_header`, or nothing)."""
    line = f"%d,-1,{BOX_FORMAT},{BOX_FORMAT},{BOX_FORMAT},{BOX_FORMAT},{SCORE_FORMAT},-1,-1,-1\n"
    return header + "".join(line % (f, *box, s) for f, box, s in zip(np.asarray(frames).tolist(),
                                                                    np.asarray(boxes).tolist(),
                                                                    np.asarray(scores).tolist()))


def detector_file_text(found, config: DetectionConfig) -> str:
    """The ``<name>.det.txt`` text of the boxes ``found`` (:class:`~sotmot.types.Detections`) that the detector of
    ``config`` gave a run: its header (:func:`detections_header`), then the boxes, so that the file replays the
    run exactly (``--det``)."""
    header = detections_header(model_in_use(config.model, "detector"))
    return format_detections(found.frames, found.boxes, found.scores, header)


def detections_path(results: str | Path) -> Path:
    """``<name>.det.txt`` beside ``<name>.txt``: the detections a model run used."""
    results = Path(results)
    return results.with_name(results.stem + ".det.txt")


__all__ = ["BOX_FORMAT", "DETECTORS", "ENV_VAR", "HEADER", "KNOWN_FAMILIES", "SCORE_FORMAT", "Detector",
           "detection_source", "detections_header", "detections_path", "detector_file_text", "file_detections",
           "format_detections", "known_family", "make_detector", "read_header", "resolve_detector_path", "rounded"]
