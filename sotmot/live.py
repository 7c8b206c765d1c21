"""A live source tracked into files (``sotmot track --live``): a camera, a network stream or a video read once as
it plays, in committed windows (:func:`sotmot.stream`), each window's final boxes appended to the results as they
come. The files are those ``sotmot track --window`` writes (:mod:`sotmot.runs`), beside a run record that names the
source instead of hashing inputs (:func:`sotmot.provenance.live_record`)."""

from __future__ import annotations

import logging
import sys
import time
from contextlib import closing
from pathlib import Path

from sotmot.api import stream_config
from sotmot.appearance import resolve_backend
from sotmot.config import TrackerConfig
from sotmot.detection import detections_header, detections_path, format_detections
from sotmot.errors import InputError, SotmotError
from sotmot.hashing import file_sha256
from sotmot.io import check_output_dir, format_results, guard_outputs, results_path, write_text_atomic
from sotmot.io.flags import FLAGS_HEADER, flags_path, format_flags
from sotmot.io.video import open_live, paced, shown
from sotmot.models import model_in_use
from sotmot.provenance import live_record, record_path, write_record
from sotmot.runs import Outcome, append_lines, low_confidence_path, output_paths, resolve_paths

log = logging.getLogger(__name__)
#: A camera's frame final this many windows after it came means the tracker fell behind the camera: the reader
#: holds two windows of frames at most (:func:`sotmot.stream`), so the camera's later frames waited in its own
#: buffer (which may drop them).
BEHIND_WINDOWS = 2.0


def track_live(source: str, out_dir: str | Path, config: TrackerConfig, progress: bool = False,
               reads: tuple[str | Path | None, ...] = ()) -> Outcome:
    """Track a live source (``sotmot track --live``: a camera's number, a stream's URL, a video file read as it
    plays; :func:`sotmot.io.video.open_live`) in committed windows (:func:`sotmot.stream`; ``[windows] seconds``,
    30 s when unset), appending each window's final boxes to ``<name>.txt``, its flags (and unconfirmed boxes,
    ``--unconfirmed file``; the detector's boxes, ``<name>.det.txt``, when it runs) as soon as they are final,
    and saying in the run record how far they are (``live``: ``frames_final``; for a camera or a stream also
    ``late_s``, how long after it came the newest final frame was final, and ``behind`` once that exceeds
    :data:`BEHIND_WINDOWS` windows, with a warning).

    An earlier session's files of the same name in ``out_dir`` are never replaced: the run refuses before it reads
    a frame. The files are made when the first part is final, so a run that fails or is stopped before leaves none. A
    failure after keeps what is final (the outcome and the record say how far); Ctrl-C or SIGTERM too, the
    record saying where it stopped, then the interrupt goes on to the caller. A live source is read once:
    there is no ``--resume``. ``reads``: other files the run reads (``--config``), never written over.
    """
    from sotmot.api import stream  # read at each call: tests stand in for it

    config = resolve_paths(config)
    config = stream_config(config.replace("appearance", backend=resolve_backend(config.appearance).backend))
    frames, rate, name = open_live(source, config.input.fps)
    out = results_path(check_output_dir(out_dir), name)
    detected = config.detection.file is None  # the detector runs: its boxes are written beside the results
    outputs = output_paths(out_dir, name, config, detected=detected)
    guard_outputs(outputs, [config.detection.file, config.preprocess.mask, source, *reads],
                  hint="choose another --out")
    record = live_record(shown(source), rate, name, config)
    files = {out: "", flags_path(out): FLAGS_HEADER}
    if low_confidence_path(out) in outputs:
        files[low_confidence_path(out)] = ""
    if detected:
        files[detections_path(out)] = detections_header(model_in_use(config.detection.model, "detector"))
    earlier = [path for path in (*files, record_path(out)) if path.exists()]
    if earlier:  # an earlier session's boxes (a camera's cannot be had again): never replaced
        raise InputError(earlier[0], f"an earlier session of {name!r} left its results here, and a live session "
                                     f"never replaces them; give another --out, or move {out.name} and the files "
                                     f"beside it away")
    state = {"frames_final": 0, "complete": False}

    def progress_record() -> None:
        record["live"] = {**state, "bytes": {path.name: path.stat().st_size for path in files}}
        write_record(out, record)

    camera = paced(source)
    start = time.perf_counter()
    ids: set[int] = set()
    made: list[Path] = []
    try:
        with closing(stream(frames, frame_rate=rate, config=config, name=name, progress=progress)) as parts:
            for part in parts:
                if not state["frames_final"]:  # the first part: the files are made now, empty
                    for path, text in files.items():
                        write_text_atomic(path, text)
                        made.append(path)
                append_lines(out, format_results(part.tracks))
                append_lines(flags_path(out), format_flags(part.tracks))
                if low_confidence_path(out) in files:
                    append_lines(low_confidence_path(out), format_results(part.dropped))
                if part.detected is not None and detections_path(out) in files:
                    d = part.detected
                    append_lines(detections_path(out), format_detections(d.frames, d.boxes, d.scores))
                state["frames_final"] = part.last
                if camera:  # how long after its coming the newest final frame was final
                    state["late_s"] = round(time.perf_counter() - start - part.last / rate, 1)
                    if state["late_s"] > BEHIND_WINDOWS * config.windows.seconds and not state.get("behind"):
                        state["behind"] = True
                        log.warning("%s: frame %d was final %.0f s after it came: tracking is slower than the "
                                    "source, whose frames now wait in its own buffer, which may drop some (the "
                                    "tracker counts time by frames); track every k-th frame (--step K), "
                                    "fewer pixels ([detection] input_height), without re-ID (--appearance "
                                    "none) or on a faster machine",
                                    name, part.last, state["late_s"])
                progress_record()
                ids.update(int(i) for i in part.tracks.ids)
                log.info("%s: frames 1-%d final (%.0f s of the stream)", name, part.last, part.last / rate)
                if progress:
                    print(f"{name}: frames 1-{part.last} final ({part.last / rate:.0f} s of the stream; "
                          f"{time.perf_counter() - start:.0f} s)", file=sys.stderr)
    except BaseException as exc:
        if not state["frames_final"]:
            for path in made:  # stopped while the first part was being written: nothing is final
                path.unlink(missing_ok=True)
            raise
        state["stopped"] = "interrupted" if isinstance(exc, KeyboardInterrupt) else f"failed: {exc}"
        progress_record()
        kept = f"frames 1-{state['frames_final']} are final in {out} ({record_path(out).name} says so)"
        if isinstance(exc, SotmotError):
            return Outcome(shown(source), "failed", str(out), f"{shown(source)}: {exc}; {kept}")
        print(f"sotmot: {name}: stopped; {kept}", file=sys.stderr)
        raise
    state["complete"] = True
    record["results_sha256"] = file_sha256(out)
    record["side_files"] = {path.name: file_sha256(path) for path in files if path != out}
    progress_record()
    seconds = time.perf_counter() - start
    # a camera or a stream has no end of its own: OpenCV's read failed (unplugged, the connection dropped)
    ended = "; the source stopped giving frames" if camera else ""
    return Outcome(shown(source), "done", str(out),
                   f"{name}: {state['frames_final']} frames ({state['frames_final'] / rate:.0f} s at {rate:g} "
                   f"frames/s) in windows of {config.windows.seconds:g} s, {len(ids)} tracks, "
                   f"{state['frames_final'] / seconds:.1f} frames/s -> {out}{ended}")
