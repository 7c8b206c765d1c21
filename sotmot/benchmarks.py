"""What the benchmark scripts in ``scripts/`` share: where the data is, which sequences, which machine.

Scripts import these instead of importing each other. ``DEFAULT_DATA`` is
``../shared/data`` beside the project (an editable install), or the
environment variable ``SOTMOT_DATA``.
"""

from __future__ import annotations

import os
import platform
from pathlib import Path

from sotmot.config import TrackerConfig

DEFAULT_DATA = Path(os.environ.get("SOTMOT_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


def machine() -> str:
    """One line: CPU model, logical CPUs, OS and Python version (benchmarks report what they ran on)."""
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (f"{cpu}, {os.cpu_count()} logical CPUs, {platform.system()} {platform.release()}, "
            f"Python {platform.python_version()}")


def sequences(data: Path) -> list[Path]:
    """Sequence folders with frames under ``data`` (the label-only MOT16-labels folders are skipped)."""
    return sorted(p for p in data.iterdir() if (p / "seqinfo.ini").is_file() and (p / "img1").exists())


def before_confirmation(config: TrackerConfig) -> TrackerConfig:
    """``config`` as sotmot ran before the confirmation stage (issue #11): every box kept, every gap filled."""
    return config.replace("confirm", enabled=False).replace("postprocess", interpolate_max_seconds=None)
