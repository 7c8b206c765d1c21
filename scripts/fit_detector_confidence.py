#!/usr/bin/env python3
"""Fit the built-in detector's confidence family (``pd0202``) leave-one-video-out, and its entry score.

For every labelled sequence with frames (by default those of at least 30
frames: the three full-length videos and the five 30-frame MOT16 clips, other
streets and a camera on a vehicle, eight scenes) the built-in detector's
boxes (detected once, cached) are tracked without confirmation and every box
is labelled by TrackEval's matching, at each candidate entry score (the
score below which boxes never enter tracking; ``--min-scores``). Holding out
one **video** at a time (MOT16-09 and MOT17-09-* are one video: the same
frames, so the same detections; MOT17-09-SDP's ground truth is
MOT17-09-FRCNN's, so only one of them is used), the family's score map
(isotonic), its confirmation model (logistic) and threshold (the best mean
MOTA over the training videos among thresholds with which none loses more
than 0.5 HOTA or IDF1), and the entry score (the best mean HOTA over the
training videos after their own confirmation) are fitted on the others and
the held-out video is scored. Public detections are not touched: the family
has its own map, box model and threshold, so every public run is unchanged.

    .venv/bin/python scripts/fit_detector_confidence.py \\
        --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --detector-model ../shared/models/person-detection-0202/person-detection-0202.FP16-INT8.xml \\
        --json fit_detector.json --write sotmot/data/confidence.json

``--write`` adds (or replaces) the family's entries in a calibration file,
leaving every other entry as it is.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA, add_confirmation_fit_arguments
from sotmot.benchmarks import cached_features, model_detections
from sotmot.fitting.confidence import (
    Labelled,
    detection_labels,
    fit,
    held_out_tracks,
    label_sequence,
    score,
    unconfirmed_tracks,
)
from sotmot.config import TrackerConfig
from sotmot.scoring import METRICS
from sotmot.io import read_detections, read_seqinfo, write_text_atomic
from sotmot.pipeline import prepare_sequence
from sotmot.preprocess import preprocess_indices
from sotmot.versions import machine

ROOT = Path(__file__).resolve().parents[1]
FAMILY = "pd0202"
COLUMNS = ("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDSW", "FP", "FN")


def videos(data: Path, min_length: int) -> dict[str, list[Path]]:
    """Labelled sequences of at least ``min_length`` frames grouped by their frames (one video may carry several
    ground truths); a sequence whose frames and ground truth repeat another's is left out."""
    groups: dict[str, list[Path]] = {}
    seen = set()
    for p in sorted(data.iterdir()):
        if not ((p / "seqinfo.ini").is_file() and (p / "img1").exists() and (p / "gt" / "gt.txt").is_file()):
            continue
        info = read_seqinfo(p)
        if info.length < min_length:
            continue
        key = (str(info.frames_dir.resolve()), (p / "gt" / "gt.txt").read_bytes())
        if key in seen:
            continue
        seen.add(key)
        groups.setdefault(str(info.frames_dir.resolve()), []).append(p)
    return {paths[0].name: paths for paths in groups.values()}


def row(name: str, values: dict[str, float]) -> str:
    return f"{name:<34}" + "".join(f"{values[c]:8.1f}" if METRICS[c][2] else f"{values[c]:8.0f}" for c in COLUMNS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--min-length", type=int, default=30,
                        help="sequences of at least this many frames (default 30: the clips too; 100: the full-length "
                             "videos alone, as fitted before 2026-12-05)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--detector-model", required=True, help="the detector (OpenVINO IR .xml)")
    parser.add_argument("--min-scores", default="0.3,0.4,0.5",
                        help="candidate entry scores; the first is what the cached detections keep "
                             "(default: %(default)s)")
    parser.add_argument("--cache", type=Path, default=ROOT / ".cache" / "features")
    parser.add_argument("--det-cache", type=Path, default=ROOT / ".cache" / "detections")
    parser.add_argument("--json", type=Path, help="write every number here")
    parser.add_argument("--write", type=Path, help="add the family fitted on every video to this calibration file")
    parser.add_argument("--final-entry", type=float,
                        help="fit the written family at this entry score, one of --min-scores (default: the best "
                             "mean HOTA on every video); for keeping [detection] min_score where the candidates "
                             "tie")
    add_confirmation_fit_arguments(parser)
    args = parser.parse_args(argv)

    start = time.perf_counter()
    entry = [float(s) for s in args.min_scores.split(",")]
    if args.final_entry is not None and args.final_entry not in entry:
        parser.error(f"--final-entry {args.final_entry} is not one of --min-scores {args.min_scores}")
    thresholds = [float(t) for t in args.thresholds.split(",")]
    base_config = (TrackerConfig().replace("appearance", model=args.model)
                   .replace("detection", model=args.detector_model, min_score=entry[0])
                   .replace("preprocess", confidence="quantile").replace("confirm", enabled=False))
    groups = videos(args.data, args.min_length)
    if len(groups) < 2:
        print(f"need at least two labelled videos under {args.data}; found {len(groups)}", file=sys.stderr)
        return 1
    embedder_box: list = []
    labelled: dict[float, dict[str, Labelled]] = {s: {} for s in entry}
    samples: dict[float, dict[str, tuple]] = {s: {} for s in entry}
    video_of: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="sotmot-labels-") as tmp:
        work = Path(tmp)
        for video, paths in groups.items():
            for seq in paths:
                found = model_detections(seq, base_config, args.det_cache)
                info = read_seqinfo(seq)
                everything = base_config.replace("detection", file=str(found)).replace("preprocess", nms="none")
                features = cached_features(seq, everything, args.cache, embedder_box)  # every box, once
                raw = read_detections(found, info.length)
                for s in entry:
                    cfg = base_config.replace("detection", file=str(found)).replace("preprocess", score_threshold=s)
                    kept = preprocess_indices(raw, cfg.preprocess)
                    prepared = prepare_sequence(seq, cfg, features=features[kept])
                    solved = cfg.replace("association", solver=args.solver)
                    labelled[s][info.name] = label_sequence(prepared, raw.scores, solved, work, FAMILY)
                    samples[s][info.name] = detection_labels(seq, cfg, work, FAMILY)
                video_of[info.name] = video
                print(f"{info.name} [{video}]: {len(raw)} detector boxes", file=sys.stderr, flush=True)

    names = list(video_of)
    configs = {s: base_config.replace("preprocess", score_threshold=s) for s in entry}
    bases = {s: score(list(labelled[s].values()), lambda q: unconfirmed_tracks(q, configs[s])) for s in entry}
    kinds = ((FAMILY, "auto"),)

    def fitted(s: float, train: list[str]):
        seqs = [labelled[s][n] for n in train]
        result = fit(seqs, {}, samples[s], thresholds, configs[s], bases[s], args.l2, kinds)
        confirmed = score(seqs, lambda q: held_out_tracks(q, "auto", result.calibration, configs[s])[1])
        return result, float(np.mean([v["HOTA"] for v in confirmed.sequences.values()]))

    report: dict = {"machine": machine(), "videos": {v: [p.name for p in ps] for v, ps in groups.items()},
                    "entry_scores": entry, "thresholds": thresholds, "folds": {}}
    held: dict[str, object] = {}
    chosen_entry: dict[str, float] = {}
    for video in groups:
        train = [n for n in names if video_of[n] != video]
        trials = {s: fitted(s, train) for s in entry}
        best = max(entry, key=lambda s: (trials[s][1], -s))
        result = trials[best][0]
        for n in (n for n in names if video_of[n] == video):
            held[n] = held_out_tracks(labelled[best][n], "auto", result.calibration, configs[best])[1]
            chosen_entry[n] = best
        report["folds"][video] = {"entry_score": best,
                                  "train_mean_hota": {f"{s:.2f}": round(trials[s][1], 3) for s in entry},
                                  "threshold": result.calibration.thresholds[FAMILY]}
    held_report = score([labelled[chosen_entry[n]][n] for n in names], lambda q: held[q.name])
    unconfirmed = score([labelled[entry[0]][n] for n in names],
                        lambda q: unconfirmed_tracks(q, configs[entry[0]]))
    head = f"{'sequence':<34}" + "".join(f"{c:>8}" for c in COLUMNS)
    lines = [head, "-" * len(head)]
    for n in names:
        lines.append(row(f"{n} unconfirmed (entry {entry[0]:.2f})", unconfirmed.sequences[n]))
        fold = report["folds"][video_of[n]]
        lines.append(row(f"{n} held out (entry {chosen_entry[n]:.2f}, t {fold['threshold']:.2f})",
                         held_report.sequences[n]))
    lines.append(row("COMBINED unconfirmed", unconfirmed.combined))
    lines.append(row("COMBINED held out", held_report.combined))
    print("\n".join(lines))

    trials = {s: fitted(s, names) for s in entry}
    best = max(entry, key=lambda s: (trials[s][1], -s)) if args.final_entry is None else args.final_entry
    final = trials[best][0].calibration
    forced = " (--final-entry)" if args.final_entry is not None else ""
    print(f"\nfitted on every video: entry score {best:.2f}{forced} (mean HOTA "
          + ", ".join(f"{s:.2f}: {trials[s][1]:.2f}" for s in entry) + f"), threshold {final.thresholds[FAMILY]:.2f}; "
          f"{time.perf_counter() - start:.0f} s; machine: {machine()}")
    report.update({"held_out": held_report.to_dict(), "unconfirmed": unconfirmed.to_dict(),
                   "entry_score_held_out": chosen_entry, "final_entry_score": best,
                   "final_entry_forced": args.final_entry is not None,
                   "final": {"family": list(map(list, final.families[FAMILY])),
                             "box_model": final.box_models[FAMILY].to_dict(), "threshold": final.thresholds[FAMILY]}})
    if args.write:
        data = json.loads(args.write.read_text(encoding="utf-8"))
        data["families"][FAMILY] = {"scores": list(final.families[FAMILY][0]),
                                    "confidence": list(final.families[FAMILY][1])}
        data["box_models"][FAMILY] = final.box_models[FAMILY].to_dict()
        data["thresholds"][FAMILY] = final.thresholds[FAMILY]
        data["provenance"][FAMILY] = {
            "script": "scripts/fit_detector_confidence.py", "detector": Path(args.detector_model).name,
            "model": Path(args.model).name, "solver": args.solver, "sequences": names, "entry_score": best,
            "threshold_scores": final.provenance["threshold_scores"][FAMILY]}
        write_text_atomic(args.write, json.dumps(data, indent=1) + "\n")
        print(f"family {FAMILY} written to {args.write}")
    if args.json:
        write_text_atomic(args.json, json.dumps(report, indent=1, default=float) + "\n")
        print(f"report written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
