#!/usr/bin/env python3
"""The paper's Table 3, on our data: what does the SOT step add to the MOT part?

Rows per sequence (``--rows``; default: the paper's Table 3 under both rules, with and without interpolation):
MOT only; SOT(template)+MOT and SOT(deep)+MOT with Algorithm 1 as published
(``[sot] rules = "paper"``) and with the confident rules (``"confident"``:
only extensions that reach another box, issue #12); SOT after association,
"+ends" (trajectory ends extended, ``[sot] extend_seconds`` as configured,
the default since issue #12; every other row extends nothing) and
"+gaps" (interpolated boxes replaced by boxes found in the frames, ``[sot]
refine_gaps``); every row also "no-interp", without interpolation, to see
whether SOT boxes only fill gaps that interpolation fills anyway.
Columns: TrackEval HOTA, MOTA, MOTP, IDF1, FP, FN, IDSW; frames per second of
the whole pipeline (the detections' re-ID features are computed once per
sequence and their time is added to every row); the SOT boxes in the output
(Algorithm 1's that survived NMS and confirmation, end extensions, refined
gap boxes) and their precision against the ground truth (IoU >= 0.5 with a
considered pedestrian box in that frame), in all and split into "gap" boxes
(between the first and last other box of their track) and "end" boxes.

    python scripts/ablation.py --model ../shared/models/person-reidentification-retail-0288.onnx --json ablation.json
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sotmot.appearance import make_embedder
from common import DEFAULT_DATA
from sotmot.benchmarks import machine, sequences
from sotmot.boxes import iou_matrix
from sotmot.config import TrackerConfig, load_config
from sotmot.evaluate import evaluate_files
from sotmot.io import read_detections, read_ground_truth, read_seqinfo, results_path, write_results
from sotmot.passes import embed_detections
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.preprocess import preprocess

ENDS = None  # "+ends" rows: the end extension as configured (the default's, or --config's)
ROWS = {
    "MOT": {"variant": "none"},
    # Algorithm 1 as published (``[sot] rules = "paper"``), and the confident rules (issue #12)
    "SOT(template)+MOT": {"variant": "template", "rules": "paper"},
    "SOT(template)+MOT+links": {"variant": "template", "rules": "paper", "must_link": True},
    "SOT(deep)+MOT": {"variant": "deep", "rules": "paper"},
    "SOT(template)+MOT confident": {"variant": "template", "rules": "confident"},
    "SOT(deep)+MOT confident": {"variant": "deep", "rules": "confident"},
    "SOT(template)+MOT seeds>=0.95": {"variant": "template", "rules": "paper", "seed_min_confidence": 0.95},
    "SOT(deep)+MOT seeds>=0.9": {"variant": "deep", "rules": "paper", "seed_min_confidence": 0.9},
    # SOT after association: trajectory ends, and interpolated boxes replaced by boxes found in the frames
    "MOT+ends": {"variant": "none", "extend_seconds": ENDS},
    "MOT+gaps": {"variant": "none", "refine_gaps": True},
    "MOT+ends+gaps": {"variant": "none", "extend_seconds": ENDS, "refine_gaps": True},
    "SOT(deep)+MOT+ends": {"variant": "deep", "rules": "paper", "extend_seconds": ENDS},
    "SOT(deep)+MOT confident+ends": {"variant": "deep", "rules": "confident", "extend_seconds": ENDS},
    "SOT(deep)+MOT+ends seeds>=0.9": {"variant": "deep", "rules": "paper", "seed_min_confidence": 0.9,
                                      "extend_seconds": ENDS},
}
# every row also without interpolation: does SOT fill gaps that interpolation would have filled anyway? (issue #12)
ROWS.update({f"{name} no-interp": {**spec, "postprocess": {"interpolate": False}} for name, spec in list(ROWS.items())})
#: The default rows: the paper's Table 3 (MOT, SOT(template)+MOT, SOT(deep)+MOT) under both rules, with and
#: without interpolation, and SOT after association.
TABLE3 = [r for base in ("MOT", "SOT(template)+MOT", "SOT(deep)+MOT", "SOT(template)+MOT confident",
                         "SOT(deep)+MOT confident", "MOT+ends", "MOT+gaps", "MOT+ends+gaps")
          for r in (base, f"{base} no-interp")]
COLUMNS = ("HOTA", "MOTA", "MOTP", "IDF1", "FP", "FN", "IDSW")


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
    parser.add_argument("--config", type=Path)
    parser.add_argument("--rows", default=",".join(TABLE3),
                        help="comma-separated subset of: " + ", ".join(ROWS) + " (default: the paper's Table 3 rows, "
                             "both rules, with and without interpolation)")
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    base = (load_config(args.config) if args.config else TrackerConfig()).replace("appearance", model=args.model)
    embedder = make_embedder(base.appearance)
    rows = [r for r in args.rows.split(",") if r]
    seqs = sequences(args.data, args.sequences)
    results: dict[str, dict[str, dict]] = {}
    pairs: dict[str, list] = {r: [] for r in rows}
    with tempfile.TemporaryDirectory() as tmp:
        for seq in seqs:
            info = read_seqinfo(seq)
            start = time.perf_counter()
            dets = preprocess(read_detections(info.det_path, info.length), base.preprocess)
            features = embed_detections(info, dets, embedder)
            embed_seconds = time.perf_counter() - start
            results[info.name] = {}
            for row in rows:
                spec = {"extend_seconds": 0.0, **ROWS[row]}  # rows without "+ends" extend nothing
                if spec["extend_seconds"] is ENDS:
                    spec["extend_seconds"] = base.sot.extend_seconds
                config = base.replace("sot", **{k: v for k, v in spec.items() if k != "postprocess"})
                if "postprocess" in spec:
                    config = config.replace("postprocess", **spec["postprocess"])
                start = time.perf_counter()
                prepared = prepare_sequence(seq, config, embedder, features=features)
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
                                           "sot_steps": prepared.sot_steps, "stage_seconds": run.timings}
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
        args.json.write_text(json.dumps({"machine": machine(), "config": base.to_dict(), "rows": results,
                                         "combined": combined}, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
