"""The plan of one run: every ``"auto"`` of the configuration decided once, for one sequence, before any stage runs.

:func:`resolve` turns a :class:`~sotmot.config.TrackerConfig` and a sequence
into a frozen :class:`Plan`; the stages of :mod:`sotmot.pipeline` read the
plan, nothing re-decides or replaces configuration during a run, and the run
record (:mod:`sotmot.provenance`) writes the plan's decisions. What depends on
the detections' scores (NMS ``"auto"``, the confidence method ``"auto"``) is
decided once where the scores are first read, in preprocessing.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from sotmot.appearance import resolve_backend
from sotmot.config import AppearanceConfig, AssociationConfig, DetectionConfig, TrackerConfig
from sotmot.detection import detection_source, detector_detections, known_family
from sotmot.errors import ConfigError
from sotmot.io import SeqInfo
from sotmot.io.mask import Mask, read_mask
from sotmot.motion import in_pass
from sotmot.sot.support import WEAK_MIN_SCORE
from sotmot.tracklets import checked_batch_length


@dataclass(frozen=True)
class Plan:
    """Every decision of one run of one sequence.

    Attributes
    ----------
    info
        The sequence.
    config
        The configuration as given (its ``"auto"`` values stay; the fields below decide them).
    source
        Where the detections come from: ``"file"`` (``det_file``), ``"model"``
        (the detector run on the frames) or ``"given"`` (handed over in memory).
    det_file
        The detections file of ``source = "file"``, else None.
    weak_boxes
        ``[detection] weak_boxes`` decided: whether the detector's weak boxes
        check what SOT finds and extend trajectory ends.
    detector
        The detector that finds the boxes tracked (``source = "model"``), as
        this run runs it: ``min_score`` lowered to the weak boxes'
        :data:`~sotmot.sot.support.WEAK_MIN_SCORE` when they are used (one pass
        gives both); else None.
    weak_detector
        With ``weak_boxes``: the detector at :data:`~sotmot.sot.support.WEAK_MIN_SCORE`,
        run on the frames the searches visit where no pass of the detector gave
        the weak boxes (a detections file); else None.
    family
        The confidence family of a known detector (``"pd0202"``), else None.
    appearance
        ``[appearance]`` with its backend decided (``"auto"``: OpenVINO where
        installed on the CPU) and its threads no more than the machine's CPUs.
    association
        ``[association]`` with its gap limit in frames at the rate tracked (the
        sequence's, divided by ``[input] step``).
    motion_in_pass
        Whether the pass over the frames measures the camera's motion too
        (a video whose camera ``[motion]`` looks at:
        :func:`sotmot.motion.in_pass`).
    mask
        ``[preprocess] mask`` read and checked against the frames' size, else None.
    """

    info: SeqInfo
    config: TrackerConfig
    source: Literal["file", "model", "given"]
    det_file: Path | None
    weak_boxes: bool
    detector: DetectionConfig | None
    weak_detector: DetectionConfig | None
    family: str | None
    appearance: AppearanceConfig
    association: AssociationConfig
    motion_in_pass: bool = False
    mask: Mask | None = field(default=None, compare=False, repr=False)

    @property
    def sot(self) -> bool:
        """Whether Algorithm 1 runs (``[sot] variant``)."""
        return self.config.sot.variant != "none"

    @property
    def ends_from(self) -> Literal["detections", "sot"]:
        """Where the boxes that extend trajectory ends come from: the detector's weak boxes when the run has
        them, else SOT."""
        return "detections" if self.weak_boxes else "sot"

    def finishing(self, config: TrackerConfig) -> Plan:
        """This plan's decisions on the detections (their source, the detector that found them) with ``config``
        finishing the run (association, post-processing, trajectory ends): ``[detection] weak_boxes`` "on" or
        "off" in ``config`` overrides this plan's, "auto" keeps it (the weak boxes are at hand or not)."""
        weak = {"on": True, "off": False}.get(config.detection.weak_boxes, self.weak_boxes)
        return dataclasses.replace(self, config=config, weak_boxes=weak, weak_detector=_weak(config.detection, weak),
                                   appearance=resolve_backend(config.appearance),
                                   association=_association(config, self.info))

    def record(self) -> dict[str, Any]:
        """The decisions, for the run record."""
        return {"detections": self.source, "weak_boxes": self.weak_boxes, "ends_from": self.ends_from,
                "detector_min_score": None if self.detector is None else self.detector.min_score,
                "confidence_family": self.family, "appearance_backend": self.appearance.backend,
                "l_max_frames": self.association.l_max}


def resolve(config: TrackerConfig, info: SeqInfo, given: bool = False) -> Plan:
    """The plan of tracking ``info`` with ``config``; ``given``: the detections are handed over in memory (else
    ``[detection] source`` decides)."""
    if config.sot.variant != "none" and config.appearance.backend == "none":
        raise ConfigError(f"[sot] variant = {config.sot.variant!r} needs a re-ID model; [appearance] backend = "
                          f"'none' (motion only) tracks without one: set variant = 'none' or choose a backend")
    source, det_file = ("given", None) if given else detection_source(config.detection, info)
    detection = config.detection
    weak = detection.weak_boxes == "on" or (detection.weak_boxes == "auto" and detector_detections(detection, info))
    detector = None
    if source == "model":  # one pass gives the boxes tracked and, below min_score, the weak ones
        low = min(detection.min_score, WEAK_MIN_SCORE) if weak else detection.min_score
        detector = detection if low == detection.min_score else dataclasses.replace(detection, min_score=low)
    step = config.input.step
    checked_batch_length(info.frame_rate / step, config.tracklets, step)  # before any work, not after it
    mask = None if config.preprocess.mask is None else read_mask(config.preprocess.mask, info.width, info.height,
                                                                  info.name)
    return Plan(info, config, source, det_file, weak, detector, _weak(detection, weak),
                known_family(detection, info), resolve_backend(config.appearance),
                _association(config, info), in_pass(info, config.motion),
                mask)


def _association(config: TrackerConfig, info: SeqInfo) -> AssociationConfig:
    """``[association]`` at the frame rate tracked: the sequence's, divided by ``[input] step``."""
    return config.association.at(info.frame_rate / config.input.step)


def _weak(detection: DetectionConfig, needed: bool) -> DetectionConfig | None:
    """The detector at the weak boxes' threshold, when ``needed``."""
    return dataclasses.replace(detection, min_score=WEAK_MIN_SCORE) if needed else None
