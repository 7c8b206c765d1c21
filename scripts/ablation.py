#!/usr/bin/env python3
"""The paper's Table 3, on our data: what does the SOT step add to the MOT part?

Rows per sequence (``--rows``; default: :data:`TABLE3`): MOT only;
SOT(template)+MOT and SOT(deep)+MOT with Algorithm 1 as published; the same
checked by the person detector's weak boxes ("verified", ``[detection]
weak_boxes = "on"``, issue #25: each SOT box regressed onto a detector box
scoring at least 0.1, and an extension ends where none supports it, the
paper's box regression on SOT results); after association, "+ends"
(trajectory ends extended by SOT, ``[ends] seconds`` as configured; every other
row extends nothing) and "+weak ends" (by the detector's weak boxes, no SOT:
ByteTrack's second association at trajectory ends); every row also
"no-interp", without interpolation, to see whether SOT boxes only fill gaps
that interpolation fills anyway. A row without "verified" or "weak" runs with
the weak boxes off, under both protocols.

    python scripts/ablation.py --model ../shared/models/person-reidentification-retail-0288.onnx \
        --detector-model ../shared/models/person-detection-0202/person-detection-0202.FP16-INT8.xml \
        [--private] --json ablation.json
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sotmot.appearance import make_embedder
from common import DEFAULT_DATA, named_sequences
from sotmot.boxes import iou_matrix
from sotmot.config import TrackerConfig, load_config
from sotmot.scoring import evaluate_files
from sotmot.io import read_ground_truth, read_seqinfo, results_path, write_results, write_text_atomic
from sotmot.detection import make_detector
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.plan import resolve
from sotmot.versions import machine

ENDS = None  # "+ends" rows: the end extension as configured (the default's, or --config's)
OFF = {"detection": {"weak_boxes": "off"}}  # no weak boxes (the default, "auto", uses them in private runs)
WEAK = {"detection": {"weak_boxes": "on"}}
ROWS: dict[str, dict] = {
    "MOT": {"sot": {"variant": "none"}, **OFF},
    # Algorithm 1 as published, alone and checked by the weak boxes (issue #25)
    "SOT(template)+MOT": {"sot": {"variant": "template"}, **OFF},
    "SOT(deep)+MOT": {"sot": {"variant": "deep"}, **OFF},
    "SOT(template)+MOT verified": {"sot": {"variant": "template"}, **WEAK},
    "SOT(deep)+MOT verified": {"sot": {"variant": "deep"}, **WEAK},
    # after association: trajectory ends, by SOT or by the weak boxes
    "MOT+ends": {"sot": {"variant": "none"}, "ends": {"seconds": ENDS}, **OFF},
    "MOT+weak ends": {"sot": {"variant": "none"}, "ends": {"seconds": ENDS}, **WEAK},
    "SOT(deep)+MOT+ends": {"sot": {"variant": "deep"}, "ends": {"seconds": ENDS}, **OFF},
    "SOT(deep)+MOT verified+weak ends": {"sot": {"variant": "deep"}, "ends": {"seconds": ENDS}, **WEAK},
}
# every row also without interpolation: does SOT fill gaps that interpolation would have filled anyway? (issue #12)
ROWS.update({f"{name} no-interp": {**spec, "postprocess": {"interpolate": False}} for name, spec in list(ROWS.items())})


def row_config(base: TrackerConfig, row: str) -> TrackerConfig:
    """``base`` with the sections ``row`` sets; a row without "+ends" extends nothing, "+ends" as ``base`` does."""
    config = base.replace("ends", seconds=0.0)
    for section, fields in ROWS[row].items():
        config = config.replace(section, **{k: base.ends.seconds if v is ENDS else v for k, v in fields.items()})
    return config


#: The default rows: the paper's Table 3 (MOT, SOT(template)+MOT, SOT(deep)+MOT), unchecked and checked by the
#: weak boxes, the trajectory ends by SOT and by the weak boxes, and both checked.
TABLE3 = ["MOT", "SOT(template)+MOT", "SOT(deep)+MOT", "SOT(template)+MOT verified", "SOT(deep)+MOT verified",
          "MOT+ends", "MOT+weak ends", "SOT(deep)+MOT verified+weak ends"]
#: The rows without the detector (all of them before issue #25).
UNCHECKED = [r for r in ROWS if ROWS[r]["detection"]["weak_boxes"] != "on"]
COLUMNS = ("HOTA", "MOTA", "MOTP", "IDF1", "FP", "FN", "IDSW")


class CachedDetector:
    """A detector that remembers what it found in each image (by content), so every row of one sequence sees the
    detections of one pass; ``min_score`` is the inner detector's (the pipeline splits tracked and weak boxes)."""

    def __init__(self, detector) -> None:
        self.detector, self.min_score = detector, detector.min_score
        self.found: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def detect(self, image: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = hashlib.blake2b(np.ascontiguousarray(image).data, digest_size=16).digest()
        if key not in self.found:
            self.found[key] = self.detector.detect(image)
        return self.found[key]


def added_boxes(run) -> dict[str, tuple[int, float]]:
    """SOT boxes in the output and the fraction that hit a ground-truth pedestrian (IoU >= 0.5), in all and
    split by where they lie: ``gap`` between the first and last other box of their track, ``end`` before or
    after them (only SOT reaches there)."""
    t = run.tracks
    gt = read_ground_truth(run.info.gt_path, run.info.length).pedestrians()
    where = {"all": [], "gap": [], "end": []}
    for track_id in np.unique(t.ids[t.from_sot]):
        rows = np.flatnonzero(t.ids == track_id)
        anchored = t.frames[rows[~t.from_sot[rows]]]
        for i in rows[t.from_sot[rows]]:
            g = gt.boxes[gt.frames == t.frames[i]]
            hit = bool(len(g)) and iou_matrix(t.boxes[i], g).max() >= 0.5
            inside = len(anchored) and anchored.min() < t.frames[i] < anchored.max()
            where["all"].append(hit)
            where["gap" if inside else "end"].append(hit)
    return {k: (len(v), float(np.mean(v)) if v else float("nan")) for k, v in where.items()}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--model", required=True)
    parser.add_argument("--detector-model",
                        help="the person detector: checks SOT boxes in the 'verified' and 'weak' rows; with --private "
                             "its boxes are the tracking input")
    parser.add_argument("--private", action="store_true",
                        help="track the detector's boxes (MOTChallenge's private detections) instead of det/det.txt")
    parser.add_argument("--config", type=Path)
    parser.add_argument("--rows", default=None,
                        help="comma-separated subset of: " + ", ".join(ROWS) + " (default: the paper's Table 3 rows, "
                             "checked by the weak boxes or not, and the trajectory ends; without "
                             "--detector-model only the unchecked ones)")
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--min-length", type=int, default=100,
                        help="only sequences of at least this many frames: the full-length ones (default: "
                             "%(default)s; 0 takes the 30-frame clips too)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    rows = [r for r in (args.rows or ",".join(TABLE3 if args.detector_model else [r for r in TABLE3 if r in UNCHECKED]))
            .split(",") if r]
    unknown = [r for r in rows if r not in ROWS]
    if unknown:
        parser.error(f"unknown rows: {', '.join(unknown)}")
    if not args.detector_model and (args.private or any(r not in UNCHECKED for r in rows)):
        parser.error("--private and the rows the detector checks need --detector-model")
    base = (load_config(args.config) if args.config else TrackerConfig()).replace("appearance", model=args.model)
    if args.detector_model:
        base = base.replace("detection", model=str(Path(args.detector_model).resolve()),
                            source="model" if args.private else base.detection.source)
    embedder = make_embedder(base.appearance)
    seqs = [s for s in named_sequences(parser, args.data, args.sequences) if read_seqinfo(s).length >= args.min_length]
    if args.private:  # one run per video: the MOT17-09-* sequences repeat MOT16-09's frames
        seqs = [s for s in seqs if not (s.name.startswith("MOT17-09-"))]
    results: dict[str, dict[str, dict]] = {}
    pairs: dict[str, list] = {r: [] for r in rows}
    with tempfile.TemporaryDirectory() as tmp:
        for seq in seqs:
            info = read_seqinfo(seq)
            detector = None
            if args.detector_model:  # one detector per sequence, at the weak boxes' threshold, for every row
                detector = CachedDetector(make_detector(resolve(row_config(base, "MOT+weak ends"), info).weak_detector))
            start = time.perf_counter()
            # the re-ID features (and the detections) of the rows without SOT: computed once, shared by every row
            features = prepare_sequence(seq, row_config(base, "MOT"), embedder, detector=detector).features
            embed_seconds = time.perf_counter() - start
            results[info.name] = {}
            for row in rows:
                config = row_config(base, row)
                start = time.perf_counter()
                prepared = prepare_sequence(seq, config, embedder, detector=detector,
                                            features=None if config.sot.variant != "none" else features)
                run = finish_sequence(prepared, config, embedder=embedder)
                seconds = time.perf_counter() - start + embed_seconds
                path = results_path(Path(tmp) / row, info.name)
                write_results(path, run.tracks)
                pairs[row].append((path, info.gt_path, info.length, info.name))
                added = added_boxes(run)
                results[info.name][row] = {"fps": info.length / seconds, "seconds": seconds,
                                           "added": added["all"][0], "added_precision": added["all"][1],
                                           "gap": added["gap"][0], "gap_precision": added["gap"][1],
                                           "end": added["end"][0], "end_precision": added["end"][1],
                                           "sot_steps": prepared.sot_steps,
                                           "sot_boxes": int(prepared.detections.from_sot.sum()),
                                           "stage_seconds": run.timings}
                print(f"{info.name} {row}: {info.length / seconds:.1f} fps, {added['all'][0]} added", file=sys.stderr)
        combined: dict[str, dict] = {}
        for row in rows:
            report = evaluate_files(pairs[row])
            for name, scores in report.sequences.items():
                results[name][row].update(scores)
            combined[row] = dict(report.combined)
            frames = sum(p[2] for p in pairs[row])
            combined[row]["fps"] = frames / sum(results[p[3]][row]["seconds"] for p in pairs[row])
            for kind in ("added", "gap", "end"):
                per_seq = [results[p[3]][row] for p in pairs[row]]
                n = sum(v[kind] for v in per_seq)
                hits = sum(v[kind] * v[f"{kind}_precision"] for v in per_seq if v[kind])
                combined[row][kind] = n
                combined[row][f"{kind}_precision"] = hits / n if n else float("nan")
    head = (f"{'sequence':<17}{'row':<40}" + "".join(f"{c:>7}" for c in COLUMNS)
            + "".join(f"{c:>7}" for c in ("fps", "added", "prec", "gap", "prec", "end", "prec")))
    lines = [head, "-" * len(head)]
    for name, by_row in list(results.items()) + [("ALL", combined)]:
        for row in rows:
            v = by_row[row]
            cells = "".join(f"{v[c]:7.1f}" if c in ("HOTA", "MOTA", "MOTP", "IDF1") else f"{v[c]:7.0f}"
                            for c in COLUMNS)
            cells += "".join(f"{v[k]:7d}{v[f'{k}_precision']:7.2f}".replace("    nan", "      –")
                             for k in ("added", "gap", "end"))
            lines.append(f"{name:<17}{row:<40}{cells[:7 * len(COLUMNS)]}{v['fps']:7.1f}{cells[7 * len(COLUMNS):]}")
    print("\n".join(lines))
    print(f"machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "config": base.to_dict(),
                                                 "private": args.private, "detector_model": args.detector_model,
                                                 "rows": results, "combined": combined}, indent=2, default=float)
                          + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
