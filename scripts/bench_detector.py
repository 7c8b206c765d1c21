#!/usr/bin/env python3
"""The built-in detector on small, far people: recall by box height against its input size and entry score.

Issue #41, item 4. The person detector (person-detection-0202, or
``--detector-model``) runs on every frame of each ``--sequences`` entry at its
default input size (:func:`sotmot.detection.openvino.input_size`: 512 x 672
for 4:3 frames, 448 x 768 for 16:9 ones up to 1536 x 864, 544 x 960 for
1080p) and at that size's sides multiplied by
each ``--scales`` factor (rounded to multiples of 32): a larger input sees
small people at more pixels, at a cost in time that grows with the area.

Each detection is matched to the ground truth as TrackEval's CLEAR MOT
matching does (IoU >= 0.5, one to one; for MOT16-layout ground truth only the
pedestrians it counts, with detections on distractors, static people and
reflections removed). Reported per sequence, input size and
entry score (``--entry``; the default 0.4 is ``[detection] min_score``, the
score below which boxes never enter tracking):

* recall of the people in three height bands, as a share of the frame's
  height: ``far`` (< 0.1), ``mid`` (0.1 to 0.25), ``near`` (>= 0.25);
* precision: the detections that are not false ones (a detection on a box
  the ground truth does not count is not false) over all detections;
* milliseconds per frame of ``detect`` (resize and inference; decoding the
  frame and compiling the network for the size, once, not included).

    .venv/bin/python scripts/bench_detector.py --json docs/results/detector.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA
from sotmot.config import DetectionConfig
from sotmot.detection import make_detector
from sotmot.detection.openvino import STRIDE, input_size
from sotmot.fitting.confidence import clear_matching
from sotmot.io import FrameReader, SeqInfo, read_seqinfo, write_text_atomic
from sotmot.progress import as_progress
from sotmot.types import Tracks
from sotmot.versions import machine

#: Height bands, as a share of the frame's height: far people are below the first bound, near ones above the second.
BANDS = (("far", 0.0, 0.1), ("mid", 0.1, 0.25), ("near", 0.25, float("inf")))


def scaled(size: tuple[int, int], factor: float) -> tuple[int, int]:
    """``(height, width)`` with both sides multiplied by ``factor``, each a multiple of the network's stride."""
    return tuple(max(STRIDE, round(side * factor / STRIDE) * STRIDE) for side in size)  # type: ignore[return-value]


def detect_all(info: SeqInfo, size: tuple[int, int], model: str | None, lowest: float,
               progress: bool) -> tuple[list[tuple[np.ndarray, np.ndarray]], float]:
    """The detector's boxes and scores (down to ``lowest``) on every frame at input ``size``; ms per frame."""
    detector = make_detector(DetectionConfig(model=model, min_score=lowest, input_height=size[0],
                                             input_width=size[1]))
    reader = FrameReader(info, cache_size=1)
    detector.detect(reader(1))  # compiles the network for this size: not part of the time a frame costs
    out, seconds = [], 0.0
    for f in as_progress(progress)(range(1, info.length + 1), f"{info.name} {size[0]}x{size[1]}"):
        frame = reader(f)
        start = time.perf_counter()
        out.append(detector.detect(frame))
        seconds += time.perf_counter() - start
    return out, 1000.0 * seconds / info.length


def score(info: SeqInfo, detections: list[tuple[np.ndarray, np.ndarray]], entry: float,
          workdir: Path) -> tuple[dict[str, float | None], dict[str, int]]:
    """Recall per height band and precision of the detections scoring at least ``entry`` (see the docstring), and
    how many people (box-frames) each band holds.

    Each detection is written as a track of its own and matched by TrackEval's preprocessing and the CLEAR rule
    (:func:`sotmot.fitting.confidence.clear_matching`), as the confirmation fits label boxes: a detection on a box
    the ground truth does not count is removed there, so it is neither a hit nor a false one.
    """
    kept = [(f, b[s >= entry], s[s >= entry]) for f, (b, s) in enumerate(detections, 1)]
    frames = np.concatenate([np.full(len(b), f) for f, b, _ in kept]) if kept else np.zeros(0, np.int64)
    boxes = np.concatenate([b for _, b, _ in kept]).reshape(-1, 4) if kept else np.zeros((0, 4))
    scores = np.concatenate([s for _, _, s in kept]) if kept else np.zeros(0)
    errors = clear_matching(Tracks(frames, np.arange(1, len(frames) + 1), boxes, scores), info, workdir)
    hit = np.array([g[3] for rows in errors.matched.values() for g, *_ in rows]) / info.height
    missed = np.array([g[3] for rows in errors.misses.values() for g in rows]) / info.height
    false = sum(len(rows) for rows in errors.false_positives.values())
    out: dict[str, float | None] = {}
    people: dict[str, int] = {}
    for name, low, high in BANDS:
        k = int(((hit >= low) & (hit < high)).sum())
        people[name] = k + int(((missed >= low) & (missed < high)).sum())
        out[f"recall_{name}"] = 100.0 * k / people[name] if people[name] else None
    out["recall"] = 100.0 * len(hit) / max(1, len(hit) + len(missed))
    out["precision"] = 100.0 * (len(frames) - false) / len(frames) if len(frames) else None
    out["detections"] = len(frames)
    return out, people


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--sequences", default="MOT16-09,PETS09-S2L1,MOT16-05-clip30,MOT16-10-clip30,MOT16-13-clip30",
                        help="sequence folders with ground truth, comma-separated (default: %(default)s)")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="the detector (default: the bundled person-detection-0202)")
    parser.add_argument("--scales", default="0.8,1,1.25",
                        help="input sides as multiples of the default size, comma-separated (default: %(default)s; "
                             "0.8 of 1080p's 544 x 960 is the 448 x 768 it had before issue #41)")
    parser.add_argument("--entry", default="0.4,0.1",
                        help="entry scores to report, comma-separated (default: %(default)s; 0.4 is [detection] "
                             "min_score)")
    parser.add_argument("--json", type=Path, help="write every number here")
    args = parser.parse_args(argv)
    entries = [float(e) for e in args.entry.split(",")]
    report: dict[str, dict] = {}
    with tempfile.TemporaryDirectory(prefix="sotmot-detector-") as tmp:
        for name in [n for n in args.sequences.split(",") if n]:
            seq = args.data / name
            info = read_seqinfo(seq)
            default = input_size(info.width, info.height)
            report[name] = {"width": info.width, "height": info.height, "frames": info.length, "runs": {}}
            for factor in (float(s) for s in args.scales.split(",")):
                size = scaled(default, factor)
                detections, ms = detect_all(info, size, args.detector_model, min(entries), sys.stderr.isatty())
                scored = {f"{e:g}": score(info, detections, e, Path(tmp)) for e in entries}
                report[name]["people"] = next(iter(scored.values()))[1]  # the ground truth's, whatever is entered
                report[name]["runs"][f"{size[0]}x{size[1]}"] = {
                    "scale": factor, "ms_per_frame": ms, "entry": {e: metrics for e, (metrics, _) in scored.items()}}
    print(f"machine: {machine()}")
    print(f"{'sequence':<16} {'input':>9} {'ms/frame':>9} {'entry':>6} {'far':>6} {'mid':>6} {'near':>6} "
          f"{'recall':>7} {'prec.':>6}")
    for name, r in report.items():
        for size, run in r["runs"].items():
            for e, s in run["entry"].items():
                shown = [f"{s[k]:>{w}.1f}" if s[k] is not None else f"{'-':>{w}}" for k, w in
                         (("recall_far", 6), ("recall_mid", 6), ("recall_near", 6), ("recall", 7), ("precision", 6))]
                print(f"{name:<16} {size:>9} {run['ms_per_frame']:>9.1f} {e:>6} " + " ".join(shown))
        print(f"{'':<16} people (box-frames): " + ", ".join(f"{band} {n}" for band, n in r["people"].items()))
    if args.json:
        data = {"machine": machine(), "detector": args.detector_model or "bundled",
                "bands": [[n, lo, hi if hi < 1e9 else None] for n, lo, hi in BANDS],
                "sequences": report}
        write_text_atomic(args.json, json.dumps(data, allow_nan=False, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
