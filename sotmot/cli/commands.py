"""The sub-commands' work: each ``cmd_<name>`` takes the parsed arguments, calls the library and prints."""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from sotmot.cli.flags import build_config
from sotmot.errors import SotmotError

#: train-appearance warns when fewer people than this are held out: their validation AUC is then mostly chance.
MIN_VALIDATION_IDENTITIES = 5

def _int_at_least(text: str, lowest: int) -> int:
    """An integer >= ``lowest`` from ``text``, else argparse's error saying why."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < lowest:
        raise argparse.ArgumentTypeError(f"must be at least {lowest}, got {value}")
    return value


def _positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    return _int_at_least(text, 1)


def _non_negative_int(text: str) -> int:
    """argparse type: an integer >= 0."""
    return _int_at_least(text, 0)


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


def refuse_urls(paths, why: str) -> None:
    """Refuse a stream's URL given where a path goes, named without its password (:func:`~sotmot.io.video.shown`):
    ``why`` says what to do instead. A URL given as a path has lost a slash (``rtsp://host`` -> ``rtsp:/host``)."""
    from sotmot.io.video import URL, shown

    for seq in paths:
        url = str(seq).replace(":/", "://", 1)
        if URL.match(url) and not Path(seq).exists():
            raise SotmotError(f"{shown(url)}: {why}")


def cmd_track(args: argparse.Namespace) -> int:
    from sotmot.io.video import is_video

    if args.live is not None:
        return _track_live(args)
    if not args.seq_dirs:
        raise SotmotError("nothing to track: give SEQ_DIR (a sequence folder, a video, a folder of images) or "
                          "--live SOURCE (a camera, a stream)")
    refuse_urls(args.seq_dirs, "a stream is tracked with --live URL (a camera with --live 0)")
    videos = [p for p in args.seq_dirs if is_video(p)]
    if args.det is not None and len(args.seq_dirs) > 1:
        raise SotmotError("--det belongs to one video or sequence; track several in separate runs")
    if videos and args.eval:
        raise SotmotError(f"{videos[0]}: --eval needs ground truth (a sequence folder with gt/gt.txt); a video has "
                          f"none")
    config = _track_config(args, f"{videos[0]}: a video" if videos else None)
    return _track(args, config, args.seq_dirs)  # a video's frames are read from the file itself


def _track_config(args: argparse.Namespace, without_det: str | None):
    """The configuration of a ``track`` run: its flags (:func:`build_config`) and ``--det`` (which must exist and
    not come with ``--detections model``). ``without_det``: the input that has no det.txt of its own ("VIDEO: a
    video"), named when the configuration asks for a detections file and ``--det`` gives none."""
    if args.det is not None and args.detections == "model":
        raise SotmotError("--det gives the detections, --detections model asks the detector for them: choose one")
    config = build_config(args)
    if args.det is not None:  # read where it lies: its errors name it, its run record (if any) says its detector
        if not args.det.is_file():
            raise SotmotError(f"{args.det}: detections file not found (--det)")
        config = config.replace("detection", file=str(args.det))
    if without_det and config.detection.source == "file" and config.detection.file is None:
        raise SotmotError(f"{without_det} has no det.txt: give its detections with --det FILE, or let the detector "
                          f"find the people (--detections auto or model)")
    return config


def _track_live(args: argparse.Namespace) -> int:
    """``sotmot track --live SOURCE``: :func:`sotmot.live.track_live`."""
    from sotmot.io.video import shown
    from sotmot.live import track_live

    asked = [flag for flag, given in (("SEQ_DIR", args.seq_dirs), ("--eval", args.eval), ("--resume", args.resume),
                                      ("--workers", args.workers > 1), ("--cluster", args.cluster)) if given]
    if asked:
        raise SotmotError(f"--live reads one source once, as it comes: not with {', '.join(asked)}")
    config = _track_config(args, f"{shown(args.live)}: a live source")
    made = not args.out.exists()
    try:
        outcome = track_live(args.live, args.out, config, progress=_progress(args), reads=(args.config,))
    finally:
        if made and args.out.is_dir() and not any(args.out.iterdir()):
            args.out.rmdir()  # this run made the folder and wrote nothing into it
    if outcome.status == "failed":
        print(f"sotmot: error: {outcome.message}", file=sys.stderr)
        return 2
    print(outcome.message)
    return 0


def _track(args: argparse.Namespace, config, seq_dirs: list[Path]) -> int:
    from sotmot.runs import sequence_inputs, sequence_outputs, track_many
    from sotmot.io import read_seqinfo, refuse_overwriting

    infos = [read_seqinfo(s, config.input.fps) for s in seq_dirs]  # a bad folder or video fails before any work
    names = [i.name for i in infos]
    if len(set(names)) != len(names):
        raise SotmotError(f"two sequences share a name: {names}")
    for info in infos:
        refuse_overwriting(sequence_outputs(args.out, info, config), [*sequence_inputs(info, config), args.config],
                           "choose another --out")  # --config may be a run record in --out
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
        if ran == "openvino":
            other = "--appearance onnx runs onnxruntime"
        elif config.appearance.device != "cpu":
            other = f"OpenVINO, the faster backend on the CPU, is not used on --device {config.appearance.device}"
        else:
            other = "openvino, a dependency of sotmot, gives a backend about twice as fast: pip install openvino"
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
    from sotmot.io import guard_outputs, read_seqinfo, results_path

    if path.is_dir():
        raise SotmotError(f"{path}: --json must name a file, but this is a folder")
    inputs, folders = [], []
    for seq in seq_dirs:
        info = read_seqinfo(seq, rate_needed=False)
        inputs += [info.source, info.det_path, info.gt_path]
        if info.video is None:  # a sequence folder or a folder of images: no report lands among its files
            folders += [info.path, info.frames_dir]
        if results_dir is not None:
            inputs.append(results_path(results_dir, info.name))
    guard_outputs([path], inputs, folders, "choose another --json")


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

    plain = [seq for seq in args.seq_dirs if seq.is_dir() and not (seq / "seqinfo.ini").is_file()]
    if (args.results_dir / "seqinfo.ini").is_file() and plain:
        raise SotmotError(f"{args.results_dir} is a sequence folder and {plain[0]} is not: eval takes the results "
                          f"folder first, then the sequences (sotmot eval {plain[0]} {args.results_dir})")
    _check_json(args.json, args.seq_dirs, args.results_dir)
    doubts = {}  # said before the scores: a partial or changed file is not scored as if it were the whole run
    for seq in args.seq_dirs:
        name = read_seqinfo(seq, rate_needed=False).name
        for doubt in results_doubts(results_path(args.results_dir, name)):
            print(f"sotmot: warning: {doubt}", file=sys.stderr)
            doubts.setdefault(name, []).append(doubt)
    report = evaluate(args.results_dir, args.seq_dirs)
    print(format_table(report))
    print("TrackEval rules: " + ", ".join(f"{name} {rules}" for name, rules in report.benchmark.items())
          + " (MOT16: boxes on distractor classes removed; MOT15: people marked 0 in gt.txt left out, a box on "
            "them counts as false)")
    if doubts:
        print(f"sotmot: the scores of {', '.join(doubts)} are of results that are not a whole run as it was "
              f"written (warnings above)", file=sys.stderr)
    _write_json(args.json, {**report.to_dict(), **({"warnings": doubts} if doubts else {})}, "scores")
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

    config = build_config(args)
    for seq in args.seq_dirs:  # every solver is scored: the ground truth must be there, said before the work
        info = read_seqinfo(seq, config.input.fps)
        if info.video is not None:
            raise SotmotError(f"{seq}: compare scores each solver against ground truth (gt/gt.txt of a sequence "
                              f"folder); a video has none")
        if not info.gt_path.is_file():
            raise SotmotError(f"{info.gt_path}: compare scores each solver against the ground truth of {info.name}, "
                              f"and there is none")
    _check_json(args.json, args.seq_dirs)
    result = compare(args.seq_dirs, solvers, config, progress=_progress(args), jitter=args.jitter)
    print(format_comparison(result))
    _write_json(args.json, result.to_dict(), "comparison")
    return 0


def cmd_render(args: argparse.Namespace) -> int:
    from sotmot.io import refuse_overwriting
    from sotmot.io.video import is_video
    from sotmot.io.flags import flags_path
    from sotmot.runs import low_confidence_path

    if args.seq_dir.is_file() and not is_video(args.seq_dir) and (args.results.is_dir() or is_video(args.results)):
        raise SotmotError(f"{args.seq_dir} is a results file and {args.results} what was tracked: render takes the "
                          f"sequence, video or folder of images first, then the results (sotmot render "
                          f"{args.results} {args.seq_dir} --out ...)")
    inputs = [args.seq_dir, args.results, flags_path(args.results), low_confidence_path(args.results), args.mask]
    refuse_overwriting([args.out], inputs, "choose another --out")  # before a video is read
    if args.gt and is_video(args.seq_dir):
        raise SotmotError("--gt needs a sequence folder with gt/gt.txt, not a video")
    return _render(args, args.seq_dir, inputs)


def _render(args: argparse.Namespace, seq_dir: Path, inputs: list[Path]) -> int:
    from sotmot.io import read_results, read_seqinfo
    from sotmot.progress import progress_bar
    from sotmot.inspect.render import check_render_target, render
    from sotmot.io.flags import flags_path, read_flags
    from sotmot.provenance import partial_doubt, side_file_doubt

    info = read_seqinfo(seq_dir, args.fps)
    check_render_target(info, args.out, inputs)  # before reading and matching anything
    tracks = read_results(args.results, info.length)
    partial = partial_doubt(args.results)
    if partial:  # drawn, but never as if it were the whole run
        print(f"sotmot: warning: {partial}: the frames after the last final one are drawn without boxes",
              file=sys.stderr)
    doubt = side_file_doubt(args.results, flags_path(args.results))
    if doubt:
        print(f"sotmot: warning: {doubt}: drawn without the SOT and interpolation markers", file=sys.stderr)
    else:
        tracks = read_flags(args.results, tracks)
    dropped = None
    if args.dropped:
        from sotmot.runs import low_confidence_path

        low = low_confidence_path(args.results)
        if not low.is_file():
            raise SotmotError(f"{low}: --dropped draws the boxes confirmation dropped from this file beside the "
                              f"results, and there is none; track with --unconfirmed file to keep them there")
        doubt = side_file_doubt(args.results, low)
        if doubt:
            raise SotmotError(f"{doubt}: its boxes would be drawn as another run's dropped ones")
        dropped = read_results(low, info.length)
    mask = None
    if args.mask is not None:
        from sotmot.io.mask import read_mask

        mask = read_mask(args.mask, info.width, info.height, info.name)
    errors = None
    if args.gt:
        from sotmot.scoring import frame_errors

        errors = frame_errors(args.results, info.gt_path, info.length, info.name)
        totals = errors.totals()
        print(f"CLEAR matching (as TrackEval): FP {totals['FP']}, FN {totals['FN']}, IDSW {totals['IDSW']}")
    out = render(info, tracks, args.out, errors=errors, inputs=inputs, dropped=dropped, mask=mask,
                 progress=lambda it: progress_bar(it, f"{info.name}: render", _progress(args), info.length))
    also = f" and {len(dropped)} dropped boxes" if dropped is not None else ""
    print(f"{info.length} frames, {tracks.n_tracks} tracks{also} -> {out}")
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

    for kind, model in MODELS.items():
        bundled_path(kind)  # a changed or cut bundled file: one clear error, not a table that hides it
        given = os.environ.get(model.env_var)
        if given and not Path(given).expanduser().is_file():  # every run would fail on it: said here first
            raise SotmotError(f"{model.env_var}={given}: no such file; every run would fail to open it. Give the "
                              f"path of a {kind} model file, or unset {model.env_var} for the bundled one")
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


def _track_for_inspection(args: argparse.Namespace, config, seq):
    """``seq`` (a path, or the :class:`~sotmot.io.SeqInfo` the command read already) tracked with ``config``, the
    whole sequence at once (``[windows]`` said to be ignored: its track ids are an unwindowed run's); with
    ``[input] step`` above 1 its tracked frames, as a sequence of their own (said: frames are counted as that
    run counts them)."""
    from sotmot.io import read_seqinfo
    from sotmot.pipeline import track_sequence
    from sotmot.stepping import track_tracked_frames

    if config.windows.seconds:
        print(f"sotmot: warning: [windows] seconds = {config.windows.seconds:g} is ignored here: the whole sequence "
              f"is tracked at once, and its track ids are those 'sotmot track' writes without --window (a windowed "
              f"run's may differ)", file=sys.stderr)
    step = config.input.step
    if step == 1:
        return track_sequence(seq, config, progress=_progress(args))
    print(f"sotmot: note: [input] step = {step}: the tracked frames are inspected as a sequence of their own, so "
          f"frame k here is the sequence's frame 1 + (k - 1) * {step} (track ids are those of the results file)",
          file=sys.stderr)
    info = seq if not isinstance(seq, (str, Path)) else read_seqinfo(seq, config.input.fps)
    return track_tracked_frames(info, config, progress=_progress(args))


def cmd_graph(args: argparse.Namespace) -> int:
    from sotmot.inspect.explain import graph_files, inspection_graph, parse_frames
    from sotmot.inspect.graph_view import SHOWN, html_page, png_bytes, shown_edges, tracklet_crops
    from sotmot.io import check_output_dir, read_seqinfo, write_files_atomic
    from sotmot.io.files import refuse_inside
    from sotmot.stepping import tracked_count

    config = build_config(args)
    info = read_seqinfo(args.seq_dir, config.input.fps)
    step = config.input.step
    frames = parse_frames(args.frames, tracked_count(info.length, step), step)  # the frames tracked
    if info.video is None:  # as track --out and render --out: never among the sequence's own files
        refuse_inside(args.out, [info.path, info.frames_dir])
    check_output_dir(args.out)  # a file, a read-only folder: said now, not after the tracking
    result = _track_for_inspection(args, config, info)
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
    from sotmot.inspect.explain import (explain, explain_confirmation, explain_gaps, explain_tracklets,
                                        inspection_graph, parse_ids, track_table)

    if (args.ids is not None) + (args.tracklets is not None) + bool(args.tracks) != 1:
        raise SotmotError("give one of --ids (one or two track ids of the results file), --tracklets (two tracklet "
                          "ids as 'sotmot graph' draws them) or --tracks (every track in a table)")
    # ids are checked before the tracking, which takes the time
    ids = None if args.tracks else parse_ids(args.ids) if args.ids is not None else parse_ids(args.tracklets,
                                                                                              "tracklet")
    config = build_config(args)
    result = _track_for_inspection(args, config, args.seq_dir)
    if ids is None:
        print(track_table(result, config))
        return 0
    a, b = ids
    graph = inspection_graph(result, config)
    print(explain(graph, a, b, config) if args.ids is not None else explain_tracklets(graph, a, b, config))
    if args.ids is not None and a == b:  # one track: also what filled the holes between its tracklets, and
        print(explain_gaps(result, config, a))  # how confirmation judged its boxes
        print(explain_confirmation(result, config, a))
    return 0
