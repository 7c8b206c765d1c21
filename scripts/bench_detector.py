#!/usr/bin/env python3
"""The built-in detector on small, far people: recall by box height against its input size and entry score.

Issue #41, item 4. The person detector (person-detection-0202, or
``--detector-model``) runs on every frame of each ``--sequences`` entry at its
default input size (:func:`sotmot.detection.openvino.input_size`: 448 x 768
for 16:9 frames, 512 x 672 for 4:3) and at that size's sides multiplied by
each ``--scales`` factor (rounded to multiples of 32): a larger input sees
small people at more pixels, at a cost in time that grows with the area.

Each ground-truth person (MOT16 layout: class 1 with its consider flag set;
2DMOT2015: every box) is matched one to one to the detections of its frame by
the Hungarian algorithm at IoU >= 0.5. Reported per sequence, input size and
entry score (``--entry``; the default 0.4 is ``[detection] min_score``, the
score below which boxes never enter tracking):

* recall of the people in three height bands, as a share of the frame's
  height: ``far`` (< 0.1), ``mid`` (0.1 to 0.25), ``near`` (>= 0.25);
* precision: detections matched to a person, or to a box the ground truth
  marks as not to be counted (distractors, static people, reflections), over
  all detections;
* milliseconds per frame of ``detect`` (resize and inference; decoding the
  frame and compiling the network for the size, once, not included).

    .venv/bin/python scripts/bench_detector.py --json docs/results/detector.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from common import DEFAULT_DATA
from sotmot.benchmarks import machine
from sotmot.boxes import iou_matrix
from sotmot.config import DetectionConfig
from sotmot.detection import make_detector
from sotmot.detection.openvino import STRIDE, input_size
from sotmot.io import FrameReader, read_ground_truth, read_seqinfo, write_text_atomic
from sotmot.progress import as_progress

#: Height bands, as a share of the frame's height: far people are below the first bound, near ones above the second.
BANDS = (("far", 0.0, 0.1), ("mid", 0.1, 0.25), ("near", 0.25, float("inf")))
#: A detection and a person are one at this IoU or more (MOTChallenge's rule).
MATCH_IOU = 0.5


def scaled(size: tuple[int, int], factor: float) -> tuple[int, int]:
    """``(height, width)`` with both sides multiplied by ``factor``, each a multiple of the network's stride."""
    return tuple(max(STRIDE, round(side * factor / STRIDE) * STRIDE) for side in size)  # type: ignore[return-value]


def detect_all(seq: Path, size: tuple[int, int], model: str | None, lowest: float,
               progress: bool) -> tuple[list[tuple[np.ndarray, np.ndarray]], float]:
    """The detector's boxes and scores (down to ``lowest``) on every frame at input ``size``; ms per frame."""
    info = read_seqinfo(seq)
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


def score(seq: Path, detections: list[tuple[np.ndarray, np.ndarray]], entry: float) -> dict[str, float]:
    """Recall per height band and precision of the detections scoring at least ``entry`` (see the docstring)."""
    info = read_seqinfo(seq)
    gt = read_ground_truth(info.gt_path, info.length)
    person = gt.consider & (gt.classes == 1)
    found = {name: [0, 0] for name, _, _ in BANDS}
    matched = total = 0
    for f, (boxes, scores) in enumerate(detections, 1):
        boxes = boxes[scores >= entry]
        rows = gt.frames == f
        people, ignored = gt.boxes[rows & person], gt.boxes[rows & ~person]
        hit = np.zeros(len(people), bool)
        used = np.zeros(len(boxes), bool)
        if len(people) and len(boxes):
            iou = iou_matrix(people, boxes)
            r, c = linear_sum_assignment(-iou)
            ok = iou[r, c] >= MATCH_IOU
            hit[r[ok]] = True
            used[c[ok]] = True
        if len(ignored) and (~used).any():  # a detection on a box not to be counted is not a false one
            used[~used] = iou_matrix(boxes[~used], ignored).max(axis=1) >= MATCH_IOU
        share = people[:, 3] / info.height
        for name, low, high in BANDS:
            band = (share >= low) & (share < high)
            found[name][0] += int(hit[band].sum())
            found[name][1] += int(band.sum())
        matched += int(used.sum())
        total += len(boxes)
    out: dict[str, float | None] = {f"recall_{name}": (100.0 * k / n if n else None) for name, (k, n) in found.items()}
    out.update({f"people_{name}": n for name, (_, n) in found.items()})
    out["recall"] = 100.0 * sum(k for k, _ in found.values()) / max(1, sum(n for _, n in found.values()))
    out["precision"] = 100.0 * matched / total if total else None
    out["detections"] = total
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--sequences", default="MOT16-09,PETS09-S2L1,MOT16-05-clip30,MOT16-10-clip30,MOT16-13-clip30",
                        help="sequence folders with ground truth, comma-separated (default: %(default)s)")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="the detector (default: the bundled person-detection-0202)")
    parser.add_argument("--scales", default="1,1.25,1.5",
                        help="input sides as multiples of the default size, comma-separated (default: %(default)s)")
    parser.add_argument("--entry", default="0.4,0.1",
                        help="entry scores to report, comma-separated (default: %(default)s; 0.4 is [detection] "
                             "min_score)")
    parser.add_argument("--json", type=Path, help="write every number here")
    args = parser.parse_args(argv)
    entries = [float(e) for e in args.entry.split(",")]
    report: dict[str, dict] = {}
    for name in [n for n in args.sequences.split(",") if n]:
        seq = args.data / name
        info = read_seqinfo(seq)
        default = input_size(info.width, info.height)
        report[name] = {"width": info.width, "height": info.height, "frames": info.length, "runs": {}}
        for factor in (float(s) for s in args.scales.split(",")):
            size = scaled(default, factor)
            detections, ms = detect_all(seq, size, args.detector_model, min(entries), sys.stderr.isatty())
            report[name]["runs"][f"{size[0]}x{size[1]}"] = {
                "scale": factor, "ms_per_frame": ms, "entry": {f"{e:g}": score(seq, detections, e) for e in entries}}
    print(f"machine: {machine()}")
    print(f"{'sequence':<16} {'input':>9} {'ms/frame':>9} {'entry':>6} {'far':>6} {'mid':>6} {'near':>6} "
          f"{'recall':>7} {'prec.':>6}")
    for name, r in report.items():
        for size, run in r["runs"].items():
            for e, s in run["entry"].items():
                shown = [f"{s[k]:>{w}.1f}" if s[k] is not None else f"{'-':>{w}}" for k, w in
                         (("recall_far", 6), ("recall_mid", 6), ("recall_near", 6), ("recall", 7), ("precision", 6))]
                print(f"{name:<16} {size:>9} {run['ms_per_frame']:>9.1f} {e:>6} " + " ".join(shown))
        people = next(iter(r["runs"].values()))["entry"][f"{entries[0]:g}"]
        print(f"{'':<16} people (box-frames): far {people['people_far']}, mid {people['people_mid']}, "
              f"near {people['people_near']}")
    if args.json:
        data = {"machine": machine(), "detector": args.detector_model or "bundled",
                "bands": [[n, lo, hi if hi < 1e9 else None] for n, lo, hi in BANDS], "match_iou": MATCH_IOU,
                "sequences": report}
        write_text_atomic(args.json, json.dumps(data, allow_nan=False, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
