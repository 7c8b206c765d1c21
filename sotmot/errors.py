"""The exception family of sotmot.

Every error the library raises on purpose is a :class:`SotmotError`. The CLI
catches it once, prints its message and exits non-zero; library code never
prints or exits. Messages say what is wrong and what to do about it.
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


class SotmotError(Exception):
    """Base class of every error sotmot raises on purpose."""


class InputError(SotmotError):
    """Bad input data: a malformed file, a missing frame, an invalid box.

    Parameters
    ----------
    path
        The file (or folder) that holds the problem.
    message
        What is wrong, in words a user can act on.
    line
        1-based line number inside ``path`` where the problem is, if any.
    """

    def __init__(self, path: str | Path, message: str, line: int | None = None) -> None:
        self.path = Path(path)
        self.line = line
        self.reason = message
        where = f"{self.path}:{line}" if line is not None else f"{self.path}"
        super().__init__(f"{where}: {message}")


class ConfigError(SotmotError):
    """An invalid configuration: unknown key, wrong type, value out of range."""


class ModelError(SotmotError):
    """The appearance model is missing, unreadable, or not a re-ID model."""


class SolverError(SotmotError):
    """A long-term association solver failed or was asked for by an unknown name."""


class EvaluationError(SotmotError):
    """Scoring with TrackEval failed or is not possible for the given input."""


def runtime_message(exc: BaseException) -> str:
    """A model runtime's error in one line: OpenVINO's messages span several lines and name its own C++ source
    files ("Exception from src/...cpp:84:"), which tell a user nothing; the rest is kept."""
    lines = [line.strip() for line in str(exc).splitlines()]
    kept = [line for line in lines if line and not (line.startswith("Exception from ") and line.endswith(":"))]
    return " ".join(kept) or type(exc).__name__


@contextmanager
def native_noise_held() -> Iterator[None]:
    """Hold what native code writes to the process's stderr (file descriptor 2) while the block runs: passed on
    when the block succeeds, dropped when it raises. OpenVINO tries every front end on a file it cannot read, and
    TensorFlow's parser printed "Error parsing text-format tensorflow.GraphDef" lines before sotmot's own message
    about a broken model file; that message (:func:`runtime_message`) says what they meant."""
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), 2)
        ok = False
        try:
            yield
            ok = True
        finally:
            os.dup2(saved, 2)
            os.close(saved)
            if ok:
                held.seek(0)
                data = held.read()
                if data:
                    os.write(2, data)
