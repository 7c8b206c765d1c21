"""What code a run ran on: Python, the system, the CPU and the versions of the libraries that compute its boxes.

Run records (:mod:`sotmot.provenance`) carry :func:`environment`; a run repeated from a record says which of these
differ (:func:`environment_changes`), since re-ID in another OpenVINO or onnxruntime, or another NumPy or OpenCV,
can move a box or flip a close decision, and so can another CPU: OpenVINO has kernels of its own per instruction
set (re-ID runs in float32 everywhere by default, ``[appearance] precision``; in bf16, where OpenVINO chose it
before, the same inputs on an AMD EPYC with AVX-512 bf16 and on an Intel Xeon with AMX gave MOT17-09-SDP 72.22
and 72.14 HOTA; docs/benchmarks.md). Versions are read from
the installed packages' metadata: nothing here imports the libraries themselves.
"""

from __future__ import annotations

import os
import platform
from functools import lru_cache
from pathlib import Path
from typing import Any

#: The distributions whose versions a run record keeps (those installed): the numerics, the solvers, frame
#: decoding, and the three runtimes that run the re-ID model and the detector.
PACKAGES = ("numpy", "scipy", "networkx", "ortools", "opencv-python-headless", "opencv-python", "openvino",
            "onnxruntime", "torch")


#: The CPU features that choose the kernels, and with them the rounding, of the re-ID model and the detector.
CPU_FEATURES = ("avx2", "avx512f", "avx512_vnni", "avx512_bf16", "amx_bf16", "amx_int8")


@lru_cache(maxsize=1)
def cpu() -> tuple[str, tuple[str, ...]]:
    """This machine's CPU: its model name (``/proc/cpuinfo``, else :func:`platform.processor`) and which of
    :data:`CPU_FEATURES` it has (none known off Linux)."""
    model, flags = "", set()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and not model:
                model = value.strip()
            elif key.strip() == "flags" and not flags:
                flags = set(value.split())
    except OSError:
        pass
    return model or platform.processor() or platform.machine(), tuple(f for f in CPU_FEATURES if f in flags)


def _cpu_words(described: dict) -> str:
    """``"model (feature, ...)"`` of a CPU as :func:`environment` records it (a hand-edited record may hold
    anything: said as it is)."""
    features = described.get("features")
    features = [str(f) for f in features] if isinstance(features, list) else []
    return f"{described.get('model')}" + (f" ({', '.join(features)})" if features else "")


def machine() -> str:
    """One line: CPU model, logical CPUs, OS and Python version (what benchmarks report they ran on)."""
    return (f"{cpu()[0]}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}, "
            f"Python {platform.python_version()}")


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
    """``{"python": ..., "system": ..., "cpu": {"model": ..., "features": [...]}, "packages": {name: version}}``
    of this process (the CPU as :func:`cpu` reads it; packages of :data:`PACKAGES` that are installed)."""
    python, system, packages = _environment()
    model, features = cpu()
    return {"python": python, "system": system, "cpu": {"model": model, "features": list(features)},
            "packages": dict(packages)}


def environment_changes(recorded: Any) -> list[str]:
    """How this process differs from a record's ``environment``: ``"openvino 2026.4.1 -> 2026.5.0"`` for each
    package installed in either with another version (``"absent"`` where one lacks it), then Python's, then the
    CPU's (``"CPU AMD EPYC (avx2, avx512f, avx512_bf16) -> Intel(R) Xeon(R) Processor (...)"``, where the
    record has one: records before sotmot kept it have none); empty when ``recorded`` is not such a table (a
    record written before sotmot recorded it)."""
    if not isinstance(recorded, dict) or not isinstance(recorded.get("packages"), dict):
        return []
    now = environment()
    old, new = recorded["packages"], now["packages"]
    changes = [f"{name} {old.get(name, 'absent')} -> {new.get(name, 'absent')}"
               for name in PACKAGES if old.get(name) != new.get(name) and (name in old or name in new)]
    if recorded.get("python") not in (None, now["python"]):
        changes.append(f"Python {recorded['python']} -> {now['python']}")
    was = recorded.get("cpu")
    if isinstance(was, dict) and (was.get("model"), was.get("features")) != (now["cpu"]["model"],
                                                                            now["cpu"]["features"]):
        changes.append(f"CPU {_cpu_words(was)} -> {_cpu_words(now['cpu'])}")
    return changes
