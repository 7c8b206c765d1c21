"""Builders for hand-made tracklets."""

from __future__ import annotations

import numpy as np

from sotmot.types import Tracklet


def tk(tid: int, frames, boxes, feature=(1.0, 0.0), scores=None, det_start: int | None = None) -> Tracklet:
    """A tracklet with given frames and boxes (one box repeated if a single box is given)."""
    frames = np.asarray(frames)
    boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
    if len(boxes) == 1 and len(frames) > 1:
        boxes = np.repeat(boxes, len(frames), axis=0)
    scores = np.ones(len(frames)) if scores is None else np.asarray(scores, dtype=float)
    start = 1000 * tid if det_start is None else det_start
    return Tracklet(id=tid, frames=frames, boxes=boxes, scores=scores,
                    det_index=np.arange(start, start + len(frames)), feature=np.asarray(feature), n_features=len(frames))


def direction(degrees_from_x: float, out_of_plane: float = 0.0) -> tuple[float, float, float]:
    """A unit 3-D feature at this angle from the x axis, tilted out of the x-y plane by ``out_of_plane`` degrees."""
    a, z = np.radians(degrees_from_x), np.radians(out_of_plane)
    return (float(np.cos(z) * np.cos(a)), float(np.cos(z) * np.sin(a)), float(np.sin(z)))


def one_person_in_three_pieces() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Features of three pieces of one person: first and last at affinity 0.8, the middle at 0.6 to either
    (as when the middle piece is partly occluded; PETS09-S2L1, person 16)."""
    first, last = np.array(direction(0.0)), np.array(direction(23.07))
    bisector = (first + last) / np.linalg.norm(first + last)
    middle = np.cos(np.radians(46.1)) * bisector + np.sin(np.radians(46.1)) * np.array([0.0, 0.0, 1.0])
    return first, middle, last


def load_script(name: str):
    """The module ``scripts/<name>.py`` (its ``from common import ...`` finds scripts/common.py)."""
    import importlib.util
    import sys
    from pathlib import Path

    scripts = Path(__file__).resolve().parents[1] / "scripts"
    sys.path.insert(0, str(scripts))
    try:
        spec = importlib.util.spec_from_file_location(name, scripts / f"{name}.py")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # as an import would: a dataclass in the script looks its module up there
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(scripts))
    return module
