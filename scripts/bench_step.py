#!/usr/bin/env python3
"""What tracking every k-th frame (``[input] step``, ``sotmot track --step K``) costs and gains: accuracy against
the ground truth of every frame, and the time of the run.

Each sequence is tracked whole with ``step`` = 1, 2, 3, ... (frames 1, 1 + k, ... tracked at the frame rate
divided by k; the frames between get their tracks' boxes on the line between the tracked frames around them,
:mod:`sotmot.stepping`), from its public detections and from the built-in detector, and scored by TrackEval on
**every** frame. A step is run where the tracked rate stays at ``--min-fps`` or above. Per row: HOTA, MOTA, IDF1,
FP, FN, IDSW, the boxes filled between tracked frames, and the run's seconds (models loaded before the clock
starts; one run each, on this machine, in this process). Public and model detections are separate tables, as
MOTChallenge reports them. ``--window SECONDS`` tracks each run in committed windows of that length (of the
tracked frames at a step: ``sotmot track --step K --window SECONDS``) instead of whole.

    .venv/bin/python scripts/bench_step.py --json docs/results/step.json
    .venv/bin/python scripts/bench_step.py --window 10 --detections public --json /tmp/step_windows.json
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import sotmot
from common import DEFAULT_DATA, comma_numbers, named_sequences, write_report
from make_results_page import step_table
from sotmot.io import read_seqinfo

SHOWN = ("HOTA", "MOTA", "IDF1", "FP", "FN", "IDSW")


def step_run(seq: Path, step: int, detections: str, window: float = 0.0) -> dict:
    """``seq`` tracked at every ``step``-th frame from ``detections`` ("public" or "model"), in committed windows
    of ``window`` seconds (0: whole), scored on every frame."""
    info = read_seqinfo(seq)
    config = {"input": {"step": step}, "windows": {"seconds": window}}
    if detections == "model":
        config["detection"] = {"source": "model"}
    start = time.perf_counter()
    result = sotmot.track(seq, config=config)
    seconds = time.perf_counter() - start
    scores = result.scores(gt=seq)
    row = {"sequence": info.name, "detections": detections, "frame_rate": info.frame_rate, "step": step,
           "window_seconds": window,
           "tracked_fps": round(info.frame_rate / step, 2), "frames": info.length, "seconds": round(seconds, 1),
           "filled": int(result.tracks.interpolated.sum()), "boxes": len(result.tracks),
           **{m: round(float(scores[m]), 2) for m in SHOWN}}
    print(f"  {info.name} ({detections}), step {step}: HOTA {row['HOTA']:.1f}, MOTA {row['MOTA']:.1f}, "
          f"{seconds:.1f} s", flush=True)
    return row


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--sequences", default="PETS09-S2L1,TUD-Stadtmitte,MOT16-09,MOT17-09-FRCNN,MOT17-09-SDP",
                        help="comma-separated sequences with frames and ground truth (default: %(default)s)")
    parser.add_argument("--steps", default="1,2,3", help="steps to run (default: %(default)s)")
    parser.add_argument("--min-fps", type=float, default=7.0,
                        help="run a step above 1 only where the tracked rate stays at this or above "
                             "(default: %(default)s)")
    parser.add_argument("--detections", default="public,model",
                        help="public (the sequence's det.txt), model (the built-in detector), or both "
                             "(default: %(default)s)")
    parser.add_argument("--window", type=float, default=0.0, metavar="SECONDS",
                        help="track in committed windows of this many seconds (default: 0, whole)")
    parser.add_argument("--json", type=Path, help="write every number here")
    args = parser.parse_args(argv)
    seqs = named_sequences(parser, args.data, args.sequences)
    steps = sorted(set(comma_numbers(parser, "--steps", args.steps, int)))
    kinds = [k for k in args.detections.split(",") if k]
    if not kinds or set(kinds) - {"public", "model"}:
        parser.error(f"--detections: {args.detections!r}; expected public, model or public,model")
    warm = read_seqinfo(seqs[0])  # models loaded and compiled before any clock starts
    sotmot.track([warm.frame_path(1), warm.frame_path(2)], frame_rate=warm.frame_rate)
    rows = []
    for kind in kinds:
        for seq in seqs:
            rate = read_seqinfo(seq).frame_rate
            rows += [step_run(seq, step, kind, args.window) for step in steps
                     if step == 1 or rate / step >= args.min_fps]
    for kind in kinds:
        print(f"\n{kind} detections\n" + "\n".join(step_table([r for r in rows if r["detections"] == kind])))
    write_report(args.json, "bench_step.py", argv, rows=rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
