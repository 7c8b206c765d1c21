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

import logging
from dataclasses import dataclass

import numpy as np

from sotmot.boxes import centers, cxcywh_to_xywh
from sotmot.config import MotionConfig
from sotmot.io.frames import FrameSource, frame_source
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
        """Compose pair estimates (row ``f``: frame ``f`` -> ``f - 1``) into transforms to frame 1."""
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


def still_check_frames(info: SeqInfo, config: MotionConfig) -> tuple[int, frozenset[int]] | None:
    """For a video whose camera ``auto`` checks: the factor its frames are reduced by and the frames the still check
    reads, which the pass that decodes every frame anyway keeps for it (:func:`sotmot.passes.grey_keeper`), so
    that the check decodes none of them again (a video cannot be decoded small the way a JPEG can: the check cost
    MOT16-09 from its video 1-2 s, a second decode of it). None otherwise: a JPEG frame decodes small on its own,
    and its copy from the full image would not be the same bytes."""
    if config.compensation != "auto" or info.video is None or info.length < 2:
        return None
    wanted = frozenset(f for pair in still_check_pairs(info.length, info.frame_rate, video=True) for f in pair)
    return reduce_factor(info.width, STILL_CHECK_WIDTH), wanted


def camera_is_still(source: FrameSource, info: SeqInfo, detections: Detections, config: MotionConfig,
                    seen: dict[int, np.ndarray] | None = None) -> bool:
    """True when frames half a second apart never moved more than ``still_pixels`` (:func:`still_check_pairs`).

    Costs one small grey decode per half second of a JPEG sequence; a video
    is decoded on the way (its frames between are grabbed), so a long one is
    looked at in :data:`STILL_CHECK_PAIRS` places only, and frames a pass kept
    already (``seen``, :func:`still_check_frames`) are not decoded again. A pair
    whose estimate cannot be trusted counts as moving (the full estimate
    decides).
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
        transform, confidence = estimate_pair(previous, grey[b], factor,
                                              detections.boxes[by_frame.get(a, np.zeros(0, np.int64))])
        if confidence == 0.0 or _corner_motion(transform, info.width, info.height) > config.still_pixels:
            return False
    return True


def estimate_motion(info: SeqInfo, detections: Detections, config: MotionConfig,
                    progress: "bool | Progress" = False, seen: dict[int, np.ndarray] | None = None) -> CameraMotion:
    """The camera's motion over the sequence as ``[motion]`` asks (``compensation``: auto, on or off).

    ``detections`` (image pixels) are masked out of the frames. Off, auto on
    a still camera, or auto on a folder without frames (detections and ground
    truth only): :meth:`CameraMotion.still`. A frame pair whose
    estimate is not trusted (fewer than :data:`MIN_INLIERS` corners agree, or
    fewer than ``min_confidence`` of them) gets the identity. ``seen``: the
    still check's frames a pass kept already (:func:`still_check_frames`).
    """
    if config.compensation == "off" or info.length < 2:
        return CameraMotion.still(info.length)
    if config.compensation == "auto" and info.video is None and info.frames is None and not info.frames_dir.is_dir():
        log.info("%s: no frames (%s missing): camera motion not estimated", info.name, info.frames_dir)
        return CameraMotion.still(info.length)
    source = frame_source(info)
    try:
        if config.compensation == "auto" and camera_is_still(source, info, detections, config, seen):
            log.info("%s: the camera is still (no pair of frames half a second apart moved %.1f px)", info.name,
                     config.still_pixels)
            return CameraMotion.still(info.length)
        factor = reduce_factor(info.width)
        by_frame = detections.by_frame()
        pair = np.tile(_identity(), (info.length + 1, 1, 1))
        confidence = np.zeros(info.length + 1)
        confidence[:2] = 1.0
        previous = source.read_grey(1, factor)
        show = as_progress(progress)
        for f in show(range(2, info.length + 1), f"{info.name}: camera motion"):
            current = source.read_grey(f, factor)
            transform, share = estimate_pair(previous, current, factor,
                                             detections.boxes[by_frame.get(f - 1, np.zeros(0, np.int64))],
                                             guess=pair[f - 1])
            if share >= config.min_confidence:
                pair[f], confidence[f] = transform, share
            previous = current
    finally:
        source.close()
    motion = CameraMotion.from_pairs(pair, confidence)
    log.info("%s: camera motion %s", info.name, motion.summary())
    return motion
