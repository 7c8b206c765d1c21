"""Configuration of tracklets (paper Sec. 3.4, 1-second batches) and long-term association."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal

from sotmot.config.common import MAX_FRAME_RATE, _check
from sotmot.plugins import SOLVERS


@dataclass(frozen=True)
class TrackletConfig:
    """Short tracklets by frame-by-frame Hungarian matching (paper Sec. 3.4).

    Attributes
    ----------
    batch_seconds
        Length of a batch in seconds (paper: 1 s); frames per batch are
        ``round(batch_seconds * frameRate)``, at least 1. On the validation set
        0.5 s loses up to 3.3 HOTA (MOT16-04, motion only) and 2 s up to 5.2
        (TUD-Stadtmitte at 8 fps; docs/benchmarks.md, "Three more of the constants").
    tail
        The affinity of a detection to a tracklet uses the mean feature of the
        tracklet's last ``tail`` detections (paper: 5). On the validation set
        3 and 10 each lose more than 0.5 HOTA or MOTA on some sequence
        (MOT16-09 -1.9 and -1.7 HOTA; docs/benchmarks.md, "Four of the paper's constants").
    min_affinity
        Matches with a lower appearance affinity are not linked. The paper
        leaves this gate implicit; 0.45 lies between the balanced thresholds
        of the re-ID model 0288 on PETS09-S2L1 (0.44) and MOT16-04-clip30 (0.50)
        (docs/calibration.md); on the validation set's 13 sequences with frames
        0.40 and 0.50 each lose more than 0.5 HOTA or MOTA on some of them, and
        every leave-one-video-out fold keeps 0.45 (docs/benchmarks.md).
    min_iou
        Matches whose IoU with the tracklet's last box is lower are not linked.
        Our addition (the paper matches on appearance alone): it keeps two
        similar-looking people far apart from being linked inside one second.
        With re-ID, 0.1 and 0.3 lose 1.3 and 1.0 HOTA on a validation
        sequence (MOT16-09, PETS09-S2L1) and every leave-one-video-out fold
        keeps 0.2; without re-ID (where it is the only gate) stricter gates
        were measured and lost too (docs/benchmarks.md).
    l_min
        Tracklets with <= l_min boxes are dropped (paper: 1). Only detector
        boxes count: without this, one false detection that the SOT step
        extended over 15 frames would survive as a tracklet.
    predict
        Compare a detection with the tracklet's last box moved on by its
        constant velocity (over its last ``tail`` boxes), not with the last box
        itself, in the IoU gate (and, motion only, the IoU that weights the
        match). False (default): the last box, as before.
    yield_weaker
        Where the last boxes of two open tracklets overlap (IoU 0.3 or more)
        and both may take the same detection, the one whose last three
        detections scored lower on average yields it:
        its affinity (motion only: its IoU) with that detection counts this
        much less. When two people overlap the detector tends to keep the one
        in front, and the one behind scores less as it disappears; without
        this the tracklet of the person behind can take the box of the one in
        front. 0 (default): off, the paper's matching. 0.05 is the candidate
        measured on the validation set (``docs/validation/yield0.05.toml``;
        docs/benchmarks.md, "A tracklet that yields").
    """

    batch_seconds: float = 1.0
    tail: int = 5
    min_affinity: float = 0.45
    min_iou: float = 0.2
    l_min: int = 1
    predict: bool = False
    yield_weaker: float = 0.0

    def __post_init__(self) -> None:
        _check(0 < self.batch_seconds <= 60, "tracklets", "batch_seconds must be in (0, 60]")
        _check(1 <= self.tail <= 1000, "tracklets", "tail must be between 1 and 1000")
        _check(0.0 <= self.min_affinity <= 1.0, "tracklets", "min_affinity must be in [0, 1]")
        _check(0.0 <= self.min_iou <= 1.0, "tracklets", "min_iou must be in [0, 1]")
        _check(0 <= self.l_min <= 1000, "tracklets", "l_min must be between 0 and 1000")
        _check(0.0 <= self.yield_weaker <= 1.0, "tracklets", "yield_weaker must be in [0, 1]")


@dataclass(frozen=True)
class AssociationConfig:
    """Long-term association constraints A(t1, t2) (paper Sec. 3.4).

    Attributes
    ----------
    tau_iou
        On every temporally overlapping segment of two trajectories the mean
        IoU of their boxes must be strictly greater than this (paper: 0.5).
        On the validation set 0.7 changes no output and 0.3 loses up to 0.87
        MOTA on some sequences (docs/benchmarks.md, "Four of the paper's constants").
    l_max
        Every gap of the merged trajectory must be at most this many frames
        (frame difference between the boxes at the gap's ends; paper: 60).
        Used only without ``l_max_seconds``: a configuration (file or
        :meth:`TrackerConfig.replace`) that sets ``l_max`` and not
        ``l_max_seconds`` counts the gap in frames, as the paper did.
    l_max_seconds
        The gap limit in seconds at each sequence's frame rate
        (``round(l_max_seconds * frameRate)`` frames; :meth:`at`); ``None``
        counts ``l_max`` frames. The paper's 60 frames are 2 s at 30 fps but
        8.6 s at 7 fps. 4 s was chosen leave one video out from 2-6 s and
        raised held-out HOTA on every full-length sequence (people occluded
        for 2-4 s re-identified; docs/benchmarks.md, "The gap limit").
    velocity_adjacent, velocity_short, velocity_long
        Velocity bound in every gap, as a fraction of the mean width ``w`` of
        the two boxes at the gap's ends: ``w`` for a gap of 1 frame, ``2/3 w``
        for 2 to ``short_gap`` frames, ``1/3 w`` beyond (paper). Velocity is
        the centre displacement divided by the frame difference, in pixels
        per frame (linear motion). All three at 0.75 or 1.5 times the paper's
        lose more than 0.5 HOTA on some validation sequence (MOT16-13 at 15
        fps -1.0, MOT17-09-SDP -1.9; docs/benchmarks.md, "Four of the paper's constants").
    short_gap
        Longest gap that counts as short (paper: 5). 3 and 8 tie with it on the
        validation set, 8 losing MOT16-09 at 15 fps 1.1 MOTA (docs/benchmarks.md, "Three more of the constants").
    solver
        The long-term association solver, a name in ``sotmot.plugins.SOLVERS``:
        ``"greedy"`` (the paper's greedy merge), ``"flow"`` (min-cost flow,
        OR-Tools), ``"flow-nx"`` (the same with networkx), ``"flow-staged"``
        (the same flow twice: links of at most ``flow_stage_gap`` frames, then
        links between the trajectories they made) or ``"lifted"`` (the
        lifted objective, exact per window with CP-SAT; ``solvers/lifted.py``).
        ``--solver`` (alias ``--merger``) sets it.
    min_affinity
        Pairs of trajectories with a lower appearance affinity are never merged.
        The paper's tau_a = 0.75 is for its own model (with model 0288 only 6%
        of same-person pairs on PETS09-S2L1 pass it); 0.45 lies between the
        balanced thresholds of model 0288 on PETS09-S2L1 (0.44) and
        MOT16-04-clip30 (0.50) (docs/calibration.md); on the validation set
        (with re-ID, and as the gate of the motion-only mode's affinity) 0.40
        and 0.50 each lose more than 0.5 HOTA or MOTA on some sequence, and
        every leave-one-video-out fold keeps 0.45 (docs/benchmarks.md).
    long_gap_affinity
        A bridge must be more certain the longer it is: the affinity a link
        needs rises linearly from ``min_affinity`` at a gap of half ``l_max``
        to this at ``l_max`` (the gap the merge creates or changes, the
        velocity rule's); ``None`` (default): ``min_affinity`` at every gap.
    motion_gap_speed
        The motion-only mode (``[appearance] backend = "none"``) joins two
        trajectories across a gap of more than 1 s only where the person moved
        at most this many of their heights per second over it (box centres at
        the gap's two ends; the link's motion affinity is 0 otherwise). Without
        re-ID a walk extrapolated over seconds meets someone else in a crowd:
        on the label-only validation sequences 213 of the 408 such joins whose
        two sides were both people joined two people, and the ones of one
        person were mostly people standing still, hidden. 0.75 was chosen leave
        one video out from 0.3, 0.5, 0.75 and 1 (every fold; docs/benchmarks.md);
        ``None``: no limit. Runs with re-ID never read it.
    frame_rate
        The sequence's frame rate, which :meth:`at` sets for each run (the
        rules counted in seconds read it); not a setting: a file that gives it
        is refused (``[input] fps`` gives a video's rate).
    flow_stage_gap
        ``flow-staged``: the longest gap, in frames, that its first stage links
        across (8 was chosen leave-one-sequence-out from 8, 15 and 30; docs/benchmarks.md).
    lifted_window, lifted_step
        The lifted solver decides the tracklets that start within a window of
        ``lifted_window`` frames at once and commits the links into those that
        start within the first ``lifted_step`` frames before moving on. 30 /
        15 finds the same lifted objective as 60 / 30 on PETS09-S2L1 and
        MOT17-09-FRCNN and 0.05 % less on MOT16-09 and TUD-Stadtmitte, and
        PETS09-S2L1 (7 fps: 60 frames hold 8.6 s of crowd) takes 1.3 s
        instead of 6.9 (docs/benchmarks.md).
    lifted_horizon
        Largest gap in frames between two tracklets of one trajectory that the
        lifted objective scores; None: ``l_max``.
    lifted_costs
        What a pair of tracklets ``a``, ``b`` (``n`` detector boxes each) of one
        trajectory adds to the lifted objective: ``"learned"``, ``n_a * n_b``
        times the log-likelihood ratio of "one person" against "two people"
        given their affinity and the shorter one's length (``lifted_coefficients``);
        ``"threshold"``, ``n_a * n_b * (affinity - lifted_threshold)``.
    lifted_coefficients
        The learned costs' log-likelihood ratio ``c0 + c1 a + c2 log m + c3 a log m``
        (``a`` the affinity, ``m`` the shorter tracklet's number of boxes):
        logistic regression on ground truth with both classes weighted equally,
        fitted by ``scripts/fit_lifted.py`` on the four full-length
        sequences (held-out results in docs/benchmarks.md), for re-ID model
        0288's affinities: refit them for another model. A longer tracklet
        has a steadier mean feature, so the affinity at which a pair starts to
        pay rises with its length (0.38 for single boxes, 0.56 at 30 boxes).
        In the motion-only mode they weigh the motion affinity, which they
        were not fitted on (the MOT16-05 label set: lifted 31.1 HOTA, greedy
        33.3).
    lifted_threshold
        ``lifted_costs = "threshold"``: the affinity above which two tracklets
        of one trajectory add to the lifted objective; None: ``min_affinity``.
        0.5 was chosen leave-one-sequence-out over the full-length sequences
        from 0.45, 0.5 and 0.55 (docs/benchmarks.md).
    lifted_time_limit
        Seconds CP-SAT may spend on one connected component of one window; a
        component without any solution by then is an error.
    lifted_workers
        CP-SAT search workers per component (1 keeps the result reproducible).
    """

    tau_iou: float = 0.5
    l_max: int = 60
    l_max_seconds: float | None = 4.0
    velocity_adjacent: float = 1.0
    velocity_short: float = 2.0 / 3.0
    velocity_long: float = 1.0 / 3.0
    short_gap: int = 5
    min_affinity: float = 0.45
    long_gap_affinity: float | None = None
    motion_gap_speed: float | None = 0.75
    frame_rate: float | None = None
    solver: str = "greedy"
    flow_stage_gap: int = 8
    lifted_window: int = 30
    lifted_step: int = 15
    lifted_horizon: int | None = None
    lifted_costs: Literal["learned", "threshold"] = "learned"
    lifted_coefficients: tuple[float, float, float, float] = (-12.27, 32.41, -5.38, 6.43)
    lifted_threshold: float | None = 0.5
    lifted_time_limit: float = 10.0
    lifted_workers: int = 1

    def __post_init__(self) -> None:
        _check(0.0 <= self.tau_iou < 1.0, "association", "tau_iou must be in [0, 1)")
        _check(1 <= self.l_max <= 1_000_000, "association", "l_max must be between 1 and 1,000,000 frames")
        _check(self.l_max_seconds is None or 0 < self.l_max_seconds <= 36_000, "association",
               "l_max_seconds must be in (0, 36000] (or absent to count l_max in frames)")
        for name in ("velocity_adjacent", "velocity_short", "velocity_long"):
            _check(0 < getattr(self, name) <= 10, "association", f"{name} must be in (0, 10] widths per frame")
        _check(2 <= self.short_gap <= 1_000_000, "association", "short_gap must be between 2 and 1,000,000 frames")
        _check(0.0 <= self.min_affinity <= 1.0, "association", "min_affinity must be in [0, 1]")
        _check(self.long_gap_affinity is None or self.min_affinity <= self.long_gap_affinity <= 1.0, "association",
               "long_gap_affinity must be in [min_affinity, 1] (or absent for one gate at every gap)")
        _check(self.motion_gap_speed is None or 0 < self.motion_gap_speed <= 100, "association",
               "motion_gap_speed must be in (0, 100] heights per second (or absent for no limit)")
        _check(self.frame_rate is None or 0 < self.frame_rate <= MAX_FRAME_RATE, "association",
               f"frame_rate must be in (0, {MAX_FRAME_RATE:g}] frames per second")
        _check(1 <= self.flow_stage_gap <= 1_000_000, "association", "flow_stage_gap must be between 1 and "
               "1,000,000 frames")
        _check(1 <= self.lifted_step <= self.lifted_window <= 1_000_000, "association",
               "lifted_step and lifted_window must satisfy 1 <= lifted_step <= lifted_window <= 1,000,000")
        _check(self.lifted_horizon is None or 1 <= self.lifted_horizon <= 1_000_000, "association",
               "lifted_horizon must be None or between 1 and 1,000,000 frames")
        _check(self.lifted_threshold is None or 0.0 <= self.lifted_threshold <= 1.0, "association",
               "lifted_threshold must be None or in [0, 1]")
        _check(self.lifted_costs in ("learned", "threshold"), "association",
               f"lifted_costs must be 'learned' or 'threshold'; got {self.lifted_costs!r}")
        _check(len(self.lifted_coefficients) == 4 and all(math.isfinite(c) for c in self.lifted_coefficients),
               "association", "lifted_coefficients must be four finite numbers (c0, c1, c2, c3)")
        _check(0 < self.lifted_time_limit <= 3600, "association", "lifted_time_limit must be in (0, 3600] seconds")
        _check(1 <= self.lifted_workers <= 64, "association", "lifted_workers must be between 1 and 64")
        _check(self.solver in SOLVERS, "association",
               f"solver must be one of {', '.join(sorted(SOLVERS))}; got {self.solver!r}")

    def at(self, frame_rate: float | None) -> AssociationConfig:
        """This configuration for a sequence of ``frame_rate`` frames per second: its ``frame_rate``, and its gap
        limit in frames, ``l_max`` from ``l_max_seconds`` (at least 1 frame) and ``l_max_seconds`` None, so that
        a solver may narrow ``l_max`` further (``l_max`` as it was without ``l_max_seconds``). Without a frame rate,
        ``l_max`` frames and no rule counted in seconds."""
        if not frame_rate:
            return dataclasses.replace(self, l_max_seconds=None, frame_rate=None)
        l_max = self.l_max if self.l_max_seconds is None else max(1, int(round(self.l_max_seconds * frame_rate)))
        return dataclasses.replace(self, l_max=l_max, l_max_seconds=None, frame_rate=float(frame_rate))
