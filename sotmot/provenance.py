"""How a results file was made: the run record written beside it as ``<name>.run.json``.

The record holds the sotmot version, Python's and the libraries' versions
(:func:`sotmot.versions.environment`), the resolved configuration (solver
included), the re-ID model file and its SHA-256, the detector model's (when
the detections came from it), the confidence calibration's SHA-256, the
SHA-256 of ``seqinfo.ini``, of the detections file used and of the mask, a fingerprint of
the frame folder (file names and sizes, not their bytes: hashing every frame
would cost more than tracking small sequences), the time, and the SHA-256 of
the results file it sits beside. ``track --resume`` skips a sequence only when
its record matches the current run in everything but the time and the results
file still has the recorded hash. A live run (``sotmot track --live``: a camera, a
stream) has no input to hash and no resume: its record names the source and its
frame rate instead, and says how far its results are final (:func:`live_record`).
"""

from __future__ import annotations

import hashlib
import json
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from sotmot import __version__
from sotmot.config import TrackerConfig
from sotmot.hashing import file_sha256
from sotmot.io import SeqInfo
from sotmot.versions import environment

#: Record fields that never make a resume re-run: when it ran and on which library versions, how fast (threads,
#: batch size), what it found (the camera's motion, the line check's bound), what the configuration's "auto" choices
#: became (they follow from the configuration and inputs, which are compared), and paths whose file contents are
#: compared by hash instead.
IGNORED = ("time", "environment", "camera_motion", "line_check", "plan", "config.appearance.threads",
           "config.appearance.batch_size", "config.appearance.model", "config.confirm.calibration", "reid_model.path",
           "confidence_calibration.path", "results_sha256", "config.detection.model", "config.detection.file",
           "config.detection.threads", "detector_model.path", "inputs.detections.path", "side_files",
           "confidence_method", "windows", "config.preprocess.mask", "inputs.mask.path")


def frames_fingerprint(info: SeqInfo) -> str | None:
    """SHA-256 of the frame folder's listing: each file's name and size (for a video, the file's).

    Not modification times: a copied dataset has the same frames; and not the
    bytes of a video, which can be large (its size and name stand for them).
    """
    if info.video is not None:
        return hashlib.sha256(f"{info.video.name}\t{info.video.stat().st_size}\n".encode()).hexdigest()
    folder = info.frames_dir
    if not folder.is_dir():
        return None
    digest = hashlib.sha256()
    for entry in sorted(folder.iterdir()):
        if entry.is_file():
            digest.update(f"{entry.name}\t{entry.stat().st_size}\n".encode())
    return digest.hexdigest()


def run_record(info: SeqInfo, config: TrackerConfig) -> dict[str, Any]:
    """The record of tracking ``info`` with ``config`` (its solver included), as of now."""
    from sotmot.plan import resolve

    plan = resolve(config, info)
    source, det_file = plan.source, plan.det_file
    return {
        **_run_fields(info.name, config, config.detection.model if plan.detector is not None or plan.weak_boxes
                      else None),
        "inputs": {"seqinfo.ini": None if info.video is not None or info.files is not None  # video, images: below
                   else file_sha256(info.source),
                   "detections": {"source": source, "path": None if det_file is None else str(det_file),
                                  "sha256": None if det_file is None else file_sha256(det_file)},
                   "frames (names, sizes)": frames_fingerprint(info),
                   # only where there is one, so that the records of runs without a mask still match
                   **({} if plan.mask is None else
                      {"mask": {"path": str(plan.mask.path), "sha256": file_sha256(plan.mask.path)}})},
        # every "auto" as the run decided it (sotmot.plan): whether the detector's weak boxes checked the SOT
        # boxes, where the boxes that extend trajectory ends came from, the gap limit in frames, ...
        "plan": plan.record(),
    }


def live_record(source: str, frame_rate: float, name: str, config: TrackerConfig) -> dict[str, Any]:
    """The record of tracking a live source (``sotmot track --live``: a camera, a network stream, a video read as
    it plays) with ``config``. A live source is read once and has nothing to hash, so its results cannot be
    resumed; the record names the source (as :func:`sotmot.io.video.shown` does: no password) and its frame rate
    instead of input hashes, and the runner adds how far the results are final (``live``). ``results_sha256`` is
    filled in when the source has ended."""
    det_file = config.detection.file
    mask = config.preprocess.mask
    return {
        **_run_fields(name, config, None if det_file and config.detection.weak_boxes != "on"
                      else config.detection.model),
        "inputs": {"live": {"source": source, "frame_rate": frame_rate},
                   "detections": {"source": "file" if det_file else "model", "path": det_file,
                                  "sha256": file_sha256(det_file) if det_file else None},
                   **({} if mask is None else {"mask": {"path": mask, "sha256": file_sha256(mask)}})},
        "results_sha256": None,
    }


def reid_precision(appearance) -> str | None:
    """The arithmetic re-ID runs in under ``appearance`` (an :class:`~sotmot.config.AppearanceConfig` whose
    backend is resolved): ``"f32"``, or what OpenVINO picks on this CPU for ``precision = "fast"``; None without
    re-ID."""
    if appearance.backend == "auto":
        from sotmot.appearance import resolve_backend

        appearance = resolve_backend(appearance)
    if appearance.backend == "none":
        return None
    if appearance.backend != "openvino":
        return "f32"
    from sotmot.appearance.openvino import openvino_precision

    return openvino_precision(appearance.precision)


def _run_fields(name: str, config: TrackerConfig, detector: str | None) -> dict[str, Any]:
    """What every run record holds: versions, the configuration, the models and calibration by SHA-256
    (``detector``: the detector model, where the run's boxes came from it), the environment and the time."""
    from importlib import resources

    model = config.appearance.model
    calibration = config.confirm.calibration
    packaged = resources.files("sotmot").joinpath("data", "confidence.json")
    return {
        "sotmot": __version__,
        "sequence": name,
        "solver": config.association.solver,
        "config": config.to_dict(),
        "reid_model": {"path": model, "sha256": file_sha256(model) if model else None},
        "reid_precision": reid_precision(config.appearance),
        "confidence_calibration": {"path": calibration or "packaged",
                                   "sha256": file_sha256(calibration or str(packaged))},
        "detector_model": {"path": detector, "sha256": file_sha256(detector) if detector else None},
        # recorded, not compared: a library upgrade does not make --resume track again
        "environment": environment(),
        "time": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def findings(result, config: TrackerConfig) -> dict[str, Any]:
    """What a whole run (a :class:`~sotmot.pipeline.TrackResult` of ``config``) found or chose by itself, as its
    run record keeps it (none of it makes ``--resume`` track again): ``camera_motion``, the camera's motion where it
    was found moving (:meth:`~sotmot.motion.CameraMotion.summary`); ``line_check``, ``{"interpolate_max_seconds":
    s}`` where the line check lowered the interpolation bound (:func:`sotmot.postprocess.line_checked`); and
    ``confidence_method``, the score map ``auto`` became."""
    found: dict[str, Any] = {}
    if result.motion is not None and result.motion.moving:
        found["camera_motion"] = result.motion.summary()
    post = result.postprocess
    if post is not None and post.interpolate_max_seconds != config.postprocess.interpolate_max_seconds:
        found["line_check"] = {"interpolate_max_seconds": post.interpolate_max_seconds}
    found["confidence_method"] = result.confidence_method
    return found


def record_path(results: str | Path) -> Path:
    """``<name>.run.json`` beside ``<name>.txt``."""
    results = Path(results)
    return results.with_name(results.stem + ".run.json")


def record_text(record: dict[str, Any]) -> str:
    """The text of a run record file, as :func:`write_record` writes it."""
    return json.dumps(record, indent=2, sort_keys=True, default=str) + "\n"


def write_record(results: str | Path, record: dict[str, Any]) -> None:
    """Write the run record beside ``results`` (atomically)."""
    from sotmot.io import write_text_atomic

    write_text_atomic(record_path(results), record_text(record))


def differences(old: dict[str, Any], new: dict[str, Any], prefix: str = "") -> list[str]:
    """Dotted names of the fields in which two records differ (those of :data:`IGNORED` left out)."""
    out = []
    for key in sorted(set(old) | set(new)):
        if f"{prefix}{key}" in IGNORED:
            continue
        a, b = old.get(key), new.get(key)
        if isinstance(a, dict) and isinstance(b, dict):
            out += differences(a, b, f"{prefix}{key}.")
        elif a != b:
            out.append(f"{prefix}{key}")
    return out


def read_record(results: str | Path) -> dict[str, Any] | None:
    """The run record beside ``results``; None when there is none or it cannot be read as a JSON object."""
    try:
        record = json.loads(record_path(results).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def _side_state(side: Path, digest: str) -> str | None:
    """``"missing"`` or ``"changed"`` when the side file ``side`` is not the one whose SHA-256 a record holds."""
    if not side.is_file():
        return "missing"
    return "changed" if file_sha256(side) != digest else None


def side_file_doubt(results: str | Path, side: str | Path) -> str | None:
    """Why the side file ``side`` of ``results`` cannot be trusted, when the run record beside ``results``
    says: it is missing though the run wrote it, or it is not the file the run wrote. None: it is the run's, or
    there is no record that lists side files (results from elsewhere)."""
    results, side = Path(results), Path(side)
    sides = (read_record(results) or {}).get("side_files")
    if not isinstance(sides, dict):
        return None
    if side.name not in sides:
        return (f"{side.name} is not one of the files the run of {results.name} wrote (from an earlier run?)"
                if side.is_file() else None)
    state = _side_state(side, sides[side.name])
    if state == "missing":
        return f"{side.name}, written with {results.name}, is missing"
    if state == "changed":
        return f"{side.name} is not the file written with {results.name} (changed since)"
    return None


def partial_doubt(results: str | Path, record: dict[str, Any] | None = None) -> str | None:
    """Why ``results`` is not a whole run, when its run ``record`` says so (read beside ``results`` when not
    given): a windowed run (``sotmot track --window``) or a live session stopped before its end, with how far its
    boxes are final and how to finish it. None: the record says it is whole, or there is no record (results from
    elsewhere)."""
    results = Path(results)
    record = (read_record(results) if record is None else record) or {}
    windowed, live = record.get("windows"), record.get("live")
    if isinstance(windowed, dict) and windowed.get("complete") is False:
        final, length = windowed.get("frames_final"), windowed.get("length")
        how_far = (f"frames 1-{final} of {length} are final" if isinstance(final, int) and final and length
                   else "only its first windows are final" if windowed.get("done") else "no frame is final yet")
        return (f"{results} is partial: its run stopped before the end ({how_far}, {record_path(results).name} "
                f"says so); `sotmot track` of the same sequence with the same settings, --out {results.parent} "
                f"and --resume, finishes it")
    if isinstance(live, dict) and live.get("complete") is False:
        final = live.get("frames_final", 0)
        return (f"{results} is partial: its live session stopped ({live.get('stopped', 'before the source ended')})"
                f" with frames 1-{final} final; a live source cannot be resumed")
    return None


def results_doubts(results: str | Path) -> list[str]:
    """What a reader of ``results`` should know before trusting scores of it: the run stopped before the end
    (:func:`partial_doubt`), the file is empty, or it no longer matches the run record ``sotmot track`` wrote
    beside it (cut or edited since). Empty: no doubt."""
    results = Path(results)
    record = read_record(results) or {}
    doubts = [doubt] if (doubt := partial_doubt(results, record)) else []
    if results.is_file() and not results.read_text(encoding="utf-8-sig", errors="replace").strip():
        doubts.append(f"{results} is empty: every ground-truth box counts as missed")
    made = record.get("results_sha256")
    if made is not None and made != file_sha256(results):
        doubts.append(f"{results} is not the file its run record {record_path(results).name} describes (changed, "
                      f"cut or emptied since sotmot track wrote it): the scores are of the file as it is now")
    return doubts


def why_rerun(results: str | Path, record: dict[str, Any]) -> str | None:
    """None when ``results`` exists with a record equal to ``record``; else why it must be made again."""
    results = Path(results)
    if not results.is_file():
        return "no results yet"
    path = record_path(results)
    try:
        old = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return f"{results.name} has no run record ({path.name}), so how it was made is unknown"
    except (OSError, ValueError) as exc:
        return f"its run record {path.name} cannot be read ({exc})"
    changed = differences(old, json.loads(json.dumps(record, default=str)))
    if not changed:
        if old.get("results_sha256") is None:
            return f"its run record {path.name} holds no hash of {results.name}, so whether it is whole is unknown"
        if old["results_sha256"] != file_sha256(results):
            return f"{results.name} changed since it was written (emptied or cut?): its SHA-256 is not the record's"
        for name, digest in (old.get("side_files") or {}).items():
            state = _side_state(results.with_name(name), digest)
            if state is not None:
                return f"its side file {name} is {state}"
        return None
    shown = ", ".join(changed[:4]) + (f" and {len(changed) - 4} more" if len(changed) > 4 else "")
    return f"made with a different {shown}"
