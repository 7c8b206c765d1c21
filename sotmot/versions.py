"""What code a run ran on: Python, the system and the versions of the libraries that compute its boxes.

Run records (:mod:`sotmot.provenance`) carry :func:`environment`; a run repeated from a record says which of these
differ (:func:`environment_changes`), since re-ID in another OpenVINO or onnxruntime, or another NumPy or OpenCV,
can move a box or flip a close decision. Versions are read from the installed packages' metadata: nothing here
imports the libraries themselves.
"""

from __future__ import annotations

import platform
from functools import lru_cache
from typing import Any

#: The distributions whose versions a run record keeps (those installed): the numerics, the solvers, frame
#: decoding, and the three runtimes that run the re-ID model and the detector.
PACKAGES = ("numpy", "scipy", "networkx", "ortools", "opencv-python-headless", "opencv-python", "openvino",
            "onnxruntime", "torch")


@lru_cache(maxsize=1)
def _environment() -> tuple[str, str, tuple[tuple[str, str], ...]]:
    from importlib.metadata import PackageNotFoundError, version

    found = []
    for name in PACKAGES:
        try:
            found.append((name, version(name)))
        except PackageNotFoundError:
            pass
    return (platform.python_version(), f"{platform.system()} {platform.release()} {platform.machine()}",
            tuple(found))


def environment() -> dict[str, Any]:
    """``{"python": ..., "system": ..., "packages": {name: version}}`` of this process (packages of
    :data:`PACKAGES` that are installed)."""
    python, system, packages = _environment()
    return {"python": python, "system": system, "packages": dict(packages)}


def environment_changes(recorded: Any) -> list[str]:
    """How this process differs from a record's ``environment``: ``"openvino 2026.4.1 -> 2026.5.0"`` for each
    package installed in either with another version (``"absent"`` where one lacks it), then Python's; empty when
    ``recorded`` is not such a table (a record written before sotmot recorded it)."""
    if not isinstance(recorded, dict) or not isinstance(recorded.get("packages"), dict):
        return []
    now = environment()
    old, new = recorded["packages"], now["packages"]
    changes = [f"{name} {old.get(name, 'absent')} -> {new.get(name, 'absent')}"
               for name in PACKAGES if old.get(name) != new.get(name) and (name in old or name in new)]
    if recorded.get("python") not in (None, now["python"]):
        changes.append(f"Python {recorded['python']} -> {now['python']}")
    return changes
