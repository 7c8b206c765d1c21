#!/usr/bin/env python3
"""How long after a frame comes are its boxes final, when frames come at a camera's pace (``sotmot track --live``).

A live source is tracked in committed windows (:func:`sotmot.stream`, the engine of ``sotmot track --live``):
a frame's boxes are final once the frame a window after it has come and that window is tracked. This plays
each sequence's JPEGs at the sequence's own frame rate, as a camera gives them (each frame read when it is due,
never sooner), and for every frame measures its **lag**: the seconds from the moment it came to the moment its
part of the stream was yielded final. The built-in detector finds the people (a camera has no ``det.txt``);
models are loaded before the clock starts. A tracker that keeps up has a lag of about the window plus the time
to track one window, whatever the stream's length; one that does not falls further behind with each window
(``behind``, :func:`behind`). Per sequence and window: the lag's median and maximum, the
last frame's, the wall time against the stream's length, and HOTA / MOTA / IDF1 of the parts put together
(the same tracks ``sotmot track --window`` writes, box for box: ``tests/test_stream.py``). One run each.

    .venv/bin/python scripts/bench_live.py --sequences PETS09-S2L1,MOT16-09 --windows 10,30 \\
        --json docs/results/live.json
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import sotmot
from common import DEFAULT_DATA, comma_numbers, named_sequences, write_report
from make_results_page import live_table
from sotmot.io import read_seqinfo
from sotmot.types import Tracks


def paced(files: list[Path], rate: float, came: dict[int, float]):
    """The frames of ``files`` as a camera at ``rate`` gives them: frame ``k`` read no sooner than ``(k - 1) /
    rate`` seconds after the first; ``came[k]`` the moment it was handed over (``time.perf_counter``)."""
    import cv2

    start = time.perf_counter()
    for k, path in enumerate(files, 1):
        wait = start + (k - 1) / rate - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        image = cv2.imread(str(path))
        came[k] = time.perf_counter()
        yield image


def live_run(seq: Path, seconds: float, step: int = 1) -> dict:
    """One sequence played at its rate through :func:`sotmot.stream` with windows of ``seconds``, tracking every
    ``step``-th frame (``[input] step``): each frame's lag, the parts, the scores."""
    info = read_seqinfo(seq)
    files = [info.frame_path(k) for k in range(1, info.length + 1)]
    config = {"windows": {"seconds": seconds}, "input": {"step": step}}
    came: dict[int, float] = {}
    lag = np.zeros(info.length)
    parts, tracks = [], []
    start = time.perf_counter()
    for part in sotmot.stream(paced(files, info.frame_rate, came), frame_rate=info.frame_rate, config=config,
                              name=info.name):
        final = time.perf_counter()
        lag[part.first - 1:part.last] = [final - came[k] for k in range(part.first, part.last + 1)]
        parts.append({"first": part.first, "last": part.last, "final_s": round(final - start, 2),
                      "lag_first_s": round(float(lag[part.first - 1]), 2),
                      "lag_last_s": round(float(lag[part.last - 1]), 2)})
        tracks.append(part.tracks)
        print(f"  {info.name}, {seconds:g}-s windows, step {step}: frames {part.first}-{part.last} final "
              f"{final - start:.1f} s after the start (their lag {lag[part.first - 1]:.1f}-{lag[part.last - 1]:.1f} "
              f"s)", flush=True)
    wall = time.perf_counter() - start
    scores = sotmot.evaluate(Tracks.concatenate(tracks), seq)
    return {"sequence": info.name, "frame_rate": info.frame_rate, "frames": info.length,
            "size": f"{info.width} x {info.height}", "window_s": seconds, "step": step,
            "stream_s": round(info.length / info.frame_rate, 1), "wall_s": round(wall, 1),
            "lag_median_s": round(float(np.median(lag)), 1), "lag_max_s": round(float(lag.max()), 1),
            "lag_last_frame_s": round(float(lag[-1]), 1),
            "behind_s": behind(parts),
            "parts": parts, **{m: round(scores[m], 2) for m in ("HOTA", "MOTA", "IDF1")}}


def behind(parts: list[dict]) -> float | None:
    """How much later the last frame of the last part cut by a window was final than the first part's last frame
    (seconds): about 0 where tracking keeps up, growing with the stream where it does not. The stream's last part
    ends with the stream and waits for no window, so it is left out; None with fewer than two other parts."""
    cut = parts[:-1]
    return round(cut[-1]["lag_last_s"] - cut[0]["lag_last_s"], 1) if len(cut) >= 2 else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--sequences", default="PETS09-S2L1,MOT16-09",
                        help="comma-separated sequences with frames (default: %(default)s)")
    parser.add_argument("--windows", default="10,30", help="window lengths in seconds (default: %(default)s)")
    parser.add_argument("--steps", default="1", help="track every k-th frame, for each k of this comma-separated "
                        "list ([input] step; default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write every number here")
    args = parser.parse_args(argv)
    seqs = named_sequences(parser, args.data, args.sequences)
    windows = comma_numbers(parser, "--windows", args.windows)
    steps = comma_numbers(parser, "--steps", args.steps, int)
    warm = read_seqinfo(seqs[0])  # models loaded and compiled before any clock starts
    list(sotmot.stream(paced([warm.frame_path(1), warm.frame_path(2)], warm.frame_rate, {}),
                       frame_rate=warm.frame_rate))
    rows = [live_run(seq, seconds, step) for seq in seqs for seconds in windows for step in steps]
    print("\n".join(live_table(rows)))
    write_report(args.json, "bench_live.py", argv, detections="the built-in detector (person-detection-0202)",
                 rows=rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
