"""Camera motion: one estimate per sequence, and one reference frame for every comparison of positions.

A moving camera moves every box in the image, so boxes of one person in two
frames stop overlapping and their speeds look large: the tracklet IoU, the
association rules (IoU, velocity, gap) and interpolation all judge image
positions. :func:`estimate_motion` measures the global motion between
consecutive frames (FAST corners tracked by pyramidal Lucas-Kanade on grey frames
decoded small, the detections masked out, a similarity model fitted by
RANSAC); :class:`CameraMotion` composes the pair estimates into a transform
from each frame to the first (the reference) and maps boxes into it and back.
The pipeline builds tracklets, associates and interpolates in the reference
frame and writes results in each frame's own pixels. Every rule that compares
positions (IoU, speeds against the boxes' width, the interpolated line) is
unchanged by a change of scale and offset (and nearly so by a camera's small
rotations: boxes stay upright), so two frames compared in frame 1's pixels are
compared as in either frame's own, however far the camera has moved in
between (a test tracks a sequence in a reference of another scale and offset).

``[motion] compensation = "auto"`` first looks at pairs of frames half a
second apart; when none moved more than ``still_pixels`` the camera is still,
nothing else is computed and nothing changes (results are byte-identical to
``"off"``).

Boxes are ``x, y, w, h`` pixels, frames 1-based.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from sotmot.boxes import centers, cxcywh_to_xywh
from sotmot.config import MotionConfig
from sotmot.io.frames import FrameSource, frame_source, grey_reduced
from sotmot.io.mot import SeqInfo
from sotmot.progress import Progress, as_progress
from sotmot.types import Detections

log = logging.getLogger(__name__)

#: Corners tracked per frame pair, and the fewest RANSAC inliers an estimate needs to be trusted.
MAX_CORNERS = 240
MIN_INLIERS = 20
#: The still check reads frames at least this wide (a 1080p frame at 1/8): it only asks whether the camera moved
#: pixels, not by how much to a tenth of one.
STILL_CHECK_WIDTH = 160
#: The most frame pairs the still check compares in a video: past 50 s (at any rate) it looks at this many places
#: spread over it instead of every half second, so an hour of video is not decoded twice (each place costs a
#: seek, about 0.17 s at 1080p: 17 s for any length).
STILL_CHECK_PAIRS = 100
#: RANSAC's inlier distance, in pixels of the full-size frame.
RANSAC_PIXELS = 1.5


def reduce_factor(width: int, target: int = 320) -> int:
    """The largest of 1, 2, 4, 8 that keeps a frame ``width`` pixels wide at least ``target`` wide after reduction
    (a 1080p frame is read at 1/4: 480 px)."""
    factor = 1
    while factor < 8 and width // (factor * 2) >= target:
        factor *= 2
    return factor


def _identity() -> np.ndarray:
    return np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The 2x3 affine transform ``a o b`` (``b`` first)."""
    return np.hstack([a[:, :2] @ b[:, :2], (a[:, :2] @ b[:, 2] + a[:, 2])[:, None]])


def invert(a: np.ndarray) -> np.ndarray:
    """The inverse of a 2x3 affine transform."""
    inv = np.linalg.inv(a[:, :2])
    return np.hstack([inv, (-inv @ a[:, 2])[:, None]])


def warp_boxes(transforms: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """Boxes ``(N, 4)`` moved by one 2x3 transform each ``(N, 2, 3)``: the centre mapped, width and height scaled
    by the transform's scale (a box stays upright; the small rotations of a camera are left out)."""
    if not len(boxes):
        return np.asarray(boxes, dtype=np.float64).reshape(0, 4)
    c = centers(boxes)
    mapped = np.einsum("nij,nj->ni", transforms[:, :, :2], c) + transforms[:, :, 2]
    scale = np.sqrt(np.abs(np.linalg.det(transforms[:, :, :2])))
    wh = boxes[:, 2:] * scale[:, None]
    return cxcywh_to_xywh(np.hstack([mapped, wh]))


@dataclass(frozen=True, eq=False)
class CameraMotion:
    """The camera's motion over a sequence, as transforms from each frame to the reference (frame 1).

    Attributes
    ----------
    to_reference
        ``(L + 1, 2, 3)``: row ``f`` maps pixel coordinates of frame ``f`` to
        those of frame 1 (row 0 is unused).
    pair
        ``(L + 1, 2, 3)``: row ``f`` maps frame ``f`` to frame ``f - 1``, as
        estimated (row 0 and 1: identity).
    confidence
        ``(L + 1,)``: the share of tracked corners that agreed with row
        ``f`` of ``pair`` (0 where the estimate fell back to the identity).
    moving
        False when the camera was found still: every transform is the identity
        and the pipeline changes nothing.
    """

    to_reference: np.ndarray
    pair: np.ndarray
    confidence: np.ndarray
    moving: bool

    @classmethod
    def still(cls, length: int) -> "CameraMotion":
        """A still camera over ``length`` frames."""
        eye = np.tile(_identity(), (length + 1, 1, 1))
        return cls(eye, eye.copy(), np.ones(length + 1), False)

    @classmethod
    def from_pairs(cls, pair: np.ndarray, confidence: np.ndarray) -> "CameraMotion":
        """Compose pair estimates (row ``f``: frame ``f`` -> ``f - 1``) into transforms to frame 1. Where no pair
        could be estimated (frames without corners: every transform the identity) the camera is not said to
        move: it is still, as far as anything here can tell, and nothing is compensated."""
        if not (np.asarray(confidence)[2:] > 0).any():
            return cls.still(len(pair) - 1)
        to_reference = np.empty_like(pair)
        to_reference[0] = to_reference[1] = _identity()
        for f in range(2, len(pair)):
            to_reference[f] = compose(to_reference[f - 1], pair[f])
        return cls(to_reference, pair, confidence, True)

    @property
    def length(self) -> int:
        return len(self.to_reference) - 1

    def to_ref(self, frames: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """``(N, 4)`` boxes of 1-based ``frames`` in the reference frame's pixels (a still camera: ``boxes``
        themselves, not a float round trip of them)."""
        if not self.moving:
            return boxes
        return warp_boxes(self.to_reference[np.asarray(frames, dtype=np.int64)], boxes)

    def from_ref(self, frames: np.ndarray, boxes: np.ndarray) -> np.ndarray:
        """``(N, 4)`` reference-frame boxes back in the pixels of their 1-based ``frames`` (a still camera:
        ``boxes`` themselves)."""
        if not self.moving:
            return boxes
        frames = np.asarray(frames, dtype=np.int64)
        unique, inverse = np.unique(frames, return_inverse=True)
        back = np.stack([invert(self.to_reference[f]) for f in unique]) if len(unique) else np.zeros((0, 2, 3))
        return warp_boxes(back[inverse], boxes)

    def box_to_ref(self, frame: int, box: np.ndarray) -> np.ndarray:
        """One ``(4,)`` box of 1-based ``frame`` in the reference frame's pixels (:meth:`to_ref`)."""
        return self.to_ref(np.array([frame]), box[None])[0]

    def box_from_ref(self, frame: int, box: np.ndarray) -> np.ndarray:
        """One ``(4,)`` reference-frame box back in the pixels of 1-based ``frame`` (:meth:`from_ref`)."""
        return self.from_ref(np.array([frame]), box[None])[0]

    def to_ref_detections(self, detections: Detections) -> Detections:
        """``detections`` with their boxes in the reference frame (scores and flags unchanged)."""
        if not self.moving:
            return detections
        return Detections(detections.frames, self.to_ref(detections.frames, detections.boxes), detections.scores,
                          detections.from_sot)

    def summary(self) -> dict[str, float | bool]:
        """The numbers a run record keeps: moving, the median and largest shift of the image origin from one
        frame to the next (pixels), and the share of frame pairs estimated."""
        shifts = np.hypot(self.pair[2:, 0, 2], self.pair[2:, 1, 2]) if self.length > 1 else np.zeros(1)
        estimated = float((self.confidence[2:] > 0).mean()) if self.length > 1 else 1.0
        return {"moving": self.moving, "median_shift_px": round(float(np.median(shifts)), 3),
                "max_shift_px": round(float(shifts.max()), 3), "estimated_share": round(estimated, 4)}


def _box_mask(shape: tuple[int, int], boxes: np.ndarray, factor: int) -> np.ndarray:
    """255 outside every box (full-size ``x, y, w, h``) on an image of ``shape`` read ``factor`` times smaller."""
    mask = np.full(shape, 255, np.uint8)
    for x, y, w, h in np.asarray(boxes) / factor:
        x0, y0 = max(int(np.floor(x)), 0), max(int(np.floor(y)), 0)
        x1, y1 = min(int(np.ceil(x + w)), shape[1]), min(int(np.ceil(y + h)), shape[0])
        if x1 > x0 and y1 > y0:
            mask[y0:y1, x0:x1] = 0
    return mask


def _corners(image: np.ndarray, mask: np.ndarray | None) -> np.ndarray:
    """Up to :data:`MAX_CORNERS` FAST corners ``(K, 1, 2)`` float32, the strongest of each cell of an 8 x 6 grid
    (spread over the frame, so no textured patch decides alone)."""
    import cv2

    keypoints = ()
    for threshold in (20, 8):  # a low-contrast frame: try again with a lower threshold
        keypoints = cv2.FastFeatureDetector_create(threshold, True).detect(image, mask)
        if len(keypoints) >= 4 * MIN_INLIERS:
            break
    if not keypoints:
        return np.zeros((0, 1, 2), np.float32)
    points = np.array([k.pt for k in keypoints], np.float32)
    response = np.array([k.response for k in keypoints])
    height, width = image.shape
    cell = (points[:, 1] * 6 // height).astype(np.int64) * 8 + (points[:, 0] * 8 // width).astype(np.int64)
    order = np.lexsort((-response, cell))
    rank = np.arange(len(order)) - np.searchsorted(cell[order], cell[order])
    keep = order[rank < -(-MAX_CORNERS // 48)]
    return points[keep].reshape(-1, 1, 2)


def _fit(previous: np.ndarray, current: np.ndarray, corners: np.ndarray, factor: int,
         shift: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Corners tracked from ``previous`` into ``current`` starting ``shift`` (reduced pixels) away, and the
    similarity RANSAC fits to them in full-size pixels; None when fewer than :data:`MIN_INLIERS` agree."""
    import cv2

    start = (corners + shift.astype(np.float32)).astype(np.float32)
    moved, ok, _ = cv2.calcOpticalFlowPyrLK(previous, current, corners, start, winSize=(15, 15), maxLevel=3,
                                            criteria=(cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 10, 0.03),
                                            flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
    good = ok[:, 0] == 1
    if good.sum() < MIN_INLIERS:
        return None
    # pixel i of a frame read at 1/factor covers full-size pixels factor*i .. factor*i + factor - 1
    src = moved[good, 0] * factor + (factor - 1) / 2
    dst = corners[good, 0] * factor + (factor - 1) / 2
    transform, inliers = cv2.estimateAffinePartial2D(src, dst, method=cv2.RANSAC,
                                                      ransacReprojThreshold=RANSAC_PIXELS, maxIters=2000,
                                                      confidence=0.995, refineIters=10)
    if transform is None or inliers is None or int(inliers.sum()) < MIN_INLIERS:
        return None
    return transform.astype(np.float64), float(inliers.sum()) / len(corners)


def estimate_pair(previous: np.ndarray, current: np.ndarray, factor: int = 1,
                  people: np.ndarray | None = None, guess: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """The similarity transform from ``current``'s pixels to ``previous``'s, and its confidence.

    Parameters
    ----------
    previous, current
        Grey frames read ``factor`` times smaller (see :meth:`FrameSource.read_grey`).
    factor
        The reduction; the transform is in full-size pixels.
    people
        ``(N, 4)`` full-size ``x, y, w, h`` boxes in ``previous`` to leave out
        (people move on their own).
    guess
        The previous pair's transform (a camera's motion changes little from
        one frame to the next): corners are first looked for where it puts
        them. When that fails, phase correlation of the two frames gives the
        start (a fast pan, a jolt).

    Returns
    -------
    transform, confidence
        2x3 affine transform, and the share of tracked corners RANSAC kept;
        the identity and 0.0 when fewer than :data:`MIN_INLIERS` agree.
    """
    import cv2

    mask = _box_mask(previous.shape, people, factor) if people is not None and len(people) else None
    corners = _corners(previous, mask)
    if len(corners) < MIN_INLIERS:
        return _identity(), 0.0
    start = np.zeros(2) if guess is None else -guess[:, 2] / factor
    fitted = _fit(previous, current, corners, factor, start)
    if fitted is None:
        (dx, dy), _ = cv2.phaseCorrelate(previous.astype(np.float32), current.astype(np.float32))
        if np.hypot(dx - start[0], dy - start[1]) > 0.5:
            fitted = _fit(previous, current, corners, factor, np.array([dx, dy]))
    return fitted if fitted is not None else (_identity(), 0.0)


def _corner_motion(transform: np.ndarray, width: int, height: int) -> float:
    """The farthest any corner of a ``width`` x ``height`` frame moves under ``transform`` (pixels)."""
    corners = np.array([[0, 0], [width, 0], [0, height], [width, height]], dtype=np.float64)
    return float(np.linalg.norm(corners @ transform[:, :2].T + transform[:, 2] - corners, axis=1).max())


def still_check_pairs(length: int, frame_rate: float, video: bool = False) -> list[tuple[int, int]]:
    """The frame pairs, half a second apart, that the still check compares: one chain through the whole
    sequence; for a ``video`` of more than :data:`STILL_CHECK_PAIRS` pairs, that many spread evenly over it
    (a JPEG frame is read on its own, a video's are decoded on the way to it)."""
    step = max(1, int(round(frame_rate / 2)))
    frames = list(range(1, length + 1, step))
    if frames[-1] != length:
        frames.append(length)
    pairs = list(zip(frames[:-1], frames[1:]))
    if not video or len(pairs) <= STILL_CHECK_PAIRS:
        return pairs
    starts = np.linspace(1, length - step, STILL_CHECK_PAIRS).round().astype(int)
    return [(int(a), int(a) + step) for a in starts]


def in_pass(info: SeqInfo, config: MotionConfig) -> bool:
    """Whether the pass that decodes every frame of ``info`` measures the camera too (:class:`PassMotion`):
    wherever ``[motion]`` looks at the camera and there are frames (a video, a folder of JPEGs, frames in
    memory). The estimate reads each frame as the full image made small (:func:`~sotmot.io.frames.grey_reduced`,
    for every source alike, so one sequence handed over any way gives one estimate), which the pass has decoded
    already; a decode of its own cost MOT16-09 1-2 s from its video."""
    if config.compensation == "off" or info.length < 2:
        return False
    return info.video is not None or info.frames is not None or info.frames_dir.is_dir()


def _moved(previous: np.ndarray, current: np.ndarray, factor: int, people: np.ndarray, info: SeqInfo,
           config: MotionConfig) -> bool:
    """Whether the camera moved more than ``still_pixels`` between two frames of the still check (read
    ``factor`` times smaller; ``people``: full-size boxes in ``previous``); an estimate that cannot be trusted
    counts as moving (the full estimate decides)."""
    transform, confidence = estimate_pair(previous, current, factor, people)
    return confidence == 0.0 or _corner_motion(transform, info.width, info.height) > config.still_pixels


def camera_is_still(source: FrameSource, info: SeqInfo, detections: Detections, config: MotionConfig,
                    seen: dict[int, np.ndarray] | None = None) -> bool:
    """True when frames half a second apart never moved more than ``still_pixels`` (:func:`still_check_pairs`).

    Costs one small grey decode per half second of a JPEG sequence; a video
    is decoded on the way (its frames between are grabbed), so a long one is
    looked at in :data:`STILL_CHECK_PAIRS` places only, and frames a pass kept
    already (``seen``: frame -> small grey image, :class:`PassMotion`) are not
    decoded again. A pair whose estimate cannot be trusted counts as moving
    (the full estimate decides).
    """
    factor = reduce_factor(info.width, STILL_CHECK_WIDTH)
    seen = {} if seen is None else seen
    by_frame = detections.by_frame()

    def read(f: int) -> np.ndarray:
        return seen.pop(f) if f in seen else source.read_grey(f, factor)

    grey: dict[int, np.ndarray] = {}
    for a, b in still_check_pairs(info.length, info.frame_rate, info.video is not None):
        previous = grey.pop(a) if a in grey else read(a)
        grey = {b: read(b)}  # a chain reads each frame once
        if _moved(previous, grey[b], factor, _people(detections, by_frame, a), info, config):
            return False
    return True


class _Chain:
    """The full estimate: every frame pair in order, each estimate started where the one before put the corners.

    Frames are added one after another from frame 1, small and grey (at
    :func:`reduce_factor` of the width), with the full-size boxes of the
    people in them; :meth:`motion` composes the pairs.
    """

    def __init__(self, info: SeqInfo, config: MotionConfig) -> None:
        self.factor = reduce_factor(info.width)
        self.min_confidence = config.min_confidence
        self.pair = np.tile(_identity(), (info.length + 1, 1, 1))
        self.confidence = np.zeros(info.length + 1)
        self.confidence[:2] = 1.0
        self.frame = 0  # the last frame added
        self._previous: tuple[np.ndarray, np.ndarray] | None = None  # its grey image and people

    def add(self, frame: int, grey: np.ndarray, people: np.ndarray) -> None:
        """Frame ``frame`` (the one after the last added), small and grey, and the people in it."""
        if self._previous is not None:
            previous, left_out = self._previous
            transform, share = estimate_pair(previous, grey, self.factor, left_out, guess=self.pair[frame - 1])
            if share >= self.min_confidence:
                self.pair[frame], self.confidence[frame] = transform, share
        self.frame, self._previous = frame, (grey, people)

    def motion(self) -> CameraMotion:
        return CameraMotion.from_pairs(self.pair, self.confidence)


def _people(detections: Detections, by_frame: dict[int, np.ndarray], frame: int) -> np.ndarray:
    """The boxes of ``detections`` in ``frame`` (``(N, 4)``, canonical order): the people left out of it."""
    return detections.boxes[by_frame.get(frame, np.zeros(0, np.int64))]


def _fold(digest, frame: int, people: np.ndarray) -> None:
    """Add a frame and the boxes the estimate was given for it to ``digest`` (the same boxes, the same bytes)."""
    digest.update(np.int64(frame).tobytes())
    digest.update(np.ascontiguousarray(people, dtype=np.float64).tobytes())


class PassMotion:
    """The camera's motion measured inside the pass that decodes every frame of a video (:func:`in_pass`), so
    the estimate decodes none again.

    The pass calls :meth:`see` with each frame in order, from frame 1: its
    decoded image and what the pass found in it, from which ``people`` gives
    the boxes the estimate leaves out (by default the boxes themselves; for a
    detector, the boxes preprocessing will keep). The still check's frames are
    kept small, and each of its pairs is judged once its second frame is seen,
    as :func:`camera_is_still` judges them. When the first pair moved (or
    from the start, with ``compensation = "on"``), every frame pair is
    estimated as the frame arrives, as :func:`estimate_motion` does after a
    pass; the frames up to that pair's second wait small and grey for it. A
    camera still at first and found moving later is measured after the pass,
    from a second decode.
    :meth:`outcome` hands :func:`estimate_motion` what was measured, provided
    the boxes left out were those of the detections the run goes on with.
    Called from one thread at a time (the pass's, then the caller's).
    """

    def __init__(self, info: SeqInfo, config: MotionConfig,
                 people: Callable[[int, object], np.ndarray] | None = None) -> None:
        self.info, self.config = info, config
        self._people = people if people is not None else (lambda frame, found: found)
        self._pairs = still_check_pairs(info.length, info.frame_rate, video=info.video is not None) \
            if config.compensation == "auto" else []
        self._check_factor = reduce_factor(info.width, STILL_CHECK_WIDTH)
        self._check_frames = {f for pair in self._pairs for f in pair}
        #: the still check's frames (small and grey) and their people, kept until their pairs are judged
        self.kept: dict[int, np.ndarray] = {}
        self._kept_people: dict[int, np.ndarray] = {}
        self._judged = 0  # pairs judged
        self._checked = hashlib.blake2b(digest_size=16)  # the people of each judged pair's first frame
        #: the verdict: True moving, False still, None not yet
        self.moving: bool | None = True if config.compensation == "on" else None
        self._chain = _Chain(info, config)
        self._chained = hashlib.blake2b(digest_size=16)  # the people of each frame added to the chain
        self._waiting: list[tuple[int, np.ndarray, np.ndarray]] | None = []  # None: not measured here
        self._last = 0  # the last frame seen

    def see(self, frame: int, image: np.ndarray, found: object) -> None:
        """Frame ``frame`` (the one after the last seen), decoded (BGR), and what the pass found in it."""
        if frame != self._last + 1:  # a frame skipped: nothing after it can be measured here
            self._waiting = None
            self._last = -1
            return
        self._last = frame
        checked = self.moving is None and frame in self._check_frames
        if not checked and self._waiting is None:
            return
        people = np.ascontiguousarray(self._people(frame, found), dtype=np.float64).reshape(-1, 4)
        if checked:
            self.kept[frame], self._kept_people[frame] = grey_reduced(image, self._check_factor), people
            self._judge(frame)
        if self._waiting is None:
            return
        if self._judged and not self.moving:  # still at the start: if it moves later, measured after the pass
            self._waiting = None
            return
        self._waiting.append((frame, grey_reduced(image, self._chain.factor), people))
        if self.moving:
            for waited in self._waiting:
                _fold(self._chained, waited[0], waited[2])
                self._chain.add(*waited)
            self._waiting.clear()

    def _judge(self, frame: int) -> None:
        """Judge the still check's pairs that end at ``frame``, in order, until one moved."""
        while self.moving is None and self._judged < len(self._pairs) and self._pairs[self._judged][1] <= frame:
            a, b = self._pairs[self._judged]
            self._judged += 1
            _fold(self._checked, a, self._kept_people[a])
            if _moved(self.kept[a], self.kept[b], self._check_factor, self._kept_people[a], self.info, self.config):
                self.moving = True
            for f in [f for f in self.kept if f < b]:  # frame b may begin the next pair
                del self.kept[f], self._kept_people[f]
        if self.moving is None and self._judged == len(self._pairs):
            self.moving = False

    def outcome(self, detections: Detections) -> "CameraMotion | bool | None":
        """What the pass measured, given the ``detections`` the run goes on with: the camera's motion (still or
        moving); True when the still check found it moving but the frames were not estimated here; None when
        nothing here holds (the boxes left out were not ``detections``' own, or no verdict)."""
        by_frame = detections.by_frame()
        checked = hashlib.blake2b(digest_size=16)
        for a, _ in self._pairs[:self._judged]:
            _fold(checked, a, _people(detections, by_frame, a))
        if self.moving is None or checked.digest() != self._checked.digest():
            return None
        if not self.moving:
            return CameraMotion.still(self.info.length)
        chained = hashlib.blake2b(digest_size=16)
        for f in range(1, self._chain.frame + 1):
            _fold(chained, f, _people(detections, by_frame, f))
        if self._chain.frame == self.info.length and chained.digest() == self._chained.digest():
            return self._chain.motion()
        return True


def estimate_motion(info: SeqInfo, detections: Detections, config: MotionConfig,
                    progress: "bool | Progress" = False, seen: PassMotion | None = None) -> CameraMotion:
    """The camera's motion over the sequence as ``[motion]`` asks (``compensation``: auto, on or off).

    ``detections`` (image pixels) are masked out of the frames. Off, auto on
    a still camera, or auto on a folder without frames (detections and ground
    truth only): :meth:`CameraMotion.still`. A frame pair whose
    estimate is not trusted (fewer than :data:`MIN_INLIERS` corners agree, or
    fewer than ``min_confidence`` of them) gets the identity. ``seen``: what
    the pass over a video measured already (:class:`PassMotion`); what it
    could not, is measured here.
    """
    if config.compensation == "off" or info.length < 2:
        return CameraMotion.still(info.length)
    if config.compensation == "auto" and info.video is None and info.frames is None and not info.frames_dir.is_dir():
        log.info("%s: no frames (%s missing): camera motion not estimated", info.name, info.frames_dir)
        return CameraMotion.still(info.length)
    known = seen.outcome(detections) if seen is not None else None
    if isinstance(known, CameraMotion):
        motion = known
    else:
        source = frame_source(info)
        try:
            if config.compensation == "auto" and known is None and \
                    camera_is_still(source, info, detections, config, seen.kept if seen is not None else None):
                motion = CameraMotion.still(info.length)
            else:
                chain = _Chain(info, config)
                by_frame = detections.by_frame()
                show = as_progress(progress)
                for f in show(range(1, info.length + 1), f"{info.name}: camera motion"):
                    chain.add(f, source.read_grey(f, chain.factor), _people(detections, by_frame, f))
                motion = chain.motion()
        finally:
            source.close()
    if motion.moving:
        log.info("%s: camera motion %s%s", info.name, motion.summary(),
                 " (measured in the pass over the frames)" if motion is known else "")
    else:
        log.info("%s: the camera is still (no pair of frames half a second apart moved %.1f px)", info.name,
                 config.still_pixels)
    return motion
