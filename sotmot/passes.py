"""One pass over a sequence's frames: each frame decoded once, its boxes found (read or detected) and embedded.

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from contextlib import closing

import numpy as np

from sotmot.appearance import Embedder
from sotmot.io import FrameReader, SeqInfo
from sotmot.progress import Progress, as_progress
from sotmot.types import Detections


#: Frames the appearance stage searches (detects) and crops ahead of the one the model embeds; decoding runs one
#: frame ahead of the search.
PREFETCH_FRAMES = 8


def embed_detections(info: SeqInfo, detections: Detections, embedder: Embedder,
                     progress: "bool | Progress" = False, timings: dict[str, float] | None = None,
                     tap: Callable[[int, np.ndarray, object], None] | None = None) -> np.ndarray:
    """Appearance features ``(N, D)`` of every detection (see :func:`frame_pass` for how frames are read); an
    embedder of no features (``dim == 0``, the motion-only mode) reads no frame. The pass reads the frames that
    have detections, and with a ``tap`` every frame (it sees each, with the frame's boxes)."""
    features = np.zeros((len(detections), embedder.dim), dtype=np.float32)
    if embedder.dim == 0:
        return features
    per_frame = detections.by_frame()
    none = np.zeros(0, np.int64)
    frames = sorted(per_frame) if tap is None else list(range(1, info.length + 1))
    passed = frame_pass(info, frames, lambda frame, image: detections.boxes[per_frame.get(frame, none)],
                        embedder, f"{info.name}: appearance", progress, timings, tap)
    for frame, _, feats in passed:
        if frame in per_frame:
            features[per_frame[frame]] = feats
    return features


def frame_pass(info: SeqInfo, frames: list[int], boxes_of: Callable[[int, np.ndarray], object],
               embedder: Embedder | None, desc: str, progress: "bool | Progress" = False,
               timings: dict[str, float] | None = None,
               tap: Callable[[int, np.ndarray, object], None] | None = None) -> list[tuple[int, object, np.ndarray]]:
    """Read each of ``frames`` once, find its boxes and embed them: ``[(frame, found, features), ...]``.

    ``boxes_of(frame, image)`` gives the frame's boxes: an ``(N, 4)`` array,
    or ``(boxes, scores)`` from a detector (whose call is timed as
    ``"detect"``); ``embedder`` None skips the embedding (features
    ``(N, 0)``). Three threads share the work, each releasing the GIL in its
    native code: one decodes frames (one frame ahead of the search: the
    reader's own, :class:`~sotmot.io.FrameReader` made to decode ``ahead``), one
    searches them (the detector) and, for the crop-based backends (onnx and
    openvino), crops the boxes, :data:`PREFETCH_FRAMES` frames ahead of the
    caller's thread, which embeds. So on two cores decoding, detection and
    re-ID overlap (docs/benchmarks.md, "Speed"). The crop-based backends get the crops of
    several frames in one call that fills about one forward pass
    (``batch_size`` rows; with the flip a crop is two rows): a frame holds a
    few boxes, and small batches waste the runtime's time; other embedders
    are called once per frame. ``timings``, when given, receives ``"decode"``
    (the seconds spent reading and cropping frames), ``"detect"`` and
    ``"motion_in_pass"`` (the ``tap``'s), all overlapped with the embedding,
    so part of, not added to, the stage's wall time. ``tap(frame, image,
    found)``, when given, sees each frame once its boxes are found, in the
    order of ``frames`` (in the thread that searches them; a later stage
    measures what it needs there instead of decoding the frame again:
    :class:`sotmot.motion.PassMotion`).
    """
    from concurrent.futures import ThreadPoolExecutor

    from sotmot.appearance.base import CropEmbedder, crop_boxes

    frame_reader = FrameReader(info, cache_size=1, ahead=True)  # called from the finding thread only
    spent = {"detect": 0.0, "crop": 0.0, "motion_in_pass": 0.0}  # each key written by one thread
    batched = isinstance(embedder, CropEmbedder)
    per_call = max(1, embedder.batch_size // (2 if embedder.flip else 1)) if batched else 1  # crops: one forward pass
    out: list[tuple[int, object, np.ndarray]] = []

    def find(k: int) -> tuple[np.ndarray, object, np.ndarray]:
        for ahead in frames[k:k + 2]:  # the next frame decodes while this one is searched: two held, not eight
            frame_reader.prefetch(ahead)
        frame = frames[k]
        image = frame_reader(frame)
        start = time.perf_counter()
        found = boxes_of(frame, image)
        boxes = found[0] if isinstance(found, tuple) else found
        spent["detect" if isinstance(found, tuple) else "crop"] += time.perf_counter() - start
        if tap is not None:
            start = time.perf_counter()
            tap(frame, image, found)
            spent["motion_in_pass"] += time.perf_counter() - start
        start = time.perf_counter()
        if batched:
            image = crop_boxes(image, boxes)
        spent["crop"] += time.perf_counter() - start
        return boxes, found, image

    pending: list[tuple[int, np.ndarray]] = []  # (index into out, crops) not embedded yet

    def flush() -> None:
        sizes = [len(c) for _, c in pending]
        if sum(sizes):
            feats = embedder.embed_crops(np.concatenate([c for _, c in pending]))
            for (k, _), part in zip(pending, np.split(feats, np.cumsum(sizes)[:-1])):
                out[k] = (out[k][0], out[k][1], part)
        pending.clear()

    with closing(frame_reader), ThreadPoolExecutor(max_workers=1, thread_name_prefix="sotmot-find") as finding:
        # a few frames ahead: one call of the model consumes several frames' crops at once; each frame is decoded
        # in one thread, then searched (detected) and cropped in the next
        upcoming = deque(finding.submit(find, k) for k in range(min(PREFETCH_FRAMES, len(frames))))
        for k, frame in enumerate(as_progress(progress)(frames, desc, len(frames))):
            boxes, found, item = upcoming.popleft().result()
            if k + PREFETCH_FRAMES < len(frames):
                upcoming.append(finding.submit(find, k + PREFETCH_FRAMES))
            out.append((frame, found, np.zeros((len(boxes), embedder.dim if embedder else 0), np.float32)))
            if embedder is None:
                continue
            if not batched:
                out[-1] = (frame, found, embedder.embed(item, boxes))
                continue
            pending.append((len(out) - 1, item))
            if sum(len(c) for _, c in pending) >= per_call or k + 1 == len(frames):
                flush()
    if timings is not None:
        spent["decode"] = frame_reader.decode_seconds + spent.pop("crop")
        for stage, seconds in spent.items():
            if seconds:
                timings[stage] = timings.get(stage, 0.0) + seconds
    return out


def detect_sequence(info: SeqInfo, detector, embedder: Embedder | None = None, progress: "bool | Progress" = False,
                    timings: dict[str, float] | None = None,
                    weak: dict[int, tuple[np.ndarray, np.ndarray]] | None = None,
                    min_score: float | None = None,
                    tap: Callable[[int, np.ndarray, object], None] | None = None) -> tuple[Detections, np.ndarray]:
    """Run ``detector`` on every frame: the detections in canonical order and, with ``embedder``, their features
    from the same decoded frames (``(N, D)``; ``(N, 0)`` without); ``tap`` sees each frame and the boxes found
    in it, ``(boxes, scores)`` (:func:`frame_pass`).

    ``min_score``, when given, keeps only boxes scoring at least this as the
    detections (and embeds only those); ``weak``, when given, receives every
    box the detector returned, frame -> (``(K, 4)`` ``x, y, w, h``, ``(K,)``
    scores): run at a lower threshold, one pass gives both the tracked boxes
    and the weak boxes that check the SOT step
    (:class:`sotmot.sot.support.DetectorSupport`).
    """
    def boxes_of(frame: int, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        boxes, scores = detector.detect(image)
        if weak is not None:
            weak[frame] = (np.asarray(boxes, dtype=np.float64).reshape(-1, 4), np.asarray(scores, np.float64))
        if min_score is None:
            return boxes, scores
        keep = np.asarray(scores) >= min_score
        return boxes[keep], scores[keep]

    passed = frame_pass(info, list(range(1, info.length + 1)), boxes_of, embedder, f"{info.name}: detection",
                        progress, timings, tap)
    dim = embedder.dim if embedder is not None else 0
    frames = np.concatenate([np.full(len(found[0]), frame, np.int64) for frame, found, _ in passed] or [[]])
    raw = Detections(frames, np.concatenate([found[0] for _, found, _ in passed] or [np.zeros((0, 4))]),
                     np.concatenate([found[1] for _, found, _ in passed] or [[]]))
    features = np.concatenate([f for *_, f in passed] or [np.zeros((0, dim), np.float32)]).reshape(len(raw), dim)
    order = raw.canonical_order()
    return raw.subset(order), features[order]
