"""Writing files safely: atomic writes (a reader sees the old file or the whole new one) and the guards that keep
a run from writing over what it reads or into a user's sequence folders."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

from sotmot.errors import InputError


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; renamed over ``path`` when the block ends without error.

    The one way sotmot writes a file so that readers see the old file or the
    whole new one: results, side files, checkpoints, figures. On any error
    the temporary file is removed and ``path`` is untouched. ::

        with atomic_path("model.pt") as tmp:
            torch.save(state, tmp)
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; a results file is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_path`), flushed to disk before the rename."""
    with atomic_path(path) as tmp, open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` so that readers see the old file or the whole new one."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_files_atomic(files: dict[Path, bytes]) -> None:
    """Write several files all or none: every one to a temporary file first, then each renamed into place.

    A failure while writing (a full disk, a read-only folder, a target that is
    a folder) leaves every target as it was and no temporary file behind; only
    the renames, which need no space, come after the last byte is written, in
    the reverse of ``files``' order (its first file, the results, renamed last).
    """
    with ExitStack() as stack:
        staged = [(stack.enter_context(atomic_path(path)), data) for path, data in files.items()]
        for tmp, data in staged:
            with open(tmp, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        for path in files:  # what would stop a rename, found before the first one
            if Path(path).is_dir():
                raise InputError(path, "is a folder, and a file would go here; nothing was written")
        # leaving the stack renames each temporary file over its target, last entered first


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name one file (through links, ``..`` and case-folding file systems alike)."""
    a, b = Path(a), Path(b)
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def refuse_overwriting(outputs: Iterable[str | Path], inputs: Iterable[str | Path | None], hint: str) -> None:
    """Raise an :class:`InputError` when an output path would write over one of the run's input files.

    A run never writes over a file it reads: a results file named like the
    detections it was made from (``--out`` the folder of ``--det``, a sequence
    named ``det`` written into its own ``det/``), a render over its video.
    Paths compare after resolving links; ``None`` inputs are skipped.
    """
    inputs = [Path(p) for p in inputs if p is not None]
    for out in map(Path, outputs):
        for source in inputs:
            if same_file(out, source) or out.resolve() == source.resolve():
                raise InputError(out, f"would write over {source}, which this run reads; {hint}")


def refuse_inside(out: str | Path, folders: Iterable[str | Path], hint: str = "choose --out elsewhere") -> None:
    """Raise an :class:`InputError` when ``out`` is one of the sequence ``folders`` (or their frame folders) or
    lies inside one: results never land among a user's inputs (``track --out``, ``render --out``)."""
    target = Path(out).resolve()
    for folder in map(Path, folders):
        protected = folder.resolve()
        if target == protected or target.is_relative_to(protected):
            raise InputError(out, f"refusing to write into the sequence folder {protected}: results would land "
                             f"among its frames and detections; {hint}")


def guard_outputs(outputs: Iterable[str | Path], reads: Iterable[str | Path | None] = (),
                  folders: Iterable[str | Path | None] = (), hint: str = "choose another path") -> None:
    """The one check every writer of files makes before any work (``track``, ``render``, ``graph``, the JSON
    reports, :meth:`sotmot.Result.save`, live sessions).

    Each output file must not be a folder, must not be one of the files the
    run ``reads`` (:func:`refuse_overwriting`) and must not lie inside one of
    the user's sequence ``folders`` (:func:`refuse_inside`; ``None`` entries
    skipped). Raises :class:`InputError` naming the output and ``hint``.
    """
    outputs = [Path(p) for p in outputs]
    for out in outputs:
        if out.is_dir():
            raise InputError(out, f"is a folder, and a file would go here; {hint}")
    refuse_overwriting(outputs, reads, hint)
    folders = [Path(f) for f in folders if f is not None]
    for out in outputs:
        refuse_inside(out, folders, hint)


def check_output_dir(path: str | Path) -> Path:
    """Make sure results can be written into the folder ``path`` (created if missing), before any work.

    Raises
    ------
    InputError
        ``path`` is a file, cannot be created, or is not writable.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(path, "--out must be a folder, but this is a file")
    try:
        path.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".sotmot-write-test.", dir=path)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise InputError(path, f"cannot write results here: {exc.strerror}") from exc
    return path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
