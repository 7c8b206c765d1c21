#!/usr/bin/env python3
"""The gates of SOT after association (trajectory ends), fitted leave-one-sequence-out on the full-length sequences.

Each labelled sequence of at least ``--min-length`` frames under ``--data`` is
tracked once with the configuration (appearance cached under ``--cache``),
then its confirmed trajectories' ends are extended once with the loosest gates
of the grid (``sotmot.sot.extend.extend_ends`` with a trace of every added box and
its re-ID affinity). Every grid point -- ``[ends] min_confidence`` (the
trajectory's mean confirmation confidence), ``min_affinity`` and
``seconds`` -- is then the same run cut where its gates would have
stopped each end (an end stops at its first box that fails a gate, so cutting
the loose run reproduces the strict one, except that a box cut from one end
no longer blocks another track's end), and scored with TrackEval. Each grid
point is chosen leave-one-sequence-out: for each sequence, the point with the
best mean HOTA on the sequences of the *other* videos (MOT16-09 and MOT17-09-FRCNN/-SDP
are one video, left out together); the table gives what it does on the
held-out sequence, beside no extension.

With ``--weak`` the ends grow by the person detector's weak boxes
(``--detector-model``, ``[detection] weak_boxes = "on"``) instead of SOT:
the detector's boxes near the motion prior (ByteTrack's second association at
trajectory ends), each gated by the fixed affinity of
:data:`sotmot.sot.support.SUPPORTED_AFFINITY` (``--affinities`` then changes
nothing). With ``--private`` the
sequences are tracked from that detector's boxes (MOTChallenge's private
detections) instead of their public ``det.txt``. The rows give the added
boxes and how many of them are right (matched to ground truth by the CLEAR
rule).

    python scripts/fit_sot.py --model ../shared/models/person-reidentification-retail-0288.onnx --json fit_sot.json
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from common import add_fit_arguments, fit_setup
from sotmot.appearance import make_embedder
from sotmot.benchmarks import cached_features, private_config, video_of
from sotmot.fitting.confidence import box_labels
from sotmot.scoring import evaluate_files
from sotmot.sot.extend import extend_ends, gated, with_added
from sotmot.sot.support import DetectorSupport
from sotmot.io import FrameReader, results_path, write_results, write_text_atomic
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.plan import resolve
from sotmot.versions import machine

ROOT = Path(__file__).resolve().parents[1]
SHOWN = ("HOTA", "MOTA", "IDF1", "FP", "FN", "IDSW")


def floats(text: str) -> list[float]:
    return [float(v) for v in text.split(",") if v.strip()]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_fit_arguments(parser, ROOT / ".cache" / "features")
    parser.add_argument("--confidences", default="0,0.6,0.7,0.8",
                        help="candidate [ends] min_confidence values (default: %(default)s)")
    parser.add_argument("--affinities", default="0.5,0.6,0.7",
                        help="candidate [ends] min_affinity values (default: %(default)s)")
    parser.add_argument("--seconds", default="0.5,1.0", help="candidate [ends] seconds values (default: %(default)s)")
    parser.add_argument("--detector-model", metavar="PATH.xml", help="the person detector of --weak and --private")
    parser.add_argument("--weak", action="store_true",
                        help="the ends grow by the detector's weak boxes, no SOT ([detection] weak_boxes = on)")
    parser.add_argument("--private", action="store_true",
                        help="track from the detector's boxes instead of each sequence's det/det.txt")
    parser.add_argument("--det-cache", type=Path, default=ROOT / ".cache" / "detections",
                        help="with --private: where the detector's boxes are kept (default: %(default)s)")
    args = parser.parse_args(argv)
    if (args.private or args.weak) and not args.detector_model:
        parser.error("--private and --weak need --detector-model")

    config, seq_dirs = fit_setup(args)
    grid = list(itertools.product(floats(args.confidences), floats(args.affinities), floats(args.seconds)))
    loosest = config.replace("ends", min_confidence=0.0, min_affinity=min(g[1] for g in grid),
                             seconds=max(g[2] for g in grid)).ends
    support = None
    if args.detector_model:
        config = config.replace("detection", model=args.detector_model)
    weak = config.replace("detection", weak_boxes="on")
    embedder_box: list = []
    traced: dict[str, tuple] = {}
    for seq_dir in seq_dirs:
        seq_config = private_config(config, seq_dir, args.detector_model, args.det_cache) if args.private else config
        prepared = prepare_sequence(seq_dir, seq_config, features=cached_features(seq_dir, seq_config, args.cache,
                                                                                    embedder_box))
        run = finish_sequence(prepared, seq_config.replace("ends", seconds=0.0))
        info = prepared.info
        identity = run.identities()
        if not embedder_box:
            embedder_box.append(make_embedder(config.appearance))
        if args.weak:  # the detector at the weak boxes' threshold, on the frames the ends visit (per sequence)
            support = DetectorSupport.from_config(resolve(weak, info).weak_detector)
        trace: list[dict] = []
        extend_ends(run.tracks, identity, FrameReader.walking(info), info.length, info.frame_rate,
                    embedder_box[0], config.sot, loosest, trace=trace, support=support)
        traced[info.name] = (info, run.tracks, trace)
        print(f"{info.name}: {len(trace)} end boxes at the loosest gates, {sum(b['supported'] for b in trace)} "
              f"supported by a detector box", file=sys.stderr, flush=True)
    names = list(traced)
    runs = {"none": None, **{f"conf>={c:g} aff>={a:g} {s:g}s": (c, a, s) for c, a, s in grid}}
    rows: dict[str, dict[str, dict]] = {name: {} for name in names}
    files: dict[str, list] = {run: [] for run in runs}
    with tempfile.TemporaryDirectory(prefix="sotmot-fit-sot-") as tmp:
        for index, (run, gates) in enumerate(runs.items()):
            for name in names:
                info, tracks, trace = traced[name]
                if gates is None:
                    out = tracks
                else:
                    c, a, s = gates
                    strict = dataclasses.replace(loosest, min_confidence=c, min_affinity=a, seconds=s)
                    out = with_added(tracks, [(b["frame"], b["track"], b["box"])
                                              for b in gated(trace, info.frame_rate, strict)])
                path = results_path(Path(tmp) / f"run{index}", name)
                write_results(path, out)
                files[run].append((path, info.gt_path, info.length, name, out))
                rows[name][run] = {"added": int(out.from_sot.sum())}
        combined = {}
        for run in runs:
            report = evaluate_files([f[:4] for f in files[run]])
            for name, scores in report.sequences.items():
                rows[name][run].update(scores)
            combined[run] = dict(report.combined)
        candidates = [r for r in runs if r != "none"]

        def mean_hota(run: str, seqs: list[str]) -> float:
            return float(np.mean([rows[s][run]["HOTA"] for s in seqs]))

        held_out, chosen_files = {}, []
        for name in names:
            train = [s for s in names if video_of(s) != video_of(name)]  # leave the whole video out
            best = max(candidates, key=lambda r: (mean_hota(r, train), -candidates.index(r)))
            held_out[name] = best
            chosen = next(f for f in files[best] if f[3] == name)
            info, out = traced[name][0], chosen[4]
            labels = box_labels(out, info, Path(tmp) / "labels" / name)[out.from_sot]
            rows[name]["held out"] = dict(rows[name][best], chosen=best, added_right=int((labels == 1).sum()))
            chosen_files.append(chosen[:4])
        combined["held out"] = dict(evaluate_files(chosen_files).combined)
        combined["held out"]["added"] = sum(rows[n]["held out"]["added"] for n in names)
        combined["held out"]["added_right"] = sum(rows[n]["held out"]["added_right"] for n in names)
        combined["none"]["added"] = combined["none"]["added_right"] = 0
        for name in names:
            rows[name]["none"]["added_right"] = 0
        fitted_on_all = max(candidates, key=lambda r: (mean_hota(r, names), -candidates.index(r)))
        combined[fitted_on_all]["added"] = sum(rows[n][fitted_on_all]["added"] for n in names)
        for name in names:
            out = next(f for f in files[fitted_on_all] if f[3] == name)[4]
            labels = box_labels(out, traced[name][0], Path(tmp) / "labels-all" / name)[out.from_sot]
            rows[name][fitted_on_all]["added_right"] = int((labels == 1).sum())
        combined[fitted_on_all]["added_right"] = sum(rows[n][fitted_on_all]["added_right"] for n in names)
    head = f"  {'gates':<34}" + "".join(f"{c:>8}" for c in SHOWN + ("added", "right"))
    for name in names:
        print(f"\n{name} (held out: {held_out[name]})\n{head}")
        for run in ("none", "held out", fitted_on_all):
            v = rows[name][run]
            print(f"  {run:<34}" + "".join(f"{v[c]:8.2f}" if c in ("HOTA", "MOTA", "IDF1") else f"{v[c]:8.0f}"
                                           for c in SHOWN + ("added", "added_right")))
    print(f"\nall {len(names)} sequences, TrackEval combined\n{head}")
    for run in ("none", "held out", fitted_on_all):
        v = combined[run]
        print(f"  {run:<34}" + "".join(f"{v[c]:8.2f}" if c in ("HOTA", "MOTA", "IDF1") else f"{v[c]:8.0f}"
                                       for c in SHOWN + ("added", "added_right")))
    print(f"fitted on all sequences: {fitted_on_all}")
    print(f"machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "grid": grid, "rows": rows,
                                                 "detector_model": args.detector_model, "weak": args.weak,
                                                 "private": args.private,
                                                 "combined": combined, "held_out": held_out,
                                                 "fitted_on_all": fitted_on_all}, indent=1, default=float) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
