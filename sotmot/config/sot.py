"""Configuration of the single-object-tracking step (paper Sec. 3.3, Algorithm 1) and of trajectory ends."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sotmot.config.common import _check


@dataclass(frozen=True)
class SotConfig:
    """The single-object-tracking step that adds missed boxes, as the paper publishes it (Sec. 3.3, Algorithm 1).

    Every detection seeds a forward and a backward extension; an extension
    stops when it has ``L`` boxes, meets an opposite end, loses the object or
    runs into a box. The search geometry (``search_radius``, ``scales``,
    ``rerank``) is shared with the trajectory ends (``[ends]``).

    Attributes
    ----------
    variant
        ``"none"`` (no SOT step), ``"template"`` (OpenCV normalised
        cross-correlation, the paper's naive variant) or ``"deep"`` (template
        proposals re-ranked by the re-ID model).
    tau
        ``next()`` returns its best candidate only if its affinity with the
        seed is above this (paper: 0.5).
    tau_a
        An end meets an opposite end, or keeps a new box, only with affinity
        above this (paper: 0.75). For ``deep`` the affinity is sotmot's re-ID
        affinity, for ``template`` the correlation coefficient.
    tau_I
        IoU above which two boxes are the same object (paper: 0.5).
    e
        Score decay per SOT step (paper: 0.9).
    L
        Longest extension, in boxes, of one end (paper: 15).
    search_radius
        The search window is the prior box grown by this many box sizes on
        every side (the spread of the paper's dense sampling around B).
    scales
        Box scales tried around the prior (the paper samples scale too).
    rerank
        ``deep`` and the trajectory ends: how many template proposals the
        re-ID model re-ranks per step.
    window
        Frames per SOT window (ends never leave their window; only a window's
        frames are in memory); 0 means ``2 L + 1``.
    """

    variant: Literal["none", "template", "deep"] = "none"
    tau: float = 0.5
    tau_a: float = 0.75
    tau_I: float = 0.5
    e: float = 0.9
    L: int = 15
    search_radius: float = 0.5
    scales: tuple[float, ...] = (0.95, 1.0, 1.05)
    rerank: int = 4
    window: int = 0

    def __post_init__(self) -> None:
        _check(self.variant in ("none", "template", "deep"), "sot",
               f"variant must be one of none, template, deep; got {self.variant!r}")
        for name in ("tau", "tau_a", "tau_I", "e"):
            _check(0.0 <= getattr(self, name) <= 1.0, "sot", f"{name} must be in [0, 1]")
        _check(1 <= self.L <= 1000, "sot", "L must be between 1 and 1000 boxes")
        _check(0 < self.search_radius <= 10, "sot", "search_radius must be in (0, 10] box sizes")
        _check(1 <= len(self.scales) <= 16 and all(0.5 <= s <= 2.0 for s in self.scales), "sot",
               "scales must be 1 to 16 factors, each in [0.5, 2]")
        _check(1 <= self.rerank <= 64, "sot", "rerank must be between 1 and 64")
        _check(0 <= self.window <= 100_000, "sot", "window must be between 0 and 100,000 frames")


@dataclass(frozen=True)
class EndsConfig:
    """Trajectory ends after association (``sotmot.sot.extend``): each confirmed trajectory followed past its last
    and before its first box, where interpolation cannot reach.

    The boxes come from the person detector's weak boxes when the run has them
    (``[detection] weak_boxes``: a detector box near the trajectory's motion
    prior, re-ranked by re-ID; ByteTrack's second association, here at
    trajectory ends), else from SOT (the template search of ``[sot]``,
    re-ranked by re-ID). Held out (``scripts/fit_sot.py``, issue #25) the weak
    boxes gained more than SOT under both protocols.

    Attributes
    ----------
    seconds
        How far an end may grow, in seconds; 0 turns the extension off. On by
        default since issue #12. Its gates chosen held out on the full-length
        sequences (docs/results.md, "Trajectory ends"), combined HOTA / MOTA
        against no extension: public, by SOT +0.07 / +0.3, by the weak boxes
        ("public, refined") +0.55 / +0.9; private, by the weak boxes +0.0 /
        +0.0 (+0.1 / +0.1 before 1080p frames went to the detector at 544 x
        960). On the validation set 0.5, 1.5 and 2 s tie with 1 s (no sequence
        moved by more than 0.05 HOTA; the detector's weak boxes run out within
        0.5 s; docs/benchmarks.md, "The trajectory ends, judged by the validation set").
    min_confidence
        Only trajectories whose boxes' mean confirmation confidence
        (``[confirm]``, ``sotmot.confidence``) is at least this are extended:
        extensions of doubtful trajectories are mostly false (issue #12).
        Trajectories without confidences (confirmation off) are extended.
    min_affinity
        A found box is kept only if its re-ID affinity with the trajectory's
        mean feature is at least this (a detector's weak box needs 0.5, fitted
        with the weak boxes in issue #25). With model 0288 the same person one
        to 14 frames apart has median affinity 0.71-0.81, a box shifted to IoU
        0.5 about 0.63, another person 0.33; 0.5, with ``min_confidence`` 0.8
        and ``seconds`` 1, was fitted leave-one-sequence-out in issue #12
        (``scripts/fit_sot.py``, docs/benchmarks.md); with today's defaults the
        held-out choices differ by fold and score no better than these
        (public, by SOT: 63.6 HOTA held out, 63.9 with these gates).
    stop_iou
        An end stops where its SOT candidate overlaps a box of someone else
        (another trajectory, another detection) at IoU above this: a lagging
        duplicate of a detection overlaps it at 0.3-0.5. A detector's box is a
        detection of its own and stops an end only above 0.7. On the validation
        set 0.2 loses up to 1.4 MOTA; 0.4 to 0.7 gain the public sequences with
        frames a little (+0.18 to +0.29 HOTA, +0.27 to +0.41 MOTA on average,
        PETS09-S2L1 down to -0.45 MOTA at 0.7), within what changes that should
        change nothing move and on one video only (docs/benchmarks.md, "Three more of the constants").
    """

    seconds: float = 1.0
    min_confidence: float = 0.8
    min_affinity: float = 0.5
    stop_iou: float = 0.3

    def __post_init__(self) -> None:
        _check(0.0 <= self.seconds <= 60.0, "ends", "seconds must be in [0, 60]")
        for name in ("min_confidence", "min_affinity", "stop_iou"):
            _check(0.0 <= getattr(self, name) <= 1.0, "ends", f"{name} must be in [0, 1]")

    @property
    def enabled(self) -> bool:
        """Whether anything runs after confirmation: the ends extended."""
        return self.seconds > 0
