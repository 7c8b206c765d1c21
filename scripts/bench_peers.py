#!/usr/bin/env python3
"""sotmot against established trackers: same detections, same evaluator, same machine, one run.

Trackers:

* sotmot with the default configuration (MOT only), with the template SOT
  step and with the deep SOT step, each with the greedy merge and the flow
  solver;
* SORT, ByteTrack and OC-SORT from the ``trackers`` package (Roboflow,
  Apache-2.0), default settings, frame rate from ``seqinfo.ini``;
* DeepSORT from ``deep-sort-realtime``, fed sotmot's own re-ID embeddings
  (so the comparison isolates association, not the feature model), its
  cosine gate set to sotmot's calibrated affinity gate (see below);
* BoT-SORT, StrongSORT, DeepOCSORT, BoostTrack++, HybridSORT and OccluBoost
  from ``boxmot`` 25.0.0, each with its defaults, fed sotmot's detections and
  embeddings through ``boxmot.structures.Detections(embeddings=...)`` (so
  boxmot builds no re-ID model and downloads nothing) and the frames (for
  camera-motion compensation); each again with boxmot's offline GSI
  post-processing (``+GSI``), and without camera-motion compensation where
  it can be turned off (``no-CMC``; every full-length sequence here has a still
  camera), and given sotmot's memory (``+GSI 4s``: a lost track kept
  ``[association] l_max_seconds`` at the sequence's frame rate, boxmot's
  ``max_age`` or ``track_buffer``, and GSI filling gaps as long; issue #38's
  fair peers). ``--shuffle-check`` adds rows with the embeddings permuted across
  the detections: if a tracker uses them, its scores drop.

With ``--detector-model`` every tracker gets the built-in person detector's
boxes instead (MOTChallenge's "private" detections), detected once per
sequence and cached; the tables say which detections they used.

Same input for everyone: ``det.txt`` cleaned by sotmot's preprocessing with
the default configuration (no score threshold; per-frame NMS at 0.6, by IoM
for DPM scores and by IoU for probability scores). Peers that need scores in
[0, 1] get them as they are when all scores of the sequence lie in [0, 1]
(PETS09-S2L1), otherwise as the per-sequence rank of each score divided by
the number of detections (the MOT16 DPM scores): a monotone map, so each
peer's own confidence thresholds keep their meaning as quantiles.

Scores come from TrackEval (HOTA, DetA, AssA, MOTA, IDF1, IDSW, FP, FN) per
sequence, for the full-length sequences combined and for the 30-frame clips
combined (``MOT16 clips``, and ``MOT17 clips``: with ``--mot17-clips``, each
MOT17 label set's boxes, DPM, Faster R-CNN and SDP, on the frames of the
MOT16 clip of the same video, its first 30 frames, made under ``--clip-cache``
by :func:`sotmot.benchmarks.detector_clips`: the stronger detectors where a
camera moves, MOT17-05 and -10, which no full-length sequence here has).
Speed: ``loop fps`` is frames per second of each tracker's tracking loop,
median of ``--runs`` runs, all in this process: detections are in memory,
frames are read outside the clock, results are written after the clock stops;
``e2e fps`` adds the re-ID of the detector boxes (frame decoding included) for
the trackers that use appearance. The re-ID features of the detector boxes are
computed once per sequence, outside the clock, and given to sotmot, DeepSORT
and the boxmot trackers alike (their time is printed separately); sotmot's SOT
variants read frames and embed the boxes they add inside the clock, since that
is part of their work.

One run of a sequence is a noisy measurement: moving every box by under half a pixel, a change that means
nothing, moves a busy sequence's score by up to about 2 HOTA, for sotmot and the peers alike. ``--jitter K``
runs every tracker once more on K copies of each sequence's detections so moved (seeds 1 to K, as ``sotmot
compare --jitter`` makes them; results under ``--out/jitter<k>``, scored, not timed), and ``peers.md`` ends
with each tracker's lowest and highest over the runs and sotmot's lead over it run by run
(``scripts/peers_paired.py`` reads the same from ``peers.json``; the results page shows the peer sotmot leads
least).

Needs the benchmark extras (not needed to use sotmot)::

    bash scripts/bootstrap.sh --bench
    .venv/bin/python scripts/bench_peers.py --model ../shared/models/person-reidentification-retail-0288.onnx \\
        --out bench_peers

Writes ``peers.md``, ``peers.json``, ``peers.png`` and every results file under ``--out``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from sotmot.appearance import make_embedder
from common import DEFAULT_DATA, add_more_argument, more_found, named_sequences, read_report
from peers_paired import paired_text
from sotmot.benchmarks import JITTER_PIXELS, detector_clips, private_config, sequences
from sotmot.config import TrackerConfig
from sotmot.inspect.compare import jitter_runs
from sotmot.scoring import evaluate_files
from sotmot.io import read_seqinfo, results_path, write_results, write_text_atomic
from sotmot.peers import (BOXMOT, BOXMOT_CMC, BOXMOT_ROWS, TRACKERS_ROWS, SeqInput, load, report_tables,
                          row_machines, run_boxmot, run_peer)
from sotmot.pipeline import finish_sequence, prepare_sequence
from sotmot.types import Tracks
from sotmot.versions import machine

COLUMNS = ("HOTA", "DetA", "AssA", "MOTA", "IDF1", "IDSW", "FP", "FN")
SOTMOT = {  # name -> (SOT variant, solver)
    "sotmot": ("none", "greedy"),
    "sotmot flow": ("none", "flow"),
    "sotmot lifted": ("none", "lifted"),
    "sotmot SOT-template": ("template", "greedy"),
    "sotmot SOT-template flow": ("template", "flow"),
    "sotmot SOT-deep": ("deep", "greedy"),
    "sotmot SOT-deep flow": ("deep", "flow"),
}
PEERS = (*TRACKERS_ROWS, "DeepSORT", *BOXMOT_ROWS)
GROUPS = {"full-length": lambda name: "-clip" not in name,
          "MOT16 clips": lambda name: "-clip" in name and name.startswith("MOT16"),
          "MOT17 clips": lambda name: "-clip" in name and name.startswith("MOT17")}


def run_sotmot(seq: SeqInput, config: TrackerConfig, variant: str, solvers: list[str],
               embedder) -> dict[str, tuple[Tracks, float]]:
    """sotmot with one SOT variant, then each solver on the same tracklets; seconds exclude reading det.txt."""
    cfg = config.replace("sot", variant=variant)
    start = time.perf_counter()
    prepared = prepare_sequence(seq.path, cfg, embedder, features=seq.features)
    shared = time.perf_counter() - start - prepared.timings.get("read", 0.0)
    out = {}
    for solver in solvers:
        start = time.perf_counter()
        result = finish_sequence(prepared, cfg.replace("association", solver=solver), embedder)
        out[solver] = (result.tracks, shared + time.perf_counter() - start)
    return out


def uses_appearance(tracker: str) -> bool:
    """Whether ``tracker`` needs the re-ID features (its end-to-end time includes computing them)."""
    return tracker.startswith("sotmot") or tracker == "DeepSORT" or tracker.split(" ")[0] in BOXMOT


def run_trackers(seq: SeqInput, config: TrackerConfig, trackers: list[str], embedder, min_affinity: float,
                 shuffle_check: bool = False) -> dict[str, tuple[Tracks, float]]:
    """Every tracker of ``trackers`` once on ``seq``: ``tracker -> (tracks, seconds)``; sotmot's rows of one SOT
    variant share its tracklets. With ``shuffle_check``, also each boxmot default row with shuffled embeddings."""
    made: dict[str, tuple[Tracks, float]] = {}
    for variant in dict.fromkeys(SOTMOT[t][0] for t in trackers if t in SOTMOT):
        names = [t for t in trackers if t in SOTMOT and SOTMOT[t][0] == variant]
        got = run_sotmot(seq, config, variant, [SOTMOT[t][1] for t in names], embedder)
        made.update({t: got[SOTMOT[t][1]] for t in names})
    for peer in (t for t in trackers if t in PEERS):
        if peer in BOXMOT_ROWS:
            made[peer] = run_boxmot(peer, seq)
            if shuffle_check and BOXMOT_ROWS[peer][1] == "default":
                made[f"{peer} shuffled"] = run_boxmot(peer, seq, shuffle=True)
        else:
            made[peer] = run_peer(peer, seq, min_affinity)
    return made


def score_table(files: dict[str, list[tuple[Path, Path, int, str]]]) -> dict[str, dict[str, dict[str, float]]]:
    """TrackEval's scores of each tracker's results files: ``table[tracker][row]``, a row per sequence, per group
    of :data:`GROUPS` it has sequences of (combined), and ``ALL`` (every sequence combined)."""
    table: dict[str, dict[str, dict[str, float]]] = {}
    for tracker, chosen_files in files.items():
        report = evaluate_files(chosen_files)
        table[tracker] = dict(report.sequences)
        for group, member in GROUPS.items():
            chosen = [f for f in chosen_files if member(f[3])]
            if chosen:
                table[tracker][group] = evaluate_files(chosen).combined if len(chosen) > 1 \
                    else report.sequences[chosen[0][3]]
        table[tracker]["ALL"] = report.combined
    return table


def same_detections(kept: dict, detector_model: str | None) -> bool:
    """Whether an earlier report (``--keep``) was made from the detections asked for now: public, or the same
    detector model file by name (paths may differ)."""
    def detections(text: str) -> str:
        return Path(text.removeprefix("private: ")).name if text.startswith("private: ") else text

    return detections(kept["detections"]) == detections(f"private: {detector_model}" if detector_model else "public")


def kept_machines(kept: dict, rows: list[str]) -> dict[str, str]:
    """The machine each of ``rows`` of an earlier report (``--keep``) was measured on: the report's own, or,
    for a row that report kept in turn from a still earlier one, that row's own machine."""
    own = row_machines(kept["kept"]) if "kept" in kept else {}
    return {row: own.get(row, kept["machine"]) for row in rows}


def bar_chart(path: Path, table: dict[str, dict[str, dict[str, float]]], trackers: list[str]) -> None:
    """HOTA and IDF1 per tracker, one panel per group, drawn with OpenCV."""
    import cv2

    groups = [g for g in GROUPS if any(g in table[t] for t in trackers)]
    row_h, label_w, panel_w, top = 34, 250, 420, 70
    width = label_w + panel_w * len(groups) + 20
    height = top + row_h * len(trackers) + 40
    img = np.full((height, width, 3), 255, np.uint8)
    colours = {"HOTA": (180, 119, 31), "IDF1": (14, 127, 255)}  # BGR
    font = cv2.FONT_HERSHEY_SIMPLEX
    cv2.putText(img, "HOTA and IDF1 (TrackEval), same detections", (10, 24), font, 0.65, (0, 0, 0), 1, cv2.LINE_AA)
    for key, colour in colours.items():
        x = width - (200 if key == "HOTA" else 100)
        cv2.rectangle(img, (x, 12), (x + 14, 26), colour, -1)
        cv2.putText(img, key, (x + 20, 25), font, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    for g, group in enumerate(groups):
        x0 = label_w + g * panel_w
        cv2.putText(img, group, (x0 + 10, top - 12), font, 0.55, (0, 0, 0), 1, cv2.LINE_AA)
        cv2.line(img, (x0, top - 4), (x0, height - 30), (160, 160, 160), 1)
        for tick in range(0, 101, 25):
            x = x0 + int(tick / 100 * (panel_w - 60))
            cv2.line(img, (x, height - 32), (x, height - 28), (0, 0, 0), 1)
            cv2.putText(img, str(tick), (x - 8, height - 12), font, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
        for r, name in enumerate(trackers):
            values = table[name].get(group)
            if values is None:
                continue
            y = top + r * row_h
            for b, (key, colour) in enumerate(colours.items()):
                length = int(values[key] / 100 * (panel_w - 60))
                y0 = y + 4 + b * 13
                cv2.rectangle(img, (x0 + 1, y0), (x0 + 1 + length, y0 + 11), colour, -1)
                cv2.putText(img, f"{values[key]:.1f}", (x0 + length + 5, y0 + 10), font, 0.38, (0, 0, 0), 1,
                            cv2.LINE_AA)
    for r, name in enumerate(trackers):
        cv2.putText(img, name, (10, top + r * row_h + 21), font, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    if not cv2.imwrite(str(path), img):
        raise OSError(f"could not write {path}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder of sequences (default: %(default)s)")
    parser.add_argument("--model", required=True, help="ONNX re-ID model (sotmot and DeepSORT)")
    add_more_argument(parser)
    parser.add_argument("--out", type=Path, required=True, help="folder for results files, peers.md/json/png")
    parser.add_argument("--sequences", default="", help="comma-separated subset of sequence names")
    parser.add_argument("--trackers", default=",".join([*SOTMOT, *PEERS]),
                        help="comma-separated subset (default: all): " + ", ".join([*SOTMOT, *PEERS]))
    parser.add_argument("--runs", type=int, default=3, help="timed runs per tracker and sequence; the median counts")
    parser.add_argument("--detector-model", metavar="PATH.xml",
                        help="private detections: every tracker gets the boxes of this person detector (run once per "
                             "sequence, cached in --det-cache) instead of the sequence's public det/det.txt")
    parser.add_argument("--det-cache", type=Path, default=Path(".cache/detections"),
                        help="where the detector's boxes are kept between runs (default: %(default)s)")
    parser.add_argument("--mot17-clips", action="store_true",
                        help="also the MOT17 label sets' boxes on the frames of the MOT16 clips of their videos "
                             "(MOT17-04/05/10 under DPM, Faster R-CNN and SDP, first 30 frames; made once under "
                             "--clip-cache; not with --detector-model); --sequences selects among them too")
    parser.add_argument("--clip-cache", type=Path, default=Path(".cache/validation/clips"),
                        help="where --mot17-clips makes its sequences (default: %(default)s)")
    parser.add_argument("--shuffle-check", action="store_true",
                        help="also run each boxmot tracker with its embeddings permuted across the sequence's "
                             "detections (rows '... shuffled'): if they are used, scores must drop")
    parser.add_argument("--jitter", type=int, default=0, metavar="K",
                        help="also run every tracker once on K copies of each sequence's detections whose every box "
                             "moved by under half a pixel (seeds 1 to K; results under --out/jitter<k>, scored, not "
                             "timed): one run's score moves by up to about 2 HOTA on a busy sequence from such a "
                             "change, so peers.md and peers.json also give each tracker's lowest and highest and "
                             "sotmot's lead over it run by run (default: 0)")
    parser.add_argument("--keep", type=Path, metavar="PEERS.json",
                        help="an earlier peers.json of the same sequences and detections: its peer rows for the "
                             "trackers not run now are kept (sotmot's are not: they depend on its defaults), so "
                             "that sotmot alone can be rerun after a change of its own; the JSON says which rows "
                             "came from where")
    args = parser.parse_args(argv)
    if args.mot17_clips and args.detector_model:
        parser.error("--mot17-clips puts other detectors' boxes on the MOT16 clips' frames; with --detector-model "
                     "every tracker gets the detector's boxes instead, so they would be the MOT16 clips' runs again")
    if args.jitter < 0:
        parser.error(f"--jitter takes a number of copies, 0 or more, not {args.jitter}")
    trackers = [t.strip() for t in args.trackers.split(",") if t.strip()]
    kept = None
    if args.keep:
        kept = read_report(parser, args.keep, f"--keep {args.keep}", ("table", "machine", "detections", "runs"))
        if not same_detections(kept, args.detector_model):
            parser.error(f"--keep {args.keep}: made with {kept['detections']} detections, not these")
    unknown = [t for t in trackers if t not in SOTMOT and t not in PEERS]
    if unknown:
        parser.error(f"unknown trackers {unknown}; choose from {[*SOTMOT, *PEERS]}")
    try:
        if any(t in TRACKERS_ROWS for t in trackers):
            import trackers as _trackers  # noqa: F401
        if "DeepSORT" in trackers:
            import deep_sort_realtime  # noqa: F401
        if any(t in BOXMOT_ROWS for t in trackers):
            import boxmot  # noqa: F401
    except ImportError as exc:
        print(f"bench_peers needs the benchmark extras ({exc}); run: bash scripts/bootstrap.sh --bench",
              file=sys.stderr)
        return 2
    # --sequences names the data folder's sequences and, with --mot17-clips, the MOT17 clips
    seqs = named_sequences(parser, args.data, args.sequences, sequences(args.data) + more_found(args) + (
        detector_clips(args.data, args.clip_cache) if args.mot17_clips else []))
    if kept is not None:  # every kept row must cover every sequence run now (the groups are checked at the end)
        names = [read_seqinfo(path).name for path in seqs]
        for tracker, by_row in kept["table"].items():
            missing = [n for n in names if n not in by_row]
            if not tracker.startswith("sotmot") and tracker not in trackers and missing:
                parser.error(f"--keep {args.keep}: {tracker} has no rows for {', '.join(missing)}; run it now "
                             f"(--trackers) or keep a report of these sequences")
    config = TrackerConfig().replace("appearance", model=args.model)
    embedder = make_embedder(config.appearance)
    from ortools.graph.python import min_cost_flow  # noqa: F401  (imported before any clock starts)
    if not seqs:
        print(f"no sequences with frames under {args.data}", file=sys.stderr)
        return 1

    seconds: dict[str, dict[str, list[float]]] = {t: {} for t in trackers}
    files: dict[str, list[tuple[Path, Path, int, str]]] = {t: [] for t in trackers}
    reid: dict[str, float] = {}
    frames: dict[str, int] = {}
    jitter_trackers = [t for t in trackers if t in SOTMOT or t in PEERS]
    jitter_files: list[dict[str, list[tuple[Path, Path, int, str]]]] = [
        {t: [] for t in jitter_trackers} for _ in range(args.jitter)]
    with tempfile.TemporaryDirectory(prefix="sotmot-peers-jitter-") as tmp:
        for path in seqs:
            seq_config = config
            if args.detector_model:  # the same model detections for sotmot and every peer
                seq_config = private_config(config, path, args.detector_model, args.det_cache)
            seq = load(path, seq_config, embedder)
            name = seq.info.name
            reid[name], frames[name] = seq.reid_seconds, seq.info.length
            print(f"{name}: {len(seq.detections)} detections after preprocessing, re-ID {seq.reid_seconds:.1f} s",
                  file=sys.stderr, flush=True)
            for run in range(args.runs):
                made = run_trackers(seq, seq_config, trackers, embedder, config.association.min_affinity,
                                    args.shuffle_check)
                for tracker, (tracks, secs) in made.items():
                    seconds.setdefault(tracker, {}).setdefault(name, []).append(secs)
                    files.setdefault(tracker, [])
                    if run == 0:
                        out = results_path(args.out / "results" / tracker.replace(" ", "_"), name)
                        write_results(out, tracks)
                        files[tracker].append((out, seq.info.gt_path, seq.info.length, name))
                print(f"  run {run + 1}/{args.runs}: " + ", ".join(f"{t} {s:.2f} s" for t, (_, s) in made.items()),
                      file=sys.stderr, flush=True)
            # the same trackers again on --jitter copies of the detections, every box moved by under half a
            # pixel: the spread of one run's score (scored, not timed)
            for copy, copy_config in enumerate(jitter_runs(path, seq_config, args.jitter, Path(tmp) / name), 1):
                made = run_trackers(load(path, copy_config, embedder), copy_config, jitter_trackers, embedder,
                                    config.association.min_affinity)
                for tracker, (tracks, _) in made.items():
                    out = results_path(args.out / f"jitter{copy}" / "results" / tracker.replace(" ", "_"), name)
                    write_results(out, tracks)
                    jitter_files[copy - 1][tracker].append((out, seq.info.gt_path, seq.info.length, name))
                print(f"  copy {copy}/{args.jitter} tracked", file=sys.stderr, flush=True)

    trackers += [t for t in seconds if t not in trackers]  # the shuffled-embedding rows
    table = score_table({t: files[t] for t in trackers})
    for tracker in trackers:
        med = {n: statistics.median(v) for n, v in seconds[tracker].items()}
        # end to end: the loop plus the re-ID of the detector boxes (frame decoding included), for the
        # trackers that use appearance; SORT, ByteTrack and OC-SORT need no more than their loop
        reid_part = {n: reid[n] if uses_appearance(tracker) else 0.0 for n in med}
        for n, s in med.items():
            table[tracker][n]["fps"] = frames[n] / s
            table[tracker][n]["e2e fps"] = frames[n] / (s + reid_part[n])
        for group, member in [*GROUPS.items(), ("ALL", lambda n: True)]:
            names = [n for n in med if member(n)]
            if names and group in table[tracker]:
                table[tracker][group]["fps"] = sum(frames[n] for n in names) / sum(med[n] for n in names)
                table[tracker][group]["e2e fps"] = sum(frames[n] for n in names) / sum(
                    med[n] + reid_part[n] for n in names)

    kept_rows = []
    if kept is not None:
        kept_rows = [t for t in kept["table"] if not t.startswith("sotmot") and t not in table]
        for tracker in kept_rows:
            missing = set(table[trackers[0]]) - set(kept["table"][tracker])
            if missing:
                print(f"{args.keep}: {tracker} has no rows for {sorted(missing)}", file=sys.stderr)
                return 1
            table[tracker], seconds[tracker] = kept["table"][tracker], kept["seconds"][tracker]
        trackers += kept_rows
    jitter_tables = [score_table(by_tracker) for by_tracker in jitter_files]
    rows = [*dict.fromkeys(n for t in trackers for n in table[t])]
    kind = (f"private detections (MOTChallenge's term): {Path(args.detector_model).name}, every tracker the same boxes"
            if args.detector_model else "public detections (each sequence's det/det.txt)")
    lines = [f"Machine: {machine()}; median of {args.runs} runs; re-ID model {Path(args.model).name}; {kind}.", ""]
    machines = kept_machines(kept, kept_rows) if kept_rows else {}
    if kept_rows:
        lines[-1:-1] = [f"Rows kept from {args.keep} (median of {kept['runs']} runs), the others run now: " + "; ".join(
            f"{', '.join(t for t in kept_rows if machines[t] == m)} (machine: {m})" for m in dict.fromkeys(
                machines.values())) + "."]
    for row in rows:
        lines += [f"**{row}**", "", "| tracker | " + " | ".join(COLUMNS) + " | loop fps | e2e fps |",
                  "|---|" + "---|" * (len(COLUMNS) + 2)]
        for tracker in trackers:
            v = table[tracker].get(row)
            if v is None:
                continue
            cells = [f"{v[c]:.1f}" if c in ("HOTA", "DetA", "AssA", "MOTA", "IDF1") else f"{v[c]:.0f}"
                     for c in COLUMNS]
            lines.append(f"| {tracker} | " + " | ".join(cells) + f" | {v['fps']:.1f} | {v['e2e fps']:.1f} |")
        lines.append("")
    lines.append("re-ID features of the detector boxes (computed once, shared by sotmot, DeepSORT and the boxmot "
                 "trackers; in e2e fps, not in loop fps): " + ", ".join(f"{n} {s:.1f} s" for n, s in reid.items()))
    lines.append("camera-motion compensation in boxmot's defaults: "
                 + ", ".join(f"{n} {m}" for n, m in BOXMOT_CMC.items()) + "; StrongSORT none")
    goal = []
    peers_run = [t for t in trackers if t in PEERS]
    if "sotmot" in trackers and peers_run:
        for group in GROUPS:
            if group not in table["sotmot"]:
                continue
            for metric in ("HOTA", "IDF1"):
                best = max(peers_run, key=lambda t: table[t][group][metric])
                margin = table["sotmot"][group][metric] - table[best][group][metric]
                goal.append(f"- {group} {metric}: sotmot {table['sotmot'][group][metric]:.1f}, best peer {best} "
                            f"{table[best][group][metric]:.1f} ({'ahead' if margin > 0 else 'BEHIND'} by "
                            f"{abs(margin):.1f})")
    lines += ["", "Goal (default sotmot above every peer on HOTA and IDF1):", *goal]
    jitter = {"copies": args.jitter, "pixels": JITTER_PIXELS, "trackers": jitter_trackers, "tables": jitter_tables}
    if jitter_tables and "sotmot" in jitter_trackers:
        paired, _ = paired_text(report_tables({"table": table, "jitter": jitter}), "sotmot")
        lines += ["", f"Run by run: the boxes themselves, then {args.jitter} copies whose every box moved by under "
                      f"{JITTER_PIXELS:g} px (`--jitter`).", *paired.splitlines()]
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(args.out / "peers.md", text)
    write_text_atomic(args.out / "peers.json", json.dumps({
        "machine": machine(), "runs": args.runs, "model": str(args.model), "table": table,
        "detections": "private: " + str(args.detector_model) if args.detector_model else "public",
        "seconds": seconds, "reid_seconds": reid, "frames": frames,
        "preprocessing": "sotmot default: no score threshold, per-frame NMS 0.6 (IoM for DPM scores, IoU otherwise)",
        "peer_scores": "as given when all in [0, 1], else per-sequence rank / count",
        **({"jitter": jitter} if args.jitter else {}),
        **({"kept": {"from": str(args.keep), "runs": kept["runs"], "rows": kept_rows, "machines": machines}}
           if kept is not None else {}),
    }, indent=2) + "\n")
    bar_chart(args.out / "peers.png", table, trackers)
    return 0


if __name__ == "__main__":
    sys.exit(main())
