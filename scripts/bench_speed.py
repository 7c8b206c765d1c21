#!/usr/bin/env python3
"""Where the time goes: seconds per stage, per sequence, and each stage's share.

Stages: read (det.txt), preprocess (threshold + NMS), appearance (re-ID
features, with the frame decoding of the appearance pass), sot (the SOT step,
if enabled: template search and frame decoding), tracklets, association,
postprocess, confirm, extend (SOT after association: trajectory ends, the
default since issue #12). ``decode``: the seconds spent reading frames, part
of the stage that read them (beside the columns, not added to the total).
With ``--sot`` the frames are decoded once (issue #15): the SOT step decodes
each frame of its window and computes the detections' features from it, so
appearance is then all re-ID of the run (detections, SOT candidates, added
boxes) and the frame decoding counts in sot. Prints a table and writes JSON
with the machine it ran on.

    python scripts/bench_speed.py --model ../shared/models/person-reidentification-retail-0288.onnx [--sot template] \
        [--appearance openvino] [--no-flip] [--appearance torch --device cuda]

With ``--sot none`` (the default) the same run times ``--peers`` end to end:
each peer's tracking loop on sotmot's detections and features, plus the
seconds of sotmot's appearance stage (the same re-ID work, which every
appearance tracker needs), so the table shows which side the frames go
faster on.

With ``--detector-model`` the run is end to end with detection (private
detections): one pass over the frames decodes each, detects in the
background thread and embeds what was found, so ``appearance`` is then the
wall time of that pass and ``detect`` (like ``decode``) the seconds of
detection inside it.

``det/s`` is detections embedded per second of the appearance stage (MOT
only, frame decoding included: it overlaps the embedding in a background
thread; with ``--sot`` the stage also embeds candidates and it is not shown).
``busy``: the process's CPU seconds (every thread) over the wall seconds times
the machine's cores, in the one-process run; ``1 - busy`` is the idle share of
the cores. With ``--whole`` each sequence is also tracked by ``sotmot track``
in a child process with the same flags (imports, model loading and the
results file included, no scoring): the fps a user sees, and its peak
resident memory (``/usr/bin/time``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

from sotmot.appearance import make_embedder, resolve_backend
from sotmot.plugins import BACKENDS
from common import DEFAULT_DATA, named_sequences, run_timed
from sotmot.config import TrackerConfig
from sotmot.io import read_seqinfo, write_text_atomic
from sotmot.pipeline import pass_detector, track_sequence
from sotmot.plan import resolve
from sotmot.versions import machine

STAGES = ("read", "detect", "preprocess", "appearance", "decode", "motion", "sot", "tracklets", "association",
          "postprocess", "confirm", "extend")


def time_peers(peers: list[str], seq: Path, result, config: TrackerConfig) -> dict[str, dict[str, float]]:
    """Each peer's loop on the detections and features of sotmot's run ``result``, and its end-to-end fps with
    the seconds of sotmot's appearance stage added (the re-ID every appearance tracker needs)."""
    if not peers:
        return {}
    from sotmot.peers import SeqInput, peer_scores, run_peer

    frames, reid = result.info.length, result.timings.get("appearance", 0.0)
    inputs = SeqInput(seq, result.info, result.detections, result.features, peer_scores(result.detections.scores),
                      reid)
    out = {}
    for peer in peers:
        try:  # the peers' packages are imported when their tracker first runs
            _, loop = run_peer(peer, inputs, config.association.min_affinity)
        except ImportError as exc:
            print(f"{peer} skipped ({exc}); install the peers with bash scripts/bootstrap.sh --bench", file=sys.stderr)
            continue
        out[peer] = {"loop_seconds": loop, "loop_fps": frames / max(loop, 1e-9), "fps": frames / (reid + loop)}
    return out


def whole_process(seq: Path, args: argparse.Namespace) -> dict[str, float]:
    """``sotmot track`` on ``seq`` in a child process with this run's flags (:func:`common.run_timed`): wall
    seconds, CPU seconds and peak resident memory (MB)."""
    with tempfile.TemporaryDirectory(prefix="sotmot-speed-") as out:
        command = [sys.executable, "-m", "sotmot", "track", str(seq), "--out", out, "-q", "--reid-model", args.model,
                   "--solver", args.solver, "--sot", args.sot, "--appearance", args.appearance,
                   "--device", args.device]
        command += ["--no-flip"] if args.no_flip else []
        command += ["--detections", "model", "--detector-model", args.detector_model] if args.detector_model else []
        return run_timed(command)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA)
    parser.add_argument("--model", required=True)
    parser.add_argument("--sot", default="none", choices=["none", "template", "deep"])
    parser.add_argument("--solver", "--merger", dest="solver", default="greedy",
                        help="long-term association solver (default: %(default)s)")
    parser.add_argument("--appearance", default="auto", choices=["auto", *sorted(BACKENDS)],
                        help="appearance backend (default: %(default)s, as sotmot track)")
    parser.add_argument("--no-flip", action="store_true", help="embed each crop once, without its mirror image")
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--device", default="cpu", choices=["cpu", "cuda"])
    parser.add_argument("--peers", default="DeepSORT,OccluBoost +GSI",
                        help="trackers timed end to end beside sotmot (MOT only): their loop on sotmot's detections "
                             "and features plus the seconds of sotmot's appearance stage, the same re-ID work for "
                             "them; '' for none; needs bash scripts/bootstrap.sh --bench (default: %(default)s)")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="end to end with detection: the built-in detector runs on every frame (private "
                             "detections) instead of reading det/det.txt")
    parser.add_argument("--whole", action="store_true",
                        help="also time each sequence tracked by 'sotmot track' in a child process (whole process)")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    peers = [p.strip() for p in args.peers.split(",") if p.strip()] if args.sot == "none" else []
    config = TrackerConfig().replace("appearance", model=args.model, backend=args.appearance, device=args.device,
                                     flip=not args.no_flip)
    config = config.replace("sot", variant=args.sot)
    detector = None
    seqs = named_sequences(parser, args.data, args.sequences)
    if args.detector_model:
        config = config.replace("detection", source="model", model=args.detector_model)
        # loaded once, outside the clock, like the re-ID model; at the weak boxes' threshold, as sotmot track runs it
        detector = pass_detector(resolve(config, read_seqinfo(seqs[0])))
    config = config.replace("appearance", backend=resolve_backend(config.appearance).backend)  # the one that runs
    embedder = make_embedder(config.appearance)
    rows = {}
    for seq in seqs:
        start, cpu = time.perf_counter(), time.process_time()
        result = track_sequence(seq, config.replace("association", solver=args.solver), embedder=embedder,
                                detector=detector)
        total, cpu = time.perf_counter() - start, time.process_time() - cpu
        n_dets = int((~result.detections.from_sot).sum())
        rows[result.info.name] = {"frames": result.info.length, "seconds": total, "detections": n_dets,
                                  "fps": result.info.length / total, "stages": result.timings,
                                  "busy": cpu / (total * (os.cpu_count() or 1)),
                                  "reid_per_s": n_dets / max(result.timings.get("appearance", 0.0), 1e-9),
                                  "peers": time_peers(peers, seq, result, config)}
        if args.whole:
            whole = whole_process(seq, args)
            rows[result.info.name]["whole"] = {**whole, "fps": result.info.length / whole["seconds"]}
    head = f"{'sequence':<17}{'whole':>7}{'fps':>7}{'busy':>6}{'det/s':>7}" + "".join(f"{s:>13}" for s in STAGES)
    lines = [head, "-" * len(head)]
    for name, r in rows.items():
        cells = "".join(f"{r['stages'].get(s, 0.0):7.2f}s{100 * r['stages'].get(s, 0.0) / r['seconds']:4.0f}%"
                        for s in STAGES)
        per_s = f"{r['reid_per_s']:7.0f}" if args.sot == "none" else f"{'–':>7}"  # with SOT: candidates too
        whole = f"{r['whole']['fps']:7.1f}" if "whole" in r else f"{'–':>7}"
        lines.append(f"{name:<17}{whole}{r['fps']:7.1f}{100 * r['busy']:5.0f}%{per_s}{cells}")
    print("\n".join(lines))
    timed = [p for p in peers if all(p in r["peers"] for r in rows.values())]
    if timed:
        head = f"{'sequence':<17}{'sotmot':>9}" + "".join(f"{p:>22}" for p in timed)
        lines = ["\nend to end fps (loop fps), the same re-ID for everyone", head, "-" * len(head)]
        for name, r in rows.items():
            lines.append(f"{name:<17}{r['fps']:9.1f}" + "".join(
                f"{r['peers'][p]['fps']:>12.1f} ({r['peers'][p]['loop_fps']:7.0f})" for p in timed))
        print("\n".join(lines))
    detections = f"model {Path(args.detector_model).name}" if args.detector_model else "det/det.txt (public)"
    print(f"machine: {machine()}; detections: {detections}; sot: {args.sot}; solver: {args.solver}; appearance: "
          f"{config.appearance.backend} on {args.device}, flip {'off' if args.no_flip else 'on'}")
    if args.json:
        write_text_atomic(args.json, json.dumps({"machine": machine(), "sot": args.sot, "solver": args.solver,
                                                 "appearance": config.appearance.backend, "device": args.device,
                                                 "flip": not args.no_flip, "detections": detections,
                                                 "rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
