#!/usr/bin/env python3
"""Where the false boxes come from: every output box sorted by the stage that wrote it, and its FP counted there.

Issue #39 measured the 4-s gap adding false positives on unseen sequences (FP
+57 %); :mod:`miss_analysis` sorts the misses, this sorts the false boxes.
Each configuration (``--config NAME=FILE``; the first is the reference,
default today's defaults) tracks the validation set (``--groups``: the
full-length sequences with frames, their 8-15 fps variants, the label-only
sequences and their 12.5-15 fps variants in the motion-only mode;
:func:`sotmot.benchmarks.validation_set`)
or any folder of MOTChallenge sequences with frames (``--data``). Every output
box TrackEval scores (boxes on distractors are removed first, as TrackEval
does) is put under the stage that wrote it:

* ``detection``: a box of the tracker's input (``det/det.txt``, or with
  ``--detector-model`` the built-in detector's boxes: private detections);
* ``sot``: a box the SOT step or the end extension added;
* ``short gap``: interpolated in a gap of at most ``[postprocess]
  occlusion_seconds`` (1 s when the check is off);
* ``long gap, on the line``: interpolated in a longer gap whose straight line
  the walk on both sides leads along (motion agreement at least ``[postprocess]
  min_agreement``, the box not standing still: ``still_speed``): written on
  trust;
* ``long gap, off the line``: interpolated in a longer gap off the walk's line
  or across which the box stood still (:func:`sotmot.postprocess.off_the_line`):
  written only where a detection in front could hide the person (every box,
  when the occlusion check is off).

Per stage: the boxes scored, their FP (TrackEval's CLEAR matching,
:func:`sotmot.scoring.frame_errors`), and what lies under each false box:
``misplaced`` (a person nobody matched overlaps it at IoU >= 0.3: the tracker
is there, the box is off), ``double`` (a person matched to another box overlaps
it at IoU >= 0.5: a second box on someone), ``no one`` (neither).

    python scripts/fp_analysis.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --config defaults= --config gap60f=docs/validation/gap60f.toml --json docs/results/false_boxes.json
    # private detections, on sequences with frames only
    python scripts/fp_analysis.py --model ... --groups frames \\
        --detector-model ../shared/models/person-detection-0202/person-detection-0202.FP16-INT8.xml
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA, named_config, named_sequences, validation_groups
from sotmot.benchmarks import (FULL_LENGTH, GROUPS, LABEL_GROUPS, for_group, group_features, preparation_key,
                               private_config, sequences, validation_set)
from sotmot.boxes import iou_matrix
from sotmot.config import PostprocessConfig
from sotmot.io import read_seqinfo, results_path, write_results, write_text_atomic
from sotmot.pipeline import TrackResult, finish_sequence, prepare_sequence
from sotmot.postprocess import long_gap_frames, off_the_line
from sotmot.scoring import FrameErrors, evaluate_files, frame_errors
from sotmot.versions import machine

ORIGINS = ("detection", "sot", "short gap", "long gap, on the line", "long gap, off the line")
UNDER = ("misplaced", "double", "no one")
#: Where a gap is long when ``[postprocess] occlusion_seconds`` is off: the default's 1 s.
LONG_SECONDS = PostprocessConfig().occlusion_seconds or 1.0


def origins(result: TrackResult, config: PostprocessConfig) -> dict[tuple[int, int], str]:
    """``(frame, output id)`` -> the stage that wrote that box of ``result.tracks`` (:data:`ORIGINS`); a gap's
    length and line judged as :mod:`sotmot.postprocess` judges them, on the trajectory the box was filled in."""
    tracks = result.tracks
    trajectory = {i: t for t, i in zip(result.trajectories, result.track_ids) if i is not None}
    long_after = long_gap_frames(config.occlusion_seconds if config.occlusion_seconds is not None else LONG_SECONDS,
                                 result.info.frame_rate)
    gap_kind: dict[tuple[int, int], str] = {}
    out = {}
    for frame, tid, filled, sot in zip(tracks.frames.tolist(), tracks.ids.tolist(), tracks.interpolated.tolist(),
                                       tracks.from_sot.tolist()):
        if sot or not filled:
            out[frame, tid] = "sot" if sot else "detection"
            continue
        t = trajectory[tid]
        k = int(np.searchsorted(t.frames, frame)) - 1  # the gap after the trajectory's k-th box
        if (tid, k) not in gap_kind:
            if t.frames[k + 1] - t.frames[k] <= long_after:
                gap_kind[tid, k] = "short gap"
            else:
                on_line = not off_the_line(t.frames, t.boxes, np.array([k]), config, result.info.frame_rate)[0]
                gap_kind[tid, k] = "long gap, on the line" if on_line else "long gap, off the line"
        out[frame, tid] = gap_kind[tid, k]
    return out


def empty_counts() -> dict[str, dict[str, int]]:
    return {o: dict.fromkeys(("boxes", "FP", *UNDER), 0) for o in ORIGINS}


def classify(errors: FrameErrors, origin: dict[tuple[int, int], str]) -> dict[str, dict[str, int]]:
    """Per stage (:data:`ORIGINS`): the boxes TrackEval scored, their FP, and what lies under each FP
    (:data:`UNDER`), from one sequence's CLEAR matching and :func:`origins`."""
    counts = empty_counts()
    for frame, rows in errors.matched.items():
        for _, _, tid, _ in rows:
            counts[origin[frame, tid]]["boxes"] += 1
    for frame, rows in errors.false_positives.items():
        missed = np.asarray(errors.misses.get(frame, []), dtype=np.float64).reshape(-1, 4)
        taken = np.asarray([gt for gt, *_ in errors.matched.get(frame, [])], dtype=np.float64).reshape(-1, 4)
        for box, tid in rows:
            row = counts[origin[frame, tid]]
            row["boxes"] += 1
            row["FP"] += 1
            box = np.asarray(box, dtype=np.float64).reshape(1, 4)
            if len(missed) and iou_matrix(box, missed).max() >= 0.3:
                row["misplaced"] += 1
            elif len(taken) and iou_matrix(box, taken).max() >= 0.5:
                row["double"] += 1
            else:
                row["no one"] += 1
    return counts


def combine(per_sequence: list[dict[str, dict[str, int]]]) -> dict[str, dict[str, int]]:
    """Cell-wise sum of :func:`classify` counts."""
    out = empty_counts()
    for counts in per_sequence:
        for o in ORIGINS:
            for k, v in counts[o].items():
                out[o][k] += v
    return out


def table(counts: dict[str, dict[str, int]]) -> list[str]:
    """One stage per line: boxes, FP, the stage's share of all FP, its precision, ``TP - FP`` (what its boxes do
    to MOTA's numerator: each right box is a miss saved, each false one a false positive added; negative, the
    stage costs MOTA) and what lies under its FP."""
    total = sum(counts[o]["FP"] for o in ORIGINS)
    head = (f"{'stage':<24}{'boxes':>8}{'FP':>7}{'of FP':>7}{'precision':>10}{'TP - FP':>9}"
            + "".join(f"{u:>11}" for u in UNDER))
    lines = [head, "-" * len(head)]
    for o in ORIGINS:
        row = counts[o]
        precision = f"{100 * (1 - row['FP'] / row['boxes']):.1f}%" if row["boxes"] else "-"
        lines.append(f"{o:<24}{row['boxes']:>8}{row['FP']:>7}{100 * row['FP'] / max(total, 1):>6.0f}%"
                     f"{precision:>10}{net(row):>+9}" + "".join(f"{row[u]:>11}" for u in UNDER))
    return lines


def net(row: dict[str, int]) -> int:
    """``TP - FP`` of one stage's boxes (:func:`table`)."""
    return row["boxes"] - 2 * row["FP"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model (for the sequences with frames)")
    parser.add_argument("--config", action="append", type=named_config, metavar="NAME=FILE",
                        help="a configuration to analyse (repeat; FILE empty: the defaults; default: defaults=)")
    parser.add_argument("--groups", type=validation_groups, default=",".join(g for g in GROUPS if g != "clips"),
                        help=f"which parts of the validation set: {', '.join(GROUPS)} (default: %(default)s; the "
                             f"clips are too short for long gaps)")
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--cache", type=Path, default=Path(".cache/validation"),
                        help="frame-rate variants and re-ID features kept between runs (default: %(default)s)")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="track the person detector's boxes (private detections) instead of det/det.txt; only "
                             "the sequences with frames (--groups frames and rates)")
    parser.add_argument("--det-cache", type=Path, default=Path(".cache/detections"),
                        help="where the detector's boxes are kept between runs (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write the counts here")
    args = parser.parse_args(argv)
    groups = args.groups
    if args.detector_model and set(LABEL_GROUPS) & set(groups):
        parser.error("--detector-model detects on frames: the label-only sequences have none; give --groups frames, "
                     "rates or clips")
    if args.detector_model and not Path(args.detector_model).is_file():
        parser.error(f"--detector-model: no such file: {args.detector_model}")
    detections = (f"private detections: the boxes of {Path(args.detector_model).name}" if args.detector_model
                  else "public detections: each sequence's det/det.txt")
    described = dict(args.config or [named_config("defaults=")])
    pool = validation_set(args.data, args.cache, groups, private=bool(args.detector_model))
    too_short = [p for p in sequences(args.data) if read_seqinfo(p).length <= FULL_LENGTH]
    # a name is a validation sequence or a clip left out for its length (each name once); any other is refused
    chosen = {p.name for p in named_sequences(parser, args.data, args.sequences,
                                              list({p.name: p for p in [*(s for _, s in pool), *too_short]}.values()))}
    members = [(g, s) for g, s in pool if s.name in chosen]
    short = [p.name for p in too_short if p.name in chosen]
    if short and {"frames", "rates"} & set(groups):
        print(f"left out, {FULL_LENGTH} frames or fewer (too short for long gaps): {', '.join(short)}",
              file=sys.stderr)
    if not members:
        print(f"no sequences of the groups {','.join(groups)} under {args.data}", file=sys.stderr)
        return 1
    embedders: dict[str, list] = {}
    counts: dict[str, dict[str, dict]] = {name: {} for name in described}
    pairs: dict[str, list] = {name: [] for name in described}
    group_of: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="sotmot-fp-") as tmp:
        for group, seq in members:
            made: dict[str, object] = {}  # configurations that agree on what a preparation reads share one
            for name, (cfg, _) in described.items():
                cfg = for_group(cfg, group, args.model)
                if args.detector_model:
                    cfg = private_config(cfg, seq, str(Path(args.detector_model).resolve()), args.det_cache)
                key = preparation_key(cfg)
                if key not in made:
                    made[key] = prepare_sequence(seq, cfg, features=group_features(seq, cfg, group, args.cache,
                                                                                   embedders))
                result = finish_sequence(made[key], cfg)
                info = result.info
                path = results_path(Path(tmp) / name, info.name)
                write_results(path, result.tracks)
                pairs[name].append((path, info.gt_path, info.length, info.name))
                counts[name][info.name] = classify(frame_errors(path, info.gt_path, info.length, info.name),
                                                   origins(result, cfg.postprocess))
            group_of[info.name] = group
            print(f"{info.name}: " + ", ".join(f"{n} {sum(c[o]['FP'] for o in ORIGINS)} FP"
                                               for n, c in ((n, counts[n][info.name]) for n in described)),
                  file=sys.stderr)
        metrics = {name: evaluate_files(rows).sequences for name, rows in pairs.items()}
    combined = {name: {g: combine([c for s, c in per.items() if group_of[s] == g]) for g in groups
                       if g in group_of.values()} for name, per in counts.items()}
    lines = []
    for name, per_group in combined.items():
        for group, total in per_group.items():
            lines += ["", f"{name} ({described[name][1]}), {group}: combined over "
                      f"{sum(1 for g in group_of.values() if g == group)} sequences"] + table(total)
    lines += ["", "FP per sequence, by stage (" + ", ".join(ORIGINS) + "):"]
    for seq in group_of:
        lines.append(f"  {seq:<24}" + "   ".join(
            f"{name} " + " / ".join(str(counts[name][seq][o]["FP"]) for o in ORIGINS) for name in described))
    lines += ["", f"{detections}; frames: re-ID {Path(args.model).name}; labels: motion only (no frames); "
              f"machine: {machine()}"]
    print("\n".join(lines).lstrip("\n"))
    if args.json:
        write_text_atomic(args.json, json.dumps({
            "machine": machine(), "model": Path(args.model).name, "detections": detections,
            "configs": {name: what for name, (_, what) in described.items()},
            "groups": group_of, "origins": list(ORIGINS), "under": list(UNDER), "combined": combined,
            "sequences": counts,
            "metrics": {name: {s: {k: per[s][k] for k in ("HOTA", "MOTA", "IDF1", "FP", "FN")} for s in group_of}
                        for name, per in metrics.items()},
        }, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
