"""What the benchmark and fit scripts in ``scripts/`` share: which sequences, which machine, cached inputs
(and the jittered copies ``sotmot compare --jitter`` runs too).

Library code: every function takes its paths from the caller and raises on
bad input; the scripts' command-line side (default paths, shared arguments)
is ``scripts/common.py``.
"""

from __future__ import annotations

import hashlib
import json
import re
import sys
from pathlib import Path

import numpy as np

from sotmot.appearance import resolve_backend
from sotmot.config import TrackerConfig
from sotmot.errors import InputError
from sotmot.io import SeqInfo, atomic_path, is_row, read_detections, read_seqinfo, write_text_atomic

#: Full-length sequences are longer than this many frames; shorter ones are the 30-frame clips (quick tests only).
FULL_LENGTH = 100
#: Frame-rate variants of the validation set are made of the full-length sequences at this frame rate or above.
VARIANT_MIN_FPS = 20.0
#: The validation set's label-only sequences (detections and ground truth, no frames), as patterns under the data.
LABEL_SETS = ("MOT16-labels/*", "MOT17-labels/*")
#: The validation set's groups (:func:`validation_set`).
GROUPS = ("frames", "rates", "clips", "labels", "label-rates")
#: The groups without frames, tracked in the motion-only mode (:func:`for_group`).
LABEL_GROUPS = ("labels", "label-rates")
#: The configuration sections a preparation (:func:`sotmot.pipeline.prepare_sequence`) reads.
PREPARATION = ("input", "detection", "preprocess", "appearance", "sot", "tracklets", "motion")


#: The full-length sequences with frames that do not fit in ``../shared/data``: a crowd (``MOT20-01``) and a camera
#: on a moving vehicle (``MOT16-13`` and the same frames under MOT17's ground truth and detectors), built on the
#: user's machine by ``../shared/more/prepare.sh`` (issue #87). Optional: tests and CI never need them.
MORE_SEQUENCES = ("MOT20-01", "MOT16-13", "MOT17-13-DPM", "MOT17-13-FRCNN")
#: How a benchmark says where the :data:`MORE_SEQUENCES` come from when they are missing.
MORE_HOW = ("build them with bash ../shared/more/prepare.sh SNAPSHOTS OUT (its header names the three public "
            "repositories whose snapshots it reads) and give OUT as --more (or SOTMOT_MORE)")


def more_sequences(more: Path | None) -> tuple[list[Path], str]:
    """The :data:`MORE_SEQUENCES` found under ``more`` (None: not asked for), and a line saying which are missing
    and how to build them (empty when none is)."""
    if more is None:
        return [], f"the crowd and the vehicle ({', '.join(MORE_SEQUENCES)}) are left out: {MORE_HOW}"
    found = [more / name for name in MORE_SEQUENCES if (more / name / "seqinfo.ini").is_file()]
    missing = [name for name in MORE_SEQUENCES if more / name not in found]
    return found, (f"{', '.join(missing)} not under {more}: {MORE_HOW}" if missing else "")


def sequences(data: Path, only: str = "") -> list[Path]:
    """Sequence folders with frames under ``data`` (the label-only MOT16-labels folders are skipped); ``only``, a
    comma-separated list of folder names (a script's ``--sequences``), keeps those alone (:func:`only_named`)."""
    found = sorted(p for p in data.iterdir() if (p / "seqinfo.ini").is_file() and (p / "img1").exists())
    return only_named(found, only, data)


def only_named(found: list[Path], only: str, where: Path) -> list[Path]:
    """``found`` kept to the comma-separated folder names ``only`` (a script's ``--sequences``; every one when
    empty), in ``found``'s order.

    Raises
    ------
    InputError
        A name that none of ``found`` has (a typo must not shrink a benchmark unnoticed), naming ``where``.
    """
    if not only:
        return found
    names = [n for n in only.split(",") if n]
    have = {p.name for p in found}
    missing = [n for n in names if n not in have]
    if missing:
        raise InputError(where, f"no sequence named {', '.join(missing)} here; there are "
                                f"{', '.join(p.name for p in found) or 'none'}")
    return [p for p in found if p.name in names]


def video_of(name: str) -> str:
    """The video a sequence shows: MOT16-09 and MOT17-09-FRCNN / -SDP are one video under three detectors (MOTChallenge
    numbers a training video alike in MOT16 and MOT17, its clips too: ``MOT16-10-clip30`` is ``MOT-10``), and a
    validation copy at a lower frame rate (``...-every2``, :func:`subsampled_name`) shows its sequence's video (a
    leave-one-out fold leaves out the video, not the sequence)."""
    name = re.sub(r"-every\d+", "", name)
    match = re.match(r"MOT1[67]-(\d+)", name)
    return f"MOT-{match.group(1)}" if match else name


def before_confirmation(config: TrackerConfig) -> TrackerConfig:
    """``config`` as sotmot ran before the confirmation stage (issue #11): every box kept, every gap filled, no
    end extension (issue #12), no occlusion check and no line check (issue #39)."""
    return (config.replace("confirm", enabled=False)
            .replace("postprocess", interpolate_max_seconds=None, occlusion_seconds=None, line_check_seconds=None)
            .replace("ends", seconds=0.0))


def cached_features(seq: Path, config: TrackerConfig, cache: Path, embedder_box: list) -> np.ndarray:
    """Features of the preprocessed detections of ``seq``, from ``cache`` or computed and stored there.

    The cache key holds the sequence, the model file's name and size, the
    detection cleaning configuration, the flip setting, the backend and any
    fine-tuned weights. ``embedder_box`` is a list that receives the embedder
    when one is first needed, so several calls share it: one box per
    ``[appearance]`` setting, since its embedder computes whatever is not
    cached (a box whose embedder flips otherwise than ``config`` is refused
    with ``ValueError``).
    """
    from sotmot.detection import detection_source
    from sotmot.passes import embed_detections
    from sotmot.preprocess import preprocess

    info = read_seqinfo(seq)
    model = Path(config.appearance.model or "")
    # the detector-score calibration changes no box and no feature: it is not part of the key
    cleaning = {k: v for k, v in config.preprocess.__dict__.items() if k != "confidence"}
    if cleaning.get("mask") is None:  # no mask: the keys of the runs before masks existed
        cleaning.pop("mask", None)
    # the runtime and fine-tuned weights, when not the defaults (so keys of default runs stay as they were)
    backend = resolve_backend(config.appearance).backend
    runtime = [v for v in (backend if backend != "onnx" else None,
                           config.appearance.weights) if v]
    detections = [config.detection.file] if config.detection.file else []  # default runs keep their keys
    key = hashlib.sha256(json.dumps([info.name, model.name, model.stat().st_size if model.is_file() else 0,
                                     cleaning, config.appearance.flip, *runtime, *detections],
                                    sort_keys=True, default=str).encode()).hexdigest()[:16]
    path = cache / f"{info.name}-{key}.npy"
    if path.is_file():
        return np.load(path)
    if not embedder_box:
        from sotmot.appearance import make_embedder

        embedder_box.append(make_embedder(config.appearance))  # built once, for the first sequence not cached
    if getattr(embedder_box[0], "flip", config.appearance.flip) != config.appearance.flip:
        raise ValueError(f"{seq}: the embedder in the box embeds with flip = {embedder_box[0].flip}, the "
                         f"configuration asks for {config.appearance.flip}: one box per [appearance] setting")
    dets = preprocess(read_detections(detection_source(config.detection, info)[1] or info.det_path, info.length),
                      config.preprocess)
    features = embed_detections(info, dets, embedder_box[0], progress=sys.stderr.isatty())
    cache.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.save(fh, features)
    return features


def validation_set(data: Path, cache: Path, groups: "set[str] | tuple[str, ...]" = GROUPS, private: bool = False,
                   more: "list[Path] | None" = None) -> list[tuple[str, Path]]:
    """``(group, folder)`` of every validation sequence under ``data`` (issue #39): ``frames``, the full-length
    sequences with frames; ``rates``, each of them at :data:`VARIANT_MIN_FPS` or above at every 2nd and 3rd
    frame (:func:`subsampled_sequence`, made once under ``cache / "rates"``); ``clips``, the short sequences with
    frames and the label-only sequences' boxes on the frames of their videos' clips (:func:`detector_clips`, made
    once under ``cache / "clips"``): moving cameras with pixels, under the stronger detectors; ``labels``, the
    label-only sequences (:data:`LABEL_SETS`), tracked without frames (:func:`for_group`); ``label-rates``, each
    label-only sequence at :data:`VARIANT_MIN_FPS` or above at every 2nd frame (made alike), tracked alike.
    ``private``: the sequences are tracked from a detector's boxes, so ``clips`` keeps the clips of ``data``
    alone (another detector's boxes on the same frames would be the same run again). ``more``: further
    full-length sequences with frames (:func:`more_sequences`), members of ``frames`` and ``rates`` as those of
    ``data`` are."""
    members: list[tuple[str, Path]] = []
    found = sequences(data)
    full = {p: info for p in [*found, *(more or [])] if (info := read_seqinfo(p)).length > FULL_LENGTH}
    if "frames" in groups:
        members += [("frames", p) for p in full]
    if "rates" in groups:
        members += [("rates", subsampled_sequence(p, step, cache / "rates")) for p, info in full.items()
                    if info.frame_rate >= VARIANT_MIN_FPS for step in (2, 3)]
    if "clips" in groups:
        members += [("clips", p) for p in found if p not in full]
        members += [] if private else [("clips", p) for p in detector_clips(data, cache / "clips")]
    labelled = [p for pattern in LABEL_SETS for p in sorted(data.glob(pattern)) if (p / "seqinfo.ini").is_file()]
    if "labels" in groups:
        members += [("labels", p) for p in labelled]
    if "label-rates" in groups:
        members += [("label-rates", subsampled_sequence(p, 2, cache / "rates")) for p in labelled
                    if read_seqinfo(p).frame_rate >= VARIANT_MIN_FPS]
    return members


def motion_only(config: TrackerConfig) -> TrackerConfig:
    """``config`` for a sequence without frames: no re-ID, no camera motion, nothing that reads pixels."""
    return (config.replace("appearance", backend="none", model=None)
            .replace("motion", compensation="off").replace("sot", variant="none")
            .replace("ends", seconds=0.0))


def for_group(config: TrackerConfig, group: str, model: str) -> TrackerConfig:
    """``config`` as a validation sequence of ``group`` is tracked with it: the re-ID ``model`` given, and the
    motion-only mode (:func:`motion_only`) for the groups without frames (:data:`LABEL_GROUPS`)."""
    config = config.replace("appearance", model=model)
    return motion_only(config) if group in LABEL_GROUPS else config


def preparation_key(config: TrackerConfig) -> str:
    """What a preparation of a sequence depends on in ``config`` (its :data:`PREPARATION` sections): configurations
    with the same key can share one preparation and finish it each their own way."""
    return json.dumps({s: config.to_dict()[s] for s in PREPARATION}, sort_keys=True, default=str)


def group_features(seq: Path, config: TrackerConfig, group: str, cache: Path, embedders: dict[str, list]
                   ) -> np.ndarray | None:
    """Re-ID features of a validation sequence's detections, kept under ``cache`` (none for the label-only
    group). ``embedders`` holds one embedder box (:func:`cached_features`) per ``[appearance]`` setting, so that
    a configuration's missing features come from its own runtime and flip."""
    if group in LABEL_GROUPS:
        return None
    box = embedders.setdefault(json.dumps(config.to_dict()["appearance"], sort_keys=True, default=str), [])
    return cached_features(seq, config, cache, box)


def model_detections(seq: Path, config: TrackerConfig, cache: Path) -> Path:
    """The detector's boxes of ``seq`` (``[detection]`` of ``config``) as a ``det.txt`` in ``cache``, made once.

    The file is what ``sotmot track`` writes as ``<name>.det.txt``: fed back
    as ``[detection] file`` it gives the very run the detector would (tested),
    so benchmarks detect each sequence once and hand sotmot and the peers the
    same boxes. The cache key holds the sequence, the detector file's SHA-256
    and the detector settings that change boxes (the input size as the
    detector resolves it for the sequence's frames).
    """
    from sotmot.detection import format_detections, make_detector, resolve_detector_path
    from sotmot.detection.openvino import network_input
    from sotmot.passes import detect_sequence
    from sotmot.provenance import file_sha256

    info = read_seqinfo(seq)
    detection = config.detection
    settings = [info.name, str(info.frames_dir.resolve()), file_sha256(resolve_detector_path(detection.model)),
                detection.backend, detection.min_score, *network_input(detection, info.width, info.height)]
    key = hashlib.sha256(json.dumps(settings).encode()).hexdigest()[:16]
    path = cache / f"{info.name}-{key}.det.txt"
    if not path.is_file():
        found, _ = detect_sequence(info, make_detector(detection), progress=sys.stderr.isatty())
        cache.mkdir(parents=True, exist_ok=True)
        with atomic_path(path) as tmp:
            tmp.write_text(format_detections(found.frames, found.boxes, found.scores), encoding="utf-8")
    return path


def private_config(config: TrackerConfig, seq: Path, detector_model: str, cache: Path) -> TrackerConfig:
    """``config`` for tracking ``seq`` from a detector's boxes (MOTChallenge's private detections): the boxes
    from :func:`model_detections`, and, with ``auto`` confidence, the detector's family when it is a known
    one, and with ``auto`` weak boxes, the detector's weak boxes checking the SOT step and extending trajectory
    ends (found again on the frames visited), as ``sotmot track --detections model`` would take them."""
    from sotmot.detection import known_family

    detection = config.replace("detection", source="model", model=detector_model)
    family = known_family(detection.detection, read_seqinfo(seq))
    out = config.replace("detection", file=str(model_detections(seq, detection, cache)), model=detector_model)
    if family and config.preprocess.confidence == "auto":
        out = out.replace("preprocess", confidence=family)
    if config.detection.weak_boxes == "auto":
        out = out.replace("detection", weak_boxes="on")
    return out


def fit_sequences(data: Path, min_length: int, only: str = "") -> list[Path]:
    """The sequences with frames under ``data`` of at least ``min_length`` frames (``only``: a comma-separated list of
    names, those alone), for a leave-one-sequence-out fit.

    Raises
    ------
    InputError
        Fewer than two (nothing to hold out).
    """
    found = [p for p in sequences(data, only) if read_seqinfo(p).length >= min_length]
    if len(found) < 2:
        raise InputError(data, f"a leave-one-sequence-out fit needs at least two sequences of >= {min_length} "
                               f"frames here, found {len(found)}")
    return found


def _every_nth_lines(text: str, step: int) -> str:
    """The MOTChallenge rows (``frame, ...``) of frames ``1, 1 + step, 1 + 2 step, ...``, renumbered from 1."""
    out = []
    for line in text.splitlines():
        head, sep, rest = line.partition(",")
        if not sep:
            continue
        frame = int(float(head))
        if (frame - 1) % step == 0:
            out.append(f"{(frame - 1) // step + 1}{sep}{rest}")
    return "\n".join(out) + ("\n" if out else "")


def subsampled_name(name: str, step: int) -> str:
    """The name of ``name`` at every ``step``-th frame: ``MOT16-09`` -> ``MOT16-09-every2``; a MOTChallenge
    detector suffix stays last (``MOT17-09-SDP`` -> ``MOT17-09-every2-SDP``), so the family is still named."""
    from sotmot.confidence.maps import family_from_name

    if family_from_name(name) is not None:
        stem, suffix = name.rsplit("-", 1)
        return f"{stem}-every{step}-{suffix}"
    return f"{name}-every{step}"


def subsampled_sequence(seq: Path, step: int, root: Path) -> Path:
    """``seq`` at every ``step``-th frame (frames 1, 1 + step, ...), a lower frame rate of the same video.

    Made once under ``root`` (a MOTChallenge folder named by
    :func:`subsampled_name`): ``seqinfo.ini`` with ``frameRate / step`` and the
    new length, ``det/det.txt`` and ``gt/gt.txt`` with the kept frames
    renumbered from 1, and ``img1/`` holding links to the original JPEGs.
    Folders under ``root`` are written by this function only; a complete one
    (its ``seqinfo.ini`` is written last) is reused.
    """
    info = read_seqinfo(seq)
    length = (info.length - 1) // step + 1
    texts = {path: _every_nth_lines(path.read_text(encoding="utf-8-sig"), step)
             for path in (info.det_path, info.gt_path)}
    return _derived_sequence(info, root / subsampled_name(info.name, step), texts, step, length)


def _first_frames_lines(text: str, length: int) -> str:
    """The MOTChallenge rows (``frame, ...``) of frames ``1 .. length``."""
    kept = [line for line in text.splitlines()
            if line.partition(",")[1] and int(float(line.partition(",")[0])) <= length]
    return "\n".join(kept) + ("\n" if kept else "")


def detector_clips(data: Path, root: Path) -> list[Path]:
    """Each label-only sequence of :data:`LABEL_SETS` whose video has a clip with frames under ``data``, on those
    frames: another detector's boxes where the pixels are (MOTChallenge numbers a training video alike in MOT16
    and MOT17, so ``MOT17-labels/MOT17-10-SDP`` and ``MOT16-10-clip30`` are one video).

    Each is made once under ``root`` as ``<label set>-clip<K>`` (``MOT17-10-SDP-clip30``): ``img1/`` links to
    the clip's frames, ``det/det.txt`` and ``gt/gt.txt`` the label set's rows of frames 1 to K, and
    ``seqinfo.ini`` the clip's (rate, size), written last; a complete folder is reused. A label set whose frame
    rate or image size differs from its clip's is not the same video and is left out; a label set of a clip's
    own name (the MOT16 clip's own detections) too.

    Returns
    -------
    list of Path
        The clips, sorted by name.
    """
    clips = [clip for clip in sequences(data) if "-clip" in clip.name]
    made = []
    for pattern in LABEL_SETS:
        for labels in sorted(data.glob(pattern)):
            if not (labels / "seqinfo.ini").is_file():
                continue
            info = read_seqinfo(labels)
            for clip in (c for c in clips if video_of(c.name) == video_of(labels.name)):
                frames = read_seqinfo(clip)
                if clip.name.startswith(labels.name) or (frames.frame_rate, frames.width, frames.height) != (
                        info.frame_rate, info.width, info.height):
                    continue
                texts = {path: _first_frames_lines(path.read_text(encoding="utf-8-sig"), frames.length)
                         for path in (info.det_path, info.gt_path) if path.is_file()}
                name = f"{labels.name}-clip{frames.length}"
                made.append(_derived_sequence(frames, root / name, texts, 1, frames.length, name=name))
    return sorted(made, key=lambda p: p.name)


#: The largest offset of a jittered box (:func:`jittered_text`), pixels: below a ``det.txt``'s own rounding to whole
#: pixels, so a change that should change nothing.
JITTER_PIXELS = 0.5


def jittered_sequence(seq: Path, seed: int, root: Path, pixels: float = JITTER_PIXELS) -> Path:
    """``seq`` with every detection box moved by a seeded offset of at most ``pixels`` in x and in y (its size
    kept): a change that should change nothing, less than a ``det.txt``'s own rounding to whole pixels.

    Made once under ``root / f"jitter{seed}"`` with the sequence's own name (its results are scored and
    compared as the sequence's), ``gt/gt.txt`` and ``seqinfo.ini`` as they are, and ``img1/`` (where the
    sequence has frames) holding links to the original frames; written last, ``seqinfo.ini`` marks a complete
    folder, which is reused. Boxes are ``x, y, w, h`` in pixels.
    """
    info = read_seqinfo(seq)
    texts = {info.det_path: jittered_text(info.det_path.read_text(encoding="utf-8-sig"), seed, pixels),
             info.gt_path: info.gt_path.read_text(encoding="utf-8-sig")}
    return _derived_sequence(info, root / f"jitter{seed}" / info.name, texts, 1, info.length, name=info.name)


def jittered_detections(path: Path, seed: int, root: Path, pixels: float = JITTER_PIXELS) -> Path:
    """The detections file ``path`` (``det.txt`` layout) with every box moved as :func:`jittered_sequence` moves
    a sequence's, written once as ``root / f"jitter{seed}" / path.name``: the same change for boxes that come
    from a detector run rather than from the sequence's folder (``[detection] file``)."""
    out = root / f"jitter{seed}" / path.name
    if not out.is_file():
        out.parent.mkdir(parents=True, exist_ok=True)
        write_text_atomic(out, jittered_text(path.read_text(encoding="utf-8-sig"), seed, pixels))
    return out


def jittered_text(text: str, seed: int, pixels: float) -> str:
    """The lines of a ``det.txt`` with each box's ``x, y`` moved by a seeded offset of at most ``pixels`` (its
    size kept), the other fields as they were; comment lines (``#``, the header ``sotmot track`` writes) kept
    as they are, the offsets drawn for the boxes alone."""
    lines = [line for line in text.splitlines() if line.strip()]
    boxes = [k for k, line in enumerate(lines) if is_row(line)]
    offsets = np.random.default_rng(seed).uniform(-pixels, pixels, size=(len(boxes), 2))
    for k, (dx, dy) in zip(boxes, offsets):
        fields = lines[k].split(",")
        fields[2], fields[3] = f"{float(fields[2]) + dx:.3f}", f"{float(fields[3]) + dy:.3f}"
        lines[k] = ",".join(fields)
    return "\n".join(lines) + "\n"


def _derived_sequence(info: SeqInfo, out: Path, texts: dict[Path, str], step: int, length: int, name: str | None = None
                      ) -> Path:
    """A MOTChallenge folder ``out`` made from ``info``'s: frame ``n`` links to the original frame ``(n - 1) *
    step + 1`` (where the original has frames), ``texts`` maps each original ``det``/``gt`` file to the text its
    copy holds, and ``seqinfo.ini`` (named ``name``, else ``out``'s folder name; ``frameRate / step``) is
    written last. A folder whose ``seqinfo.ini`` exists is complete and returned as it is."""
    import configparser

    if (out / "seqinfo.ini").is_file():
        return out
    if info.frames_dir.is_dir():
        (out / info.im_dir).mkdir(parents=True, exist_ok=True)
        for new in range(1, length + 1):
            link = out / info.im_dir / f"{new:06d}{info.im_ext}"
            if not link.is_symlink():
                link.symlink_to(info.frame_path((new - 1) * step + 1).resolve())
    for path, text in texts.items():
        (out / path.parent.name).mkdir(parents=True, exist_ok=True)
        write_text_atomic(out / path.parent.name / path.name, text)
    parser = configparser.ConfigParser(interpolation=None)
    parser.optionxform = str
    parser["Sequence"] = {"name": name or out.name, "imDir": info.im_dir, "frameRate": f"{info.frame_rate / step:g}",
                          "seqLength": str(length), "imWidth": str(info.width), "imHeight": str(info.height),
                          "imExt": info.im_ext}
    with atomic_path(out / "seqinfo.ini") as tmp:
        with open(tmp, "w", encoding="utf-8") as fh:
            parser.write(fh)
    return out
