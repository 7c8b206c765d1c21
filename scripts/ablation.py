#!/usr/bin/env python3
"""The paper's Table 3, on our data: what does the SOT step add to the MOT part?

Rows per sequence: MOT only, SOT(template)+MOT, SOT(template)+MOT with the SOT
links as must-link hints, SOT(deep)+MOT, and with "+ends" the extension of the
confirmed trajectories' ends after association (``[sot] extend_seconds = 0.5``);
"no-interp" rows turn interpolation off, to see whether SOT boxes only fill
gaps that interpolation fills anyway.
Columns: TrackEval HOTA, MOTA, MOTP, IDF1, FP, FN, IDSW; frames per second of
the whole pipeline (the detections' re-ID features are computed once per
sequence and their time is added to every row); the SOT boxes in the output
(Algorithm 1's that survived NMS and confirmation, plus end extensions) and
their precision against the ground truth (IoU >= 0.5 with a considered
pedestrian box in that frame).

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
from sotmot.benchmarks import DEFAULT_DATA, machine, sequences
from sotmot.boxes import iou_matrix
from sotmot.config import TrackerConfig, load_config
from sotmot.evaluate import evaluate_files
from sotmot.io import read_detections, read_ground_truth, read_seqinfo, results_path, write_results
from sotmot.pipeline import embed_detections, finish_sequence, preprocess, prepare_sequence

ROWS = {
    "MOT": {"variant": "none"},
    "SOT(template)+MOT": {"variant": "template"},
    "SOT(template)+MOT+links": {"variant": "template", "must_link": True},
    "SOT(deep)+MOT": {"variant": "deep"},
    "MOT+ends": {"variant": "none", "extend_seconds": 0.5},
    "SOT(deep)+MOT+ends": {"variant": "deep", "extend_seconds": 0.5},
    "SOT(template)+MOT seeds>=0.95": {"variant": "template", "seed_min_confidence": 0.95},
    "SOT(deep)+MOT seeds>=0.9": {"variant": "deep", "seed_min_confidence": 0.9},
    "SOT(deep)+MOT+ends seeds>=0.9": {"variant": "deep", "seed_min_confidence": 0.9, "extend_seconds": 0.5},
    # without interpolation: does SOT fill gaps that interpolation would have filled anyway? (issue #12)
    "MOT no-interp": {"variant": "none", "postprocess": {"interpolate": False}},
    "SOT(template)+MOT no-interp": {"variant": "template", "postprocess": {"interpolate": False}},
    "SOT(deep)+MOT no-interp": {"variant": "deep", "postprocess": {"interpolate": False}},
}
COLUMNS = ("HOTA", "MOTA", "MOTP", "IDF1", "FP", "FN", "IDSW")


def added_precision(run) -> tuple[int, float]:
    """Number of SOT boxes in the output (Algorithm 1's that survived, and end extensions) and the
    fraction that hit a ground-truth pedestrian."""
    t = run.tracks
    gt = read_ground_truth(run.info.gt_path, run.info.length).pedestrians()
    added = np.flatnonzero(t.from_sot)
    if len(added) == 0:
        return 0, float("nan")
    hits = 0
    for i in added:
        g = gt.boxes[gt.frames == t.frames[i]]
        hits += bool(len(g)) and iou_matrix(t.boxes[i], g).max() >= 0.5
    return len(added), hits / len(added)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--model", required=True)
    parser.add_argument("--config", type=Path)
    parser.add_argument("--rows", default=",".join(ROWS), help="comma-separated subset of: " + ", ".join(ROWS))
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    base = (load_config(args.config) if args.config else TrackerConfig()).replace("appearance", model=args.model)
    embedder = make_embedder(base.appearance)
    rows = [r for r in args.rows.split(",") if r]
    seqs = sequences(args.data)
    if args.sequences:
        seqs = [s for s in seqs if s.name in args.sequences.split(",")]
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
                spec = dict(ROWS[row])
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
                n_added, precision = added_precision(run)
                results[info.name][row] = {"fps": info.length / seconds, "seconds": seconds, "added": n_added,
                                           "added_precision": precision, "sot_steps": prepared.sot_steps,
                                           "stage_seconds": run.timings}
                print(f"{info.name} {row}: {info.length / seconds:.1f} fps, {n_added} added", file=sys.stderr)
        combined: dict[str, dict] = {}
        for row in rows:
            report = evaluate_files(pairs[row])
            for name, scores in report.sequences.items():
                results[name][row].update(scores)
            combined[row] = dict(report.combined)
            frames = sum(p[2] for p in pairs[row])
            combined[row]["fps"] = frames / sum(results[p[3]][row]["seconds"] for p in pairs[row])
            combined[row]["added"] = sum(results[p[3]][row]["added"] for p in pairs[row])
    head = f"{'sequence':<17}{'row':<32}" + "".join(f"{c:>7}" for c in COLUMNS) + f"{'fps':>7}{'added':>7}{'prec':>7}"
    lines = [head, "-" * len(head)]
    for name, by_row in list(results.items()) + [("ALL", combined)]:
        for row in rows:
            v = by_row[row]
            cells = "".join(f"{v[c]:7.1f}" if c in ("HOTA", "MOTA", "MOTP", "IDF1") else f"{v[c]:7.0f}"
                            for c in COLUMNS)
            prec = v.get("added_precision", float("nan"))
            lines.append(f"{name:<17}{row:<32}{cells}{v['fps']:7.1f}{v['added']:7d}{prec:7.2f}")
    print("\n".join(lines))
    print(f"machine: {machine()}")
    if args.json:
        args.json.write_text(json.dumps({"machine": machine(), "config": base.to_dict(), "rows": results,
                                         "combined": combined}, indent=2, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
