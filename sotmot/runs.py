"""Tracking many sequences: one after another, in worker processes on this machine, or on a Dask cluster.

Each sequence is one job that reads its own frames (nothing but paths and
the configuration crosses process or machine boundaries), writes
``<name>.low.txt`` (with ``[confirm] low_confidence = "file"``), ``<name>.flags.csv``,
``<name>.run.json`` (how it was made, :mod:`sotmot.provenance`) then ``<name>.txt``,
each atomically, and reports success or its error. A failing sequence never
loses the others' results; with ``resume`` a sequence is skipped when its
results file exists (written last, so it is complete) and its run record
matches the current run; otherwise the outcome says why it ran again.

On a Dask cluster (``cluster="dask://HOST:PORT"``, the scheduler of an
existing ``distributed`` cluster) the paths must name the same files on the
workers as here (a shared filesystem). The client resolves the whole run
before sending it: every sequence, ``--out``, and every model and
calibration path, however it was given (flag, config or environment
variable, :func:`resolve_paths`), made absolute; the workers read no
environment of their own. Each worker process loads the appearance model
once. A worker lost mid-sequence costs that sequence's run on another worker
(Dask reschedules the task): every file is written atomically, so nothing
half-written is left, and the results are those of a serial run.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from sotmot.config import TrackerConfig
from sotmot.errors import ConfigError, SotmotError
from sotmot.workers import dask_worker_threads, process_threads, worker_embedder

log = logging.getLogger(__name__)
_SLOTS = None  # free terminal lines for the per-sequence progress bars of pool workers
DASK_HINT = "install Dask's scheduler client with: pip install -e '.[dask]' (distributed)"


@dataclass(frozen=True)
class Outcome:
    """What happened to one sequence.

    Attributes
    ----------
    seq_dir
        The sequence folder.
    status
        ``"done"``, ``"skipped"`` (results existed, ``resume``) or ``"failed"``.
    results
        The results file (None if it failed before knowing the name).
    message
        One line: tracks and speed, or the error.
    """

    seq_dir: str
    status: str
    results: str | None
    message: str


def _die_with_parent() -> None:
    """End this worker process when the process that started it ends (TERM, KILL, a crash).

    Linux is asked to send SIGKILL at the parent's death (``PR_SET_PDEATHSIG``);
    a watchdog thread that sees the parent change covers other systems and a
    parent that died before the request. SIGTERM gets its default action back:
    the pool ends its workers with it.
    """
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    parent = os.getppid()
    try:
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="sotmot-parent-watch", daemon=True).start()


def _init_worker(config: TrackerConfig, bar_lock=None, slots=None) -> None:
    """Tie the worker to its parent and load the appearance model; with progress bars, share tqdm's lock
    and the free terminal lines."""
    global _SLOTS
    _die_with_parent()
    worker_embedder(config.appearance)
    if bar_lock is not None:
        from tqdm import tqdm

        tqdm.set_lock(bar_lock)
    _SLOTS = slots


def _pooled_job(seq_dir: str, out_dir: str, config: TrackerConfig, resume: bool,
                progress: bool) -> Outcome:
    """One sequence in a pool worker; with progress, its bars drawn on a free line under the overall bar."""
    from sotmot.progress import bars

    embedder = worker_embedder(config.appearance)
    if not (progress and _SLOTS is not None):
        return track_one(seq_dir, out_dir, config, resume, embedder=embedder)
    slot = _SLOTS.get()
    try:
        return track_one(seq_dir, out_dir, config, resume, progress=bars(slot), embedder=embedder)
    finally:
        _SLOTS.put(slot)


def low_confidence_path(results: Path) -> Path:
    """``<name>.low.txt`` beside ``<name>.txt``: the boxes confirmation dropped (``low_confidence = "file"``)."""
    return results.with_name(results.stem + ".low.txt")


def output_paths(out_dir: str | Path, name: str, config: TrackerConfig, detected: bool = False) -> list[Path]:
    """Every file tracking sequence ``name`` writes into ``out_dir``, the results file ``<name>.txt`` last;
    ``detected``: the detections come from the model (and are written as ``<name>.det.txt``)."""
    from sotmot.detection import detections_path
    from sotmot.io import results_path
    from sotmot.provenance import record_path
    from sotmot.io.flags import flags_path

    out = results_path(out_dir, name)
    side = [flags_path(out), record_path(out)]
    if config.confirm.enabled and config.confirm.low_confidence == "file":
        side.append(low_confidence_path(out))
    if detected:
        side.append(detections_path(out))
    return side + [out]


def sequence_outputs(out_dir: str | Path, info, config: TrackerConfig) -> list[Path]:
    """:func:`output_paths` of tracking sequence ``info`` with ``config`` (``<name>.det.txt`` when the model detects)."""
    from sotmot.detection import detection_source

    return output_paths(out_dir, info.name, config, detection_source(config.detection, info)[0] == "model")


def sequence_inputs(info, config: TrackerConfig) -> list[Path | None]:
    """The files tracking ``info`` reads: no output may land on one of them (:func:`sotmot.io.refuse_overwriting`)."""
    from sotmot.detection import detection_source

    return [info.source, detection_source(config.detection, info)[1], info.det_path, info.gt_path,
            config.appearance.model, config.appearance.weights, config.confirm.calibration,
            config.detection.model, config.preprocess.mask]


def resolve_paths(config: TrackerConfig) -> TrackerConfig:
    """``config`` with the re-ID model (flag, config or ``SOTMOT_REID_MODEL``, else the bundled one), the detector
    model (flag, config or ``SOTMOT_DETECTOR_MODEL``, else the bundled one), the detections file, fine-tuned
    weights, calibration file and mask as absolute paths.

    Done once, by the process that starts the run: the run record then names
    (and hashes) the model however it was given, and workers on other
    machines read the same files rather than their own environment.
    """
    from sotmot.models import model_given, model_in_use

    def absolute(path: str | None) -> str | None:
        return None if not path else str(Path(path).expanduser().resolve())

    # a run with re-ID names its model, the bundled one too; motion only names one only when it was given
    reid = model_given if config.appearance.backend == "none" else model_in_use
    config = config.replace("appearance", model=absolute(reid(config.appearance.model, "reid")),
                            weights=absolute(config.appearance.weights))
    config = config.replace("detection", file=absolute(config.detection.file),
                            model=absolute(model_in_use(config.detection.model, "detector")))
    config = config.replace("preprocess", mask=absolute(config.preprocess.mask))
    return config.replace("confirm", calibration=absolute(config.confirm.calibration))


def track_one(seq_dir: str, out_dir: str, config: TrackerConfig, resume: bool,
              progress=False, embedder=None, window_workers: int = 1, window_submit=None) -> Outcome:
    """Track one sequence into ``out_dir``; never raises (errors become a ``failed`` outcome). With ``[windows]``
    on and a sequence longer than one window, window by window (:func:`track_windowed`, its windows in
    ``window_workers`` processes, or submitted to ``window_submit``, a Dask client's ``submit``)."""
    from sotmot.detection import detections_path, detector_file_text
    from sotmot.io import format_results, guard_outputs, read_seqinfo, write_files_atomic
    from sotmot.provenance import findings, record_path, record_text, run_record, why_rerun
    from sotmot.stepping import track_whole
    from sotmot.io.flags import FLAGS_HEADER, flags_path, format_flags

    try:
        info = read_seqinfo(seq_dir, config.input.fps)
        outputs = sequence_outputs(out_dir, info, config)
        guard_outputs(outputs, sequence_inputs(info, config), hint="choose another --out")  # before any work
        out = outputs[-1]
        record = run_record(info, config)
        rerun = ""
        if resume:
            why = why_rerun(out, record)
            if why is None:
                return Outcome(seq_dir, "skipped", str(out),
                               f"{info.name}: results exist from the same run settings, skipped (--resume)")
            rerun = f" (re-run: {why})" if out.is_file() else ""
        from sotmot.windows import plan

        windows = plan(info.length, info.frame_rate, config)
        if len(windows) > 1:
            return track_windowed(seq_dir, info, windows, outputs, config, record, resume, progress, embedder,
                                  window_workers, rerun, window_submit)
        start = time.perf_counter()
        result = track_whole(info, config, embedder=embedder, progress=progress)  # every k-th frame with a step
        text = format_results(result.tracks)
        record["results_sha256"] = hashlib.sha256(text.encode("utf-8")).hexdigest()  # --resume checks it
        record.update(findings(result, config))  # what the run found and "auto" chose (a replay must choose alike)
        bound = record.get("line_check", {}).get("interpolate_max_seconds")
        # every file of the run staged first, then renamed into place, the results last (write_files_atomic): a
        # failure (a path that became a folder, a full disk, Ctrl-C) leaves the earlier run's files as they were
        staged: dict[Path, bytes] = {out: text.encode("utf-8")}
        if low_confidence_path(out) in outputs:
            staged[low_confidence_path(out)] = format_results(result.dropped).encode("utf-8")
        if result.detected is not None:  # what the model found, to repeat the run or feed the peers
            staged[detections_path(out)] = detector_file_text(result.detected, config.detection).encode("utf-8")
        staged[flags_path(out)] = (FLAGS_HEADER + format_flags(result.tracks)).encode("utf-8")
        # the side files of these results, each by its hash: --resume and render know them from an earlier run's
        record["side_files"] = {path.name: hashlib.sha256(data).hexdigest() for path, data in staged.items()
                                if path != out}
        staged[record_path(out)] = record_text(record).encode("utf-8")
        write_files_atomic(staged)
        written = list(staged)
        fps = info.length / (time.perf_counter() - start)
        stale = [path.name for path in (low_confidence_path(out), detections_path(out))
                 if path not in written and path.exists()]
        if stale:  # never removed (this run did not make them), but said: they do not belong to these results
            rerun += (f"; {' and '.join(stale)} beside it {'is' if len(stale) == 1 else 'are'} from an earlier run, "
                      f"not this one (left as {'it is' if len(stale) == 1 else 'they are'})")
        dropped = ""
        if len(result.dropped):
            where = (f"written to {low_confidence_path(out).name}" if low_confidence_path(out) in outputs
                     else "dropped")
            dropped = f", {len(result.dropped)} unconfirmed {where}"
        made = [f"{n} {how}" for n, how in ((int(result.tracks.interpolated.sum()), "interpolated"),
                                            (int(result.tracks.from_sot.sum()), "added by SOT or weak boxes")) if n]
        said = [", ".join(made)] if made else []
        if bound is not None:
            said.append(f"gaps filled up to {bound:g} s: the straight line did not hold over "
                        f"{config.postprocess.line_check_seconds:g} s here")
        if not result.tracks.n_tracks and len(result.detections) and not result.tracklets:  # why nothing came
            l_min = config.tracklets.l_min
            said.append(f"{len(result.detections)} detections, but a tracklet needs a person seen in more than "
                        f"[tracklets] l_min = {l_min} frame{'s' if l_min != 1 else ''}"
                        + (f", and the sequence has {info.length}" if info.length <= l_min + 1 else ""))
        boxes = f"{len(result.tracks)} boxes" + (f" ({'; '.join(said)})" if said else "")
        moved = (f"; the camera moves ({record['camera_motion']['median_shift_px']:.1f} px a frame at the median), "
                 f"compensated" if "camera_motion" in record else "")
        if config.preprocess.confidence == "auto":  # said: the same boxes read by another map track otherwise
            moved += f"; scores read as {record['confidence_method']!r} (--confidence sets the map)"
        return Outcome(seq_dir, "done", str(out), f"{info.name}: {result.tracks.n_tracks} tracks, "
                                                  f"{boxes}{dropped}, {fps:.1f} frames/s{moved} -> {out}{rerun}")
    except SotmotError as exc:
        return Outcome(seq_dir, "failed", None, f"{seq_dir}: {exc}")
    except Exception as exc:  # a bug must not lose the other sequences' results either
        detail = traceback.format_exc(limit=3).strip().splitlines()[-1]
        return Outcome(seq_dir, "failed", None, f"{seq_dir}: unexpected {type(exc).__name__}: {detail}")


def _resumable_windows(out: Path, record: dict, windows: list, files: list[Path]) -> dict | None:
    """The progress of an interrupted windowed run of the same settings into ``out`` (from its run record), when
    it appended to exactly ``files`` (those this run writes) and each still holds what it committed; else None."""
    from sotmot.provenance import differences, read_record

    old = read_record(out) or {}
    done = old.get("windows")
    if not isinstance(done, dict) or done.get("complete") is not False or done.get("plan") != windows:
        return None
    if differences(old, json.loads(json.dumps(record, default=str))):
        return None
    sizes = done.get("bytes", {})
    if not isinstance(sizes, dict) or set(sizes) != {path.name for path in files}:
        return None  # only this run's own files are ever cut back to what was committed
    if any(not out.with_name(name).is_file() or out.with_name(name).stat().st_size < size
           for name, size in sizes.items()):
        return None
    return done


def append_lines(path: Path, text: str) -> None:
    """Append whole lines to ``path`` in one write, flushed to disk before the run record says they are there."""
    data = text.encode("utf-8")
    if not data:
        return
    fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    try:
        os.write(fd, data)
        os.fsync(fd)
    finally:
        os.close(fd)


def track_windowed(seq_dir: str, info, windows: list, outputs: list[Path], config: TrackerConfig, record: dict,
                   resume: bool, progress=False, embedder=None, workers: int = 1, rerun: str = "",
                   submit=None) -> Outcome:
    """Track ``info`` window by window (:mod:`sotmot.windows`), committing each window's boxes as soon as it is
    joined to the one before: the results file, its flags and (when written) the unconfirmed boxes and the
    detector's boxes grow by whole lines, and the run record says after each window how far they are final. An
    interrupted run of the same settings resumes (``--resume``) after its last committed window, with the same
    results as an uninterrupted one."""
    from sotmot.detection import detections_header, detections_path, file_detections, format_detections
    from sotmot.hashing import file_sha256
    from sotmot.io import format_results, write_text_atomic
    from sotmot.io.flags import FLAGS_HEADER, flags_path, format_flags
    from sotmot.models import model_in_use
    from sotmot.provenance import write_record
    from sotmot.stepping import full_frames
    from sotmot.windows import Stitcher, cut, windowed

    start = time.perf_counter()
    out = outputs[-1]
    step = config.input.step
    detections = file_detections(config.detection, info)
    files = {out: "", flags_path(out): FLAGS_HEADER}
    if low_confidence_path(out) in outputs:
        files[low_confidence_path(out)] = ""
    if detections is None:  # the detector runs: its boxes are written beside the results
        files[detections_path(out)] = detections_header(model_in_use(config.detection.model, "detector"))
    state = _resumable_windows(out, record, [list(w) for w in windows], list(files)) if resume else None
    if state is not None:
        stitcher = Stitcher.from_state(windows, config.windows.join_iou, state, step, info.length)
        for name, size in state["bytes"].items():
            os.truncate(out.with_name(name), size)  # lines appended after the last record are made again
        rerun = f" (resumed after window {stitcher.done} of {len(windows)})"
    else:
        stitcher = Stitcher(windows, config.windows.join_iou, step=step, length=info.length)
        for path, text in files.items():
            write_text_atomic(path, text)

    def final_through(done: int) -> int:
        """The last frame final once ``done`` windows are committed (0: none yet)."""
        if done == 0:
            return 0
        return int(full_frames(cut(windows, done) - 1, step)) if done < len(windows) else info.length

    def progress_record(complete: bool) -> None:
        record["windows"] = {"plan": [list(w) for w in windows], "complete": complete,
                             "frames_final": final_through(stitcher.done), "length": info.length,
                             "bytes": {path.name: path.stat().st_size for path in files}, **stitcher.state()}
        write_record(out, record)

    progress_record(False)
    ids: set[int] = set()
    workers = usable_workers(workers, len(windows) - stitcher.done)
    results = windowed(info, windows, config, detections, stitcher.done, workers, embedder, progress, submit)
    try:
        while True:
            try:
                k, result = next(results)
            except StopIteration:
                break
            except SotmotError as exc:  # what is committed stays, and says so: --resume continues from there
                done = f"windows 1-{stitcher.done} of {len(windows)} are" if stitcher.done else "no window is yet"
                return Outcome(seq_dir, "failed", str(out), f"{seq_dir}: {exc}; {done} committed in {out} "
                                                            f"(--resume continues)")
            tracks, dropped, detected = stitcher.add(k, result)
            append_lines(out, format_results(tracks))
            append_lines(flags_path(out), format_flags(tracks))
            if low_confidence_path(out) in files:
                append_lines(low_confidence_path(out), format_results(dropped))
            if detected is not None and detections_path(out) in files:
                append_lines(detections_path(out),
                             format_detections(detected.frames, detected.boxes, detected.scores))
            progress_record(False)
            ids.update(int(i) for i in tracks.ids)
            last = final_through(k + 1)
            log.info("%s: frames 1-%d of %d final (window %d of %d)", info.name, last, info.length, k + 1,
                     len(windows))
            if progress:
                print(f"{info.name}: frames 1-{last} of {info.length} final (window {k + 1} of {len(windows)}; "
                      f"{time.perf_counter() - start:.0f} s)", file=sys.stderr)
    except KeyboardInterrupt:  # Ctrl-C, SIGTERM: what is committed stays, and is said to be partial
        final = final_through(stitcher.done)
        print(f"sotmot: {info.name}: stopped; the results are partial: frames 1-{final} of {info.length} are final "
              f"in {out} (the same command with --resume continues)" if final else
              f"sotmot: {info.name}: stopped before the first window was committed; {out} holds no boxes yet",
              file=sys.stderr)
        raise
    record["results_sha256"] = file_sha256(out)
    record["side_files"] = {path.name: file_sha256(path) for path in files if path != out}
    progress_record(True)
    fps = info.length / (time.perf_counter() - start)
    joined = sum(j["joined"] for j in stitcher.joins)
    with open(out, encoding="utf-8") as fh:  # the file's tracks: a resumed run's windows hold only some of them
        in_file = len({line.split(",", 2)[1] for line in fh if line.strip()})
    here = f" ({len(ids)} in the windows tracked now)" if rerun.startswith(" (resumed") else ""
    return Outcome(seq_dir, "done", str(out),
                   f"{info.name}: {len(windows)} windows of {config.windows.seconds:g} s ({joined} tracks joined "
                   f"across them), {in_file} tracks{here}, {fps:.1f} frames/s -> {out}{rerun}")


def track_many(seq_dirs: list[str | Path], out_dir: str | Path, config: TrackerConfig,
               workers: int = 1, resume: bool = False, progress: bool = False, report=None,
               cluster: str | None = None) -> list[Outcome]:
    """Track every sequence; ``workers > 1`` runs them in that many processes, ``cluster`` on Dask.

    With several workers each gets ``cpu_count // workers`` onnxruntime
    threads (unless the config sets them), so the machine is not
    oversubscribed. ``cluster`` is ``"dask://HOST:PORT"``, the address of a
    running Dask scheduler. ``report`` is called with each :class:`Outcome`
    as it arrives. Outcomes come back in the order of ``seq_dirs``.

    Raises
    ------
    ConfigError
        Both ``workers > 1`` and ``cluster``; a malformed cluster address,
        an unreachable scheduler, or ``distributed`` not installed.
    """
    from sotmot.appearance import resolve_backend
    from sotmot.io import check_output_dir
    from sotmot.io.files import refuse_inside

    config = resolve_paths(config)
    # the backend "auto" picks, decided here once: the run record and every worker see the one that runs
    config = config.replace("appearance", backend=resolve_backend(config.appearance).backend)
    if config.detection.weak_boxes == "on":  # the weak boxes need the detector: said now, not after tracking
        from sotmot.detection import resolve_detector_path

        resolve_detector_path(config.detection.model)
    seq_dirs = [str(s) for s in seq_dirs]
    folders = [Path(seq) for seq in seq_dirs if Path(seq).is_dir()]  # a video's folder holds more than its inputs
    refuse_inside(out_dir, [*folders, *(folder / "img1" for folder in folders)])
    try:
        out_dir = str(check_output_dir(out_dir))  # a file, a read-only folder: said now, not after the work
    except SotmotError:
        # a folder this run cannot write into that holds every sequence's whole results of these settings:
        # --resume has nothing to write there, and says each is skipped
        if not (resume and Path(out_dir).is_dir() and all(_resumable(seq, str(out_dir), config)
                                                          for seq in seq_dirs)):
            raise
        out_dir = str(out_dir)
    report = report or (lambda outcome: None)
    if cluster is not None:
        if workers > 1:
            raise ConfigError("use --workers (this machine) or --cluster (Dask), not both")
        return _track_on_dask(cluster, seq_dirs, out_dir, config, resume, progress, report)
    # one sequence and several workers: its windows (when [windows] is on) are what is spread over them
    window_workers = workers if len(seq_dirs) == 1 else 1
    workers = usable_workers(workers, len(seq_dirs))
    from sotmot.appearance import make_embedder

    if workers <= 1 or len(seq_dirs) <= 1:
        embedder = None
        outcomes = []
        for seq in seq_dirs:
            if embedder is None and not (resume and _resumable(seq, out_dir, config)):
                embedder = make_embedder(config.appearance)  # a bad model path stops everything, once
            outcome = track_one(seq, out_dir, config, resume, progress, embedder, window_workers)
            report(outcome)
            outcomes.append(outcome)
        return outcomes
    config = process_threads(config, workers)
    make_embedder(config.appearance)  # fail here, once, on a bad model path rather than in every worker
    initargs: tuple = (config,)
    if progress:  # line 0: the overall bar; lines 1..workers: one per running sequence
        import multiprocessing

        from tqdm import tqdm

        slots = multiprocessing.Queue()  # handed to the workers as they start
        for line in range(1, workers + 1):
            slots.put(line)
        initargs = (config, tqdm.get_lock(), slots)
    with _pool(workers, initargs) as pool:
        futures = {pool.submit(_pooled_job, seq, out_dir, config, resume, progress): seq
                   for seq in seq_dirs}
        by_seq = _gather(futures, as_completed(futures), "in a worker process", progress,
                         lambda o: None if _broken(o) else report(o))
    # a worker that died (a crash in native code) breaks the whole pool and fails every sequence still
    # in it: run those again one per fresh process, so the crash fails its own sequence only
    for seq in seq_dirs:
        if not _broken(by_seq[seq]):
            continue
        with _pool(1, (config,)) as alone:
            future = alone.submit(_pooled_job, seq, out_dir, config, resume, False)
            by_seq.update(_gather({future: seq}, as_completed([future]), "in a worker process", False,
                                  lambda o: None))
        if _broken(by_seq[seq]):
            by_seq[seq] = Outcome(seq, "failed", None, f"{seq}: the worker process died while tracking it "
                                                       f"(a crash in native code, e.g. OpenCV or onnxruntime)")
        report(by_seq[seq])
    return [by_seq[s] for s in seq_dirs]


def usable_workers(asked: int, sequences: int) -> int:
    """How many worker processes a run of ``sequences`` (or of one sequence's windows) starts when ``asked`` for:
    never more than there are of them to track or CPUs to run them (each worker loads the re-ID model, a few
    hundred MB)."""
    cpus = os.cpu_count() or 1
    usable = max(1, min(asked, sequences, cpus))
    if usable < asked:
        log.info("%d worker processes asked for; %d used (%d sequences, %d CPUs)", asked, usable, sequences, cpus)
    return usable


@contextmanager
def _pool(workers: int, initargs: tuple) -> Iterator[ProcessPoolExecutor]:
    """A process pool whose workers are ended, not waited for, when the block is left by an error or a signal."""
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_init_worker, initargs=initargs)
    try:
        yield pool
    except BaseException:
        for process in list((pool._processes or {}).values()):  # the executor offers no public way
            process.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def _broken(outcome: Outcome) -> bool:
    """Whether a sequence failed only because its pool broke (a worker died), not by its own error."""
    return outcome.status == "failed" and "BrokenProcessPool" in outcome.message


def _gather(futures: dict, completed, where: str, progress: bool, report) -> dict[str, Outcome]:
    """Outcome per sequence as the ``futures`` (future -> sequence) complete, under the overall bar.

    A job that raised instead of returning (its worker died) becomes a ``failed`` outcome of its
    sequence only.
    """
    if progress:
        from tqdm import tqdm

        completed = tqdm(completed, total=len(futures), desc="sequences", unit="seq", dynamic_ncols=True,
                         position=0)
    by_seq: dict[str, Outcome] = {}
    for future in completed:
        seq = futures[future]
        try:
            outcome = future.result()
        except Exception as exc:
            outcome = Outcome(seq, "failed", None, f"{seq}: {where}: {type(exc).__name__}: {exc}")
        by_seq[seq] = outcome
        report(outcome)
    return by_seq


def dask_address(cluster: str) -> str:
    """The scheduler address ``tcp://HOST:PORT`` of ``dask://HOST:PORT``."""
    host, sep, port = cluster.removeprefix("dask://").rpartition(":")
    if not cluster.startswith("dask://") or not sep or not host or not port.isdigit():
        raise ConfigError(f"cluster address must look like dask://HOST:PORT, got {cluster!r}")
    return f"tcp://{host}:{port}"


def _dask_job(seq_dir: str, out_dir: str, config: TrackerConfig, resume: bool) -> Outcome:
    """One sequence on a Dask worker, with that worker process's appearance model.

    Every path in ``config`` was made absolute by the client (:func:`resolve_paths`), so the worker reads
    no environment of its own; a failure names the worker, since a path the client sees may be missing there.
    """
    embedder = None
    outcome = None
    config = dask_worker_threads(config)
    if not (resume and _resumable(seq_dir, out_dir, config)):
        try:
            embedder = worker_embedder(config.appearance)
        except SotmotError as exc:
            outcome = Outcome(seq_dir, "failed", None, f"{seq_dir}: {exc}")
    outcome = outcome or track_one(seq_dir, out_dir, config, resume, embedder=embedder)
    if outcome.status != "failed":
        return outcome
    try:
        from distributed import get_worker

        where = get_worker().address
    except (ImportError, ValueError):
        where = "unknown"
    return dataclasses.replace(outcome, message=f"{outcome.message} (on Dask worker {where})")


def _track_on_dask(cluster: str, seq_dirs: list[str], out_dir: str, config: TrackerConfig,
                   resume: bool, progress: bool, report) -> list[Outcome]:
    address = dask_address(cluster)
    try:
        from distributed import Client, as_completed as dask_completed
    except ImportError as exc:
        raise ConfigError(f"--cluster needs the 'distributed' package ({exc}); {DASK_HINT}") from exc
    # the workers resolve paths on their side: send absolute ones (a shared filesystem is assumed)
    seq_dirs_abs = [str(Path(s).resolve()) for s in seq_dirs]
    out_dir = str(Path(out_dir).resolve())  # the model paths were made absolute by resolve_paths
    try:
        client = Client(address, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise ConfigError(f"cannot reach the Dask scheduler at {cluster} ({address}): {exc}") from exc
    try:
        if len(seq_dirs) == 1 and config.windows.seconds > 0:  # one sequence: its windows spread over the workers
            outcome = track_one(seq_dirs_abs[0], out_dir, config, resume, progress,
                                window_submit=lambda fn, *args: client.submit(fn, *args, pure=False))
            outcome = dataclasses.replace(outcome, seq_dir=seq_dirs[0])
            report(outcome)
            return [outcome]
        futures = {client.submit(_dask_job, seq, out_dir, config, resume, pure=False): orig
                   for seq, orig in zip(seq_dirs_abs, seq_dirs)}
        by_seq = _gather(futures, dask_completed(list(futures)), "on the cluster", progress, report)
    finally:
        client.close()
    return [by_seq[s] for s in seq_dirs]


def _resumable(seq_dir: str, out_dir: str, config: TrackerConfig) -> bool:
    """Whether ``--resume`` will skip this sequence (its results exist from the same run settings)."""
    from sotmot.io import read_seqinfo, results_path
    from sotmot.provenance import run_record, why_rerun

    try:
        info = read_seqinfo(seq_dir, config.input.fps)
        return why_rerun(results_path(out_dir, info.name), run_record(info, config)) is None
    except SotmotError:
        return False
