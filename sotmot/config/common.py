"""What every configuration section shares: the check that names the section, and the frame-rate bound."""

from __future__ import annotations

from sotmot.errors import ConfigError


def _check(cond: bool, section: str, message: str) -> None:
    if not cond:
        raise ConfigError(f"[{section}] {message}")


#: The highest frame rate taken (``frameRate``, ``--fps``, a video container's): every stage counts time in
#: frames from it (1-second batches, the 2-second interpolation bound), and a wrong one silently breaks them all.
MAX_FRAME_RATE = 240.0
