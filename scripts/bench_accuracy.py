#!/usr/bin/env python3
"""Accuracy and speed of sotmot on every sequence with frames in the shared data folder.

Tracks each sequence with the default configuration, scores it with TrackEval
and prints HOTA, MOTA, IDF1, IDSW, FP, FN per sequence, for the MOT16 clips
combined, and over everything, plus frames per second of the whole pipeline
(reading, appearance, tracklets, association, post-processing; not scoring).
Writes the table and the machine it ran on as JSON.

    python scripts/bench_accuracy.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --json bench_accuracy.json

The reference rows are the established trackers' scores quoted in issue #2
(measured by the project on the same det.txt files with TrackEval); they are
not re-measured by this script.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from sotmot.config import TrackerConfig, load_config
from sotmot.evaluate import evaluate_files
from sotmot.io import results_path, write_results
from sotmot.pipeline import track_sequence

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_DATA = Path(os.environ.get("SOTMOT_DATA", ROOT.parent / "shared" / "data"))
COLUMNS = ("HOTA", "MOTA", "IDF1", "IDSW", "FP", "FN")
REFERENCE = {  # issue #2: best established tracker per group, default settings, same det.txt
    "PETS09-S2L1": ("ByteTrack", {"HOTA": 36.3, "IDF1": 50.4, "MOTA": 61.9}),
    "MOT16 clips": ("SORT", {"HOTA": 39.8, "IDF1": 45.1, "MOTA": 24.4}),
}


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}, Python {platform.python_version()}"


def sequences(data: Path) -> list[Path]:
    """Sequence folders with frames (the label-only MOT16-labels folders are skipped)."""
    return sorted(p for p in data.iterdir() if (p / "seqinfo.ini").is_file() and (p / "img1").is_dir())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--merger", default="greedy")
    parser.add_argument("--config", type=Path, help="tracker configuration file")
    parser.add_argument("--json", type=Path, help="write results here")
    parser.add_argument("--results", type=Path, help="keep the results files here (default: a temp folder)")
    args = parser.parse_args(argv)

    config = load_config(args.config) if args.config else TrackerConfig()
    config = config.replace("appearance", model=args.model)
    seqs = sequences(args.data)
    if not seqs:
        print(f"no sequences with frames under {args.data}", file=sys.stderr)
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        out = args.results or Path(tmp)
        runs = {}
        pairs = []
        for seq in seqs:
            start = time.perf_counter()
            result = track_sequence(seq, config, merger=args.merger, progress=sys.stderr.isatty())
            seconds = time.perf_counter() - start
            path = results_path(out, result.info.name)
            write_results(path, result.tracks)
            pairs.append((path, result.info.gt_path, result.info.length, result.info.name))
            runs[result.info.name] = {"frames": result.info.length, "seconds": seconds,
                                      "fps": result.info.length / seconds,
                                      "stage_seconds": result.timings}
            print(f"{result.info.name}: {result.info.length / seconds:.1f} frames/s", file=sys.stderr)
        report = evaluate_files(pairs)
        mot16 = [p for p in pairs if p[3].startswith("MOT16")]
        report_mot16 = evaluate_files(mot16) if mot16 else None
    rows = [(name, report.sequences[name], runs[name]["fps"]) for name in report.sequences]
    total_frames = sum(r["frames"] for r in runs.values())
    total_seconds = sum(r["seconds"] for r in runs.values())
    if report_mot16 is not None:
        frames16 = sum(runs[p[3]]["frames"] for p in mot16)
        seconds16 = sum(runs[p[3]]["seconds"] for p in mot16)
        rows.append(("MOT16 clips", report_mot16.combined, frames16 / seconds16))
    rows.append(("ALL", report.combined, total_frames / total_seconds))
    head = f"{'sequence':<18}" + "".join(f"{c:>8}" for c in COLUMNS) + f"{'fps':>8}"
    lines = [head, "-" * len(head)]
    for name, values, fps in rows:
        cells = "".join(f"{values[c]:8.1f}" if c in ("HOTA", "MOTA", "IDF1") else f"{values[c]:8.0f}"
                        for c in COLUMNS)
        lines.append(f"{name:<18}{cells}{fps:8.1f}")
    for group, (tracker, ref) in REFERENCE.items():
        lines.append(f"{'ref ' + tracker:<18}" + "".join(f"{ref[c]:8.1f}" if c in ref else f"{'':>8}"
                                                          for c in COLUMNS) + f"   ({group}, issue #2)")
    print("\n".join(lines))
    print(f"machine: {machine()}")
    if args.json:
        args.json.write_text(json.dumps({
            "machine": machine(), "merger": args.merger, "model": args.model, "config": config.to_dict(),
            "sequences": report.sequences, "mot16_clips_combined": report_mot16.combined if report_mot16 else None,
            "combined": report.combined, "speed": runs, "reference_issue_2": REFERENCE,
        }, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
