"""Configuration of where the boxes and their appearance come from: the video, the detector, cleaning, re-ID."""

from __future__ import annotations

import typing
from dataclasses import dataclass
from typing import Literal

from sotmot.config.common import MAX_FRAME_RATE, _check
from sotmot.plugins import BACKENDS, DETECTORS

#: The longest ``[input] step``: beyond it the frames between two tracked ones are too far apart for a line.
MAX_STEP = 10


@dataclass(frozen=True)
class InputConfig:
    """How a video file or a folder of images is read (a MOTChallenge folder's ``seqinfo.ini`` says all of it).

    Attributes
    ----------
    fps
        Frame rate of a video or of a folder of images without a
        ``seqinfo.ini`` (``--fps``): every stage counts time in frames from it;
        None takes the video container's (a folder of images needs it).
    step
        Track every ``step``-th frame (``--step``): frames 1, 1 + step, ...
        are tracked as a sequence of their own at the frame rate divided by
        ``step``, and the frames between get their tracks' boxes by a straight
        line between the tracked frames around them (flagged interpolated).
        About ``step`` times faster: on two cores a 30-fps 1080p camera stays
        live at 2 with 30-s windows, at 3 with 10-s ones (docs/benchmarks.md,
        "A live source"). At 2 the 30-fps video loses 1.4-1.9 HOTA from its public
        detections and gains 0.7 from the built-in detector's
        (docs/results.md, "Tracking every k-th frame"). A detections file's
        rows of the frames between are not used; the frames after the last
        tracked one (fewer than ``step``) hold its boxes. 1: every frame.
        With ``[windows]`` the windows are of the tracked frames, their
        seconds the same.
    """

    fps: float | None = None
    step: int = 1

    def __post_init__(self) -> None:
        _check(self.fps is None or 0 < self.fps <= MAX_FRAME_RATE, "input",
               f"fps must be a frame rate above 0 and at most {MAX_FRAME_RATE:g} per second")
        _check(isinstance(self.step, int) and not isinstance(self.step, bool) and 1 <= self.step <= MAX_STEP,
               "input", f"step must be a whole number of frames from 1 (every frame) to {MAX_STEP}")


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
        Boxes the detector scores below this never leave it. 0.4 for
        person-detection-0202, fitted leave-one-out on eight scenes (three
        videos, five MOT16 clips) with its confirmation model
        (``scripts/fit_detector_confidence.py``): 0.4 in seven folds of
        eight; on all eight mean HOTA 58.75 / 59.15 / 58.34 at 0.3 / 0.4 /
        0.5. Since that fit's confirmation drops nothing (``[confirm]``), this
        is the one filter of the detector's boxes; the end extension's weak
        boxes are those below it.
    input_height, input_width
        The network's input size in pixels (multiples of 32); 0 keeps the
        frame's aspect ratio at the area of 512 x 672 (448 x 768 for 16:9,
        512 x 672 for 4:3), or, for frames that would be shrunk more than 2x
        to it, the frame shrunk 2x, up to 1.5x those sides: 544 x 960 for
        1080p, whose far people 448 x 768 left unfound (MOT16-09 with the
        detector and the confirmation of then: HOTA / MOTA / IDF1 65.1 / 77.7
        / 83.9 -> 68.6 / 82.3 / 89.3; the 1080p clips +2.8 to +5.9 HOTA), for
        about 1.5x the detector's time. ``input_height = 448``,
        ``input_width = 768`` is the faster choice for 1080p.
    threads
        CPU threads of the detector (0: the runtime's choice; with
        ``--workers N``: each process's share of the cores).
    weak_boxes
        The detector's weak boxes (scoring from 0.1 up to ``min_score``; never
        tracked themselves) as evidence after tracking: ``"on"``: every box SOT
        finds (Algorithm 1) is checked by them (a found box that
        overlaps a weak box at IoU 0.5 or more is replaced by it, the paper's box
        regression on SOT results; in Algorithm 1 an unsupported candidate ends
        its extension), and trajectory ends (``[ends]``) grow by weak boxes
        instead of SOT. Only trajectories that exist are extended, so tracks
        still start from the detections tracked (MOTChallenge's public rule
        holds with public detections: "public, refined"). ``"off"``: none.
        ``"auto"`` (default): ``"on"`` when the detections come from the
        detector (``source``; its weak boxes come from the same pass over the
        frames, or a replayed ``<name>.det.txt`` of the same detector),
        ``"off"`` for other detections files, so a public run is refined only
        when asked.
    """

    source: Literal["auto", "file", "model"] = "auto"
    file: str | None = None
    model: str | None = None
    backend: str = "openvino"
    min_score: float = 0.4
    input_height: int = 0
    input_width: int = 0
    threads: int = 0
    weak_boxes: Literal["auto", "on", "off"] = "auto"

    def __post_init__(self) -> None:
        _check(self.source in ("auto", "file", "model"), "detection",
               f"source must be one of auto, file, model; got {self.source!r}")
        _check(self.weak_boxes in ("auto", "on", "off"), "detection",
               f"weak_boxes must be one of auto, on, off; got {self.weak_boxes!r}")
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
        0.5 and 0.7 cost TUD-Stadtmitte's ACF boxes 5.9 and 24.7 MOTA on the
        validation set and change nothing from the built-in detector's boxes
        (docs/benchmarks.md, "Four of the paper's constants").
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
    mask
        An image the size of the frames (PNG or any format OpenCV reads), white where people are tracked and
        black where detections are ignored: a detection whose foot point (the middle of its bottom edge) lies on
        a dark pixel (below 128) is dropped before anything else, and so is such a weak box of the detector. For
        what the detector takes for a person and never is: a poster, a mannequin, a reflection, a screen, the
        bonnet of the vehicle that carries the camera. A person in front of an ignored poster stands below it and
        is kept; tracks are still followed through the region (interpolation, SOT). In the frame's pixels: with a
        moving camera it covers part of the image, not of the scene. ``None``: every detection is kept.
    """

    score_threshold: float | None = None
    nms: Literal["auto", "iou", "iom", "none"] = "auto"
    nms_threshold: float = 0.6
    confidence: ConfidenceMethod = "auto"
    mask: str | None = None

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
        (in float32, as ``precision`` says); ``"none"``: no
        re-ID at all, the **motion-only mode** (``sotmot.appearance.none``): no
        model and no frame read for appearance (a folder of detections and
        ground truth without ``img1/`` is tracked), tracklets matched by IoU,
        long-term links ranked and gated by how well the two trajectories'
        motion agrees (``sotmot.association.affinity``), confirmation without
        its appearance feature; no SOT step, no end extension. Several times
        faster with a ``det.txt``, about twice as fast with the built-in
        detector (which then does most of the work: MOT16-09's 1080p frames
        at 48.2 against 25.8 frames/s on two cores), and what
        ``scripts/bench_validation.py`` tracks label-only sequences with;
        ahead of SORT, ByteTrack and OC-SORT there (combined HOTA 48.0
        against at most 44.3). Where frames exist it trails re-ID by 6 to 25
        HOTA on each full-length sequence (docs/results.md, "Without
        re-ID"). Where the camera moves,
        nothing compensates it here (no frames): the line check
        (``[postprocess] line_check_seconds``) fills gaps only as far as the
        straight line holds on the sequence.
    model
        Path to the ONNX re-ID model (N x 3 x 256 x 128 BGR input, e.g. Intel's
        person-reidentification-retail-0288). ``None`` reads the environment
        variable ``SOTMOT_REID_MODEL``, else runs the bundled
        person-reidentification-retail-0288 (``sotmot models``). The larger
        person-reidentification-retail-0277 (8.6 MB, not bundled; give its
        path) tracks better on average with every gate as it is, at 2.2-2.5
        times the whole run's time: on the validation set's 13 sequences with
        frames +0.75 HOTA / +1.44 IDF1 from public detections and +0.53 / +0.71
        from the built-in detector's boxes, the MOT16-09 video gaining most and
        TUD-Stadtmitte at 8 fps losing 3.6 MOTA from the detector's boxes, and
        the vehicle clip MOT16-13 1.7 HOTA from its public ones
        (docs/benchmarks.md, "Re-ID").
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
    precision
        The arithmetic of the OpenVINO backend: ``"f32"`` (default), float32 on
        every CPU, so one sequence gives the same features, and the same tracks,
        on any x86 machine; ``"fast"``, what OpenVINO runs fastest on this CPU
        (bf16 where it has AMX or AVX-512 BF16, float32 elsewhere): faster
        there, with features that differ in the third decimal of their cosine,
        and tracks that differ with them. The run record says which ran
        (``reid_precision``). onnxruntime and torch compute in float32; the
        built-in detector always runs in float32.
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
    precision: Literal["f32", "fast"] = "f32"
    device: Literal["cpu", "cuda"] = "cpu"
    weights: str | None = None

    def __post_init__(self) -> None:
        _check(self.weights is None or self.backend == "torch", "appearance",
               "weights (a fine-tuned checkpoint) need backend = 'torch'")
        _check(self.backend in BACKENDS or self.backend == "auto", "appearance",
               f"backend must be 'auto' or one of {', '.join(sorted(BACKENDS))}; got {self.backend!r}")
        _check(self.device in ("cpu", "cuda"), "appearance", f"device must be 'cpu' or 'cuda'; got {self.device!r}")
        _check(self.precision in ("f32", "fast"), "appearance",
               f"precision must be 'f32' or 'fast'; got {self.precision!r}")
        _check(1 <= self.batch_size <= 4096, "appearance", "batch_size must be between 1 and 4096 crops")
        _check(0 <= self.threads <= 1024, "appearance", "threads must be between 0 and 1024")
