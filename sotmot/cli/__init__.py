"""The ``sotmot`` command line: the parser and ``main``. The tracker's flags come from one table
(:mod:`sotmot.cli.flags`), each sub-command's work is in :mod:`sotmot.cli.commands`; the library does the rest."""

from __future__ import annotations

import argparse
import logging
import signal
import sys
import threading
from pathlib import Path

from sotmot.cli.commands import (_non_negative_int, _positive_float, _positive_int, cmd_compare, cmd_eval, cmd_explain,
                                 cmd_graph, cmd_models, cmd_render, cmd_track, cmd_train)
from sotmot.cli.flags import add_tracker_flags
from sotmot.errors import SotmotError

EPILOG_TRACK = """\
examples:
  sotmot track ../shared/data/PETS09-S2L1 --out results --eval   # the bundled models
  sotmot track ../shared/data/MOT16-*-clip30 --out results --eval
  sotmot track SEQ --out results --config my.toml   # every threshold, see docs/configuration.md
  sotmot track DATA/* --out results --workers 2 --resume   # 2 processes, skip finished sequences
  sotmot track /shared/DATA/* --out /shared/results --cluster dask://scheduler:8786
  sotmot track street.mp4 --out results   # a plain video: the bundled detector finds the people
  sotmot track SEQ --out results --reid-model my-reid.onnx --detector-model my-detector.xml   # other models
  sotmot track street.mp4 --det street_det.txt --out results   # a video and its detections
  sotmot track frames/ --fps 25 --out results   # a folder of images (no seqinfo.ini): frames in name order
  sotmot track ../shared/data/MOT16-09 --detections model --out results   # the detector, not det/det.txt
  sotmot track --live 0 --fps 25 --out results --window 10   # camera 0: boxes final 10 s after, Ctrl-C stops
  sotmot track --live rtsp://10.0.0.5/stream1 --out results   # a network camera: results/10.0.0.5-stream1.txt
  timeout 600 sotmot track --live 0 --fps 25 --out results   # ten minutes of camera 0; what is final stays
  sotmot track --live 0 --fps 30 --step 2 --out results   # every 2nd frame tracked, those between filled

The models are the two sotmot ships with (`sotmot models` lists them): Intel's
person-reidentification-retail-0288 and person-detection-0202 (Apache-2.0). Another model comes
from --reid-model / --detector-model, the config, or the environment variables SOTMOT_REID_MODEL
and SOTMOT_DETECTOR_MODEL. A sequence folder with det/det.txt is tracked from that
file; a plain video (or --detections model) from the detector's boxes, written beside the
results as <name>.det.txt (MOTChallenge det format) so that the run can be repeated with --det.
Results are written as DIR/<name>.txt (MOTChallenge format: frame, id, x, y, w, h,
score, -1, -1, -1; boxes in pixels, frames 1-based), each file atomically; <name> is
the name in seqinfo.ini (a video's or a folder of images' own name) and must be a plain file name (no path
separators). Beside it:
<name>.flags.csv (interpolated / SOT boxes, each box's confidence) and <name>.run.json
(sotmot version, full configuration, solver, model and input hashes, library versions, the CPU,
time); --resume skips a sequence only when that record matches the current run (library
versions and CPU aside), and --config <name>.run.json repeats the run, saying which versions
differ and whether the CPU does (re-ID runs in float32 on every CPU, [appearance] precision, but
another instruction set rounds otherwise: a close decision may flip).
"""

EPILOG_EVAL = """\
Scores RESULTS_DIR/<name>.txt against SEQ_DIR/gt/gt.txt with TrackEval (HOTA, CLEAR,
Identity). MOT16-layout ground truth (9 columns) is scored with the MOT16 rules
(output boxes on distractor classes removed); 2DMOT2015-layout ground truth (10 columns)
with the MOT15 rules: no classes, people marked 0 in its 7th column left out, and an output
box on one of them counted as a false positive.

example:
  sotmot eval results ../shared/data/PETS09-S2L1 --json scores.json
"""


EPILOG_COMPARE = """\
Each sequence goes once through detection cleaning, appearance and tracklets; then every
solver runs on those same tracklets. Columns: TrackEval HOTA, MOTA, IDF1, IDSW; tracks, the
identities in the results the run writes (as 'sotmot track' writes them); lifted_obj, the one
objective every solver is scored on (the sum over pairs of tracklets in one trajectory within the
horizon of n_a * n_b times the learned log-likelihood ratio that they are one person, or
(affinity - lifted_threshold) with lifted_costs = "threshold"; higher is better); window_gap,
for the lifted solver, how far CP-SAT's proved bound lies above its solution in windows not
proven optimal (0: every window optimal); flow_net_cost, the flow
network's own cost (entry cost per trajectory + (1 - affinity) per link; lower is better for that
network only); the solver's time in seconds.

One run's scores move with changes that should change nothing: with every detection box moved
by under half a pixel, MOT16-09's HOTA moves by up to about 2 and TUD-Stadtmitte's MOTA by over
10 (docs/results.md, the validation set's noise floor). --jitter K runs every solver on K such
copies of each sequence too, prints each solver's lowest and highest HOTA, MOTA and IDF1 over the
runs, and each solver's difference from the first, run by run: a difference whose sign changes
between runs cannot be told from chance (one sign in every run is the more telling the larger K).

examples:
  sotmot compare ../shared/data/PETS09-S2L1 --solvers greedy,flow,lifted --json compare.json
  sotmot compare ../shared/data/PETS09-S2L1 ../shared/data/TUD-Stadtmitte --jitter 2
"""


def _out_path(text: str) -> Path:
    """An ``--out`` path; an empty one (``--out ""``, an unset shell variable) is refused, not taken for the
    current folder."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; name a folder or file (--out . for the current folder)")
    return Path(text)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sotmot",
        description="Multi-object tracking of people by detection, after 'SOT for MOT' (He et al.): "
                    "Hungarian tracklets in 1-second batches, long-term association under IoU, velocity "
                    "and gap constraints, interpolation and smoothing. Input: MOTChallenge folders, videos or "
                    "folders of images.")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    from sotmot import __version__

    parser.add_argument("--version", action="version", version=f"sotmot {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("track", help="track sequences and write MOTChallenge results",
                       description="Track one or more MOTChallenge sequence folders, videos or folders of images,\n"
                                   "or a live source: a camera or a network stream (--live).",
                       epilog=EPILOG_TRACK, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("seq_dirs", nargs="*", type=Path, metavar="SEQ_DIR",
                   help="folder with seqinfo.ini, img1/ and (usually) det/det.txt; a video file (.mp4, .avi, ...); "
                        "or a folder of images without seqinfo.ini (the images in it, or in its img1/, in the order "
                        "of their names, numbers compared as numbers: frame_2 before frame_10; --fps gives the rate; "
                        "det/det.txt and gt/gt.txt read as in a sequence folder)")
    p.add_argument("--out", type=_out_path, required=True, metavar="DIR", help="where <name>.txt results go")
    p.add_argument("--live", metavar="SOURCE",
                   help="instead of SEQ_DIR: a camera (its number, e.g. 0), a network stream (its URL: rtsp://..., "
                        "http://...) or a video file read once as it plays, tracked as the frames come in committed "
                        "windows (--window, default 30 s; the boxes of a frame are final a window after it): each "
                        "window's final boxes are appended to DIR/<name>.txt (<name>: camera0, the URL's host and "
                        "path, the file's stem; a password in the URL is never written or shown) and <name>.run.json "
                        "says how far they are final, until the source ends or Ctrl-C stops it (what is final "
                        "stays; a new session refuses a DIR holding an earlier one's <name>.txt). The detector "
                        "finds the people unless --det gives boxes (frames counted from the first frame read); "
                        "--fps where the source gives no rate; --step K where the camera is faster than the "
                        "tracker. Not with --eval, --resume, --workers or --cluster")
    add_tracker_flags(p, "track")
    p.add_argument("--det", type=Path, metavar="DET.txt",
                   help="the detections of the one video or sequence tracked (MOTChallenge layout: frame, id, x, y, "
                        "w, h, score; frames counted from 1 at the video's first frame), instead of its det/det.txt "
                        "or the detector; e.g. the <name>.det.txt a model run wrote")
    p.add_argument("--eval", action="store_true", help="score the results with TrackEval afterwards")
    p.add_argument("--workers", type=_positive_int, default=1, metavar="N",
                   help="track N sequences at once in separate processes, or the windows of one sequence with "
                        "--window (default: 1; never more than the sequences or the CPUs; the workers end with this "
                        "process)")
    p.add_argument("--cluster", metavar="dask://HOST:PORT",
                   help="run the sequences on an existing Dask cluster (its scheduler's address), one task a "
                        "sequence; the workers must see the same paths (shared filesystem) and have sotmot "
                        "installed (pip install -e '.[dask]'). Every path, the models' from the environment "
                        "too, is resolved here before the tasks are sent; a lost worker's sequence runs again "
                        "on another")
    p.add_argument("--resume", action="store_true",
                   help="skip sequences whose results exist from the same run settings (model, config, inputs, "
                        "all hashed in <name>.run.json) and are unchanged since (their hash is recorded too)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars (drawn only when stderr is a terminal)")
    p.set_defaults(func=cmd_track)

    p = sub.add_parser("eval", help="score results with TrackEval", description="Score tracking results.",
                       epilog=EPILOG_EVAL, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("results_dir", type=Path, metavar="RESULTS_DIR", help="folder with <name>.txt results")
    p.add_argument("seq_dirs", nargs="+", type=Path, metavar="SEQ_DIR", help="sequence folders with gt/gt.txt")
    p.add_argument("--json", type=Path, metavar="FILE", help="also write the scores as JSON")
    p.set_defaults(func=cmd_eval)

    p = sub.add_parser("compare", help="compare association solvers on the same tracklets",
                       description="Compare long-term association solvers on identical tracklets.",
                       epilog=EPILOG_COMPARE, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("seq_dirs", nargs="+", type=Path, metavar="SEQ_DIR", help="sequence folders with gt/gt.txt")
    p.add_argument("--solvers", "--mergers", dest="solvers", default="greedy,flow", metavar="SOLVERS",
                   help="comma-separated solver names (default: %(default)s; --mergers is the older name)")
    p.add_argument("--jitter", type=_non_negative_int, default=0, metavar="K",
                   help="also run every solver on K copies of each sequence whose detection boxes moved by under "
                        "half a pixel (a change that should change nothing), and say which differences between "
                        "solvers keep their sign in every run; K + 1 times the work (default: 0, the sequence "
                        "itself only)")
    add_tracker_flags(p, "compare")
    p.add_argument("--json", type=Path, metavar="FILE", help="also write the table as JSON")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars (drawn only when stderr is a terminal)")
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("train-appearance", help="fine-tune the re-ID model with triplet loss on ground truth",
                       description="Fine-tune the re-ID model (torch backend) with a batch-hard triplet loss on "
                                   "ground-truth crops of the given sequences; a quarter of the identities is "
                                   "held out for validation; early layers are frozen. Use the result with "
                                   "--appearance torch --weights FILE.",
                       epilog="example:\n  sotmot train-appearance ../shared/data/PETS09-S2L1 --out tuned.pt",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("seq_dirs", nargs="+", type=Path, metavar="SEQ_DIR",
                   help="sequences with gt/gt.txt and img1/ (seqinfo.ini optional: without it the frames are read "
                        "in name order)")
    p.add_argument("--init", metavar="MODEL.onnx",
                   help="the re-ID model to start from (default: the bundled person-reidentification-retail-0288, "
                        "or SOTMOT_REID_MODEL)")
    p.add_argument("--out", type=_out_path, required=True, metavar="FILE.pt", help="checkpoint (best validation AUC)")
    p.add_argument("--epochs", type=_positive_int, default=3, help="passes over the crops (default: %(default)s)")
    p.add_argument("--margin", type=_positive_float, default=0.3, help="triplet margin (default: %(default)s)")
    p.add_argument("--lr", type=_positive_float, default=1e-4, help="Adam learning rate (default: %(default)s)")
    p.add_argument("--train-last", type=int, default=12, metavar="K",
                   help="train only the last K weight tensors (default: %(default)s; 0 = all)")
    p.add_argument("--seed", type=int, default=0, help="seed of the identity split and sampling (default: %(default)s)")
    p.add_argument("--device", choices=["cpu", "cuda"], default="cpu", help="where to train (default: %(default)s)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar (drawn only when stderr is a terminal)")
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("render", help="draw results on the frames (video or JPEG folder)",
                       description="Draw tracking results on the frames: stable colour per id, id label, "
                                   "short trail; SOT boxes dashed, interpolated boxes thin with an 'i' "
                                   "(from the .flags.csv that 'sotmot track' writes beside the results). "
                                   "With --gt, the ground truth is drawn beside them with the errors of "
                                   "the CLEAR matching: FP red, FN dashed red, ID switches flagged.")
    p.add_argument("seq_dir", type=Path, metavar="SEQ_DIR",
                   help="the sequence the results are of (frames from img1/), the video file or the folder of "
                        "images they were tracked on")
    p.add_argument("--fps", type=_positive_float, metavar="N",
                   help="frame rate of the video written: a folder of images without seqinfo.ini needs it (give "
                        "the rate it was tracked at); a video's replaces the container's")
    p.add_argument("results", type=Path, metavar="RESULTS.txt",
                   help="MOTChallenge results, e.g. from sotmot track (its .flags.csv beside it marks SOT and "
                        "interpolated boxes)")
    p.add_argument("--out", type=_out_path, required=True, metavar="VIDEO.mp4|DIR",
                   help="a .mp4 or .avi file, or a folder name without extension for one JPEG per frame; never "
                        "inside the sequence folder, never over an input. A video or a new folder is written under "
                        "a hidden .partial name and renamed when complete; an existing folder must be empty or hold "
                        "an earlier render's NNNNNN.jpg frames only, and is written into frame by frame")
    p.add_argument("--gt", action="store_true", help="draw SEQ_DIR/gt/gt.txt beside, with the errors marked")
    p.add_argument("--dropped", action="store_true",
                   help="also draw the boxes confirmation dropped, grey and dashed with an 'x' after the id: the "
                        "<name>.low.txt beside the results, which 'sotmot track --unconfirmed file' writes")
    p.add_argument("--mask", type=Path, metavar="IMAGE",
                   help="shade the pixels this mask ignores (the image 'sotmot track --mask' was given: black where "
                        "detections are ignored), to see what it covers")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar (drawn only when stderr is a terminal)")
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("models", help="list the models a run uses: origin, licence, size, SHA-256",
                       description="The two models sotmot ships with (Intel Open Model Zoo, Apache-2.0) and the ones "
                                   "a run uses now: a model named by SOTMOT_REID_MODEL or SOTMOT_DETECTOR_MODEL "
                                   "replaces the bundled one, as --reid-model / --detector-model or the config do "
                                   "for one run. Each bundled file is checked against its SHA-256.")
    p.add_argument("--json", action="store_true", help="print the table as JSON")
    p.set_defaults(func=cmd_models)

    for name, func, text in (("graph", cmd_graph, "export the association graph (GraphML, JSON, PNG, HTML)"),
                             ("explain", cmd_explain, "say why two tracks (or two tracklets) were or were not merged, "
                                                     "how one track was made, or list every track")):
        p = sub.add_parser(name, help=text, description=text[0].upper() + text[1:] + ". The sequence is "
                           "tracked first, with the same options as 'sotmot track'; track ids are those "
                           "of the results file that run writes.")
        p.add_argument("seq_dir", type=Path, metavar="SEQ_DIR",
                       help="folder with seqinfo.ini, det/det.txt and img1/, a video file, or a folder of images "
                            "(with --fps)")
        if name == "graph":
            p.add_argument("--out", type=_out_path, required=True, metavar="DIR",
                           help="folder for graph.graphml, graph.json, graph.png and graph.html")
            p.add_argument("--frames", metavar="A:B", help="only tracklets that touch frames A..B (with --step K, "
                                                               "tracked frames: frame k is the sequence's 1 + (k - 1) "
                                                               "* K)")
        else:
            p.add_argument("--ids", metavar="ID[,ID]",
                           help="two track ids of the results file (e.g. 3,17: why they were not merged), or one "
                                "(e.g. 5: why its tracklets were merged into it, what filled the gaps between "
                                "them, and how confirmation judged its boxes: their P(true), the threshold, what "
                                "each feature of the box model added)")
            p.add_argument("--tracklets", metavar="ID,ID",
                           help="two tracklet ids, as 'sotmot graph' draws them (e.g. 4,9: merged or not, and why)")
            p.add_argument("--tracks", action="store_true",
                           help="every track in one table, the least certain first (the median P(true) "
                                "confirmation gave its boxes): where to look with --ids")
        add_tracker_flags(p, name)
        p.add_argument("-q", "--quiet", action="store_true",
                       help="no progress bars (drawn only when stderr is a terminal)")
        p.set_defaults(func=func)
    for p in sub.choices.values():  # -v also after the command: sotmot track ... -v
        p.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                       help="more log output (-vv for debug)")
    return parser


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that every ``with`` and ``finally`` cleans up as for Ctrl-C."""


def _terminate(signum, frame) -> None:
    raise Terminated


def main(argv: list[str] | None = None) -> int:
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _terminate)
    parser = build_parser()
    args = parser.parse_args(argv)
    level = [logging.WARNING, logging.INFO, logging.DEBUG][min(args.verbose, 2)]
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    try:
        if args.command != "track":  # track says it its own way (--live)
            from sotmot.cli.commands import refuse_urls

            refuse_urls([*getattr(args, "seq_dirs", ()), *([args.seq_dir] if hasattr(args, "seq_dir") else [])],
                        f"{args.command} reads a sequence folder, a video file or a folder of images; a stream is "
                        f"tracked live (sotmot track --live URL)")
        return args.func(args)
    except SotmotError as exc:
        print(f"sotmot: error: {exc}", file=sys.stderr)
        return 2
    except Terminated:
        print("sotmot: terminated", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("sotmot: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
