"""The confirmation model (stage 2 of :mod:`sotmot.confidence`): what each output box's trajectory is made of,
and a logistic model of P(box is a true positive) over it. Fitted by :mod:`sotmot.fitting.confidence`; applied by
:mod:`sotmot.confirm`.

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sotmot.appearance import unit, unit_affinity_rows
from sotmot.errors import ConfigError
from sotmot.postprocess import Expanded
from sotmot.types import Tracklet

#: Names of the features :func:`box_features` computes, in column order.
FEATURES = ("box_conf", "interpolated", "track_conf_mean", "track_conf_top", "track_interp_share",
            "track_appearance", "track_brevity")

#: Trajectories shorter than this (seconds) count as short: ``track_brevity`` is the log of how many
#: times shorter (0 for longer ones, so a trajectory cut by the end of a short clip is not penalised
#: for the clip's length).
SHORT_SECONDS = 1.0
#: Confidences are clipped to [EPS, 1 - EPS] before taking their log-odds.
EPS = 0.01
#: ``track_conf_top`` is this quantile of a trajectory's detection confidences (a quantile, not the
#: mean of the top k, whose expected value grows with the number of boxes).
TOP_QUANTILE = 0.8


def logit(p: np.ndarray) -> np.ndarray:
    """Log-odds of probabilities clipped to ``[EPS, 1 - EPS]``."""
    p = np.clip(np.asarray(p, dtype=np.float64), EPS, 1.0 - EPS)
    return np.log(p / (1.0 - p))


def logistic(z: np.ndarray | float) -> np.ndarray:
    """Probabilities from log-odds ``z`` (the inverse of :func:`logit`, without its clipping)."""
    return 1.0 / (1.0 + np.exp(-np.asarray(z, dtype=np.float64)))


@dataclass(frozen=True)
class BoxModel:
    """A logistic model of P(box is a true positive) over the :data:`FEATURES`.

    Attributes
    ----------
    mean, scale
        Standardisation of each feature (``(x - mean) / scale``).
    coef
        One weight per feature.
    intercept
        The bias.
    """

    mean: tuple[float, ...]
    scale: tuple[float, ...]
    coef: tuple[float, ...]
    intercept: float

    def terms(self, x: np.ndarray) -> np.ndarray:
        """``(N, len(FEATURES))`` what each feature adds to the log-odds of each row of the feature matrix ``x``,
        against a box whose every feature is at its training mean (whose log-odds are :attr:`intercept`); a
        feature that could not be measured (NaN: ``track_appearance`` without re-ID) adds 0."""
        z = np.nan_to_num((np.asarray(x, dtype=np.float64) - np.asarray(self.mean)) / np.asarray(self.scale), nan=0.0)
        return z * np.asarray(self.coef)

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Probabilities ``(N,)`` for a feature matrix ``(N, len(FEATURES))``: the logistic of :meth:`terms`'
        sum plus :attr:`intercept`."""
        return logistic(self.terms(x).sum(axis=1) + self.intercept)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form, with the feature names."""
        return {"features": list(FEATURES), "mean": list(self.mean), "scale": list(self.scale),
                "coef": list(self.coef), "intercept": self.intercept}

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "model") -> "BoxModel":
        """Read :meth:`to_dict`'s form, checking that its features are this version's."""
        if list(data.get("features", [])) != list(FEATURES):
            raise ConfigError(f"{source}: its features {data.get('features')} are not {list(FEATURES)}; "
                              f"refit it with scripts/fit_confidence.py")
        return cls(tuple(data["mean"]), tuple(data["scale"]), tuple(data["coef"]), float(data["intercept"]))


def box_features(trajectory: Tracklet, expanded: Expanded, confidence: np.ndarray, from_sot: np.ndarray,
                 features: np.ndarray, frame_rate: float) -> np.ndarray:
    """The :data:`FEATURES` of each box of one expanded trajectory, ``(L, len(FEATURES))``.

    Parameters
    ----------
    trajectory
        The merged trajectory (before interpolation).
    expanded
        The same trajectory as written (see :class:`~sotmot.postprocess.Expanded`).
    confidence
        ``(N,)`` confidence of every detection of the sequence.
    from_sot
        ``(N,)`` True for boxes the SOT step added (they do not count as detector boxes).
    features
        ``(N, D)`` appearance features of the detections.
    frame_rate
        Frames per second (durations are in seconds).
    """
    idx = trajectory.det_index
    det = idx[~from_sot[idx]]
    if not len(det):
        det = idx
    conf = confidence[det]
    top = np.quantile(conf, TOP_QUANTILE)
    consistency = math.nan  # no re-ID (motion only): not measured
    if features.shape[1]:
        mean_unit = unit(features[det].mean(axis=0))
        consistency = float(unit_affinity_rows(unit(features[det]), np.repeat(mean_unit, len(det), axis=0)).mean())
    span = trajectory.end - trajectory.start + 1
    brevity = max(0.0, float(np.log(SHORT_SECONDS * frame_rate / span)))
    track = [float(logit(conf).mean()), float(logit(top).mean()), 1.0 - len(trajectory) / span, consistency, brevity]

    n = len(expanded.frames)
    box_conf = np.zeros(n)
    real = ~expanded.filled
    box_conf[real] = confidence[expanded.det_index[real]]
    pos = np.flatnonzero(real)
    for a, b in zip(pos[:-1], pos[1:]):
        if b - a > 1:
            box_conf[a + 1:b] = max(box_conf[a], box_conf[b])
    columns = [logit(box_conf), expanded.filled.astype(float)]
    return np.hstack([np.stack(columns, axis=1), np.tile(track, (n, 1))])


def feature_table(rows: Sequence[np.ndarray]) -> np.ndarray:
    """Stack per-trajectory feature blocks into one ``(N, len(FEATURES))`` matrix."""
    return np.vstack(rows) if rows else np.zeros((0, len(FEATURES)))
