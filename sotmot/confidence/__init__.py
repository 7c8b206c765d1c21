"""Telling true boxes from false ones: detection confidence and box confirmation after association.

Two stages, both without ground truth at run time:

1. **Detection confidence.** Detector scores are not comparable across
   detectors (public DPM about -1..4, ACF about -0.3..127, Faster R-CNN
   0..1). :func:`~sotmot.confidence.maps.detection_confidence` maps them monotonically to [0, 1]:

   * ``"quantile"``: the score's rank among the sequence's own detections
     (an empirical CDF; needs no fitting, but says nothing of absolute quality);
   * ``"dpm"``, ``"acf"``, ``"frcnn"``: the probability that a detection of that
     detector family with this score matches a pedestrian (IoU >= 0.5), an
     isotonic (monotone) fit on training sequences, stored as data in
     ``sotmot/data/confidence.json`` (``scripts/fit_confidence.py`` makes it);
   * ``"raw"``: the scores clipped to [0, 1] (for scores that are already
     probabilities);
   * ``"auto"``: the family from the score range (:func:`~sotmot.confidence.maps.detector_family`).

2. **Box confirmation.** After long-term association and interpolation each
   output box gets a probability of being a true positive from a logistic
   model (:class:`~sotmot.confidence.box_model.BoxModel`) of what its trajectory is made of: its detector
   boxes' confidences (mean and top-k), the share of the trajectory that is
   interpolated, its appearance consistency and its duration, plus the box's
   own confidence (for an interpolated box the higher of its gap's two ends)
   and whether it is interpolated. Durations are in seconds and counts are
   shares, never numbers of frames: a model fitted at 30 fps must not read a
   7 fps sequence's trajectories as short ones. (How long a gap may be
   interpolated at all is ``[postprocess] interpolate_max_seconds``.) Boxes below
   ``[confirm] threshold`` are dropped (or written to a separate file).
   Dropping a box whose probability of being true is ``p`` changes MOTA's
   numerator by ``(1 - p) - p``: it pays when ``p < 0.5``.

Boxes are ``x, y, w, h`` pixels, frames 1-based.

Modules: :mod:`~sotmot.confidence.maps` (stage 1: detector scores to
confidences, the stored family maps and the ``"self"`` map fitted on a
sequence's own trajectories), :mod:`~sotmot.confidence.box_model` (stage 2's
model: the box features and the logistic model over them),
:mod:`~sotmot.confidence.calibration` (the fitted maps, models and thresholds,
read from ``sotmot/data/confidence.json`` or a file). The confirmation stage
itself is :mod:`sotmot.confirm`; the fits are in :mod:`sotmot.fitting`.
"""
