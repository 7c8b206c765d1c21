#!/usr/bin/env python3
"""Scaling of the long-term association solvers on the full-length MOT16 detection sets.

Uses ``../shared/data/MOT16-labels`` (detections and ground truth, no pixels).
Because there are no pixels, the appearance feature is replaced, **for this
benchmark only**, by an appearance-free one computed from the box size (a
smooth function of log width and log height, so boxes of similar size have
high affinity). That makes far more pairs pass the affinity gate than real
re-ID features do: it is a stress test of the solvers, not a tracking result.

For 10%, 25%, 50% and 100% of each sequence's frames (the first frames), it
builds tracklets with the default configuration, then times each solver and
measures its peak Python memory (tracemalloc, in a separate run so that the
timing is not slowed), and fits the growth exponent ``time ~ tracklets^k``.
With ``--tile N`` it instead repeats each whole sequence 1, 2, 5 and N times
one after the other in time, to see how a solver grows on long sequences.

    python scripts/bench_solvers.py --json bench_solvers.json
    python scripts/bench_solvers.py --sequences MOT16-04 --tile 10 --solvers greedy,flow --repeat 1
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

from common import named_sequences
from sotmot.association import get_solver
from sotmot.appearance import normalize
from sotmot.config import TrackerConfig
from sotmot.io import read_detections, read_seqinfo, write_text_atomic
from sotmot.preprocess import preprocess
from sotmot.tracklets import build_tracklets
from sotmot.types import Detections
from sotmot.versions import machine

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_LABELS = Path(os.environ.get("SOTMOT_DATA", ROOT.parent / "shared" / "data")) / "MOT16-labels"
FRACTIONS = (0.10, 0.25, 0.50, 1.00)


def size_features(boxes: np.ndarray, dim: int = 16) -> np.ndarray:
    """Appearance-free features: Fourier features of (log w, log h); similar sizes, similar features."""
    logs = np.log(np.asarray(boxes, dtype=np.float64)[:, 2:4])
    k = np.arange(1, dim // 4 + 1) * 2.0
    parts = [np.cos(np.outer(logs[:, c], k)) for c in (0, 1)] + [np.sin(np.outer(logs[:, c], k)) for c in (0, 1)]
    return normalize(np.concatenate(parts, axis=1))


def tiled(dets: Detections, length: int, times: int) -> Detections:
    """The detections of a sequence repeated ``times`` times one after the other (frames offset by ``length``)."""
    offsets = np.repeat(np.arange(times) * length, len(dets))
    return Detections(frames=np.tile(dets.frames, times) + offsets, boxes=np.tile(dets.boxes, (times, 1)),
                      scores=np.tile(dets.scores, times))


def timed(solver, tracklets, config, repeat: int) -> tuple[float, int]:
    """Best-of-``repeat`` seconds and the number of trajectories."""
    best, groups = float("inf"), 0
    for _ in range(repeat):
        gc.collect()
        start = time.perf_counter()
        result = solver(tracklets, config)
        best = min(best, time.perf_counter() - start)
        groups = len(result.groups)
    return best, groups


def peak_mb(solver, tracklets, config) -> float:
    gc.collect()
    tracemalloc.start()
    solver(tracklets, config)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--labels", type=Path, default=DEFAULT_LABELS, help="MOT16-labels folder (default: %(default)s)")
    parser.add_argument("--solvers", "--mergers", dest="solvers", default="greedy,flow",
                        help="solvers to time (default: %(default)s)")
    parser.add_argument("--sequences", default="", help="comma-separated subset, e.g. MOT16-04")
    parser.add_argument("--repeat", type=int, default=3, help="timing runs per point (best is kept)")
    parser.add_argument("--tile", type=int, default=0,
                        help="instead of the fractions: each sequence whole, then repeated 2, 5 and TILE times one "
                             "after the other in time (e.g. --sequences MOT16-04 --tile 10: ~10k frames)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    solvers_asked = args.solvers.split(",")
    config = TrackerConfig()
    seqs = sorted(p for p in args.labels.iterdir() if (p / "seqinfo.ini").is_file())
    seqs = named_sequences(parser, args.labels, args.sequences, seqs)
    rows = []
    head = f"{'sequence':<10}{'frames':>7}{'dets':>7}{'tracklets':>10}" + "".join(
        f"{m + ' s':>10}{m + ' MB':>10}{m + ' traj':>11}" for m in solvers_asked)
    print(head)
    print("-" * len(head))
    for seq in seqs:
        info = read_seqinfo(seq)
        gaps = config.association.at(info.frame_rate)
        dets_all = preprocess(read_detections(info.det_path, info.length), config.preprocess)
        steps = [(1.0, t) for t in sorted({1, 2, 5, args.tile})] if args.tile > 1 else [(f, 1) for f in FRACTIONS]
        for fraction, times in steps:
            last = max(1, int(round(fraction * info.length)))
            dets = dets_all.subset(np.flatnonzero(dets_all.frames <= last))
            if times > 1:
                dets, last = tiled(dets, info.length, times), info.length * times
            tracklets = tuple(build_tracklets(dets, size_features(dets.boxes), info.frame_rate, config.tracklets))
            row = {"sequence": info.name, "fraction": fraction, "frames": last, "detections": len(dets),
                   "tracklets": len(tracklets)}
            cells = ""
            for m in solvers_asked:
                solver = get_solver(m)
                seconds, groups = timed(solver, tracklets, gaps, args.repeat)
                mb = peak_mb(solver, tracklets, gaps)
                row[m] = {"seconds": seconds, "peak_mb": mb, "trajectories": groups}
                cells += f"{seconds:10.3f}{mb:10.1f}{groups:11d}"
            rows.append(row)
            print(f"{info.name:<10}{last:7d}{len(dets):7d}{len(tracklets):10d}{cells}", flush=True)
    fits = {}
    for m in solvers_asked:
        n = np.array([r["tracklets"] for r in rows], float)
        t = np.array([r[m]["seconds"] for r in rows], float)
        ok = (n > 0) & (t > 0)
        if ok.sum() >= 2:
            k, _ = np.polyfit(np.log(n[ok]), np.log(t[ok]), 1)
            fits[m] = float(k)
    print("growth exponent (time ~ tracklets^k): " + ", ".join(f"{m}: k = {k:.2f}" for m, k in fits.items()))
    print(f"machine: {machine()}")
    print("affinity: appearance-free box-size features (no pixels in MOT16-labels); a solver stress test")
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "rows": rows, "growth_exponent": fits,
                                                 "note": "appearance-free box-size affinity; not a tracking result"},
                                                indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
