"""sotmot: multi-object tracking of people by detection, after *SOT for MOT* (He et al.).

Boxes are ``x, y, w, h`` pixels and frames are 1-based everywhere, as in
MOTChallenge files. Start with :func:`sotmot.pipeline.track_sequence` or the
``sotmot`` command line.
"""

__version__ = "0.1.0"
