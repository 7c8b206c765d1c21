"""Confirmation: each output box scored by the calibrated box model, and the boxes more likely false than
true dropped (the model and its features: :mod:`sotmot.confidence.box_model`)."""

from __future__ import annotations

import numpy as np

from sotmot.confidence.box_model import BoxModel, box_features
from sotmot.confidence.calibration import load_calibration, model_kind
from sotmot.config import TrackerConfig
from sotmot.postprocess import BoxScorer, Expanded
from sotmot.types import Detections, Tracklet, Tracks


def box_scorer(model: BoxModel, detections: Detections, features: np.ndarray, confidence: np.ndarray,
               frame_rate: float) -> BoxScorer:
    """``model`` as a :data:`~sotmot.postprocess.BoxScorer` for one sequence's ``detections`` (after
    preprocessing), their ``(N, D)`` features and ``(N,)`` detection confidences."""

    def score(trajectory: Tracklet, expanded: Expanded) -> np.ndarray:
        return model.predict(box_features(trajectory, expanded, confidence, detections.from_sot, features,
                                          frame_rate))

    return score


def confirmation_threshold(config: TrackerConfig, method: str) -> float:
    """The probability below which confirmation drops a box: ``[confirm] threshold``, or the calibration's for the
    model kind (:func:`~sotmot.confidence.calibration.model_kind`) of the resolved confidence ``method``."""
    if config.confirm.threshold is not None:
        return config.confirm.threshold
    return load_calibration(config.confirm.calibration).thresholds[model_kind(method)]


def confirm(tracks: Tracks, config: TrackerConfig, method: str = "raw") -> tuple[Tracks, Tracks]:
    """Split scored ``tracks`` into the confirmed boxes and the dropped ones.

    The threshold is ``[confirm] threshold``, or the calibration's for the
    model kind of the confidence ``method`` the sequence used.
    """
    threshold = confirmation_threshold(config, method)
    keep = ~(tracks.confidence < threshold)  # NaN (not scored) is kept
    return tracks.subset(np.flatnonzero(keep)), tracks.subset(np.flatnonzero(~keep))
