#!/usr/bin/env python3
"""What a long video costs: wall time, frames/s, peak memory and peak temporary disk, and how they grow with length.

For each ``--sequences`` entry ``NAME:K`` (default: PETS09-S2L1 up to 6 times,
MOT16-09 up to 8 times) the shared sequence is played ``k`` times in a row
for each ``k`` of ``--factors`` up to ``K``, written once as an MPEG-4 video
(cached under ``--cache``) with its public detections shifted to match, and
tracked end to end by ``sotmot track VIDEO --det DET`` in a child process under
``/usr/bin/time`` (peak resident memory). The child's ``TMPDIR`` is a fresh
folder whose size is sampled every 0.1 s (peak temporary disk; the results
folder is not counted). The growth exponent is the least-squares slope of
log(time) and log(peak memory) against log(frames): 1 is linear.

    .venv/bin/python scripts/bench_long.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --json bench_long.json

With ``--windows 30,60`` it measures committed windows instead (issue #45): for each
``NAME:K`` the video of each ``--factors`` length (ground truth repeated, each copy's
people under new ids), tracked whole, then in windows of each length serially, and
the first window length also on ``--window-workers`` processes: wall time, peak
RSS, HOTA / IDF1 / MOTA / IDSW, the ID switches at window joins (in an overlap or
the frame after it), and whether the parallel results equal the serial.

    .venv/bin/python scripts/bench_long.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --sequences MOT16-09:16 --factors 8,16 --windows 30,60 --json docs/results/windows.json
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np

from common import DEFAULT_DATA, ROOT, run_timed
from sotmot.io import read_seqinfo, write_text_atomic
from sotmot.versions import machine

#: The issue's targets for the longest MOT16-09 video (8x, 4,200 frames at 1080p).
TARGETS = {"peak_rss_mb": 1536, "peak_tmp_mb": 100, "exponent": 1.1}


def repeated_video(seq: Path, factor: int, cache: Path) -> tuple[Path, Path]:
    """``seq`` played ``factor`` times as ``cache/<name>-x<factor>.mp4`` and its shifted detections (made once)."""
    import cv2

    from sotmot.io import FrameReader, atomic_path

    info = read_seqinfo(seq)
    video = cache / f"{info.name}-x{factor}.mp4"
    det = cache / f"{info.name}-x{factor}.det.txt"
    if not det.is_file():
        lines = info.det_path.read_text().splitlines()
        shifted = [f"{int(float(line.split(',', 1)[0])) + r * info.length},{line.split(',', 1)[1]}"
                   for r in range(factor) for line in lines if line.strip()]
        cache.mkdir(parents=True, exist_ok=True)
        with atomic_path(det) as tmp:
            tmp.write_text("\n".join(shifted) + "\n")
    if not video.is_file():
        cache.mkdir(parents=True, exist_ok=True)
        with atomic_path(video) as tmp:
            part = tmp.with_suffix(".mp4")
            writer = cv2.VideoWriter(str(part), cv2.VideoWriter_fourcc(*"mp4v"), info.frame_rate,
                                     (info.width, info.height))
            reader = FrameReader(info, cache_size=1)
            for _ in range(factor):
                for f in range(1, info.length + 1):
                    writer.write(np.ascontiguousarray(reader(f)))
            writer.release()
            part.replace(tmp)
    return video, det


def folder_bytes(folder: Path) -> int:
    total = 0
    for root, _, files in os.walk(folder):
        for name in files:
            try:
                total += (Path(root) / name).stat().st_size
            except OSError:
                pass  # removed while we looked
    return total


def measure(command: list[str], tmpdir: Path) -> dict[str, float]:
    """Wall seconds, CPU seconds of the run and its children, the share of the cores they kept busy (CPU seconds
    over wall seconds times the cores: with two cores, a run already at 0.9 can go no more than 1 / 0.9 times
    faster on more processes), peak RSS (MB, :func:`common.run_timed`) and peak size of ``tmpdir`` (MB, the
    child's ``TMPDIR``) of one run."""
    peak = [0]
    done = threading.Event()

    def watch() -> None:
        while not done.is_set():
            peak[0] = max(peak[0], folder_bytes(tmpdir))
            done.wait(0.1)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    try:
        got = run_timed(command, env={**os.environ, "TMPDIR": str(tmpdir)})
    finally:
        done.set()
        watcher.join()
    return {"seconds": got["seconds"], "cpu_seconds": got["cpu_seconds"],
            "busy": got["cpu_seconds"] / (got["seconds"] * (os.cpu_count() or 1)), "peak_rss_mb": got["peak_rss_mb"],
            "peak_tmp_mb": peak[0] / 2**20}


def repeated_gt(seq: Path, factor: int, cache: Path) -> Path:
    """``seq``'s ground truth for the video played ``factor`` times: frames shifted, each copy's ids new."""
    from sotmot.io import atomic_path

    info = read_seqinfo(seq)
    gt = cache / f"{info.name}-x{factor}.gt.txt"
    if not gt.is_file():
        rows = [line.split(",") for line in info.gt_path.read_text().splitlines() if line.strip()]
        top = max(int(float(r[1])) for r in rows)
        lines = [",".join([str(int(float(r[0])) + k * info.length), str(int(float(r[1])) + k * top), *r[2:]])
                 for k in range(factor) for r in rows]
        cache.mkdir(parents=True, exist_ok=True)
        with atomic_path(gt) as tmp:
            tmp.write_text("\n".join(lines) + "\n")
    return gt


def join_switches(results: Path, gt: Path, length: int, name: str, windows: list) -> int:
    """ID switches (TrackEval's CLEAR matching, :func:`sotmot.scoring.frame_errors`) at window joins: in a frame
    of an overlap of two consecutive ``windows`` (``[(first, last), ...]``) or the frame after it, where one
    window's identities hand over to the next's. A person unseen across the whole overlap and matched later
    under a new id is not counted here."""
    from sotmot.scoring import frame_errors

    spans = [(after[0], before[1] + 1) for before, after in zip(windows, windows[1:])]
    matched = frame_errors(results, gt, length, name).matched
    return sum(any(first <= frame <= last for first, last in spans) and switch
               for frame, rows in matched.items() for *_, switch in rows)


def windows_experiment(args, factors: list[int]) -> int:
    """Whole-sequence against windowed tracking of long videos (``--windows``): time, memory, accuracy."""
    from sotmot.api import evaluate

    sotmot = Path(sys.executable).with_name("sotmot")
    seconds = [float(w) for w in args.windows.split(",")]
    rows = []
    for item in args.sequences.split(","):
        name, most = item.split(":")
        seq = args.data / name
        info = read_seqinfo(seq)
        for factor in sorted({f for f in factors if f <= int(most)}):
            video, det = repeated_video(seq, factor, args.cache)
            gt = repeated_gt(seq, factor, args.cache)
            modes = [("whole", [])] + [(f"W={w:g}s", ["--window", f"{w:g}"]) for w in seconds]
            modes.append((f"W={seconds[0]:g}s, {args.window_workers} workers",
                          ["--window", f"{seconds[0]:g}", "--workers", str(args.window_workers)]))
            texts = {}
            for mode, extra in modes:
                with tempfile.TemporaryDirectory(prefix="sotmot-long-") as tmp:
                    scratch = Path(tmp) / "tmp"
                    scratch.mkdir()
                    out = Path(tmp) / "out"
                    got = measure([str(sotmot), "track", str(video), "--det", str(det), "--out", str(out),
                                   "--reid-model", args.model, "-q", *extra], scratch)
                    results = out / f"{video.stem}.txt"
                    texts[mode] = results.read_bytes()
                    scores = evaluate(results, gt, length=info.length * factor, name=f"{name}-x{factor}")
                    record = json.loads((out / f"{video.stem}.run.json").read_text())
                    windows = record.get("windows", {}).get("plan", [[1, info.length * factor]])
                    at_joins = join_switches(results, gt, info.length * factor, f"{name}-x{factor}", windows)
                joins = record.get("windows", {}).get("joins", [])
                row = {"sequence": name, "factor": factor, "frames": info.length * factor, "mode": mode, **got,
                       "fps": info.length * factor / got["seconds"], "windows": len(windows),
                       "joined": sum(j["joined"] for j in joins),
                       **{k: scores[k] for k in ("HOTA", "IDF1", "MOTA", "IDSW")}, "IDSW_joins": at_joins}
                rows.append(row)
                print(f"{name} x{factor} {mode}: {got['seconds']:.0f} s ({row['fps']:.1f} frames/s, cores "
                      f"{100 * got['busy']:.0f} % busy), peak RSS "
                      f"{got['peak_rss_mb']:.0f} MB, HOTA {row['HOTA']:.2f} IDF1 {row['IDF1']:.2f} MOTA "
                      f"{row['MOTA']:.2f} IDSW {row['IDSW']:.0f}", flush=True)
            parallel = modes[-1][0]
            rows[-1]["equals_serial"] = texts[parallel] == texts[f"W={seconds[0]:g}s"]
    print("\n| video | mode | wall s | frames/s | busy | peak RSS MB | HOTA | IDF1 | MOTA | IDSW | at joins | "
          "windows |\n|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['sequence']} x{r['factor']} | {r['mode']} | {r['seconds']:.0f} | {r['fps']:.1f} | "
              f"{100 * r['busy']:.0f} % | "
              f"{r['peak_rss_mb']:.0f} | {r['HOTA']:.2f} | {r['IDF1']:.2f} | {r['MOTA']:.2f} | {r['IDSW']:.0f} | "
              f"{r['IDSW_joins']} | {r['windows']} |")
    print(f"machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"script": "scripts/bench_long.py --windows", "machine": machine(),
                                                 "rows": rows}, indent=2) + "\n")
    return 0


def full_length_windows(args) -> int:
    """The accuracy cost of windows (each ``--windows`` length) on each full-length folder: whole against
    windowed, from the folder's own frames and public detections."""
    from sotmot.api import evaluate

    sotmot = Path(sys.executable).with_name("sotmot")
    modes = [("whole", [])] + [(f"W={float(w):g}s", ["--window", f"{float(w):g}"]) for w in args.windows.split(",")]
    rows = []
    for name in args.full_length.split(","):
        seq = args.data / name
        for mode, extra in modes:
            with tempfile.TemporaryDirectory(prefix="sotmot-windows-") as tmp:
                out = Path(tmp) / "out"
                subprocess.run([str(sotmot), "track", str(seq), "--out", str(out), "--reid-model", args.model, "-q",
                                *extra], check=True)
                info = read_seqinfo(seq)
                scores = evaluate(out / f"{info.name}.txt", seq)
                record = json.loads((out / f"{info.name}.run.json").read_text())
                windows = record.get("windows", {}).get("plan", [[1, info.length]])
                at_joins = join_switches(out / f"{info.name}.txt", info.gt_path, info.length, info.name, windows)
            rows.append({"sequence": name, "mode": mode, "windows": len(windows),
                         **{k: scores[k] for k in ("HOTA", "IDF1", "MOTA", "IDSW")}, "IDSW_joins": at_joins})
            r = rows[-1]
            print(f"{name} {mode}: {r['windows']} windows, HOTA {r['HOTA']:.2f} IDF1 {r['IDF1']:.2f} MOTA "
                  f"{r['MOTA']:.2f} IDSW {r['IDSW']:.0f} ({at_joins} at joins)", flush=True)
    if args.json:
        write_text_atomic(args.json, json.dumps({"script": "scripts/bench_long.py --full-length", "machine": machine(),
                                                 "full_length": rows}, indent=2) + "\n")
    return 0


def exponent(frames: list[int], values: list[float]) -> float:
    """Slope of log(value) against log(frames): how a cost grows with length (1 = linearly)."""
    if len(frames) < 2:
        return float("nan")
    return float(np.polyfit(np.log(frames), np.log(values), 1)[0])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--sequences", default="PETS09-S2L1:6,MOT16-09:8",
                        help="NAME:K, comma-separated: each sequence up to K times (default: %(default)s)")
    parser.add_argument("--factors", default="1,2,4,8", help="lengths tried, in multiples of the sequence "
                        "(those up to each K, and K itself; default: %(default)s)")
    parser.add_argument("--cache", type=Path, default=ROOT / ".cache" / "long",
                        help="where the long videos are kept between runs (default: %(default)s)")
    parser.add_argument("--json", type=Path, help="write every number here")
    parser.add_argument("--windows", metavar="S,S", help="measure committed windows of these lengths (seconds)")
    parser.add_argument("--window-workers", type=int, default=2, help="processes for the parallel windowed run")
    parser.add_argument("--full-length", metavar="NAME,NAME",
                        help="with --windows: track these folders whole and in windows instead (accuracy only)")
    args = parser.parse_args(argv)
    if args.windows and args.full_length:
        return full_length_windows(args)
    if not Path("/usr/bin/time").exists():
        print("needs /usr/bin/time (Debian package 'time')", file=sys.stderr)
        return 2
    sotmot = Path(sys.executable).with_name("sotmot")
    factors = sorted({int(f) for f in args.factors.split(",")})
    if args.windows:
        return windows_experiment(args, factors)
    rows, growth = [], {}
    for item in args.sequences.split(","):
        name, most = item.split(":")
        seq = args.data / name
        info = read_seqinfo(seq)
        mine = sorted({f for f in factors if f <= int(most)} | {int(most)})
        seq_rows = []
        for factor in mine:
            video, det = repeated_video(seq, factor, args.cache)
            with tempfile.TemporaryDirectory(prefix="sotmot-long-") as tmp:
                scratch = Path(tmp) / "tmp"
                scratch.mkdir()
                got = measure([str(sotmot), "track", str(video), "--det", str(det), "--out", str(Path(tmp) / "out"),
                               "--reid-model", args.model, "-q"], scratch)
            frames = info.length * factor
            row = {"sequence": name, "factor": factor, "frames": frames, "size": f"{info.width}x{info.height}",
                   **got, "fps": frames / got["seconds"]}
            rows.append(row)
            seq_rows.append(row)
            print(f"{name} x{factor}: {frames} frames {row['size']}, {got['seconds']:.0f} s ({row['fps']:.1f} "
                  f"frames/s, cores {100 * got['busy']:.0f} % busy), peak RSS {got['peak_rss_mb']:.0f} MB, "
                  f"peak temporary disk {got['peak_tmp_mb']:.1f} MB",
                  flush=True)
        growth[name] = {"time": exponent([r["frames"] for r in seq_rows], [r["seconds"] for r in seq_rows]),
                        "memory": exponent([r["frames"] for r in seq_rows], [r["peak_rss_mb"] for r in seq_rows])}
        print(f"{name}: growth exponent, time {growth[name]['time']:.2f}, peak memory {growth[name]['memory']:.2f}")
    print("\n| sequence | frames | wall s | frames/s | peak RSS MB | peak temp MB |\n|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['sequence']} x{r['factor']} | {r['frames']} | {r['seconds']:.0f} | {r['fps']:.1f} | "
              f"{r['peak_rss_mb']:.0f} | {r['peak_tmp_mb']:.1f} |")
    print(f"machine: {machine()}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"script": "scripts/bench_long.py", "machine": machine(),
                                                 "rows": rows, "growth": growth, "targets": TARGETS},
                                                indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
