"""The ``<name>.flags.csv`` side file of a results file: per box, interpolated, found by SOT, and its confidence.

MOTChallenge results have no room for these, so ``sotmot track`` writes them
beside each results file and ``sotmot render`` reads them back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sotmot.errors import InputError
from sotmot.io.files import write_text_atomic
from sotmot.types import Tracks


def flags_path(results: str | Path) -> Path:
    """The side file with the SOT / interpolation flags of a results file."""
    results = Path(results)
    return results.with_name(results.stem + ".flags.csv")


#: The first line of a flags file.
FLAGS_HEADER = "frame,id,interpolated,from_sot,confidence\n"


def format_flags(tracks: Tracks) -> str:
    """The rows (no header) of a flags file for ``tracks``, sorted by frame then id as the results are."""
    order = np.lexsort((tracks.ids, tracks.frames))
    conf = ["" if np.isnan(c) else f"{c:.4f}" for c in tracks.confidence]
    return "".join(f"{tracks.frames[i]},{tracks.ids[i]},{int(tracks.interpolated[i])},{int(tracks.from_sot[i])},"
                   f"{conf[i]}\n" for i in order)


def write_flags(results: str | Path, tracks: Tracks) -> None:
    """Write ``frame,id,interpolated,from_sot,confidence`` for every box of ``tracks`` (atomically).

    ``confidence`` is the confirmation stage's probability that the box is a
    true positive (empty where it was not computed).
    """
    write_text_atomic(flags_path(results), FLAGS_HEADER + format_flags(tracks))


def read_flags(results: str | Path, tracks: Tracks) -> Tracks:
    """``tracks`` with the flags of its side file, if there is one (else unchanged)."""
    path = flags_path(results)
    if not path.is_file():
        return tracks
    flags: dict[tuple[int, int], tuple[bool, bool, float]] = {}
    for number, line in enumerate(path.read_text().splitlines()[1:], 2):
        cells = line.split(",")
        try:
            f, i, interp, sot = (int(x) for x in cells[:4])
            conf = float(cells[4]) if len(cells) == 5 and cells[4] else float("nan")
            if len(cells) not in (4, 5):
                raise ValueError
        except ValueError:
            raise InputError(path, "expected frame,id,interpolated,from_sot[,confidence]", line=number) from None
        flags[f, i] = (bool(interp), bool(sot), conf)
    got = [flags.get((int(f), int(i)), (False, False, float("nan"))) for f, i in zip(tracks.frames, tracks.ids)]
    return Tracks(tracks.frames, tracks.ids, tracks.boxes, tracks.scores,
                  [g[0] for g in got], [g[1] for g in got], [g[2] for g in got])
