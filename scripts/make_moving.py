"""A moving-camera version of a still MOTChallenge sequence, with the true camera path written beside it.

Every frame is a window (``--window`` of the frame's size) cropped along a
path: a sinusoidal pan (``--pan-x``, ``--pan-y`` pixels of amplitude, one
period every ``--period`` seconds), random jitter (``--jitter`` pixels,
uniform, fixed by ``--seed``) and optionally a zoom (``--zoom``: 0.05 is +-5 %).
Without zoom the path is rounded to whole pixels (``--subpixel`` keeps the
fractions; frames are then resampled, and the blur alone changes re-ID).

**Forward motion** (issue #41), a camera driving on: ``--forward 1.6`` zooms in
steadily from 1.0 at the first frame to 1.6 at the last (everyone grows, people
near the edges leave the window), ``--rotate 3`` turns the image steadily by up
to 3 degrees, and ``--turn 200`` moves the point the camera heads for by 200
source pixels sideways over the sequence (a turn). A zoom of the whole image is
not parallax (every depth grows alike): it tests the compensation's scale and
the gates measured in pixels, not a 3-D scene. Boxes are mapped by their
centre and scaled by the zoom (a person stays upright in an image turned a few
degrees).
``--still`` holds the window at the centre of the path: the same crop, size
and box rule without motion, so the tracking cost of motion is the difference
between the two. Detections and ground truth are mapped into the window; a
detection is kept when at least half of it is inside, a ground-truth box when
any part of it is (as annotators mark people partly out of the frame).

Writes ``OUT/{img1/,det/det.txt,gt/gt.txt,seqinfo.ini}`` and ``OUT/path.txt``:
one line per frame, ``frame, a11, a12, tx, a21, a22, ty``, the affine map
from the source frame's pixels to the window's. ``OUT`` must not exist.

    python scripts/make_moving.py ../shared/data/PETS09-S2L1 /tmp/moving/PETS09-S2L1-pan
    python scripts/make_moving.py ../shared/data/PETS09-S2L1 /tmp/moving/PETS09-S2L1-still --still
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from sotmot.boxes import inside_share  # noqa: E402
from sotmot.errors import InputError  # noqa: E402
from sotmot.io import FrameReader, read_seqinfo, write_text_atomic  # noqa: E402
from sotmot.progress import as_progress  # noqa: E402

#: The least share of a box inside the window for a detection to be kept (a detector sees little of a person
#: mostly outside the frame); ground truth keeps every box with any part inside, as annotators do.
DETECTION_INSIDE = 0.5


def window_path(length: int, frame_rate: float, width: int, height: int, args: argparse.Namespace) -> np.ndarray:
    """``(length + 1, 2, 3)``: row ``f`` maps frame ``f``'s pixels to the window's (row 0 unused)."""
    rng = np.random.default_rng(args.seed)
    out_w, out_h = round(width * args.window), round(height * args.window)
    t = np.arange(length + 1) / frame_rate
    phase = 2 * np.pi * t / args.period
    progress = np.clip((np.arange(length + 1) - 1) / max(1, length - 1), 0.0, 1.0)  # 0 at frame 1, 1 at the last
    if args.still:
        dx = dy = zoom = angle = np.zeros(length + 1)
    else:
        dx = args.pan_x * np.sin(phase) + rng.uniform(-args.jitter, args.jitter, length + 1) + args.turn * progress
        dy = args.pan_y * np.sin(2 * phase + 1.0) + rng.uniform(-args.jitter, args.jitter, length + 1)
        zoom = args.zoom * np.sin(phase / 2) + (args.forward - 1.0) * progress
        angle = np.radians(args.rotate) * progress
    scale = 1.0 + zoom
    # the window's centre follows the path; source point p maps to scale * R(angle) (p - centre) + window centre
    if not args.subpixel and not args.zoom and args.forward == 1.0 and not args.rotate:
        left, top = (width - out_w) / 2, (height - out_h) / 2  # no resampling: frames hold the source's own pixels
        dx, dy = np.round(dx + left) - left, np.round(dy + top) - top
    cx, cy = width / 2 + dx, height / 2 + dy
    cos, sin = scale * np.cos(angle), scale * np.sin(angle)
    path = np.zeros((length + 1, 2, 3))
    path[:, 0, 0], path[:, 0, 1], path[:, 1, 0], path[:, 1, 1] = cos, -sin, sin, cos
    path[:, 0, 2] = out_w / 2 - (cos * cx - sin * cy)
    path[:, 1, 2] = out_h / 2 - (sin * cx + cos * cy)
    # every corner of every window must come from the frame: map the corners back and look
    corners = np.array([[0, 0], [out_w, 0], [0, out_h], [out_w, out_h]], dtype=np.float64)
    a, b = path[1:, :, :2], path[1:, :, 2]
    back = np.einsum("fij,fkj->fki", np.linalg.inv(a), corners[None] - b[:, None, :])
    over = max(0.0, -back[..., 0].min(), back[..., 0].max() - width, -back[..., 1].min(), back[..., 1].max() - height)
    if over > 0.5:
        raise SystemExit(f"the path leaves the frame by up to {over:.0f} px; lower --pan-x/--pan-y/--zoom/--turn/"
                         f"--rotate, or --window, or zoom in more (--forward)")
    return path


def into_window(rows: np.ndarray, path: np.ndarray) -> np.ndarray:
    """MOTChallenge rows (frame, id, x, y, w, h, ...) of the source frame mapped into the window along ``path``
    (:func:`read_path`), every row kept."""
    if not len(rows):
        return rows
    a = path[rows[:, 0].astype(np.int64)]
    scale = np.hypot(a[:, 0, 0], a[:, 1, 0])
    centre = rows[:, 2:4] + rows[:, 4:6] / 2
    moved = np.einsum("nij,nj->ni", a[:, :, :2], centre) + a[:, :, 2]
    out = rows.copy()
    out[:, 4:6] = rows[:, 4:6] * scale[:, None]
    out[:, 2:4] = moved - out[:, 4:6] / 2
    return out


def map_rows(rows: np.ndarray, path: np.ndarray, out_w: int, out_h: int, min_inside: float) -> np.ndarray:
    """MOTChallenge rows (frame, id, x, y, w, h, ...) mapped into the window; rows with less than ``min_inside``
    of their area inside it dropped (0: rows wholly outside)."""
    out = into_window(rows, path)
    if not len(out):
        return out
    inside = inside_share(out[:, 2:6], out_w, out_h)
    return out[(inside >= min_inside) & (inside > 0)]


def window_share(rows: np.ndarray, still: Path, moving: Path) -> np.ndarray:
    """``(N,)``: the share of each box of ``rows`` (MOTChallenge rows of the still window ``still``) inside the
    moving window ``moving`` (both made by this script from one source)."""
    info = read_seqinfo(moving)
    source = to_source(rows, read_path(still, read_seqinfo(still).length))
    seen = into_window(source, read_path(moving, info.length))
    return inside_share(seen[:, 2:6], info.width, info.height) if len(seen) else np.zeros(0)


def refuse_existing(out: Path) -> Path:
    """The ``.partial`` folder a new sequence ``out`` is written into; raises FileExistsError, naming the folder,
    when ``out`` or a failed run's ``.partial`` exists."""
    partial = out.with_name(out.name + ".partial")
    if out.exists():
        raise FileExistsError(f"{out} exists; give a new folder")
    if partial.exists():
        raise FileExistsError(f"{partial} exists (a run that did not finish?); remove it or give another folder")
    return partial


@contextmanager
def new_sequence(out: Path) -> Iterator[Path]:
    """A folder to write a new sequence into: ``out`` with ``.partial`` added, with ``det/`` and ``gt/`` made,
    renamed to ``out`` when the block completes and removed again if it fails. Raises FileExistsError, naming
    the folder, when ``out`` or a failed run's ``.partial`` exists (nothing is written over or removed then)."""
    partial = refuse_existing(out)
    (partial / "det").mkdir(parents=True)  # made by this run: removed again if it fails
    try:
        (partial / "gt").mkdir()
        yield partial
        partial.rename(out)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise


def read_path(seq: Path, length: int) -> np.ndarray:
    """``(length + 1, 2, 3)``: the ``path.txt`` of a window made by this script (row ``f`` maps the source frame's
    pixels to the window's; row 0 unused)."""
    path = np.zeros((length + 1, 2, 3))
    for row in np.loadtxt(seq / "path.txt", delimiter=",", ndmin=2):
        path[int(row[0])] = row[1:].reshape(2, 3)
    return path


def to_source(rows: np.ndarray, path: np.ndarray) -> np.ndarray:
    """MOTChallenge rows of a window (frame, id, x, y, w, h, ...) back in the source frame's pixels (the inverse
    of :func:`map_rows`, nothing dropped)."""
    if not len(rows):
        return rows
    a = path[rows[:, 0].astype(np.int64)]
    inverse = np.linalg.inv(a[:, :, :2])
    scale = np.hypot(a[:, 0, 0], a[:, 1, 0])
    centre = np.einsum("nij,nj->ni", inverse, rows[:, 2:4] + rows[:, 4:6] / 2 - a[:, :, 2])
    out = rows.copy()
    out[:, 4:6] = rows[:, 4:6] / scale[:, None]
    out[:, 2:4] = centre - out[:, 4:6] / 2
    return out


def same_view(still: Path, moving: Path, out: Path) -> None:
    """The still window ``still`` given only the detections the moving window ``moving`` keeps (both made by this
    script from one source), written to ``out`` (frames linked, not copied).

    A moving window sees less than the still one where it narrows (a zoom) or moves off: people near its edges
    lose their detections and leave the view. Tracking this folder and seeing its results through the moving
    window (:func:`through`) gives what the still camera scores with the same detections in view: the moving
    window's score minus this one is what the motion itself costs the tracker.
    """
    still_info, moving_info = read_seqinfo(still), read_seqinfo(moving)
    detections = read_rows(moving / "det" / "det.txt")
    source = to_source(detections, read_path(moving, moving_info.length))
    kept = map_rows(source, read_path(still, still_info.length), still_info.width, still_info.height,
                    DETECTION_INSIDE)
    with new_sequence(out) as partial:
        (partial / "img1").symlink_to((still / "img1").resolve(), target_is_directory=True)
        write_text_atomic(partial / "det" / "det.txt", format_rows(kept, 2))
        write_text_atomic(partial / "gt" / "gt.txt", (still / "gt" / "gt.txt").read_text())
        write_text_atomic(partial / "path.txt", (still / "path.txt").read_text())
        write_text_atomic(partial / "seqinfo.ini",
                          (still / "seqinfo.ini").read_text().replace(f"name={still_info.name}\n",
                                                                       f"name={out.name}\n"))


def through(results: Path, still: Path, moving: Path, out: Path) -> None:
    """Results tracked on the still window ``still`` (MOTChallenge text) as the moving window ``moving`` would show
    them, written to ``out``: every box mapped into the moving window, boxes wholly outside it dropped (the
    rule of its ground truth)."""
    moving_info = read_seqinfo(moving)
    source = to_source(read_rows(results), read_path(still, read_seqinfo(still).length))
    mapped = map_rows(source, read_path(moving, moving_info.length), moving_info.width, moving_info.height, 0.0)
    write_text_atomic(out, format_rows(mapped, 2))


def format_rows(rows: np.ndarray, integer_columns: int) -> str:
    """Rows as MOTChallenge text: the first ``integer_columns`` as integers, the rest with up to 6 decimals."""
    lines = []
    for row in rows:
        head = [str(int(v)) for v in row[:integer_columns]]
        tail = [f"{v:.6f}".rstrip("0").rstrip(".") if v != int(v) else str(int(v)) for v in row[integer_columns:]]
        lines.append(",".join(head + tail))
    return "\n".join(lines) + ("\n" if lines else "")


def read_rows(path: Path) -> np.ndarray:
    text = path.read_text()
    rows = [[float(v) for v in line.split(",")] for line in text.splitlines() if line.strip()]
    return np.array(rows) if rows else np.zeros((0, 10))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("sequence", type=Path, help="a still MOTChallenge sequence folder (img1/, det/, gt/)")
    parser.add_argument("out", type=Path, help="the new sequence folder (must not exist)")
    parser.add_argument("--window", type=float, default=5 / 6, help="window size as a share of the frame's")
    parser.add_argument("--pan-x", type=float, default=None,
                        help="horizontal pan amplitude in pixels (default: 80%% of the horizontal margin)")
    parser.add_argument("--pan-y", type=float, default=None,
                        help="vertical pan amplitude in pixels (default: 40%% of the vertical margin)")
    parser.add_argument("--period", type=float, default=8.0, help="seconds per horizontal pan period")
    parser.add_argument("--jitter", type=float, default=1.0, help="uniform jitter in pixels, each frame")
    parser.add_argument("--zoom", type=float, default=0.0, help="zoom amplitude (0.05: +-5%%)")
    parser.add_argument("--forward", type=float, default=1.0, metavar="Z",
                        help="forward motion: zoom in steadily from 1 at the first frame to Z at the last (1.6: "
                             "everyone 60%% larger by the end)")
    parser.add_argument("--rotate", type=float, default=0.0, metavar="DEG",
                        help="turn the image steadily, up to DEG degrees at the last frame")
    parser.add_argument("--turn", type=float, default=0.0, metavar="PX",
                        help="move the point the camera heads for PX source pixels sideways over the sequence")
    parser.add_argument("--seed", type=int, default=0, help="seed of the jitter")
    parser.add_argument("--still", action="store_true", help="hold the window still (the comparison)")
    parser.add_argument("--subpixel", action="store_true",
                        help="keep the path's fractions of a pixel (frames resampled bilinearly, as with --zoom); "
                             "by default a path without zoom is rounded to whole pixels, so every frame holds the "
                             "source's own pixels, as a real camera's would. Resampling blurs each frame by a "
                             "different amount, which alone costs re-ID (PETS09-S2L1: about 6 HOTA)")
    parser.add_argument("--quality", type=int, default=95, help="JPEG quality of the frames")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    args = parser.parse_args(argv)
    import cv2

    try:
        info = read_seqinfo(args.sequence)
    except InputError as exc:
        raise SystemExit(str(exc))
    try:
        refuse_existing(args.out)
    except FileExistsError as exc:
        raise SystemExit(str(exc))
    out_w, out_h = round(info.width * args.window), round(info.height * args.window)
    margin_x, margin_y = (info.width - out_w) / 2, (info.height - out_h) / 2
    args.pan_x = 0.8 * margin_x if args.pan_x is None else args.pan_x
    args.pan_y = 0.4 * margin_y if args.pan_y is None else args.pan_y
    path = window_path(info.length, info.frame_rate, info.width, info.height, args)
    with new_sequence(args.out) as partial:
        (partial / "img1").mkdir()
        reader = FrameReader(info, cache_size=1)
        for f in as_progress(not args.quiet)(range(1, info.length + 1), f"{info.name}: frames"):
            image = cv2.warpAffine(reader(f), path[f], (out_w, out_h), flags=cv2.INTER_LINEAR,
                                   borderMode=cv2.BORDER_REPLICATE)
            ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, args.quality])
            if not ok:
                raise SystemExit(f"frame {f} of {args.sequence} could not be encoded as JPEG")
            (partial / "img1" / f"{f:06d}.jpg").write_bytes(data.tobytes())
        det = read_rows(args.sequence / "det" / "det.txt")
        write_text_atomic(partial / "det" / "det.txt",
                          format_rows(map_rows(det, path, out_w, out_h, DETECTION_INSIDE), 2))
        gt = read_rows(args.sequence / "gt" / "gt.txt")
        write_text_atomic(partial / "gt" / "gt.txt", format_rows(map_rows(gt, path, out_w, out_h, 0.0), 2))
        kind = "still" if args.still else "forward" if args.forward != 1.0 else "pan"
        write_text_atomic(partial / "seqinfo.ini", "\n".join([
            "[Sequence]", f"name={args.out.name}", "imDir=img1", f"frameRate={info.frame_rate:g}",
            f"seqLength={info.length}", f"imWidth={out_w}", f"imHeight={out_h}", "imExt=.jpg", ""]))
        lines = [f"{f}," + ",".join(f"{v:.6f}" for v in path[f].ravel()) for f in range(1, info.length + 1)]
        write_text_atomic(partial / "path.txt", "\n".join(lines) + "\n")
    shifts = np.linalg.norm(np.diff(path[1:, :, 2], axis=0), axis=1)
    print(f"{args.out}: {info.length} frames {out_w} x {out_h}, {kind}; camera shift per frame median "
          f"{np.median(shifts):.1f} px, max {shifts.max():.1f} px")
    return 0


if __name__ == "__main__":
    sys.exit(main())
