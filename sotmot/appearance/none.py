"""The ``"none"`` backend: no re-ID model at all (motion-only tracking).

Features are ``(N, 0)``: nothing is cropped or embedded, and no frame is read
for appearance, so a sequence without frames (detections and ground truth
only) can be tracked. Every stage that compared features compares geometry
instead: tracklets match by IoU with the tracklet's last box, and long-term
association ranks and gates links by how well the two trajectories' motion
agrees (:func:`sotmot.association.affinity.motion_affinities`).
"""

from __future__ import annotations

import numpy as np

from sotmot.config import AppearanceConfig


class NoAppearance:
    """An embedder of zero-width features: the motion-only mode (``[appearance] backend = "none"``)."""

    dim = 0

    def __init__(self, config: AppearanceConfig | None = None) -> None:
        self.config = config

    def embed(self, frame: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """``(N, 0)`` float32 for ``(N, 4)`` ``x, y, w, h`` boxes: no appearance."""
        return np.zeros((len(np.asarray(boxes).reshape(-1, 4)), 0), dtype=np.float32)
