"""Configuration of what happens after association: post-processing, confirmation, camera motion, windows."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sotmot.config.common import _check


@dataclass(frozen=True)
class PostprocessConfig:
    """Interpolation and smoothing of the final trajectories (paper Sec. 3.5).

    Attributes
    ----------
    interpolate
        Fill every gap inside a trajectory by linear interpolation.
    smooth_window
        ``"auto"`` (default): each coordinate of a box (centre x, centre y,
        width, height) becomes a straight line fitted through the trajectory's
        values within ``+- w`` frames, evaluated at the box's frame, ``w`` chosen
        for each trajectory and coordinate from 3, 4, 6, 8 and 12 frames by
        cross-validation on its detected boxes (each predicted from the others,
        leaving out those within a frame of it: a detector errs alike on
        consecutive frames). Noisy boxes of a walk get long windows, a turn or a
        moving camera short ones. A number of frames: the paper's smoothing,
        each box the mean of the trajectory's boxes within ``+- smooth_window``
        frames (paper: 3; the default before issue #39's validation set chose
        ``"auto"``: docs/benchmarks.md); 0 turns smoothing off.
    min_length
        Output trajectories with fewer boxes (after interpolation) are dropped;
        1 keeps everything (the paper drops only tracklets, see ``l_min``).
    interpolate_max_seconds
        Gaps longer than this (in seconds, from the frame rate) are left
        unfilled; ``None`` fills every gap. 4.0 fills every gap the default
        association bridges (``[association] l_max_seconds``) and no longer
        one, should ``l_max`` be given in frames (60 frames are 8.6 s at
        7 fps, where boxes interpolated over more than 2 s were 30 % correct
        before confirmation: docs/calibration.md). Chosen leave one sequence
        out from 2, 3 and 4 s with confirmation refitted each time: 4 s
        had the best HOTA on every full-length sequence (docs/calibration.md).
    occlusion_seconds, min_agreement
        Interpolation fills occlusions: a gap longer than ``occlusion_seconds``
        is filled on trust only where the walk on both sides leads along its
        straight line (a motion agreement, :func:`sotmot.boxes.motion_agreement`
        from up to 10 boxes each side, of at least ``min_agreement``); in any
        other long gap a box is written only where a detection stands in
        front of it (overlapping it, its bottom edge as low or lower: nearer
        the camera) and could hide the person. A person the detector missed
        that long, off the line and with nothing in front, was not there, or
        left the image and came back. ``None``: every gap up to the bound is
        filled. 1.0 s and 0.5 (default) passed the validation set's rule (no
        sequence losing more than 0.5 HOTA or MOTA, the moving-camera
        variants included; docs/benchmarks.md, "The validation set").
    still_speed
        The walk's line says nothing where nobody walked: a long gap (over
        ``occlusion_seconds``) across which the box's centre moved less than
        this many of its heights per second is judged as one off the line (a
        box only where a detection stands in front). A person standing still
        whom the detector lost for over a second was hidden by someone; a
        still thing the detector fires on now and then (a sign, a poster, a
        mannequin) is not a person. ``None`` (default): such gaps are filled
        on trust. Judged leave one video out (0.01 to 0.1) it stays off:
        from the built-in detector's boxes 0.02 lifts the MOT16-09 video by
        0.7-0.9 HOTA and 2.3-3.1 MOTA at every rate, removing only false boxes
        (a sign with balloons, bridged across 4 s), and costs no other
        validation sequence more than 0.4 HOTA or MOTA (MOT17-05-SDP, motion
        only); so the fold that holds that video out keeps it off
        (docs/benchmarks.md). Worth trying where something still is taken for
        a person, beside ``[preprocess] mask``, which needs to know where.
    min_seen_share
        A trajectory with boxes in fewer than this share of the frames from
        its first to its last (mostly gaps: a few detections of a still thing,
        or of several people, joined across gaps) gets no box in any gap,
        long or short, on the line or off it, hidden or not; its detections
        are kept (where ``occlusion_seconds`` judges gaps). Short gaps too
        since 2026-12-06: from the built-in detector's boxes at 30 fps the
        detector's second, shorter box on a person makes such tracks, whose
        short gaps held 109 of MOT16-09's 140 false short-gap boxes (4 right);
        on the validation set this lifts that video by 0.6 HOTA and 2.0 MOTA,
        changes nothing public with re-ID, and moves the label sets' FP by
        -225 and FN by +197 (none worse than -0.1 MOTA; docs/benchmarks.md,
        "A trajectory seen too little"). ``None``: not judged (the default
        before 2026-12-05). 0.3 (default):
        long-gap boxes of trajectories seen in under 0.3 of their frames were
        0-36 % right on the validation set (public, private, motion only),
        from 0.3 to 0.4 about half (TUD-Stadtmitte's people walking behind
        others, seen in 0.31-0.36 of their frames, 54-99 %); it lifts the
        MOT16-09 video from the built-in detector's boxes by 2.2 HOTA and 7.8
        MOTA and the label sets' MOTA by 0.2, and loses no validation sequence
        more than 0.3 MOTA; left one video out, seven folds of eight choose
        0.3 from 0.2 to 0.4, and the eighth's 0.4 would cost TUD-Stadtmitte
        up to 3.75 HOTA (docs/benchmarks.md, "A trajectory seen too
        little").
    line_check_seconds
        Interpolation trusts the straight line between a person's boxes; this
        checks that line on the sequence's own trajectories, over spans where
        people were seen: the line from a box to the box this many seconds
        later must land on the box halfway (IoU >= 0.3: a detector's loose
        boxes must not fail a line that follows the person) in at least half
        the samples. Where it does not (a camera that moves with nothing to
        compensate it, as in the motion-only mode), gaps are filled only up to
        the longest span from 1 s, in steps of 0.5 s, over which it holds
        (:func:`sotmot.postprocess.line_checked`; ``sotmot track`` says so
        in its summary line and, for a whole run, in the run record's
        ``line_check``).
        ``None`` trusts the line (the default before 2026-12-04). 2.0 changes
        no validation sequence with frames and no compensated synthetic
        camera, and lifts the motion-only mode on the moving-camera label sets
        by up to 3.1 HOTA and 17 MOTA, none worse, at their recorded rates and
        at half of them, over paired runs with moved boxes too
        (docs/benchmarks.md, "Interpolation that checks its line").
    """

    interpolate: bool = True
    smooth_window: int | Literal["auto"] = "auto"
    min_length: int = 1
    interpolate_max_seconds: float | None = 4.0
    occlusion_seconds: float | None = 1.0
    min_agreement: float = 0.5
    still_speed: float | None = None
    min_seen_share: float | None = 0.3
    line_check_seconds: float | None = 2.0

    def __post_init__(self) -> None:
        _check(self.smooth_window == "auto" or 0 <= self.smooth_window <= 1000, "postprocess",
               "smooth_window must be \"auto\" or a number of frames between 0 and 1000")
        _check(1 <= self.min_length <= 1_000_000, "postprocess", "min_length must be between 1 and 1,000,000")
        _check(self.interpolate_max_seconds is None or 0 < self.interpolate_max_seconds <= 3600, "postprocess",
               "interpolate_max_seconds must be in (0, 3600] (or absent to fill every gap)")
        _check(0.0 <= self.min_agreement <= 1.0, "postprocess", "min_agreement must be in [0, 1]")
        _check(self.occlusion_seconds is None or 0 <= self.occlusion_seconds <= 3600, "postprocess",
               "occlusion_seconds must be in [0, 3600] (or absent to fill every gap on trust)")
        _check(self.still_speed is None or 0 <= self.still_speed <= 100, "postprocess",
               "still_speed must be in [0, 100] heights per second (or absent)")
        _check(self.min_seen_share is None or 0 <= self.min_seen_share <= 1, "postprocess",
               "min_seen_share must be in [0, 1] (or absent)")
        _check(self.line_check_seconds is None or 0 < self.line_check_seconds <= 3600, "postprocess",
               "line_check_seconds must be in (0, 3600] (or absent to trust the line)")


@dataclass(frozen=True)
class ConfirmConfig:
    """Confirmation after association: drop the boxes that are more likely false than true.

    Each output box (detector, SOT or interpolated) gets a probability of being
    a true positive from what its trajectory is made of (``sotmot.confidence``);
    boxes below ``threshold`` are not written to the results. Interpolation is
    bounded the same way: an interpolated box in a long gap of a weak
    trajectory scores low and is dropped.

    Attributes
    ----------
    enabled
        Run the confirmation stage (False writes every box, as before, and
        extends every trajectory's ends). With the built-in detector's boxes
        the fitted threshold is 0: the stage drops nothing there and its box
        model only chooses which ends grow (``[ends] min_confidence``). Fitted
        on eight scenes (three videos and five MOT16 clips of other streets and
        a vehicle's camera, leave one out), no threshold above 0 kept every
        scene within 0.5 HOTA and IDF1 of keeping every box; the earlier fit on
        the three videos alone dropped true boxes on the clips (MOT16-13 -9.3
        HOTA) to remove MOT16-09's false ones (+3.5 HOTA, +11.9 MOTA there;
        docs/benchmarks.md, "The built-in detector's confirmation drops
        nothing").
    threshold
        Boxes with a lower probability are dropped. ``None``: the value fitted
        with the calibration (leave-one-sequence-out, ``docs/calibration.md``).
        Dropping a box of probability p changes MOTA's numerator by 1 - 2p, so
        0.5 is MOTA's break-even; HOTA and IDF1 favour lower values.
    calibration
        JSON from ``scripts/fit_confidence.py`` with the detector-family maps and
        the box model; ``None``: the one packaged with sotmot
        (``sotmot/data/confidence.json``). ``[preprocess] confidence`` reads its
        family maps from here too.
    low_confidence
        ``"drop"``: dropped boxes are gone; ``"file"``: they are written to
        ``<name>.low.txt`` beside the results (same ids, MOTChallenge format).
    """

    enabled: bool = True
    threshold: float | None = None
    calibration: str | None = None
    low_confidence: Literal["drop", "file"] = "drop"

    def __post_init__(self) -> None:
        _check(self.threshold is None or 0.0 <= self.threshold <= 1.0, "confirm", "threshold must be in [0, 1]")
        _check(self.low_confidence in ("drop", "file"), "confirm",
               f"low_confidence must be 'drop' or 'file'; got {self.low_confidence!r}")


@dataclass(frozen=True)
class MotionConfig:
    """Camera motion compensation (``sotmot.motion``): positions compared in one reference frame.

    Attributes
    ----------
    compensation
        ``"auto"``: estimate the camera's motion when frames half a second
        apart moved (a still camera changes nothing: results are identical to
        ``"off"``); ``"on"``: always estimate and compensate; ``"off"``: never.
    still_pixels
        ``auto`` calls the camera still when no corner of any frame moved
        farther than this (pixels) between frames half a second apart (the
        still cameras of the shared data: at most 1.4 px, MOT16-09; a camera
        drifting 3 px a half second moves a box 12 px over the longest
        interpolated gap of 2 s).
    min_confidence
        A frame pair's estimate is used when at least this share of the tracked
        corners agreed with it; below, the pair counts as no motion.
    """

    compensation: Literal["auto", "on", "off"] = "auto"
    still_pixels: float = 3.0
    min_confidence: float = 0.2

    def __post_init__(self) -> None:
        _check(self.compensation in ("auto", "on", "off"), "motion",
               f"compensation must be 'auto', 'on' or 'off'; got {self.compensation!r}")
        _check(0.0 < self.still_pixels <= 1000.0, "motion", "still_pixels must be in (0, 1000]")
        _check(0.0 <= self.min_confidence <= 1.0, "motion", "min_confidence must be in [0, 1]")


@dataclass(frozen=True)
class WindowConfig:
    """Committed time windows (``sotmot.windows``): a long sequence tracked window by window, so that memory holds
    one window and results are written while the video plays. Off by default.

    Each window is tracked as a sequence of its own; consecutive windows
    overlap by at least the association's gap (``[association]
    l_max_seconds``), so every link the gap rule allows lies wholly inside one
    window, and the tracks of two windows are joined where their boxes agree
    in the overlap (mean IoU at least ``join_iou``, one to one). Each frame's
    boxes come from one window: the earlier one up to the middle of the
    overlap, the later one after it. A sequence no longer than one window is
    tracked exactly as without windows.

    Attributes
    ----------
    seconds
        Window length in seconds (0: off, the whole sequence at once). At least
        twice the overlap.
    overlap_seconds
        Overlap of consecutive windows; ``None``: the association's gap limit
        (``l_max_seconds``, or ``l_max`` frames). Never less than that gap.
    join_iou
        Two tracks of consecutive windows are one person when their boxes in
        the overlap's shared frames have at least this mean IoU.
    """

    seconds: float = 0.0
    overlap_seconds: float | None = None
    join_iou: float = 0.5

    def __post_init__(self) -> None:
        _check(0.0 <= self.seconds <= 86400.0, "windows", "seconds must be in [0, 86400] (0: off)")
        _check(self.overlap_seconds is None or 0.0 < self.overlap_seconds <= 3600.0, "windows",
               "overlap_seconds must be in (0, 3600] (or absent: the association's gap limit)")
        _check(0.0 < self.join_iou <= 1.0, "windows", "join_iou must be in (0, 1]")
