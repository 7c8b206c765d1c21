"""Draw tracking results on the frames: a video (``.mp4``/``.avi``) or a folder of JPEGs.

Each id keeps one colour (derived from the id, so two renders agree); boxes
carry the id and a short trail of past centres. Boxes found by the SOT step
are drawn dashed, boxes filled in by interpolation thin with an ``i`` after
the id; those two flags come from the ``<name>.flags.csv`` file that
``sotmot track`` writes beside each results file. The boxes confirmation
dropped (``<name>.low.txt``, ``track --unconfirmed file``) may be drawn
too, grey and dashed with an ``x``, and the pixels a mask (``track --mask``) ignores
shaded. Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import colorsys
import os
import re
import shutil
import tempfile
from collections import deque
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

from sotmot.errors import InputError
from sotmot.io import FrameReader, SeqInfo, check_output_dir, refuse_overwriting, write_bytes_atomic
from sotmot.io.files import refuse_inside
from sotmot.io.mask import Mask
from sotmot.types import Tracks, rows_by_frame

TRAIL = 12


def colour(track_id: int) -> tuple[int, int, int]:
    """A stable, well-spread BGR colour for an id (golden-ratio hue steps)."""
    hue = (track_id * 0.618033988749895) % 1.0
    r, g, b = colorsys.hsv_to_rgb(hue, 0.85, 0.95)
    return int(b * 255), int(g * 255), int(r * 255)


def _dashed_rectangle(img: np.ndarray, p1: tuple[int, int], p2: tuple[int, int], col, thickness: int) -> None:
    import cv2

    (x1, y1), (x2, y2) = p1, p2
    dash = 8
    for x in range(x1, x2, 2 * dash):
        cv2.line(img, (x, y1), (min(x + dash, x2), y1), col, thickness)
        cv2.line(img, (x, y2), (min(x + dash, x2), y2), col, thickness)
    for y in range(y1, y2, 2 * dash):
        cv2.line(img, (x1, y), (x1, min(y + dash, y2)), col, thickness)
        cv2.line(img, (x2, y), (x2, min(y + dash, y2)), col, thickness)


def draw_frame(image: np.ndarray, tracks: Tracks, rows: np.ndarray,
               trails: dict[int, deque] | None = None) -> np.ndarray:
    """A copy of ``image`` with the boxes ``rows`` of ``tracks`` drawn on it."""
    import cv2

    out = image.copy()
    thick = max(1, round(out.shape[0] / 400))
    for r in rows:
        tid = int(tracks.ids[r])
        x, y, w, h = tracks.boxes[r]
        p1, p2 = (int(round(x)), int(round(y))), (int(round(x + w)), int(round(y + h)))
        col = colour(tid)
        if trails is not None:
            trail = trails.setdefault(tid, deque(maxlen=TRAIL))
            trail.append((int(round(x + w / 2)), int(round(y + h))))
            for a, b in zip(list(trail)[:-1], list(trail)[1:]):
                cv2.line(out, a, b, col, thick)
        if tracks.from_sot[r]:
            _dashed_rectangle(out, p1, p2, col, thick + 1)
        else:
            cv2.rectangle(out, p1, p2, col, 1 if tracks.interpolated[r] else thick + 1)
        label = f"{tid}{'i' if tracks.interpolated[r] else ''}"
        scale = 0.4 + out.shape[0] / 1500
        (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        cv2.rectangle(out, (p1[0], p1[1] - th - 4), (p1[0] + tw + 4, p1[1]), col, -1)
        cv2.putText(out, label, (p1[0] + 2, p1[1] - 3), cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 1, cv2.LINE_AA)
    return out


RED, GREEN, GREY = (0, 0, 230), (0, 190, 0), (160, 160, 160)


#: The colour (BGR) the ignored pixels of a mask are shaded towards, and how far.
MASK_SHADE, MASK_ALPHA = (0, 0, 160), 0.45


def draw_mask(image: np.ndarray, mask: Mask) -> np.ndarray:
    """A copy of ``image`` with the pixels ``mask`` ignores (where no detection is tracked) shaded red."""
    out = image.copy()
    ignored = ~mask.tracked
    out[ignored] = ((1 - MASK_ALPHA) * out[ignored] + MASK_ALPHA * np.asarray(MASK_SHADE)).astype(np.uint8)
    return out


def draw_dropped(image: np.ndarray, dropped: Tracks, rows: np.ndarray) -> np.ndarray:
    """A copy of ``image`` with the boxes ``rows`` of ``dropped`` (boxes confirmation dropped) drawn grey and
    dashed, each labelled with its track id and an ``x``."""
    import cv2

    out = image.copy()
    thick = max(1, round(out.shape[0] / 400))
    scale = 0.4 + out.shape[0] / 1500
    for r in rows:
        x, y, w, h = dropped.boxes[r]
        p1, p2 = (int(round(x)), int(round(y))), (int(round(x + w)), int(round(y + h)))
        _dashed_rectangle(out, p1, p2, (0, 0, 0), thick + 2)  # a dark edge keeps the grey visible on any scene
        _dashed_rectangle(out, p1, p2, GREY, thick)
        for col, width in (((0, 0, 0), 3), (GREY, 1)):
            cv2.putText(out, f"{int(dropped.ids[r])}x", (p1[0] + 2, p2[1] - 4), cv2.FONT_HERSHEY_SIMPLEX, scale, col,
                        width, cv2.LINE_AA)
    return out


def draw_errors(left: np.ndarray, plain: np.ndarray, frame: int, errors) -> np.ndarray:
    """Side by side: the results with false positives (red, "FP") and ID switches ("IDSW") marked,
    and the ground truth with matched boxes green and misses dashed red ("FN")."""
    import cv2

    left = left.copy()
    right = plain.copy()
    thick = max(1, round(left.shape[0] / 300))
    for box, _ in errors.false_positives.get(frame, []):
        x, y, w, h = (int(round(v)) for v in box)
        cv2.rectangle(left, (x, y), (x + w, y + h), RED, thick + 1)
        cv2.putText(left, "FP", (x + 2, y + h - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.5, RED, 2, cv2.LINE_AA)
    for gt_box, trk_box, _, switch in errors.matched.get(frame, []):
        x, y, w, h = (int(round(v)) for v in gt_box)
        cv2.rectangle(right, (x, y), (x + w, y + h), GREEN, thick)
        if switch:
            tx, ty, _, th = (int(round(v)) for v in trk_box)
            cv2.putText(left, "IDSW", (tx + 2, ty + th // 2), cv2.FONT_HERSHEY_SIMPLEX, 0.6, RED, 2, cv2.LINE_AA)
    for box in errors.misses.get(frame, []):
        x, y, w, h = (int(round(v)) for v in box)
        _dashed_rectangle(right, (x, y), (x + w, y + h), RED, thick + 1)
        cv2.putText(right, "FN", (x + 2, y + h - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.5, RED, 2, cv2.LINE_AA)
    cv2.rectangle(right, (0, 0), (150, 32), (0, 0, 0), -1)
    cv2.putText(right, "ground truth", (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1, cv2.LINE_AA)
    return np.hstack([left, right])


#: Output kinds ``render`` writes: a video container by extension, or a folder of JPEGs (no extension).
VIDEO_EXTENSIONS = {".mp4": "mp4v", ".avi": "MJPG"}


def check_render_target(info: SeqInfo, out: Path, inputs: Iterable[str | Path] = ()) -> bool:
    """Whether ``out`` is a video (else a folder); refuse, before any work, targets that would destroy input.

    Parameters
    ----------
    info
        The sequence rendered.
    out
        The target: a ``.mp4``/``.avi`` file, or a folder for one JPEG per frame.
    inputs
        Further files the run reads (the results, their flags, a video), none
        of which ``out`` may name.

    Raises
    ------
    InputError
        ``out`` lies inside the sequence folder or its frame folder, or holds
        the sequence folder; names one of ``inputs``; has an extension OpenCV
        cannot write here; is a folder where a video is asked for (or a file
        where a folder is); is an existing folder holding anything but the
        ``NNNNNN.jpg`` frames of an earlier render; or lies where no folder can
        be made (below a file, read-only).
    """
    target = out.resolve()
    refuse_inside(out, [info.path, info.frames_dir])
    for protected in (info.path.resolve(), info.frames_dir.resolve()):
        if protected.is_relative_to(target):
            raise InputError(out, f"refusing to write into a folder that holds the sequence folder {protected}; "
                             f"choose --out elsewhere")
    refuse_overwriting([out], inputs, "choose another --out")
    suffix = out.suffix.lower()
    if suffix and suffix not in VIDEO_EXTENSIONS:
        raise InputError(out, f"cannot write {suffix!r}; supported: {', '.join(VIDEO_EXTENSIONS)} (video) or a "
                         f"folder name without extension (JPEG frames)")
    video = suffix in VIDEO_EXTENSIONS
    if video and out.is_dir():
        raise InputError(out, "a folder is in the way of the video file")
    if not video and out.exists() and not out.is_dir():
        raise InputError(out, "a file is in the way of the frames folder")
    if not video and out.is_dir():
        other = sorted(p.name for p in out.iterdir() if not _FRAME_NAME.fullmatch(p.name) or not p.is_file())
        if other:
            raise InputError(out, f"the folder holds other files ({', '.join(other[:3])}"
                             f"{', ...' if len(other) > 3 else ''}); render frames into a new or empty folder, "
                             f"or one holding an earlier render's frames only")
    check_output_dir(out.parent)
    return video


#: The file names of rendered frames; a folder holding only these is an earlier render, written into again.
_FRAME_NAME = re.compile(r"\d{6}\.jpg")


def render(info: SeqInfo, tracks: Tracks, out: str | Path,
           progress: Callable[[Iterable[int]], Iterable[int]] | None = None, errors=None,
           inputs: Iterable[str | Path] = (), dropped: Tracks | None = None, mask: Mask | None = None) -> Path:
    """Render every frame of the sequence with ``tracks`` into a video file or a folder of JPEGs.

    A path ending in ``.mp4`` or ``.avi`` is a video (OpenCV's writer); a path
    without extension is a folder of ``NNNNNN.jpg``. A video, and a new
    folder, appear only when complete: they are written under a hidden
    temporary name beside the target and renamed at the end. An existing
    folder (empty, or an earlier render) is written into frame by frame,
    each frame replaced atomically; nothing else in it is touched. Every
    write is checked (a full disk is an error, never a short video). With
    ``errors`` (:func:`sotmot.scoring.frame_errors`), the ground truth is
    drawn beside the results with the errors marked. With ``dropped`` (the boxes confirmation dropped, from
    ``<name>.low.txt``), those are drawn too, grey and dashed (:func:`draw_dropped`), under the results; with
    ``mask`` (the one ``track --mask`` was given), the pixels it ignores are shaded (:func:`draw_mask`).

    Raises
    ------
    InputError
        A target :func:`check_render_target` refuses (``inputs`` are passed
        to it), or a write that failed.
    """
    import cv2

    out = Path(out)
    video = check_render_target(info, out, inputs)
    reader = FrameReader(info, cache_size=1)
    per_frame = rows_by_frame(tracks.frames)
    dropped_per_frame = rows_by_frame(dropped.frames) if dropped is not None else {}
    frames = range(1, info.length + 1)
    trails: dict[int, deque] = {}
    into_existing = not video and out.is_dir()
    # paths made by this run, and only those, are removed on failure
    if video:
        fd, name = tempfile.mkstemp(prefix=f".{out.stem}.", suffix=f".partial{out.suffix}", dir=out.parent)
        os.close(fd)
        tmp = Path(name)
        size = (info.width * (2 if errors is not None else 1), info.height)
        writer = cv2.VideoWriter(str(tmp), cv2.VideoWriter_fourcc(*VIDEO_EXTENSIONS[out.suffix.lower()]),
                                 float(info.frame_rate), size)
        if not writer.isOpened():
            tmp.unlink(missing_ok=True)
            raise InputError(out, "OpenCV cannot write a video here (try .avi, or a folder)")
    elif into_existing:
        tmp = out
    else:
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".partial", dir=out.parent))
    try:
        for f in (progress(frames) if progress else frames):
            plain = reader(f)
            image = plain if mask is None else draw_mask(plain, mask)
            if f in dropped_per_frame:
                image = draw_dropped(image, dropped, dropped_per_frame[f])
            image = draw_frame(image, tracks, per_frame.get(f, np.zeros(0, np.int64)), trails)
            if errors is not None:
                image = draw_errors(image, plain, f, errors)
            if video:
                writer.write(image)
                continue
            ok, data = cv2.imencode(".jpg", image)
            if not ok:
                raise InputError(tmp / f"{f:06d}.jpg", "OpenCV could not encode the frame")
            try:
                write_bytes_atomic(tmp / f"{f:06d}.jpg", data.tobytes())
            except OSError as exc:
                raise InputError(tmp / f"{f:06d}.jpg", f"could not be written: {exc.strerror}") from exc
        if video:
            writer.release()
            written = _video_frames(tmp)
            if written != info.length:
                raise InputError(out, f"the video holds {written} of {info.length} frames (disk full?)")
    except BaseException:
        if video:
            writer.release()
            tmp.unlink(missing_ok=True)
        elif not into_existing:
            shutil.rmtree(tmp, ignore_errors=True)
        raise
    if not into_existing:  # mkstemp and mkdtemp make private paths; the result is an ordinary file or folder
        mask = os.umask(0)
        os.umask(mask)
        os.chmod(tmp, (0o666 if video else 0o777) & ~mask)
        tmp.replace(out)  # a file over a file, or a new folder where there was none
    return out


def _video_frames(path: Path) -> int:
    """How many frames OpenCV can read back from a video file (0 if it cannot open it)."""
    import cv2

    capture = cv2.VideoCapture(str(path))
    try:
        if not capture.isOpened():
            return 0
        count = 0
        while capture.grab():
            count += 1
        return count
    finally:
        capture.release()
