"""Template search: where a seed's crop reappears around a prior box (the SOT steps' shared motion model).

Algorithm 1 (:mod:`sotmot.sot.algorithm1`) and the end extension
(:mod:`sotmot.sot.extend`) both search with :class:`TemplateSearch`: OpenCV's
normalised cross-correlation (``cv2.matchTemplate``, ``TM_CCOEFF_NORMED``) of
the seed's grey crop over a window around the prior, at a few scales. Boxes
are ``x, y, w, h`` pixels.
"""

from __future__ import annotations

import numpy as np

from sotmot.boxes import iou_matrix, pixel_bounds
from sotmot.config import SotConfig

#: Height in pixels of a seed template (its width keeps the box's aspect ratio).
TEMPLATE_HEIGHT = 64


def crop_resized(frame: np.ndarray, box: np.ndarray, width: int, height: int) -> np.ndarray:
    """The ``x, y, w, h`` box of ``frame`` resized to ``(height, width)``, clipped to the image, grey."""
    import cv2

    x1, y1, x2, y2 = (int(c[0]) for c in pixel_bounds(np.asarray(box)[None], frame.shape[1], frame.shape[0]))
    patch = frame[y1:y2, x1:x2]
    if patch.ndim == 3:
        patch = cv2.cvtColor(patch, cv2.COLOR_BGR2GRAY)
    return cv2.resize(patch, (width, height), interpolation=cv2.INTER_AREA)


class TemplateSearch:
    """Dense search for a seed template around a prior box with one ``matchTemplate`` per scale.

    The template is the seed crop at a fixed height of 64 pixels; the search
    window (the prior box grown by ``radius`` box sizes on every side) is
    rescaled by the same factor, so the cost does not grow with resolution.

    With ``beyond_edge`` the window is not clipped to the image: the part
    outside is filled by repeating the image's edge pixels
    (``cv2.BORDER_REPLICATE``), so a proposal may lie partly outside the
    image, as a person leaving it does (MOTChallenge annotates such people
    with boxes past the edge). The caller decides where a proposal is too far
    out (the trajectory ends stop under half inside,
    :data:`sotmot.sot.extend.MIN_INSIDE`). Without it (Algorithm 1, which has
    no such stop) every proposal lies wholly inside the image.
    """

    def __init__(self, config: SotConfig, beyond_edge: bool = False) -> None:
        self.radius = config.search_radius
        self.scales = config.scales
        self.beyond_edge = beyond_edge

    @staticmethod
    def template(frame: np.ndarray, box: np.ndarray) -> np.ndarray:
        """The seed template: grey crop at height 64 with the box's aspect ratio."""
        w = max(4, int(round(TEMPLATE_HEIGHT * box[2] / box[3])))
        return crop_resized(frame, box, w, TEMPLATE_HEIGHT).astype(np.float32)

    def score_box(self, template: np.ndarray, frame: np.ndarray, box: np.ndarray) -> float:
        """Normalised correlation of the template with ``box`` of ``frame``, clipped to [0, 1]."""
        import cv2

        patch = crop_resized(frame, box, template.shape[1], template.shape[0]).astype(np.float32)
        return float(np.clip(cv2.matchTemplate(patch, template, cv2.TM_CCOEFF_NORMED)[0, 0], 0.0, 1.0))

    def search(self, template: np.ndarray, frame: np.ndarray, prior: np.ndarray,
               top: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Best ``top`` boxes ``(k, 4)`` around ``prior`` and their correlations ``(k,)`` in [0, 1]."""
        import cv2

        img_h, img_w = frame.shape[:2]
        grey = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)  # callers pass grey
        boxes, scores = [], []
        for s in self.scales:
            bw, bh = prior[2] * s, prior[3] * s
            k = TEMPLATE_HEIGHT / bh  # image pixels -> template pixels
            tw = max(4, int(round(bw * k)))
            tmpl = cv2.resize(template, (tw, TEMPLATE_HEIGHT), interpolation=cv2.INTER_AREA)
            cx, cy = prior[0] + prior[2] / 2, prior[1] + prior[3] / 2
            x1 = int(np.floor(cx - bw / 2 - self.radius * bw))
            y1 = int(np.floor(cy - bh / 2 - self.radius * bh))
            x2 = int(np.ceil(cx + bw / 2 + self.radius * bw))
            y2 = int(np.ceil(cy + bh / 2 + self.radius * bh))
            inner = max(0, x1), max(0, y1), min(img_w, x2), min(img_h, y2)  # the window's part in the image
            if not self.beyond_edge:
                x1, y1, x2, y2 = inner
            rw, rh = int(round((x2 - x1) * k)), int(round((y2 - y1) * k))
            if rw < tw or rh < TEMPLATE_HEIGHT or min(inner[2] - inner[0], inner[3] - inner[1]) < 2:
                continue  # the window is too small, or (beyond the edge) holds under 2 pixels of the image
            region = grey[inner[1]:inner[3], inner[0]:inner[2]]
            if self.beyond_edge:
                region = cv2.copyMakeBorder(region, inner[1] - y1, y2 - inner[3], inner[0] - x1, x2 - inner[2],
                                            cv2.BORDER_REPLICATE)
            region = cv2.resize(region, (rw, rh), interpolation=cv2.INTER_AREA).astype(np.float32)
            response = cv2.matchTemplate(region, tmpl, cv2.TM_CCOEFF_NORMED)
            if top == 1:
                flat = [int(np.argmax(response))]
            else:
                flat = np.argpartition(response, -4 * top, axis=None)[-4 * top:] if response.size > 4 * top \
                    else np.arange(response.size)
            for idx in flat:
                py, px = np.unravel_index(idx, response.shape)
                boxes.append([x1 + px / k, y1 + py / k, bw, bh])
                scores.append(float(response[py, px]))
        if not boxes:
            return np.zeros((0, 4)), np.zeros(0)
        boxes_arr, scores_arr = np.asarray(boxes), np.clip(np.nan_to_num(np.asarray(scores)), 0.0, 1.0)
        order = np.argsort(-scores_arr, kind="stable")
        overlaps = iou_matrix(boxes_arr, boxes_arr)
        keep: list[int] = []
        for i in order:  # spread the proposals: no two nearly the same box
            if not keep or overlaps[i, keep].max() < 0.7:
                keep.append(int(i))
            if len(keep) == top:
                break
        return boxes_arr[keep], scores_arr[keep]
