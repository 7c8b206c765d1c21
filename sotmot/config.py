"""Configuration: one frozen dataclass per stage, the paper's values as defaults.

Every threshold of the tracker is a field here, documented with its meaning
and where it comes from (He et al., *SOT for MOT*, section numbers below).
Where our re-ID model needs another value than the paper's, the default says
so and points at ``docs/calibration.md``, which derives it from data.

A configuration file (TOML or JSON) holds one table per stage
(``detection``, ``preprocess``, ``appearance``, ``sot``, ``tracklets``, ``association``,
``postprocess``, ``confirm``)::

    [preprocess]
    nms = "iou"
    [association]
    l_max = 45

Unknown tables and keys are errors (a typo must not be silently ignored).
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import math
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from sotmot.errors import ConfigError
from sotmot.plugins import BACKENDS, DETECTORS, SOLVERS


def _check(cond: bool, section: str, message: str) -> None:
    if not cond:
        raise ConfigError(f"[{section}] {message}")


#: The highest frame rate taken (``frameRate``, ``--fps``, a video container's): every stage counts time in
#: frames from it (1-second batches, the 2-second interpolation bound), and a wrong one silently breaks them all.
MAX_FRAME_RATE = 240.0


@dataclass(frozen=True)
class InputConfig:
    """How a video file is read (a MOTChallenge folder's ``seqinfo.ini`` says all of it).

    Attributes
    ----------
    fps
        Frame rate of a video input (``--fps``): every stage counts time in
        frames from it; None takes the container's.
    """

    fps: float | None = None

    def __post_init__(self) -> None:
        _check(self.fps is None or 0 < self.fps <= MAX_FRAME_RATE, "input",
               f"fps must be a frame rate above 0 and at most {MAX_FRAME_RATE:g} per second")


@dataclass(frozen=True)
class DetectionConfig:
    """Where the detections come from: a detector's file, or the built-in person detector run on the frames.

    Attributes
    ----------
    source
        ``"file"``: the sequence's ``det/det.txt`` (or ``file``); ``"model"``:
        the person detector ``model`` run on every frame; ``"auto"``: the file
        when the sequence has one, the model otherwise (a plain video).
    file
        A detections file (MOTChallenge ``det.txt`` layout) used instead of
        the sequence's ``det/det.txt``, e.g. the ``<name>.det.txt`` an earlier
        model run wrote; for a run of one sequence.
    model
        The detector: an OpenVINO IR ``.xml`` (its ``.bin`` beside it) of an
        SSD-style person detector such as Intel's person-detection-0202.
        ``None`` reads the environment variable ``SOTMOT_DETECTOR_MODEL``, else
        runs the bundled person-detection-0202 FP16-INT8 (``sotmot models``).
    backend
        The runtime that runs ``model`` (``sotmot.plugins.DETECTORS``).
    min_score
        Boxes the detector scores below this never leave it. Low on purpose:
        confirmation (``[confirm]``) decides which boxes are kept. 0.4 for
        person-detection-0202, fitted leave-one-video-out with its confirmation
        model (``scripts/fit_detector_confidence.py``): 0.4 in two folds of
        three; on all three videos mean HOTA 68.20 / 68.19 / 67.60 at 0.3 /
        0.4 / 0.5, a tie with 0.3, kept at 0.4 (fewer boxes to embed, and the
        end extension's weak boxes, those below it, were fitted with 0.4).
    input_height, input_width
        The network's input size in pixels (multiples of 32); 0 keeps the
        frame's aspect ratio at the area of 512 x 672 (448 x 768 for 16:9,
        512 x 672 for 4:3).
    threads
        CPU threads of the detector (0: the runtime's choice; with
        ``--workers N``: each process's share of the cores).
    """

    source: Literal["auto", "file", "model"] = "auto"
    file: str | None = None
    model: str | None = None
    backend: str = "openvino"
    min_score: float = 0.4
    input_height: int = 0
    input_width: int = 0
    threads: int = 0

    def __post_init__(self) -> None:
        _check(self.source in ("auto", "file", "model"), "detection",
               f"source must be one of auto, file, model; got {self.source!r}")
        _check(self.backend in DETECTORS, "detection",
               f"backend must be one of {', '.join(sorted(DETECTORS))}; got {self.backend!r}")
        _check(0.0 <= self.min_score <= 1.0, "detection", "min_score must be in [0, 1]")
        for name in ("input_height", "input_width"):
            value = getattr(self, name)
            _check(value == 0 or (32 <= value <= 4096 and value % 32 == 0), "detection",
                   f"{name} must be 0 (automatic) or a multiple of 32 from 32 to 4096")
        _check((self.input_height == 0) == (self.input_width == 0), "detection",
               "input_height and input_width are given together, or both 0")
        _check(0 <= self.threads <= 1024, "detection", "threads must be between 0 and 1024")


#: The names ``[preprocess] confidence`` accepts: the one list (``sotmot.confidence.maps.METHODS`` and the command
#: line's choices read it). After the four methods, the detector families with a stored calibration.
ConfidenceMethod = Literal["auto", "raw", "quantile", "self", "dpm", "acf", "frcnn", "sdp", "pd0202"]


@dataclass(frozen=True)
class PreprocessConfig:
    """Detection cleaning before tracking (paper Sec. 6.1).

    Attributes
    ----------
    score_threshold
        Boxes with a score below this are dropped; ``None`` keeps all. Scores
        keep the detector's own range (public DPM scores run from about -1 to 2).
    nms
        ``"iou"``, ``"iom"`` (intersection over the smaller box), ``"none"``, or
        ``"auto"``: IoM for detections whose scores are not probabilities (any
        score outside [0, 1], as with the public DPM detections; the paper uses
        NMS-IoM 0.6 there), IoU otherwise.
    nms_threshold
        Overlap above which the lower-scoring box is suppressed (paper: 0.6).
    confidence
        How detector scores become confidences in [0, 1] (``sotmot.confidence``):
        ``"dpm"``, ``"acf"``, ``"frcnn"``, ``"sdp"`` (a monotone map per detector
        family, fitted once on training sequences and stored with the package),
        ``"pd0202"`` (the built-in detector, person-detection-0202),
        ``"quantile"`` (the score's rank within the sequence), ``"raw"`` (scores
        clipped to [0, 1]), ``"self"`` (a map fitted on the sequence itself from
        what association made of it: detections of long trajectories against
        lone ones; for a detector none of the families fits) or ``"auto"``: pd0202 for the built-in detector's
        boxes (run now, or a detections file whose first line names it, as the
        ``<name>.det.txt`` of a model run does), else the family the sequence's name ends with (MOTChallenge's
        ``-DPM``, ``-FRCNN``, ``-SDP``), else the family guessed from the score
        range (all in [0, 1] frcnn, any above 10 acf, else dpm).
    """

    score_threshold: float | None = None
    nms: Literal["auto", "iou", "iom", "none"] = "auto"
    nms_threshold: float = 0.6
    confidence: ConfidenceMethod = "auto"

    def __post_init__(self) -> None:
        _check(self.nms in ("auto", "iou", "iom", "none"), "preprocess",
               f"nms must be one of auto, iou, iom, none; got {self.nms!r}")
        _check(0.0 < self.nms_threshold <= 1.0, "preprocess", "nms_threshold must be in (0, 1]")
        methods = typing.get_args(typing.get_type_hints(PreprocessConfig)["confidence"])
        _check(self.confidence in methods, "preprocess",
               f"confidence must be one of {', '.join(methods)}; got {self.confidence!r}")


@dataclass(frozen=True)
class AppearanceConfig:
    """The appearance model (paper Sec. 4 and eq. 1).

    Attributes
    ----------
    backend
        ``"auto"`` (default): ``"openvino"`` where the OpenVINO runtime is
        installed and the device is the CPU, else ``"onnx"``
        (:func:`sotmot.appearance.resolve_backend`; the run record holds the
        one that ran). Or a name in ``sotmot.plugins.BACKENDS``: ``"onnx"``, a
        person re-ID network run with onnxruntime; ``"torch"``:
        the same network executed by torch, weights read from the ONNX file
        (needs the ``torch`` extra: ``torch==2.13.0`` and ``onnx``);
        ``"openvino"``: the same ONNX file (or an OpenVINO IR ``.xml``) run by
        the OpenVINO runtime on the CPU, about twice as fast as onnxruntime here
        with the same tracking scores (within 0.1 HOTA and IDF1 on each
        full-length sequence; needs the ``openvino`` extra); ``"none"``: no
        re-ID at all, the **motion-only mode** (``sotmot.appearance.none``): no
        model and no frame read for appearance (a folder of detections and
        ground truth without ``img1/`` is tracked), tracklets matched by IoU,
        long-term links ranked and gated by how well the two trajectories'
        motion agrees (``sotmot.association.affinity``), confirmation without
        its appearance feature; no SOT step, no end extension. Several times
        faster, and what ``scripts/bench_validation.py`` tracks label-only
        sequences with. On the five full-length sequences with frames it
        trails re-ID by 18 HOTA combined (45.1 against 63.4; docs/benchmarks.md).
        Its gaps: the label sets prefer ``l_max_seconds = 2`` with
        ``interpolate_max_seconds = 2`` (``docs/validation/gap2s.toml``: HOTA
        +1.0, MOTA +3.3 combined), a recommendation, not a default.
    model
        Path to the ONNX re-ID model (N x 3 x 256 x 128 BGR input, e.g. Intel's
        person-reidentification-retail-0288). ``None`` reads the environment
        variable ``SOTMOT_REID_MODEL``, else runs the bundled
        person-reidentification-retail-0288 (``sotmot models``).
    flip
        Average the features of the crop and its mirror image (paper eq. 1).
        Off halves the re-ID work, but the association gates and the
        confirmation were chosen with flip-averaged features: without it some
        sequences lose HOTA and MOTA (docs/benchmarks.md, "Speed").
    batch_size
        Crops per forward pass (a flipped crop counts as one).
    threads
        Inference threads of the re-ID runtime (OpenVINO, onnxruntime or
        torch); 0 lets the runtime choose (with ``--workers N``: each
        process's share of the cores).
    device
        ``"cpu"`` or ``"cuda"`` (onnxruntime's CUDA provider, or torch on the GPU);
        asking for ``"cuda"`` where there is none is an error, never a silent fallback.
    weights
        ``torch`` backend: a checkpoint from ``sotmot train-appearance`` whose
        weights replace the ONNX file's (the file still gives the network).
    """

    backend: str = "auto"
    model: str | None = None
    flip: bool = True
    batch_size: int = 64
    threads: int = 0
    device: Literal["cpu", "cuda"] = "cpu"
    weights: str | None = None

    def __post_init__(self) -> None:
        _check(self.weights is None or self.backend == "torch", "appearance",
               "weights (a fine-tuned checkpoint) need backend = 'torch'")
        _check(self.backend in BACKENDS or self.backend == "auto", "appearance",
               f"backend must be 'auto' or one of {', '.join(sorted(BACKENDS))}; got {self.backend!r}")
        _check(self.device in ("cpu", "cuda"), "appearance", f"device must be 'cpu' or 'cuda'; got {self.device!r}")
        _check(1 <= self.batch_size <= 4096, "appearance", "batch_size must be between 1 and 4096 crops")
        _check(0 <= self.threads <= 1024, "appearance", "threads must be between 0 and 1024")


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


@dataclass(frozen=True)
class TrackletConfig:
    """Short tracklets by frame-by-frame Hungarian matching (paper Sec. 3.4).

    Attributes
    ----------
    batch_seconds
        Length of a batch in seconds (paper: 1 s); frames per batch are
        ``round(batch_seconds * frameRate)``, at least 1.
    tail
        The affinity of a detection to a tracklet uses the mean feature of the
        tracklet's last ``tail`` detections (paper: 5).
    min_affinity
        Matches with a lower appearance affinity are not linked. The paper
        leaves this gate implicit; 0.45 lies between the balanced thresholds
        of the re-ID model 0288 on PETS09-S2L1 (0.44) and MOT16-04-clip30 (0.50)
        (docs/calibration.md).
    min_iou
        Matches whose IoU with the tracklet's last box is lower are not linked.
        Our addition (the paper matches on appearance alone): it keeps two
        similar-looking people far apart from being linked inside one second.
    l_min
        Tracklets with <= l_min boxes are dropped (paper: 1). Only detector
        boxes count: without this, one false detection that the SOT step
        extended over 15 frames would survive as a tracklet.
    predict
        Compare a detection with the tracklet's last box moved on by its
        constant velocity (over its last ``tail`` boxes), not with the last box
        itself, in the IoU gate (and, motion only, the IoU that weights the
        match). False (default): the last box, as before.
    """

    batch_seconds: float = 1.0
    tail: int = 5
    min_affinity: float = 0.45
    min_iou: float = 0.2
    l_min: int = 1
    predict: bool = False

    def __post_init__(self) -> None:
        _check(0 < self.batch_seconds <= 60, "tracklets", "batch_seconds must be in (0, 60]")
        _check(1 <= self.tail <= 1000, "tracklets", "tail must be between 1 and 1000")
        _check(0.0 <= self.min_affinity <= 1.0, "tracklets", "min_affinity must be in [0, 1]")
        _check(0.0 <= self.min_iou <= 1.0, "tracklets", "min_iou must be in [0, 1]")
        _check(0 <= self.l_min <= 1000, "tracklets", "l_min must be between 0 and 1000")


@dataclass(frozen=True)
class AssociationConfig:
    """Long-term association constraints A(t1, t2) (paper Sec. 3.4).

    Attributes
    ----------
    tau_iou
        On every temporally overlapping segment of two trajectories the mean
        IoU of their boxes must be strictly greater than this (paper: 0.5).
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
        per frame (linear motion).
    short_gap
        Longest gap that counts as short (paper: 5).
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
        MOT16-04-clip30 (0.50) (docs/calibration.md).
    long_gap_affinity
        A bridge must be more certain the longer it is: the affinity a link
        needs rises linearly from ``min_affinity`` at a gap of half ``l_max``
        to this at ``l_max`` (the gap the merge creates or changes, the
        velocity rule's); ``None`` (default): ``min_affinity`` at every gap.
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
        """This configuration for a sequence of ``frame_rate`` frames per second, its gap limit in frames:
        ``l_max`` from ``l_max_seconds`` (at least 1 frame) and ``l_max_seconds`` None, so that a solver
        may narrow ``l_max`` further. Unchanged without ``l_max_seconds``; without a frame rate, ``l_max``
        frames."""
        if self.l_max_seconds is None:
            return self
        if not frame_rate:
            return dataclasses.replace(self, l_max_seconds=None)
        return dataclasses.replace(self, l_max=max(1, int(round(self.l_max_seconds * frame_rate))),
                                   l_max_seconds=None)


@dataclass(frozen=True)
class PostprocessConfig:
    """Interpolation and smoothing of the final trajectories (paper Sec. 3.5).

    Attributes
    ----------
    interpolate
        Fill every gap inside a trajectory by linear interpolation.
    smooth_window
        Each box becomes the mean of the trajectory's boxes within
        ``+- smooth_window`` frames (paper: 3); 0 turns smoothing off.
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
    check_seconds, min_agreement
        Interpolation that checks its line: a gap longer than
        ``check_seconds`` (and at most ``interpolate_max_seconds``) is filled
        only where the straight line agrees with how the person moved on both
        sides of it, a motion agreement
        (:func:`sotmot.boxes.motion_agreement`, up to 10 boxes
        each side) of at least ``min_agreement``; shorter gaps are filled on
        trust. ``None`` (default): every gap up to the bound is filled.
    """

    interpolate: bool = True
    smooth_window: int = 3
    min_length: int = 1
    interpolate_max_seconds: float | None = 4.0
    check_seconds: float | None = None
    min_agreement: float = 0.5

    def __post_init__(self) -> None:
        _check(0 <= self.smooth_window <= 1000, "postprocess", "smooth_window must be between 0 and 1000")
        _check(1 <= self.min_length <= 1_000_000, "postprocess", "min_length must be between 1 and 1,000,000")
        _check(self.interpolate_max_seconds is None or 0 < self.interpolate_max_seconds <= 3600, "postprocess",
               "interpolate_max_seconds must be in (0, 3600] (or absent to fill every gap)")
        _check(self.check_seconds is None or 0 <= self.check_seconds <= 3600, "postprocess",
               "check_seconds must be in [0, 3600] (or absent to fill every gap on trust)")
        _check(0.0 <= self.min_agreement <= 1.0, "postprocess", "min_agreement must be in [0, 1]")


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
        Run the confirmation stage (False writes every box, as before).
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


@dataclass(frozen=True)
class TrackerConfig:
    """The whole tracker: one section per stage."""

    input: InputConfig = field(default_factory=InputConfig)
    detection: DetectionConfig = field(default_factory=DetectionConfig)
    preprocess: PreprocessConfig = field(default_factory=PreprocessConfig)
    appearance: AppearanceConfig = field(default_factory=AppearanceConfig)
    sot: SotConfig = field(default_factory=SotConfig)
    tracklets: TrackletConfig = field(default_factory=TrackletConfig)
    association: AssociationConfig = field(default_factory=AssociationConfig)
    postprocess: PostprocessConfig = field(default_factory=PostprocessConfig)
    confirm: ConfirmConfig = field(default_factory=ConfirmConfig)
    motion: MotionConfig = field(default_factory=MotionConfig)
    windows: WindowConfig = field(default_factory=WindowConfig)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain nested dict, the same layout a config file uses."""
        return dataclasses.asdict(self)

    def replace(self, section: str, **changes: Any) -> "TrackerConfig":
        """A copy with some fields of one section changed (validated)."""
        if section not in SECTIONS:
            raise ConfigError(f"unknown section {section!r}; valid: {', '.join(SECTIONS)}")
        current = dataclasses.asdict(getattr(self, section))
        return dataclasses.replace(self, **{section: _build(section, {**current, **_in_frames(section, changes),
                                                                      **changes})})


SECTIONS: dict[str, type] = {
    "input": InputConfig,
    "detection": DetectionConfig,
    "preprocess": PreprocessConfig,
    "appearance": AppearanceConfig,
    "sot": SotConfig,
    "tracklets": TrackletConfig,
    "association": AssociationConfig,
    "postprocess": PostprocessConfig,
    "confirm": ConfirmConfig,
    "motion": MotionConfig,
    "windows": WindowConfig,
}


def field_docs(cls: type) -> dict[str, str]:
    """Field name -> its description, from the numpy-style ``Attributes`` section of a section's docstring: what
    docs/configuration.md and the command line's help both say of it."""
    lines = inspect.getdoc(cls).splitlines()
    docs: dict[str, str] = {}
    names: list[str] = []
    for line in lines[lines.index("Attributes") + 2:]:
        if line and not line.startswith(" "):
            names = [n.strip() for n in line.split(",")]
            docs.update((n, "") for n in names)
        elif line.strip():
            for n in names:
                docs[n] = (docs[n] + " " + line.strip()).strip()
    return docs


def _coerce(section: str, name: str, hint: Any, value: Any) -> Any:
    """Check ``value`` against the field's type hint; ints are accepted for floats."""
    args = typing.get_args(hint)
    origin = typing.get_origin(hint)
    if origin in (typing.Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        inner = [a for a in args if a is not type(None)]
        return _coerce(section, name, inner[0], value)
    if origin is Literal:
        if value not in args:
            raise ConfigError(f"[{section}] {name} must be one of {', '.join(map(repr, args))}; got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"[{section}] {name} must be a list; got {value!r}")
        return tuple(_coerce(section, name, args[0], v) for v in value)
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ConfigError(f"[{section}] {name} must be a finite number; got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"[{section}] {name} must be an integer; got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"[{section}] {name} must be true or false; got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"[{section}] {name} must be a string; got {value!r}")
        return value
    return value


def _in_frames(section: str, given: dict[str, Any]) -> dict[str, Any]:
    """What ``given`` (the fields a file or a caller sets) implies beyond itself: a gap limit given as ``l_max``
    alone is counted in frames, so ``l_max_seconds`` (set by default) is cleared."""
    if section == "association" and "l_max" in given and "l_max_seconds" not in given:
        return {"l_max_seconds": None}
    return {}


def _build(section: str, values: dict[str, Any]) -> Any:
    cls = SECTIONS[section]
    hints = typing.get_type_hints(cls)
    names = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise ConfigError(f"[{section}] unknown key(s) {', '.join(unknown)}; valid keys: {', '.join(names)}")
    values = {**values, **_in_frames(section, values)}
    return cls(**{k: _coerce(section, k, hints[k], v) for k, v in values.items()})


def config_from_dict(data: dict[str, Any]) -> TrackerConfig:
    """Build a :class:`TrackerConfig` from nested dicts, rejecting unknown sections and keys."""
    if not isinstance(data, dict):
        raise ConfigError("a configuration must be a table of sections")
    loose = sorted(key for key, value in data.items() if not isinstance(value, dict))
    if loose:  # `l_max = 30` above every [table] of a TOML file
        raise ConfigError(f"key(s) {', '.join(loose)} outside any [section]: every key belongs to the table of its "
                          f"stage, e.g. [association] l_max_seconds = 3; sections: {', '.join(SECTIONS)}")
    unknown = sorted(set(data) - set(SECTIONS))
    if unknown:
        raise ConfigError(f"unknown section(s) {', '.join(unknown)}; valid sections: {', '.join(SECTIONS)}")
    parts = {}
    for section, values in data.items():
        if not isinstance(values, dict):
            raise ConfigError(f"[{section}] must be a table of keys")
        parts[section] = _build(section, values)
    return TrackerConfig(**parts)


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    """A JSON object as a dict; a key given twice is an error (TOML refuses it too), never last-wins."""
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ConfigError(f"key {key!r} is given twice")
        out[key] = value
    return out


def load_config(path: str | Path) -> TrackerConfig:
    """Read a TOML (``.toml``) or JSON (``.json``) configuration file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(f"{path}: configuration file not found")
    try:
        if path.suffix == ".json":
            data = json.loads(path.read_text(encoding="utf-8-sig"), object_pairs_hook=_unique_keys)
        elif path.suffix == ".toml":
            data = tomllib.loads(path.read_text(encoding="utf-8-sig"))
        else:
            raise ConfigError("configuration must be a .toml or .json file")
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ConfigError(f"{path}: cannot be parsed: {exc}") from exc
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not UTF-8 text (byte {exc.start}); save it as UTF-8") from exc
    try:
        return config_from_dict(data)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
