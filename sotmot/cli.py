"""The ``sotmot`` command line. It only parses arguments and prints; the work is in the library."""

from __future__ import annotations

import argparse
import json
import logging
import math
import signal
import sys
import threading
import typing
from pathlib import Path

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
  sotmot track ../shared/data/MOT16-09 --detections model --out results   # the detector, not det/det.txt

The models are the two sotmot ships with (`sotmot models` lists them): Intel's
person-reidentification-retail-0288 and person-detection-0202 (Apache-2.0). Another model comes
from --reid-model / --detector-model, the config, or the environment variables SOTMOT_REID_MODEL
and SOTMOT_DETECTOR_MODEL. A sequence folder with det/det.txt is tracked from that
file; a plain video (or --detections model) from the detector's boxes, written beside the
results as <name>.det.txt (MOTChallenge det format) so that the run can be repeated with --det.
Results are written as DIR/<name>.txt (MOTChallenge format: frame, id, x, y, w, h,
score, -1, -1, -1; boxes in pixels, frames 1-based), each file atomically; <name> is
the name in seqinfo.ini and must be a plain file name (no path separators). Beside it:
<name>.flags.csv (interpolated / SOT boxes, each box's confidence) and <name>.run.json
(sotmot version, full configuration, solver, model and input hashes, time); --resume
skips a sequence only when that record matches the current run.
"""

#: train-appearance warns when fewer people than this are held out: their validation AUC is then mostly chance.
MIN_VALIDATION_IDENTITIES = 5

EPILOG_EVAL = """\
Scores RESULTS_DIR/<name>.txt against SEQ_DIR/gt/gt.txt with TrackEval (HOTA, CLEAR,
Identity). MOT16-layout ground truth (9 columns) is scored with the MOT16 rules
(distractor classes removed); 2DMOT2015-layout ground truth with the plain rules.

example:
  sotmot eval results ../shared/data/PETS09-S2L1 --json scores.json
"""


def _positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def _frame_rate(text: str) -> float:
    """argparse type: a frame rate above 0 and at most :data:`sotmot.io.mot.MAX_FRAME_RATE`."""
    from sotmot.io.mot import MAX_FRAME_RATE

    value = _positive_float(text)
    if value > MAX_FRAME_RATE:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_FRAME_RATE:g} frames per second, got {text}")
    return value


def _positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f"must be a finite number above 0, got {text}")
    return value


def _progress(args: argparse.Namespace) -> bool:
    """Progress bars only for a person watching: not with -q, not when stderr is a file or a pipe."""
    return not args.quiet and sys.stderr.isatty()


def _add_tracker_options(p: argparse.ArgumentParser) -> None:
    from sotmot.config import SECTIONS, ConfidenceMethod  # light: the config imports no plug-in

    p.add_argument("--config", type=Path, metavar="FILE",
                   help="TOML or JSON file with " + ", ".join(f"[{name}]" for name in SECTIONS)
                        + " tables (docs/configuration.md); unknown keys are errors")
    p.add_argument("--reid-model", metavar="PATH",
                   help="ONNX (or OpenVINO IR) person re-ID model instead of the bundled "
                        "person-reidentification-retail-0288 (overrides the config and SOTMOT_REID_MODEL)")
    from sotmot.plugins import BACKENDS

    p.add_argument("--appearance", choices=["auto", *sorted(BACKENDS)],
                   help="run the re-ID model with openvino (about twice as fast on CPUs, the same tracking scores; "
                        "a dependency of sotmot), onnxruntime (onnx) or torch (the torch extra); auto = openvino where "
                        "it is installed and the device is the CPU, else onnx (default: auto); none = no re-ID, "
                        "motion only: tracklets by IoU, links by motion agreement, no model, no frames read for "
                        "appearance")
    p.add_argument("--no-flip", action="store_true",
                   help="embed each box's crop once instead of averaging it with its mirror image ([appearance] "
                        "flip = false): half the re-ID work, at a cost in accuracy on some sequences (the gates "
                        "were chosen with the flip; docs/benchmarks.md, 'Speed')")
    p.add_argument("--device", choices=["cpu", "cuda"], help="where the re-ID model runs (default: cpu)")
    p.add_argument("--weights", metavar="FILE.pt", help="fine-tuned weights from train-appearance (torch backend)")
    p.add_argument("--detections", choices=["auto", "file", "model"],
                   help="where the boxes come from ([detection] source): file = the sequence's det/det.txt (or "
                        "--det), model = the person detector (--detector-model) run on every frame, auto = the "
                        "file when there is one, else the model (default)")
    p.add_argument("--detector-model", metavar="PATH.xml",
                   help="person detector, an OpenVINO IR .xml with its .bin beside it, instead of the bundled "
                        "person-detection-0202 (overrides the config and SOTMOT_DETECTOR_MODEL)")
    p.add_argument("--score-threshold", type=float, metavar="S",
                   help="drop detections scoring below S (default: keep all)")
    p.add_argument("--nms", choices=["auto", "iou", "iom", "none"],
                   help="NMS overlap: auto = IoM for non-probability scores such as DPM's, else IoU (default: auto)")
    p.add_argument("--confidence", choices=typing.get_args(ConfidenceMethod),
                   help="how detector scores become confidences in [0, 1]: a stored map per detector family "
                        "(dpm, acf, frcnn, sdp; pd0202 the built-in detector), the score's rank in the sequence "
                        "(quantile), a map fitted on the sequence from what the tracker made of it (self: long "
                        "trajectories against lone boxes), scores as they are (raw), or auto = pd0202 for the "
                        "built-in detector's boxes, "
                        "else the family the sequence's name ends with (-DPM, -FRCNN, -SDP), else the one guessed "
                        "from the score range (default: auto)")
    p.add_argument("--unconfirmed", choices=["drop", "file", "keep"],
                   help="boxes more likely false than true after association: drop them (default), write them "
                        "to DIR/<name>.low.txt, or keep them (confirmation off); see docs/calibration.md")
    p.add_argument("--extend-ends", type=float, metavar="SECONDS",
                   help="SOT after association: follow each confirmed trajectory the confirmation trusts up to "
                        "SECONDS past its last and before its first box, re-ID checked (default: the config's, 1; "
                        "0 turns it off)")
    p.add_argument("--refine-gaps", action="store_true",
                   help="SOT after association: replace interpolated boxes by boxes found in the frames where "
                        "template and re-ID agree (default: off)")
    p.add_argument("--verify-sot", choices=["auto", "none", "detector"],
                   help="check every box SOT finds with the person detector's weak boxes (down to [sot] "
                        "verify_min_score): a found box a detector box overlaps is replaced by it (box regression), "
                        "and the trajectory ends are extended by the detector's boxes (ends are re-ID checked; "
                        "[sot] extend_by); tracks still start only from the detections tracked. 'auto' (default): "
                        "on when the detections come from the detector, off for a det.txt; 'detector' with a det.txt "
                        "is 'public, refined' and needs --detector-model")
    p.add_argument("--camera-motion", choices=["auto", "on", "off"],
                   help="camera-motion compensation: estimate the camera's motion from the frames and compare "
                        "positions (tracklets, association, interpolation, end extension) in frame 1's pixels; "
                        "auto does so only when frames half a second apart moved (a still camera's results do not "
                        "change) (default: the config's, auto)")
    p.add_argument("--sot", choices=["none", "template", "deep"],
                   help="single-object-tracking step that adds missed boxes (paper Algorithm 1): template = "
                        "OpenCV correlation, deep = re-ID re-ranking (default: the config's, see docs)")
    p.add_argument("--sot-rules", choices=["paper", "confident"],
                   help="which boxes the SOT step keeps: paper = Algorithm 1 as published (every extension), "
                        "confident = only extensions that reach another box, none overlapping a box at IoU > "
                        "[sot] stop_iou, searched along the extension's motion (default: the config's)")


def _build_config(args: argparse.Namespace):
    from sotmot.config import TrackerConfig, load_config

    config = load_config(args.config) if args.config else TrackerConfig()
    if args.reid_model:
        config = config.replace("appearance", model=args.reid_model)
    if args.appearance:
        config = config.replace("appearance", backend=args.appearance)
    if getattr(args, "fps", None):
        config = config.replace("input", fps=args.fps)
    if getattr(args, "no_flip", False):
        config = config.replace("appearance", flip=False)
    if args.device:
        config = config.replace("appearance", device=args.device)
    if args.weights:
        config = config.replace("appearance", backend="torch", weights=args.weights)
    if args.detections:
        config = config.replace("detection", source=args.detections)
    if args.detector_model:
        config = config.replace("detection", model=args.detector_model)
    if args.score_threshold is not None:
        config = config.replace("preprocess", score_threshold=args.score_threshold)
    if args.nms:
        config = config.replace("preprocess", nms=args.nms)
    if args.confidence:
        config = config.replace("preprocess", confidence=args.confidence)
    if args.unconfirmed == "keep":
        config = config.replace("confirm", enabled=False)
    elif args.unconfirmed:
        config = config.replace("confirm", enabled=True, low_confidence=args.unconfirmed)
    if args.sot:
        config = config.replace("sot", variant=args.sot)
    if args.sot_rules:
        config = config.replace("sot", rules=args.sot_rules)
    if args.verify_sot:
        config = config.replace("sot", verify=args.verify_sot)
    if getattr(args, "refine_gaps", False):
        config = config.replace("sot", refine_gaps=True)
    if args.extend_ends is not None:
        config = config.replace("sot", extend_seconds=args.extend_ends)
    if getattr(args, "solver", None):
        config = config.replace("association", solver=args.solver)
    if getattr(args, "camera_motion", None):
        config = config.replace("motion", compensation=args.camera_motion)
    if getattr(args, "window", None) is not None:
        config = config.replace("windows", seconds=args.window)
    return config


def cmd_track(args: argparse.Namespace) -> int:
    from sotmot.io.video import is_video

    videos = [p for p in args.seq_dirs if is_video(p)]
    if args.det is not None and len(args.seq_dirs) > 1:
        raise SotmotError("--det belongs to one video or sequence; track several in separate runs")
    if args.det is not None and args.detections == "model":
        raise SotmotError("--det gives the detections, --detections model asks the detector for them: choose one")
    if videos and args.eval:
        raise SotmotError(f"{videos[0]}: --eval needs ground truth (a sequence folder with gt/gt.txt); a video has "
                          f"none")
    config = _build_config(args)
    if args.det is not None:  # read where it lies: its errors name it, its run record (if any) says its detector
        if not args.det.is_file():
            raise SotmotError(f"{args.det}: detections file not found (--det)")
        config = config.replace("detection", file=str(args.det))
    if videos and config.detection.source == "file" and config.detection.file is None:
        raise SotmotError(f"{videos[0]}: a video has no det.txt: give its detections with --det FILE, or let the "
                          f"detector find the people (--detections auto or model)")
    return _track(args, config, args.seq_dirs)  # a video's frames are read from the file itself


def _track(args: argparse.Namespace, config, seq_dirs: list[Path]) -> int:
    from sotmot.runs import sequence_inputs, sequence_outputs, track_many
    from sotmot.io import read_seqinfo, refuse_overwriting

    infos = [read_seqinfo(s, config.input.fps) for s in seq_dirs]  # a bad folder or video fails before any work
    names = [i.name for i in infos]
    if len(set(names)) != len(names):
        raise SotmotError(f"two sequences share a name: {names}")
    for info in infos:
        refuse_overwriting(sequence_outputs(args.out, info, config), sequence_inputs(info, config),
                           "choose another --out")
        if args.eval and not info.gt_path.is_file():
            raise SotmotError(f"{info.gt_path}: --eval needs the ground truth of {info.name}, and there is none; "
                              f"track without --eval")

    def report(outcome) -> None:
        from tqdm import tqdm

        failed = outcome.status == "failed"
        # tqdm.write keeps the lines clear of the progress bars
        tqdm.write(f"sotmot: error: {outcome.message}" if failed else outcome.message,
                   file=sys.stderr if failed else sys.stdout)

    if config.appearance.backend == "auto" and not args.quiet:
        from sotmot.appearance import resolve_backend

        ran = resolve_backend(config.appearance).backend
        other = ("--appearance onnx runs onnxruntime" if ran == "openvino"
                 else "openvino, a dependency of sotmot, gives a backend about twice as fast: pip install openvino")
        print(f"sotmot: re-ID by {ran} (--appearance auto; {other})", file=sys.stderr)
    made = not args.out.exists()
    outcomes = track_many(seq_dirs, args.out, config, workers=args.workers,
                          resume=args.resume, progress=_progress(args), report=report, cluster=args.cluster)
    failed = [o for o in outcomes if o.status == "failed"]
    if failed:
        if len(failed) < len(outcomes):
            print(f"sotmot: {len(failed)} of {len(outcomes)} sequences failed; the others' results are in "
                  f"{args.out}", file=sys.stderr)
            return 2
        if made and args.out.is_dir() and not any(args.out.iterdir()):
            args.out.rmdir()  # this run made the folder and wrote nothing into it
        what = "the sequence" if len(outcomes) == 1 else f"all {len(outcomes)} sequences"
        kept = "; what was committed before the failure is kept" if any(o.results for o in failed) else \
            "; no results written"
        print(f"sotmot: {what} failed{kept}", file=sys.stderr)
        return 2
    if args.eval:
        return cmd_eval(argparse.Namespace(results_dir=args.out, seq_dirs=seq_dirs, json=None))
    return 0


def _check_json(path: Path | None, seq_dirs: list[Path], results_dir: Path | None = None) -> None:
    """Refuse, before the work, a ``--json`` that is a folder or one of the files the command reads."""
    if not path:
        return
    from sotmot.io import read_seqinfo, refuse_overwriting, results_path

    if path.is_dir():
        raise SotmotError(f"{path}: --json must name a file, but this is a folder")
    inputs = []
    for seq in seq_dirs:
        info = read_seqinfo(seq)
        inputs += [info.source, info.det_path, info.gt_path]
        if results_dir is not None:
            inputs.append(results_path(results_dir, info.name))
    refuse_overwriting([path], inputs, "choose another --json")


def _json_ready(value):
    """``value`` with every NaN or infinite float as None: JSON has no NaN (``JSON.parse`` refuses it)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_ready(v) for v in value]
    return value


def _write_json(path: Path | None, data: dict, what: str) -> None:
    """Write ``data`` as JSON to ``path`` (atomically) when a path was given (checked by :func:`_check_json` before
    the work), and say so."""
    if path:
        from sotmot.io import write_text_atomic

        try:
            write_text_atomic(path, json.dumps(_json_ready(data), indent=2, allow_nan=False) + "\n")
        except OSError as exc:
            raise SotmotError(f"{path}: cannot write the {what}: {exc.strerror}") from exc
        print(f"{what} written to {path}")


def cmd_eval(args: argparse.Namespace) -> int:
    from sotmot.io import read_seqinfo, results_path
    from sotmot.provenance import results_doubts
    from sotmot.scoring import evaluate, format_table

    _check_json(args.json, args.seq_dirs, args.results_dir)
    report = evaluate(args.results_dir, args.seq_dirs)
    for seq in args.seq_dirs:
        for doubt in results_doubts(results_path(args.results_dir, read_seqinfo(seq).name)):
            print(f"sotmot: warning: {doubt}", file=sys.stderr)
    print(format_table(report))
    print("TrackEval rules: " + ", ".join(f"{name} {rules}" for name, rules in report.benchmark.items())
          + " (MOT16: distractor classes removed; MOT15: every ground-truth box counts)")
    _write_json(args.json, report.to_dict(), "scores")
    return 0


def cmd_compare(args: argparse.Namespace) -> int:
    from sotmot.association import get_solver
    from sotmot.inspect.compare import compare, format_comparison

    solvers = [m.strip() for m in args.solvers.split(",")]
    if not all(solvers):
        raise SotmotError(f"--solvers {args.solvers!r}: give solver names separated by commas, none empty "
                          f"(e.g. greedy,flow)")
    if len(set(solvers)) != len(solvers):
        raise SotmotError(f"--solvers {args.solvers!r} names a solver twice")
    for m in solvers:
        get_solver(m)  # unknown names fail here, listing the valid ones
    from sotmot.io import read_seqinfo

    for seq in args.seq_dirs:  # every solver is scored: the ground truth must be there, said before the work
        info = read_seqinfo(seq)
        if info.video is not None:
            raise SotmotError(f"{seq}: compare scores each solver against ground truth (gt/gt.txt of a sequence "
                              f"folder); a video has none")
        if not info.gt_path.is_file():
            raise SotmotError(f"{info.gt_path}: compare scores each solver against the ground truth of {info.name}, "
                              f"and there is none")
    config = _build_config(args)
    _check_json(args.json, args.seq_dirs)
    result = compare(args.seq_dirs, solvers, config, progress=_progress(args))
    print(format_comparison(result))
    _write_json(args.json, result.to_dict(), "comparison")
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from sotmot.io import refuse_overwriting
    from sotmot.io.video import is_video
    from sotmot.io.flags import flags_path

    inputs = [args.seq_dir, args.results, flags_path(args.results)]
    refuse_overwriting([args.out], inputs, "choose another --out")  # before a video is read
    if args.gt and is_video(args.seq_dir):
        raise SotmotError("--gt needs a sequence folder with gt/gt.txt, not a video")
    return _render(args, args.seq_dir, inputs)


def _render(args: argparse.Namespace, seq_dir: Path, inputs: list[Path]) -> int:
    from sotmot.io import read_results, read_seqinfo
    from sotmot.progress import progress_bar
    from sotmot.inspect.render import check_render_target, render
    from sotmot.io.flags import flags_path, read_flags
    from sotmot.provenance import side_file_doubt

    info = read_seqinfo(seq_dir)
    check_render_target(info, args.out, inputs)  # before reading and matching anything
    tracks = read_results(args.results, info.length)
    doubt = side_file_doubt(args.results, flags_path(args.results))
    if doubt:
        print(f"sotmot: warning: {doubt}: drawn without the SOT and interpolation markers", file=sys.stderr)
    else:
        tracks = read_flags(args.results, tracks)
    errors = None
    if args.gt:
        from sotmot.scoring import frame_errors

        errors = frame_errors(args.results, info.gt_path, info.length, info.name)
        totals = errors.totals()
        print(f"CLEAR matching (as TrackEval): FP {totals['FP']}, FN {totals['FN']}, IDSW {totals['IDSW']}")
    out = render(info, tracks, args.out, errors=errors, inputs=inputs,
                 progress=lambda it: progress_bar(it, f"{info.name}: render", _progress(args), info.length))
    print(f"{info.length} frames, {tracks.n_tracks} tracks -> {out}")
    return 0


def cmd_train(args: argparse.Namespace) -> int:
    from sotmot.config import AppearanceConfig
    from sotmot.progress import progress_bar
    from sotmot.train import TrainConfig, train

    from sotmot.io import refuse_overwriting

    refuse_overwriting([args.out], [args.init, *(Path(s) / "gt" / "gt.txt" for s in args.seq_dirs)],
                       "choose another --out")
    config = TrainConfig(epochs=args.epochs, margin=args.margin, lr=args.lr, train_last=args.train_last,
                         seed=args.seed)
    appearance = AppearanceConfig(model=args.init, backend="torch", device=args.device)
    summary = train(args.seq_dirs, appearance, args.out, config,
                    progress=lambda it: progress_bar(it, "epochs", _progress(args), config.epochs))
    for h in summary["history"]:
        print(f"epoch {h['epoch']}: train loss {h['train_loss']:.4f}, validation AUC {h['val_auc']:.4f}")
    if summary["identities_val"] < MIN_VALIDATION_IDENTITIES:
        print(f"sotmot: warning: only {summary['identities_val']} validation identities: their AUC says little "
              f"about other people (an AUC of 1.0 is easy with two); train on more sequences, at least "
              f"{MIN_VALIDATION_IDENTITIES * 4} identities in all", file=sys.stderr)
    print(f"{summary['identities_train']} training / {summary['identities_val']} validation identities, "
          f"{summary['crops']} crops; validation AUC {summary['val_auc_before']:.4f} before, "
          f"{summary['val_auc_best']:.4f} best (epoch {summary['best_epoch']}); {summary['seconds']:.0f} s "
          f"-> {summary['out']}")
    return 0


def cmd_models(args: argparse.Namespace) -> int:
    from sotmot.models import MODELS, bundled_path, describe

    for kind in MODELS:
        bundled_path(kind)  # a changed or cut bundled file: one clear error, not a table that hides it
    rows = describe()
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for row in rows:
        print(f"{row['kind']}: {row['files'][0]} ({row['bytes'] / 1e6:.2f} MB, checked)")
        print(f"  origin   {row['origin']}")
        print(f"  licence  {row['licence']}")
        for name, digest in row["sha256"].items():
            print(f"  sha256   {digest}  {name}")
        print(f"  in use   {row['in_use']}")
        print(f"  change   {row['how_to_change']}")
    return 0


def _track_for_inspection(args: argparse.Namespace):
    from sotmot.pipeline import track_sequence

    config = _build_config(args)
    return config, track_sequence(args.seq_dir, config, progress=_progress(args))


def cmd_graph(args: argparse.Namespace) -> int:
    from sotmot.inspect.explain import graph_files, inspection_graph, parse_frames
    from sotmot.inspect.graph_view import SHOWN, html_page, png_bytes, shown_edges, tracklet_crops
    from sotmot.io import check_output_dir, read_seqinfo, write_files_atomic

    frames = parse_frames(args.frames, read_seqinfo(args.seq_dir).length)
    check_output_dir(args.out)  # a file, a read-only folder: said now, not after the tracking
    config, result = _track_for_inspection(args)
    graph = inspection_graph(result, config, frames)
    title = f"{result.info.name}: association graph ({config.association.solver})"
    files = {args.out / name: data for name, data in graph_files(graph).items()}
    files[args.out / "graph.png"] = png_bytes(graph)
    files[args.out / "graph.html"] = html_page(graph, tracklet_crops(result, graph), title).encode("utf-8")
    write_files_atomic(files)  # all four or none: a full disk leaves no partial set
    paths = list(files)
    taken = sum(1 for *_, d in graph.edges(data=True) if d["taken"])
    dropped = len({d["track"] for _, d in graph.nodes(data=True) if d["track"] >= 0 and not d["in_results"]})
    kept = len({d["track"] for _, d in graph.nodes(data=True) if d["in_results"]})
    print(f"{graph.number_of_nodes()} tracklets in {kept} tracks of the results"
          + (f" (and {dropped} tracks confirmation dropped)" if dropped else "")
          + f", {graph.number_of_edges()} candidate links ({taken} taken by {config.association.solver}); the "
          f"picture and the page draw {len(shown_edges(graph))} of them ({SHOWN}) -> " + ", ".join(map(str, paths)))
    return 0


def cmd_explain(args: argparse.Namespace) -> int:
    from sotmot.inspect.explain import explain, explain_tracklets, inspection_graph, parse_ids

    if (args.ids is None) == (args.tracklets is None):
        raise SotmotError("give --ids (one or two track ids of the results file) or --tracklets (two tracklet ids "
                          "as 'sotmot graph' draws them)")
    a, b = parse_ids(args.ids) if args.ids is not None else parse_ids(args.tracklets, "tracklet")
    config, result = _track_for_inspection(args)
    graph = inspection_graph(result, config)
    print(explain(graph, a, b, config) if args.ids is not None else explain_tracklets(graph, a, b, config))
    return 0


EPILOG_COMPARE = """\
Each sequence goes once through detection cleaning, appearance and tracklets; then every
solver runs on those same tracklets. Columns: TrackEval HOTA, MOTA, IDF1, IDSW; tracks, the
identities in the results the run writes (as 'sotmot track' writes them); lifted_obj, the one
objective every solver is scored on (the sum over pairs of tracklets in one trajectory within the
horizon of n_a * n_b times the learned log-likelihood ratio that they are one person, or
(affinity - lifted_threshold) with lifted_costs = "threshold"; higher is better); window_gap, for the lifted solver, how far CP-SAT's proved bound lies above
its solution in windows not proven optimal (0: every window optimal); flow_net_cost, the flow
network's own cost (entry cost per trajectory + (1 - affinity) per link; lower is better for that
network only); the solver's time in seconds.

example:
  sotmot compare ../shared/data/PETS09-S2L1 --solvers greedy,flow,lifted --json compare.json
"""


def build_parser() -> argparse.ArgumentParser:
    from sotmot.plugins import SOLVERS

    parser = argparse.ArgumentParser(
        prog="sotmot",
        description="Multi-object tracking of people by detection, after 'SOT for MOT' (He et al.): "
                    "Hungarian tracklets in 1-second batches, long-term association under IoU, velocity "
                    "and gap constraints, interpolation and smoothing. Input: MOTChallenge folders.")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    from sotmot.provenance import sotmot_version

    parser.add_argument("--version", action="version", version=f"sotmot {sotmot_version()}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("track", help="track sequences and write MOTChallenge results",
                       description="Track one or more MOTChallenge sequence folders.",
                       epilog=EPILOG_TRACK, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("seq_dirs", nargs="+", type=Path, metavar="SEQ_DIR",
                   help="folder with seqinfo.ini, img1/ and (usually) det/det.txt, or a video file (.mp4, .avi, ...)")
    p.add_argument("--out", type=Path, required=True, metavar="DIR", help="where <name>.txt results go")
    p.add_argument("--solver", "--merger", dest="solver", choices=sorted(SOLVERS),
                   help="long-term association solver ([association] solver): greedy (the paper's greedy merge, "
                        "default), flow (min-cost flow, OR-Tools), flow-nx (the same with networkx, slow; for "
                        "cross-checks), flow-staged (flow over short gaps first, then between the trajectories "
                        "made), lifted (the lifted objective, exact per window with CP-SAT; slower). "
                        "--merger is the older name")
    _add_tracker_options(p)
    p.add_argument("--det", type=Path, metavar="DET.txt",
                   help="the detections of the one video or sequence tracked (MOTChallenge layout: frame, id, x, y, "
                        "w, h, score; frames counted from 1 at the video's first frame), instead of its det/det.txt "
                        "or the detector; e.g. the <name>.det.txt a model run wrote")
    p.add_argument("--fps", type=_frame_rate, metavar="N",
                   help="with a video: its frame rate, when the container's is missing or wrong")
    p.add_argument("--eval", action="store_true", help="score the results with TrackEval afterwards")
    p.add_argument("--workers", type=_positive_int, default=1, metavar="N",
                   help="track N sequences at once in separate processes, or the windows of one sequence with "
                        "--window (default: 1; never more than the sequences or the CPUs; the workers end with this "
                        "process)")
    p.add_argument("--window", type=float, metavar="SECONDS",
                   help="track in committed windows of this many seconds ([windows] seconds; 0: off, the default): "
                        "memory holds one window, results are written while the video plays and --resume continues "
                        "an interrupted run after its last window; windows overlap by the association's gap")
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
    _add_tracker_options(p)
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
    p.add_argument("seq_dirs", nargs="+", type=Path, metavar="SEQ_DIR", help="sequences with gt/gt.txt and img1/")
    p.add_argument("--init", metavar="MODEL.onnx",
                   help="the re-ID model to start from (default: the bundled person-reidentification-retail-0288, "
                        "or SOTMOT_REID_MODEL)")
    p.add_argument("--out", type=Path, required=True, metavar="FILE.pt", help="checkpoint (best validation AUC)")
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
                   help="the sequence the results are of (frames from img1/), or the video file they were tracked on")
    p.add_argument("results", type=Path, metavar="RESULTS.txt",
                   help="MOTChallenge results, e.g. from sotmot track (its .flags.csv beside it marks SOT and "
                        "interpolated boxes)")
    p.add_argument("--out", type=Path, required=True, metavar="VIDEO.mp4|DIR",
                   help="a .mp4 or .avi file, or a folder name without extension for one JPEG per frame; never "
                        "inside the sequence folder, never over an input. A video or a new folder is written under "
                        "a hidden .partial name and renamed when complete; an existing folder must be empty or hold "
                        "an earlier render's NNNNNN.jpg frames only, and is written into frame by frame")
    p.add_argument("--gt", action="store_true", help="draw SEQ_DIR/gt/gt.txt beside, with the errors marked")
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
                             ("explain", cmd_explain, "say why two tracks (or two tracklets) were or were not merged")):
        p = sub.add_parser(name, help=text, description=text[0].upper() + text[1:] + ". The sequence is "
                           "tracked first, with the same options as 'sotmot track'; track ids are those "
                           "of the results file that run writes.")
        p.add_argument("seq_dir", type=Path, metavar="SEQ_DIR", help="folder with seqinfo.ini, det/det.txt and img1/")
        p.add_argument("--solver", "--merger", dest="solver", choices=sorted(SOLVERS),
                       help="long-term association solver whose links are shown (default: the config's, greedy)")
        if name == "graph":
            p.add_argument("--out", type=Path, required=True, metavar="DIR",
                           help="folder for graph.graphml, graph.json, graph.png and graph.html")
            p.add_argument("--frames", metavar="A:B", help="only tracklets that touch frames A..B")
        else:
            p.add_argument("--ids", metavar="ID[,ID]",
                           help="two track ids of the results file (e.g. 3,17: why they were not merged), or one "
                                "(e.g. 5: why its tracklets were merged into it)")
            p.add_argument("--tracklets", metavar="ID,ID",
                           help="two tracklet ids, as 'sotmot graph' draws them (e.g. 4,9: merged or not, and why)")
        _add_tracker_options(p)
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
