#!/usr/bin/env python3
"""Where the tracker's misses lie, and what evidence there is in their frames: the ceiling on what SOT can add.

Tracks every full-length sequence with the configuration given (by default
the defaults, as ``sotmot track`` runs them; public: each ``det/det.txt``,
``--private``: the person detector's boxes) and sorts every miss (a
ground-truth box TrackEval's CLEAR matching leaves unmatched, the FN column)
two ways.

Where it lies in its person's tracked life (:meth:`FrameErrors.miss_positions`):

* ``gap``: between two frames where the person is matched to one trajectory,
  inside it (interpolation, gap refinement or Algorithm 1 could reach it);
* ``link``: between two frames where the person is matched to two different
  trajectories association did not join (extending either could reach it);
* ``end<=E``: before the person's first or after their last matched frame, at
  most ``[ends] seconds`` away (the default end extension's reach);
* ``end<=L``: further, within ``[association] l_max_seconds`` (a longer
  extension could reach it);
* ``end>L``: further still;
* ``never``: a person no trajectory ever matches; under the public protocol
  only a trajectory started from the given detections may reach them.

What the frame holds there (a box at IoU >= 0.5 with the missed one that no
other person's ground truth overlaps more: in a crowd the box of the person in
front covers the one behind too; the first that applies):

* ``input``: a box the tracker was given (public: ``det/det.txt`` at any
  score; private: the detector's boxes at ``[detection] min_score``): the
  person was detected, and cleaning, association or confirmation lost them;
* ``weak``: a detector box scoring at least the weak boxes' 0.1
  (:data:`sotmot.sot.support.WEAK_MIN_SCORE`: what SOT checked by the
  detector, and the weak-box ends, can use);
* ``faint``: a detector box scoring at least ``--faint`` (0.05) but less;
* ``none``: no detector box; only SOT's own template and re-ID evidence could
  find the person.

Two more counts per position: ``placed``, misses with an output box over them
at IoU in [0.3, 0.5) (the tracker is there but misplaced: box regression could
turn the pair FP + FN into one TP), and ``hidden``, misses of ground truth less
than 25 % visible (MOT16/17 ground truth only; 2DMOT2015's has no visibility).

The ceiling line adds the misses that extending or regressing existing
trajectories onto detector evidence could reach (every position but
``never``, with ``input`` or ``weak`` evidence), as a share of FN: an upper bound for
"SOT checked by the detector", since each of those boxes must also be found,
accepted and matched.

    python scripts/miss_analysis.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --detector-model ../shared/models/person-detection-0202/person-detection-0202.FP16-INT8.xml \\
        [--private] --json docs/results/misses_public.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA, named_sequences
from sotmot.appearance import make_embedder
from sotmot.benchmarks import model_detections, private_config
from sotmot.boxes import iou_matrix
from sotmot.config import TrackerConfig, load_config
from sotmot.scoring import evaluate_files, frame_errors
from sotmot.io import read_detections, read_ground_truth, read_seqinfo, results_path, write_results
from sotmot.io import write_text_atomic
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.sot.support import WEAK_MIN_SCORE
from sotmot.versions import machine

EVIDENCE = ("input", "weak", "faint", "none")
POSITIONS = ("gap", "link", "end<=E", "end<=L", "end>L", "never")
COLUMNS = (*EVIDENCE, "placed", "hidden")


def by_frame(frames: np.ndarray, boxes: np.ndarray, scores: np.ndarray | None = None) -> dict[int, tuple]:
    """Frame -> (boxes, scores) of those rows."""
    out = {}
    for f in np.unique(frames):
        rows = frames == f
        out[int(f)] = (boxes[rows], None if scores is None else scores[rows])
    return out


def covering(box: np.ndarray, boxes: np.ndarray, people: np.ndarray) -> np.ndarray:
    """Which of ``boxes`` cover the ground-truth ``box``: IoU >= 0.5 with it, and no other person of the frame
    (``people``, its ground-truth boxes, ``box`` among them) overlaps them more. In a crowd the box of the person
    in front often overlaps the one behind at 0.5 too; it is evidence for the one in front only."""
    own = iou_matrix(box, boxes)[0]
    others = people[iou_matrix(box, people)[0] < 1.0 - 1e-9]
    rival = iou_matrix(boxes, others).max(axis=1) if len(others) else np.zeros(len(boxes))
    return (own >= 0.5) & (own >= rival)


def classify(errors, tracker_input: dict, detector: dict, people: dict, frame_rate: float,
             extend_seconds: float, gap_seconds: float, weak_score: float) -> dict:
    """Counts of misses per position and evidence, plus ``placed`` and ``hidden`` per position (see the module
    docstring). ``tracker_input`` and ``detector`` map a frame to (boxes, scores); ``people`` maps a frame to
    (the considered pedestrians' ground-truth boxes, their visible fraction)."""
    counts = {p: dict.fromkeys(COLUMNS, 0) for p in POSITIONS}
    empty = (np.zeros((0, 4)), np.zeros(0))
    positions = errors.miss_positions()
    for frame, boxes in errors.misses.items():
        placed = np.array([b for b, _ in errors.false_positives.get(frame, [])]).reshape(-1, 4)
        gt_boxes, visible = people.get(frame, empty)
        for box, (where, distance) in zip(boxes, positions[frame]):
            box = np.asarray(box, dtype=np.float64)
            if where == "end":
                seconds = distance / frame_rate
                where = "end<=E" if seconds <= extend_seconds else "end<=L" if seconds <= gap_seconds else "end>L"
            found, scores = detector.get(frame, empty)
            mine = covering(box, found, gt_boxes)
            if covering(box, tracker_input.get(frame, empty)[0], gt_boxes).any():
                evidence = "input"
            elif (scores[mine] >= weak_score).any():
                evidence = "weak"
            elif mine.any():
                evidence = "faint"
            else:
                evidence = "none"
            row = counts[where]
            row[evidence] += 1
            row["placed"] += int((iou_matrix(box, placed)[0] >= 0.3).any())
            same = iou_matrix(box, gt_boxes)[0]
            row["hidden"] += int(len(same) > 0 and visible[int(np.argmax(same))] < 0.25)
    return counts


def missed(row: dict) -> int:
    """The misses one position holds (each has one evidence class)."""
    return sum(row[e] for e in EVIDENCE)


def reachable(counts: dict) -> int:
    """Misses inside or beyond a trajectory that exists, with a detector box (given or weak) over them."""
    return sum(counts[p]["input"] + counts[p]["weak"] for p in POSITIONS if p != "never")


def combine(per_sequence: dict[str, dict]) -> dict:
    """Cell-wise sum of :func:`classify` counts."""
    out = {p: dict.fromkeys(COLUMNS, 0) for p in POSITIONS}
    for counts in per_sequence.values():
        for p in POSITIONS:
            for k in out[p]:
                out[p][k] += counts[p][k]
    return out


def table(counts: dict, extend_seconds: float, gap_seconds: float) -> list[str]:
    """The position x evidence table of one set of counts."""
    total = sum(missed(counts[p]) for p in POSITIONS)
    head = f"{'position':<14}{'FN':>7}{'share':>8}" + "".join(f"{k:>8}" for k in COLUMNS)
    lines = [head, "-" * len(head)]
    names = {"end<=E": f"end<={extend_seconds:g}s", "end<=L": f"end<={gap_seconds:g}s", "end>L": f"end>{gap_seconds:g}s"}
    for p in POSITIONS:
        n = missed(counts[p])
        lines.append(f"{names.get(p, p):<14}{n:>7}{100 * n / max(total, 1):>7.1f}%"
                     + "".join(f"{counts[p][k]:>8}" for k in COLUMNS))
    lines.append(f"{'all':<14}{total:>7}{100.0 if total else 0:>7.1f}%"
                 + "".join(f"{sum(counts[p][k] for p in POSITIONS):>8}" for k in COLUMNS))
    lines.append(f"ceiling for SOT checked by the detector (misses of tracked people under an input or weak box): "
                 f"{reachable(counts)} of {total} FN ({100 * reachable(counts) / max(total, 1):.1f} %)")
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX or OpenVINO re-ID model")
    parser.add_argument("--detector-model", required=True, metavar="PATH.xml",
                        help="the person detector whose weak boxes are the evidence (and, with --private, the "
                             "tracking input)")
    parser.add_argument("--private", action="store_true",
                        help="track the detector's boxes (MOTChallenge's private detections) instead of det/det.txt")
    parser.add_argument("--config", type=Path, help="tracker configuration file (default: the defaults)")
    parser.add_argument("--faint", type=float, default=0.05,
                        help="the lowest detector score counted as evidence (default: %(default)s)")
    parser.add_argument("--det-cache", type=Path, default=Path(".cache/detections"),
                        help="where the detector's boxes are kept between runs (default: %(default)s)")
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--min-length", type=int, default=100,
                        help="only sequences of at least this many frames: the full-length ones (default: "
                             "%(default)s; 0 takes the 30-frame clips too)")
    parser.add_argument("--json", type=Path, help="write the counts here")
    args = parser.parse_args(argv)

    config = (load_config(args.config) if args.config else TrackerConfig()).replace("appearance", model=args.model)
    detector_model = str(Path(args.detector_model).resolve())
    embedder = make_embedder(config.appearance)
    seqs = [s for s in named_sequences(parser, args.data, args.sequences) if read_seqinfo(s).length >= args.min_length]
    if args.private:  # one run per video: the MOT17-09-* sequences repeat MOT16-09's frames
        seqs = [s for s in seqs if not s.name.startswith("MOT17-09-")]
    if not seqs:
        print(f"no sequences of at least {args.min_length} frames with frames under {args.data}", file=sys.stderr)
        return 1
    faint_config = config.replace("detection", model=detector_model, min_score=args.faint)
    per_sequence: dict[str, dict] = {}
    pairs = []
    with tempfile.TemporaryDirectory(prefix="sotmot-misses-") as tmp:
        for seq in seqs:
            info = read_seqinfo(seq)
            seq_config = private_config(config, seq, detector_model, args.det_cache) if args.private else config
            result = finish_sequence(prepare_sequence(seq, seq_config, embedder, progress=sys.stderr.isatty()),
                                     seq_config, embedder)
            path = results_path(Path(tmp), info.name)
            write_results(path, result.tracks)
            pairs.append((path, info.gt_path, info.length, info.name))
            given = read_detections(seq_config.detection.file if args.private else info.det_path, info.length)
            found = read_detections(model_detections(seq, faint_config, args.det_cache), info.length)
            gt = read_ground_truth(info.gt_path, info.length).pedestrians()
            frame_rate = info.frame_rate
            association = seq_config.association.at(frame_rate)
            per_sequence[info.name] = classify(
                frame_errors(path, info.gt_path, info.length, info.name),
                by_frame(given.frames, given.boxes, given.scores), by_frame(found.frames, found.boxes, found.scores),
                by_frame(gt.frames, gt.boxes, gt.visibility), frame_rate, seq_config.ends.seconds,
                association.l_max / frame_rate, WEAK_MIN_SCORE)
            print(f"{info.name}: {sum(missed(per_sequence[info.name][p]) for p in POSITIONS)} misses", file=sys.stderr)
        report = evaluate_files(pairs)
    extend_seconds = config.ends.seconds
    gap_seconds = config.association.l_max_seconds or float("nan")
    kind = ("private detections: the boxes of " + Path(args.detector_model).name if args.private
            else "public detections: each sequence's det/det.txt")
    combined = combine(per_sequence)
    lines = [f"{kind}; combined over {', '.join(per_sequence)}"] + table(combined, extend_seconds, gap_seconds)
    for name, counts in per_sequence.items():
        lines += ["", name] + table(counts, extend_seconds, gap_seconds)
    lines += ["", f"evidence: detector {Path(args.detector_model).name}, boxes from score {args.faint:g} ('faint'), "
              f"'weak' from {WEAK_MIN_SCORE:g}; machine: {machine()}"]
    print("\n".join(lines))
    if args.json:
        write_text_atomic(args.json, json.dumps({
            "machine": machine(), "detections": kind, "detector": Path(args.detector_model).name,
            "faint": args.faint, "weak": WEAK_MIN_SCORE, "extend_seconds": extend_seconds,
            "gap_seconds": gap_seconds, "config": config.to_dict(),
            "metrics": {name: {k: report.sequences[name][k] for k in ("HOTA", "MOTA", "FP", "FN")}
                        for name in per_sequence},
            "combined": combined, "sequences": per_sequence,
            "ceiling": {"combined": reachable(combined), **{n: reachable(c) for n, c in per_sequence.items()}},
        }, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
