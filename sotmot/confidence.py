"""Telling true boxes from false ones: detection confidence and box confirmation after association.

Two stages, both without ground truth at run time:

1. **Detection confidence.** Detector scores are not comparable across
   detectors (public DPM about -1..4, ACF about -0.3..127, Faster R-CNN
   0..1). :func:`detection_confidence` maps them monotonically to [0, 1]:

   * ``"quantile"``: the score's rank among the sequence's own detections
     (an empirical CDF; needs no fitting, but says nothing of absolute quality);
   * ``"dpm"``, ``"acf"``, ``"frcnn"``: the probability that a detection of that
     detector family with this score matches a pedestrian (IoU >= 0.5), an
     isotonic (monotone) fit on training sequences, stored as data in
     ``sotmot/data/confidence.json`` (``scripts/fit_confidence.py`` makes it);
   * ``"raw"``: the scores clipped to [0, 1] (for scores that are already
     probabilities);
   * ``"auto"``: the family from the score range (:func:`detector_family`).

2. **Box confirmation.** After long-term association and interpolation each
   output box gets a probability of being a true positive from a logistic
   model (:class:`BoxModel`) of what its trajectory is made of: its detector
   boxes' confidences (mean and top-k), the share of the trajectory that is
   interpolated, its appearance consistency and its duration, plus the box's
   own confidence (for an interpolated box the higher of its gap's two ends)
   and whether it is interpolated. Durations are in seconds and counts are
   shares, never numbers of frames: a model fitted at 30 fps must not read a
   7 fps sequence's trajectories as short ones. (How long a gap may be
   interpolated at all is ``[postprocess] interpolate_max_seconds``.) Boxes below
   ``[confirm] threshold`` are dropped (or written to a separate file).
   Dropping a box whose probability of being true is ``p`` changes MOTA's
   numerator by ``(1 - p) - p``: it pays when ``p < 0.5``.

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import json
import math
import typing
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from sotmot.appearance import unit, unit_affinity_rows
from sotmot.boxes import centers
from sotmot.config import ConfidenceMethod
from sotmot.errors import ConfigError
from sotmot.postprocess import Expanded
from sotmot.types import Detections, Tracklet

#: Detector families with a stored calibration, and the names ``[preprocess] confidence`` accepts. ``pd0202`` is
#: the built-in detector (Intel's person-detection-0202): never guessed from scores, known from the detector run.
METHODS: tuple[str, ...] = typing.get_args(ConfidenceMethod)
FAMILIES = METHODS[4:]
#: Families whose confirmation model and threshold are their own (fitted on that detector's runs only); the
#: public detectors' families share the ``"calibrated"`` model.
OWN_MODELS = ("pd0202",)

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


def scores_are_probabilities(scores: np.ndarray) -> bool:
    """Whether detection scores all lie in [0, 1] (the public DPM and ACF detections' do not): the one test
    behind NMS ``auto`` (IoU for probabilities, IoM otherwise) and the ``frcnn`` family guess."""
    scores = np.asarray(scores)
    return not len(scores) or bool(scores.min() >= 0.0 and scores.max() <= 1.0)


#: MOTChallenge names a sequence's public detector at the end of its name (``MOT17-09-SDP``).
NAMED_FAMILIES = {"DPM": "dpm", "FRCNN": "frcnn", "SDP": "sdp"}


def family_from_name(name: str) -> str | None:
    """The detector family a sequence's name gives (``MOT17-04-SDP`` -> ``"sdp"``), or None."""
    return NAMED_FAMILIES.get(name.rsplit("-", 1)[-1].upper()) if "-" in name else None


def detector_family(scores: np.ndarray, name: str = "") -> str:
    """The detector family of a sequence's detections (``"auto"`` confidence): named, else guessed.

    The sequence ``name`` says it when it ends in a MOTChallenge detector's
    name (:data:`NAMED_FAMILIES`). Otherwise the score range decides: all in
    [0, 1]: ``"frcnn"`` (a probability-like detector); any score above 10:
    ``"acf"`` (the 2DMOT2015 ACF detections reach about 127); otherwise
    ``"dpm"`` (MOT16's public DPM, about -1 to 5). Name the family in the
    config (``[preprocess] confidence``) when it is known.
    """
    named = family_from_name(name)
    if named is not None:
        return named
    if scores_are_probabilities(scores):
        return "frcnn"
    return "acf" if np.max(scores) > 10.0 else "dpm"


def isotonic(x: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Monotone (non-decreasing) least-squares fit of ``y`` on ``x`` by pool-adjacent-violators.

    Returns knots ``(xs, ys)``: the mean ``x`` and fitted ``y`` of each pooled
    block, both increasing, for :func:`numpy.interp` (which keeps the map
    monotone and continuous between knots, flat beyond them).
    """
    order = np.argsort(np.asarray(x, dtype=np.float64), kind="stable")
    x = np.asarray(x, dtype=np.float64)[order]
    y = np.asarray(y, dtype=np.float64)[order]
    w = np.ones(len(x)) if weights is None else np.asarray(weights, dtype=np.float64)[order]
    blocks: list[list[float]] = []  # [sum w*y, sum w, sum w*x]
    for xi, yi, wi in zip(x, y, w):
        blocks.append([wi * yi, wi, wi * xi])
        while len(blocks) > 1 and blocks[-2][0] / blocks[-2][1] >= blocks[-1][0] / blocks[-1][1]:
            last = blocks.pop()
            blocks[-1] = [a + b for a, b in zip(blocks[-1], last)]
    xs = np.array([b[2] / b[1] for b in blocks])
    ys = np.array([b[0] / b[1] for b in blocks])
    return xs, ys


def fit_logistic(x: np.ndarray, y: np.ndarray, weights: np.ndarray | None = None,
                 l2: float = 1000.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Maximum-likelihood logistic regression of ``y`` (0 / 1) on ``x`` ``(N, F)``: the one fit of the package.

    The features are standardised (``(x - mean) / scale``) and their weights
    carry an L2 penalty ``l2`` (relative to the summed log-likelihood of the
    ``N`` samples); ``weights`` ``(N,)`` weigh the samples (default: all 1).
    Returns ``mean, scale, coef, intercept``: P(y = 1) = sigmoid(z @ coef + intercept).
    """
    from scipy.optimize import minimize

    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    n = len(y)
    sample = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64) * n / np.sum(weights)
    mean = x.mean(axis=0)
    scale = np.where(x.std(axis=0) > 1e-9, x.std(axis=0), 1.0)
    z = np.hstack([(x - mean) / scale, np.ones((n, 1))])

    def loss(w: np.ndarray) -> tuple[float, np.ndarray]:
        s = z @ w
        nll = sample * (np.logaddexp(0.0, s) - y * s)
        p = 1.0 / (1.0 + np.exp(-s))
        reg = 0.5 * l2 * float(w[:-1] @ w[:-1])
        grad = z.T @ (sample * (p - y)) / n
        grad[:-1] += l2 * w[:-1] / n
        return float(nll.mean()) + reg / n, grad

    w = minimize(loss, np.zeros(z.shape[1]), jac=True, method="L-BFGS-B").x
    return mean, scale, w[:-1], float(w[-1])


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

    def predict(self, x: np.ndarray) -> np.ndarray:
        """Probabilities ``(N,)`` for a feature matrix ``(N, len(FEATURES))``; a feature that could not be
        measured (NaN: ``track_appearance`` without re-ID) counts as its training mean."""
        z = np.nan_to_num((np.asarray(x, dtype=np.float64) - np.asarray(self.mean)) / np.asarray(self.scale), nan=0.0)
        return 1.0 / (1.0 + np.exp(-(z @ np.asarray(self.coef) + self.intercept)))

    @classmethod
    def fit(cls, x: np.ndarray, y: np.ndarray, l2: float = 1000.0) -> "BoxModel":
        """Maximum-likelihood logistic regression with an L2 penalty ``l2`` on the standardised weights."""
        mean, scale, coef, intercept = fit_logistic(x, y, l2=l2)
        return cls(tuple(mean.tolist()), tuple(scale.tolist()), tuple(coef.tolist()), intercept)

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


def model_kind(method: str) -> str:
    """Which box model serves detections whose confidence came from ``method`` (a resolved method).

    Quantile confidences are ranks, not probabilities, so they get a model of
    their own (``"quantile"``); the families of :data:`OWN_MODELS` have theirs
    too; the other family maps and raw probabilities share ``"calibrated"``.
    """
    if method in OWN_MODELS:
        return method
    return "quantile" if method == "quantile" else "calibrated"  # "self" maps are probabilities too


@dataclass(frozen=True)
class Calibration:
    """Everything fitted once on training sequences: per-family score maps and the box models.

    Attributes
    ----------
    families
        Family name -> ``(scores, confidences)`` knots of a monotone map.
    box_models
        :func:`model_kind` -> the confirmation model for confidences of that kind.
    thresholds
        :func:`model_kind` -> the fitted confirmation threshold (``[confirm]
        threshold`` defaults to it).
    provenance
        What it was fitted on, by which script and how (free text and numbers).
    """

    families: dict[str, tuple[tuple[float, ...], tuple[float, ...]]]
    box_models: dict[str, BoxModel]
    thresholds: dict[str, float]
    provenance: dict[str, Any]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"families": {k: {"scores": list(v[0]), "confidence": list(v[1])} for k, v in self.families.items()},
                "box_models": {k: m.to_dict() for k, m in self.box_models.items()},
                "thresholds": dict(self.thresholds), "provenance": self.provenance}

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "calibration") -> "Calibration":
        """Read :meth:`to_dict`'s form."""
        try:
            families = {k: (tuple(map(float, v["scores"])), tuple(map(float, v["confidence"])))
                        for k, v in data["families"].items()}
            models = {k: BoxModel.from_dict(m, source) for k, m in data["box_models"].items()}
            thresholds = {k: float(v) for k, v in data["thresholds"].items()}
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ConfigError(f"{source}: not a sotmot confidence calibration ({exc!r})") from exc
        needed = {"calibrated", "quantile"} | {f for f in OWN_MODELS if f in families}  # a map needs its model
        missing = sorted(needed - set(models) | needed - set(thresholds))
        if missing:
            raise ConfigError(f"{source}: no box model or threshold for {', '.join(missing)}")
        return cls(families, models, thresholds, dict(data.get("provenance", {})))


def load_calibration(path: str | Path | None = None) -> Calibration:
    """The calibration in ``path`` (JSON from ``scripts/fit_confidence.py``), or the packaged one.

    Read once per file version (the pipeline asks for it at several stages).
    """
    if path is None:
        return _packaged()
    path = Path(path)
    try:
        st = path.stat()
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the confidence calibration: {exc.strerror}") from exc
    return _read_calibration(str(path.resolve()), st.st_size, st.st_mtime_ns)


@lru_cache(maxsize=8)
def _read_calibration(path: str, size: int, mtime_ns: int) -> Calibration:
    try:
        return Calibration.from_dict(json.loads(Path(path).read_text(encoding="utf-8")), path)
    except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read the confidence calibration: {exc}") from exc


@lru_cache(maxsize=1)
def _packaged() -> Calibration:
    text = resources.files("sotmot").joinpath("data", "confidence.json").read_text(encoding="utf-8")
    return Calibration.from_dict(json.loads(text), "sotmot/data/confidence.json")


def quantile_map(reference: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Knots of the empirical CDF of ``reference`` scores (mid-ranks in (0, 1); ties share a value)."""
    ref = np.sort(np.asarray(reference, dtype=np.float64))
    if not len(ref):
        return np.array([0.0]), np.array([0.5])
    values, first = np.unique(ref, return_index=True)
    last = np.r_[first[1:], len(ref)]
    return values, (first + last) / (2.0 * len(ref))


def confidence_knots(method: str, reference: np.ndarray, calibration: Calibration | None = None,
                     family: str | None = None, name: str = "") -> tuple[str, tuple[np.ndarray, np.ndarray] | None]:
    """Resolve ``method`` for a sequence: the method actually used and its knots (None for ``"raw"``).

    ``reference`` are the sequence's detector scores (the quantile map and
    ``"auto"`` look at them). ``"auto"`` takes the map of ``family`` when the
    detector is known (the built-in one), else of :func:`detector_family` (the
    sequence ``name``, then the scores), or ``"self"`` when ``calibration`` has
    none for that family (held out, a detector never seen: self-fitted maps
    tracked better than the ranks, ``scripts/transfer_confidence.py``).
    """
    if method not in METHODS:
        raise ConfigError(f"[preprocess] confidence must be one of {', '.join(METHODS)}; got {method!r}")
    if method not in ("raw", "quantile"):
        calibration = calibration or load_calibration()
    if method == "auto":
        method = family or detector_family(reference, name)
        if method not in calibration.families:  # a family the calibration never saw: learn it from the sequence
            method = "self"
    if method == "raw":
        return method, None
    if method in ("quantile", "self"):  # "self": the ranks until association has run (then self_knots)
        return method, quantile_map(reference)
    if method not in calibration.families:
        raise ConfigError(f"no stored calibration for detector family {method!r} (have: "
                          f"{', '.join(sorted(calibration.families))}); use confidence = 'quantile'")
    xs, ys = calibration.families[method]
    return method, (np.asarray(xs), np.asarray(ys))


#: ``"self"`` confidence: a detection in a trajectory spanning at least this long (seconds) counts as true, one in
#: no trajectory or in one shorter than ``SELF_SHORT_SECONDS`` as false; those between teach nothing.
SELF_LONG_SECONDS = 2.0
SELF_SHORT_SECONDS = 0.5
#: A long trajectory whose centre stays within this share of its median box height (both ways) stands still: a
#: person waiting or a fixed object the detector keeps firing on, so it teaches nothing. A walker covers about
#: 0.8 of their height a second, so even a slow one leaves this spot within :data:`SELF_LONG_SECONDS`.
SELF_STILL_EXTENT = 0.5
#: The fewest detections of each kind a ``"self"`` map needs; with fewer the ranks (quantile map) stay.
SELF_MIN_SAMPLES = 20


def self_labels(n_detections: int, trajectories: Sequence[Tracklet], from_sot: np.ndarray,
                frame_rate: float) -> np.ndarray:
    """``(N,)`` pseudo-labels of a sequence's detections from its trajectories: 1 true, 0 false, -1 unknown.

    The tracker's own evidence, no ground truth: a person seen walking for
    :data:`SELF_LONG_SECONDS` or more is there; a box that joined no
    trajectory (a lone box) or a trajectory shorter than
    :data:`SELF_SHORT_SECONDS` is most likely not. A long trajectory that
    never leaves its spot (:data:`SELF_STILL_EXTENT`) teaches nothing: a
    detector that keeps firing on a fixed object makes one (MOT16-09's DPM:
    the longest trajectory, 17 s, is a false one that jitters in place), and
    taking it for a person made the map trust low scores (Brier score against
    the ground truth 0.133, 0.091 without them; ``docs/calibration.md``).
    Positions are the trajectories' own (after camera-motion compensation,
    when the camera moved). SOT boxes are left out.
    """
    labels = np.zeros(n_detections, dtype=np.int64)
    for t in trajectories:
        seconds = (t.end - t.start + 1) / frame_rate
        if seconds >= SELF_LONG_SECONDS:
            labels[t.det_index] = -1 if stands_still(t.boxes) else 1
        elif seconds >= SELF_SHORT_SECONDS:
            labels[t.det_index] = -1
    labels[np.asarray(from_sot, dtype=bool)] = -1
    return labels


def stands_still(boxes: np.ndarray) -> bool:
    """Whether ``(L, 4)`` ``x, y, w, h`` boxes keep their centre within :data:`SELF_STILL_EXTENT` of their median
    height, horizontally and vertically."""
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not len(boxes):
        return True
    extent = np.ptp(centers(boxes), axis=0).max()
    return bool(extent < SELF_STILL_EXTENT * np.median(boxes[:, 3]))


def self_knots(scores: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Monotone map of ``scores`` to the share of :func:`self_labels`' true ones; None with too few of either."""
    known = labels >= 0
    if (labels[known] == 1).sum() < SELF_MIN_SAMPLES or (labels[known] == 0).sum() < SELF_MIN_SAMPLES:
        return None
    return isotonic(np.asarray(scores, dtype=np.float64)[known], labels[known].astype(np.float64))


def self_map(detections: Detections, trajectories: Sequence[Tracklet],
             frame_rate: float) -> tuple[np.ndarray, np.ndarray] | None:
    """The ``"self"`` knots of a sequence's ``detections`` from what association made of them (its
    ``trajectories``): :func:`self_labels`, then :func:`self_knots`; None when the sequence teaches too little."""
    return self_knots(detections.scores, self_labels(len(detections), trajectories, detections.from_sot, frame_rate))


def detection_confidence(scores: np.ndarray, knots: tuple[np.ndarray, np.ndarray] | None) -> np.ndarray:
    """Confidences in [0, 1] of ``scores`` through monotone ``knots`` (None: scores clipped to [0, 1])."""
    scores = np.asarray(scores, dtype=np.float64)
    if knots is None:
        return np.clip(scores, 0.0, 1.0)
    return np.clip(np.interp(scores, knots[0], knots[1]), 0.0, 1.0)


def box_features(trajectory: Tracklet, expanded: Expanded, confidence: np.ndarray, from_sot: np.ndarray,
                 features: np.ndarray, frame_rate: float) -> np.ndarray:
    """The :data:`FEATURES` of each box of one expanded trajectory, ``(L, len(FEATURES))``.

    Parameters
    ----------
    trajectory
        The merged trajectory (before interpolation).
    expanded
        The same trajectory as written (see :class:`Expanded`).
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
