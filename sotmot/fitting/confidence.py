"""Fitting the confidence calibration (``sotmot/data/confidence.json``) from labelled sequences.

Used by ``scripts/fit_confidence.py`` and ``scripts/fit_detector_confidence.py`` (the lifted costs:
:mod:`sotmot.fitting.lifted`); nothing here runs while tracking. Labels
come from TrackEval's own preprocessing and the CLEAR matching rule
(:func:`sotmot.scoring.frame_errors`): a box is a true positive when it is
matched to a considered pedestrian at IoU >= 0.5, a false positive when it is
unmatched, and is left out when TrackEval removes it (a box on a distractor
class of MOT16 ground truth). The labels come from one matching of the whole
unconfirmed output; once a box is dropped its ground truth may match another
track's box instead, which the labels do not see (a small approximation).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sotmot.confidence.box_model import FEATURES, BoxModel, box_features
from sotmot.confidence.calibration import Calibration, model_kind
from sotmot.confidence.maps import (
    FAMILIES,
    confidence_knots,
    detection_confidence,
    detector_family,
    isotonic,
    quantile_map,
    self_map,
)
from sotmot.config import PostprocessConfig, TrackerConfig
from sotmot.scoring import EvalReport, FrameErrors, evaluate_files, frame_errors
from sotmot.io import SeqInfo, read_detections, read_seqinfo, results_path, write_results
from sotmot.confirm import box_scorer, confirm
from sotmot.fitting.logistic import fit_box_model
from sotmot.pipeline import Prepared, associate
from sotmot.preprocess import preprocess
from sotmot.postprocess import expand, line_checked, output_ids
from sotmot.types import Tracklet, Tracks


def clear_matching(tracks: Tracks, info: SeqInfo, workdir: Path) -> FrameErrors:
    """``tracks`` written as the sequence's results under ``workdir`` and matched to its ground truth, frame by
    frame (:func:`sotmot.scoring.frame_errors`)."""
    path = results_path(workdir, info.name)
    write_results(path, tracks)
    return frame_errors(path, info.gt_path, info.length, info.name)


def box_labels(tracks: Tracks, info: SeqInfo, workdir: Path) -> np.ndarray:
    """``(N,)`` label of each row of ``tracks``: 1 true positive, 0 false positive, -1 not scored."""
    errors = clear_matching(tracks, info, workdir)
    status: dict[tuple[int, int], int] = {}
    for frame, rows in errors.matched.items():
        for _, _, tid, _ in rows:
            status[frame, tid] = 1
    for frame, rows in errors.false_positives.items():
        for _, tid in rows:
            status[frame, tid] = 0
    return np.array([status.get((int(f), int(i)), -1) for f, i in zip(tracks.frames, tracks.ids)], dtype=np.int64)


def detection_labels(seq_dir: str | Path, config: TrackerConfig, workdir: Path,
                     family: str | None = None) -> tuple[str, np.ndarray, np.ndarray]:
    """Family (``family``, else guessed from the scores), scores and labels of a sequence's preprocessed
    detections (frames are not needed).

    Each detection is written as a track of its own, so the CLEAR matching
    labels every box independently.
    """
    from sotmot.detection import detection_source

    info = read_seqinfo(seq_dir)
    raw = read_detections(detection_source(config.detection, info)[1] or info.det_path, info.length)
    dets = preprocess(raw, config.preprocess)
    tracks = Tracks(dets.frames, np.arange(1, len(dets) + 1), dets.boxes, dets.scores)
    return family or detector_family(raw.scores, info.name), dets.scores, box_labels(tracks, info, workdir)


@dataclass
class Labelled:
    """One training sequence taken through association, with every output box labelled.

    Attributes
    ----------
    prepared
        The sequence up to the tracklets (detections, features, tracklets).
    trajectories
        The solver's merged trajectories.
    family
        The detector family: the one given, or the one its scores look like.
    raw_scores
        Every detector score in ``det.txt`` (the quantile map's reference).
    labels
        ``(frame, id) -> 1 / 0`` for the boxes of the unconfirmed output.
    track_ids
        The output track id of each trajectory (:func:`~sotmot.postprocess.output_ids`).
    """

    prepared: Prepared
    trajectories: list[Tracklet]
    family: str
    raw_scores: np.ndarray
    labels: dict[tuple[int, int], int] = field(default_factory=dict)
    track_ids: list[int | None] = field(default_factory=list)

    @property
    def name(self) -> str:
        return self.prepared.info.name

    def postprocess(self, config: TrackerConfig) -> PostprocessConfig:
        """``config``'s ``[postprocess]`` as it applies to these trajectories (the interpolation bound after the
        line check, :func:`~sotmot.postprocess.line_checked`), as the tracker applies it."""
        return line_checked(config.postprocess, self.trajectories, self.prepared.info.frame_rate)


def label_sequence(prepared: Prepared, raw_scores: np.ndarray, config: TrackerConfig,
                   workdir: Path, family: str | None = None) -> Labelled:
    """Associate, post-process without confirmation, and label every output box; the detector ``family``, else
    guessed from the scores."""
    _, trajectories = associate(prepared.tracklets, prepared.finishing(config))
    post = line_checked(config.postprocess, trajectories, prepared.info.frame_rate)
    ids = output_ids(trajectories, post, prepared.info.frame_rate, prepared.occluders)
    tracks = prepared.written(trajectories, post, None, ids)
    labels = box_labels(tracks, prepared.info, workdir)
    keyed = {(int(f), int(i)): int(v) for f, i, v in zip(tracks.frames, tracks.ids, labels) if v >= 0}
    return Labelled(prepared, trajectories, family or detector_family(raw_scores, prepared.info.name),
                    np.asarray(raw_scores), keyed, ids)


def labelled_data(seq_dirs: Sequence[Path], label_dirs: Sequence[Path], config: TrackerConfig, solver: str,
                  cache: Path, workdir: Path, report: Callable[[str], None] | None = None
                  ) -> tuple[list[Labelled], dict[str, tuple[str, np.ndarray, np.ndarray]],
                             dict[str, list[tuple[np.ndarray, np.ndarray]]]]:
    """What the confidence fits learn from: each sequence with frames taken through association by ``solver`` and
    labelled (:func:`label_sequence`; features from ``cache``), its detections' labels by name, and the label-only
    sequences' detection labels by family (:func:`detection_labels`). ``report`` receives a line per sequence."""
    from sotmot.benchmarks import cached_features
    from sotmot.pipeline import prepare_sequence

    say = report or (lambda line: None)
    embedder_box: list = []
    seqs, samples, extra = [], {}, {}
    for seq_dir in seq_dirs:
        prepared = prepare_sequence(seq_dir, config, features=cached_features(seq_dir, config, cache, embedder_box))
        raw = read_detections(prepared.info.det_path, prepared.info.length)
        seqs.append(label_sequence(prepared, raw.scores, config.replace("association", solver=solver), workdir))
        samples[prepared.info.name] = detection_labels(seq_dir, config, workdir)
        say(f"{prepared.info.name}: {len(prepared.detections)} detections, {len(seqs[-1].trajectories)} "
            f"trajectories, family {seqs[-1].family}")
    for seq_dir in label_dirs:
        family, scores, labels = detection_labels(seq_dir, config, workdir)
        extra.setdefault(family, []).append((scores, labels))
        say(f"{Path(seq_dir).name} (labels only): {len(scores)} detections, family {family}")
    return seqs, samples, extra


def fit_families(samples: dict[str, list[tuple[np.ndarray, np.ndarray]]]) -> dict[str, tuple[tuple, tuple]]:
    """Isotonic maps per family from ``family -> [(scores, labels), ...]`` (labels -1 left out)."""
    out = {}
    for family, parts in samples.items():
        scores = np.concatenate([p[0] for p in parts])
        labels = np.concatenate([p[1] for p in parts])
        keep = labels >= 0
        if keep.sum() < 2:
            continue
        xs, ys = isotonic(scores[keep], labels[keep])
        out[family] = (tuple(xs.tolist()), tuple(ys.tolist()))
    return out


def sequence_confidence(seq: Labelled, method: str, calibration: Calibration) -> tuple[str, np.ndarray]:
    """The method used and the detection confidences of ``seq`` under ``calibration``.

    ``"auto"`` falls back to ``"self"`` when the calibration has no map for
    the sequence's family (as when it is the only sequence of its family and
    is held out), and ``"self"`` to ``"quantile"`` when the sequence teaches
    too little, as they do when tracking.
    """
    used, knots = confidence_knots(method, seq.raw_scores, calibration, seq.family)
    dets = seq.prepared.detections
    if used == "self":  # as finish_sequence does: the map from this sequence's own trajectories
        knots = self_map(dets, seq.trajectories, seq.prepared.info.frame_rate)
        if knots is None:
            used, knots = "quantile", quantile_map(seq.raw_scores)
    return used, detection_confidence(dets.scores, knots)


def scored_boxes(seq: Labelled, confidence: np.ndarray, config: TrackerConfig) -> tuple[np.ndarray, np.ndarray]:
    """Features ``(M, len(FEATURES))`` and labels ``(M,)`` of the labelled output boxes of ``seq``."""
    p, post = seq.prepared, seq.postprocess(config)
    rows, labels = [], []
    occluders = p.occluders
    for t, tid in zip(seq.trajectories, seq.track_ids):
        if tid is None:
            continue
        e = expand(t, post, p.info.frame_rate, occluders)
        x = box_features(t, e, confidence, p.detections.from_sot, p.features, p.info.frame_rate)
        y = np.array([seq.labels.get((int(f), tid), -1) for f in e.frames])
        rows.append(x[y >= 0])
        labels.append(y[y >= 0])
    if not rows:
        return np.zeros((0, len(FEATURES))), np.zeros(0)
    return np.vstack(rows), np.concatenate(labels).astype(np.float64)


def confirmed_tracks(seq: Labelled, confidence: np.ndarray, model: BoxModel, threshold: float,
                     config: TrackerConfig) -> Tracks:
    """The output of ``seq`` after confirmation with ``model`` at ``threshold``."""
    p = seq.prepared
    scorer = box_scorer(model, p.detections, p.features, confidence, p.info.frame_rate)
    tracks = p.written(seq.trajectories, seq.postprocess(config), scorer, seq.track_ids)
    return confirm(tracks, config.replace("confirm", threshold=threshold))[0]


def score(seqs: Sequence[Labelled], make_tracks: Callable[[Labelled], Tracks]) -> EvalReport:
    """TrackEval scores of ``make_tracks(seq)`` for each sequence."""
    with tempfile.TemporaryDirectory(prefix="sotmot-fit-") as tmp:
        pairs = []
        for seq in seqs:
            path = results_path(Path(tmp), seq.name)
            write_results(path, make_tracks(seq))
            pairs.append((path, seq.prepared.info.gt_path, seq.prepared.info.length, seq.name))
        return evaluate_files(pairs)


#: How much HOTA or IDF1 a training sequence may lose against the unconfirmed output for a threshold to count.
TOLERANCE = 0.5


def objective(report: EvalReport, base: EvalReport) -> float:
    """What threshold selection maximises: the mean MOTA over sequences, when no sequence loses more
    than :data:`TOLERANCE` HOTA or IDF1 against ``base`` (the unconfirmed output); else minus infinity."""
    for name, values in report.sequences.items():
        if any(values[m] < base.sequences[name][m] - TOLERANCE for m in ("HOTA", "IDF1")):
            return float("-inf")
    return float(np.mean([v["MOTA"] for v in report.sequences.values()]))


def unconfirmed_tracks(seq: Labelled, config: TrackerConfig) -> Tracks:
    """The output of ``seq`` without confirmation (post-processing as configured)."""
    return seq.prepared.written(seq.trajectories, seq.postprocess(config), None, seq.track_ids)


@dataclass
class Fit:
    """A calibration fitted on some sequences, and how its thresholds were chosen.

    Attributes
    ----------
    calibration
        The fitted maps, models and thresholds.
    threshold_scores
        Model kind -> threshold -> :func:`objective` on the training sequences.
    """

    calibration: Calibration
    threshold_scores: dict[str, dict[float, float]]


#: The box models :func:`fit` makes by default: model kind -> the ``[preprocess] confidence`` method it serves.
PUBLIC_KINDS = (("calibrated", "auto"), ("quantile", "quantile"))


def fit(train: Sequence[Labelled], extra_families: dict[str, list[tuple[np.ndarray, np.ndarray]]],
        detection_samples: dict[str, tuple[str, np.ndarray, np.ndarray]], thresholds: Sequence[float],
        config: TrackerConfig, base: EvalReport, l2: float = 1000.0,
        kinds: Sequence[tuple[str, str]] = PUBLIC_KINDS) -> Fit:
    """Fit family maps, the box models of ``kinds`` and their thresholds on ``train``.

    Parameters
    ----------
    train
        Labelled training sequences.
    extra_families
        ``family -> [(scores, labels)]`` from label-only sequences (no frames),
        used for the family maps only.
    detection_samples
        ``name -> (family, scores, labels)`` of each training sequence's detections.
    thresholds
        Candidate thresholds; the one with the best :func:`objective` on
        ``train`` wins (0 keeps every box, so one always qualifies).
    base
        Scores of the unconfirmed output of (at least) the training sequences.
    l2
        L2 penalty of the logistic models (boxes of one trajectory are far
        from independent samples: a strong penalty keeps the weights small).
    kinds
        ``(model kind, method)`` pairs: a box model for each, fitted on the
        training sequences whose ``method`` resolves to that kind (the
        built-in detector's runs: ``(("pd0202", "auto"),)``).
    """
    samples: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {f: list(v) for f, v in extra_families.items()}
    for seq in train:
        family, scores, labels = detection_samples[seq.name]
        samples.setdefault(family, []).append((scores, labels))
    families = fit_families({f: v for f, v in samples.items() if f in FAMILIES})
    draft = Calibration(families, {}, {}, {})
    models, chosen, scores_by_kind = {}, {}, {}
    for kind, method in kinds:
        confidences, xs, ys = {}, [], []
        for seq in train:
            used, confidences[seq.name] = sequence_confidence(seq, method, draft)
            if model_kind(used) != kind:
                continue  # a family without a map: its quantiles serve the other model only
            x, y = scored_boxes(seq, confidences[seq.name], config)
            xs.append(x)
            ys.append(y)
        model = fit_box_model(np.vstack(xs), np.concatenate(ys), l2=l2)
        results = {}
        for threshold in sorted({0.0, *map(float, thresholds)}):
            report = score(train, lambda s: confirmed_tracks(s, confidences[s.name], model, threshold, config))
            results[threshold] = objective(report, base)
        models[kind] = model
        chosen[kind] = max(results, key=lambda t: (results[t], -t))
        scores_by_kind[kind] = results
    calibration = Calibration(families, models, chosen, {
        "sequences": [s.name for s in train],
        "threshold_objective": f"mean MOTA, no sequence losing more than {TOLERANCE} HOTA or IDF1",
        "threshold_scores": {k: {f"{t:.2f}": (round(v, 3) if np.isfinite(v) else None) for t, v in r.items()}
                             for k, r in scores_by_kind.items()}})
    return Fit(calibration, scores_by_kind)


def held_out_tracks(seq: Labelled, method: str, calibration: Calibration, config: TrackerConfig
                    ) -> tuple[str, Tracks]:
    """The confidence method ``seq`` ends up with and its confirmed output under ``calibration``."""
    used, confidence = sequence_confidence(seq, method, calibration)
    kind = model_kind(used)
    return used, confirmed_tracks(seq, confidence, calibration.box_models[kind], calibration.thresholds[kind], config)
