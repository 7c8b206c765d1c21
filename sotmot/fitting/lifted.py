"""The lifted solver's learned pair costs, fitted on ground truth (``scripts/fit_lifted.py``).

Every tracklet gets the ground-truth identity most of its boxes match; the
pairs a lifted trajectory can hold become samples (:data:`~sotmot.association.objective.PAIR_FEATURES`,
same person or not), and a balanced logistic regression gives
``[association] lifted_coefficients``.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from sotmot.association.objective import lifted_horizon, pair_features, pair_inputs
from sotmot.fitting.logistic import fit_logistic
from sotmot.config import AssociationConfig
from sotmot.fitting.confidence import clear_matching
from sotmot.io import SeqInfo
from sotmot.motion import CameraMotion
from sotmot.types import Tracklet, Tracks


def tracklet_identities(tracklets: Sequence[Tracklet], info: SeqInfo, workdir: Path,
                        motion: CameraMotion | None = None) -> np.ndarray:
    """``(T,)`` ground-truth identity of each tracklet, or -1 when fewer than half its boxes are one identity's.

    Each tracklet is written as a track of its own and matched by the CLEAR
    rule (:func:`sotmot.scoring.frame_errors`); a box on a distractor or on
    no one counts against every identity. Tracklets hold reference-frame
    boxes: on a moving camera pass its ``motion`` (``Prepared.motion``) so
    they are matched in each frame's own pixels, as the ground truth is.
    """
    if not tracklets:
        return np.zeros(0, dtype=np.int64)
    frames = np.concatenate([t.frames for t in tracklets])
    boxes = np.concatenate([t.boxes for t in tracklets])
    tracks = Tracks(frames, np.concatenate([np.full(len(t.frames), k + 1) for k, t in enumerate(tracklets)]),
                    boxes if motion is None else motion.from_ref(frames, boxes),
                    np.concatenate([t.scores for t in tracklets]))
    matched = clear_matching(tracks, info, workdir).identities
    out = np.full(len(tracklets), -1, dtype=np.int64)
    for k, t in enumerate(tracklets):
        ids, counts = np.unique([matched.get((int(f), k + 1), -1) for f in t.frames], return_counts=True)
        best = int(np.argmax(np.where(ids >= 0, counts, 0)))
        if ids[best] >= 0 and 2 * counts[best] >= len(t.frames):
            out[k] = ids[best]
    return out


def lifted_pair_samples(tracklets: Sequence[Tracklet], identities: np.ndarray,
                        config: AssociationConfig) -> tuple[np.ndarray, np.ndarray]:
    """The learned lifted costs' training pairs of one sequence: features
    (:data:`~sotmot.association.objective.PAIR_FEATURES`) and labels.

    Every pair of tracklets with known identities, one ending 1 to ``H``
    frames (the lifted horizon) before the other starts: the pairs a
    trajectory of the lifted solver can hold. Label 1 when both are the same
    person.
    """
    known = np.flatnonzero(identities >= 0)
    starts = np.array([tracklets[k].start for k in known], dtype=np.int64)
    ends = np.array([tracklets[k].end for k in known], dtype=np.int64)
    gap = starts[None, :] - ends[:, None]
    early, late = np.nonzero((gap >= 1) & (gap <= lifted_horizon(config)))
    if len(early) == 0:
        return np.zeros((0, 3)), np.zeros(0)
    affinity, n_early, n_late, _ = pair_inputs(tracklets, known[early], known[late])
    same = identities[known[early]] == identities[known[late]]
    return pair_features(affinity, n_early, n_late), same.astype(np.float64)


def fit_lifted_costs(samples: Sequence[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float, float, float]:
    """``[association] lifted_coefficients`` from the pairs of :func:`lifted_pair_samples` of several sequences.

    Logistic regression with the two classes weighted equally, so that its
    log-odds are the log-likelihood ratio of "one person" against "two
    people" (the share of same-person pairs among candidates is not a prior
    of the pairs a trajectory holds); returned in raw feature units,
    intercept first.
    """
    x = np.concatenate([f for f, _ in samples])
    y = np.concatenate([label for _, label in samples])
    if y.min(initial=1.0) == y.max(initial=0.0):
        raise ValueError("the lifted costs need both same-person and different-person pairs")
    weights = np.where(y > 0, 0.5 / y.sum(), 0.5 / (len(y) - y.sum()))
    mean, scale, coef, intercept = fit_logistic(x, y, weights, l2=1.0)
    raw = coef / scale
    return (float(intercept - raw @ mean), *(float(c) for c in raw))
