"""sotmot: multi-object tracking of people by detection, after *SOT for MOT* (He et al.).

Track a video, a MOTChallenge folder or frames in memory (offline: the whole
sequence is associated at once), with the two bundled models::

    import sotmot
    result = sotmot.track("street.mp4")
    result.tracks.boxes       # (N, 4) x, y, w, h pixels; .frames (1-based), .ids, .scores
    result.save("out/street.txt")

Boxes are ``x, y, w, h`` pixels and frames are 1-based everywhere, as in
MOTChallenge files. The names below are imported when first used, so
``import sotmot`` loads no model and no heavy library. The command line is
``sotmot --help``; the API is in :mod:`sotmot.api` and ``docs/api.md``.
"""

__version__ = "0.1.0"

#: The public names, each from the module that defines it (imported on first use).
_EXPORTS = {
    "track": "sotmot.api",
    "stream": "sotmot.api",
    "evaluate": "sotmot.api",
    "Result": "sotmot.api",
    "TrackerConfig": "sotmot.config",
    "Tracks": "sotmot.types",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'sotmot' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS})
