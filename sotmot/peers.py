"""Other trackers run on sotmot's inputs, for the benchmarks (``scripts/bench_peers.py``, ``scripts/bench_speed.py``).

Every peer gets the same :class:`SeqInput`: sotmot's preprocessed detections,
their re-ID features (computed once, by sotmot's embedder) and scores mapped
to [0, 1] where they are not (:func:`peer_scores`). Each ``run_*`` returns the
peer's output as :class:`~sotmot.types.Tracks` and the seconds of its
tracking loop alone. The peers' packages (``trackers`` and ``supervision``,
``deep-sort-realtime``, ``boxmot``) come with ``bash scripts/bootstrap.sh
--bench`` and are imported only when their tracker runs. :func:`report_tables`
and :func:`row_machines` read the reports ``bench_peers.py`` writes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sotmot.boxes import xywh_to_xyxy, xyxy_to_xywh
from sotmot.confidence.maps import scores_are_probabilities
from sotmot.config import TrackerConfig
from sotmot.io import FrameReader, read_detections, read_seqinfo
from sotmot.passes import embed_detections
from sotmot.preprocess import preprocess
from sotmot.types import Detections, Tracks

#: boxmot trackers: display name -> (boxmot name, options that turn its camera-motion compensation off, or None
#: where it has none to turn off (StrongSORT) or no switch for it (HybridSORT, always ECC)).
BOXMOT = {
    "BoT-SORT": ("botsort", {"use_cmc": False}),
    "StrongSORT": ("strongsort", None),
    "DeepOCSORT": ("deepocsort", {"cmc_off": True}),
    "BoostTrack++": ("boosttrack", {"use_cmc": False}),
    "HybridSORT": ("hybridsort", None),
    "OccluBoost": ("occluboost", {"use_cmc": False}),
}
#: The option of each boxmot tracker that says how many frames a lost track is kept (its memory).
BOXMOT_MEMORY = {"BoT-SORT": "track_buffer", "StrongSORT": "max_age", "DeepOCSORT": "max_age",
                 "BoostTrack++": "max_age", "HybridSORT": "max_age", "OccluBoost": "max_age"}
#: ``+GSI 4s`` rows: a peer given sotmot's memory, its lost-track buffer and its GSI interval both
#: ``[association] l_max_seconds`` (4 s) at the sequence's frame rate (issue #38: a fair comparison).
MEMORY_SECONDS = TrackerConfig().association.l_max_seconds
BOXMOT_CMC = {"BoT-SORT": "SOF", "DeepOCSORT": "SOF", "BoostTrack++": "ECC", "HybridSORT": "ECC", "OccluBoost": "SOF"}
#: Every boxmot tracker with its defaults, with boxmot's GSI post-processing, and without CMC where it can be off.
BOXMOT_ROWS = {**{name: (name, "default") for name in BOXMOT},
               **{f"{name} +GSI": (name, "gsi") for name in BOXMOT},
               **{f"{name} no-CMC": (name, "no-cmc") for name, (_, off) in BOXMOT.items() if off is not None},
               **{f"{name} +GSI 4s": (name, "memory") for name in BOXMOT}}
@dataclass
class SeqInput:
    """What every tracker gets for one sequence."""

    path: Path
    info: object
    detections: Detections
    features: np.ndarray
    peer_scores: np.ndarray
    reid_seconds: float


def peer_scores(scores: np.ndarray) -> np.ndarray:
    """Scores in [0, 1] for peers: unchanged if they already are, else rank / count (see the module docstring)."""
    scores = np.asarray(scores, dtype=np.float64)
    if scores_are_probabilities(scores):
        return scores
    from scipy.stats import rankdata

    return rankdata(scores, method="average") / len(scores)


def memory_frames(seconds: float, seq: SeqInput) -> int:
    """``seconds`` of a sequence in frames at its rate (at least one): a peer's lost-track buffer or GSI interval."""
    return max(1, int(round(seconds * float(seq.info.frame_rate))))


def frames_of(seq: SeqInput) -> list[np.ndarray]:
    """Row indices of the detections of each frame, 1..length."""
    frames = seq.detections.frames
    order = np.argsort(frames, kind="stable")
    bounds = np.searchsorted(frames[order], np.arange(1, seq.info.length + 2))
    return [order[bounds[f]:bounds[f + 1]] for f in range(seq.info.length)]


#: The motion-only peers of the ``trackers`` package (they read neither frames nor embeddings).
TRACKERS_PACKAGE = ("SORT", "ByteTrack", "OC-SORT")
#: Each of them as it comes and given sotmot's memory (``+GSI 4s``: a lost track kept :data:`MEMORY_SECONDS`, boxmot's
#: GSI filling gaps as long): display name -> (tracker, memory in seconds or None).
TRACKERS_ROWS = {**{name: (name, None) for name in TRACKERS_PACKAGE},
                 **{f"{name} +GSI {MEMORY_SECONDS:g}s": (name, MEMORY_SECONDS) for name in TRACKERS_PACKAGE}}


def run_trackers_package(name: str, seq: SeqInput, memory_seconds: float | None = None) -> tuple[Tracks, float]:
    """SORT, ByteTrack or OC-SORT from ``trackers``: boxes of detections given a track id, per frame.

    ``memory_seconds``: keep a lost track that long (its ``lost_track_buffer``, which counts frames at 30 fps
    and is scaled by the frame rate) instead of the package's default second; None keeps the default.
    """
    import supervision as sv
    from trackers import ByteTrackTracker, OCSORTTracker, SORTTracker

    cls = {"SORT": SORTTracker, "ByteTrack": ByteTrackTracker, "OC-SORT": OCSORTTracker}[name]
    memory = {} if memory_seconds is None else {"lost_track_buffer": max(1, int(round(30 * memory_seconds)))}
    tracker = cls(frame_rate=float(seq.info.frame_rate), **memory)
    per_frame = frames_of(seq)
    xyxy = xywh_to_xyxy(seq.detections.boxes)
    inputs = [sv.Detections(xyxy=xyxy[rows], confidence=seq.peer_scores[rows],
                            class_id=np.zeros(len(rows), dtype=int)) for rows in per_frame]
    out: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]] = []
    start = time.perf_counter()
    for frame, dets in enumerate(inputs, start=1):
        result = tracker.update(dets)
        keep = np.asarray(result.tracker_id) >= 0
        out.append((frame, np.asarray(result.tracker_id)[keep], result.xyxy[keep],
                    np.asarray(result.confidence)[keep]))
    seconds = time.perf_counter() - start
    return as_tracks(out, boxes_are_xyxy=True), seconds


def run_deepsort(seq: SeqInput, min_affinity: float) -> tuple[Tracks, float]:
    """DeepSORT (deep-sort-realtime) on sotmot's features; confirmed tracks matched in the frame."""
    from deep_sort_realtime.deepsort_tracker import DeepSort

    # sotmot's affinity is 1 - ||a - b|| / 2 on unit features, and cosine distance is ||a - b||^2 / 2,
    # so the affinity gate g is the cosine distance 2 (1 - g)^2
    tracker = DeepSort(max_cosine_distance=2.0 * (1.0 - min_affinity) ** 2, embedder=None)
    per_frame = frames_of(seq)
    boxes, scores = seq.detections.boxes, seq.peer_scores
    inputs = [([(boxes[r].tolist(), float(scores[r]), "person") for r in rows], [seq.features[r] for r in rows])
              for rows in per_frame]
    out = []
    start = time.perf_counter()
    for frame, (raw, embeds) in enumerate(inputs, start=1):
        tracks = tracker.update_tracks(raw, embeds=embeds)
        live = [t for t in tracks if t.is_confirmed() and t.time_since_update == 0]
        out.append((frame, np.array([int(t.track_id) for t in live], dtype=np.int64),
                    np.array([t.to_ltwh(orig=True) for t in live], dtype=np.float64).reshape(-1, 4),
                    np.array([t.get_det_conf() or 0.0 for t in live], dtype=np.float64)))
    seconds = time.perf_counter() - start
    return as_tracks(out, boxes_are_xyxy=False), seconds


def run_boxmot(row: str, seq: SeqInput, shuffle: bool = False) -> tuple[Tracks, float]:
    """A boxmot tracker (see :data:`BOXMOT_ROWS`) fed sotmot's detections and embeddings, one frame at a time.

    With embeddings given, boxmot builds no re-ID model. The frames are read
    (the trackers that compensate camera motion need them) outside the clock;
    the seconds count ``update`` calls only. ``shuffle`` permutes the
    embeddings across the sequence's detections (the check that they are used).
    """
    import torch
    from boxmot.structures.detections import Detections as BoxmotDetections
    from boxmot.structures.geometry import Boxes
    from boxmot.trackers.factory import create_tracker
    from boxmot.trackers.specs import TrackerSpec

    name, mode = BOXMOT_ROWS[row]
    boxmot_name, cmc_off = BOXMOT[name]
    options = tuple(sorted((cmc_off or {}).items())) if mode == "no-cmc" else ()
    memory = memory_frames(MEMORY_SECONDS, seq) if mode == "memory" else None
    if memory is not None:
        options = ((BOXMOT_MEMORY[name], memory),)
    tracker = create_tracker(TrackerSpec(name=boxmot_name, options=options))
    features = seq.features.astype(np.float32)
    if shuffle:
        features = features[np.random.default_rng(0).permutation(len(features))]
    xyxy = xywh_to_xyxy(seq.detections.boxes).astype(np.float32)
    reader = FrameReader(seq.info, cache_size=1)
    out, seconds = [], 0.0
    for frame, rows in enumerate(frames_of(seq), start=1):
        image = reader(frame)
        dets = BoxmotDetections(geometry=Boxes(torch.from_numpy(xyxy[rows])),
                                scores=torch.from_numpy(seq.peer_scores[rows].astype(np.float32)),
                                class_ids=torch.zeros(len(rows), dtype=torch.int64), sample_id=str(frame),
                                embeddings=torch.from_numpy(features[rows]).reshape(len(rows), features.shape[1]))
        start = time.perf_counter()
        result = tracker.update(dets, image)
        seconds += time.perf_counter() - start
        out.append((frame, result.track_ids.numpy().astype(np.int64), result.geometry.values.numpy().astype(float),
                    result.scores.numpy().astype(float)))
    tracks = as_tracks(out, boxes_are_xyxy=True)
    if memory is not None:
        return gsi(tracks, interval=memory), seconds
    return (gsi(tracks) if mode == "gsi" else tracks), seconds


def gsi(tracks: Tracks, interval: int = 20, tau: float = 10.0) -> Tracks:
    """boxmot's offline Gaussian-smoothed interpolation (its defaults) applied to ``tracks``."""
    from boxmot.postprocessing.gsi import gaussian_smooth, linear_interpolation

    if not len(tracks):
        return tracks
    data = np.column_stack([tracks.frames, tracks.ids, tracks.boxes, tracks.scores, -np.ones(len(tracks))])
    smoothed = gaussian_smooth(linear_interpolation(data, interval), tau)
    # with intervals of seconds, boxmot's interpolation can write a frame of a track twice (its frames are floats,
    # one a hair below the integer): keep the first box of each (track, frame)
    smoothed[:, 0] = np.round(smoothed[:, 0])
    _, first = np.unique(smoothed[:, [1, 0]], axis=0, return_index=True)
    smoothed = smoothed[np.sort(first)]
    return Tracks(frames=smoothed[:, 0].astype(np.int64), ids=smoothed[:, 1].astype(np.int64),
                  boxes=smoothed[:, 2:6], scores=smoothed[:, 6])


def as_tracks(rows: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]], boxes_are_xyxy: bool) -> Tracks:
    """A peer's output, ``(frame, ids, boxes, scores)`` per frame, as :class:`Tracks` with ids 1, 2, ..."""
    frames = np.concatenate([np.full(len(ids), f) for f, ids, _, _ in rows]) if rows else np.zeros(0)
    ids = np.concatenate([ids for _, ids, _, _ in rows]) if rows else np.zeros(0)
    boxes = np.concatenate([b for _, _, b, _ in rows]).reshape(-1, 4) if rows else np.zeros((0, 4))
    scores = np.concatenate([s for _, _, _, s in rows]) if rows else np.zeros(0)
    if boxes_are_xyxy:
        boxes = xyxy_to_xywh(boxes)
    _, ids = np.unique(ids, return_inverse=True)  # 1-based consecutive identities
    return Tracks(frames=frames, ids=ids + 1, boxes=boxes, scores=scores)


def load(path: Path, config: TrackerConfig, embedder) -> SeqInput:
    """A sequence's :class:`SeqInput`: detections (``det/det.txt``, or ``[detection] file``) cleaned by ``config``,
    embedded (and timed) by ``embedder``."""
    info = read_seqinfo(path)
    det_file = Path(config.detection.file) if config.detection.file else info.det_path
    dets = preprocess(read_detections(det_file, info.length), config.preprocess)
    start = time.perf_counter()
    features = embed_detections(info, dets, embedder)
    return SeqInput(path, info, dets, features, peer_scores(dets.scores), time.perf_counter() - start)


def run_peer(name: str, seq: SeqInput, min_affinity: float) -> tuple[Tracks, float]:
    """Any peer by its display name (a row of :data:`TRACKERS_ROWS`, DeepSORT, or a row of :data:`BOXMOT_ROWS`)."""
    if name in BOXMOT_ROWS:
        return run_boxmot(name, seq)
    if name == "DeepSORT":
        return run_deepsort(seq, min_affinity)
    tracker, memory = TRACKERS_ROWS[name]
    tracks, seconds = run_trackers_package(tracker, seq, memory)
    if memory is None:
        return tracks, seconds
    return gsi(tracks, interval=memory_frames(memory, seq)), seconds


def report_tables(report: dict) -> list[dict]:
    """A ``scripts/bench_peers.py`` report's score tables: its own, then those of its ``--jitter`` copies (if
    any), each restricted to the trackers that ran on the copies."""
    jitter = report.get("jitter")
    if not jitter:
        return [report["table"]]
    return [{t: report["table"][t] for t in jitter["trackers"]}, *jitter["tables"]]


def row_machines(kept: dict) -> dict[str, str]:
    """The machine each row of a report's ``kept`` section (``bench_peers.py --keep``) was measured on; a report
    made before the rows carried their own names one machine for them all."""
    return kept.get("machines") or {row: kept["machine"] for row in kept["rows"]}
