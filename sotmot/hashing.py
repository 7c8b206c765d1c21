"""The SHA-256 of a file, the one way sotmot fingerprints the files a run reads and writes (models, inputs,
results, side files)."""

from __future__ import annotations

import hashlib
from functools import lru_cache
from pathlib import Path


@lru_cache(maxsize=64)
def _file_sha256(path: str, size: int, mtime_ns: int) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def file_sha256(path: str | Path) -> str | None:
    """SHA-256 of a file's bytes (cached while its size and modification time stay), None if absent."""
    path = Path(path)
    if not path.is_file():
        return None
    st = path.stat()
    return _file_sha256(str(path.resolve()), st.st_size, st.st_mtime_ns)
