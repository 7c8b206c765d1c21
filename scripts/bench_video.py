#!/usr/bin/env python3
"""What reading a video costs against a folder of JPEGs: the same frames, the same detections, tracked in-process.

A sequence's frames are tracked from its JPEG folder, from an MPEG-4 video
OpenCV writes of them (``mp4v``, cached under ``--cache`` as
``scripts/bench_long.py`` makes it), and from any video files given with
``--video LABEL=PATH`` (the same frames, e.g. H.264 made by ffmpeg), each with
the sequence's public detections (``det/det.txt``) and, with
``--detector-model``, again with the detector's boxes; models loaded once, one
run each. A video goes back only by a seek, which decodes from the last key
frame, so the stages that read frames out of order (the end extension; the
camera-motion check, every half second) cost more than from JPEGs, the more
the farther apart a file's key frames lie. Per input and detections: wall
seconds and frames/s, the seconds of the stages that read frames
(``decode``: the appearance pass's reading; ``motion_in_pass``: a video's
camera-motion estimate inside that pass; ``motion``: the camera-motion stage
after it; ``extend``), and the seeks the video made (count and seconds;
every seek of the run). The tracks
differ between inputs (each codec decodes other pixels), not between runs of
one.

    .venv/bin/python scripts/bench_video.py --model ../shared/models/person-reidentification-retail-0288.onnx \
        --detector-model ../shared/models/person-detection-0202/person-detection-0202.FP16-INT8.xml \
        --video "H.264, key frame every 250=/tmp/MOT16-09-g250.mp4" --json docs/results/video.json

An H.264 file with ffmpeg's default key-frame interval (250 frames), made so (ffmpeg is not a dependency of
sotmot; any build with libx264 does):

    ffmpeg -framerate 30 -i ../shared/data/MOT16-09/img1/%06d.jpg -c:v libx264 -preset veryfast -crf 23 -g 250 \
        -pix_fmt yuv420p /tmp/MOT16-09-g250.mp4

A moving camera (the results page's "A moving camera" under "Video input"): MOT16-09 seen by a camera driving
forward (``scripts/make_moving.py``), whose motion a video's pass measures as it decodes the frames:

    .venv/bin/python scripts/make_moving.py ../shared/data/MOT16-09 .cache/moving/MOT16-09-fwd --forward 1.6 \
        --rotate 3 --turn 200
    .venv/bin/python scripts/bench_video.py --model ... --detector-model ... --data .cache/moving \
        --sequence MOT16-09-fwd --video "H.264, key frame every 250=/tmp/MOT16-09-fwd-g250.mp4" \
        --note "..." --json docs/results/video_moving.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from bench_long import repeated_video
from common import DEFAULT_DATA, ROOT
from sotmot.appearance import make_embedder
from sotmot.config import TrackerConfig
from sotmot.io import read_seqinfo, write_text_atomic
from sotmot.io.frames import VideoFile
from sotmot.pipeline import pass_detector, track_sequence
from sotmot.plan import resolve
from sotmot.versions import machine

STAGES = ("decode", "appearance", "motion_in_pass", "motion", "extend")


@contextmanager
def counted_seeks():
    """Counts and times every seek a :class:`VideoFile` makes while inside: yields ``{"seeks", "seek_seconds"}``."""
    seeks = {"seeks": 0, "seek_seconds": 0.0}
    original = VideoFile._seek

    def seek(self, frame):
        began = time.perf_counter()
        try:
            return original(self, frame)
        finally:
            seeks["seeks"] += 1
            seeks["seek_seconds"] += time.perf_counter() - began

    VideoFile._seek = seek
    try:
        yield seeks
    finally:
        VideoFile._seek = original


def track_input(label: str, path: Path, config: TrackerConfig, embedder, detector) -> dict:
    """``path`` (a sequence folder or a video) tracked as ``config`` says: wall seconds, frames/s, stage seconds,
    seeks."""
    with counted_seeks() as seeks:
        began = time.perf_counter()
        result = track_sequence(path, config, embedder=embedder, detector=detector)
        wall = time.perf_counter() - began
    frames = result.info.length
    return {"input": label, "path": str(path), "detections": config.detection.source, "frames": frames,
            "seconds": wall, "fps": frames / wall, "stages": {s: result.timings.get(s, 0.0) for s in STAGES},
            **seeks, "end_boxes": int(result.tracks.from_sot.sum())}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", required=True, help="ONNX re-ID model")
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--sequence", default="MOT16-09", help="the sequence whose frames are read (default: "
                        "%(default)s)")
    parser.add_argument("--video", action="append", default=[], metavar="LABEL=PATH",
                        help="a video of the sequence's frames to measure too (repeatable)")
    parser.add_argument("--cache", type=Path, default=ROOT / ".cache" / "long",
                        help="where the MPEG-4 video is kept (default: %(default)s)")
    parser.add_argument("--detector-model", metavar="PATH.xml", help="also track every input with this person "
                        "detector's boxes (private detections: the detector runs in the pass)")
    parser.add_argument("--note", default="", help="what the sequence is, for the results page (e.g. how a moving "
                        "camera was made)")
    parser.add_argument("--json", type=Path, help="write every number here")
    args = parser.parse_args(argv)
    seq = args.data / args.sequence
    if not (seq / "seqinfo.ini").is_file():
        parser.error(f"{seq} is not a sequence folder (no seqinfo.ini)")
    inputs = [("JPEG folder", seq), ("MPEG-4 (OpenCV mp4v)", repeated_video(seq, 1, args.cache)[0])]
    for given in args.video:
        label, sep, path = given.rpartition("=")
        if not sep or not label or not Path(path).is_file():
            parser.error(f"--video {given!r}: expected LABEL=PATH of an existing video file")
        inputs.append((label, Path(path)))
    config = TrackerConfig().replace("appearance", model=args.model)
    embedder = make_embedder(config.appearance)
    runs = [(config.replace("detection", source="file", file=str(seq / "det" / "det.txt")), None)]
    if args.detector_model:
        private = config.replace("detection", source="model", model=args.detector_model)
        runs.append((private, pass_detector(resolve(private, read_seqinfo(seq)))))
    rows = []
    print(f"{'input':<40} {'dets':>7} {'s':>6} {'fps':>6} " + " ".join(f"{s:>10}" for s in STAGES)
          + f" {'seeks':>6} {'seek s':>7}")
    for run, detector in runs:
        for label, path in inputs:
            row = track_input(label, path, run, embedder, detector)
            rows.append(row)
            stages = " ".join(f"{row['stages'][s]:10.2f}" for s in STAGES)
            print(f"{label:<40} {row['detections']:>7} {row['seconds']:6.1f} {row['fps']:6.1f} {stages} "
                  f"{row['seeks']:6d} {row['seek_seconds']:7.2f}", flush=True)
    if args.json:
        record = {"machine": machine(), "sequence": args.sequence, "note": args.note, "rows": rows}
        write_text_atomic(args.json, json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
