#!/usr/bin/env python3
"""Accuracy and speed of sotmot on every sequence with frames in the shared data folder, before and after confirmation.

Tracks each sequence twice on the same detections and features: **before**
(the configuration without the confirmation stage and with every gap
interpolated, as sotmot was until the confidence issue) and **after** (the
configuration given, by default the defaults). Scores come from TrackEval:
HOTA, DetA, AssA, MOTA, IDF1, IDSW, FP, FN per sequence, for the full-length
sequences combined (more than 100 frames) and for the 30-frame clips combined,
plus frames per second of the whole "after" pipeline (reading, appearance,
tracklets, association, post-processing, confirmation; not scoring), and how
many interpolated boxes each output has and how many of them are right.

With ``--loo fit_confidence.json`` (the report of ``scripts/fit_confidence.py``)
the leave-one-sequence-out rows are printed too: each full-length sequence
scored with a calibration fitted on the others only. The ``min_hits k`` rows
apply the online trackers' confirmation instead (a trajectory is kept once it
has k detector boxes), to show what seeing whole trajectories adds.

    python scripts/bench_accuracy.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --loo fit_confidence.json --json bench_accuracy.json

The peer rows are the best MOTA among the peers on the same detections and
embeddings, quoted from the confidence issue (#11; boxmot 25.0.0 trackers with
and without GSI, DeepSORT from scripts/bench_peers.py); they are not
re-measured by this script; with ``--detector-model`` (private detections)
they do not apply and ``scripts/bench_peers.py --detector-model`` measures
the peers on the same boxes.

With ``--detector-model`` every sequence is tracked from the built-in
detector's boxes (detected once and cached; fps then excludes detection,
which ``scripts/bench_speed.py`` times) instead of its public ``det.txt``.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

from sotmot.appearance import make_embedder
from common import DEFAULT_DATA
from sotmot.benchmarks import FULL_LENGTH, before_confirmation, private_config, sequences
from sotmot.fitting.confidence import box_labels
from sotmot.config import TrackerConfig, load_config
from sotmot.scoring import METRICS, EvalReport, evaluate_files
from sotmot.io import results_path, write_results, write_text_atomic
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.postprocess import line_checked
from sotmot.versions import machine

COLUMNS = ("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDSW", "FP", "FN")
BEST_PEER_MOTA = {  # issue #11, same detections and embeddings; not re-measured here
    "PETS09-S2L1": ("BoostTrack++ with GSI", 74.3),
    "MOT16-09": ("HybridSORT with GSI", 50.6),
    "MOT17-09-FRCNN": ("BoT-SORT with GSI", 57.8),
    "TUD-Stadtmitte": ("DeepSORT", 59.5),
}


def cells(values: dict[str, float]) -> str:
    return "".join(f"{values[c]:8.1f}" if METRICS[c][2] else f"{values[c]:8.0f}" for c in COLUMNS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--solver", "--merger", dest="solver", default="greedy",
                        help="long-term association solver (default: %(default)s)")
    parser.add_argument("--config", type=Path, help="tracker configuration file for 'after' (default: the defaults)")
    parser.add_argument("--min-hits", default="3,5,10",
                        help="comparison rows: the online trackers' rule, a trajectory is kept once it has this "
                             "many detector boxes (no other confirmation; gaps bounded as in 'after'); "
                             "comma-separated, empty for none (default: %(default)s)")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="private detections: track the boxes of this person detector (run once per sequence, "
                             "cached in --det-cache) instead of each sequence's public det/det.txt")
    parser.add_argument("--det-cache", type=Path, default=Path(".cache/detections"),
                        help="where the detector's boxes are kept between runs (default: %(default)s)")
    parser.add_argument("--loo", type=Path, help="report of scripts/fit_confidence.py: print its held-out rows")
    parser.add_argument("--json", type=Path, help="write results here")
    parser.add_argument("--results", type=Path, help="keep the results files here (default: a temp folder)")
    args = parser.parse_args(argv)

    config = load_config(args.config) if args.config else TrackerConfig()
    config = config.replace("appearance", model=args.model)
    configs = {"before": before_confirmation(config), "after": config}
    embedder = make_embedder(config.appearance)
    hits = [int(h) for h in args.min_hits.split(",") if h.strip()]
    seqs = sequences(args.data)
    if not seqs:
        print(f"no sequences with frames under {args.data}", file=sys.stderr)
        return 1
    pairs: dict[str, list[tuple[Path, Path, int, str]]] = {"before": [], "after": []}
    pairs.update({f"min_hits {k}": [] for k in hits})
    runs: dict[str, dict] = {}
    interpolation: dict[str, dict[str, dict[str, int]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        out = args.results or Path(tmp)
        for seq in seqs:
            seq_config = config
            if args.detector_model:  # detected once, outside the clock (bench_speed times detection)
                seq_config = private_config(config, seq, args.detector_model, args.det_cache)
            start = time.perf_counter()
            prepared = prepare_sequence(seq, seq_config, embedder, progress=sys.stderr.isatty())
            seconds = time.perf_counter() - start  # the "after" pipeline: preparation plus its finish
            for label, cfg in configs.items():
                lap = time.perf_counter()
                result = finish_sequence(prepared, cfg.replace("association", solver=args.solver), embedder)
                if label == "after":
                    seconds += time.perf_counter() - lap
                path = results_path(out / label, result.info.name)
                write_results(path, result.tracks)
                pairs[label].append((path, result.info.gt_path, result.info.length, result.info.name))
                labels = box_labels(result.tracks, result.info, out / f"{label}-labels")
                filled = result.tracks.interpolated
                interpolation.setdefault(result.info.name, {})[label] = {
                    "boxes": int(filled.sum()), "TP": int((labels[filled] == 1).sum()),
                    "FP": int((labels[filled] == 0).sum())}
            if result.info.length > FULL_LENGTH:
                online = config.replace("confirm", enabled=False)
                for k in hits:
                    kept = [t for t in result.trajectories
                            if int((~prepared.detections.from_sot[t.det_index]).sum()) >= k]
                    post = line_checked(online.postprocess, kept, result.info.frame_rate)
                    tracks = prepared.written(kept, post)
                    path = results_path(out / f"min_hits_{k}", result.info.name)
                    write_results(path, tracks)
                    pairs[f"min_hits {k}"].append((path, result.info.gt_path, result.info.length, result.info.name))
            runs[result.info.name] = {"frames": result.info.length, "seconds": seconds,
                                      "fps": result.info.length / seconds, "stage_seconds": result.timings,
                                      "confidence": prepared.confidence_method}
            print(f"{result.info.name}: {result.info.length / seconds:.1f} frames/s", file=sys.stderr)
        reports: dict[str, dict[str, EvalReport]] = {}
        for label in configs:
            full = [p for p in pairs[label] if p[2] > FULL_LENGTH]
            clips = [p for p in pairs[label] if p[2] <= FULL_LENGTH]
            reports[label] = {"all": evaluate_files(pairs[label]),
                              "full": evaluate_files(full) if full else EvalReport(),
                              "clips": evaluate_files(clips) if clips else EvalReport()}
        online_reports = {label: evaluate_files(p) for label, p in pairs.items() if label.startswith("min_hits") and p}
    loo = json.loads(args.loo.read_text()) if args.loo else None
    head = f"{'sequence':<34}" + "".join(f"{c:>8}" for c in COLUMNS) + f"{'fps':>8}"
    lines = [head, "-" * len(head)]
    names = [n for n in reports["after"]["all"].sequences]
    full_names = [n for n in names if runs[n]["frames"] > FULL_LENGTH]
    for name in full_names + [n for n in names if n not in full_names]:
        for label in configs:
            fps = f"{runs[name]['fps']:8.1f}" if label == "after" else ""
            lines.append(f"{name + ' ' + label:<34}" + cells(reports[label]["all"].sequences[name]) + fps)
        if loo and name in loo["methods"]["auto"]["held_out"]["sequences"]:
            used = loo["methods"]["auto"]["confidence_used"][name]
            lines.append(f"{name + ' held out [' + used + ']':<34}"
                         + cells(loo["methods"]["auto"]["held_out"]["sequences"][name]))
        for label, rep in online_reports.items():
            if name in rep.sequences:
                lines.append(f"{name + ' ' + label:<34}" + cells(rep.sequences[name]))
        if name in BEST_PEER_MOTA and not args.detector_model:  # quoted for public detections only
            peer, mota = BEST_PEER_MOTA[name]
            lines.append(f"{'  best peer MOTA: ' + peer:<34}" + " " * 24 + f"{mota:8.1f}")
    for group, title in (("full", "full-length combined"), ("clips", "clips combined")):
        for label in configs:
            if reports[label][group].combined:
                lines.append(f"{title + ' ' + label:<34}" + cells(reports[label][group].combined))
        if group == "full" and loo:
            lines.append(f"{title + ' held out':<34}" + cells(loo["methods"]["auto"]["held_out"]["combined"]))
        if group == "full":
            for label, rep in online_reports.items():
                lines.append(f"{title + ' ' + label:<34}" + cells(rep.combined))
    lines += ["", "interpolated boxes (TP / FP by TrackEval's matching)",
              f"{'sequence':<20}{'before':>20}{'after':>20}"]
    for name in full_names:
        b, a = interpolation[name]["before"], interpolation[name]["after"]
        lines.append(f"{name:<20}{b['boxes']:>8} ({b['TP']:>4} / {b['FP']:>4})"
                     f"{a['boxes']:>8} ({a['TP']:>4} / {a['FP']:>4})")
    kind = (f"private detections (MOTChallenge's term): the boxes of {Path(args.detector_model).name}"
            if args.detector_model else "public detections: each sequence's det/det.txt")
    print("\n".join(lines))
    print(f"detections: {kind}")
    print(f"machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({
            "machine": machine(), "solver": args.solver, "model": args.model, "config": config.to_dict(),
            "detections": kind,
            "before": {k: r.to_dict() for k, r in reports["before"].items()},
            "after": {k: r.to_dict() for k, r in reports["after"].items()},
            "held_out": loo["methods"]["auto"]["held_out"] if loo else None,
            "min_hits": {label: rep.to_dict() for label, rep in online_reports.items()},
            "speed": runs, "interpolated_boxes": interpolation, "best_peer_mota_issue_11": BEST_PEER_MOTA,
        }, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
