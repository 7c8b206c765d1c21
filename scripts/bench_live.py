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
last frame's, the wall time against the stream's length, the process's resident memory (its peak while the
stream plays, and when each part is final: flat where memory is bounded), and HOTA / MOTA / IDF1 of the parts
put together (the same tracks ``sotmot track --window`` writes, box for box: ``tests/test_stream.py``). One run
each. ``NAME:K`` plays the sequence K times back to back (a stream K times as long; its ground truth repeated
with each copy's people new, as ``bench_long.py`` repeats it), to see lag and memory stay level over time.

    .venv/bin/python scripts/bench_live.py --sequences PETS09-S2L1,MOT16-09 --windows 10,30 \\
        --json docs/results/live.json
    .venv/bin/python scripts/bench_live.py --sequences MOT16-09:8 --windows 30 --steps 2 --json /tmp/live_long.json
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

import sotmot
from bench_long import repeated_gt
from common import DEFAULT_DATA, ROOT, comma_numbers, named_sequences, write_report
from make_results_page import live_table
from sotmot.io import read_seqinfo
from sotmot.stepping import full_frames, tracked_count
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


def rss_mb() -> float:
    """This process's resident memory now, in MB (Linux: ``/proc/self/statm``)."""
    import os

    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


@contextmanager
def peak_rss(every: float = 0.1):
    """The process's resident memory sampled every ``every`` seconds in a thread while the block runs: yields a
    list whose one number is the peak so far (MB)."""
    peak, done = [rss_mb()], threading.Event()

    def sample() -> None:
        while not done.wait(every):
            peak[0] = max(peak[0], rss_mb())

    thread = threading.Thread(target=sample, daemon=True)
    thread.start()
    try:
        yield peak
    finally:
        done.set()
        thread.join()
        peak[0] = max(peak[0], rss_mb())


def live_run(seq: Path, seconds: float, step: int = 1, copies: int = 1, cache: Path = ROOT / ".cache" / "long"
             ) -> dict:
    """One sequence played at its rate ``copies`` times back to back through :func:`sotmot.stream` with windows of
    ``seconds``, tracking every ``step``-th frame (``[input] step``): each frame's lag, the parts, the memory, the
    scores (against the ground truth repeated as many times, kept in ``cache``)."""
    info = read_seqinfo(seq)
    files = [info.frame_path(k) for k in range(1, info.length + 1)] * copies
    length = len(files)
    name = info.name if copies == 1 else f"{info.name} x{copies}"
    config = {"windows": {"seconds": seconds}, "input": {"step": step}}
    came: dict[int, float] = {}
    lag = np.zeros(length)
    parts, tracks = [], []
    start = time.perf_counter()
    with peak_rss() as peak:
        for part in sotmot.stream(paced(files, info.frame_rate, came), frame_rate=info.frame_rate, config=config,
                                  name=info.name):
            final = time.perf_counter()
            lag[part.first - 1:part.last] = [final - came[k] for k in range(part.first, part.last + 1)]
            parts.append({"first": part.first, "last": part.last, "final_s": round(final - start, 2),
                          "lag_first_s": round(float(lag[part.first - 1]), 2),
                          "lag_last_s": round(float(lag[part.last - 1]), 2), "rss_mb": round(rss_mb())})
            tracks.append(part.tracks)
            print(f"  {name}, {seconds:g}-s windows, step {step}: frames {part.first}-{part.last} final "
                  f"{final - start:.1f} s after the start (their lag {lag[part.first - 1]:.1f}-"
                  f"{lag[part.last - 1]:.1f} s; {parts[-1]['rss_mb']} MB resident)", flush=True)
        wall = time.perf_counter() - start
    gt = seq if copies == 1 else repeated_gt(seq, copies, cache)
    scores = sotmot.evaluate(Tracks.concatenate(tracks), gt, length=length, name=info.name)
    last_tracked = int(full_frames(tracked_count(length, step), step))
    cut = [p["rss_mb"] for p in cut_parts(parts, last_tracked)] or [parts[-1]["rss_mb"]]
    return {"sequence": name, "frame_rate": info.frame_rate, "frames": length, "copies": copies,
            "size": f"{info.width} x {info.height}", "window_s": seconds, "step": step,
            "stream_s": round(length / info.frame_rate, 1), "wall_s": round(wall, 1),
            "lag_median_s": round(float(np.median(lag)), 1), "lag_max_s": round(float(lag.max()), 1),
            "lag_last_frame_s": round(float(lag[-1]), 1),
            "behind_s": behind(parts, last_tracked), "peak_rss_mb": round(peak[0]),
            "rss_first_part_mb": cut[0], "rss_last_cut_part_mb": cut[-1],
            "parts": parts, **{m: round(scores[m], 2) for m in ("HOTA", "MOTA", "IDF1")}}


def cut_parts(parts: list[dict], last_tracked: int | None = None) -> list[dict]:
    """The parts a window cut: all but those that reach ``last_tracked`` (the last frame tracked), the stream's own
    end, which waits for no window (at a step the frames after the last tracked one are a part of their own);
    without ``last_tracked``, all but the last part."""
    return [p for p in parts if p["last"] < last_tracked] if last_tracked is not None else parts[:-1]


def behind(parts: list[dict], last_tracked: int | None = None) -> float | None:
    """How much later the last frame of the last part cut by a window (:func:`cut_parts`) was final than the first
    part's last frame (seconds): about 0 where tracking keeps up, growing with the stream where it does not; None
    with fewer than two such parts."""
    cut = cut_parts(parts, last_tracked)
    return round(cut[-1]["lag_last_s"] - cut[0]["lag_last_s"], 1) if len(cut) >= 2 else None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--sequences", default="PETS09-S2L1,MOT16-09",
                        help="comma-separated sequences with frames, NAME or NAME:K (played K times back to back; "
                             "default: %(default)s)")
    parser.add_argument("--windows", default="10,30", help="window lengths in seconds (default: %(default)s)")
    parser.add_argument("--steps", default="1", help="track every k-th frame, for each k of this comma-separated "
                        "list ([input] step; default: %(default)s)")
    parser.add_argument("--cache", type=Path, default=ROOT / ".cache" / "long",
                        help="where the repeated ground truth of NAME:K is kept (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write every number here")
    args = parser.parse_args(argv)
    entries = [item.partition(":") for item in args.sequences.split(",") if item]
    copies = comma_numbers(parser, "--sequences", ",".join(k or "1" for _, _, k in entries), int)
    if min(copies) < 1:
        parser.error(f"--sequences: {args.sequences!r}; K in NAME:K is a number of copies, 1 or more")
    found = {seq.name: seq for seq in named_sequences(parser, args.data, ",".join(name for name, _, _ in entries))}
    seqs = [found[name] for name, _, _ in entries]  # in the order given, each with its K
    windows = comma_numbers(parser, "--windows", args.windows)
    steps = comma_numbers(parser, "--steps", args.steps, int)
    warm = read_seqinfo(seqs[0])  # models loaded and compiled before any clock starts
    list(sotmot.stream(paced([warm.frame_path(1), warm.frame_path(2)], warm.frame_rate, {}),
                       frame_rate=warm.frame_rate))
    rows = [live_run(seq, seconds, step, k, args.cache) for seq, k in zip(seqs, copies) for seconds in windows
            for step in steps]
    print("\n".join(live_table(rows)))
    write_report(args.json, "bench_live.py", argv, detections="the built-in detector (person-detection-0202)",
                 rows=rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
