"""Reading and writing MOTChallenge files, with errors that name file and line.

A sequence folder holds ``seqinfo.ini``, ``img1/NNNNNN.jpg``, ``det/det.txt``
and (for training sequences) ``gt/gt.txt``. Boxes are ``x, y, w, h`` pixels,
frames are 1-based.
"""

from __future__ import annotations

import configparser
import logging
import math
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any, Literal

import numpy as np

from sotmot.config import MAX_FRAME_RATE
from sotmot.errors import InputError
from sotmot.io.files import write_text_atomic
from sotmot.types import Detections, Tracks

GtStyle = Literal["MOT15", "MOT16"]
_LINK_STUB_BYTES = 1024  # a checked-out symbolic link is a text file no longer than its target path
#: A detection box wider or taller than this many image widths or heights is an input error.
MAX_BOX_SCALE = 4.0
#: Track and ground-truth ids are positive integers below this (TrackEval indexes arrays by them).
MAX_ID = 2**31 - 1
log = logging.getLogger(__name__)

_SEQINFO_KEYS = {
    "name": str, "imDir": str, "frameRate": float, "seqLength": int,
    "imWidth": int, "imHeight": int, "imExt": str,
}


@dataclass(frozen=True)
class SeqInfo:
    """The ``[Sequence]`` section of a ``seqinfo.ini``.

    Attributes
    ----------
    path
        The sequence folder.
    name
        Sequence name (``name`` key), used for result file names.
    frame_rate
        Frames per second (``frameRate``); sets the 1-second tracklet batches.
    length
        Number of frames (``seqLength``); valid frames are ``1..length``.
    width, height
        Image size in pixels (``imWidth``, ``imHeight``).
    im_dir, im_ext
        Image folder name and file extension (``imDir``, ``imExt``).
    video
        For a sequence read straight from a video file (:func:`sotmot.io.video.video_info`): that
        file, which is then also ``path``; None for a MOTChallenge folder.
    frames
        For a sequence whose frames the caller holds (:func:`sotmot.track` on images in memory):
        a sequence of BGR ``uint8`` images, ``frames[k]`` being frame ``k + 1``
        (:class:`sotmot.io.frames.ArrayFrames` reads them); ``path`` then only names it.
    files
        For a folder of images without a ``seqinfo.ini`` (:func:`sotmot.io.images.image_folder_info`):
        the image of each frame, ``files[k]`` being frame ``k + 1``; None otherwise (frames are named
        ``NNNNNN<imExt>``).
    """

    path: Path
    name: str
    frame_rate: float
    length: int
    width: int
    height: int
    im_dir: str = "img1"
    im_ext: str = ".jpg"
    video: Path | None = None
    frames: Any = field(default=None, compare=False, repr=False)
    files: tuple[Path, ...] | None = field(default=None, compare=False, repr=False)

    @property
    def source(self) -> Path:
        """The file that describes the sequence: ``seqinfo.ini``, the video file, or a folder of images itself."""
        if self.video is not None:
            return self.video
        return self.path if self.files is not None else self.path / "seqinfo.ini"

    @property
    def det_path(self) -> Path:
        """``det/det.txt`` of this sequence."""
        return self.path / "det" / "det.txt"

    @property
    def gt_path(self) -> Path:
        """``gt/gt.txt`` of this sequence."""
        return self.path / "gt" / "gt.txt"

    @cached_property
    def frames_dir(self) -> Path:
        """The folder of the frames, ``imDir`` of the sequence folder.

        Sequences that share frames (MOT17's three detector variants of one
        video) link ``img1`` to another sequence's folder. Where the link was
        checked out as a small text file holding the relative path (git with
        ``core.symlinks=false``, copies that do not keep links), that path is
        followed. For a video: the video file.
        """
        if self.video is not None:
            return self.video
        folder = self.path / self.im_dir
        if folder.is_file() and folder.stat().st_size <= _LINK_STUB_BYTES:
            try:
                target = folder.parent / folder.read_text(encoding="utf-8").strip()
            except (OSError, UnicodeDecodeError):
                return folder
            if target.is_dir():
                return target
        return folder

    def frame_path(self, frame: int) -> Path:
        """Image file of a 1-based ``frame``."""
        if self.files is not None and 1 <= frame <= len(self.files):
            return self.files[frame - 1]
        return self.frames_dir / f"{frame:06d}{self.im_ext}"


def is_plain_name(name: str) -> bool:
    """Whether ``name`` is one path component that stays inside the folder it is joined to."""
    return (bool(name) and name not in (".", "..") and not any(c in name for c in "/\\\0")
            and not Path(name).is_absolute() and ":" not in name[:2])


def read_seqinfo_ini(seq_dir: str | Path) -> SeqInfo:
    """Read ``seq_dir/seqinfo.ini`` (a video file is read by :func:`sotmot.io.sequence.read_seqinfo`).

    Raises
    ------
    InputError
        The folder or file is missing, a key is missing, or a value is not a
        positive number where one is needed.
    """
    seq_dir = Path(seq_dir)
    if not seq_dir.is_dir():
        raise InputError(seq_dir, "not a sequence folder (it does not exist or is not a folder)")
    path = seq_dir / "seqinfo.ini"
    if not path.is_file():
        try:
            inside = sorted(p.name for p in seq_dir.iterdir() if (p / "seqinfo.ini").is_file())
        except OSError:  # an unreadable folder: the missing file is the news
            inside = []
        hint = (f"; {seq_dir} holds {len(inside)} sequence folder(s) ({', '.join(inside[:3])}"
                f"{', ...' if len(inside) > 3 else ''}): give those, e.g. {seq_dir / '*'}" if inside else "")
        raise InputError(path, f"missing; a MOTChallenge sequence folder needs seqinfo.ini{hint}")
    parser = configparser.ConfigParser(interpolation=None)  # a '%' in a value is just a character
    parser.optionxform = str  # keep key case: frameRate, seqLength
    try:
        parser.read(path, encoding="utf-8-sig")  # -sig: files saved by Excel or Notepad start with a BOM
    except (configparser.Error, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot be parsed as an ini file: {exc}") from exc
    if "Sequence" not in parser:
        raise InputError(path, "has no [Sequence] section")
    section = parser["Sequence"]
    values: dict[str, object] = {}
    for key, kind in _SEQINFO_KEYS.items():
        if key not in section:
            if key in ("imDir", "imExt"):
                continue
            raise InputError(path, f"missing key {key!r} in [Sequence]", line=_ini_line(path, "[Sequence]"))
        raw = section[key].strip()
        try:
            value = kind(raw)
        except ValueError:
            raise InputError(path, f"{key}={raw!r} is not a valid {kind.__name__}",
                             line=_ini_line(path, key)) from None
        if kind in (int, float) and not (math.isfinite(value) and value > 0):
            raise InputError(path, f"{key}={raw!r} must be a positive number", line=_ini_line(path, key))
        if key == "frameRate" and value > MAX_FRAME_RATE:
            raise InputError(path, f"{key}={raw!r} is above {MAX_FRAME_RATE:g} frames per second; every stage "
                             f"counts time in frames from it, so it must be the real rate", line=_ini_line(path, key))
        values[key] = value
    name = str(values["name"])
    if not is_plain_name(name):
        raise InputError(path, f"name={name!r} must be a plain file name (no path separators, not '.' or "
                         f"'..'): results are written as <out>/<name>.txt", line=_ini_line(path, "name"))
    return SeqInfo(path=seq_dir, name=name, frame_rate=float(values["frameRate"]),
                   length=int(values["seqLength"]), width=int(values["imWidth"]),
                   height=int(values["imHeight"]), im_dir=str(values.get("imDir", "img1")),
                   im_ext=str(values.get("imExt", ".jpg")))


def _ini_line(path: Path, needle: str) -> int | None:
    for number, text in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        if text.strip().startswith(needle):
            return number
    return None


#: The columns of each kind of MOTChallenge text file, as an error names them.
_COLUMNS = {"detections": "frame, id, x, y, w, h, score, ...", "results": "frame, id, x, y, w, h, score, ...",
            "ground-truth": "frame, id, x, y, w, h, ...",
            ("ground-truth", 9): "frame, id, x, y, w, h, consider, class, visibility"}


def _parse_rows(path: Path, min_cols: int, max_cols: int, seq_length: int | None,
                what: str, ids: bool = False) -> tuple[np.ndarray, list[int]]:
    """Parse a comma-separated MOTChallenge text file into a float array.

    Returns the ``(N, max_cols)`` array (missing trailing columns filled with -1)
    and the 1-based line number of each row. Every row is validated: column
    count and numbers here (with ``ids``, results and ground truth, every row
    as many columns as the first), the values by :func:`check_rows`.
    """
    if not path.is_file():
        raise InputError(path, f"missing; expected the {what} file here")
    rows: list[list[float]] = []
    lines: list[int] = []
    first: tuple[int, int] | None = None  # (columns, line) of the first row: every row has as many
    with open(path, encoding="utf-8-sig", errors="replace") as fh:  # -sig: tolerate a leading BOM
        for number, text in enumerate(fh, 1):
            if not is_row(text):
                continue
            ends = text.endswith("\n")
            text = text.strip()
            fields = _fields(text)
            if not (min_cols <= len(fields) <= max_cols):
                if not ends and len(fields) < min_cols and rows:  # the last line, and no newline after it
                    raise InputError(path, f"the file ends in the middle of this line ({len(fields)} of "
                                     f"{min_cols} columns): cut short while it was written or copied", line=number)
                hint = ("; no score column? a detector that gives none: add the same score to every line (e.g. "
                        "',1'), and each box counts as one it stands behind" if len(fields) == 6 and not ids else "")
                raise InputError(path, f"{len(fields)} columns, expected {min_cols} to {max_cols} "
                                 f"({_COLUMNS.get((what, min_cols), _COLUMNS[what])}){hint}", line=number)
            try:
                values = [float(f) for f in fields]
            except ValueError:
                bad = next(f for f in fields if not _is_float(f))
                raise InputError(path, f"non-numeric field {bad!r}", line=number) from None
            if first is None:
                first = (len(fields), number)
            elif ids and len(fields) != first[0]:  # results and ground truth go to TrackEval, which needs one layout
                raise InputError(path, f"{len(fields)} columns where line {first[1]} has {first[0]}: a line cut "
                                 f"short, or lines of two layouts mixed in one file", line=number)
            rows.append(values + [-1.0] * (max_cols - len(values)))
            lines.append(number)
    arr = np.asarray(rows, dtype=np.float64).reshape(-1, max_cols)
    check_rows(arr, lines, path, seq_length, ids)
    return arr, lines


def check_rows(arr: np.ndarray, lines: list[int], path: str | Path, seq_length: int | None,
               ids: bool = False) -> None:
    """Check the values of MOTChallenge rows ``arr`` (``frame, id, x, y, w, h, score, ...``; the line of each in
    ``lines``): finite, an integer frame in ``1..seq_length``, with ``ids`` an id that is an integer in
    ``1..MAX_ID``, positive width and height.

    Raises
    ------
    InputError
        At the first bad row, naming ``path`` and its line.
    """
    if not len(arr):
        return
    finite = np.isfinite(arr)
    frame = arr[:, 0]
    with np.errstate(invalid="ignore"):
        checks = [  # in the order a row is read; the first that fails names the problem
            ~finite.all(axis=1),
            frame != np.floor(frame),
            (frame < 1) | ((frame > seq_length) if seq_length is not None else False),
            ~((arr[:, 1] == np.floor(arr[:, 1])) & (arr[:, 1] >= 1) & (arr[:, 1] <= MAX_ID)) if ids
            else np.zeros(len(arr), bool),
            (arr[:, 4] <= 0) | (arr[:, 5] <= 0),
        ]
    bad = np.logical_or.reduce(checks)
    if not bad.any():
        return
    k = int(np.flatnonzero(bad)[0])
    row, line = arr[k], lines[k]
    if checks[0][k]:
        col = int(np.flatnonzero(~finite[k])[0])
        raise InputError(path, f"column {col + 1} is '{row[col]:g}'; NaN and inf are not allowed", line=line)
    if checks[1][k]:
        raise InputError(path, f"frame number '{row[0]:g}' is not an integer", line=line)
    if checks[2][k]:
        limit = f"1..{seq_length}" if seq_length is not None else ">= 1"
        hint = ("; MOTChallenge files count frames from 1, and this one's start at 0: add 1 to the first column"
                if row[0] == 0 and frame.min() == 0 else "")
        raise InputError(path, f"frame {int(row[0])} is outside {limit}, the sequence's frames{hint}", line=line)
    if checks[3][k]:
        raise InputError(path, f"id '{row[1]:g}' must be an integer from 1 to {MAX_ID}", line=line)
    raise InputError(path, f"box width and height must be positive, got w={row[4]:g}, h={row[5]:g}", line=line)


def is_row(line: str) -> bool:
    """Whether a line of a MOTChallenge text file holds a row: neither blank nor a comment (``#``, as the header
    of the ``<name>.det.txt`` that ``sotmot track`` writes)."""
    text = line.strip()
    return bool(text) and not text.startswith("#")


def _fields(text: str) -> list[str]:
    """The fields of one stripped line: comma-separated, or separated by white space when it has no comma."""
    return [f.strip() for f in text.replace(" ", "").split(",")] if "," in text else text.split()


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def read_detections(path: str | Path, seq_length: int | None = None,
                    image_size: tuple[int, int] | None = None) -> Detections:
    """Read a MOTChallenge ``det.txt``: ``frame, id, x, y, w, h, score[, x, y, z]``.

    The boxes come back in the canonical order of :meth:`Detections.sorted`.
    With ``image_size = (width, height)`` (``imWidth``, ``imHeight``) a box
    more than :data:`MAX_BOX_SCALE` times the image's width or height is an
    error (one absurd box would suppress a frame's real detections in NMS),
    and boxes mostly outside the image are counted in a warning.

    Raises
    ------
    InputError
        With the file and 1-based line of the first bad row.
    """
    path = Path(path)
    arr, lines = _parse_rows(path, 7, 10, seq_length, "detections")
    return _detections(arr, lines, path, image_size)


def detections_from_array(rows: np.ndarray, seq_length: int | None = None,
                          image_size: tuple[int, int] | None = None, source: str = "detections") -> Detections:
    """Detections held in memory: ``rows`` ``(N, 6)`` ``frame, x, y, w, h, score`` (boxes in pixels, frames
    1-based), checked as :func:`read_detections` checks a ``det.txt`` (errors name ``source`` and the 1-based
    row), in the same canonical order.

    Raises
    ------
    InputError
        Not an ``(N, 6)`` array of numbers, or a bad row.
    """
    try:
        rows = np.asarray(rows, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(source, f"must be an (N, 6) array of numbers (frame, x, y, w, h, score): {exc}") from None
    if rows.ndim != 2 or rows.shape[1] != 6:
        raise InputError(source, f"must be an (N, 6) array (frame, x, y, w, h, score); got shape {rows.shape}")
    arr = np.column_stack([rows[:, :1], np.full(len(rows), -1.0), rows[:, 1:]])  # the det.txt columns
    lines = list(range(1, len(arr) + 1))
    check_rows(arr, lines, f"{source} row", seq_length)
    return _detections(arr, lines, Path(f"{source} row"), image_size)


def _detections(arr: np.ndarray, lines: list[int], path: Path, image_size: tuple[int, int] | None) -> Detections:
    """Checked ``det.txt`` rows as :class:`Detections`; with ``image_size = (width, height)`` an absurdly large
    box is an error and boxes mostly outside the image are counted in a warning."""
    if image_size is not None and len(arr):
        width, height = image_size
        huge = np.flatnonzero((arr[:, 4] > MAX_BOX_SCALE * width) | (arr[:, 5] > MAX_BOX_SCALE * height))
        if len(huge):
            k = int(huge[0])
            raise InputError(path, f"box {arr[k, 4]:g} x {arr[k, 5]:g} px is far larger than the "
                             f"{width} x {height} image", line=lines[k])
        if min(width, height) > 2 and (arr[:, 2:6] >= 0).all() and (arr[:, 2] + arr[:, 4] <= 1).all() \
                and (arr[:, 3] + arr[:, 5] <= 1).all():
            raise InputError(path, f"every box lies within 0..1 ({arr[0, 4]:g} x {arr[0, 5]:g} here): these look "
                             f"like coordinates relative to the image; boxes are x, y, w, h in pixels (multiply x "
                             f"and w by {width}, y and h by {height})", line=lines[0])
        ix = np.clip(arr[:, 2] + arr[:, 4], 0, width) - np.clip(arr[:, 2], 0, width)
        iy = np.clip(arr[:, 3] + arr[:, 5], 0, height) - np.clip(arr[:, 3], 0, height)
        outside = np.flatnonzero(ix * iy < 0.5 * arr[:, 4] * arr[:, 5])
        if len(outside):
            corners = np.mean((arr[:, 4] > arr[:, 2]) & (arr[:, 5] > arr[:, 3])) >= 0.9  # w > x, h > y: x2, y2?
            log.warning("%s: %d box(es) lie mostly outside the %d x %d image (first on line %d)%s", path,
                        len(outside), width, height, lines[int(outside[0])],
                        "; nearly every row has w > x and h > y: if its columns are x1, y1, x2, y2, write x, y, "
                        "x2 - x1, y2 - y1 (MOTChallenge's x, y, w, h)" if corners else "")
    return Detections(arr[:, 0].astype(np.int64), arr[:, 2:6], arr[:, 6]).sorted()


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """Ground-truth boxes of a sequence.

    Attributes
    ----------
    frames, ids
        ``(N,)`` int64 1-based frame and identity.
    boxes
        ``(N, 4)`` float64 ``x, y, w, h`` pixels.
    consider
        ``(N,)`` bool, the ``conf`` column: False rows are ignored by evaluation.
    classes
        ``(N,)`` int64 MOT16 class (1 = pedestrian); all 1 for 2DMOT2015 files.
    visibility
        ``(N,)`` float64 visible fraction; all 1.0 for 2DMOT2015 files.
    style
        ``"MOT16"`` for 9-column files with class and visibility, ``"MOT15"`` for
        the 2DMOT2015 layout (10 columns, the last three world coordinates).
    """

    frames: np.ndarray
    ids: np.ndarray
    boxes: np.ndarray
    consider: np.ndarray
    classes: np.ndarray
    visibility: np.ndarray
    style: GtStyle

    def pedestrians(self, min_visibility: float = 0.0) -> "GroundTruth":
        """Rows that evaluation scores: considered pedestrians with enough visibility."""
        keep = self.consider & (self.classes == 1) & (self.visibility >= min_visibility)
        return GroundTruth(self.frames[keep], self.ids[keep], self.boxes[keep], self.consider[keep],
                           self.classes[keep], self.visibility[keep], self.style)


def gt_style(path: str | Path) -> GtStyle:
    """Whether a ``gt.txt`` is MOT16-style (9 columns) or 2DMOT2015-style.

    Decided from the columns of the first line that is neither empty nor a comment, split as the
    readers split it (commas, or white space); :func:`read_ground_truth`
    checks the rest.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError(path, "missing; expected the ground-truth file here")
    with open(path, encoding="utf-8-sig", errors="replace") as fh:  # -sig: tolerate a leading BOM
        for text in fh:
            if is_row(text):
                return "MOT16" if len(_fields(text.strip())) == 9 else "MOT15"
    return "MOT15"


def mot_rows(path: str | Path, kind: Literal["results", "gt"], seq_length: int | None = None) -> np.ndarray:
    """The checked rows of a results or ground-truth file as an ``(N, C)`` float array, every row with the
    file's own columns (10 for results and 2DMOT2015 ground truth, shorter rows filled with -1; 9 for MOT16
    ground truth), in the file's order: what :func:`read_results` and :func:`read_ground_truth` read, and what
    TrackEval is given (:mod:`sotmot.scoring`), so that a blank line or a byte-order mark never reaches it.

    Raises
    ------
    InputError
        A bad line, named; an id with two boxes in one frame.
    """
    return _id_rows(Path(path), kind, seq_length)[0]


def _id_rows(path: Path, kind: str, seq_length: int | None) -> tuple[np.ndarray, list[int]]:
    if kind == "gt" and gt_style(path) == "MOT16":
        arr, lines = _parse_rows(path, 9, 9, seq_length, "ground-truth", ids=True)
    else:
        arr, lines = _parse_rows(path, 7, 10, seq_length, "ground-truth" if kind == "gt" else "results", ids=True)
    # TrackEval asserts this with a traceback; say which line instead
    _check_one_box_per_id(path, arr[:, 0].astype(np.int64), arr[:, 1].astype(np.int64), lines)
    return arr, lines


def read_ground_truth(path: str | Path, seq_length: int | None = None) -> GroundTruth:
    """Read a ``gt.txt`` in MOT16 (9 columns) or 2DMOT2015 (10 columns) layout."""
    path = Path(path)
    style = gt_style(path)
    arr, _ = _id_rows(path, "gt", seq_length)
    if style == "MOT16":
        classes = arr[:, 7].astype(np.int64)
        visibility = arr[:, 8]
    else:
        classes = np.ones(len(arr), np.int64)
        visibility = np.ones(len(arr))
    return GroundTruth(arr[:, 0].astype(np.int64), arr[:, 1].astype(np.int64), arr[:, 2:6],
                       arr[:, 6] != 0, classes, visibility, style)


def read_results(path: str | Path, seq_length: int | None = None) -> Tracks:
    """Read a MOTChallenge results file (``frame, id, x, y, w, h, score, -1, -1, -1``)."""
    arr, _ = _id_rows(Path(path), "results", seq_length)
    return Tracks(arr[:, 0].astype(np.int64), arr[:, 1].astype(np.int64), arr[:, 2:6], arr[:, 6])


def _check_one_box_per_id(path: Path, frames: np.ndarray, ids: np.ndarray, lines: list[int]) -> None:
    """Raise an :class:`InputError` at the first row whose id already has a box in its frame."""
    seen: dict[tuple[int, int], int] = {}
    for frame, tid, line in zip(frames.tolist(), ids.tolist(), lines):
        if (frame, tid) in seen:
            raise InputError(path, f"id {tid} has a second box in frame {frame} "
                             f"(first on line {seen[frame, tid]})", line=line)
        seen[frame, tid] = line


def results_path(out_dir: str | Path, seq_name: str) -> Path:
    """Where the results of sequence ``seq_name`` live in ``out_dir``: ``<out_dir>/<name>.txt``.

    Raises
    ------
    InputError
        ``seq_name`` is not a plain file name (it would put the file outside ``out_dir``).
    """
    if not is_plain_name(seq_name):
        raise InputError(Path(out_dir), f"sequence name {seq_name!r} is not a plain file name; results would be "
                         f"written outside this folder")
    return Path(out_dir) / f"{seq_name}.txt"


def format_results(tracks: Tracks) -> str:
    """MOTChallenge text for ``tracks``, sorted by frame then id, 2 decimals for boxes."""
    order = np.lexsort((tracks.ids, tracks.frames))
    out = []
    for i in order:
        x, y, w, h = tracks.boxes[i]
        out.append(f"{tracks.frames[i]},{tracks.ids[i]},{x:.2f},{y:.2f},{w:.2f},{h:.2f},"
                   f"{tracks.scores[i]:.4f},-1,-1,-1\n")
    return "".join(out)


def write_results(path: str | Path, tracks: Tracks) -> None:
    """Write ``tracks`` as a MOTChallenge results file, atomically."""
    write_text_atomic(path, format_results(tracks))
