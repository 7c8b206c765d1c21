"""Configuration of the single-object-tracking step (paper Sec. 3.3, Algorithm 1) and of trajectory ends."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Literal

from sotmot.config.common import _check


@dataclass(frozen=True)
class SotConfig:
    """The single-object-tracking step that adds missed boxes (paper Sec. 3.3, Algorithm 1).

    Attributes
    ----------
    variant
        ``"none"`` (no SOT step), ``"template"`` (OpenCV normalised
        cross-correlation, the paper's naive variant) or ``"deep"`` (template
        proposals re-ranked by the re-ID model).
    rules
        ``"paper"`` (default): Algorithm 1 as published (every extension is
        kept, a candidate is refused only when it overlaps a box at IoU above
        ``tau_I``, the search is centred on the last box), so ``--sot
        template`` alone runs the paper's method. ``"confident"`` (issue #12,
        an experiment kept for the ablation table's rows; it gained nothing
        held out): a candidate that overlaps any box at IoU above
        ``stop_iou`` stops the extension, the search is centred on a
        constant-velocity prior (the extension's own last step), and an
        extension is kept only if it reaches another box (meets an opposite end
        or runs into a box); extensions that run to ``L``, to the window's edge
        or lose the object are dropped, which is where false isolated seeds go.
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
        ``deep``: how many template proposals the re-ID model re-ranks per step.
    window
        Frames per SOT window (ends never leave their window; only a window's
        frames are in memory); 0 means ``2 L + 1``.
    must_link
        Use the links SOT made as must-link hints in tracklet generation.
    seed_min_confidence
        Only detections with at least this confidence (``[preprocess]
        confidence``) start extensions; 0 (the paper) seeds from every
        detection. Extensions of false, isolated detections are the SOT
        step's main source of false boxes (issue #12).
    extend_seconds
        SOT after association (``sotmot.sot.extend``): track each confirmed
        trajectory up to this many seconds past its last and before its first
        box, where interpolation cannot reach; 0 turns it off. Works with any
        ``variant``; candidates are re-ranked by the re-ID model. On by
        default since issue #12 (held out on the full-length sequences: HOTA
        +0.3, MOTA +0.5 combined).
    extend_min_confidence
        Only trajectories whose boxes' mean confirmation confidence
        (``[confirm]``, ``sotmot.confidence``) is at least this have their ends
        extended: extensions of doubtful trajectories are mostly false
        (issue #12). Trajectories without confidences (confirmation off) are
        extended.
    refine_gaps
        SOT after association, inside gaps: search for each interpolated box
        around itself with the track's template and re-ID identity, and
        replace it by the box found when the evidence passes the same gates as
        an end extension (else the interpolated box stays).
    extend_min_affinity
        An end extension (or a gap box) keeps a candidate only if its re-ID
        affinity with the trajectory's mean feature is at least this. With
        model 0288 the same person one to 14 frames apart has median affinity
        0.71-0.81, a box shifted to IoU 0.5 about 0.63, another person 0.33;
        0.5, with ``extend_min_confidence`` 0.8 and ``extend_seconds`` 1, was
        fitted leave-one-sequence-out (``scripts/fit_sot.py``, docs/benchmarks.md).
    stop_iou
        An end extension, and an extension under the ``confident`` rules,
        stops where its candidate overlaps a box of someone else (another
        trajectory, another detection) at IoU above this: a lagging duplicate
        of a detection overlaps it at 0.3-0.5.
    verify
        ``"detector"``: every box SOT finds (Algorithm 1's extensions, the end
        extension, gap refinement) is checked by the person detector
        (``[detection] model``): a found box that overlaps a detector box
        scoring at least ``verify_min_score`` at IoU ``verify_iou`` or more is
        replaced by that box (the paper's box regression on SOT results);
        after association it then needs a re-ID affinity of only
        ``extend_supported_affinity`` (an unsupported one needs
        ``extend_min_affinity``), and in Algorithm 1 an unsupported candidate
        ends its extension. Only trajectories that exist are extended, so
        tracks still start from the detections tracked (MOTChallenge's public
        rule holds with public detections: "public, refined"). ``"none"``: no
        detector check. ``"auto"`` (default): ``"detector"`` when the
        detections come from the detector (``[detection] source``; its weak
        boxes come from the same pass over the frames), ``"none"`` for a
        detections file, so a public run is refined only when asked.
    verify_min_score, verify_iou
        The detector boxes that count as support: score and overlap.
    extend_supported_affinity
        The re-ID affinity a detector-supported box needs (``verify``).
    extend_supported_stop_iou
        ``stop_iou`` for a box a detector box supports (after association:
        the end extension and gap refinement; the weak-box ends): such a box
        is a detection of its own, not a template drifting onto someone else,
        so it stops an end only where it overlaps another trajectory's box
        more than this. A person walking behind another overlaps them at
        0.3-0.7; at 0.7 the weak-box ends found 416 boxes (80 % right) on the
        public sequences where 0.3 found 275 (72 %) (issue #25, leave one video
        out in docs/benchmarks.md).
    extend_by
        Where the boxes that extend a trajectory come from: ``"sot"`` (the
        template search, re-ranked by re-ID; checked by the detector with
        ``verify``), or ``"detections"``: the detector's boxes alone (scoring
        at least ``verify_min_score``, overlapping the trajectory's motion
        prior at IoU ``verify_iou`` or more, re-ranked by re-ID and gated by
        ``extend_supported_affinity``), the simplest use of weak boxes
        (ByteTrack's second association, here at trajectory ends), with no
        SOT; it needs the detector. ``"auto"`` (default): ``"detections"``
        when ``verify`` resolves to the detector, else ``"sot"``: held out
        (``scripts/fit_sot.py``, issue #25) the weak boxes gained more than
        SOT checked by the detector under both protocols.
    """

    variant: Literal["none", "template", "deep"] = "none"
    rules: Literal["paper", "confident"] = "paper"
    tau: float = 0.5
    tau_a: float = 0.75
    tau_I: float = 0.5
    e: float = 0.9
    L: int = 15
    search_radius: float = 0.5
    scales: tuple[float, ...] = (0.95, 1.0, 1.05)
    rerank: int = 4
    window: int = 0
    must_link: bool = False
    seed_min_confidence: float = 0.0
    extend_seconds: float = 1.0
    extend_min_confidence: float = 0.8
    refine_gaps: bool = False
    extend_min_affinity: float = 0.5
    stop_iou: float = 0.3
    verify: Literal["auto", "none", "detector"] = "auto"
    verify_min_score: float = 0.1
    verify_iou: float = 0.5
    extend_supported_affinity: float = 0.5
    extend_supported_stop_iou: float = 0.7
    extend_by: Literal["auto", "sot", "detections"] = "auto"

    def __post_init__(self) -> None:
        _check(self.variant in ("none", "template", "deep"), "sot",
               f"variant must be one of none, template, deep; got {self.variant!r}")
        for name in ("tau", "tau_a", "tau_I", "e"):
            _check(0.0 <= getattr(self, name) <= 1.0, "sot", f"{name} must be in [0, 1]")
        _check(self.rules in ("paper", "confident"), "sot",
               f"rules must be one of paper, confident; got {self.rules!r}")
        _check(1 <= self.L <= 1000, "sot", "L must be between 1 and 1000 boxes")
        _check(0 < self.search_radius <= 10, "sot", "search_radius must be in (0, 10] box sizes")
        _check(1 <= len(self.scales) <= 16 and all(0.5 <= s <= 2.0 for s in self.scales), "sot",
               "scales must be 1 to 16 factors, each in [0.5, 2]")
        _check(1 <= self.rerank <= 64, "sot", "rerank must be between 1 and 64")
        _check(0 <= self.window <= 100_000, "sot", "window must be between 0 and 100,000 frames")
        _check(0.0 <= self.extend_seconds <= 60.0, "sot", "extend_seconds must be in [0, 60]")
        _check(self.verify in ("auto", "none", "detector"), "sot",
               f"verify must be one of auto, none, detector; got {self.verify!r}")
        _check(self.extend_by in ("auto", "sot", "detections"), "sot",
               f"extend_by must be one of auto, sot, detections; got {self.extend_by!r}")
        _check(self.extend_by != "detections" or self.verify != "none", "sot",
               "extend_by = 'detections' takes the detector's boxes: it needs verify = 'detector' (or 'auto' with "
               "the detector as the source of detections)")
        for name in ("seed_min_confidence", "extend_min_affinity", "extend_min_confidence", "stop_iou",
                     "verify_min_score", "verify_iou", "extend_supported_affinity", "extend_supported_stop_iou"):
            _check(0.0 <= getattr(self, name) <= 1.0, "sot", f"{name} must be in [0, 1]")

    def resolved(self, detector_detections: bool) -> SotConfig:
        """``verify`` and ``extend_by`` with ``"auto"`` decided: ``detector_detections`` says whether the
        detections come from the detector (private), where its weak boxes check the SOT step by default."""
        verify = self.verify if self.verify != "auto" else ("detector" if detector_detections else "none")
        extend_by = self.extend_by if self.extend_by != "auto" else ("detections" if verify == "detector" else "sot")
        return dataclasses.replace(self, verify=verify, extend_by=extend_by)
