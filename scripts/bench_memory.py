#!/usr/bin/env python3
"""Peak memory of tracking one long 1080p sequence: frames are streamed, never all loaded.

Builds a long 1920x1080 sequence by repeating MOT16-04-clip30 (30 frames)
``--repeat`` times in a temporary folder (frames are symbolic links, the
detections are copied with shifted frame numbers), then runs
``sotmot track`` on it in a child process under ``/usr/bin/time -v`` and
reads its "Maximum resident set size". Run once per setting (MOT only,
SOT template) and for two lengths, so growth with length shows.

    .venv/bin/python scripts/bench_memory.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --json bench_memory.json
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from common import DEFAULT_DATA
from sotmot.benchmarks import machine

LIMIT_MB = 2048


def repeated_sequence(src: Path, dst: Path, repeat: int) -> Path:
    """``src`` played ``repeat`` times in a row, as a new sequence folder ``dst`` (frames linked, not copied)."""
    from sotmot.io import read_seqinfo

    info = read_seqinfo(src)
    name = f"{info.name}-x{repeat}"
    (dst / "img1").mkdir(parents=True)
    (dst / "det").mkdir()
    frames = sorted((src / "img1").glob("*.jpg"))
    if len(frames) != info.length:
        raise SystemExit(f"{src}: expected {info.length} frames in img1/, found {len(frames)}")
    det_lines = (src / "det" / "det.txt").read_text().splitlines()
    out_lines = []
    for r in range(repeat):
        for k, frame in enumerate(frames, start=1):
            (dst / "img1" / f"{r * info.length + k:06d}.jpg").symlink_to(frame.resolve())
        for line in det_lines:
            frame, rest = line.split(",", 1)
            out_lines.append(f"{int(float(frame)) + r * info.length},{rest}")
    (dst / "det" / "det.txt").write_text("\n".join(out_lines) + "\n")
    ini = (src / "seqinfo.ini").read_text()
    ini = re.sub(r"(?m)^name=.*$", f"name={name}", ini)
    ini = re.sub(r"(?m)^seqLength=.*$", f"seqLength={info.length * repeat}", ini)
    (dst / "seqinfo.ini").write_text(ini)
    return dst


def peak_rss_mb(command: list[str]) -> tuple[float, float]:
    """Peak resident memory (MB) and wall seconds of ``command``, from ``/usr/bin/time -v``."""
    start = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-v", *command], capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(command)} failed:\n{proc.stderr[-3000:]}")
    match = re.search(r"Maximum resident set size \(kbytes\): (\d+)", proc.stderr)
    if not match:
        raise SystemExit("no 'Maximum resident set size' in /usr/bin/time -v output")
    return int(match.group(1)) / 1024, seconds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--repeats", default="5,20", help="comma-separated repetitions of the 30-frame clip")
    parser.add_argument("--sot", default="none,template", help="comma-separated SOT variants to measure")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    if not Path("/usr/bin/time").exists():
        print("needs /usr/bin/time (Debian package 'time')", file=sys.stderr)
        return 2
    src = args.data / "MOT16-04-clip30"
    sotmot = Path(sys.executable).with_name("sotmot")
    rows = []
    with tempfile.TemporaryDirectory(prefix="sotmot-mem-") as tmp:
        for repeat in (int(r) for r in args.repeats.split(",")):
            seq = repeated_sequence(src, Path(tmp) / f"seq{repeat}", repeat)
            for variant in args.sot.split(","):
                out = Path(tmp) / f"out-{repeat}-{variant}"
                mb, seconds = peak_rss_mb([str(sotmot), "track", str(seq), "--out", str(out), "--reid-model",
                                           args.model, "--sot", variant, "-q"])
                frames = 30 * repeat
                rows.append({"frames": frames, "sot": variant, "peak_rss_mb": mb, "seconds": seconds,
                             "fps": frames / seconds})
                print(f"{frames:6d} frames 1920x1080  sot={variant:<9} peak RSS {mb:7.0f} MB  "
                      f"({seconds:.0f} s, {frames / seconds:.1f} frames/s)", flush=True)
                shutil.rmtree(out)
    worst = max(r["peak_rss_mb"] for r in rows)
    print(f"largest peak: {worst:.0f} MB ({'below' if worst < LIMIT_MB else 'ABOVE'} the {LIMIT_MB} MB target)")
    print(f"machine: {machine()}")
    if args.json:
        args.json.write_text(json.dumps({"machine": machine(), "source": str(src), "rows": rows,
                                         "limit_mb": LIMIT_MB}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
